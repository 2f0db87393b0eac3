"""``nightlights sky observers``: many observers' skies at once, one summary point layer."""

from __future__ import annotations

import click

from .options import files_argument, output_option, overwrite_option, resolve_inout

# --- mirrors of library constants (checked by tests/cli/test_observers.py) --------------------
#: nightlights.sky.observers.SCHEDULERS
SCHEDULERS = ("threads", "processes", "synchronous")


@click.command("observers")
@files_argument("EMISSION OBSERVERS SUMMARY")
@output_option
@overwrite_option
@click.option(
    "--layer",
    default=None,
    help="Layer of the OBSERVERS file (default: its first); a 'name' field names them.",
)
@click.option(
    "--observer-crs",
    default=None,
    metavar="CRS",
    help="CRS of an OBSERVERS layer that has none.",
)
@click.option("--observer-height", default=1.7, show_default=True, help="Above ground [m].")
@click.option(
    "--kernel",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Precomputed kernel (nightlights kernel build); default: a cached scene kernel "
    "reaching from the farthest observer to the farthest lit cell.",
)
@click.option(
    "--dem",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Terrain heights above sea level [m]: each observer stands on it and sees its horizon.",
)
@click.option("--turbidity", type=float, default=None, help="Turbidity T (default 2).")
@click.option(
    "--panoramas",
    type=click.Path(file_okay=False),
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
    default="threads",
    show_default=True,
    metavar="NAME|ADDRESS",
    help=f"Dask scheduler: {', '.join(SCHEDULERS)}, or a dask.distributed scheduler address.",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Workers of the local threads or processes scheduler (default: one per core).",
)
def observers(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    layer: str | None,
    observer_crs: str | None,
    observer_height: float,
    kernel: str | None,
    dem: str | None,
    turbidity: float | None,
    panoramas: str | None,
    top_cells: int,
    scheduler: str,
    workers: int | None,
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
    if scheduler not in SCHEDULERS and "://" not in scheduler:
        raise click.BadParameter(
            f"{scheduler!r}; expected one of {', '.join(SCHEDULERS)} or an address such as "
            "tcp://host:8786",
            param_hint="--scheduler",
        )
    if panoramas is not None:
        Path(panoramas).mkdir(exist_ok=True)
    from nightlights.sky.observers import observers as stage

    result = stage(
        emission,
        out,
        observers=points,
        observers_layer=layer,
        observer_crs=observer_crs,
        observer_height=observer_height,
        kernel=kernel,
        dem=dem,
        turbidity=turbidity,
        panoramas=panoramas,
        top_cells=top_cells,
        scheduler=scheduler,
        num_workers=workers,
        overwrite=overwrite,
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


commands = [observers]
