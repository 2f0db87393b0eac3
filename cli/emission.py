"""``nightlights emission``: the upward flux density [lm m-2] that skyglow starts from.

Two sources, one subcommand each:

- ``emission ground IRRADIANCE [LIGHTS] OUTPUT``: ground-reflected light plus the luminaires'
  direct uplight, window by window; ``ground`` is the default, so ``nightlights emission
  IRRADIANCE [LIGHTS] OUTPUT`` means the same;
- ``emission viirs INPUT OUTPUT``: a VIIRS day/night-band radiance raster converted with a
  light spectrum, window by window; a geographic raster wider than one UTM zone keeps its
  grid (flux density per geodesic cell area).
"""

from __future__ import annotations

from typing import Any

import click

from .kinds import POINTS, RASTER
from .options import (
    DEFAULT_VIIRS_SPECTRUM,
    DefaultCommandGroup,
    catalog_option,
    crs_option,
    files_argument,
    output_option,
    overwrite_option,
    resolve_inout,
    skip_unknown_option,
    target_crs_option,
)
from .resources import max_memory_option


@click.group(
    "emission",
    cls=DefaultCommandGroup,
    default_command="ground",
    deprecated_spellings={"--from-viirs": "viirs"},
)
def emission() -> None:
    """Upward flux density [lm m-2] for skyglow, from modelled ground light or VIIRS.

    \b
    nightlights emission IRRADIANCE [LIGHTS] OUTPUT --resolution M --albedo A
    nightlights emission viirs INPUT OUTPUT [--spectrum NAME]

    The first form is short for `nightlights emission ground ...`.
    """


@emission.command("ground")
@files_argument("IRRADIANCE [LIGHTS] OUTPUT", RASTER, POINTS, RASTER)
@output_option
@overwrite_option
@click.option(
    "--resolution",
    type=float,
    required=True,
    help="Output cell size [m]; a multiple of the irradiance pixel size.",
)
@click.option("--albedo", required=True, help="Ground albedo [1]: a number in [0, 1] or a raster.")
@catalog_option
@skip_unknown_option
@crs_option
@max_memory_option
def ground_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    resolution: float,
    albedo: str,
    catalog: str | None,
    skip_unknown: bool,
    crs: str | None,
) -> None:
    """Ground-reflected light of IRRADIANCE plus the direct uplight of LIGHTS, aggregated to
    --resolution; write OUTPUT (COG, bands reflected and uplight [lm m-2]).

    The raster is read and written in windows, so a raster of any size fits in memory."""
    import nightlights as nl
    from nightlights.ground.checks import parse_crs

    parse_crs(crs, option="--crs")
    inputs, out = resolve_inout(
        files,
        output,
        inputs=(1, 2),
        usage="IRRADIANCE [LIGHTS] OUTPUT",
        overwrite=overwrite,
    )
    lights = inputs[1] if len(inputs) == 2 else None
    result = nl.emission(
        inputs[0],
        out,
        lights=lights,
        resolution=resolution,
        albedo=parse_albedo(albedo),
        catalog=catalog,
        skip_unknown=skip_unknown,
        crs=crs,
    )
    from rich.console import Console

    Console(stderr=True).print(
        f"reflected {result.total_flux['reflected']:.4g} lm, uplight "
        f"{result.total_flux['uplight']:.4g} lm -> {out}"
    )


def parse_albedo(text: str) -> float | str:
    """``--albedo``: a number, or the path of an existing raster."""
    try:
        return float(text)
    except ValueError:
        pass
    from pathlib import Path

    if not Path(text).exists():
        raise click.BadParameter(
            f"{text!r}: neither a number nor an existing raster", param_hint="--albedo"
        )
    return text


@emission.command("viirs")
@files_argument("INPUT OUTPUT", RASTER, RASTER)
@output_option
@overwrite_option
@click.option(
    "--spectrum",
    default=DEFAULT_VIIRS_SPECTRUM,
    show_default=True,
    help="Spectrum of the lights seen by VIIRS (HPS, LED_3000K, LED_4000K, ...).",
)
@click.option(
    "--resolution",
    type=float,
    default=None,
    help="Output cell size [m] of a projected output (default: GDAL's estimate of the native "
    "pixel size).",
)
@target_crs_option
@click.option(
    "--emission-function",
    default=None,
    help="Angular emission function of the lights (lambertian, garstang:F,G, tabulated:<json>; "
    "default lambertian): sets the flux the nadir radiance implies; written as the band's tag "
    "for skyglow.",
)
@max_memory_option
def viirs_command(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    spectrum: str,
    resolution: float | None,
    target_crs: str | None,
    emission_function: str | None,
) -> None:
    """Upward flux density of a VIIRS day/night-band radiance raster INPUT [nW cm-2 sr-1];
    write OUTPUT (COG, band upward [lm m-2]).

    The raster is read and written in windows, so a national mosaic fits in memory. A
    geographic INPUT wider than one UTM zone (6 deg of longitude) stays on its own grid:
    flux density per geodesic cell area, which `nightlights darkness` reads as it is."""
    import nightlights as nl
    from nightlights.ground.checks import parse_crs

    parse_crs(target_crs, option="--target-crs")
    (viirs,), out = resolve_inout(
        files, output, inputs=1, usage="INPUT OUTPUT", overwrite=overwrite
    )
    options: dict[str, Any] = {"spectrum": spectrum, "resolution": resolution}
    options["target_crs"] = target_crs
    if emission_function is not None:  # the stage's default otherwise
        options["emission_function"] = emission_function
    result = nl.emission_from_viirs(viirs, out, **options)
    from rich.console import Console

    grid = "geographic" if result.crs.is_geographic else "projected"
    Console(stderr=True).print(
        f"{result.total_flux['upward']:.4g} lm upward -> {out} ({grid} grid, {result.crs.name})"
    )


commands = [emission]
