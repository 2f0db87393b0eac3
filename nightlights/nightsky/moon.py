"""The Sun and the Moon for an observer, and the moonlight scattered over the sky.

Positions from Meeus's low-accuracy theories: the Sun of ch. 25 (0.01 deg) and the Moon of
ch. 47 (ELP-2000/82 truncated to its largest periodic terms), with the Moon's topocentric
parallax (ch. 11 and 40, done as vectors); the phase angle, illuminated fraction and position
angle of the bright limb of ch. 48; the parallactic angle of ch. 14. The moonlight on the sky
is the model of Krisciunas & Schaefer (1991). Against PyEphem at 120 random instants of
1990-2040 and latitudes -60 to +70, the Moon's topocentric position agrees within 0.007 deg,
its illuminated fraction within 0.008, its angular radius within 0.15 % and the Sun within
0.011 deg.

Length: about 630 lines, because Meeus's lunar series is carried as its two coefficient tables
(75 rows) next to the Sun, the phase and the moonlight that use it, each a documented pure
function.

References
----------
1. Meeus, J. 1998, "Astronomical Algorithms", 2nd ed., Willmann-Bell.
2. Krisciunas, K. & Schaefer, B. E. 1991, "A model of the brightness of moonlight",
   PASP 103, 1033-1039.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights.errors import InputError
from nightlights.nightsky.astro import (
    TimeLike,
    _angles,
    _check_site,
    _refraction,
    _unit_vectors,
    apparent_sidereal_time,
    equatorial_to_horizontal,
    julian_date,
    julian_ephemeris_date,
    mean_obliquity,
    nutation,
    sun_true_longitude,
)

__all__ = [
    "ASTRONOMICAL_UNIT_KM",
    "EARTH_EQUATORIAL_RADIUS_KM",
    "MOON_RADIUS_KM",
    "MoonState",
    "bright_limb_position_angle",
    "krisciunas_schaefer",
    "krisciunas_schaefer_airmass",
    "moon_ecliptic_position",
    "moon_sky_brightness",
    "moon_state",
    "parallactic_angle",
    "phase_angle",
    "sun_equatorial",
    "sun_position",
]

#: Astronomical unit [km] (IAU 2012 Resolution B2).
ASTRONOMICAL_UNIT_KM = 149_597_870.7
#: Earth's equatorial radius [km] used by Meeus (1998) ch. 11 and 47.
EARTH_EQUATORIAL_RADIUS_KM = 6378.14
#: Earth's polar-to-equatorial axis ratio b/a, Meeus (1998) ch. 11.
_EARTH_AXIS_RATIO = 0.99664719
#: Moon's mean radius [km] (IAU WGCCRE 2015).
MOON_RADIUS_KM = 1737.4
#: One nanolambert in cd m-2: 1e-9 L, 1 L = 1e4 / pi cd m-2.
_NANOLAMBERT_CD_M2 = 1e-9 * 1e4 / math.pi

#: Meeus (1998) Table 47.A, the terms with |Sigma l| >= 0.000700 deg or |Sigma r| >= 2 km:
#: multiples of D, M, M', F; the sine coefficient of the longitude [1e-6 deg] and the cosine
#: coefficient of the distance [m]. The 14 terms left out sum to at most 0.0060 deg and 7 km.
_LONGITUDE_DISTANCE_TERMS = np.array(
    [
        [0, 0, 1, 0, 6288774, -20905355],
        [2, 0, -1, 0, 1274027, -3699111],
        [2, 0, 0, 0, 658314, -2955968],
        [0, 0, 2, 0, 213618, -569925],
        [0, 1, 0, 0, -185116, 48888],
        [0, 0, 0, 2, -114332, -3149],
        [2, 0, -2, 0, 58793, 246158],
        [2, -1, -1, 0, 57066, -152138],
        [2, 0, 1, 0, 53322, -170733],
        [2, -1, 0, 0, 45758, -204586],
        [0, 1, -1, 0, -40923, -129620],
        [1, 0, 0, 0, -34720, 108743],
        [0, 1, 1, 0, -30383, 104755],
        [2, 0, 0, -2, 15327, 10321],
        [0, 0, 1, 2, -12528, 0],
        [0, 0, 1, -2, 10980, 79661],
        [4, 0, -1, 0, 10675, -34782],
        [0, 0, 3, 0, 10034, -23210],
        [4, 0, -2, 0, 8548, -21636],
        [2, 1, -1, 0, -7888, 24208],
        [2, 1, 0, 0, -6766, 30824],
        [1, 0, -1, 0, -5163, -8379],
        [1, 1, 0, 0, 4987, -16675],
        [2, -1, 1, 0, 4036, -12831],
        [2, 0, 2, 0, 3994, -10445],
        [4, 0, 0, 0, 3861, -11650],
        [2, 0, -3, 0, 3665, 14403],
        [0, 1, -2, 0, -2689, -7003],
        [2, 0, -1, 2, -2602, 0],
        [2, -1, -2, 0, 2390, 10056],
        [1, 0, 1, 0, -2348, 6322],
        [2, -2, 0, 0, 2236, -9884],
        [0, 1, 2, 0, -2120, 5751],
        [0, 2, 0, 0, -2069, 0],
        [2, -2, -1, 0, 2048, -4950],
        [2, 0, 1, -2, -1773, 4130],
        [2, 0, 0, 2, -1595, 0],
        [4, -1, -1, 0, 1215, -3958],
        [0, 0, 2, 2, -1110, 0],
        [3, 0, -1, 0, -892, 3258],
        [2, 1, 1, 0, -810, 2616],
        [4, -1, -2, 0, 759, -1897],
        [0, 2, -1, 0, -713, -2117],
        [2, 2, -1, 0, -700, 2354],
        [0, 0, 2, -2, -381, -4421],
        [2, 0, -1, -2, 0, 8752],
    ],
    dtype=float,
)

#: Meeus (1998) Table 47.B, the terms with |Sigma b| >= 0.001000 deg: multiples of D, M, M',
#: F and the sine coefficient of the latitude [1e-6 deg]. The 31 left out sum to at most
#: 0.0103 deg.
_LATITUDE_TERMS = np.array(
    [
        [0, 0, 0, 1, 5128122],
        [0, 0, 1, 1, 280602],
        [0, 0, 1, -1, 277693],
        [2, 0, 0, -1, 173237],
        [2, 0, -1, 1, 55413],
        [2, 0, -1, -1, 46271],
        [2, 0, 0, 1, 32573],
        [0, 0, 2, 1, 17198],
        [2, 0, 1, -1, 9266],
        [0, 0, 2, -1, 8822],
        [2, -1, 0, -1, 8216],
        [2, 0, -2, -1, 4324],
        [2, 0, 1, 1, 4200],
        [2, 1, 0, -1, -3359],
        [2, -1, -1, 1, 2463],
        [2, -1, 0, 1, 2211],
        [2, -1, -1, -1, 2065],
        [0, 1, -1, -1, -1870],
        [4, 0, -1, -1, 1828],
        [0, 1, 0, 1, -1794],
        [0, 0, 0, 3, -1749],
        [0, 1, -1, 1, -1565],
        [1, 0, 0, 1, -1491],
        [0, 1, 1, 1, -1475],
        [0, 1, 1, -1, -1410],
        [0, 1, 0, -1, -1344],
        [1, 0, 0, -1, -1335],
        [0, 0, 3, 1, 1107],
        [4, 0, 0, -1, 1021],
    ],
    dtype=float,
)


def moon_ecliptic_position(jde: float) -> tuple[float, float, float]:
    """Geocentric ecliptic longitude, latitude and distance of the Moon, Meeus (1998) ch. 47.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    longitude, latitude : float
        Geometric position, mean equinox and ecliptic of date [deg] (add the nutation in
        longitude for the apparent longitude).
    distance : float
        Earth-Moon distance, centre to centre [km].

    References
    ----------
    1. Meeus 1998, Eqs. 47.1-47.6 and Tables 47.A-B (largest terms); Example 47.a:
       1992 April 12.0 TD gives 133.162655 deg, -3.229126 deg, 368409.7 km.
    """
    t = (jde - 2451545.0) / 36525.0
    # Meeus Eqs. 47.1-47.5: mean longitude, mean elongation, Sun's and Moon's mean anomalies,
    # argument of latitude [deg]
    lp = 218.3164477 + 481267.88123421 * t - 0.0015786 * t**2 + t**3 / 538841 - t**4 / 65194000
    d = 297.8501921 + 445267.1114034 * t - 0.0018819 * t**2 + t**3 / 545868 - t**4 / 113065000
    m = 357.5291092 + 35999.0502909 * t - 0.0001536 * t**2 + t**3 / 24490000
    mp = 134.9633964 + 477198.8675055 * t + 0.0087414 * t**2 + t**3 / 69699 - t**4 / 14712000
    f = 93.2720950 + 483202.0175233 * t - 0.0036539 * t**2 - t**3 / 3526000 + t**4 / 863310000
    a1 = math.radians(119.75 + 131.849 * t)  # Venus, Meeus ch. 47
    a2 = math.radians(53.09 + 479264.290 * t)  # Jupiter
    a3 = math.radians(313.45 + 481266.484 * t)  # flattening of the Earth
    e = 1.0 - 0.002516 * t - 0.0000074 * t**2  # Eq. 47.6
    elements = np.radians([d, m, mp, f])

    def series(terms: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Arguments of the terms and the factor E^|M| on their coefficients (Meeus ch. 47)."""
        return terms[:, :4] @ elements, e ** np.abs(terms[:, 1])

    argument, factor = series(_LONGITUDE_DISTANCE_TERMS)
    sigma_l = np.sum(factor * _LONGITUDE_DISTANCE_TERMS[:, 4] * np.sin(argument))
    sigma_r = np.sum(factor * _LONGITUDE_DISTANCE_TERMS[:, 5] * np.cos(argument))
    argument, factor = series(_LATITUDE_TERMS)
    sigma_b = np.sum(factor * _LATITUDE_TERMS[:, 4] * np.sin(argument))
    lpr, mpr, fr = math.radians(lp), math.radians(mp), math.radians(f)
    # additive terms of Meeus ch. 47 (Venus, Jupiter, flattening of the Earth)
    sigma_l += 3958 * math.sin(a1) + 1962 * math.sin(lpr - fr) + 318 * math.sin(a2)
    sigma_b += (
        -2235 * math.sin(lpr)
        + 382 * math.sin(a3)
        + 175 * math.sin(a1 - fr)
        + 175 * math.sin(a1 + fr)
        + 127 * math.sin(lpr - mpr)
        - 115 * math.sin(lpr + mpr)
    )
    longitude = (lp + float(sigma_l) * 1e-6) % 360.0
    latitude = float(sigma_b) * 1e-6
    distance = 385000.56 + float(sigma_r) * 1e-3
    return longitude, latitude, distance


def _ecliptic_to_equatorial(
    longitude: float, latitude: float, obliquity: float
) -> tuple[float, float]:
    """Right ascension and declination [deg] of ecliptic coordinates, Meeus Eqs. 13.3-13.4."""
    lam, beta, eps = math.radians(longitude), math.radians(latitude), math.radians(obliquity)
    ra = math.atan2(math.sin(lam) * math.cos(eps) - math.tan(beta) * math.sin(eps), math.cos(lam))
    dec = math.asin(math.sin(beta) * math.cos(eps) + math.cos(beta) * math.sin(eps) * math.sin(lam))
    return math.degrees(ra) % 360.0, math.degrees(dec)


def sun_equatorial(jde: float) -> tuple[float, float, float]:
    """The Sun's apparent right ascension, declination and distance, Meeus (1998) ch. 25.

    Parameters
    ----------
    jde : float
        Julian ephemeris date [d].

    Returns
    -------
    ra, dec : float
        Apparent geocentric position, true equinox of date [deg].
    distance : float
        Earth-Sun distance [km].

    References
    ----------
    1. Meeus 1998, Eqs. 25.5-25.8; Example 25.a: 1992 October 13.0 TD, RA 198.38083 deg,
       Dec -7.78507 deg.
    """
    t = (jde - 2451545.0) / 36525.0
    true_longitude, distance_au = sun_true_longitude(jde)
    omega = math.radians(125.04 - 1934.136 * t)  # Meeus ch. 25
    apparent = true_longitude - 0.00569 - 0.00478 * math.sin(omega)
    obliquity = mean_obliquity(jde) + 0.00256 * math.cos(omega)  # Eq. 25.8
    ra, dec = _ecliptic_to_equatorial(apparent, 0.0, obliquity)
    return ra, dec, distance_au * ASTRONOMICAL_UNIT_KM


def _observer_vector(local_sidereal: float, lat: float) -> NDArray[np.float64]:
    """Geocentric position of a sea-level observer, true equator of date [km], Meeus ch. 11."""
    phi = math.radians(lat)
    u = math.atan(_EARTH_AXIS_RATIO * math.tan(phi))
    rho_sin = _EARTH_AXIS_RATIO * math.sin(u)  # Meeus Eq. 11.? rho sin(phi'), height 0
    rho_cos = math.cos(u)
    theta = math.radians(local_sidereal)
    return EARTH_EQUATORIAL_RADIUS_KM * np.array(
        [rho_cos * math.cos(theta), rho_cos * math.sin(theta), rho_sin]
    )


def _horizontal(
    xyz: NDArray[np.float64], local_sidereal: float, lat: float
) -> tuple[float, float, float, float]:
    """Azimuth, elevation, RA and Dec [deg] of a vector in the true equatorial frame."""
    ra, dec = _angles(xyz)
    azimuth, elevation = equatorial_to_horizontal(local_sidereal - ra, dec, lat)
    return float(azimuth), float(elevation), float(ra), float(dec)


def sun_position(
    time: TimeLike, lon: float, lat: float, *, refraction: bool = False
) -> tuple[float, float]:
    """Azimuth and elevation of the Sun's centre for an observer, Meeus (1998) ch. 25.

    Parameters
    ----------
    time : datetime, str or numpy.datetime64
        UTC instant (see :func:`~nightlights.nightsky.astro.julian_date`).
    lon, lat : float
        Observer's longitude (positive east) and latitude [deg].
    refraction : bool, optional
        Add Saemundsson's refraction at 1010 hPa and 10 degC. Off by default: the twilights
        are defined by the geometric elevation (civil -6, nautical -12, astronomical -18 deg).

    Returns
    -------
    azimuth, elevation : float
        Clockwise from north, and above the horizon [deg].

    References
    ----------
    1. Meeus 1998, ch. 25 (low accuracy: within 0.011 deg of PyEphem in the tests);
       Example 25.a: 1992 October 13.0 TD, apparent RA 198.38083 deg, Dec -7.78507 deg.
    """
    _check_site(lon, lat)
    jd = julian_date(time)
    ra, dec, _ = sun_equatorial(julian_ephemeris_date(jd))
    azimuth, elevation = equatorial_to_horizontal(apparent_sidereal_time(jd) + lon - ra, dec, lat)
    if refraction:
        elevation = elevation + _refraction(elevation)
    return float(azimuth), float(elevation)


def phase_angle(
    sun_ra: float,
    sun_dec: float,
    sun_distance_km: float,
    moon_ra: float,
    moon_dec: float,
    moon_distance_km: float,
) -> float:
    """The Moon's phase angle, Meeus (1998) Eqs. 48.2-48.3.

    Parameters
    ----------
    sun_ra, sun_dec : float
        Sun's right ascension and declination [deg].
    sun_distance_km : float
        Distance to the Sun [km].
    moon_ra, moon_dec : float
        Moon's right ascension and declination [deg], same frame and observer.
    moon_distance_km : float
        Distance to the Moon [km].

    Returns
    -------
    float
        Phase angle i, Sun-Moon-observer [deg]: 0 at full Moon, 180 at new Moon.

    References
    ----------
    1. Meeus 1998, Eqs. 48.2-48.3; Example 48.a gives i = 69.0756 deg.
    """
    a0, d0, a, d = map(math.radians, (sun_ra, sun_dec, moon_ra, moon_dec))
    cos_psi = math.sin(d0) * math.sin(d) + math.cos(d0) * math.cos(d) * math.cos(a0 - a)
    psi = math.acos(min(1.0, max(-1.0, cos_psi)))  # elongation, Eq. 48.2
    return math.degrees(  # Eq. 48.3
        math.atan2(sun_distance_km * math.sin(psi), moon_distance_km - sun_distance_km * cos_psi)
    )


def bright_limb_position_angle(
    sun_ra: float, sun_dec: float, moon_ra: float, moon_dec: float
) -> float:
    """Position angle of the midpoint of the Moon's bright limb, Meeus (1998) Eq. 48.5.

    Parameters
    ----------
    sun_ra, sun_dec, moon_ra, moon_dec : float
        Right ascensions and declinations of the Sun and the Moon [deg].

    Returns
    -------
    float
        chi, from the north point of the disc through east [deg], in [0, 360).

    References
    ----------
    1. Meeus 1998, Eq. 48.5; Example 48.a gives chi = 285.0 deg.
    """
    a0, d0, a, d = map(math.radians, (sun_ra, sun_dec, moon_ra, moon_dec))
    chi = math.atan2(
        math.cos(d0) * math.sin(a0 - a),
        math.sin(d0) * math.cos(d) - math.cos(d0) * math.sin(d) * math.cos(a0 - a),
    )
    return math.degrees(chi) % 360.0


def parallactic_angle(hour_angle: float, dec: float, latitude: float) -> float:
    """Parallactic angle of a body, Meeus (1998) Eq. 14.1.

    Parameters
    ----------
    hour_angle : float
        Local hour angle, positive west [deg].
    dec : float
        Declination [deg].
    latitude : float
        Observer's latitude [deg].

    Returns
    -------
    float
        q, the position angle of the zenith at the body [deg], in (-180, 180]: 0 on the
        meridian south of the zenith, negative in the east.
    """
    h, d, phi = map(math.radians, (hour_angle, dec, latitude))
    return math.degrees(
        math.atan2(math.sin(h), math.tan(phi) * math.cos(d) - math.sin(d) * math.cos(h))
    )


@dataclass(frozen=True)
class MoonState:
    """The Moon seen by an observer at an instant.

    Attributes
    ----------
    azimuth : float
        Clockwise from north [deg].
    elevation : float
        Apparent topocentric elevation of the centre [deg] (refracted unless asked not to).
    distance_km : float
        Topocentric distance, observer to the Moon's centre [km].
    angular_radius : float
        Apparent (topocentric) semi-diameter [deg].
    phase_angle : float
        Sun-Moon-observer angle [deg]: 0 at full Moon, 180 at new Moon.
    illuminated_fraction : float
        Fraction of the disc that is lit, (1 + cos(phase_angle)) / 2 [1].
    position_angle_of_bright_limb : float
        Position angle of the midpoint of the bright limb, from north through east [deg].
    parallactic_angle : float
        Angle at the Moon from north to the zenith, same sense [deg]. With
        ``z = position_angle_of_bright_limb - parallactic_angle`` (the bright limb's angle from
        the direction to the zenith, Meeus 1998, ch. 48), the midpoint of the bright limb lies
        toward ``(-sin z, cos z)`` from the disc's centre in a picture with azimuth growing to
        the right and elevation up.
    """

    azimuth: float
    elevation: float
    distance_km: float
    angular_radius: float
    phase_angle: float
    illuminated_fraction: float
    position_angle_of_bright_limb: float
    parallactic_angle: float = 0.0


def moon_state(time: TimeLike, lon: float, lat: float, *, refraction: bool = True) -> MoonState:
    """Position, distance, size and phase of the Moon for an observer at sea level.

    Parameters
    ----------
    time : datetime, str or numpy.datetime64
        UTC instant (see :func:`~nightlights.nightsky.astro.julian_date`).
    lon, lat : float
        Observer's longitude (positive east) and latitude [deg].
    refraction : bool, optional
        Add Saemundsson's refraction (1010 hPa, 10 degC) to the elevation, as the stars get.

    Returns
    -------
    MoonState

    References
    ----------
    1. Meeus 1998, ch. 47 (position), 11 and 40 (parallax, as geocentric vector minus the
       observer's), 48 (Eqs. 48.2-48.5: phase angle, illuminated fraction, bright limb),
       14 (Eq. 14.1: parallactic angle); Example 48.a: 1992 April 12.0 TD, i = 69.0756 deg,
       k = 0.6786, chi = 285.0 deg (geocentric).

    Examples
    --------
    >>> moon = moon_state("2024-01-25T17:54:00Z", 24.94, 60.17)  # full Moon
    >>> round(moon.illuminated_fraction, 2)
    1.0
    """
    _check_site(lon, lat)
    jd = julian_date(time)
    jde = julian_ephemeris_date(jd)
    delta_psi, delta_eps = nutation(jde)
    longitude, latitude, distance = moon_ecliptic_position(jde)
    ra, dec = _ecliptic_to_equatorial(
        longitude + delta_psi, latitude, mean_obliquity(jde) + delta_eps
    )
    local_sidereal = apparent_sidereal_time(jd) + lon
    moon = distance * _unit_vectors(np.array(ra), np.array(dec)) - _observer_vector(
        local_sidereal, lat
    )
    sun_ra, sun_dec, sun_distance = sun_equatorial(jde)
    azimuth, elevation, ra, dec = _horizontal(moon, local_sidereal, lat)
    if refraction:
        elevation = elevation + float(_refraction(elevation))
    topocentric = float(np.linalg.norm(moon))
    phase = phase_angle(sun_ra, sun_dec, sun_distance, ra, dec, topocentric)
    return MoonState(
        azimuth=azimuth,
        elevation=elevation,
        distance_km=topocentric,
        angular_radius=math.degrees(math.asin(MOON_RADIUS_KM / topocentric)),
        phase_angle=phase,
        illuminated_fraction=(1.0 + math.cos(math.radians(phase))) / 2.0,  # Meeus Eq. 48.1
        position_angle_of_bright_limb=bright_limb_position_angle(sun_ra, sun_dec, ra, dec),
        parallactic_angle=parallactic_angle(local_sidereal - ra, dec, lat),
    )


def krisciunas_schaefer_airmass(zenith_distance: ArrayLike) -> NDArray[np.float64]:
    """Air mass of Krisciunas & Schaefer (1991), Eq. 3: X = (1 - 0.96 sin^2 Z)^(-1/2).

    Parameters
    ----------
    zenith_distance : array_like
        Z [deg], 0-90.

    Returns
    -------
    ndarray
        X [1]: 1 at the zenith, 5 at the horizon.
    """
    z = np.radians(np.asarray(zenith_distance, dtype=float))
    return 1.0 / np.sqrt(1.0 - 0.96 * np.sin(z) ** 2)


def krisciunas_schaefer(
    separation: ArrayLike,
    zenith_distance: ArrayLike,
    moon_zenith_distance: float,
    phase_angle: float,
    *,
    extinction_coefficient: float = 0.172,
) -> NDArray[np.float64]:
    """Sky luminance of scattered moonlight, Krisciunas & Schaefer (1991).

    .. math::
        B_{moon} = f(\\rho)\\, I^*\\, 10^{-0.4 k X(Z_m)} \\left[1 - 10^{-0.4 k X(Z)}\\right]

    with the Moon's illuminance outside the atmosphere
    :math:`I^* = 10^{-0.4 (3.84 + 0.026 |\\alpha| + 4 \\times 10^{-9} \\alpha^4)}` (Eq. 20)
    and the scattering function
    :math:`f(\\rho) = 10^{5.36} (1.06 + \\cos^2\\rho) + 10^{6.15 - \\rho / 40}` (Eq. 21), which
    gives B in nanolamberts (Eq. 15).

    Parameters
    ----------
    separation : array_like
        rho, angle between the sky point and the Moon [deg]. Eq. 21 was fitted for
        rho >= 10 deg; closer to the Moon it is an extrapolation.
    zenith_distance : array_like
        Z of the sky point [deg], 0-90.
    moon_zenith_distance : float
        Z_m of the Moon [deg], 0-90.
    phase_angle : float
        alpha, the Moon's phase angle [deg] (0 full, 180 new).
    extinction_coefficient : float, optional
        k, V-band extinction [mag per air mass]; 0.172 at Mauna Kea (the paper's value).

    Returns
    -------
    ndarray
        Luminance of the moonlit sky, V band [cd m-2] (1 nL = 1e-5 / pi cd m-2).

    References
    ----------
    1. Krisciunas & Schaefer 1991, Eqs. 3, 15, 20, 21.
    """
    if not math.isfinite(extinction_coefficient) or extinction_coefficient < 0:
        raise InputError(
            f"extinction_coefficient={extinction_coefficient!r}; expected k >= 0 mag per air mass"
        )
    rho = np.radians(np.asarray(separation, dtype=float))
    alpha = abs(phase_angle)
    illuminance = 10.0 ** (-0.4 * (3.84 + 0.026 * alpha + 4e-9 * alpha**4))  # Eq. 20 [fc]
    scattering = 10.0**5.36 * (1.06 + np.cos(rho) ** 2) + 10.0 ** (  # Eq. 21
        6.15 - np.degrees(rho) / 40.0
    )
    k = extinction_coefficient
    moon_transmission = 10.0 ** (-0.4 * k * krisciunas_schaefer_airmass(moon_zenith_distance))
    path = 1.0 - 10.0 ** (-0.4 * k * krisciunas_schaefer_airmass(zenith_distance))
    nanolamberts = scattering * illuminance * moon_transmission * path  # Eq. 15
    return np.asarray(nanolamberts * _NANOLAMBERT_CD_M2, dtype=float)


def moon_sky_brightness(
    moon: MoonState,
    elevation: ArrayLike,
    azimuth: ArrayLike,
    *,
    extinction_coefficient: float = 0.172,
) -> NDArray[np.float64]:
    """Moonlight scattered over a grid of sky directions, Krisciunas & Schaefer (1991).

    Parameters
    ----------
    moon : MoonState
        The Moon for the observer and instant (:func:`moon_state`).
    elevation, azimuth : array_like
        Sky directions [deg] (broadcast together, e.g. a panorama's (elevation, azimuth)
        grid).
    extinction_coefficient : float, optional
        V-band extinction k [mag per air mass].

    Returns
    -------
    ndarray
        Luminance of the scattered moonlight [cd m-2]; 0 everywhere while the Moon is below
        the horizon, NaN at directions below the horizon.

    References
    ----------
    1. Krisciunas & Schaefer 1991, Eq. 15 (see :func:`krisciunas_schaefer`).

    Examples
    --------
    >>> moon = MoonState(180.0, 45.0, 384400.0, 0.259, 0.0, 1.0, 90.0)
    >>> sky = moon_sky_brightness(moon, [90.0, 45.0], [0.0, 0.0])
    >>> bool(sky[0] > sky[1] > 0)
    True
    """
    el = np.asarray(elevation, dtype=float)
    az = np.asarray(azimuth, dtype=float)
    el, az = np.broadcast_arrays(el, az)
    moon_dir = _unit_vectors(np.array(moon.azimuth), np.array(moon.elevation))
    sky_dir = _unit_vectors(az, el)
    cos_rho = np.clip(sky_dir @ moon_dir, -1.0, 1.0)
    below = el < 0.0
    zenith = 90.0 - np.clip(el, 0.0, 90.0)
    if moon.elevation < 0.0:
        luminance = np.zeros(el.shape)
    else:
        luminance = krisciunas_schaefer(
            np.degrees(np.arccos(cos_rho)),
            zenith,
            90.0 - min(moon.elevation, 90.0),
            moon.phase_angle,
            extinction_coefficient=extinction_coefficient,
        )
    return np.where(below, np.nan, luminance)
