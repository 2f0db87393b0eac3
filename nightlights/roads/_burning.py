"""Burning hours of a photocell-switched installation: when the Sun crosses a switch elevation.

A photocell switches the lights on when the daylight falls below its threshold and off when it
rises above it again. The threshold is modelled as an elevation of the Sun's centre,
:data:`SWITCH_ELEVATION` (sunset and sunrise) unless the user gives another (civil twilight,
:data:`CIVIL_TWILIGHT`, or a measured photocell's equivalent); weather, shading and the
photocell's own hysteresis and delay are not modelled. The lights burn while

.. math:: h_\\odot(t) < h_0,

with :math:`h_\\odot` the geometric (unrefracted) elevation of the Sun's centre, so the
refraction at the horizon and the Sun's semidiameter are carried by :math:`h_0` itself
(Meeus 1998, ch. 15).

The Sun: Meeus (1998) ch. 25 at low accuracy (0.01 deg): the true longitude of Eqs. 25.2-25.4,
the apparent longitude (aberration and the main nutation term) and the obliquity of Eq. 25.8,
right ascension and declination of Eqs. 25.6-25.7, the mean sidereal time of Eq. 12.4 and the
horizontal frame of Eq. 13.6; 0.01 deg of elevation is 2-6 s of switching time. It repeats
the scalar ephemeris of :mod:`nightlights.nightsky` as array functions here (road lighting
stands on a floor below the night sky, and a year is 5 10^4 instants).

The crossings: the elevation is sampled every ``step_minutes`` over the year, each sample
interval whose ends straddle :math:`h_0` is bisected to a microsecond, and each sampled local
extremum that stays on one side is refined by the vertex of its parabola through three samples
and, where that vertex lies on the other side, bisected on both flanks: a graze of the switch
elevation shorter than a step (the days at the edge of the polar day or night) is found as
well. The intervals are clipped to the UTC year; a polar night is one interval of many days, a
polar day none.

References
----------
1. Meeus, J. 1998, "Astronomical Algorithms", 2nd ed., Willmann-Bell: ch. 7 (Julian date),
   12 (sidereal time), 13 (horizontal coordinates), 15 (rising and setting, the standard
   altitude -0 deg 50' of the Sun), 25 (the Sun's position).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "CIVIL_TWILIGHT",
    "SWITCH_ELEVATION",
    "BurningIntervals",
    "annual_burning_hours",
    "burning_intervals",
    "sun_elevation",
]

#: Elevation of the Sun's centre at sunrise and sunset [deg]: -0 deg 50', the 34' of refraction
#: at the horizon and the 16' semidiameter (Meeus 1998, ch. 15, the standard altitude h0).
SWITCH_ELEVATION = -50.0 / 60.0
#: Elevation of the Sun's centre at the end of civil twilight [deg] (Meeus 1998, ch. 15).
CIVIL_TWILIGHT = -6.0
#: Sampling step of the elevation [min]: crossings are bisected and grazes refined, so the step
#: sets only the speed (``benchmarks/bench_road_burning.py``: every step from 1 to 60 min gives
#: the burning hours of a year within 3 ms of a 0.25 min step at 13 latitudes, seven around the
#: polar circle; a year at 10 min takes a few hundredths of a second).
STEP_MINUTES = 10.0
#: Bisection halvings of a sample interval: 600 s / 2**30 is under a microsecond.
_BISECTIONS = 30
#: Julian date of the Unix epoch, 1970 January 1.0 UTC [d] (Meeus 1998, ch. 7).
_UNIX_EPOCH_JD = 2440587.5
#: Julian date of J2000.0 [d] (Meeus 1998, ch. 21).
_J2000 = 2451545.0
#: TT - UT [s], about its 2020 value (IERS Bulletin A); it moves the Sun by 0.0008 deg per
#: minute of error, a second of switching time.
_DELTA_T_S = 69.0
#: The years the low-accuracy Sun and the fixed Delta T are used for.
_YEARS = (1900, 2100)
#: Allowed switch elevations [deg]: astronomical twilight to a Sun well above the horizon.
_SWITCH_RANGE = (-18.0, 10.0)


@dataclass(frozen=True, eq=False)
class BurningIntervals:
    """When a photocell-switched installation burns over one UTC year.

    Attributes
    ----------
    on, off : numpy.ndarray of datetime64[ms]
        Switch-on and switch-off instants, UTC, one pair per burning interval (one per night;
        a polar night is one interval of many days), clipped to the year.
    longitude, latitude : float
        Location [deg], longitude positive east.
    year : int
        The UTC year.
    switch_elevation : float
        Elevation of the Sun's centre at which the lights switch [deg].
    """

    on: NDArray[np.datetime64]
    off: NDArray[np.datetime64]
    longitude: float
    latitude: float
    year: int
    switch_elevation: float

    @property
    def hours(self) -> FloatArray:
        """Duration of each interval [h]."""
        return _seconds(self.off) / 3600.0 - _seconds(self.on) / 3600.0

    @property
    def total_hours(self) -> float:
        """Burning hours of the year [h]."""
        return float(np.sum(self.hours))


def _seconds(instants: NDArray[np.datetime64]) -> FloatArray:
    """Seconds since the Unix epoch of UTC instants."""
    return np.asarray(instants, dtype="datetime64[us]").astype(np.int64) / 1e6


def _elevation(unix_seconds: FloatArray, longitude: float, latitude: float) -> FloatArray:
    """Geometric elevation of the Sun's centre [deg] at instants in Unix seconds (UTC as UT)."""
    jd = _UNIX_EPOCH_JD + unix_seconds / 86400.0
    t = (jd + _DELTA_T_S / 86400.0 - _J2000) / 36525.0
    l0 = 280.46646 + 36000.76983 * t + 0.0003032 * t * t  # Meeus Eq. 25.2
    m = np.radians(357.52911 + 35999.05029 * t - 0.0001537 * t * t)  # Eq. 25.3
    centre = (
        (1.914602 - 0.004817 * t - 0.000014 * t * t) * np.sin(m)
        + (0.019993 - 0.000101 * t) * np.sin(2 * m)
        + 0.000289 * np.sin(3 * m)
    )
    omega = np.radians(125.04 - 1934.136 * t)
    apparent = np.radians(l0 + centre - 0.00569 - 0.00478 * np.sin(omega))  # ch. 25
    epsilon0 = 23.0 + 26.0 / 60.0 + (21.448 - 46.8150 * t) / 3600.0  # Eq. 22.2
    epsilon = np.radians(epsilon0 + 0.00256 * np.cos(omega))  # Eq. 25.8
    ra = np.arctan2(np.cos(epsilon) * np.sin(apparent), np.cos(apparent))  # Eq. 25.6
    sin_dec = np.sin(epsilon) * np.sin(apparent)  # Eq. 25.7
    d = jd - _J2000
    tu = d / 36525.0
    sidereal = 280.46061837 + 360.98564736629 * d + 0.000387933 * tu * tu  # Eq. 12.4
    hour_angle = np.radians(sidereal + longitude) - ra
    phi = math.radians(latitude)
    cos_dec = np.sqrt(1.0 - sin_dec * sin_dec)
    sin_h = math.sin(phi) * sin_dec + math.cos(phi) * cos_dec * np.cos(hour_angle)  # Eq. 13.6
    return np.asarray(np.degrees(np.arcsin(np.clip(sin_h, -1.0, 1.0))), dtype=float)


def _check_site(longitude: float, latitude: float, switch_elevation: float) -> None:
    if not (math.isfinite(longitude) and -180.0 <= longitude <= 360.0):
        raise InputError(f"longitude={longitude!r}; expected degrees east in [-180, 360]")
    if not (math.isfinite(latitude) and -90.0 <= latitude <= 90.0):
        raise InputError(f"latitude={latitude!r}; expected degrees north in [-90, 90]")
    low, high = _SWITCH_RANGE
    if not (math.isfinite(switch_elevation) and low <= switch_elevation <= high):
        raise InputError(
            f"switch_elevation={switch_elevation!r} deg; expected an elevation of the Sun's "
            f"centre in [{low:g}, {high:g}] (sunset {SWITCH_ELEVATION:.3f}, civil twilight -6)"
        )


def sun_elevation(instants: ArrayLike, longitude: float, latitude: float) -> FloatArray:
    """Geometric elevation of the Sun's centre, Meeus (1998) ch. 25 at low accuracy.

    Parameters
    ----------
    instants : array_like of datetime64
        UTC instants (numpy.datetime64 or ISO 8601 strings without offset, read as UTC).
    longitude, latitude : float
        Location [deg], longitude positive east.

    Returns
    -------
    ndarray
        Elevation without refraction [deg], the shape of ``instants``.

    Examples
    --------
    Meeus (1998) Example 25.a, 1992 October 13.0 TD: declination -7.78507 deg, so at the South
    Pole the Sun stands 7.785 deg high:

    >>> round(float(sun_elevation(np.datetime64("1992-10-13T00:00"), 0.0, -90.0)), 3)
    7.785
    """
    _check_site(float(longitude), float(latitude), SWITCH_ELEVATION)
    try:
        times = np.asarray(instants, dtype="datetime64[us]")
    except (TypeError, ValueError):
        raise InputError(
            "instants are not UTC instants; expected numpy.datetime64 or ISO 8601 strings"
        ) from None
    if np.isnat(times).any():
        raise InputError("instants hold NaT; expected UTC instants")
    return _elevation(_seconds(times), float(longitude), float(latitude))


def _bisect(
    lo: FloatArray, hi: FloatArray, longitude: float, latitude: float, h0: float
) -> FloatArray:
    """Crossings of ``h0`` in brackets [lo, hi] whose ends lie on opposite sides [s]."""
    lo, hi = lo.copy(), hi.copy()
    below_lo = _elevation(lo, longitude, latitude) < h0
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        same = (_elevation(mid, longitude, latitude) < h0) == below_lo
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    return 0.5 * (lo + hi)


def burning_intervals(
    longitude: float,
    latitude: float,
    year: int,
    *,
    switch_elevation: float = SWITCH_ELEVATION,
    step_minutes: float = STEP_MINUTES,
) -> BurningIntervals:
    """Switch-on and switch-off instants of a photocell-switched installation over a year.

    Parameters
    ----------
    longitude, latitude : float
        Location [deg], longitude positive east.
    year : int
        UTC year, 1900 to 2100.
    switch_elevation : float, optional
        Elevation of the Sun's centre at which the photocell switches [deg]:
        :data:`SWITCH_ELEVATION` (sunset and sunrise) by default, :data:`CIVIL_TWILIGHT` for
        the end of civil twilight.
    step_minutes : float, optional
        Sampling step [min] (0 < step <= 60); it sets the speed, not the accuracy (see the
        module notes).

    Returns
    -------
    BurningIntervals
        One interval per night, clipped to the year; none in a polar day, one spanning the
        polar night.

    Raises
    ------
    InputError
        A location, year, switch elevation or step out of range.

    Examples
    --------
    On the equator the nights are 11.9 h (the Sun's upper limb sets after its centre):

    >>> nights = burning_intervals(0.0, 0.0, 2024)
    >>> len(nights.on), round(nights.total_hours / 366, 2)
    (367, 11.88)
    """
    longitude, latitude = float(longitude), float(latitude)
    _check_site(longitude, latitude, float(switch_elevation))
    if isinstance(year, bool) or not isinstance(year, (int, np.integer)):
        raise InputError(f"year={year!r}; expected an integer year")
    if not _YEARS[0] <= year <= _YEARS[1]:
        raise InputError(f"year={year}; expected {_YEARS[0]} to {_YEARS[1]}")
    if not (math.isfinite(step_minutes) and 0.0 < step_minutes <= 60.0):
        raise InputError(f"step_minutes={step_minutes!r}; expected 0 < step_minutes <= 60")
    h0 = float(switch_elevation)
    start = np.datetime64(f"{int(year):04d}-01-01T00:00", "ms")
    end = np.datetime64(f"{int(year) + 1:04d}-01-01T00:00", "ms")
    t0, t1 = float(_seconds(np.array(start))), float(_seconds(np.array(end)))
    step = 60.0 * float(step_minutes)
    times = np.append(t0 + step * np.arange(math.ceil((t1 - t0) / step)), t1)
    f = _elevation(times, longitude, latitude) - h0
    below = f < 0
    change = np.flatnonzero(below[:-1] != below[1:])
    crossings = [_bisect(times[change], times[change + 1], longitude, latitude, h0)]
    # grazes: a sampled extremum on one side whose parabola's vertex lies on the other
    left, mid, right = f[:-2], f[1:-1], f[2:]
    curvature = left - 2.0 * mid + right
    extremum = ((mid <= left) & (mid <= right) & ~below[1:-1]) | (
        (mid >= left) & (mid >= right) & below[1:-1]
    )
    extremum &= (below[:-2] == below[1:-1]) & (below[2:] == below[1:-1]) & (curvature != 0)
    index = np.flatnonzero(extremum)
    if index.size:
        shift = 0.5 * step * (left[index] - right[index]) / curvature[index]
        vertex = times[index + 1] + np.clip(shift, -step, step)
        flips = (_elevation(vertex, longitude, latitude) < h0) != below[index + 1]
        vertex, index = vertex[flips], index[flips]
        crossings.append(_bisect(times[index], vertex, longitude, latitude, h0))
        crossings.append(_bisect(vertex, times[index + 2], longitude, latitude, h0))
    edges = np.sort(np.concatenate(crossings))
    if below[0]:
        edges = np.concatenate([[t0], edges])
    if below[-1]:
        edges = np.concatenate([edges, [t1]])
    pairs = edges.reshape(-1, 2)
    keep = pairs[:, 1] > pairs[:, 0]
    on_ms = np.round(pairs[keep, 0] * 1000.0).astype(np.int64).astype("datetime64[ms]")
    off_ms = np.round(pairs[keep, 1] * 1000.0).astype(np.int64).astype("datetime64[ms]")
    return BurningIntervals(on_ms, off_ms, longitude, latitude, int(year), h0)


def annual_burning_hours(
    longitude: float,
    latitude: float,
    year: int,
    *,
    switch_elevation: float = SWITCH_ELEVATION,
    step_minutes: float = STEP_MINUTES,
) -> float:
    """Hours a photocell-switched installation burns in a UTC year.

    Parameters
    ----------
    longitude, latitude, year, switch_elevation, step_minutes
        As :func:`burning_intervals`.

    Returns
    -------
    float
        Burning hours [h].

    Examples
    --------
    At 78 N the polar night and the polar day nearly balance:

    >>> round(annual_burning_hours(0.0, 78.0, 2024) / 8784, 2)
    0.48
    """
    return burning_intervals(
        longitude,
        latitude,
        year,
        switch_elevation=switch_elevation,
        step_minutes=step_minutes,
    ).total_hours
