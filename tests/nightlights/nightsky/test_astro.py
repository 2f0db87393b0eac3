"""Time scales, sidereal time, apparent places and the horizon frame.

Validation against Meeus (1998) worked examples and against PyEphem 4.2 (libastro, an
independent implementation) for catalogue stars over 1990-2040 and latitudes -60 to +70.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import ArrayLike

from nightlights.errors import InputError
from nightlights.nightsky import load_catalog, star_positions
from nightlights.nightsky.astro import (
    airmass,
    apparent_place,
    apparent_sidereal_time,
    equatorial_to_horizontal,
    julian_date,
    mean_obliquity,
    mean_sidereal_time,
    nutation,
    precession_matrix,
    proper_motion,
    refraction,
    sun_true_longitude,
)

ephem = pytest.importorskip("ephem")


def _hms(hours: float, minutes: float, seconds: float) -> float:
    return 15.0 * (hours + minutes / 60.0 + seconds / 3600.0)


def _dms(degrees: float, minutes: float, seconds: float) -> float:
    return math.copysign(abs(degrees) + minutes / 60.0 + seconds / 3600.0, degrees)


# --- Meeus (1998) worked examples -------------------------------------------------------------


def test_julian_date_meeus_7a_and_inputs_agree() -> None:
    # Meeus Example 7.a: 1957 October 4.81 = JD 2436116.31
    expected = 2436116.31
    aware = datetime(1957, 10, 4, 19, 26, 24, tzinfo=UTC)
    assert julian_date(aware) == pytest.approx(expected, abs=1e-9)
    assert julian_date("1957-10-04T19:26:24Z") == pytest.approx(expected, abs=1e-9)
    assert julian_date("1957-10-04T19:26:24") == pytest.approx(expected, abs=1e-9)
    assert julian_date(np.datetime64("1957-10-04T19:26:24")) == pytest.approx(expected, abs=1e-9)
    helsinki = aware.astimezone(timezone(timedelta(hours=2)))
    assert julian_date(helsinki) == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize(
    "bad",
    [datetime(2024, 1, 1), "yesterday", np.datetime64("NaT"), 2451545.0],
    ids=["naive", "text", "nat", "float"],
)
def test_julian_date_refuses_bad_times(bad: object) -> None:
    with pytest.raises(InputError, match="time"):
        julian_date(bad)  # type: ignore[arg-type]


def test_sidereal_time_meeus_12a_12b() -> None:
    # Example 12.a: 1987 April 10, 0h UT: mean 13h10m46.3668s, apparent 13h10m46.1351s
    jd = 2446895.5
    assert mean_sidereal_time(jd) == pytest.approx(_hms(13, 10, 46.3668), abs=0.0001 / 240)
    apparent = apparent_sidereal_time(jd, delta_t_s=0.0)
    assert apparent == pytest.approx(_hms(13, 10, 46.1351), abs=0.001 / 240)
    # Example 12.b: 1987 April 10, 19h21m00s UT: 128.7378734 deg
    assert mean_sidereal_time(2446896.30625) == pytest.approx(128.7378734, abs=1e-6)


def test_nutation_and_obliquity_meeus_22a() -> None:
    # Example 22.a: 1987 April 10.0 TD: dpsi = -3.788", deps = +9.443", eps0 = 23d26'27.407"
    delta_psi, delta_eps = nutation(2446895.5)
    assert delta_psi * 3600 == pytest.approx(-3.788, abs=0.005)
    assert delta_eps * 3600 == pytest.approx(9.443, abs=0.005)
    assert mean_obliquity(2446895.5) == pytest.approx(_dms(23, 26, 27.407), abs=0.001 / 3600)


def test_precession_meeus_21b() -> None:
    # Example 21.b: theta Persei, mean place of J2000.0 carried by proper motion to
    # 2028 Nov 13.19 TD (2h44m12.975s, +49d13'39.90"), precessed: 2h46m11.331s, +49d20'54.54"
    ra0, dec0 = _hms(2, 44, 12.975), _dms(49, 13, 39.90)
    xyz = np.array(
        [
            math.cos(math.radians(dec0)) * math.cos(math.radians(ra0)),
            math.cos(math.radians(dec0)) * math.sin(math.radians(ra0)),
            math.sin(math.radians(dec0)),
        ]
    )
    x, y, z = precession_matrix(2462088.69) @ xyz
    assert math.degrees(math.atan2(y, x)) == pytest.approx(_hms(2, 46, 11.331), abs=0.001 / 240)
    assert math.degrees(math.asin(z)) == pytest.approx(_dms(49, 20, 54.54), abs=0.01 / 3600)
    assert np.allclose(precession_matrix(2451545.0), np.eye(3))


def test_apparent_place_meeus_23a() -> None:
    # Example 23.a: theta Persei, J2000.0 2h44m11.986s +49d13'42.48", proper motion
    # +0.03425 s/yr and -0.0895"/yr; apparent place on 2028 Nov 13.19 TD:
    # 2h46m14.390s, +49d21'07.45"
    ra0, dec0 = _hms(2, 44, 11.986), _dms(49, 13, 42.48)
    pm_ra = 0.03425 * 15 * math.cos(math.radians(dec0))  # mu_alpha cos(dec) [arcsec/yr]
    ra, dec = apparent_place(ra0, dec0, 2462088.69, pm_ra=pm_ra, pm_dec=-0.0895)
    cos_dec = math.cos(math.radians(dec0))
    assert (float(ra) - _hms(2, 46, 14.390)) * 3600 * cos_dec == pytest.approx(0, abs=0.1)
    assert (float(dec) - _dms(49, 21, 7.45)) * 3600 == pytest.approx(0, abs=0.1)


def test_proper_motion_matches_linear_motion_away_from_pole() -> None:
    # Meeus ch. 21: over a century the linear step and ours agree far from the pole (to the
    # second-order curvature of the sphere, 0.005" here)
    ra, dec = proper_motion(100.0, 10.0, 0.5, -1.0, 100.0)
    assert float(dec) == pytest.approx(10.0 - 100.0 / 3600, abs=1e-5)
    assert float(ra) == pytest.approx(100.0 + 50.0 / 3600 / math.cos(math.radians(10)), abs=1e-5)


def test_sun_longitude_meeus_25a() -> None:
    # Example 25.a: 1992 October 13.0 TD: true longitude 199.90988 deg, R = 0.99766 au
    longitude, distance = sun_true_longitude(2448908.5)
    assert longitude == pytest.approx(199.90988, abs=1e-5)
    assert distance == pytest.approx(0.99766, abs=1e-5)


def test_horizontal_frame_conventions() -> None:
    # on the meridian a star culminates due south (north of the zenith when dec > lat)
    az, el = equatorial_to_horizontal([0.0, 0.0, 90.0, -90.0], [30.0, 70.0, 0.0, 0.0], 50.0)
    assert np.allclose(az[:2], [180.0, 0.0], atol=1e-9)
    assert np.allclose(el[:2], [70.0, 70.0])
    # six hours west of the meridian on the equator: setting due west, on the horizon
    assert float(az[2]) == pytest.approx(270.0)
    assert float(el[2]) == pytest.approx(0.0, abs=1e-9)
    assert float(az[3]) == pytest.approx(90.0)


# --- refraction and air mass ------------------------------------------------------------------


def test_refraction_saemundsson_values() -> None:
    # Meeus ch. 16 (Eq. 16.4): at h = 0 R = 1.02'/tan(10.3/5.11 deg) = 28.98'; at 45 deg
    # 1.02'/tan(45.2056 deg) = 1.013'; scaled by P/1010 and 283/(273+T)
    assert float(refraction(0.0)) * 60 == pytest.approx(28.98, abs=0.01)
    assert float(refraction(45.0)) * 60 == pytest.approx(1.013, abs=0.001)
    assert float(refraction(10.0, pressure_hpa=505.0)) == pytest.approx(float(refraction(10.0)) / 2)
    assert float(refraction(10.0, temperature_c=-10.0)) == pytest.approx(
        float(refraction(10.0)) * 283.0 / 263.0
    )
    h = np.linspace(-10.0, 90.0, 2001)
    apparent = h + refraction(h)
    assert np.all(np.diff(apparent) > 0)  # monotonic, also below the formula's turning point
    # held below the turning point at h = sqrt(10.3) - 5.11 = -1.91 deg, at 0.744 deg
    assert refraction([-1.9, -5.0, -30.0]) == pytest.approx([0.744] * 3, abs=1e-3)
    with pytest.raises(InputError, match="pressure_hpa"):
        refraction(10.0, pressure_hpa=-1.0)


def test_refraction_inverts_bennett() -> None:
    # Bennett 1982 (Meeus Eq. 16.3) gives R from the apparent elevation h0:
    # R = 1'/tan(h0 + 7.31/(h0 + 4.4)); Saemundsson built his formula as its inverse.
    h = np.linspace(0.0, 90.0, 901)
    saemundsson = refraction(h) * 60.0
    h0 = h + saemundsson / 60.0
    bennett = 1.0 / np.tan(np.radians(h0 + 7.31 / (h0 + 4.4)))
    assert np.max(np.abs(bennett - saemundsson)) < 0.062


def test_airmass_kasten_young() -> None:
    # Kasten & Young 1989, Eq. 3: X(90) = 1 (0.9997), X(30) = 1.9943, X(0) = 37.92
    x = airmass([90.0, 30.0, 0.0, -1.0])
    assert x[:3] == pytest.approx([0.9997, 1.9943, 37.920], abs=1e-3)
    assert np.isnan(x[3])
    assert airmass(np.zeros((2, 0))).shape == (2, 0)


# --- against PyEphem --------------------------------------------------------------------------

TIMES = [
    datetime(1990, 3, 21, 22, 0, tzinfo=UTC),
    datetime(2003, 8, 27, 3, 30, tzinfo=UTC),
    datetime(2024, 1, 15, 22, 0, tzinfo=UTC),
    datetime(2040, 11, 2, 18, 45, tzinfo=UTC),
]
SITES = [
    (24.94, 60.17),
    (-70.4, -24.6),
    (151.2, -33.9),
    (18.9, 69.6),
    (-155.5, 19.8),
    (-45.0, -60.0),
]


def _ephem_altaz(
    stars_ra: np.ndarray,
    stars_dec: np.ndarray,
    pm_ra: np.ndarray,
    pm_dec: np.ndarray,
    when: datetime,
    lon: float,
    lat: float,
    refract: bool,
) -> tuple[np.ndarray, np.ndarray]:
    observer = ephem.Observer()
    observer.lon, observer.lat = math.radians(lon), math.radians(lat)
    observer.elevation = 0.0
    observer.date = ephem.Date(when.replace(tzinfo=None))
    observer.pressure = 1010.0 if refract else 0.0
    observer.temp = 10.0
    az, alt = [], []
    for ra, dec, pa, pd in zip(stars_ra, stars_dec, pm_ra, pm_dec, strict=True):
        body = ephem.FixedBody()
        body._ra, body._dec = math.radians(ra), math.radians(dec)
        body._epoch = ephem.J2000
        # libastro's proper motion in RA is mu_alpha cos(dec), in mas/yr
        body._pmra, body._pmdec = pa * 1000.0, pd * 1000.0
        body.compute(observer)
        az.append(math.degrees(body.az))
        alt.append(math.degrees(body.alt))
    return np.array(az), np.array(alt)


def _separation(az1: ArrayLike, el1: ArrayLike, az2: ArrayLike, el2: ArrayLike) -> np.ndarray:
    """Angle between two directions [deg], as atan2(|u x v|, u . v) (exact near 0 and 180)."""

    def unit(az: ArrayLike, el: ArrayLike) -> np.ndarray:
        a, e = np.radians(az), np.radians(el)
        return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)

    u, v = unit(az1, el1), unit(az2, el2)
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(u * v, axis=-1)))


@pytest.mark.parametrize("refract", [False, True], ids=["airless", "refracted"])
def test_star_positions_agree_with_ephem(refract: bool) -> None:
    # the 48 stars brighter than V = 2 at 4 times x 6 sites; measured: 0.4" airless, 20"
    # refracted (the two refraction formulas differ by that much at 0-2 deg elevation)
    catalog = load_catalog()
    bright = catalog.select(catalog.vmag < 2.0)
    worst = 0.0
    for when in TIMES:
        for lon, lat in SITES:
            az, el = star_positions(bright, when, lon, lat, refraction=refract)
            ref_az, ref_el = _ephem_altaz(
                bright.ra, bright.dec, bright.pm_ra, bright.pm_dec, when, lon, lat, refract
            )
            # above the horizon; below it libastro's refraction and Saemundsson's part ways
            visible = ref_el > 0.0
            error = _separation(az, el, ref_az, ref_el)[visible]
            worst = max(worst, float(error.max()))
    assert worst < 0.05


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-180.0, 180.0),
    st.floats(-89.0, 89.0),
    st.floats(0.0, 360.0),
    st.floats(-89.0, 89.0),
    st.floats(-89.0, 89.0),
)
def test_horizon_transform_is_a_rotation(
    hour_angle: float, dec1: float, dh: float, dec2: float, lat: float
) -> None:
    # without refraction the horizon frame is a rigid rotation of the equatorial one:
    # angular separations survive it
    az, el = equatorial_to_horizontal([hour_angle, hour_angle + dh], [dec1, dec2], lat)
    # the same angle on the equatorial sphere (hour angle runs opposite to azimuth's sense,
    # which a separation does not see)
    expected = float(_separation(hour_angle, dec1, hour_angle + dh, dec2))
    assert float(_separation(az[0], el[0], az[1], el[1])) == pytest.approx(expected, abs=1e-7)
    assert np.all((az >= 0) & (az < 360)) and np.all(np.abs(el) <= 90)
