"""``nightlights sky render``: the night sky of a place and time, natural and artificial."""

from __future__ import annotations

import click

from .kinds import NETCDF, KindPath, file_kind
from .options import (
    SKY_PROJECTIONS,
    TONE_MODES,
    LibraryChoice,
    deprecated_option,
    files_argument,
    given,
    one_of,
    output_option,
    overwrite_option,
    resolve_inout,
)
from .resources import max_memory_option


def parse_lonlat(text: str) -> tuple[float, float]:
    """``LON,LAT`` -> two floats [deg]."""
    try:
        lon, lat = (float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}; expected LON,LAT", param_hint="--lonlat") from None
    return lon, lat


@click.group("sky")
def sky() -> None:
    """The whole night sky: stars, Moon, twilight, natural background and the eye."""


@sky.command("render")
@files_argument("OUTPUT", file_kind("png", "nc"))
@output_option
@overwrite_option
@click.option("--time", required=True, metavar="ISO8601", help="Instant (UTC if no zone).")
@click.option(
    "--lonlat",
    default=None,
    metavar="LON,LAT",
    help="Observer longitude,latitude [deg] (default: the --panorama's observer).",
)
@click.option(
    "--panorama",
    type=KindPath(NETCDF, exists=True, dir_okay=False),
    default=None,
    help="Skyglow panorama NetCDF (nightlights skyglow) for the artificial light.",
)
@click.option("--natural-only", is_flag=True, help="Only the natural sky.")
@click.option("--artificial-only", is_flag=True, help="Only the artificial skyglow.")
@click.option(
    "--projection",
    type=LibraryChoice(SKY_PROJECTIONS),
    default="equirectangular",
    show_default=True,
    help="equirectangular (azimuth across, zenith on top), fisheye (zenith in the centre, "
    "north up, east left) or perspective (--view-azimuth, --view-elevation, --field-of-view).",
)
@click.option("--width", type=click.IntRange(min=2), default=None, help="Image width [pixel].")
@click.option(
    "--height",
    type=click.IntRange(min=2),
    default=None,
    help="Image height [pixel] (a fisheye is square).",
)
@click.option(
    "--view-azimuth", type=float, default=180.0, show_default=True, help="Perspective [deg]."
)
@click.option(
    "--view-elevation", type=float, default=30.0, show_default=True, help="Perspective [deg]."
)
@click.option(
    "--field-of-view",
    type=float,
    default=90.0,
    show_default=True,
    help="Perspective: the horizontal field of view [deg].",
)
@deprecated_option("--fov", "old_fov", type=float, default=None, replacement="--field-of-view")
@click.option(
    "--tone",
    type=LibraryChoice(TONE_MODES),
    default="eye",
    show_default=True,
    help="PNG tone mapping: eye (night vision: blue shift, acuity) or photo (camera).",
)
@click.option(
    "--exposure",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Display value per cd m-2 (default from the image's log-average luminance).",
)
@click.option(
    "--white-temperature",
    type=click.FloatRange(1000.0, 100000.0),
    default=None,
    help="--tone photo: white balance to a light of this colour temperature [K].",
)
@deprecated_option(
    "--white",
    "old_white",
    type=click.FloatRange(1000.0, 100000.0),
    default=None,
    replacement="--white-temperature",
)
@click.option("--no-stars", is_flag=True, help="Leave out the stars.")
@click.option("--no-moon", is_flag=True, help="Leave out the Moon and its light.")
@click.option(
    "--all-stars",
    is_flag=True,
    help="Draw every catalogue star, also those fainter than the eye's limit.",
)
@click.option(
    "--spectrum",
    default="LED_4000K",
    show_default=True,
    help="Luminaire spectrum that colours a luminance-only panorama.",
)
@click.option("--no-legend", is_flag=True, help="No legend strip under the PNG.")
@click.pass_context
@max_memory_option
def render(
    ctx: click.Context,
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    time: str,
    lonlat: str | None,
    panorama: str | None,
    natural_only: bool,
    artificial_only: bool,
    projection: str,
    width: int | None,
    height: int | None,
    view_azimuth: float,
    view_elevation: float,
    field_of_view: float,
    old_fov: float | None,
    tone: str,
    exposure: float | None,
    white_temperature: float | None,
    old_white: float | None,
    no_stars: bool,
    no_moon: bool,
    all_stars: bool,
    spectrum: str,
    no_legend: bool,
) -> None:
    """Render the night sky at --time from --lonlat (or a --panorama's observer); write
    OUTPUT: .png (tone-mapped, with a legend) or .nc (linear luminance and XYZ [cd m-2])."""
    _, out = resolve_inout(files, output, inputs=0, usage="OUTPUT", overwrite=overwrite)
    if old_fov is not None:
        field_of_view = one_of(
            ctx, **{"--field-of-view": given(ctx, "field_of_view"), "--fov": old_fov}
        )
    white_temperature = one_of(
        ctx, **{"--white-temperature": white_temperature, "--white": old_white}
    )
    if natural_only and artificial_only:
        raise click.UsageError("--natural-only and --artificial-only exclude each other")
    place = parse_lonlat(lonlat) if lonlat is not None else None
    from nightlights import nightsky

    tone_mapping = nightsky.ToneMapping(
        mode=tone, exposure=exposure, white_temperature=white_temperature
    )
    from nightlights.sky import Observer

    result = nightsky.sky_render(
        Observer.from_lonlat(*place) if place is not None else None,
        out,
        time=time,
        panorama=panorama,
        natural_only=natural_only,
        artificial_only=artificial_only,
        projection=projection,
        width=width,
        height=height,
        view_azimuth=view_azimuth,
        view_elevation=view_elevation,
        field_of_view=field_of_view,
        tone_mapping=tone_mapping,
        stars=not no_stars,
        moon=not no_moon,
        limiting_magnitude=not all_stars,
        spectrum=spectrum,
        legend=not no_legend,
    )
    from rich.console import Console

    Console(stderr=True).print(f"{result.legend}\n-> {out}", soft_wrap=True, markup=False)


commands = [sky]


from .observers import observers as _observers  # noqa: E402 (a command of this group)

sky.add_command(_observers)
