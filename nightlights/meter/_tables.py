"""Tables of readings: CSV files, vector layers, DataFrames and Globe at Night exports.

The column names a table may use (:data:`ALIASES`), the parsing of its numbers, positions and
times, and the Globe at Night export's own columns ([1]_): ``Latitude``, ``Longitude``,
``LimitingMag`` (-9999 when clouds hid the constellation), ``CloudCover`` and the time, as
``UTDate`` and ``UTTime`` (UTC) or ``ObsDateTime`` (with its UTC offset). Messages name the
file and the line (``points.csv:3``), the feature (``layer.gpkg: feature 2``) or the row of an
in-memory frame (``row 0``).

References
----------
.. [1] Globe at Night (NSF NOIRLab): the yearly data exports.
"""

from __future__ import annotations

import re
import zoneinfo
from collections.abc import Callable
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
from pyproj import CRS
from pyproj.exceptions import CRSError as ProjCRSError

from nightlights.errors import CRSError, InputError

#: Column names of a table (lower case) -> the readings-table column they give.
ALIASES = {
    "lon": ("lon", "longitude", "long", "lng"),
    "lat": ("lat", "latitude"),
    "x": ("x",),
    "y": ("y",),
    "time": ("time", "datetime", "timestamp"),
    "magnitude": ("magnitude", "mag", "msas", "mpsas", "sqm"),
    "instrument": ("instrument",),
    "station": ("station",),
    "fov": ("fov",),
    # not "altitude": in a table of sites that is usually the height above sea level [m]
    "pointing_elevation": ("pointing_elevation", "elevation_angle"),
    "pointing_azimuth": ("pointing_azimuth", "azimuth"),
    "sky_temperature": ("sky_temperature",),
    "ambient_temperature": ("ambient_temperature",),
    "cloud_cover": ("cloud_cover",),
}

#: Globe at Night's ``CloudCover`` codes -> fraction of the sky ([1]_: the answers "clear",
#: "1/4 of sky", "1/2 of sky", "over 1/2 of sky"; -1 is written both for reports marked clear
#: and for ones with no answer, so it is unknown).
GLOBE_AT_NIGHT_CLOUDS = {0.0: 0.0, 25.0: 0.25, 50.0: 0.5, 75.0: 0.75, -1.0: np.nan}
#: Globe at Night's ``LimitingMag`` for "no magnitude" (clouds hid the constellation).
GLOBE_AT_NIGHT_MISSING = -9999.0

_OFFSET = re.compile(r"\d{2}:\d{2}(?::\d{2}(?:\.\d+)?)?\s*(?:Z|[+-]\d{2}(?::?\d{2})?)$")

#: Where a row is, for messages: row index -> "file:line" or "label: row N".
Where = Callable[[int], str]


def globe_at_night_table(
    frame: pd.DataFrame, label: str, where: Where, zone: zoneinfo.ZoneInfo | None
) -> pd.DataFrame:
    """The reports of a Globe at Night export: ``time`` (UTC), ``lon``, ``lat`` [deg],
    ``limiting_magnitude`` [mag] (NaN for -9999), ``cloud_cover`` [1] (NaN when unknown)."""
    table = frame.reset_index(drop=True)
    needed = ["Latitude", "Longitude", "LimitingMag"]
    missing = [name for name in needed if name not in table]
    if missing or not ({"UTDate", "UTTime"} <= set(table) or "ObsDateTime" in table):
        raise InputError(
            f"{label}: not a Globe at Night export: missing {', '.join(missing) or 'the time'}; "
            "expected Latitude, Longitude, LimitingMag and UTDate, UTTime (or ObsDateTime)"
        )
    lat = numbers_of(table["Latitude"], "Latitude", where)
    lon = numbers_of(table["Longitude"], "Longitude", where)
    refuse_missing((lat.isna() | lon.isna()).to_numpy(), label, where)
    limiting = numbers_of(table["LimitingMag"], "LimitingMag", where)
    if "UTDate" in table:
        date = table["UTDate"].fillna("").str.strip()
        stamp = date + "T" + table["UTTime"].fillna("").str.strip()
        times = times_of(stamp.where(stamp != "T", "") + "Z", label, where, zone)
    else:
        times = times_of(table["ObsDateTime"], label, where, zone)
    clouds = (
        clouds_of(numbers_of(table["CloudCover"], "CloudCover", where), where)
        if "CloudCover" in table
        else pd.Series(np.nan, index=table.index)
    )
    return pd.DataFrame(
        {
            "time": times,
            "lon": lon,
            "lat": lat,
            "limiting_magnitude": limiting.where(limiting != GLOBE_AT_NIGHT_MISSING),
            "cloud_cover": clouds.to_numpy(),
        }
    )


def rows_of(label: str, offset: int) -> Where:
    """Rows named by line (``offset`` 2: a CSV under its header line) or by index (0)."""
    return lambda index: f"{label}:{index + offset}" if offset else f"{label}: row {index}"


def features_of(label: str) -> Where:
    """Rows named as the features of a vector layer, counted from 1."""
    return lambda index: f"{label}: feature {index + 1}"


def read_csv(path: Path, label: str) -> pd.DataFrame:
    """A CSV file as text columns (``,`` or ``;`` separated, as its header line shows), after
    any leading ``#`` comment lines; ``attrs["first_line"]`` is the file line of its first row."""
    comments = 0
    with path.open(encoding="utf-8", errors="replace") as handle:
        first = handle.readline()
        while first.lstrip().startswith("#"):
            comments += 1
            first = handle.readline()
    separator = ";" if first.count(";") > first.count(",") else ","
    try:
        frame = pd.read_csv(
            path, sep=separator, dtype=str, skipinitialspace=True, skiprows=comments
        )
        frame.attrs["first_line"] = comments + 2
        return frame
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputError(f"{label}: not a readable table: {' '.join(str(exc).split())}") from exc
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def canonical(frame: pd.DataFrame, label: str) -> pd.DataFrame:
    """Rename the alias columns to the table's names (one column per name)."""
    found: dict[str, str] = {}
    rename: dict[str, str] = {}
    for column in frame.columns:
        if column == getattr(frame, "_geometry_column_name", None):
            continue
        key = str(column).strip().lower()
        for name, aliases in ALIASES.items():
            if key in aliases:
                if name in found:
                    raise InputError(
                        f"{label}: columns {found[name]!r} and {column!r} both give {name}; "
                        "keep one"
                    )
                found[name] = str(column)
                rename[column] = name
    return frame.rename(columns=rename)


def table_readings(
    frame: pd.DataFrame,
    label: str,
    where: Where,
    *,
    zone: zoneinfo.ZoneInfo | None,
    crs: CRS | None,
    instrument: str | None,
) -> gpd.GeoDataFrame:
    """Point readings of a table or layer (columns named as :data:`ALIASES`) as readings."""
    table = canonical(frame.reset_index(drop=True), label)
    points = positions_of(table, label, where, crs)
    for needed in ("time", "magnitude"):
        if needed not in table:
            names = ", ".join(ALIASES[needed])
            raise InputError(f"{label}: no {needed} column; expected one named {names}")
    if instrument is None and "instrument" not in table:
        raise InputError(f"{label}: no instrument column; give instrument=")
    wgs84 = points.to_crs("EPSG:4326")
    out = pd.DataFrame(
        {
            "station": table["station"].astype(object) if "station" in table else np.nan,
            "time": times_of(table["time"], label, where, zone),
            "magnitude": numbers_of(table["magnitude"], "magnitude", where),
            "instrument": instrument if instrument is not None else table["instrument"],
        }
    )
    defaults = {"pointing_elevation": 90.0, "pointing_azimuth": 0.0}
    for column in (
        "fov",
        "pointing_elevation",
        "pointing_azimuth",
        "sky_temperature",
        "ambient_temperature",
    ):
        if column in table:
            out[column] = numbers_of(table[column], column, where).fillna(
                defaults.get(column, np.nan)
            )
        else:
            out[column] = defaults.get(column, np.nan)
    out["lon"] = wgs84.x.to_numpy()
    out["lat"] = wgs84.y.to_numpy()
    out["source"] = label
    out["cloud_cover"] = (
        numbers_of(table["cloud_cover"], "cloud_cover", where) if "cloud_cover" in table else np.nan
    )
    outside = ~(out["cloud_cover"].isna() | out["cloud_cover"].between(0.0, 1.0)).to_numpy()
    if outside.any():
        first = int(np.flatnonzero(outside)[0])
        raise InputError(
            f"{where(first)}: cloud_cover {out['cloud_cover'].iloc[first]:g}; expected a "
            "fraction of the sky, 0 to 1"
        )
    check_pointing(out, where)
    return gpd.GeoDataFrame(out, geometry=points.to_numpy(), crs=points.crs)


def positions_of(table: pd.DataFrame, label: str, where: Where, crs: CRS | None) -> gpd.GeoSeries:
    """The readings' points: a layer's geometry, lon/lat (WGS84) or x/y in ``crs``."""
    if isinstance(table, gpd.GeoDataFrame) and table.geometry.name in table:
        layer_crs = table.crs
        if layer_crs is not None and crs is not None and CRS.from_user_input(layer_crs) != crs:
            raise CRSError(f"{label}: the layer's CRS is {layer_crs.to_string()}; crs= differs")
        if layer_crs is None and crs is None:
            raise CRSError(f"{label}: the layer has no CRS; give crs= (e.g. 'EPSG:4326')")
        geometry = table.geometry.set_crs(layer_crs or crs, allow_override=True)
        missing = (geometry.isna() | geometry.is_empty).to_numpy()
        refuse_missing(missing, label, where)
        kinds = set(geometry.geom_type)
        if kinds != {"Point"}:
            raise InputError(
                f"{label}: {', '.join(sorted(kinds))} geometries; expected points (one per reading)"
            )
        return gpd.GeoSeries(geometry.to_numpy(), crs=geometry.crs)
    if "lon" in table and "lat" in table:
        if crs is not None and not crs.equals(CRS.from_epsg(4326)):
            raise CRSError(f"{label}: lon, lat columns are WGS84 degrees; crs= is for x, y columns")
        x, y, point_crs = table["lon"], table["lat"], CRS.from_epsg(4326)
    elif "x" in table and "y" in table:
        if crs is None:
            raise CRSError(f"{label}: x, y columns without crs=; give their CRS (e.g. 'EPSG:3067')")
        x, y, point_crs = table["x"], table["y"], crs
    else:
        raise InputError(f"{label}: no position; expected lon, lat columns (or x, y with crs=)")
    xs = numbers_of(x, "x" if "x" in table else "lon", where)
    ys = numbers_of(y, "y" if "y" in table else "lat", where)
    refuse_missing((xs.isna() | ys.isna()).to_numpy(), label, where)
    if point_crs.is_geographic and not (xs.abs().le(180).all() and ys.abs().le(90).all()):
        bad = int(np.flatnonzero(~(xs.abs().le(180) & ys.abs().le(90)).to_numpy())[0])
        raise InputError(
            f"{where(bad)}: position ({xs.iloc[bad]:g}, {ys.iloc[bad]:g}) is no longitude, "
            "latitude in degrees"
        )
    return gpd.GeoSeries(gpd.points_from_xy(xs, ys), crs=point_crs)


def refuse_missing(missing: np.ndarray, label: str, where: Where) -> None:
    if missing.any():
        first = int(np.flatnonzero(missing)[0])
        raise InputError(
            f"{where(first)}: a reading without position ({int(missing.sum())} in {label}); "
            "every reading needs one"
        )


def numbers_of(values: pd.Series, name: str, where: Where) -> pd.Series:
    numbers = pd.to_numeric(values, errors="coerce").astype("float64")
    text = values.astype(object)
    words = text.astype(str).str.strip()
    given = values.notna() & (words != "") & ~words.str.lower().isin(("nan", "+nan", "-nan"))
    bad = (numbers.isna() & given).to_numpy()
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(f"{where(first)}: {name} {text.iloc[first]!r} is not a number")
    return numbers.reset_index(drop=True)


def times_of(
    values: pd.Series, label: str, where: Where, zone: zoneinfo.ZoneInfo | None
) -> pd.Series:
    values = values.reset_index(drop=True)
    if isinstance(values.dtype, pd.DatetimeTZDtype):
        return values.dt.tz_convert("UTC")
    if pd.api.types.is_datetime64_dtype(values.dtype):
        return localise(values, label, where, zone)
    text = values.astype(object).where(values.notna(), "").astype(str).str.strip()
    empty = (text == "").to_numpy()
    if empty.any():
        raise InputError(f"{where(int(np.flatnonzero(empty)[0]))}: a reading without time")
    aware = text.str.contains(_OFFSET).to_numpy()
    if aware.any() and not aware.all():
        raise InputError(
            f"{where(int(np.flatnonzero(~aware)[0]))}: time {text[~aware].iloc[0]!r} has no UTC "
            f"offset where others in {label} have one; give all times alike"
        )
    parsed = pd.to_datetime(text, format="ISO8601", errors="coerce", utc=bool(aware.all()))
    bad = parsed.isna().to_numpy()
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{where(first)}: time {text.iloc[first]!r}; expected ISO 8601 "
            "(2024-01-10T21:00:00Z, or a local time with time_zone=)"
        )
    if aware.all():
        return parsed
    return localise(parsed, label, where, zone)


def localise(
    values: pd.Series, label: str, where: Where, zone: zoneinfo.ZoneInfo | None
) -> pd.Series:
    if zone is None:
        raise InputError(
            f"{label}: times without a UTC offset ({values.iloc[0]}); give time_zone= (an IANA "
            "name such as 'Europe/Helsinki', or 'UTC')"
        )
    local = values.dt.tz_localize(zone, ambiguous="NaT", nonexistent="NaT")
    bad = local.isna().to_numpy()
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{where(first)}: local time {values.iloc[first]} is ambiguous or does not exist in "
            f"{zone.key} (a daylight-saving change); give times with a UTC offset"
        )
    return local.dt.tz_convert("UTC")


def check_pointing(frame: pd.DataFrame, where: Where) -> None:
    elevation = frame["pointing_elevation"].to_numpy(dtype=float)
    bad = ~((elevation > 0.0) & (elevation <= 90.0))
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{where(first)}: pointing_elevation {elevation[first]:g} deg; expected above the "
            "horizon, up to 90 (the zenith)"
        )


def zone_of(name: str) -> zoneinfo.ZoneInfo:
    try:
        return zoneinfo.ZoneInfo(str(name))
    except (zoneinfo.ZoneInfoNotFoundError, ValueError, TypeError) as exc:
        raise InputError(
            f"time_zone={name!r}: no such time zone; expected an IANA name such as "
            "'Europe/Helsinki' or 'UTC'"
        ) from exc


def crs_of(value: str | CRS) -> CRS:
    try:
        return CRS.from_user_input(value)
    except ProjCRSError as exc:
        raise CRSError(
            f"crs={value!r} is not a coordinate reference system; expected e.g. 'EPSG:3067'"
        ) from exc


def clouds_of(codes: pd.Series, where: Where) -> pd.Series:
    fractions = codes.map(GLOBE_AT_NIGHT_CLOUDS)
    bad = (fractions.isna() & codes.notna() & (codes != -1.0)).to_numpy()
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{where(first)}: CloudCover {codes.iloc[first]:g}; expected -1, 0, 25, 50 or 75"
        )
    return fractions.astype("float64")
