"""Which photometer readings count: astronomical night, no Moon, clear sky, one value a station.

A sky-brightness reading measures the artificial skyglow the model predicts only on a clear,
moonless night with the Sun well below the horizon. Each reading is given the Sun's and the
Moon's elevation and the Moon's illuminated fraction (:func:`sky_conditions`, from the
project's own Meeus ephemerides in :mod:`nightlights.nightsky.moon`), and is kept or rejected
with its reason (:func:`select_readings`):

- ``"sun"``: the Sun's centre at or above :data:`SUN_LIMIT` = -18 deg (geometric elevation):
  the end of astronomical twilight. There Schaefer's (1993) twilight adds 3 % (0.03 mag) to a
  22.0 mag arcsec-2 zenith and less to any brighter one; Patat et al. (2006) measured the V
  twilight at Paranal down to and beyond this depth.
- ``"moon"``: the Moon's centre at or above :data:`MOON_LIMIT` = -10 deg (geometric). Below
  the horizon the Moon still lights the sky as the Sun does in twilight: Schaefer's (1993)
  twilight, ``m = m_source + 32.5 - h - ...`` (one magnitude per degree of depression), with
  the full Moon's V = -12.73 (Krisciunas & Schaefer 1991, Eq. 9) in place of the Sun's -26.74
  puts a full Moon's zenith twilight at 22.3 mag arcsec-2 with the Moon at -0.5 deg (80 % of a
  22.0 sky), 25.8 at -4 deg (3 %), 27.8 at -6 deg (0.5 %) and 31.9 at -10 deg (0.01 %). The
  common "Moon below the horizon" criterion therefore lets moonrise through; -10 deg keeps
  the Moon's share near 1e-4 (0.01 %) of the darkest natural sky at any phase, at the cost of
  at least 40 minutes of night before each moonrise and after each moonset.
- ``"cloud"``: where the reading carries an infrared sky temperature and an ambient
  temperature (the TESS-W photometer's thermopile and its enclosure sensor), a sky-minus-ambient
  difference at or above :data:`CLOUD_LIMIT` = -24 degC. Clouds radiate at their own (near
  ambient) temperature, a clear sky far colder. The bounds are those of the Calar Alto
  Observatory's 8-14 um cloud sensor (CAHA): "mainly clear" below -28, "few or high clouds"
  -28 to -24, "some clouds" -24 to -19, overcast or fog above -14 degC. We found no published
  threshold for the TESS-W itself: -24 keeps the clear and the few-or-high-cloud skies and
  rejects "some clouds" and worse, and ``cloud_limit=`` sets another (the difference depends on
  the humidity and the site, and an enclosure heated against dew reads warmer than the air).
- ``"invalid"``: a magnitude that is not a finite number.

Readings without temperatures (SQM, eye) keep their clouds: the per-station statistic
(:func:`station_values`) is chosen to see through them. Clouds brighten a light-polluted sky
(up to 15 times, Posch et al. 2018; 18 times, Kyba et al. 2015) and darken a pristine one (by
up to 1 mag, Posch et al. 2018; to a third, Jechow et al. 2016), so neither the darkest nor the
brightest readings are the clear sky. A clear sky, however, is steady: its readings pile up
in one narrow peak night after night, while broken clouds spread theirs over a wide range.
The default statistic is therefore the **mode** of the kept readings, the peak of their
histogram: in the year-long SQM series of Posch et al. (2018) the readings of a light-polluted
site gather in two clusters, the clear nights and the overcast ones, and the clear cluster is
the higher peak wherever clear nights are the commoner. Each local night (noon to noon in the
station's mean solar time, ``UTC + lon / 15 h``) weighs the same, so a long winter night does
not outvote a short summer one, and the peak is found on a Gaussian kernel density of
bandwidth :data:`MODE_BANDWIDTH` = 0.05 mag (half the 0.10 mag arcsec-2 precision Unihedron
states for the SQM: narrow enough to separate a clear peak from a cloud state 0.2 mag away,
wide enough to smooth the readings' 0.01 mag steps).
Where overcast nights (which are steady too) outnumber clear ones the mode finds the overcast
level; the spread of the station (the night-weighted, normalised median absolute deviation
about its value) and :func:`plot_statistic` show such a station. Alternatives:

- ``"median"``: the night-weighted median (biased toward the clouds' side by their share);
- ``"darkest_third"``: the mean of the darkest third of the readings, the "significant
  magnitude" m_1/3 of Bará (2016), defined in analogy with the significant wave height
  (biased dark at pristine sites under cloud);
- ``"percentile:P"``: the night-weighted P-th percentile of the magnitudes (P = 90: the
  edge of the darkest tenth); Alarcon et al. (2021) reduced TESS-W series at dark sites to the
  natural sky by percentiles (biased dark under cloud at such sites, as the darkest third).

Speed: the ephemerides are evaluated per distinct position at the whole hours that an
eight-point Lagrange interpolation of the readings' instants needs, not per reading. The sines
of the elevations are interpolated (smooth in time, where the elevations have a cusp as a body
passes near the zenith); the result departs from the direct evaluation by under 5e-5 deg
(tested under 1e-3 deg). A position with fewer distinct instants than nodes is evaluated
directly. The cost follows the hours a position's readings span, about 10 ms a day (0.4 ms an
evaluation of the Sun and the Moon): 10^5 readings of one station every 5 minutes for a year
take 3.7 s, 10^5 readings of ten stations every minute for a week 0.9 s, and 10^5 readings at
10^5 different places (naked-eye surveys), one direct evaluation each, about 55 s.

Length: about 740 lines, because this docstring carries the sourced case for every limit and
statistic (100 lines), and the chart that shows the statistic's choice is drawn from the same
night weighting as the statistic itself.

References
----------
1. Meeus, J. 1998, "Astronomical Algorithms", 2nd ed., Willmann-Bell, ch. 25, 47, 48.
2. Schaefer, B. E. 1993, "Astronomy and the limits of vision", Vistas in Astronomy 36,
   311-361 (the twilight sky brightness; :func:`nightlights.nightsky.schaefer_twilight`).
3. Krisciunas, K. & Schaefer, B. E. 1991, "A model of the brightness of moonlight", PASP 103,
   1033, Eq. 9 (the Moon's V magnitude by phase).
4. Patat, F., Ugolnikov, O. S. & Postylyakov, O. V. 2006, "UBVRI twilight sky brightness at
   ESO-Paranal", A&A 455, 385.
5. Calar Alto Observatory (CAHA), "Cloud sensor information": the sky-minus-ambient
   calibration table of its weather station's cloud sensor.
6. Posch, T., Binder, F. & Puschnig, J. 2018, "Systematic measurements of the night sky
   brightness at 26 locations in Eastern Austria", JQSRT 211, 144.
7. Kyba, C. C. M. et al. 2015, "Worldwide variations in artificial skyglow", Sci. Rep. 5, 8409.
8. Jechow, A. et al. 2016, "Evaluating the summer night sky brightness at a research field
   site on Lake Stechlin in northeastern Germany", JQSRT 181, 24.
9. Bará, S. 2016, "Anthropogenic disruption of the night sky darkness in urban and rural
   areas", R. Soc. Open Sci. 3, 160541.
10. Alarcon, M. R., Serra-Ricart, M., Lemes-Perera, S. & Mallorquín, M. 2021, "Natural night
    sky brightness during solar minimum", AJ 162, 25.
11. Unihedron, SQM user manuals, Specifications: precision 10 % (0.10 mag arcsec-2).
"""

from __future__ import annotations

import math
import re
import warnings
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import geopandas as gpd
import numpy as np
import pandas as pd

from nightlights._typing import FloatArray
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.nightsky.moon import moon_state, sun_position

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "CLOUD_COVER_LIMIT",
    "CLOUD_LIMIT",
    "DEFAULT_STATISTIC",
    "MODE_BANDWIDTH",
    "MOON_LIMIT",
    "REASONS",
    "STATISTICS",
    "SUN_LIMIT",
    "local_night",
    "plot_statistic",
    "select_readings",
    "sky_conditions",
    "station_statistic",
    "station_values",
]

#: Sun elevation at and above which a reading is twilight or day [deg]: the end of astronomical
#: twilight (geometric elevation of the Sun's centre).
SUN_LIMIT = -18.0
#: Moon elevation at and above which a reading is moonlit [deg] (geometric, the centre): a full
#: Moon's twilight (Schaefer 1993 with V = -12.73) is then 1.1e-4 of a 22.0 mag arcsec-2 sky.
MOON_LIMIT = -10.0
#: Sky-minus-ambient infrared temperature above which a reading is cloudy [degC]: the bound
#: between "few or high clouds" and "some clouds" of the Calar Alto cloud sensor (CAHA).
CLOUD_LIMIT = -24.0
#: Reported cloud cover (a naked-eye report's ``cloud_cover``) above which a reading is cloudy
#: [1]: any cloud reported. Globe at Night asks for the cloud cover as clear, a quarter, a
#: half or more of the sky; a one-report station has no night series for its statistic to see
#: through the clouds with, so only clear reports count.
CLOUD_COVER_LIMIT = 0.0
#: Gaussian bandwidth of the kernel density whose peak is the mode [mag arcsec-2]: half the
#: SQM's stated 0.10 mag arcsec-2 precision (Unihedron).
MODE_BANDWIDTH = 0.05
#: The station statistics (``"percentile:P"`` with 0 < P < 100 stands for every percentile).
STATISTICS: tuple[str, ...] = ("mode", "median", "darkest_third", "percentile:P")
#: The statistic :func:`station_values` uses unless told otherwise.
DEFAULT_STATISTIC = "mode"
#: The reasons a reading is rejected, in the order they are tested ("" when kept).
REASONS: tuple[str, ...] = ("invalid", "sun", "moon", "cloud")

#: Spacing of the ephemeris nodes [ns]: one hour.
_NODE_STEP_NS = 3_600_000_000_000
#: Offsets of the eight Lagrange nodes around an instant, in steps from the node at or before it
#: (six nodes leave errors up to 3e-3 deg at 20 deg latitude, eight under 5e-5 deg).
_NODE_OFFSETS = np.arange(-3, 5)
#: Normal-consistent scale of the median absolute deviation.
_MAD_SCALE = 1.4826
#: Reach of the kernel density's grid around the weighted median [mag arcsec-2]: 10 mag is a
#: factor 10^4 in luminance, beyond any sky state of one station.
_MODE_REACH = 10.0
#: Grid step of the binned kernel density [mag arcsec-2].
_DENSITY_STEP = 0.005
_NS_PER_HOUR = 3_600_000_000_000
_NS_PER_DAY = 24 * _NS_PER_HOUR
_PERCENTILE = re.compile(r"^percentile:(\d+(?:\.\d*)?)$")


# --- the Sun and the Moon per reading ---------------------------------------------------------


def _utc_nanoseconds(readings: pd.DataFrame) -> np.ndarray:
    """The ``time`` column as int64 ns since 1970 UTC, refusing missing, naive or bad times."""
    if "time" not in readings.columns:
        raise InputError(
            "readings have no 'time' column; expected UTC instants (datetime64[ns, UTC])"
        )
    times = readings["time"]
    if not isinstance(times.dtype, pd.DatetimeTZDtype):
        if pd.api.types.is_datetime64_any_dtype(times.dtype):
            raise InputError(
                "readings: column 'time' has no time zone (naive); expected UTC instants "
                "(datetime64[ns, UTC])"
            )
        raise InputError(
            f"readings: column 'time' is {times.dtype}, not a time; expected UTC instants "
            "(datetime64[ns, UTC])"
        )
    missing = int(times.isna().sum())
    if missing:
        raise InputError(
            f"readings: {missing} of {len(times)} rows have no time (NaT); expected a UTC instant "
            "on every reading"
        )
    return np.asarray(times.dt.tz_convert("UTC").dt.as_unit("ns").astype("int64"), dtype=np.int64)


def _positions(readings: pd.DataFrame) -> tuple[FloatArray, FloatArray]:
    """The ``lon`` and ``lat`` columns, refusing missing or out-of-range positions."""
    absent = [name for name in ("lon", "lat") if name not in readings.columns]
    if absent:
        raise InputError(
            f"readings have no {' or '.join(repr(a) for a in absent)} column; expected the "
            "WGS84 position of every reading [deg]"
        )
    lon = np.asarray(readings["lon"], dtype=float)
    lat = np.asarray(readings["lat"], dtype=float)
    bad = ~(np.isfinite(lon) & np.isfinite(lat) & (np.abs(lon) <= 360.0) & (np.abs(lat) <= 90.0))
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"readings: {int(bad.sum())} of {bad.size} rows have no usable position (the first: "
            f"row {first}, lon={float(lon[first])!r}, lat={float(lat[first])!r}); expected WGS84 "
            "longitude and latitude in degrees on every reading"
        )
    return lon, lat


def _direct(times_ns: np.ndarray, lon: float, lat: float) -> FloatArray:
    """Sun elevation, Moon elevation, Moon illuminated fraction at each instant: ``(3, n)``."""
    out = np.empty((3, times_ns.size))
    for i, t in enumerate(times_ns):
        instant = np.datetime64(int(t), "ns")
        out[0, i] = sun_position(instant, lon, lat)[1]
        moon = moon_state(instant, lon, lat, refraction=False)
        out[1, i] = moon.elevation
        out[2, i] = moon.illuminated_fraction
    return out


def _lagrange_weights(fraction: FloatArray) -> FloatArray:
    """Weights ``(n, 8)`` of the nodes at :data:`_NODE_OFFSETS` for ``fraction`` in [0, 1)."""
    weights = np.ones((fraction.size, _NODE_OFFSETS.size))
    for j, node in enumerate(_NODE_OFFSETS):
        for other in _NODE_OFFSETS:
            if other != node:
                weights[:, j] *= (fraction - other) / (node - other)
    return weights


def _ephemerides(times_ns: np.ndarray, lon: float, lat: float) -> FloatArray:
    """``(3, n)`` Sun elevation, Moon elevation and illumination at one place, interpolated.

    Eight-point Lagrange interpolation of the sines of the elevations (and of the fraction)
    between whole hours of the direct evaluation; the direct evaluation itself where that needs
    no more calls than the distinct instants.
    """
    unique, inverse = np.unique(times_ns, return_inverse=True)
    base = np.floor_divide(unique, _NODE_STEP_NS)
    nodes = np.unique(base[:, None] + _NODE_OFFSETS[None, :])
    if nodes.size >= unique.size:
        values = _direct(unique, lon, lat)
    else:
        at_nodes = _direct(nodes * _NODE_STEP_NS, lon, lat)
        # the sines of the elevations are smooth (a sinusoid in hour angle); the elevations
        # themselves have a cusp where a body passes near the zenith
        at_nodes[:2] = np.sin(np.radians(at_nodes[:2]))
        fraction = (unique - base * _NODE_STEP_NS) / _NODE_STEP_NS
        index = np.searchsorted(nodes, base[:, None] + _NODE_OFFSETS[None, :])
        weights = _lagrange_weights(fraction)
        values = np.einsum("kij,ij->ki", at_nodes[:, index], weights)
        values[:2] = np.degrees(np.arcsin(np.clip(values[:2], -1.0, 1.0)))
        values[2] = np.clip(values[2], 0.0, 1.0)
    return np.asarray(values[:, inverse], dtype=float)


def sky_conditions(readings: pd.DataFrame) -> gpd.GeoDataFrame:
    """The Sun's and the Moon's elevation and the Moon's phase at every reading.

    Parameters
    ----------
    readings : geopandas.GeoDataFrame
        The readings table (:mod:`nightlights.meter.readings`); needs ``time`` (UTC, tz-aware),
        ``lon`` and ``lat`` [deg].

    Returns
    -------
    geopandas.GeoDataFrame
        A copy with ``sun_elevation`` and ``moon_elevation`` (geometric elevation of the
        centres, topocentric for the Moon [deg]) and ``moon_illumination`` (illuminated
        fraction of the disc [1]). Empty readings give an empty table with these columns.

    Raises
    ------
    InputError
        A reading without a time (or with a naive one) or without a position.

    References
    ----------
    Meeus 1998, ch. 25 (Sun), 47 and 40 (the Moon, topocentric), 48 (phase); within 0.02 deg of
    PyEphem (tested).

    Examples
    --------
    >>> import pandas as pd, geopandas as gpd
    >>> table = gpd.GeoDataFrame(
    ...     {"time": pd.to_datetime(["2024-01-25T23:00:00Z"]), "lon": [24.94], "lat": [60.17]})
    >>> row = sky_conditions(table).iloc[0]
    >>> bool(row.sun_elevation < -18), bool(row.moon_elevation > 30)
    (True, True)
    >>> round(float(row.moon_illumination), 2)  # full Moon
    1.0
    """
    table = gpd.GeoDataFrame(readings.copy())
    sun = np.full(len(table), np.nan)
    moon = np.full(len(table), np.nan)
    lit = np.full(len(table), np.nan)
    if len(table):
        times = _utc_nanoseconds(table)
        lon, lat = _positions(table)
        places = pd.DataFrame({"lon": lon, "lat": lat})
        for (x, y), rows in places.groupby(["lon", "lat"], sort=False).indices.items():
            values = _ephemerides(times[rows], float(x), float(y))
            sun[rows], moon[rows], lit[rows] = values
    table["sun_elevation"] = sun
    table["moon_elevation"] = moon
    table["moon_illumination"] = lit
    return table


# --- which readings count ---------------------------------------------------------------------


def _limit(name: str, value: float, low: float, high: float, unit: str) -> float:
    """A finite limit within [low, high], or InputError naming the parameter."""
    number = float(value)
    if not (math.isfinite(number) and low <= number <= high):
        raise InputError(f"{name}={value!r}; expected a finite value in [{low:g}, {high:g}] {unit}")
    return number


def _column(table: pd.DataFrame, name: str) -> FloatArray:
    """A float column, all NaN when the table lacks it."""
    if name not in table.columns:
        return np.full(len(table), np.nan)
    return np.asarray(pd.to_numeric(table[name], errors="coerce"), dtype=float)


def select_readings(
    readings: pd.DataFrame,
    *,
    sun_limit: float = SUN_LIMIT,
    moon_limit: float = MOON_LIMIT,
    cloud_limit: float = CLOUD_LIMIT,
    cloud_cover_limit: float = CLOUD_COVER_LIMIT,
) -> gpd.GeoDataFrame:
    """Mark the readings taken in astronomical night, without the Moon, under a clear sky.

    Parameters
    ----------
    readings : geopandas.GeoDataFrame
        The readings table; :func:`sky_conditions` is applied first when it lacks
        ``sun_elevation``.
    sun_limit : float, optional
        The Sun must be below this geometric elevation [deg].
    moon_limit : float, optional
        The Moon must be below this geometric elevation [deg].
    cloud_limit : float, optional
        Where ``sky_temperature`` and ``ambient_temperature`` are both given, their difference
        must be below this [degC]; readings without them are not tested for clouds.
    cloud_cover_limit : float, optional
        Where a ``cloud_cover`` is reported (naked-eye reports), it must not exceed this [1].

    Returns
    -------
    geopandas.GeoDataFrame
        A copy with ``kept`` (bool) and ``reason`` (str: ``""`` when kept, else the first
        failed test of ``"invalid"``, ``"sun"``, ``"moon"``, ``"cloud"``).

    Raises
    ------
    InputError
        A limit that is not a finite angle or temperature; readings without a time or position.

    Examples
    --------
    >>> import pandas as pd, geopandas as gpd
    >>> table = gpd.GeoDataFrame({
    ...     "station": ["a", "a"], "magnitude": [21.0, 21.0],
    ...     "time": pd.to_datetime(["2024-01-11T23:00:00Z", "2024-01-11T23:00:00Z"]),
    ...     "lon": [24.94, 24.94], "lat": [60.17, 60.17],
    ...     "sky_temperature": [-30.0, -3.0], "ambient_temperature": [0.0, 0.0]})
    >>> select_readings(table)[["kept", "reason"]].values.tolist()  # new Moon, midnight
    [[True, ''], [False, 'cloud']]
    """
    sun_limit = _limit("sun_limit", sun_limit, -90.0, 90.0, "deg")
    moon_limit = _limit("moon_limit", moon_limit, -90.0, 90.0, "deg")
    cloud_limit = _limit("cloud_limit", cloud_limit, -100.0, 100.0, "degC")
    cloud_cover_limit = _limit("cloud_cover_limit", cloud_cover_limit, 0.0, 1.0, "")
    table = readings if "sun_elevation" in readings.columns else sky_conditions(readings)
    table = gpd.GeoDataFrame(table.copy())
    if "magnitude" not in table.columns:
        raise InputError("readings have no 'magnitude' column; expected the reading [mag arcsec-2]")
    magnitude = _column(table, "magnitude")
    cloud_index = _column(table, "sky_temperature") - _column(table, "ambient_temperature")
    cover = _column(table, "cloud_cover")
    failed = {
        "invalid": ~np.isfinite(magnitude),
        "sun": ~(_column(table, "sun_elevation") < sun_limit),
        "moon": ~(_column(table, "moon_elevation") < moon_limit),
        "cloud": (np.isfinite(cloud_index) & ~(cloud_index < cloud_limit))
        | (np.isfinite(cover) & (cover > cloud_cover_limit)),
    }
    reason = np.full(len(table), "", dtype=object)
    for name in reversed(REASONS):  # the first failed test in REASONS' order wins
        reason[failed[name]] = name
    table["kept"] = reason == ""
    table["reason"] = reason.astype(str)
    return table


# --- one value a station ----------------------------------------------------------------------


def local_night(time: pd.Series | pd.DatetimeIndex, lon: Any) -> np.ndarray:
    """The local night of each instant: days since 1970 of the evening it began.

    A night runs from noon to noon in local mean solar time, ``UTC + lon / 15 h``.

    Parameters
    ----------
    time : pandas.Series or pandas.DatetimeIndex
        UTC instants (tz-aware).
    lon : float or array_like
        Longitude, positive east [deg].

    Returns
    -------
    numpy.ndarray
        int64 day numbers: the readings of one night share one.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.Series(pd.to_datetime(["2024-03-01T20:00Z", "2024-03-02T03:00Z",
    ...                               "2024-03-02T13:00Z"]))
    >>> local_night(t, 0.0).tolist()
    [19783, 19783, 19784]
    >>> local_night(t, 150.0).tolist()  # 10 h ahead of UTC: 06:00, 13:00 and 23:00 local
    [19783, 19784, 19784]
    """
    utc = pd.Series(time).dt.tz_convert("UTC").dt.as_unit("ns").astype("int64").to_numpy()
    offset = np.rint(np.asarray(lon, dtype=float) / 15.0 * _NS_PER_HOUR).astype(np.int64)
    return np.floor_divide(utc + offset - 12 * _NS_PER_HOUR, _NS_PER_DAY)


def _parse_statistic(statistic: str) -> tuple[str, float]:
    """(kind, percentile) of a statistic name, or InputError naming the choices."""
    if statistic in ("mode", "median", "darkest_third"):
        return statistic, math.nan
    match = _PERCENTILE.match(str(statistic))
    if match and 0.0 < float(match.group(1)) < 100.0:
        return "percentile", float(match.group(1))
    raise InputError(
        f"statistic={statistic!r}; expected one of 'mode', 'median', 'darkest_third' or "
        "'percentile:P' with 0 < P < 100 (e.g. 'percentile:90')"
    )


def _night_weights(night: Any) -> FloatArray:
    """1 / (readings of its night) for every reading: each night weighs 1 in all."""
    _, label, per_night = np.unique(np.asarray(night), return_inverse=True, return_counts=True)
    return np.asarray(1.0 / per_night[label], dtype=float)


def _weighted_quantile(values: FloatArray, weights: FloatArray, q: float) -> float:
    """The q-quantile (0-1) of weighted values, midpoints of the cumulative weights."""
    order = np.argsort(values, kind="stable")
    x, w = values[order], weights[order]
    cumulative = (np.cumsum(w) - w / 2.0) / w.sum()
    return float(np.interp(q, cumulative, x))


def _weighted_mode(values: FloatArray, weights: FloatArray, bandwidth: float) -> float:
    """Peak of the weighted Gaussian kernel density (binned on a fine grid, then refined).

    Readings more than :data:`_MODE_REACH` from the weighted median are left out of the grid:
    they cannot hold the peak, and a wild value would make the grid huge.
    """
    centre = _weighted_quantile(values, weights, 0.5)
    near = np.abs(values - centre) <= _MODE_REACH
    values, weights = values[near], weights[near]
    if values.size == 1 or np.ptp(values) == 0.0:
        return float(values[0])
    start = values.min() - 4.0 * bandwidth
    n = int(np.ceil((values.max() + 4.0 * bandwidth - start) / _DENSITY_STEP)) + 1
    counts = np.bincount(
        np.rint((values - start) / _DENSITY_STEP).astype(int), weights=weights, minlength=n
    )
    half = int(np.ceil(4.0 * bandwidth / _DENSITY_STEP))
    offsets = np.arange(-half, half + 1) * _DENSITY_STEP
    density = np.convolve(counts, np.exp(-0.5 * (offsets / bandwidth) ** 2), mode="same")
    peak = int(np.argmax(density))
    shift = 0.0
    if 0 < peak < density.size - 1:  # parabola through the peak and its neighbours
        left, centre, right = density[peak - 1 : peak + 2]
        curvature = left - 2.0 * centre + right
        if curvature < 0.0:
            shift = 0.5 * (left - right) / curvature
    return float(start + (peak + shift) * _DENSITY_STEP)


def station_statistic(
    magnitude: FloatArray, night: np.ndarray, *, statistic: str = DEFAULT_STATISTIC
) -> tuple[float, float]:
    """One station's value and spread from its kept readings, every night weighing the same.

    Parameters
    ----------
    magnitude : array_like
        The kept readings [mag arcsec-2].
    night : array_like
        Their local nights (:func:`local_night`), any labels.
    statistic : str, optional
        ``"mode"``, ``"median"``, ``"darkest_third"`` or ``"percentile:P"`` (see the module).

    Returns
    -------
    value, spread : float
        The statistic and the normalised median absolute deviation about it
        (1.4826 MAD, night-weighted) [mag arcsec-2].

    Examples
    --------
    >>> m = np.r_[np.full(50, 20.0), np.linspace(17.0, 19.5, 30)]  # clear + cloud-brightened
    >>> value, spread = station_statistic(m, np.zeros(m.size, int))
    >>> round(value, 2), round(station_statistic(m, np.zeros(80, int), statistic="median")[0], 2)
    (20.0, 20.0)
    """
    kind, percentile = _parse_statistic(statistic)
    values = np.asarray(magnitude, dtype=float)
    if values.size == 0:
        raise EmptyInputError("no readings to reduce; expected at least one kept reading")
    weights = _night_weights(night)
    if kind == "mode":
        value = _weighted_mode(values, weights, MODE_BANDWIDTH)
    elif kind == "median":
        value = _weighted_quantile(values, weights, 0.5)
    elif kind == "percentile":
        value = _weighted_quantile(values, weights, percentile / 100.0)
    else:  # darkest_third: mean of the upper third of the magnitudes (Bará 2016)
        upper = values >= _weighted_quantile(values, weights, 2.0 / 3.0)
        value = float(np.average(values[upper], weights=weights[upper]))
    spread = _MAD_SCALE * _weighted_quantile(np.abs(values - value), weights, 0.5)
    return value, spread


def _station_reasons(reasons: pd.Series) -> str:
    """'N sun, M moon, ...' for the rejected readings, most frequent first."""
    counts = Counter(r for r in reasons if r)
    return ", ".join(f"{n} {name}" for name, n in counts.most_common())


def _first(group: pd.DataFrame, name: str, default: Any) -> Any:
    """The column's first value in the group, or the default when the table lacks it."""
    return group[name].iloc[0] if name in group.columns else default


def station_values(
    readings: pd.DataFrame, *, statistic: str = DEFAULT_STATISTIC
) -> gpd.GeoDataFrame:
    """One clear, moonless, astronomical-night value per station.

    Parameters
    ----------
    readings : geopandas.GeoDataFrame
        The readings table; :func:`select_readings` (with its default limits) is applied first
        when it lacks ``kept``.
    statistic : str, optional
        ``"mode"`` (default, :data:`DEFAULT_STATISTIC`), ``"median"``, ``"darkest_third"`` or
        ``"percentile:P"``; see the module for what each does with clouds.

    Returns
    -------
    geopandas.GeoDataFrame
        One row per station with a kept reading, in the readings' CRS: ``station``,
        ``instrument``, ``lon``, ``lat`` [deg], ``magnitude`` (the statistic) and ``spread``
        [mag arcsec-2], ``n_readings`` and ``n_nights`` (kept), ``statistic`` (its name),
        ``time`` (the kept reading nearest the value: a representative UTC instant),
        ``pointing_elevation``, ``pointing_azimuth``, ``fov`` [deg], ``geometry``.

    Raises
    ------
    InputError
        An unknown statistic; a station whose readings name several instruments.
    EmptyInputError
        No station keeps a reading (the message counts the reasons).

    Warns
    -----
    DataQualityWarning
        A station none of whose readings count (named, with its reasons); it is left out.
    """
    _parse_statistic(statistic)
    table = readings if "kept" in readings.columns else select_readings(readings)
    if "reason" not in table.columns:  # a selection made elsewhere: kept or not, no reason
        table = table.assign(reason=np.where(table["kept"].astype(bool), "", "invalid"))
    if "station" not in table.columns:
        raise InputError("readings have no 'station' column; expected a station id per reading")
    if table["station"].isna().any():
        raise InputError(
            f"readings: {int(table['station'].isna().sum())} without a station id; expected one "
            "on every reading"
        )
    if not len(table):
        raise EmptyInputError("no readings; expected at least one clear moonless reading")
    rows: list[dict[str, Any]] = []
    geometries = []
    for station, group in table.groupby("station", sort=True):
        instruments = sorted({str(v) for v in group.get("instrument", pd.Series(["?"]))})
        if len(instruments) > 1:
            raise InputError(
                f"station {station!r}: readings of {len(instruments)} instruments "
                f"({', '.join(instruments)}); expected one instrument per station"
            )
        kept = group[group["kept"].to_numpy(bool)]
        if kept.empty:
            warnings.warn(
                f"station {station!r}: none of its {len(group)} readings count "
                f"({_station_reasons(group['reason'])}); left out",
                DataQualityWarning,
                stacklevel=2,
            )
            continue
        magnitude = kept["magnitude"].to_numpy(float)
        night = local_night(kept["time"], kept["lon"])
        value, spread = station_statistic(magnitude, night, statistic=statistic)
        nearest = int(np.argmin(np.abs(magnitude - value)))
        rows.append(
            {
                "station": str(station),
                "instrument": instruments[0],
                "lon": float(kept["lon"].iloc[0]),
                "lat": float(kept["lat"].iloc[0]),
                "magnitude": value,
                "n_readings": len(kept),
                "n_nights": len(np.unique(night)),
                "spread": spread,
                "statistic": str(statistic),
                "time": kept["time"].iloc[nearest],
                "pointing_elevation": float(_first(kept, "pointing_elevation", 90.0)),
                "pointing_azimuth": float(_first(kept, "pointing_azimuth", 0.0)),
                "fov": float(_first(kept, "fov", np.nan)),
            }
        )
        geometries.append(_first(kept, "geometry", None))
    if not rows:
        counts = Counter(str(r) for r in table["reason"])
        extra = f", {counts['invalid']} invalid" if counts["invalid"] else ""
        raise EmptyInputError(
            "no clear moonless astronomical-night readings: "
            f"{counts['sun']} sun, {counts['moon']} moon, {counts['cloud']} cloud{extra}"
        )
    crs = table.crs if isinstance(table, gpd.GeoDataFrame) and "geometry" in table else None
    if any(g is None for g in geometries):
        geometries = list(gpd.points_from_xy([r["lon"] for r in rows], [r["lat"] for r in rows]))
        crs = "EPSG:4326"
    return gpd.GeoDataFrame(rows, geometry=geometries, crs=crs)


# --- the choice, charted ----------------------------------------------------------------------

#: Colours of the rejected readings by reason, and of the kept ones (drawn last, on top).
_REASON_COLOURS = {
    "sun": "gold",
    "moon": "tab:blue",
    "cloud": "tab:grey",
    "invalid": "tab:red",
    "": "black",
}
#: Bin width of the chart's histogram [mag arcsec-2].
_HISTOGRAM_BIN = 0.05


def plot_statistic(
    readings: pd.DataFrame,
    station: str,
    *,
    statistic: str = DEFAULT_STATISTIC,
    axes: Sequence[Axes] | None = None,
) -> Figure:
    """Chart one station's readings and its statistic: the series and the histogram.

    Left: every reading against its UTC time, coloured by why it was rejected (black: kept);
    right: the night-weighted histogram of the kept readings. The statistic is the horizontal /
    vertical line, and the other statistics are marked for comparison.

    Parameters
    ----------
    readings : geopandas.GeoDataFrame
        The readings table (selected or not; :func:`select_readings` is applied if needed).
    station : str
        The station to chart.
    statistic : str, optional
        The station statistic drawn as the choice.
    axes : pair of matplotlib.axes.Axes, optional
        Where to draw (time series, histogram); None: a new figure with both.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (not shown, no pyplot state touched).

    Raises
    ------
    InputError
        An unknown statistic or a station that is not in the readings.
    """
    _parse_statistic(statistic)
    table = readings if "kept" in readings.columns else select_readings(readings)
    group = table[table["station"].astype(str) == str(station)]
    if group.empty:
        known = sorted({str(s) for s in table["station"]})
        raise InputError(f"station={station!r}; expected one of {', '.join(map(repr, known))}")
    from matplotlib.dates import AutoDateLocator, ConciseDateFormatter
    from matplotlib.figure import Figure

    if axes is None:
        figure = Figure(figsize=(11, 3.6), layout="constrained")
        series_ax, hist_ax = figure.subplots(1, 2, width_ratios=(2.2, 1))
    else:
        series_ax, hist_ax = axes
        root = series_ax.get_figure(root=True)
        if not isinstance(root, Figure):
            raise InputError("axes: the time-series Axes belongs to no figure; expected two Axes")
        figure = root
    times = group["time"].dt.tz_convert("UTC").dt.tz_localize(None).to_numpy()
    magnitude = group["magnitude"].to_numpy(float)
    reason = group["reason"].astype(str).to_numpy()
    for name, colour in _REASON_COLOURS.items():
        chosen = reason == name
        if chosen.any():
            label = f"kept ({chosen.sum()})" if not name else f"{name} ({chosen.sum()})"
            series_ax.plot(times[chosen], magnitude[chosen], ".", ms=2, color=colour, label=label)
    kept = group["kept"].to_numpy(bool)
    locator = AutoDateLocator()
    series_ax.xaxis.set_major_locator(locator)
    series_ax.xaxis.set_major_formatter(ConciseDateFormatter(locator))
    series_ax.set_xlabel("time [UTC]")
    series_ax.set_ylabel("sky brightness [mag arcsec-2]")
    series_ax.legend(loc="best", fontsize="small", markerscale=4)
    if kept.any():
        night = local_night(group["time"][kept], group["lon"][kept])
        low, high = float(magnitude[kept].min()), float(magnitude[kept].max())
        bins = max(1, min(400, math.ceil((high - low) / _HISTOGRAM_BIN)))
        hist_ax.hist(magnitude[kept], bins=bins, weights=_night_weights(night), color="0.6")
        names = dict.fromkeys(("mode", "median", "darkest_third", "percentile:90", statistic))
        marks = {
            name: station_statistic(magnitude[kept], night, statistic=name)[0] for name in names
        }
        for name, value in marks.items():
            chosen = name == statistic
            style = {"color": "tab:red" if chosen else "0.3", "lw": 2.0 if chosen else 0.8}
            hist_ax.axvline(value, ls="-" if chosen else ":", label=f"{name} {value:.2f}", **style)
            if chosen:
                series_ax.axhline(value, **style)
        hist_ax.legend(loc="best", fontsize="small")
    hist_ax.set_xlabel("kept readings [mag arcsec-2]")
    hist_ax.set_ylabel("nights")
    figure.suptitle(f"station {station}: {statistic} of the clear moonless readings")
    return figure
