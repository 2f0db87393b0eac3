"""The IDA / NSBM "Community Standard for Reporting Skyglow Observations" (version 1.0).

A file of the standard [1]_ is ASCII text: a header of lines that begin with ``# `` (one
``# Key: value`` entry per line, comma-separated where an entry holds several values), ended by
a line naming the reading's fields (``# UTC Date & Time, Local Date & Time, Temperature, Counts,
Frequency, MSAS`` for a Sky Quality Meter), a line of their units and ``# END OF HEADER``; then
one reading per line, its fields separated by ``;``. The header entries read here:

- ``Device type`` (``SQM-LE``, ``SQM-LU``, ``SQM``, ``TESS-W``...): the instrument.
- ``Instrument ID`` and ``Location name``: the station's name.
- ``Position`` (written ``Position (lat, lon, elev(m))`` by the Sky Quality Meter programs and
  ``Position`` by the TESS-W network [2]_): latitude, longitude [deg] and elevation [m].
- ``Field of view`` (``Field of view (degrees)``): the first number in it [deg].
- ``Measurement direction per channel``: two numbers, read as azimuth then zenith angle [deg],
  the order in which the TESS-W network writes and reads them [2]_ (``0, 0`` is the zenith
  either way, as the Sky Quality Meter programs write it).
- ``Moving / Stationary position`` and ``Number of channels``: a moving instrument or one of
  several channels is refused (one position per file, one magnitude per line).
- the field line: columns are found by their names, not their places, so that the Sky Quality
  Meter's six fields and the TESS-W's seven or eight (``Enclosure Temperature``, ``Sky
  Temperature``, ``ZP``, ``Sequence Number``) are read alike. ``UTC Date & Time`` is the
  reading's instant (UTC), ``MSAS`` its magnitude [mag arcsec-2], ``Sky Temperature`` the
  TESS-W's infrared sky temperature [degC]; ``Temperature`` / ``Enclosure Temperature`` is the
  instrument's own temperature [degC], the nearest the standard comes to the ambient one.

The header's own ``Number of fields per line`` is not trusted (files of the TESS-W network state
6 over seven named fields [2]_): every reading line must hold as many fields as the field line
names.

References
----------
.. [1] International Dark-Sky Association (2013). Definition of the community standard for
   skyglow observations, version 1.0 (10 April 2013); a supplement to Kyba, C. C. M. &
   Lolkema, D. E. (2012), Astronomy & Geophysics 53(6), doi:10.1111/j.1468-4004.2012.53617.x.
.. [2] The file headers written and read by the TESS-W network's tools (Universidad
   Complutense de Madrid): ``tesstractor`` (``pysqml/IDA-TESS-template.tpl``) and the TESS IDA
   tools' monthly files.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nightlights.errors import InputError

#: First header lines that mark a file of the standard (lower case, matched as prefixes once
#: ``# `` is removed): the standard's own title, the older title the Sky Quality Meter programs
#: write, and the definition line of the TESS-W network's files.
FORMAT_LINES = (
    "community standard skyglow data format",
    "light pollution monitoring data format",
    "definition of the community standard for skyglow observations",
)

#: Field names (lower case, single spaces) -> the readings-table column they fill.
FIELD_COLUMNS = {
    "utc date & time": "time",
    "msas": "magnitude",
    "sky temperature": "sky_temperature",
    "temperature": "ambient_temperature",
    "enclosure temperature": "ambient_temperature",
    "box temperature": "ambient_temperature",
    "ambient temperature": "ambient_temperature",
}

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@dataclass(frozen=True)
class IdaHeader:
    """What a file's header says about its station and instrument.

    Attributes
    ----------
    device_type : str
        The ``Device type`` entry ("" when absent).
    instrument_id : str
        The ``Instrument ID`` entry ("" when absent).
    location_name : str
        The ``Location name`` entry ("" when absent).
    latitude, longitude : float
        Position [deg], WGS84.
    elevation : float
        Elevation [m]; NaN when not stated.
    fov : float
        Field of view [deg]; NaN when not stated.
    pointing_elevation, pointing_azimuth : float
        Where the instrument looks [deg]: elevation above the horizon, azimuth clockwise from
        north (90, 0 when not stated).
    fields : tuple of str
        The reading fields, as the field line names them.
    entries : dict
        Every ``Key: value`` entry of the header.
    """

    device_type: str
    instrument_id: str
    location_name: str
    latitude: float
    longitude: float
    elevation: float
    fov: float
    pointing_elevation: float
    pointing_azimuth: float
    fields: tuple[str, ...]
    entries: dict[str, str] = field(default_factory=dict)


def is_ida(text: str) -> bool:
    """Whether ``text`` starts as a file of the standard (its first line names the format)."""
    for line in text.splitlines():
        if line.strip():
            return _entry_text(line).lower().startswith(FORMAT_LINES)
    return False


def parse_ida(text: str, *, source: str) -> tuple[IdaHeader, pd.DataFrame]:
    """Parse a file of the community standard.

    Parameters
    ----------
    text
        The file's text.
    source
        How messages name the file.

    Returns
    -------
    header : IdaHeader
        The header's station and instrument.
    readings : pandas.DataFrame
        One row per reading line: ``time`` (UTC), ``magnitude`` [mag arcsec-2],
        ``sky_temperature`` and ``ambient_temperature`` [degC] (NaN when the file has no such
        field; a field left empty on a line is NaN too), ``line`` (1-based line number).

    Raises
    ------
    InputError
        A malformed header (no position, an unparsable position, no field line, a field line
        without ``UTC Date & Time`` or ``MSAS``), a moving or multi-channel instrument, a reading
        line with the wrong number of fields, an unreadable time or magnitude: one line naming
        ``source`` and the line number.
    """
    lines = text.splitlines()
    header_end = 0
    while header_end < len(lines) and lines[header_end].lstrip().startswith("#"):
        header_end += 1
    if header_end == 0:
        raise InputError(f"{source}:1: no '#' header; expected the community standard's header")
    entries, fields, position_line = _read_header(lines[:header_end], source)
    header = _header(entries, fields, position_line, source)
    rows, numbers = _split_readings(lines, header_end, len(fields), source)
    return header, _readings_frame(rows, numbers, fields, source)


def _entry_text(line: str) -> str:
    return line.strip().lstrip("#").strip()


def _read_header(
    lines: list[str], source: str
) -> tuple[dict[str, str], tuple[str, ...], tuple[int, str] | None]:
    entries: dict[str, str] = {}
    fields: tuple[str, ...] = ()
    position: tuple[int, str] | None = None
    for number, raw in enumerate(lines, start=1):
        line = _entry_text(raw)
        if ";" in line:  # the units line (YYYY-MM-DDTHH:mm:ss.fff;...)
            continue
        if line.lower().startswith("utc date & time"):
            fields = tuple(" ".join(name.split()) for name in line.split(","))
            continue
        key, colon, value = line.partition(":")
        if not colon:
            continue
        key = " ".join(key.split())
        entries.setdefault(key, value.strip())
        if key.lower().startswith("position") and position is None:
            position = (number, value.strip())
    if not fields:
        raise InputError(
            f"{source}: the header has no field line; expected e.g. '# UTC Date & Time, "
            "Local Date & Time, Temperature, Counts, Frequency, MSAS' before the readings"
        )
    return entries, fields, position


def _entry(entries: dict[str, str], *prefixes: str) -> str:
    for key, value in entries.items():
        if key.lower().startswith(prefixes):
            return value
    return ""


def _header(
    entries: dict[str, str],
    fields: tuple[str, ...],
    position_line: tuple[int, str] | None,
    source: str,
) -> IdaHeader:
    if position_line is None:
        raise InputError(
            f"{source}: the header has no position; expected '# Position (lat, lon, elev(m)): "
            "LAT, LON, ELEV'"
        )
    latitude, longitude, elevation = _position(*position_line, source)
    lower = {name.lower() for name in fields}
    for needed in ("UTC Date & Time", "MSAS"):
        if needed.lower() not in lower:
            raise InputError(
                f"{source}: the field line names {', '.join(fields)}; expected a {needed!r} field"
            )
    moving = _entry(entries, "moving / stationary position").upper()
    if moving.startswith("MOVING"):
        raise InputError(
            f"{source}: 'Moving / Stationary position: {moving}': only stationary instruments "
            "are read (one position per file)"
        )
    channels = _numbers(_entry(entries, "number of channels"))
    if channels and channels[0] > 1:
        raise InputError(
            f"{source}: {channels[0]:g} channels; only single-channel files are read "
            "(one magnitude per reading line)"
        )
    fov_numbers = _numbers(_entry(entries, "field of view"))
    azimuth, zenith_angle = _direction(_entry(entries, "measurement direction"), source)
    return IdaHeader(
        device_type=_entry(entries, "device type"),
        instrument_id=_entry(entries, "instrument id"),
        location_name=_entry(entries, "location name"),
        latitude=latitude,
        longitude=longitude,
        elevation=elevation,
        fov=fov_numbers[0] if fov_numbers else float("nan"),
        pointing_elevation=90.0 - zenith_angle,
        pointing_azimuth=azimuth % 360.0,
        fields=fields,
        entries=entries,
    )


def _direction(text: str, source: str) -> tuple[float, float]:
    """Azimuth and zenith angle [deg] of ``# Measurement direction per channel:`` (zenith when
    not given). Each of the two comma-separated values may be written as a difference
    (``90.0 - 90.0``, as the TESS-W network's files give the zenith angle)."""
    values = [part for part in re.sub(r"\(.*?[a-zA-Z].*?\)", "", text).split(",") if part.strip()]
    parsed = []
    for part in values:
        numbers = _numbers(part.replace(" - ", " -"))
        if not numbers:
            continue
        parsed.append(sum(numbers) if len(numbers) > 1 else numbers[0])
    if not parsed:
        return 0.0, 0.0
    if len(parsed) != 2:
        raise InputError(
            f"{source}: measurement direction {text.strip()!r}; expected 'AZIMUTH, ZENITH "
            "ANGLE' in degrees"
        )
    azimuth, zenith_angle = parsed
    if not 0.0 <= zenith_angle <= 90.0:
        raise InputError(
            f"{source}: measurement direction {text.strip()!r}: zenith angle {zenith_angle:g} "
            "outside 0-90 deg"
        )
    return azimuth, zenith_angle


def _numbers(text: str) -> list[float]:
    return [float(match) for match in _NUMBER.findall(text)]


def _position(number: int, value: str, source: str) -> tuple[float, float, float]:
    parts = [part.strip().strip("()").strip() for part in value.split(",")]
    try:
        numbers = [float(part) for part in parts if part]
    except ValueError:
        numbers = []
    if len(numbers) not in (2, 3) or not all(np.isfinite(numbers)):
        raise InputError(
            f"{source}:{number}: position {value!r} is not 'LAT, LON[, ELEV]' in decimal degrees "
            "and metres"
        )
    latitude, longitude = numbers[0], numbers[1]
    if not -90.0 <= latitude <= 90.0:
        wrong = f"latitude {latitude:g} outside -90..90"
    elif not -180.0 <= longitude <= 180.0:
        wrong = f"longitude {longitude:g} outside -180..180"
    else:
        return latitude, longitude, numbers[2] if len(numbers) == 3 else float("nan")
    raise InputError(
        f"{source}:{number}: position {value!r}: {wrong}; the standard orders it latitude, "
        "longitude, elevation"
    )


def _split_readings(
    lines: list[str], start: int, width: int, source: str
) -> tuple[list[list[str]], list[int]]:
    rows: list[list[str]] = []
    numbers: list[int] = []
    for number in range(start + 1, len(lines) + 1):
        line = lines[number - 1].strip()
        if not line:
            continue
        if line.startswith("#"):
            raise InputError(f"{source}:{number}: a header line among the readings: {line[:60]!r}")
        values = [value.strip() for value in line.split(";")]
        if len(values) != width:
            raise InputError(
                f"{source}:{number}: {len(values)} fields; the field line names {width}"
            )
        rows.append(values)
        numbers.append(number)
    return rows, numbers


def _readings_frame(
    rows: list[list[str]], numbers: list[int], fields: tuple[str, ...], source: str
) -> pd.DataFrame:
    table = pd.DataFrame(rows, columns=range(len(fields)), dtype=object)
    line = np.asarray(numbers, dtype=np.int64)
    out = pd.DataFrame({"line": line})
    columns: dict[str, int] = {}
    for index, name in enumerate(fields):
        column = FIELD_COLUMNS.get(name.lower())
        if column is not None and column not in columns:
            columns[column] = index
    times = table[columns["time"]].astype(str)
    parsed = pd.to_datetime(times, format="ISO8601", errors="coerce", utc=True)
    bad = parsed.isna().to_numpy()
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{source}:{line[first]}: UTC time {times.iloc[first]!r}; expected "
            "YYYY-MM-DDTHH:mm:ss.fff"
        )
    out["time"] = parsed.to_numpy()
    for column in ("magnitude", "sky_temperature", "ambient_temperature"):
        if column not in columns:
            out[column] = np.nan
            continue
        text = table[columns[column]].astype(str)
        values = pd.to_numeric(text.where(text != "", None), errors="coerce")
        written_nan = text.str.strip().str.lower().isin(("nan", "+nan", "-nan"))
        unreadable = (values.isna() & (text != "") & ~written_nan).to_numpy()
        if unreadable.any():
            first = int(np.flatnonzero(unreadable)[0])
            raise InputError(
                f"{source}:{line[first]}: {fields[columns[column]]} {text.iloc[first]!r} is "
                "not a number"
            )
        out[column] = values.astype("float64").to_numpy()
    return out


def format_ida(header: IdaHeader, readings: pd.DataFrame, *, time_zone: str = "UTC") -> str:
    """A file of the standard for one station (the inverse of :func:`parse_ida`).

    Parameters
    ----------
    header
        The station and instrument; ``fields`` is ignored (the file names the fields it
        writes: UTC and local times, temperatures, ``MSAS``).
    readings
        ``time`` (tz-aware), ``magnitude`` [mag arcsec-2], ``ambient_temperature`` and
        ``sky_temperature`` [degC].
    time_zone
        IANA name of the local time written beside UTC.

    Returns
    -------
    str
        The text, lines ended by ``\\r\\n`` as the standard asks.
    """
    sky = bool(np.isfinite(readings["sky_temperature"].to_numpy(dtype=float)).any())
    names = ["UTC Date & Time", "Local Date & Time", "Temperature"]
    names += ["Sky Temperature"] if sky else []
    names += ["MSAS"]
    elevation = "" if np.isnan(header.elevation) else f", {header.elevation:.0f}"
    fov = "" if np.isnan(header.fov) else f"{header.fov:g}"
    lines = [
        "# Community Standard Skyglow Data Format 1.0",
        f"# Device type: {header.device_type}",
        f"# Instrument ID: {header.instrument_id}",
        f"# Location name: {header.location_name}",
        f"# Position (lat, lon, elev(m)): {header.latitude:.6f}, {header.longitude:.6f}"
        + elevation,
        f"# Local timezone: {time_zone}",
        "# Moving / Stationary position: STATIONARY",
        "# Moving / Fixed look direction: FIXED",
        "# Number of channels: 1",
        f"# Measurement direction per channel: {header.pointing_azimuth:g}, "
        f"{90.0 - header.pointing_elevation:g}",
        f"# Field of view (degrees): {fov}",
        f"# Number of fields per line: {len(names)}",
        "# " + ", ".join(names),
        "# "
        + ";".join(["YYYY-MM-DDTHH:mm:ss.fff"] * 2 + ["Celsius"] * (len(names) - 3))
        + ";mag/arcsec^2",
        "# END OF HEADER",
    ]
    utc = pd.DatetimeIndex(readings["time"]).tz_convert("UTC")
    local = utc.tz_convert(time_zone)
    for row, (when, here) in enumerate(zip(utc, local, strict=True)):
        values = [_iso(when), _iso(here), _celsius(readings["ambient_temperature"].iloc[row])]
        if sky:
            values.append(_celsius(readings["sky_temperature"].iloc[row]))
        values.append(f"{float(readings['magnitude'].iloc[row]):.2f}")
        lines.append(";".join(values))
    return "\r\n".join(lines) + "\r\n"


def _iso(when: pd.Timestamp) -> str:
    return when.strftime("%Y-%m-%dT%H:%M:%S.") + f"{when.microsecond // 1000:03d}"


def _celsius(value: float) -> str:
    return "" if not np.isfinite(value) else f"{float(value):.1f}"
