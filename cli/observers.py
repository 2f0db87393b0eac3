"""``nightlights sky observers``: many observers' skies at once, one summary point layer."""

from __future__ import annotations

import click

from .kinds import FOLDER, POINTS, RASTER, KindPath
from .options import (
    OBSERVER_SCHEDULERS,
    LibraryHelpOption,
    dem_option,
    deprecated_option,
    files_argument,
    instrument_option,
    kernel_option,
    num_workers_option,
    observer_crs_option,
    observer_height_option,
    one_of,
    output_option,
    overwrite_option,
    resolve_inout,
    scene_of,
    spectrum_option,
    turbidity_option,
)
from .resources import SchedulerText, max_memory_option


@click.command("observers")
@files_argument("EMISSION OBSERVERS SUMMARY", RASTER, POINTS, POINTS)
@output_option
@overwrite_option
@click.option(
    "--observers-layer",
    default=None,
    help="Layer of the OBSERVERS file (default: its first); a 'name' field names them.",
)
@deprecated_option("--layer", "old_layer", default=None, replacement="--observers-layer")
@observer_crs_option
@observer_height_option
@kernel_option
@dem_option
@turbidity_option
@instrument_option
@spectrum_option
@click.option(
    "--panoramas",
    type=KindPath(FOLDER, file_okay=False),
    default=None,
    metavar="DIR",
    help="Also write one panorama NetCDF per observer into DIR (NAME.nc; created if missing).",
)
@click.option(
    "--top-cells",
    type=click.IntRange(min=0),
    default=5,
    show_default=True,
    help="Lit cells listed per observer by their part of the artificial zenith (top1_x, "
    "top1_y, top1_share, ...).",
)
@click.option(
    "--scheduler",
    cls=LibraryHelpOption,
    type=SchedulerText(OBSERVER_SCHEDULERS),
    default="threads",
    show_default=True,
    metavar="NAME|ADDRESS",
    help="Dask scheduler: {schedulers}, or a dask.distributed scheduler address.",
    help_values={"schedulers": OBSERVER_SCHEDULERS},
)
@num_workers_option
@click.pass_context
@max_memory_option
def observers(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observers_layer: str | None,
    old_layer: str | None,
    observer_crs: str | None,
    observer_height: float,
    kernel: str | None,
    dem: str | None,
    turbidity: float | None,
    instrument: str | None,
    spectrum: str | None,
    panoramas: str | None,
    top_cells: int,
    scheduler: str,
    num_workers: int | None,
    old_workers: int | None,
) -> None:
    """Zenith sky brightness (artificial, natural, total; Bortle class), brightest direction
    and the brightest lit cells of every point of OBSERVERS (any vector file) over EMISSION
    [lm m-2]; write SUMMARY (GeoPackage point layer 'observers')."""
    from pathlib import Path

    (emission, points), out = resolve_inout(
        files, output, inputs=2, usage="EMISSION OBSERVERS SUMMARY", overwrite=overwrite
    )
    if not out.lower().endswith(".gpkg"):
        raise click.BadParameter(f"{out!r}; expected a .gpkg", param_hint="SUMMARY")
    observers_layer = one_of(ctx, **{"--observers-layer": observers_layer, "--layer": old_layer})
    num_workers = one_of(ctx, **{"--num-workers": num_workers, "--workers": old_workers})
    if panoramas is not None:
        Path(panoramas).mkdir(exist_ok=True)
    from nightlights.sky import Observer
    from nightlights.sky.observers import observers as stage

    sites = Observer.from_layer(
        points, layer_name=observers_layer, crs=observer_crs, height=observer_height
    )
    result = stage(
        scene_of(emission, dem=dem, kernel=kernel, turbidity=turbidity),
        sites,
        out,
        panoramas=panoramas,
        top_cells=top_cells,
        scheduler=scheduler,
        num_workers=num_workers,
        overwrite=overwrite,
        instrument=instrument,
        spectrum=spectrum,
    )
    import numpy as np
    from rich.console import Console

    summary = result.summary
    mag = summary["zenith_mag"].to_numpy()
    bortle = summary["bortle"].to_numpy()
    extra = f" and {len(result.panoramas)} panoramas in {panoramas}" if result.panoramas else ""
    Console(stderr=True).print(
        f"{len(summary)} observers: zenith {mag.min():.2f} to {mag.max():.2f} mag arcsec-2 "
        f"(median {np.median(mag):.2f}; natural + artificial), Bortle class {bortle.min()}-"
        f"{bortle.max()}; {result.seconds:.1f} s -> {out}{extra}",
        soft_wrap=True,
    )
    if instrument is not None:
        read = summary["instrument_sky_brightness"].to_numpy()
        Console(stderr=True).print(
            f"{instrument} pointing at the zenith: {read.min():.2f} to {read.max():.2f} mag "
            f"arcsec-2 in its band (median {np.median(read):.2f}; with the natural sky)",
            soft_wrap=True,
        )


commands = [observers]
