"""``nightlights validate``: the model's sky against photometer readings, calibrated on request."""

from __future__ import annotations

import click

from .kinds import FOLDER, RASTER, file_kind
from .library import (
    CALIBRATION_PARAMETERS,
    DEFAULT_STATISTIC,
    INSTRUMENT_NAMES,
    NATURAL_SKIES,
    READING_FORMATS,
    VALIDATION_METHODS,
    LibraryChoice,
    LibraryHelpOption,
)
from .options import (
    crs_option,
    dem_option,
    files_argument,
    kernel_option,
    observer_height_option,
    output_option,
    overwrite_option,
    resolve_inout,
    scene_grid_options,
    scene_of,
    spectrum_option,
    turbidity_option,
)
from .resources import max_memory_option

#: Readings: the community-standard skyglow text format, CSV, a GeoPackage of points.
READINGS = file_kind("dat", "txt", "csv", "gpkg", "geojson", "shp")


def _folds(value: str) -> str | int:
    if value == "station":
        return value
    try:
        return int(value)
    except ValueError:
        raise click.BadParameter(
            f"{value!r}; expected 'station' or a number of folds", param_hint="--folds"
        ) from None


def _numbers(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise click.BadParameter(
            f"{text!r}; expected numbers separated by commas", param_hint="--turbidities"
        ) from None


@click.command("validate")
@files_argument("EMISSION READINGS OUTPUT_DIR", RASTER, READINGS, FOLDER)
@output_option
@overwrite_option
@click.option(
    "--calibrate",
    "calibrate",
    multiple=True,
    type=LibraryChoice(CALIBRATION_PARAMETERS),
    help="Fit the emission's flux scale to the readings; repeat to fit the turbidity and the "
    "share of a two-band emission's low-angle (uplight) band too; writes "
    "emission_calibrated.tif and the held-out figures.",
)
@click.option(
    "--folds",
    default="station",
    show_default=True,
    help="Cross-validation of --calibrate: 'station' (leave one station out) or a number k "
    "(k-fold).",
)
@click.option(
    "--turbidities",
    default=None,
    metavar="T1,T2,...",
    help="Turbidities the --calibrate turbidity fit tabulates (default: -1 to +2 around the "
    "scene's).",
)
@click.option(
    "--format",
    "format",
    type=LibraryChoice(READING_FORMATS),
    default=None,
    help="Format of READINGS (default: told from the file).",
)
@click.option(
    "--time-zone",
    default=None,
    metavar="ZONE",
    help="IANA time zone of readings whose times carry no UTC offset (e.g. Europe/Helsinki).",
)
@click.option(
    "--instrument",
    "reading_instrument",
    type=LibraryChoice(INSTRUMENT_NAMES),
    default=None,
    help="Instrument of every reading in READINGS whose file or table does not name one.",
)
@crs_option
@click.option(
    "--station",
    default=None,
    help="Station name of every reading in READINGS (default: from the file).",
)
@spectrum_option
@click.option(
    "--statistic",
    cls=LibraryHelpOption,
    default=None,
    metavar="NAME",
    help="Station statistic of the clear moonless readings: mode, median, darkest_third or "
    "percentile:P (default {default}).",
    help_values={"default": DEFAULT_STATISTIC},
)
@click.option(
    "--natural",
    type=LibraryChoice(NATURAL_SKIES),
    default="time",
    show_default=True,
    help="Natural sky at each station's time and place, or a typical moonless night.",
)
@click.option(
    "--method",
    type=LibraryChoice(VALIDATION_METHODS),
    default="map",
    show_default=True,
    help="Artificial sky from one darkness map per instrument, or each station's panorama "
    "(the slower reference).",
)
@observer_height_option
@dem_option
@kernel_option
@turbidity_option
@scene_grid_options
@max_memory_option
def validate(
    files: tuple[str, ...],
    output: str | None,
    overwrite: bool,
    calibrate: tuple[str, ...],
    folds: str,
    turbidities: str | None,
    format: str | None,
    time_zone: str | None,
    reading_instrument: str | None,
    crs: str | None,
    station: str | None,
    spectrum: str | None,
    statistic: str | None,
    natural: str,
    method: str,
    observer_height: float,
    dem: str | None,
    kernel: str | None,
    turbidity: float | None,
    n_distance: int | None,
    n_elevation: int | None,
    n_azimuth: int | None,
) -> None:
    """Predict what every station's meter reads from EMISSION [lm m-2] and compare with
    READINGS (SQM / TESS-W community-standard files, CSV or GeoPackage points, Globe at Night
    CSV); write to OUTPUT_DIR a styled stations GeoPackage, validation.json (n, bias, RMS,
    MAD per instrument), the scatter plot and the residual map."""
    from nightlights.meter import read_readings
    from nightlights.meter import validate as run_validation

    (emission, readings), out = resolve_inout(
        files, output, inputs=2, usage="EMISSION READINGS OUTPUT_DIR", overwrite=True
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
    table = read_readings(
        readings,
        format=format,
        time_zone=time_zone,
        station=station,
        instrument=reading_instrument,
        crs=crs,
    )
    result = run_validation(
        scene,
        table,
        out,
        height=observer_height,
        spectrum=spectrum,
        statistic=statistic,
        natural=natural,
        method=method,
        calibrate=tuple(calibrate) if calibrate else False,
        folds=_folds(folds),
        turbidities=_numbers(turbidities),
        overwrite=overwrite,
    )
    from rich.console import Console

    overall = result.summary["overall"]
    lines = [
        f"{overall['n']} stations: bias {overall['bias']:+.2f}, RMS {overall['rms']:.2f}, "
        f"MAD {overall['mad']:.2f} mag arcsec-2 (measured - predicted)"
    ]
    if result.calibration is not None:
        c = result.calibration
        fitted = ", ".join(
            f"{name} {value:.3g} +- {c.uncertainties[name]:.2g}"
            for name, value in c.parameters.items()
        )
        lines.append(
            f"calibrated: {fitted}; held out ({c.folds}): bias {c.held_out['bias']:+.2f}, "
            f"RMS {c.held_out['rms']:.2f} (in sample RMS {c.in_sample['rms']:.2f})"
        )
    lines.append(f"-> {out}")
    Console(stderr=True).print("\n".join(lines), soft_wrap=True)


commands = [validate]
