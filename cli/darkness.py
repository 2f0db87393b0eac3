"""``nightlights darkness``: the artificial zenith sky brightness at every cell of a region."""

from __future__ import annotations

import click

from .kinds import RASTER
from .options import (
    dem_option,
    files_argument,
    instrument_option,
    kernel_option,
    natural_of,
    night_option,
    observer_height_option,
    output_option,
    overwrite_option,
    resolve_inout,
    scene_grid_options,
    scene_of,
    spectrum_option,
    turbidity_option,
)
from .resources import max_memory_option, scheduler_option


@click.command("darkness")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@observer_height_option
@dem_option
@kernel_option
@turbidity_option
@instrument_option
@spectrum_option
@night_option
@click.option(
    "--chunk-size",
    type=click.IntRange(min=1),
    default=None,
    help="Chunk edge [cells] of the Dask computation (default 4096; never below twice the "
    "kernel radius); a raster within one chunk is one FFT.",
)
@scheduler_option
@scene_grid_options
@max_memory_option
def darkness(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    turbidity: float | None,
    instrument: str | None,
    spectrum: str | None,
    night: str | None,
    chunk_size: int | None,
    scheduler: str | None,
    n_distance: int | None,
    n_elevation: int | None,
    n_azimuth: int | None,
) -> None:
    """Zenith sky brightness (cd m-2, mag arcsec-2) with the observer at every cell of
    EMISSION [lm m-2], or what --instrument reads there; write OUTPUT (COG, 2 bands)."""
    import nightlights as nl

    (emission,), out = resolve_inout(
        files, output, inputs=1, usage="EMISSION OUTPUT", overwrite=overwrite
    )
    scene = scene_of(
        emission,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
    )
    natural = None
    if night is not None:
        import rasterio

        with rasterio.open(emission) as source:
            west, south, east, north = source.bounds
            natural = natural_of(
                instrument, night, ((west + east) / 2, (south + north) / 2), source.crs
            )
    result = nl.darkness(
        scene,
        out,
        height=observer_height,
        instrument=instrument,
        spectrum=spectrum,
        natural_luminance=natural,
        chunk_size=chunk_size,
        scheduler=scheduler,
    )
    import numpy as np
    from rich.console import Console

    magnitude = result.raster.data[1]
    finite = magnitude[np.isfinite(magnitude)]
    rows, cols = result.raster.shape
    summary = (
        f"brightest {finite.min():.2f}, median {np.median(finite):.2f}, darkest "
        f"{magnitude.max():.2f} mag arcsec-2"
        if finite.size
        else "no artificial light reaches any cell"
    )
    what = (
        "zenith over {} x {} cells: {} (artificial skyglow only)"
        if instrument is None
        else f"{instrument} over {{}} x {{}} cells: {{}} (its band, with the natural sky)"
    )
    Console(stderr=True).print(
        f"{what.format(rows, cols, summary)}; {result.seconds:.1f} s -> {out}",
        soft_wrap=True,
    )


commands = [darkness]
