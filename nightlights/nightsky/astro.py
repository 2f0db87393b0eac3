"""Where the stars stand: time scales, sidereal time, apparent places and the horizon frame.

Meeus (1998) throughout: Julian dates (ch. 7), sidereal time (ch. 12), equatorial to
horizontal (ch. 13), refraction (ch. 16, Saemundsson 1986), precession (ch. 21, IAU 1976),
nutation (ch. 22, its main terms), annual aberration (ch. 23), and the Kasten & Young (1989)
air mass. Against PyEphem, the 48 stars brighter than V = 2 at four instants of 1990-2040 and
six sites at latitudes -60 to +70 agree within 0.4" without refraction and within 20" with it
above the horizon (the two refraction formulas part by that much at 0-2 deg elevation).

Conventions: angles in degrees; longitude positive east; azimuth clockwise from north;
elevation above the horizon. Times are UTC and are used as UT1 (|UT1 - UTC| < 0.9 s, under
0.004 deg of the Earth's rotation); the dynamical time is TT = UT + :data:`DELTA_T_S`.

Length: about 690 lines, because each of the eleven published steps from a catalogue entry to
a refracted elevation is its own documented pure function with its worked example, and they
share the time handling and the frame conventions kept here in one place.

References
----------
1. Meeus, J. 1998, "Astronomical Algorithms", 2nd ed., Willmann-Bell.
2. Saemundsson, T. 1986, Sky and Telescope 72, 70.
3. Kasten, F. & Young, A. T. 1989, "Revised optical air mass tables and approximation
   formula", Applied Optics 28, 4735-4738.
4. Lieske, J. H., Lederle, T., Fricke, W. & Morando, B. 1977, "Expressions for the precession
   quantities based upon the IAU (1976) system of astronomical constants", A&A 58, 1-16.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights.errors import InputError

if TYPE_CHECKING:
    from nightlights.nightsky.catalog import StarCatalog

__all__ = [
    "DELTA_T_S",
    "J2000",
    "TimeLike",
    "airmass",
    "annual_aberration",
    "apparent_place",
    "apparent_sidereal_time",
    "equatorial_to_horizontal",
    "julian_date",
    "julian_ephemeris_date",
    "mean_obliquity",
    "mean_sidereal_time",
    "nutation",
    "nutation_matrix",
    "precession_matrix",
    "proper_motion",
    "refraction",
    "star_positions",
    "sun_true_longitude",
]

TimeLike = datetime | str | np.datetime64

#: TT - UT [s], held fixed at its value around 2020 (69.36 s at 2020.0, IERS Bulletin A); it
#: enters only the Moon's and the Sun's motion (not the Earth's rotation), and the comparison
#: with PyEphem, which models Delta T over 1990-2040, includes the error of holding it.
DELTA_T_S = 69.0
#: Julian date of the epoch J2000.0 (2000 January 1.5 TT) [d], Meeus (1998) ch. 21.
J2000 = 2451545.0
#: Julian date of the Unix epoch, 1970 January 1.0 UTC [d], Meeus (1998) ch. 7.
_UNIX_EPOCH_JD = 2440587.5
_SECONDS_PER_DAY = 86400.0
_DAYS_PER_CENTURY = 36525.0
_DAYS_PER_YEAR = 365.25
_ARCSEC = 1.0 / 3600.0  # [deg]

#: Nutation, Meeus (1998) Table 22.A, the terms whose longitude coefficient is at least
#: 0.0050": multiples of D, M, M', F, Omega; then the coefficients of sin (longitude) and cos
#: (obliquity) in 0.0001" with their rates per Julian century.
_NUTATION_TERMS = np.array(
    [
        # D, M, M', F, Om, psi, psi_T, eps, eps_T
        [0, 0, 0, 0, 1, -171996, -174.2, 92025, 8.9],
        [-2, 0, 0, 2, 2, -13187, -1.6, 5736, -3.1],
        [0, 0, 0, 2, 2, -2274, -0.2, 977, -0.5],
        [0, 0, 0, 0, 2, 2062, 0.2, -895, 0.5],
        [0, 1, 0, 0, 0, 1426, -3.4, 54, -0.1],
        [0, 0, 1, 0, 0, 712, 0.1, -7, 0.0],
        [-2, 1, 0, 2, 2, -517, 1.2, 224, -0.6],
        [0, 0, 0, 2, 1, -386, -0.4, 200, 0.0],
        [0, 0, 1, 2, 2, -301, 0.0, 129, -0.1],
        [-2, -1, 0, 2, 2, 217, -0.5, -95, 0.3],
        [-2, 0, 1, 0, 0, -158, 0.0, 0, 0.0],
        [-2, 0, 0, 2, 1, 129, 0.1, -70, 0.0],
        [0, 0, -1, 2, 2, 123, 0.0, -53, 0.0],
        [2, 0, 0, 0, 0, 63, 0.0, 0, 0.0],
        [0, 0, 1, 0, 1, 63, 0.1, -33, 0.0],
        [2, 0, -1, 2, 2, -59, 0.0, 26, 0.0],
        [0, 0, -1, 0, 1, -58, -0.1, 32, 0.0],
        [0, 0, 1, 2, 1, -51, 0.0, 27, 0.0],
    ]
)


def _centuries(jde: float) -> float:
    """Julian centuries of TT since J2000.0, Meeus (1998) Eq. 22.1."""
    return (jde - J2000) / _DAYS_PER_CENTURY


def julian_date(time: TimeLike) -> float:
    """Julian date of a UTC instant, Meeus (1998) ch. 7.

    Parameters
    ----------
    time : datetime, str or numpy.datetime64
        A timezone-aware :class:`~datetime.datetime` (converted to UTC; a naive one is
        refused, it would silently mean local time), an ISO 8601 string (read as UTC when it
        carries no offset, like :class:`numpy.datetime64`), or a :class:`numpy.datetime64`
        (UTC).

    Returns
    -------
    float
        Julian date [d], counted from noon UTC.

    Raises
    ------
    InputError
        The time is naive, unreadable or not a time.

    References
    ----------
    1. Meeus 1998, ch. 7 (Example 7.a: 1957 October 4.81 is JD 2436116.31).

    Examples
    --------
    >>> julian_date("2000-01-01T12:00:00Z")
    2451545.0
    >>> julian_date(np.datetime64("1957-10-04T19:26:24"))
    2436116.31
    """
    if isinstance(time, np.datetime64):
        if np.isnat(time):
            raise InputError("time=NaT; expected a UTC instant")
        nanoseconds = int(time.astype("datetime64[ns]").astype(np.int64))
        return _UNIX_EPOCH_JD + nanoseconds / (_SECONDS_PER_DAY * 1e9)
    if isinstance(time, str):
        try:
            parsed = datetime.fromisoformat(time.strip())
        except ValueError:
            raise InputError(f"time={time!r} is not an ISO 8601 date and time") from None
        if parsed.tzinfo is None:
            parsed = parsed.replace(tzinfo=UTC)
        time = parsed
    if not isinstance(time, datetime):
        raise InputError(
            f"time={time!r}; expected an aware datetime, an ISO 8601 string or numpy.datetime64"
        )
    if time.tzinfo is None or time.utcoffset() is None:
        raise InputError(f"time={time.isoformat()} has no timezone; give it in UTC")
    seconds = (time - datetime(1970, 1, 1, tzinfo=UTC)).total_seconds()
    return _UNIX_EPOCH_JD + seconds / _SECONDS_PER_DAY


def julian_ephemeris_date(jd: float, *, delta_t_s: float = DELTA_T_S) -> float:
    """Julian ephemeris date (TT) of a Julian date in UT, Meeus (1998) ch. 10.

    Parameters
    ----------
    jd : float
        Julian date, UT [d].
    delta_t_s : float, optional
        TT - UT [s]; :data:`DELTA_T_S` by default.

    Returns
    -------
    float
        JDE = JD + Delta T [d].
    """
    return jd + delta_t_s / _SECONDS_PER_DAY


def mean_sidereal_time(jd: float) -> float:
    """Greenwich mean sidereal time, Meeus (1998) Eq. 12.4.

    Parameters
    ----------
    jd : float
        Julian date, UT [d].

    Returns
    -------
    float
        Mean sidereal time at Greenwich [deg], in [0, 360).

    References
    ----------
    1. Meeus 1998, Eq. 12.4; Example 12.b: 1987 April 10, 19h21m00s UT gives 128.7378734 deg.

    Examples
    --------
    >>> round(mean_sidereal_time(2446896.30625), 6)
    128.737873
    """
    t = (jd - J2000) / _DAYS_PER_CENTURY
    theta = (
        280.46061837 + 360.98564736629 * (jd - J2000) + 0.000387933 * t * t - t * t * t / 38710000.0
    )
    return theta % 360.0


def mean_obliquity(jde: float) -> float:
    """Mean obliquity of the ecliptic (IAU 1976), Meeus (1998) Eq. 22.2.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    float
        epsilon_0 [deg].
    """
    t = _centuries(jde)
    return 23.0 + 26.0 / 60.0 + (21.448 - 46.8150 * t - 0.00059 * t * t + 0.001813 * t**3) / 3600


def nutation(jde: float) -> tuple[float, float]:
    """Nutation in longitude and in obliquity, Meeus (1998) ch. 22, main terms of Table 22.A.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    delta_psi, delta_epsilon : float
        Nutation in longitude and in obliquity [deg], from the 18 largest of the 63 terms;
        Meeus's Example 22.a is matched within 0.002".

    References
    ----------
    1. Meeus 1998, ch. 22, Table 22.A; Example 22.a: 1987 April 10.0 TD gives
       Delta psi = -3.788", Delta epsilon = +9.443".
    """
    t = _centuries(jde)
    # Meeus 1998, ch. 22: mean elongation of the Moon, anomalies of the Sun and the Moon,
    # the Moon's argument of latitude and the longitude of its ascending node [deg]
    d = 297.85036 + 445267.111480 * t - 0.0019142 * t * t + t**3 / 189474.0
    m = 357.52772 + 35999.050340 * t - 0.0001603 * t * t - t**3 / 300000.0
    mp = 134.96298 + 477198.867398 * t + 0.0086972 * t * t + t**3 / 56250.0
    f = 93.27191 + 483202.017538 * t - 0.0036825 * t * t + t**3 / 327270.0
    om = 125.04452 - 1934.136261 * t + 0.0020708 * t * t + t**3 / 450000.0
    terms = _NUTATION_TERMS
    argument = np.radians(terms[:, :5] @ np.array([d, m, mp, f, om]))
    delta_psi = np.sum((terms[:, 5] + terms[:, 6] * t) * np.sin(argument)) * 1e-4
    delta_eps = np.sum((terms[:, 7] + terms[:, 8] * t) * np.cos(argument)) * 1e-4
    return float(delta_psi) * _ARCSEC, float(delta_eps) * _ARCSEC


def apparent_sidereal_time(jd: float, *, delta_t_s: float = DELTA_T_S) -> float:
    """Greenwich apparent sidereal time: mean plus the equation of the equinoxes, Meeus ch. 12.

    Parameters
    ----------
    jd : float
        Julian date, UT [d].
    delta_t_s : float, optional
        TT - UT [s] for the nutation's argument.

    Returns
    -------
    float
        Apparent sidereal time at Greenwich [deg], in [0, 360).

    References
    ----------
    1. Meeus 1998, ch. 12; Example 12.a: 1987 April 10, 0h UT gives 13h10m46.1351s.
    """
    jde = julian_ephemeris_date(jd, delta_t_s=delta_t_s)
    delta_psi, delta_eps = nutation(jde)
    epsilon = math.radians(mean_obliquity(jde) + delta_eps)
    return (mean_sidereal_time(jd) + delta_psi * math.cos(epsilon)) % 360.0


def precession_matrix(jde: float) -> NDArray[np.float64]:
    """Rotation from the mean equator and equinox of J2000.0 to those of date (IAU 1976).

    Parameters
    ----------
    jde : float
        Julian ephemeris date of the target equinox [d].

    Returns
    -------
    ndarray, shape (3, 3)
        P such that ``P @ r_J2000`` is the vector in the mean frame of date.

    Notes
    -----
    zeta, z, theta of Meeus (1998) Eq. 21.3 (Lieske et al. 1977) with the starting epoch J2000.0;
    the matrix is R3(-z) R2(theta) R3(-zeta), equivalent to Meeus Eq. 21.4.
    """
    t = _centuries(jde)
    zeta = math.radians((2306.2181 * t + 0.30188 * t * t + 0.017998 * t**3) * _ARCSEC)
    z = math.radians((2306.2181 * t + 1.09468 * t * t + 0.018203 * t**3) * _ARCSEC)
    theta = math.radians((2004.3109 * t - 0.42665 * t * t - 0.041833 * t**3) * _ARCSEC)
    cz, sz = math.cos(zeta), math.sin(zeta)
    cZ, sZ = math.cos(z), math.sin(z)
    ct, st = math.cos(theta), math.sin(theta)
    return np.array(
        [
            [cz * ct * cZ - sz * sZ, -sz * ct * cZ - cz * sZ, -st * cZ],
            [cz * ct * sZ + sz * cZ, -sz * ct * sZ + cz * cZ, -st * sZ],
            [cz * st, -sz * st, ct],
        ]
    )


def nutation_matrix(jde: float) -> NDArray[np.float64]:
    """Rotation from the mean equator and equinox of date to the true ones, Meeus ch. 22-23.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    ndarray, shape (3, 3)
        N = R1(-epsilon) R3(-Delta psi) R1(epsilon_0), with epsilon = epsilon_0 + Delta epsilon.
    """
    delta_psi, delta_eps = nutation(jde)
    eps0 = math.radians(mean_obliquity(jde))
    eps = eps0 + math.radians(delta_eps)
    dpsi = math.radians(delta_psi)
    cp, sp = math.cos(dpsi), math.sin(dpsi)
    ce, se = math.cos(eps), math.sin(eps)
    c0, s0 = math.cos(eps0), math.sin(eps0)
    return np.array(
        [
            [cp, -sp * c0, -sp * s0],
            [sp * ce, cp * ce * c0 + se * s0, cp * ce * s0 - se * c0],
            [sp * se, cp * se * c0 - ce * s0, cp * se * s0 + ce * c0],
        ]
    )


def sun_true_longitude(jde: float) -> tuple[float, float]:
    """The Sun's geometric true longitude and distance, low accuracy, Meeus (1998) ch. 25.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    longitude : float
        True geometric longitude, mean equinox of date [deg] (Meeus Eqs. 25.2-25.4; 0.01 deg).
    distance : float
        Sun-Earth distance [au] (Meeus Eq. 25.5).

    References
    ----------
    1. Meeus 1998, ch. 25; Example 25.a: 1992 October 13.0 TD gives 199.90988 deg and
       0.99766 au.
    """
    t = _centuries(jde)
    l0 = 280.46646 + 36000.76983 * t + 0.0003032 * t * t  # Meeus Eq. 25.2
    m = 357.52911 + 35999.05029 * t - 0.0001537 * t * t  # Eq. 25.3
    e = 0.016708634 - 0.000042037 * t - 0.0000001267 * t * t  # Eq. 25.4
    mr = math.radians(m)
    centre = (
        (1.914602 - 0.004817 * t - 0.000014 * t * t) * math.sin(mr)
        + (0.019993 - 0.000101 * t) * math.sin(2 * mr)
        + 0.000289 * math.sin(3 * mr)
    )
    anomaly = math.radians(m + centre)
    distance = 1.000001018 * (1 - e * e) / (1 + e * math.cos(anomaly))  # Eq. 25.5
    return (l0 + centre) % 360.0, distance


def _unit_vectors(ra: NDArray[np.float64], dec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit vectors, shape (..., 3), of right ascensions and declinations [deg]."""
    a, d = np.radians(ra), np.radians(dec)
    return np.stack([np.cos(d) * np.cos(a), np.cos(d) * np.sin(a), np.sin(d)], axis=-1)


def _angles(xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Right ascension in [0, 360) and declination [deg] of vectors, shape (..., 3)."""
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    ra = _wrap_360(np.degrees(np.arctan2(y, x)))
    dec = np.degrees(np.arctan2(z, np.hypot(x, y)))
    return ra, dec


def _wrap_360(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles in [0, 360) [deg]; ``% 360`` alone gives 360.0 for tiny negative angles."""
    wrapped = np.mod(angle, 360.0)
    return np.where(wrapped >= 360.0, 0.0, wrapped)


def proper_motion(
    ra: ArrayLike, dec: ArrayLike, pm_ra: ArrayLike, pm_dec: ArrayLike, years: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Carry catalogue positions along their proper motion, Meeus (1998) ch. 21.

    Parameters
    ----------
    ra, dec : array_like
        Position at the catalogue epoch [deg].
    pm_ra : array_like
        Proper motion in right ascension on the sky, mu_alpha cos(dec) [arcsec yr-1].
    pm_dec : array_like
        Proper motion in declination [arcsec yr-1].
    years : float
        Julian years from the catalogue epoch [yr].

    Returns
    -------
    ra, dec : ndarray
        Position at the new epoch [deg], same equinox.

    Notes
    -----
    The motion is a straight step on the tangent plane, renormalised to the sphere (linear
    in time like Meeus's, but without the 1/cos(dec) of the right ascension near the poles).
    """
    r = _unit_vectors(np.asarray(ra, dtype=float), np.asarray(dec, dtype=float))
    a, d = np.radians(ra), np.radians(dec)
    east = np.stack([-np.sin(a), np.cos(a), np.zeros_like(a)], axis=-1)
    north = np.stack([-np.sin(d) * np.cos(a), -np.sin(d) * np.sin(a), np.cos(d)], axis=-1)
    step = np.radians(years * _ARCSEC)
    moved = r + step * (
        np.asarray(pm_ra, dtype=float)[..., None] * east
        + np.asarray(pm_dec, dtype=float)[..., None] * north
    )
    return _angles(moved)


def annual_aberration(xyz: NDArray[np.float64], jde: float) -> NDArray[np.float64]:
    """Displace directions of the mean equator of date by the annual aberration, Meeus ch. 23.

    Parameters
    ----------
    xyz : ndarray, shape (..., 3)
        Unit vectors in the mean equatorial frame of date.
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    ndarray, shape (..., 3)
        Apparent unit vectors: ``r + v/c`` renormalised, with the Earth's velocity over c of
        Meeus Eq. 23.2 (kappa = 20.49552" and the eccentricity term e kappa toward the
        perihelion longitude pi), which is the vector form of Eq. 23.3 without its 1/cos(dec).
    """
    t = _centuries(jde)
    kappa = math.radians(20.49552 * _ARCSEC)  # constant of aberration, Meeus ch. 23
    e = 0.016708634 - 0.000042037 * t - 0.0000001267 * t * t  # Meeus Eq. 25.4
    perihelion = math.radians(102.93735 + 1.71946 * t + 0.00046 * t * t)  # Meeus ch. 23
    sun = math.radians(sun_true_longitude(jde)[0])
    # Earth's velocity / c in the ecliptic of date (Meeus Eq. 23.2 as a vector)
    vx = kappa * (math.sin(sun) - e * math.sin(perihelion))
    vy = kappa * (-math.cos(sun) + e * math.cos(perihelion))
    eps = math.radians(mean_obliquity(jde))
    velocity = np.array([vx, vy * math.cos(eps), vy * math.sin(eps)])
    moved = xyz + velocity
    return moved / np.linalg.norm(moved, axis=-1, keepdims=True)


def apparent_place(
    ra: ArrayLike,
    dec: ArrayLike,
    jde: float,
    *,
    pm_ra: ArrayLike = 0.0,
    pm_dec: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Apparent right ascension and declination of stars of J2000.0, Meeus (1998) ch. 21-23.

    Proper motion to the date, precession (IAU 1976), annual aberration, nutation (main
    terms); stellar parallax (at most 0.751", alpha Cen, in the catalogue) is left out.

    Parameters
    ----------
    ra, dec : array_like
        Position, equinox J2000.0, epoch 2000.0 [deg].
    jde : float
        Julian ephemeris date [d].
    pm_ra, pm_dec : array_like, optional
        Proper motion, mu_alpha cos(dec) and mu_delta [arcsec yr-1].

    Returns
    -------
    ra, dec : ndarray
        Apparent place: true equator and equinox of date [deg].

    References
    ----------
    1. Meeus 1998, Example 23.a: theta Persei on 2028 November 13.19 TD is at
       RA 41.5599646 deg, Dec 49.3520685 deg.
    """
    ra_t, dec_t = proper_motion(ra, dec, pm_ra, pm_dec, (jde - J2000) / _DAYS_PER_YEAR)
    xyz = _unit_vectors(ra_t, dec_t) @ precession_matrix(jde).T
    xyz = annual_aberration(xyz, jde) @ nutation_matrix(jde).T
    return _angles(xyz)


def equatorial_to_horizontal(
    hour_angle: ArrayLike, dec: ArrayLike, latitude: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Azimuth and elevation from hour angle and declination, Meeus (1998) Eqs. 13.5-13.6.

    Parameters
    ----------
    hour_angle : array_like
        Local hour angle, positive west of the meridian [deg].
    dec : array_like
        Declination [deg].
    latitude : float
        Observer's latitude, positive north [deg].

    Returns
    -------
    azimuth : ndarray
        Clockwise from north [deg], in [0, 360) (Meeus counts from south; this adds 180).
    elevation : ndarray
        Above the horizon, without refraction [deg].

    Examples
    --------
    >>> az, el = equatorial_to_horizontal(0.0, 30.0, 50.0)
    >>> float(az), float(el)
    (180.0, 70.0)
    """
    h = np.radians(np.asarray(hour_angle, dtype=float))
    d = np.radians(np.asarray(dec, dtype=float))
    phi = math.radians(latitude)
    north = np.sin(d) * math.cos(phi) - np.cos(d) * np.cos(h) * math.sin(phi)
    east = -np.cos(d) * np.sin(h)
    up = np.sin(d) * math.sin(phi) + np.cos(d) * np.cos(h) * math.cos(phi)
    azimuth = _wrap_360(np.degrees(np.arctan2(east, north)))
    elevation = np.degrees(np.arctan2(up, np.hypot(north, east)))
    return azimuth, elevation


#: True elevation [deg] at which Saemundsson's formula turns over (h + 5.11 = sqrt(10.3));
#: below it the refraction is held at its value there, so the apparent elevation keeps rising.
_SAEMUNDSSON_TURN = math.sqrt(10.3) - 5.11


def refraction(
    elevation_true: ArrayLike, *, pressure_hpa: float = 1010.0, temperature_c: float = 10.0
) -> NDArray[np.float64]:
    """Atmospheric refraction from the true elevation, Saemundsson (1986), Meeus Eq. 16.4.

    .. math:: R = \\frac{1.02'}{\\tan(h + 10.3 / (h + 5.11))}
              \\frac{P}{1010\\,\\mathrm{hPa}} \\frac{283\\,\\mathrm{K}}{273 + T}

    Parameters
    ----------
    elevation_true : array_like
        Airless (geometric) elevation h [deg].
    pressure_hpa : float, optional
        Air pressure at the observer [hPa].
    temperature_c : float, optional
        Air temperature at the observer [degC].

    Returns
    -------
    ndarray
        Refraction R [deg], to add to the true elevation. Below h = -1.9 deg, where the formula
        turns over, R is held at its value there (0.744 deg at 1010 hPa and 10 degC).

    References
    ----------
    1. Saemundsson 1986; Meeus 1998, Eq. 16.4. Inverted, it agrees with Bennett (1982,
       Meeus Eq. 16.3) within 0.062' over 0-90 deg.

    Examples
    --------
    >>> round(float(refraction(0.0)) * 60, 1)  # [arcmin] at the horizon
    29.0
    """
    if not pressure_hpa >= 0 or not math.isfinite(temperature_c) or temperature_c <= -273.15:
        raise InputError(
            f"pressure_hpa={pressure_hpa!r}, temperature_c={temperature_c!r}; expected a "
            "pressure >= 0 hPa and a temperature above absolute zero"
        )
    h = np.maximum(np.asarray(elevation_true, dtype=float), _SAEMUNDSSON_TURN)
    arcmin = 1.02 / np.tan(np.radians(h + 10.3 / (h + 5.11)))
    return arcmin / 60.0 * (pressure_hpa / 1010.0) * (283.0 / (273.0 + temperature_c))


def airmass(elevation: ArrayLike) -> NDArray[np.float64]:
    """Relative optical air mass, Kasten & Young (1989).

    .. math:: X = \\frac{1}{\\sin h + 0.50572\\,(h + 6.07995^\\circ)^{-1.6364}}

    Parameters
    ----------
    elevation : array_like
        Apparent elevation h [deg].

    Returns
    -------
    ndarray
        Air mass [1]: 1 at the zenith, 37.9 at the horizon; NaN below the horizon.

    References
    ----------
    1. Kasten & Young 1989, Eq. 3 and Table 1.

    Examples
    --------
    >>> np.round(airmass([90.0, 30.0, 0.0]), 3).tolist()
    [1.0, 1.994, 37.92]
    """
    h = np.asarray(elevation, dtype=float)
    with np.errstate(invalid="ignore"):
        x = 1.0 / (np.sin(np.radians(h)) + 0.50572 * (h + 6.07995) ** -1.6364)
    return np.where(h >= 0.0, x, np.nan)


def _check_site(lon: float, lat: float) -> None:
    """Refuse a longitude or latitude that is not a finite angle in range."""
    if not (math.isfinite(lon) and -360.0 <= lon <= 360.0):
        raise InputError(f"lon={lon!r}; expected a longitude in degrees east")
    if not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise InputError(f"lat={lat!r}; expected a latitude in [-90, 90] degrees")


def star_positions(
    catalog: StarCatalog,
    time: TimeLike,
    lon: float,
    lat: float,
    *,
    refraction: bool = True,
    pressure_hpa: float = 1010.0,
    temperature_c: float = 10.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Apparent azimuth and elevation of every catalogue star for an observer at a time.

    Parameters
    ----------
    catalog : StarCatalog
        Stars of J2000.0 with proper motions (:func:`~nightlights.nightsky.load_catalog`).
    time : datetime, str or numpy.datetime64
        UTC instant (see :func:`julian_date`).
    lon, lat : float
        Observer's longitude (positive east) and latitude (positive north) [deg].
    refraction : bool, optional
        Add Saemundsson's refraction (:func:`refraction`) to the elevation.
    pressure_hpa : float, optional
        Air pressure for the refraction [hPa].
    temperature_c : float, optional
        Air temperature for the refraction [degC].

    Returns
    -------
    azimuth : ndarray, shape (n,)
        Clockwise from north [deg], in [0, 360).
    elevation : ndarray, shape (n,)
        Above the horizon [deg]; negative for stars below it.

    References
    ----------
    1. Meeus 1998, ch. 12, 13, 16, 21-23.

    Examples
    --------
    >>> from nightlights.nightsky import load_catalog
    >>> stars = load_catalog()
    >>> az, el = star_positions(stars, "2024-01-15T22:00:00Z", 24.94, 60.17)
    >>> sirius = int(np.flatnonzero(stars.hr == 2491)[0])
    >>> round(float(az[sirius])), round(float(el[sirius]))
    (188, 13)
    """
    _check_site(lon, lat)
    jd = julian_date(time)
    jde = julian_ephemeris_date(jd)
    ra, dec = apparent_place(
        catalog.ra, catalog.dec, jde, pm_ra=catalog.pm_ra, pm_dec=catalog.pm_dec
    )
    local_sidereal = apparent_sidereal_time(jd) + lon
    azimuth, elevation = equatorial_to_horizontal(local_sidereal - ra, dec, lat)
    if refraction:
        elevation = elevation + _refraction(
            elevation, pressure_hpa=pressure_hpa, temperature_c=temperature_c
        )
    return azimuth, elevation


_refraction = refraction
