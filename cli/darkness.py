"""``nightlights darkness``: the artificial zenith sky brightness at every cell of a region."""

from __future__ import annotations

import click

from .kinds import RASTER
from .options import (
    clouds_of,
    clouds_options,
    dem_option,
    files_argument,
    instrument_option,
    kernel_option,
    natural_of,
    night_option,
    observer_height_option,
    obstacles_option,
    output_option,
    overwrite_option,
    resolve_inout,
    scene_grid_options,
    scene_of,
    spectrum_option,
    target_crs_option,
    turbidity_option,
)
from .resources import max_memory_option, scheduler_option


@click.command("darkness")
@files_argument("EMISSION OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@observer_height_option
@dem_option
@obstacles_option
@clouds_options
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
    "kernel radius); a raster within one chunk is one FFT. On the tiled map: the tile edge "
    "[cells of the output grid] (default 2048).",
)
@click.option(
    "--tiled/--in-memory",
    default=None,
    help="Map tile by tile, out of core (flat terrain), or in memory; default: tiled for a "
    "geographic EMISSION, --target-crs, --store, or a map too large for memory.",
)
@target_crs_option
@click.option(
    "--store",
    default=None,
    metavar="FOLDER|URL",
    help="Tile store of the tiled map (a folder or fsspec URL, one file per finished tile): "
    "a rerun resumes from it. Default with --scheduler: OUTPUT.tiles beside OUTPUT.",
)
@click.option(
    "--resume/--no-resume",
    default=True,
    show_default=True,
    help="Reuse the tiles of the same input and plan already in the store.",
)
@click.option(
    "--keep-store",
    is_flag=True,
    help="Keep the store's tiles once OUTPUT is written (default: removed).",
)
@click.option(
    "--retries",
    type=click.IntRange(min=0),
    default=2,
    show_default=True,
    help="Extra attempts of a tile whose task fails on a --scheduler cluster.",
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
    obstacles: str | None,
    base_height: float | None,
    optical_depth: float,
    cover: float,
    kernel: str | None,
    turbidity: float | None,
    instrument: str | None,
    spectrum: str | None,
    night: str | None,
    chunk_size: int | None,
    tiled: bool | None,
    target_crs: str | None,
    store: str | None,
    resume: bool,
    keep_store: bool,
    retries: int,
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
        obstacles=obstacles,
        dem=dem,
        kernel=kernel,
        turbidity=turbidity,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        n_distance=n_distance,
        clouds=clouds_of(base_height, optical_depth, cover),
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
        tiled=tiled,
        target_crs=target_crs,
        store=store,
        resume=resume,
        keep_store=keep_store,
        retries=retries,
    )
    import numpy as np
    from rasterio import open as rasterio_open
    from rich.console import Console

    from nightlights.sky.tiled import read_overview

    # a tiled map is only in OUTPUT: its summary from about a million cells of the overviews
    raster = result.raster if result.raster is not None else read_overview(out)
    magnitude = raster.data[1]
    finite = magnitude[np.isfinite(magnitude)]
    rows, cols = raster.shape
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
    if result.raster is None:
        with rasterio_open(out) as dataset:
            rows, cols = dataset.height, dataset.width
        reused = f", {result.reused_tiles} reused" if result.reused_tiles else ""
        summary += f" ({result.tiles} tiles{reused}; read from its overviews)"
    Console(stderr=True).print(
        f"{what.format(rows, cols, summary)}; {result.seconds:.1f} s -> {out}",
        soft_wrap=True,
    )


commands = [darkness]
