"""``nightlights irradiance`` and ``nightlights emission``: light on the ground and upwards."""

from __future__ import annotations

import click
from rich.console import Console

from cli.options import catalog_option, scheduler_option, skip_unknown_option
from nightlights.area_lights import AreaLightOptions
from nightlights.emission import DEFAULT_VIIRS_SPECTRUM, emission, emission_from_viirs
from nightlights.errors import InputError
from nightlights.irradiance import InfluenceThreshold, irradiance


def _bounds(text: str | None) -> tuple[float, float, float, float] | None:
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
@click.argument("lights", type=click.Path(exists=True, dir_okay=False))
@click.argument("out", type=click.Path(dir_okay=False))
@click.option("--resolution", type=float, required=True, help="Pixel size [m].")
@click.option(
    "--sensor",
    "sensors",
    multiple=True,
    default=("photopic",),
    show_default=True,
    help="Band per sensor (repeat): photopic [lx], scotopic, cie_x/y/z, melanopic, "
    "nvis_class_a/b [W m-2].",
)
@click.option("--bounds", default=None, help="xmin,ymin,xmax,ymax in the lights' CRS [m].")
@click.option(
    "--margin",
    type=float,
    default=None,
    help="Growth of the default extent [m] (default: the largest region of influence).",
)
@catalog_option
@click.option(
    "--dem",
    default=None,
    type=click.Path(exists=True, dir_okay=False),
    help="Elevation raster [m] for ground height and surface normals.",
)
@click.option(
    "--threshold",
    default="floor:0.01",
    show_default=True,
    help="Region of influence: energy:FRACTION, floor:LUX or none.",
)
@click.option(
    "--max-radius",
    type=float,
    default=1000.0,
    show_default=True,
    help="Cap on the region-of-influence radius [m].",
)
@click.option(
    "--area-sources",
    default=None,
    type=click.Path(exists=True, dir_okay=False),
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
    default=AreaLightOptions.height,
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
@click.option("--crs", "assume_crs", default=None, help="CRS of a light layer that has none.")
@click.option("--tile-size", type=int, default=1024, show_default=True, help="Tile edge [px].")
@scheduler_option
def irradiance_command(
    lights: str,
    out: str,
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
    assume_crs: str | None,
    tile_size: int,
    scheduler: str | None,
) -> None:
    """Ground illuminance of the lights in LIGHTS, one band per sensor, as a COG OUT."""
    result = irradiance(
        lights,
        out,
        resolution=resolution,
        sensors=sensors,
        bounds=_bounds(bounds),
        margin=margin,
        catalog=catalog,
        dem=dem,
        threshold=InfluenceThreshold.parse(threshold, max_radius=max_radius),
        area_sources=area_sources,
        exitance_field=exitance_field,
        area_options=AreaLightOptions(area_height, area_spacing, area_spectrum),
        skip_unknown=skip_unknown,
        assume_crs=assume_crs,
        scheduler=scheduler,
        tile_size=tile_size,
    )
    Console(stderr=True).print(
        f"[bold]{result.n_lights}[/] lights, {result.grid.rows} x {result.grid.cols} pixels, "
        f"{result.n_pairs:.3g} light-pixel evaluations -> {out}"
    )


@click.command("emission")
@click.argument("paths", nargs=-1, type=click.Path(dir_okay=False))
@click.option(
    "--resolution",
    type=float,
    default=None,
    help="Output cell size [m]; a multiple of the irradiance pixel size.",
)
@click.option("--albedo", default=None, help="Ground albedo: a number in [0, 1] or a raster.")
@click.option(
    "--from-viirs",
    "viirs",
    default=None,
    type=click.Path(exists=True, dir_okay=False),
    help="VIIRS DNB radiance raster [nW cm-2 sr-1] instead of irradiance + lights.",
)
@click.option(
    "--spectrum",
    default=DEFAULT_VIIRS_SPECTRUM,
    show_default=True,
    help="Light spectrum for --from-viirs.",
)
@catalog_option
@skip_unknown_option
def emission_command(
    paths: tuple[str, ...],
    resolution: float | None,
    albedo: str | None,
    viirs: str | None,
    spectrum: str,
    catalog: str | None,
    skip_unknown: bool,
) -> None:
    """Upward flux density [lm m-2] for skyglow.

    \b
    nightlights emission IRRADIANCE.tif LIGHTS OUT.tif --resolution M --albedo A
    nightlights emission --from-viirs VIIRS.tif OUT.tif [--spectrum NAME]
    """
    console = Console(stderr=True)
    if viirs is not None:
        if len(paths) != 1:
            raise click.UsageError("with --from-viirs give exactly one path: OUT.tif")
        result = emission_from_viirs(viirs, paths[0], spectrum=spectrum, resolution=resolution)
        console.print(f"{result.total_flux['upward']:.4g} lm upward -> {paths[0]}")
        return
    if len(paths) != 3:
        raise click.UsageError("expected IRRADIANCE.tif LIGHTS OUT.tif (or --from-viirs)")
    if resolution is None or albedo is None:
        raise click.UsageError("--resolution and --albedo are required")
    result = emission(
        paths[0],
        paths[1],
        paths[2],
        resolution=resolution,
        albedo=_albedo(albedo),
        catalog=catalog,
        skip_unknown=skip_unknown,
    )
    console.print(
        f"reflected {result.total_flux['reflected']:.4g} lm, uplight "
        f"{result.total_flux['uplight']:.4g} lm -> {paths[2]}"
    )


def _albedo(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        pass
    from pathlib import Path

    if not Path(text).exists():
        raise InputError(f"--albedo {text!r}: neither a number nor an existing raster")
    return text


commands = [irradiance_command, emission_command]
