"""Photometer and naked-eye sky-brightness readings, read into one table.

:func:`read_readings` reads Sky Quality Meter and TESS-W files of the IDA / NSBM community
standard (:mod:`nightlights.meter._ida`), tables of point readings (CSV, or any vector file
pyogrio reads: GeoPackage, GeoJSON...), Globe at Night naked-eye reports, or a DataFrame, into
the readings table documented by :data:`READING_COLUMNS`: one row per reading, its UTC instant,
its magnitude [mag arcsec-2] in the instrument's own band, the instrument, where it looked, the
station, its position and the file it came from.

Modelling choices:

- Times are instants in UTC. The community standard's ``UTC Date & Time`` is UTC; a table's
  times carry a UTC offset or are local times of the zone named by ``time_zone=`` (naive times
  without it are refused: a reading an hour off moves the Sun and the Moon).
- A magnitude that is not finite, or not within :data:`MAGNITUDE_RANGE`, is no sky brightness:
  such readings are dropped with a :class:`~nightlights.errors.DataQualityWarning` that names
  the file and counts them (loggers write fill values, e.g. 0 when saturated by day), the others
  are kept. Text where a number should be is refused, with its line.
- A station is one place and instrument: the ``station`` column or ``station=``, the community
  standard's ``Instrument ID`` (else ``Location name``), else one station per distinct position
  (rounded to 1e-4 deg, about 10 m) and instrument, named ``INSTRUMENT@LAT,LON``. A name used at
  several places or by several instruments is split, the place appended.
- Globe at Night reports give a naked-eye limiting magnitude; it is turned into the sky
  brightness it implies by :func:`limiting_magnitude_to_sky_brightness`, Schaefer's
  night-vision threshold [1]_ [2]_ with Krisciunas & Schaefer's luminance scale [3]_, within
  the relation's range (other reports are dropped with a warning). The report's cloud category
  is kept as ``cloud_cover``.

References
----------
.. [1] Schaefer, B. E. (1990). Telescopic limiting magnitudes. Publications of the
   Astronomical Society of the Pacific 102, 212-229: the threshold illuminance
   I = C1 (1 + sqrt(C2 B))^2 of a star against a background B.
.. [2] Schaefer, B. E. (1998). To the visual limits. Sky & Telescope 95(5), 57: the program of
   the model, with C1 = 1.5849e-10 ft-cd, C2 = 1.2589e-2 nL-1 for night vision
   (B <= 1500 nL) and m = -16.57 - 2.5 log10(I / ft-cd).
.. [3] Krisciunas, K. & Schaefer, B. E. (1991). A model of the brightness of moonlight.
   Publications of the Astronomical Society of the Pacific 103, 1033-1039, Eq. 1:
   B = 34.08 exp(20.7233 - 0.92104 V) nL for a sky of V mag arcsec-2.
.. [4] Globe at Night (NSF NOIRLab): the yearly data exports (``LimitingMag``,
   ``CloudCover``, ``Latitude``, ``Longitude``, ``UTDate`` and ``UTTime`` or ``ObsDateTime``).
"""

from __future__ import annotations

import os
import re
import warnings
import zoneinfo
from collections.abc import Iterable
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from pyproj import CRS

from nightlights._typing import FloatArray
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.io.atomic import atomic_output
from nightlights.io.vector import read_vector
from nightlights.meter import _ida, _tables
from nightlights.sky.instruments import INSTRUMENTS

#: The readings table: column -> (dtype, unit, meaning). ``cloud_cover`` is NaN but for
#: naked-eye reports that state their clouds.
READING_COLUMNS: dict[str, tuple[str, str, str]] = {
    "station": ("str", "", "station id: one place and instrument"),
    "time": ("datetime64[ns, UTC]", "", "the reading's instant, UTC"),
    "magnitude": (
        "float64",
        "mag arcsec-2",
        "sky brightness as the instrument reports it, in its own band",
    ),
    "instrument": ("str", "", "a key of nightlights.sky.instruments.INSTRUMENTS"),
    "fov": ("float64", "deg", "FWHM of the angular response when stated, else NaN (default)"),
    "pointing_elevation": ("float64", "deg", "where the instrument looks: 90 is the zenith"),
    "pointing_azimuth": ("float64", "deg", "where the instrument looks: clockwise from north"),
    "sky_temperature": ("float64", "degC", "TESS-W infrared sky temperature, else NaN"),
    "ambient_temperature": ("float64", "degC", "the instrument's temperature, else NaN"),
    "lon": ("float64", "deg", "WGS84 longitude"),
    "lat": ("float64", "deg", "WGS84 latitude"),
    "source": ("str", "", "the file the reading came from"),
    "cloud_cover": (
        "float64",
        "1",
        "optional: fraction of the sky under clouds as reported, else NaN",
    ),
    "geometry": ("geometry", "", "Point, in the CRS of the input (EPSG:4326 if they differ)"),
}

#: The instruments a reading may name: the keys of ``nightlights.sky.instruments.INSTRUMENTS``.
INSTRUMENT_NAMES = tuple(INSTRUMENTS)

#: The ``Device type`` a community-standard file names each photometer by (what
#: :func:`write_ida` writes; a type read is matched by its prefix: SQM-LE, SQM-LU are lensed).
DEVICE_TYPES = {"sqm": "SQM", "sqm-l": "SQM-L", "tess-w": "TESS-W"}

#: The formats :func:`read_readings` reads.
FORMATS = ("ida", "csv", "gpkg", "globe-at-night")

#: Magnitudes of sky brightness that can be real [mag arcsec-2]: 0 is 1.08e5 cd m-2, brighter
#: than a daylit sky; 25 is 1.1e-5 cd m-2, 16 times darker than the darkest natural night sky
#: (about 22, 171 ucd m-2) (m = -2.5 log10(L / 1.08e5), :mod:`nightlights.brightness`).
MAGNITUDE_RANGE = (0.0, 25.0)

#: Schaefer's night-vision threshold (B <= :data:`NIGHT_VISION_MAX_NANOLAMBERT`): C1 [ft-cd]
#: and C2 [nL-1] of I = C1 (1 + sqrt(C2 B))^2, and the magnitude of 1 ft-cd [mag] ([2]_).
SCHAEFER_NIGHT_C1 = 1.5849e-10
SCHAEFER_NIGHT_C2 = 1.2589e-2
SCHAEFER_ZERO_MAGNITUDE = -16.57
#: Brightest background of the night-vision branch [nL] ([2]_).
NIGHT_VISION_MAX_NANOLAMBERT = 1500.0
#: Krisciunas & Schaefer (1991) Eq. 1, B = A exp(B0 - B1 V): A [nL], B0 [1], B1 [mag-1].
KS91_SCALE_NANOLAMBERT = 34.08
KS91_EXPONENT = 20.7233
KS91_SLOPE = 0.92104

#: Limiting magnitude of a black sky (B -> 0) [mag]: -16.57 - 2.5 log10(C1) = 7.93.
BLACK_SKY_LIMITING_MAGNITUDE = SCHAEFER_ZERO_MAGNITUDE - 2.5 * np.log10(SCHAEFER_NIGHT_C1)
#: Limiting magnitude at the brightest night-vision background (1500 nL) [mag], about 4.29.
BRIGHTEST_LIMITING_MAGNITUDE = BLACK_SKY_LIMITING_MAGNITUDE - 5.0 * np.log10(
    1.0 + np.sqrt(SCHAEFER_NIGHT_C2 * NIGHT_VISION_MAX_NANOLAMBERT)
)

_VECTOR_SUFFIXES = (".gpkg", ".geojson", ".json", ".shp", ".fgb", ".gml", ".kml", ".sqlite")
#: Files a folder may hold beside readings: shapefile parts, styles, notes (skipped silently).
_NOT_READINGS = (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx", ".qml", ".md", ".xml")
_IN_MEMORY = "in-memory readings"


def limiting_magnitude_to_sky_brightness(limiting_magnitude: ArrayLike) -> FloatArray | float:
    """Sky brightness implied by a naked-eye limiting magnitude, Schaefer's night vision.

    The faintest star seen against a background B [nL] has the illuminance
    I = C1 (1 + sqrt(C2 B))^2 [ft-cd] and the magnitude m = -16.57 - 2.5 log10 I ([1]_, with
    the night-vision constants of [2]_); B in nL is the sky of V mag arcsec-2 by Krisciunas &
    Schaefer's Eq. 1 ([3]_). Solved for V:

    .. math::

        B = \\frac{(10^{(7.93 - m)/5} - 1)^2}{C_2}, \\qquad
        V = \\frac{20.7233 - \\ln(B / 34.08)}{0.92104}

    which is the inverse of the relation in common use, m = 7.93 - 5 log10(10^(4.316 - V/5) + 1).
    The star's atmospheric extinction is not subtracted and the observer is Schaefer's
    standard one (no age, experience or acuity factors), as in that common use.

    Parameters
    ----------
    limiting_magnitude
        Naked-eye limiting magnitude m [mag], within the night-vision branch:
        :data:`BRIGHTEST_LIMITING_MAGNITUDE` (4.29, a 1500 nL sky, V = 18.39) <= m <
        :data:`BLACK_SKY_LIMITING_MAGNITUDE` (7.93, a black sky).

    Returns
    -------
    float or numpy.ndarray
        Sky brightness V [mag arcsec-2], the shape of the input.

    Raises
    ------
    InputError
        A limiting magnitude that is not finite or outside the relation's range.

    Examples
    --------
    >>> round(limiting_magnitude_to_sky_brightness(6.0), 2)
    20.8
    >>> limiting_magnitude_to_sky_brightness([5.0, 6.5]).round(2).tolist()
    [19.3, 21.73]
    """
    values = np.asarray(limiting_magnitude, dtype=float)
    bad = ~(
        np.isfinite(values)
        & (values >= BRIGHTEST_LIMITING_MAGNITUDE)
        & (values < BLACK_SKY_LIMITING_MAGNITUDE)
    )
    if bad.any():
        first = float(values[bad].flat[0])
        raise InputError(
            f"limiting_magnitude: {int(bad.sum())} of {values.size} values outside the "
            f"night-vision relation's range ({first:g}); expected "
            f"{BRIGHTEST_LIMITING_MAGNITUDE:.2f} <= m < {BLACK_SKY_LIMITING_MAGNITUDE:.2f} "
            "(Schaefer 1990, backgrounds up to 1500 nL)"
        )
    root = 10.0 ** ((BLACK_SKY_LIMITING_MAGNITUDE - values) / 5.0) - 1.0  # sqrt(C2 B)
    nanolambert = root**2 / SCHAEFER_NIGHT_C2
    brightness = (KS91_EXPONENT - np.log(nanolambert / KS91_SCALE_NANOLAMBERT)) / KS91_SLOPE
    return float(brightness) if brightness.ndim == 0 else brightness


def read_readings(
    source: str | os.PathLike[str] | Iterable[str | os.PathLike[str]] | pd.DataFrame,
    *,
    format: str | None = None,
    instrument: str | None = None,
    station: str | None = None,
    time_zone: str | None = None,
    crs: str | CRS | None = None,
) -> gpd.GeoDataFrame:
    """Read sky-brightness readings into the readings table (:data:`READING_COLUMNS`).

    Parameters
    ----------
    source
        A file, a list of files, a folder (every file in it whose format can be told; others
        are skipped with a warning) or a DataFrame / GeoDataFrame of point readings.
    format
        ``"ida"`` (the community standard: Sky Quality Meter, TESS-W), ``"csv"``, ``"gpkg"``
        (any vector file pyogrio reads, points), ``"globe-at-night"``; None tells each file's
        format from its suffix and first lines.
    instrument
        Instrument of every reading (a name of :data:`INSTRUMENT_NAMES`); default: the file's
        device type, the ``instrument`` column, ``"eye"`` for Globe at Night.
    station
        Station name of every reading; default as the module says.
    time_zone
        IANA zone of times without a UTC offset in tables (``"Europe/Helsinki"``).
    crs
        CRS of a table's ``x``, ``y`` columns, or of a vector layer that has none.

    Returns
    -------
    geopandas.GeoDataFrame
        The readings, sorted by station and time; ``attrs["sources"]`` lists what was read.

    Notes
    -----
    A table's columns (any case): ``lon``/``longitude``, ``lat``/``latitude`` (or ``x``, ``y``
    with ``crs=``, or a layer's point geometry), ``time``/``datetime``/``timestamp``,
    ``magnitude``/``mag``/``msas``/``mpsas``/``sqm`` [mag arcsec-2], ``instrument``; optional
    ``station``, ``fov`` [deg], ``pointing_elevation``/``altitude`` and
    ``pointing_azimuth``/``azimuth`` [deg] (empty: 90 and 0), ``sky_temperature``,
    ``ambient_temperature`` [degC], ``cloud_cover`` [1]. Other columns are ignored.

    Raises
    ------
    InputError
        A missing file, a malformed one (its line named), an unknown ``format`` or
        ``instrument``, naive times without ``time_zone``, an unknown zone, readings without
        position.
    CRSError
        ``x``, ``y`` or a layer without a CRS and no ``crs``, or an unusable ``crs``.
    EmptyInputError
        No readings: an empty folder, list or file, or every reading dropped.

    Examples
    --------
    >>> frame = pd.DataFrame({"lon": [24.95], "lat": [60.17], "mag": [18.2],
    ...                       "time": ["2024-01-10T21:00:00Z"], "instrument": ["sqm-l"]})
    >>> read_readings(frame)[["station", "magnitude", "instrument"]].to_dict("records")
    [{'station': 'sqm-l@60.1700,24.9500', 'magnitude': 18.2, 'instrument': 'sqm-l'}]
    """
    if format is not None and format not in FORMATS:
        raise InputError(f"format={format!r}: unknown; expected one of {', '.join(FORMATS)}")
    if instrument is not None:
        _check_instruments(pd.Series([instrument]), "instrument=")
    if station is not None and not isinstance(station, str):
        raise InputError(f"station={station!r}: expected a name (str)")
    zone = None if time_zone is None else _tables.zone_of(time_zone)
    target = None if crs is None else _tables.crs_of(crs)
    parts: list[gpd.GeoDataFrame] = []
    labels: list[str] = []
    for item, kind in _sources(source, format):
        label = _IN_MEMORY if isinstance(item, pd.DataFrame) else str(item)
        part = _read_one(item, kind, label, zone=zone, crs=target, instrument=instrument)
        if station is not None:
            part["station"] = station
        parts.append(_plausible(part, label))
        labels.append(label)
    return _assemble(parts, labels)


def write_ida(
    readings: gpd.GeoDataFrame, path: str | os.PathLike[str], *, time_zone: str = "UTC"
) -> Path:
    """Write one station's photometer readings as a file of the community standard.

    Parameters
    ----------
    readings
        Readings of one station and instrument (``"sqm"``, ``"sqm-l"`` or ``"tess-w"``), in
        the layout of :data:`READING_COLUMNS`.
    path
        Output file; replaced atomically.
    time_zone
        IANA zone of the local time column.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    _tables.zone_of(time_zone)
    stations = pd.unique(readings["station"])
    instruments = pd.unique(readings["instrument"])
    devices = DEVICE_TYPES
    if len(stations) != 1 or len(instruments) != 1 or instruments[0] not in devices:
        raise InputError(
            f"write_ida: {len(stations)} stations, instruments {list(instruments)}; expected one "
            "station of one photometer (sqm, sqm-l, tess-w)"
        )
    first = readings.iloc[0]
    header = _ida.IdaHeader(
        device_type=devices[str(instruments[0])],
        instrument_id=str(stations[0]),
        location_name=str(stations[0]),
        latitude=float(first["lat"]),
        longitude=float(first["lon"]),
        elevation=float("nan"),
        fov=float(first["fov"]),
        pointing_elevation=float(first["pointing_elevation"]),
        pointing_azimuth=float(first["pointing_azimuth"]),
        fields=(),
    )
    text = _ida.format_ida(header, readings.sort_values("time"), time_zone=time_zone)
    with atomic_output(path) as tmp:
        tmp.write_bytes(text.encode("ascii", errors="replace"))
    return Path(path)


# -- sources and formats ------------------------------------------------------------------------


def _sources(source: object, format: str | None) -> list[tuple[pd.DataFrame | Path, str]]:
    if isinstance(source, pd.DataFrame):
        frame_kind = format or ("gpkg" if isinstance(source, gpd.GeoDataFrame) else "csv")
        return [(source, frame_kind)]
    if isinstance(source, str | os.PathLike):
        paths = [Path(source)]
    elif isinstance(source, Iterable):
        paths = [Path(item) for item in source]
        if not paths:
            raise EmptyInputError("source: an empty list of files")
    else:
        raise InputError(
            f"source: got {type(source).__name__}; expected a path, a list of paths, a folder "
            "or a DataFrame"
        )
    found: list[tuple[pd.DataFrame | Path, str]] = []
    for path in paths:
        if path.is_dir():
            found.extend(_folder(path, format))
        elif not path.exists():
            raise InputError(f"{path}: no such file")
        else:
            kind = format or _guess_format(path)
            if kind is None:
                raise InputError(
                    f"{path}: cannot tell its format; give format= ({', '.join(FORMATS)})"
                )
            found.append((path, kind))
    return found


def _folder(folder: Path, format: str | None) -> list[tuple[pd.DataFrame | Path, str]]:
    files = sorted(
        path
        for path in folder.iterdir()
        if path.is_file()
        and not path.name.startswith(".")
        and path.suffix.lower() not in _NOT_READINGS
    )
    found: list[tuple[pd.DataFrame | Path, str]] = []
    skipped: list[str] = []
    for path in files:
        kind = format or _guess_format(path)
        if kind is None:
            skipped.append(path.name)
        else:
            found.append((path, kind))
    if skipped:
        warnings.warn(
            f"{folder}: skipped {len(skipped)} files of no readings format: "
            f"{', '.join(skipped[:5])}",
            DataQualityWarning,
            stacklevel=4,
        )
    if not found:
        raise EmptyInputError(f"{folder}: no readings files in the folder")
    return found


def _guess_format(path: Path) -> str | None:
    if path.suffix.lower() in _VECTOR_SUFFIXES:
        return "gpkg"
    with path.open("rb") as handle:
        head = handle.read(8192)
    if b"\0" in head:
        return None
    lines = [line for line in head.decode("utf-8", errors="replace").splitlines() if line.strip()]
    if not lines:
        return "csv" if path.suffix.lower() == ".csv" else None
    if _ida.is_ida("\n".join(lines)):
        return "ida"
    while lines and lines[0].lstrip().startswith("#"):  # a commented table
        lines = lines[1:]
    if not lines:
        return None
    names = {name.strip().strip('"') for name in re.split(r"[,;]", lines[0])}
    if "LimitingMag" in names and ({"UTDate", "ObsDateTime"} & names):
        return "globe-at-night"
    if path.suffix.lower() in (".csv", ".txt") or "," in lines[0]:
        return "csv"
    return None


def _read_one(
    item: pd.DataFrame | Path,
    kind: str,
    label: str,
    *,
    zone: zoneinfo.ZoneInfo | None,
    crs: CRS | None,
    instrument: str | None,
) -> gpd.GeoDataFrame:
    if kind == "ida":
        if not isinstance(item, Path):
            raise InputError(f"{label}: format='ida' reads files, not a DataFrame")
        return _read_ida(item, label, instrument)
    if isinstance(item, pd.DataFrame):
        frame, where = item, _tables.rows_of(label, 0)
    elif kind == "gpkg":
        frame, where = read_vector(item), _tables.features_of(label)
    else:
        frame = _tables.read_csv(item, label)
        where = _tables.rows_of(label, int(frame.attrs.get("first_line", 2)))
    if frame.empty:
        return _no_readings(label)
    if kind == "globe-at-night":
        return _eye_readings(frame, label, where, zone=zone, instrument=instrument)
    return _tables.table_readings(frame, label, where, zone=zone, crs=crs, instrument=instrument)


# -- the community standard ---------------------------------------------------------------------


def _no_readings(label: str) -> gpd.GeoDataFrame:
    """An empty part, with a warning: a file of headers only adds nothing to the table."""
    warnings.warn(f"{label}: holds no readings", DataQualityWarning, stacklevel=4)
    columns = [column for column in READING_COLUMNS if column != "geometry"]
    return gpd.GeoDataFrame(pd.DataFrame(columns=columns), geometry=[], crs="EPSG:4326")


def _instrument_of_device(device_type: str) -> str | None:
    """The instrument a ``Device type`` names (:data:`DEVICE_TYPES` as prefixes, the longest
    first): SQM-L* lensed, other SQM wide, TESS* the TESS-W."""
    name = device_type.strip().upper()
    prefixes = {"tess-w": "TESS", "sqm-l": DEVICE_TYPES["sqm-l"], "sqm": DEVICE_TYPES["sqm"]}
    return next((key for key, prefix in prefixes.items() if name.startswith(prefix)), None)


def _read_ida(path: Path, label: str, instrument: str | None) -> gpd.GeoDataFrame:
    text = path.read_text(encoding="utf-8", errors="replace")
    header, rows = _ida.parse_ida(text, source=label)
    if instrument is None:
        instrument = _instrument_of_device(header.device_type)
        if instrument is None:
            raise InputError(
                f"{label}: device type {header.device_type!r} is no known instrument; give "
                f"instrument= ({', '.join(INSTRUMENT_NAMES)})"
            )
    if rows.empty:
        return _no_readings(label)
    name = header.instrument_id or header.location_name
    frame = pd.DataFrame(
        {
            "station": name if name else np.nan,
            "time": rows["time"],
            "magnitude": rows["magnitude"],
            "instrument": instrument,
            "fov": header.fov,
            "pointing_elevation": header.pointing_elevation,
            "pointing_azimuth": header.pointing_azimuth,
            "sky_temperature": rows["sky_temperature"],
            "ambient_temperature": rows["ambient_temperature"],
            "lon": header.longitude,
            "lat": header.latitude,
            "source": label,
            "cloud_cover": np.nan,
        }
    )
    points = gpd.points_from_xy(frame["lon"], frame["lat"], crs="EPSG:4326")
    return gpd.GeoDataFrame(frame, geometry=points, crs="EPSG:4326")


# -- Globe at Night -----------------------------------------------------------------------------


def _eye_readings(
    frame: pd.DataFrame,
    label: str,
    where: _tables.Where,
    *,
    zone: zoneinfo.ZoneInfo | None,
    instrument: str | None,
) -> gpd.GeoDataFrame:
    """Globe at Night reports as readings: the sky brightness their limiting magnitudes imply."""
    reports = _tables.globe_at_night_table(frame, label, where, zone)
    limiting = reports["limiting_magnitude"].to_numpy(dtype=float)
    no_place = ((reports["lat"] == 0.0) & (reports["lon"] == 0.0)).to_numpy()
    no_magnitude = np.isnan(limiting)
    outside = ~no_magnitude & ~(
        (limiting >= BRIGHTEST_LIMITING_MAGNITUDE) & (limiting < BLACK_SKY_LIMITING_MAGNITUDE)
    )
    keep = ~(no_place | no_magnitude | outside)
    if not keep.all():
        notes = [
            f"{int(no_place.sum())} at latitude 0, longitude 0 (no position)",
            f"{int(no_magnitude.sum())} without a limiting magnitude",
            f"{int(outside.sum())} with limiting magnitudes outside "
            f"{BRIGHTEST_LIMITING_MAGNITUDE:.2f}-{BLACK_SKY_LIMITING_MAGNITUDE:.2f}, the range of "
            "limiting_magnitude_to_sky_brightness",
        ]
        counts = (no_place.any(), no_magnitude.any(), outside.any())
        warnings.warn(
            f"{label}: dropped {int((~keep).sum())} of {keep.size} reports: "
            + "; ".join(note for note, count in zip(notes, counts, strict=True) if count),
            DataQualityWarning,
            stacklevel=4,
        )
    out = reports[keep].reset_index(drop=True)
    out["magnitude"] = limiting_magnitude_to_sky_brightness(limiting[keep]) if keep.any() else []
    out["station"] = np.nan
    out["instrument"] = instrument or "eye"
    out["fov"] = np.nan
    out["pointing_elevation"] = 90.0
    out["pointing_azimuth"] = 0.0
    out["sky_temperature"] = np.nan
    out["ambient_temperature"] = np.nan
    out["source"] = label
    points = gpd.points_from_xy(out["lon"], out["lat"], crs="EPSG:4326")
    return gpd.GeoDataFrame(
        out.drop(columns="limiting_magnitude"), geometry=points, crs="EPSG:4326"
    )


# -- the table ----------------------------------------------------------------------------------


def _check_instruments(names: pd.Series, label: str) -> None:
    unknown = sorted(set(names.dropna().astype(str)) - set(INSTRUMENT_NAMES))
    if unknown or names.isna().any():
        shown = ", ".join(repr(name) for name in unknown) or "a missing name"
        raise InputError(
            f"{label}: unknown instrument {shown}; expected one of {', '.join(INSTRUMENT_NAMES)}"
        )


def _plausible(frame: gpd.GeoDataFrame, label: str) -> gpd.GeoDataFrame:
    _check_instruments(frame["instrument"], label)
    magnitude = frame["magnitude"].to_numpy(dtype=float)
    low, high = MAGNITUDE_RANGE
    good = np.isfinite(magnitude) & (magnitude > low) & (magnitude < high)
    if not good.all():
        shown = ", ".join(f"{value:g}" for value in pd.unique(magnitude[~good])[:3])
        warnings.warn(
            f"{label}: dropped {int((~good).sum())} of {good.size} readings whose magnitude is "
            f"not finite or outside {low:g}-{high:g} mag arcsec-2 ({shown})",
            DataQualityWarning,
            stacklevel=3,
        )
    return frame[good].reset_index(drop=True)


def _assemble(parts: list[gpd.GeoDataFrame], labels: list[str]) -> gpd.GeoDataFrame:
    parts = [part for part in parts if not part.empty]
    if not parts:
        raise EmptyInputError(f"{', '.join(labels)}: no readings left")
    crs = {CRS.from_user_input(part.crs).to_wkt() for part in parts}
    if len(crs) > 1:
        parts = [part.to_crs("EPSG:4326") for part in parts]
    frame = pd.concat(parts, ignore_index=True)
    readings = gpd.GeoDataFrame(frame, geometry="geometry", crs=parts[0].crs)
    readings["station"] = _stations(readings)
    for column, (dtype, _, _) in READING_COLUMNS.items():
        if column != "geometry":
            readings[column] = readings[column].astype(dtype)
    readings = readings[list(READING_COLUMNS)]
    readings = readings.sort_values(["station", "time"], kind="mergesort").reset_index(drop=True)
    readings.attrs["sources"] = list(labels)
    return readings


def _stations(readings: pd.DataFrame) -> pd.Series:
    place = (
        readings["lat"].round(4).map("{:.4f}".format)
        + ","
        + readings["lon"].round(4).map("{:.4f}".format)
    )
    raw = readings["station"]
    text = raw.astype(object).where(raw.notna(), "").astype(str).str.strip()
    named = text.where(text != "")
    station = named.where(named.notna(), readings["instrument"].astype(str) + "@" + place)
    key = readings["instrument"].astype(str) + "@" + place
    spread = key.groupby(station).transform("nunique")
    split = (spread > 1).to_numpy() & named.notna().to_numpy()
    return station.where(~split, station + " " + key).astype(str)
