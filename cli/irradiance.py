"""``nightlights irradiance``: the light the luminaires put on the ground."""

from __future__ import annotations

import click

from .kinds import POINTS, POLYGONS, RASTER, KindPath
from .library import SENSORS
from .options import (
    DEFAULT_AREA_HEIGHT,
    DEFAULT_MAX_RADIUS,
    IRRADIANCE_BACKENDS,
    LibraryChoice,
    LibraryHelpOption,
    catalog_option,
    crs_option,
    dem_option,
    files_argument,
    output_option,
    overwrite_option,
    resolve_inout,
    skip_unknown_option,
)
from .resources import max_memory_option, scheduler_option


def parse_bounds(text: str | None) -> tuple[float, float, float, float] | None:
    """``xmin,ymin,xmax,ymax`` -> four floats (None stays None)."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}; expected xmin,ymin,xmax,ymax in metres") from None
    if len(values) != 4:
        raise click.BadParameter(f"{text!r}; expected four numbers xmin,ymin,xmax,ymax")
    return values[0], values[1], values[2], values[3]


@click.command("irradiance")
@files_argument("LIGHTS OUTPUT", POINTS, RASTER)
@output_option
@overwrite_option
@click.option("--resolution", type=float, required=True, help="Pixel size [m].")
@click.option(
    "--sensor",
    "sensors",
    cls=LibraryHelpOption,
    multiple=True,
    default=("photopic",),
    show_default=True,
    help="Band per sensor (repeat): {sensors}; photopic in lx, the others in W m-2.",
    help_values={"sensors": SENSORS},
)
@click.option(
    "--bounds",
    default=None,
    metavar="XMIN,YMIN,XMAX,YMAX",
    help="Output extent in the lights' CRS [m].",
)
@click.option(
    "--margin",
    type=float,
    default=None,
    help="Growth of the default extent [m] (default: the largest region of influence).",
)
@catalog_option
@dem_option
@click.option(
    "--threshold",
    default="floor:0.01",
    show_default=True,
    help="Region of influence: energy:FRACTION, floor:LUX or none.",
)
@click.option(
    "--max-radius",
    type=float,
    default=DEFAULT_MAX_RADIUS,
    show_default=True,
    help="Cap on the region-of-influence radius [m].",
)
@click.option(
    "--area-sources",
    default=None,
    type=KindPath(POLYGONS, exists=True, dir_okay=False),
    help="Polygon layer of lit areas (Voronoi pseudo-lights).",
)
@click.option(
    "--exitance-field",
    default="exitance",
    show_default=True,
    help="Field of --area-sources with luminous exitance [lm m-2].",
)
@click.option(
    "--area-height",
    type=float,
    default=DEFAULT_AREA_HEIGHT,
    show_default=True,
    help="Height of the area sources' emitting panel [m].",
)
@click.option(
    "--area-spacing",
    type=float,
    default=None,
    help="Pseudo-light spacing [m] (default: area height / 2).",
)
@click.option("--area-spectrum", default=None, help="Spectrum name of the area sources.")
@skip_unknown_option
@crs_option
@click.option("--tile-size", type=int, default=1024, show_default=True, help="Tile edge [px].")
@click.option(
    "--backend",
    type=LibraryChoice(IRRADIANCE_BACKENDS),
    default="numba",
    show_default=True,
    help="Illuminance kernel: numba (compiled) or numpy (reference).",
)
@scheduler_option
@max_memory_option
def irradiance_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    resolution: float,
    sensors: tuple[str, ...],
    bounds: str | None,
    margin: float | None,
    catalog: str | None,
    dem: str | None,
    threshold: str,
    max_radius: float,
    area_sources: str | None,
    exitance_field: str,
    area_height: float,
    area_spacing: float | None,
    area_spectrum: str | None,
    skip_unknown: bool,
    crs: str | None,
    tile_size: int,
    backend: str,
    scheduler: str | None,
) -> None:
    """Ground illuminance of the lights in LIGHTS, one band per sensor, as a COG OUTPUT."""
    import nightlights as nl
    from nightlights.ground import AreaLightOptions, InfluenceThreshold
    from nightlights.ground.checks import parse_crs

    parse_crs(crs, option="--crs")
    (lights,), out = resolve_inout(
        files, output, inputs=1, usage="LIGHTS OUTPUT", overwrite=overwrite
    )
    result = nl.irradiance(
        lights,
        out,
        resolution=resolution,
        sensors=sensors,
        bounds=parse_bounds(bounds),
        margin=margin,
        catalog=catalog,
        dem=dem,
        threshold=InfluenceThreshold.parse(threshold, max_radius=max_radius),
        area_sources=area_sources,
        exitance_field=exitance_field,
        area_options=AreaLightOptions(area_height, area_spacing, area_spectrum),
        skip_unknown=skip_unknown,
        crs=crs,
        scheduler=scheduler,
        tile_size=tile_size,
        backend=backend,
    )
    from rich.console import Console

    rows, cols = result.grid.rows, result.grid.cols
    Console(stderr=True).print(
        f"[bold]{result.n_lights}[/] lights, {rows} x {cols} pixels, "
        f"{result.n_pairs:.3g} light-pixel evaluations -> {out}"
    )


commands = [irradiance_command]
