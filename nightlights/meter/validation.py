"""Predicted against measured: the model's sky read as each station's instrument reads it.

For every station (:func:`~nightlights.meter.conditions.station_values`: one clear, moonless,
astronomical-night value per place and instrument) the model predicts the instrument's reading

.. math:: \\hat m = -2.5 \\log_{10}\\frac{A + N}{1.08\\times10^5\\ \\mathrm{cd\\,m^{-2}}},

with ``A`` the artificial sky and ``N`` the natural sky
(:func:`~nightlights.meter.natural.natural_reading`, at the station's representative time), both
weighted by the instrument's angular response and carried into its band by the colour term of
their spectrum (:mod:`nightlights.sky.instruments`; Cinzano 2005 for the zero point).

The artificial part of a zenith-pointing instrument comes from one darkness map per instrument
(:func:`~nightlights.sky.darkness.darkness` with ``instrument=``: the kernel rows weighted by
the response, convolved with the emission by FFT), sampled bilinearly between cell centres at
the stations: one map serves any number of stations. ``method="panorama"`` (and any station
that does not point at the zenith) computes each station's panorama at its exact position
(:func:`~nightlights.sky.forward.skyglow_panorama`) and reads it with the response: the
reference the map is benchmarked against.

The residual is measured minus predicted [mag arcsec-2] (positive: the sky is darker than the
model says); its bias, RMS and median absolute deviation are reported overall and per
instrument. ``calibrate`` fits the emission's flux scale and optionally the turbidity
(:mod:`nightlights.meter.calibrate`) with cross-validation, and writes the calibrated emission.

References
----------
1. Cinzano, P. 2005, "Night sky photometry with Sky Quality Meter", ISTIL Internal Report 9.
2. Falchi, F. et al. 2016, "The new world atlas of artificial night sky brightness", Sci. Adv.
   2, e1600377 (a model calibrated against SQM readings, its scatter stated).
"""

from __future__ import annotations

import math
import time as _time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import geopandas as gpd
import numpy as np
import pandas as pd

from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import CRSError, DataQualityWarning, InputError, OutputExistsError
from nightlights.io import Raster, as_raster
from nightlights.io.jsonfile import dumps_json
from nightlights.io.outputs import OutputSet, refuse_replacing_inputs
from nightlights.meter._variants import (
    TURBIDITY_GRID,
    low_angle_band,
    low_angle_share,
    scene_turbidity,
    turbidity_scenes,
)
from nightlights.meter.calibrate import (
    LEAVE_ONE_OUT,
    Calibration,
    Model,
    check_station_count,
    fit,
    residual_statistics,
)
from nightlights.meter.natural import natural_reading, natural_readings
from nightlights.sky.instruments import Instrument, get_instrument
from nightlights.sky.observer import OBSERVER_HEIGHT, Observer
from nightlights.sky.scene import KernelInput, Scene

__all__ = [
    "METHODS",
    "NATURAL_SKIES",
    "OUTPUT_FILES",
    "STATION_FIELDS",
    "TURBIDITY_GRID",
    "ValidationResult",
    "validate",
]

#: How the artificial sky at the stations is computed: ``map`` (one darkness map per
#: instrument, sampled at the stations) or ``panorama`` (each station's own panorama).
METHODS = ("map", "panorama")
#: The natural sky a prediction adds: at each station's representative time and place, or a
#: typical moonless night.
NATURAL_SKIES = ("time", "typical")
#: The files a validation writes in its output folder.
OUTPUT_FILES = {
    "stations": "stations.gpkg",
    "summary": "validation.json",
    "scatter": "validation.png",
    "residual_map": "residuals.png",
    "calibrated": "emission_calibrated.tif",
}
#: The stations layer's name in its GeoPackage.
STATIONS_LAYER = "stations"

#: The stations layer's fields beyond the station table's: what the model predicts.
STATION_FIELDS: dict[str, str] = {
    "measured": "the station's value [mag arcsec-2]",
    "predicted": "the model's reading of the instrument [mag arcsec-2]",
    "residual": "measured - predicted [mag arcsec-2]; positive: darker than predicted",
    "artificial": "the artificial sky the instrument reads [cd m-2, V-equivalent]",
    "natural": "the natural sky the instrument reads [cd m-2, V-equivalent]",
    "x": "station position in the emission's CRS [m]",
    "y": "station position in the emission's CRS [m]",
}


@dataclass(frozen=True)
class ValidationResult:
    """What :func:`validate` computed.

    Attributes
    ----------
    stations
        One row per station: the station table's fields and :data:`STATION_FIELDS` (and
        ``calibrated``, ``calibrated_residual``, ``held_out``, ``held_out_residual`` after a
        calibration), point geometry in the emission's CRS.
    summary
        ``overall`` and ``per_instrument`` residual statistics (n, bias, rms, mad), the
        calibration's parameters and in-sample / held-out statistics when calibrated, and what
        the prediction was made with.
    calibration
        The calibration, or None.
    paths
        The files written, by kind (:data:`OUTPUT_FILES`).
    seconds
        Time of the prediction once the stations were read [s].
    """

    stations: gpd.GeoDataFrame
    summary: dict[str, Any]
    calibration: Calibration | None = None
    paths: dict[str, Path] = field(default_factory=dict)
    seconds: float = 0.0


def validate(
    scene: Scene,
    readings: gpd.GeoDataFrame | PathLike | Sequence[PathLike],
    output_dir: PathLike | None = None,
    *,
    height: float = OBSERVER_HEIGHT,
    spectrum: str | None = None,
    statistic: str | None = None,
    natural: str = "time",
    method: str = "map",
    calibrate: bool | Sequence[str] = False,
    turbidities: Sequence[float] | None = None,
    kernels: Sequence[KernelInput] | None = None,
    folds: str | int = LEAVE_ONE_OUT,
    overwrite: bool = False,
    progress: bool = True,
) -> ValidationResult:
    """Predict every station's reading from an emission raster and compare it with the meter.

    Parameters
    ----------
    scene
        The emission (a streets-derived emission or ``emission viirs`` alike), terrain,
        atmosphere and kernel (:class:`~nightlights.sky.scene.Scene`).
    readings
        Readings (a table of :func:`~nightlights.meter.readings.read_readings`, or files it
        reads), or a station table of :func:`~nightlights.meter.conditions.station_values`.
    output_dir
        Folder for :data:`OUTPUT_FILES` (created); None writes nothing.
    height
        The instruments' height above the ground [m].
    spectrum
        The artificial light's spectrum (a name of ``ies.spectra.SPDS``); None: the emission's
        ``spectrum`` tag, else the darkness map's default.
    statistic
        The station statistic (:func:`~nightlights.meter.conditions.station_values`); None:
        its default.
    natural
        ``"time"``: the natural sky at each station's representative time; ``"typical"``: a
        typical moonless night.
    method
        ``"map"`` or ``"panorama"`` (:data:`METHODS`; module docstring).
    calibrate
        False; True or ``("scale",)``: fit the emission's flux scale; with ``"turbidity"``:
        and the turbidity; with ``"share"``: and the share of a two-band emission's second,
        low-angle (direct uplight) band in its flux, the total held.
    turbidities
        The turbidities a turbidity calibration tabulates (None: :data:`TURBIDITY_GRID` around
        the scene's) [1].
    kernels
        Precomputed kernels at two or more turbidities (each its own) for a turbidity
        calibration, in place of scene kernels built at ``turbidities``.
    folds
        Cross-validation of a calibration: ``"station"`` (leave one station out) or k.
    overwrite
        Replace existing outputs.
    progress
        Progress bars.

    Returns
    -------
    ValidationResult

    Raises
    ------
    InputError
        No station inside the emission raster; an unknown method or natural sky; what the
        readings, the scene or the calibration refuse.
    OutputError
        An output exists without ``overwrite``, or is one of the inputs.
    """
    if method not in METHODS:
        raise InputError(f"method={method!r}; expected one of {', '.join(METHODS)}")
    if natural not in NATURAL_SKIES:
        raise InputError(f"natural={natural!r}; expected one of {', '.join(NATURAL_SKIES)}")
    parameters = _parameters(calibrate)
    folder = Path(output_dir) if output_dir is not None else None
    files = {kind: folder / name for kind, name in OUTPUT_FILES.items()} if folder else {}
    if not parameters:
        files.pop("calibrated", None)
    inputs = {**scene.inputs, "readings": readings}
    refuse_replacing_inputs(files.values(), inputs)
    if folder is not None and not overwrite:
        for path in files.values():
            if path.exists():
                raise OutputExistsError(f"{path}: exists; give overwrite to replace it")
    stations = _stations(readings, statistic)
    emission = as_raster(scene.raster_input("validate"))
    if emission.crs is None or not emission.crs.is_projected:
        raise CRSError(f"{scene.label}: the emission raster needs a projected CRS in metres")
    stations = _inside(stations, emission, scene.label)
    if parameters:
        check_station_count(len(stations), parameters)  # before any map is computed
        from nightlights.meter.calibrate import PARAMETERS

        unknown = [name for name in parameters if name not in PARAMETERS]
        if unknown:
            raise InputError(
                f"calibrate={list(parameters)!r}; expected 'scale', optionally with "
                f"{', '.join(repr(p) for p in PARAMETERS[1:])}"
            )
    share = low_angle_share(emission, scene.label) if "share" in parameters else None
    scene = scene.replace(emission=emission)
    start = _time.perf_counter()
    measured = stations["magnitude"].to_numpy(dtype=float)
    natural_values = _natural(stations, natural)
    base = scene_turbidity(scene)
    artificial = _artificial(scene, stations, height, spectrum, method, progress)
    stations = stations.assign(
        measured=measured,
        artificial=artificial,
        natural=natural_values,
    )
    predicted = np.asarray(luminance_to_magnitude(artificial + natural_values))
    stations["predicted"] = predicted
    stations["residual"] = measured - predicted
    calibration = None
    if parameters:
        grid = None
        tabulated = [(base, scene)]
        if "turbidity" in parameters:
            tabulated = turbidity_scenes(scene, turbidities, kernels, base)
            grid = np.array([t for t, _ in tabulated])

        def readings(emission_of: Any) -> FloatArray:
            table = [
                _artificial(emission_of(other), stations, height, spectrum, method, progress)
                for _, other in tabulated
            ]
            return np.stack(table) if grid is not None else table[0]

        table = artificial if grid is None else readings(lambda other: other)
        low = None
        if share is not None:
            low = readings(lambda other: other.replace(emission=low_angle_band(emission)))
        model = Model(
            measured,
            table,
            natural_values,
            grid,
            base,
            low,
            share if share is not None else math.nan,
        )
        calibration = fit(model, parameters, folds=folds)
        stations["calibrated"] = calibration.predicted
        stations["calibrated_residual"] = measured - calibration.predicted
        stations["held_out"] = calibration.held_out_predicted
        stations["held_out_residual"] = measured - calibration.held_out_predicted
    seconds = _time.perf_counter() - start
    summary = _summary(stations, calibration, scene, spectrum, method, natural, height)
    paths: dict[str, Path] = {}
    if folder is not None:
        from nightlights.meter._figures import residual_map, scatter
        from nightlights.meter._outputs import write_calibrated, write_stations

        folder.mkdir(parents=True, exist_ok=True)
        with OutputSet(*files.values(), inputs=inputs) as outputs:
            write_stations(stations, outputs.temporary(files["stations"]), STATIONS_LAYER)
            outputs.temporary(files["summary"]).write_text(
                dumps_json(summary, indent=2) + "\n", encoding="utf-8"
            )
            scatter(stations, outputs.temporary(files["scatter"]), calibration)
            residual_map(stations, outputs.temporary(files["residual_map"]), emission)
            if calibration is not None:
                write_calibrated(
                    emission, calibration, outputs.temporary(files["calibrated"]), share
                )
        paths = dict(files)
    return ValidationResult(stations, summary, calibration, paths, seconds)


# --- stations ---------------------------------------------------------------------------------


def _parameters(calibrate: bool | Sequence[str]) -> tuple[str, ...]:
    if calibrate is False or calibrate is None:
        return ()
    if calibrate is True:
        return ("scale",)
    if isinstance(calibrate, str):
        calibrate = [calibrate]
    names = tuple(dict.fromkeys(["scale", *calibrate]))
    return names


def _stations(readings: Any, statistic: str | None) -> gpd.GeoDataFrame:
    """The station table: given, or from readings (read, conditions, selection, statistic)."""
    from nightlights.meter.conditions import select_readings, sky_conditions, station_values

    if isinstance(readings, pd.DataFrame) and "n_readings" in readings.columns:
        return gpd.GeoDataFrame(readings).reset_index(drop=True)
    if not isinstance(readings, pd.DataFrame):
        from nightlights.meter.readings import read_readings

        readings = read_readings(readings)
    # a table already selected (``kept``) keeps its selection and its limits
    selected = readings if "kept" in readings.columns else select_readings(sky_conditions(readings))
    options = {} if statistic is None else {"statistic": statistic}
    return station_values(selected, **options).reset_index(drop=True)


def _inside(stations: gpd.GeoDataFrame, emission: Raster, label: str) -> gpd.GeoDataFrame:
    """The stations in the emission's CRS, those outside the raster left out (warned)."""
    from pyproj import Transformer

    to_crs = Transformer.from_crs("EPSG:4326", emission.crs, always_xy=True)
    x, y = to_crs.transform(
        stations["lon"].to_numpy(dtype=float), stations["lat"].to_numpy(dtype=float)
    )
    west, south, east, north = emission.bounds
    inside = (x >= west) & (x <= east) & (y >= south) & (y <= north)
    if not inside.any():
        raise InputError(
            f"none of the {len(stations)} stations lies inside {label} "
            f"(bounds {west:.0f}, {south:.0f}, {east:.0f}, {north:.0f} in {emission.crs})"
        )
    if not inside.all():
        outside = stations.loc[~inside, "station"].astype(str).tolist()
        shown = ", ".join(outside[:5]) + (", ..." if len(outside) > 5 else "")
        warnings.warn(
            f"{len(outside)} station{'s' if len(outside) > 1 else ''} outside {label} left "
            f"out: {shown}",
            DataQualityWarning,
            stacklevel=3,
        )
    kept = stations.loc[inside].copy()
    kept["x"], kept["y"] = x[inside], y[inside]
    return gpd.GeoDataFrame(
        kept.drop(columns="geometry", errors="ignore"),
        geometry=gpd.points_from_xy(x[inside], y[inside]),
        crs=emission.crs,
    ).reset_index(drop=True)


def _instrument(row: Any) -> Instrument:
    device = get_instrument(str(row["instrument"]))
    fov = row.get("fov", math.nan) if hasattr(row, "get") else math.nan
    if fov is not None and np.isfinite(fov) and not np.isclose(fov, device.fwhm):
        device = device.with_fwhm(float(fov))
    return device


def _pointing(row: Any) -> tuple[float, float]:
    elevation = row.get("pointing_elevation", 90.0)
    azimuth = row.get("pointing_azimuth", 0.0)
    elevation = 90.0 if elevation is None or not np.isfinite(elevation) else float(elevation)
    azimuth = 0.0 if azimuth is None or not np.isfinite(azimuth) else float(azimuth)
    return elevation, azimuth


def _natural(stations: gpd.GeoDataFrame, natural: str) -> FloatArray:
    """Each station's natural sky reading [cd m-2, V-equivalent]: per instrument and pointing,
    shared between stations of one sidereal time and latitude
    (:func:`~nightlights.meter.natural.natural_readings`)."""
    out = np.empty(len(stations))
    rows = stations.to_dict("records")
    groups: dict[tuple[str, float, tuple[float, float]], list[int]] = {}
    devices: dict[tuple[str, float, tuple[float, float]], Instrument] = {}
    for i, row in enumerate(rows):
        device = _instrument(row)
        key = (device.name, device.fwhm, _pointing(row))
        groups.setdefault(key, []).append(i)
        devices[key] = device
    for key, members in groups.items():
        device, pointing = devices[key], key[2]
        timed = [i for i in members if natural == "time" and not pd.isna(rows[i].get("time"))]
        untimed = sorted(set(members) - set(timed))
        if untimed:
            out[untimed] = natural_reading(device, pointing=pointing)
        if timed:
            out[timed] = natural_readings(
                device,
                [rows[i]["time"] for i in timed],
                [rows[i]["lon"] for i in timed],
                [rows[i]["lat"] for i in timed],
                pointing=pointing,
            )
    return out


# --- the artificial sky -------------------------------------------------------------------------


def _artificial(
    scene: Scene,
    stations: gpd.GeoDataFrame,
    height: float,
    spectrum: str | None,
    method: str,
    progress: bool,
) -> FloatArray:
    """The artificial sky each station's instrument reads [cd m-2, V-equivalent]."""
    out = np.full(len(stations), math.nan)
    rows = stations.to_dict("records")
    devices = [_instrument(row) for row in rows]
    pointings = [_pointing(row) for row in rows]
    zenith = np.array([p[0] >= 90.0 - 1e-9 for p in pointings])
    if method == "map":
        groups: dict[tuple[str, float], list[int]] = {}
        for i, device in enumerate(devices):
            if zenith[i]:
                groups.setdefault((device.name, device.fwhm), []).append(i)
        for members in groups.values():
            out[members] = _from_map(
                scene, stations.iloc[members], devices[members[0]], height, spectrum, progress
            )
    for k in np.flatnonzero(~np.isfinite(out)):
        j = int(k)
        out[j] = _from_panorama(scene, rows[j], devices[j], pointings[j], height, spectrum)
    return out


def _from_map(
    scene: Scene,
    stations: gpd.GeoDataFrame,
    device: Instrument,
    height: float,
    spectrum: str | None,
    progress: bool,
) -> FloatArray:
    """One darkness map in the instrument's units, sampled bilinearly at the stations."""
    from scipy.ndimage import map_coordinates

    from nightlights.sky.darkness import darkness

    result = darkness(
        scene, None, height=height, instrument=device, spectrum=spectrum, progress=progress
    )
    raster = result.raster
    assert raster is not None  # without an output the map is returned, tiled or not
    band = raster.band("instrument_luminance")
    inverse = ~raster.transform
    cols, rows = inverse @ (stations["x"].to_numpy(float), stations["y"].to_numpy(float))
    # cell centres at integer + 0.5: map_coordinates samples at the centres' indices
    values = map_coordinates(
        np.nan_to_num(band),
        [np.asarray(rows) - 0.5, np.asarray(cols) - 0.5],
        order=1,
        mode="nearest",
    )
    return np.asarray(values, dtype=float)


def _from_panorama(
    scene: Scene,
    row: dict[str, Any],
    device: Instrument,
    pointing: tuple[float, float],
    height: float,
    spectrum: str | None,
) -> float:
    """A station's own panorama read with the instrument's response (the reference)."""
    from nightlights.sky.forward import skyglow_panorama
    from nightlights.sky.instrument_units import InstrumentSky, instrument_sky

    observer = Observer(float(row["x"]), float(row["y"]), height=height)
    panorama = skyglow_panorama(scene, observer, progress=False).panorama
    sky = cast(
        "InstrumentSky",
        instrument_sky(device, spectrum=spectrum, emission=scene.emission, label=scene.label),
    )  # not None: an instrument is given
    weights = sky.panorama_weights(
        panorama["elevation"].values, panorama["azimuth"].values, pointing=pointing
    )
    return sky.read(panorama["luminance"].values, weights)


def _emission_spectrum(scene: Scene) -> str:
    from nightlights.sky.instrument_units import DEFAULT_SPECTRUM, emission_spectrum

    return emission_spectrum(scene.emission) or DEFAULT_SPECTRUM


# --- outputs ----------------------------------------------------------------------------------


def _summary(
    stations: gpd.GeoDataFrame,
    calibration: Calibration | None,
    scene: Scene,
    spectrum: str | None,
    method: str,
    natural: str,
    height: float,
) -> dict[str, Any]:
    per_instrument = {
        str(name): residual_statistics(group["residual"])
        for name, group in stations.groupby("instrument", sort=True)
    }
    summary: dict[str, Any] = {
        "unit": "mag arcsec-2",
        "residual": "measured - predicted",
        "overall": residual_statistics(stations["residual"]),
        "per_instrument": per_instrument,
        "model": {
            "emission": scene.label,
            "turbidity": scene.turbidity if scene.turbidity is not None else "scene default",
            "spectrum": spectrum if spectrum is not None else _emission_spectrum(scene),
            "method": method,
            "natural_sky": natural,
            "height_m": height,
        },
    }
    if calibration is not None:
        summary["calibration"] = calibration.as_dict()
        summary["calibrated_per_instrument"] = {
            str(name): residual_statistics(group["held_out_residual"])
            for name, group in stations.groupby("instrument", sort=True)
        }
    return summary
