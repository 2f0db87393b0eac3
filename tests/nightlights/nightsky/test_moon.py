"""The Sun and the Moon for an observer, and the Krisciunas & Schaefer (1991) moonlight.

Validation against Meeus (1998) worked examples, against PyEphem 4.2 (libastro: ELP-based
Moon, VSOP87 Sun) at 120 random instants of 1990-2040 and latitudes -60 to +70, and against the
equations of Krisciunas & Schaefer (1991) evaluated by hand.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nightlights.errors import InputError
from nightlights.nightsky import MoonState, moon_sky_brightness, moon_state, sun_position
from nightlights.nightsky.astro import mean_obliquity, nutation
from nightlights.nightsky.moon import (
    bright_limb_position_angle,
    krisciunas_schaefer,
    krisciunas_schaefer_airmass,
    moon_ecliptic_position,
    parallactic_angle,
    phase_angle,
    sun_equatorial,
)

ephem = pytest.importorskip("ephem")

# --- Meeus (1998) worked examples -------------------------------------------------------------


def test_moon_meeus_47a() -> None:
    # Example 47.a: 1992 April 12.0 TD: lambda 133.162655, beta -3.229126 deg, 368409.7 km.
    # Our truncated tables (Table 47.A/B terms above 0.0007/0.001 deg) leave at most
    # 0.0060 / 0.0103 deg out; here they give 0.0008 and 0.0012 deg.
    longitude, latitude, distance = moon_ecliptic_position(2448724.5)
    assert longitude == pytest.approx(133.162655, abs=0.002)
    assert latitude == pytest.approx(-3.229126, abs=0.002)
    assert distance == pytest.approx(368409.7, abs=5.0)
    delta_psi, delta_eps = nutation(2448724.5)
    assert delta_psi == pytest.approx(0.004610, abs=2e-5)  # Meeus: apparent lambda 133.167265
    assert mean_obliquity(2448724.5) + delta_eps == pytest.approx(23.440636, abs=2e-5)


def test_sun_meeus_25a() -> None:
    # Example 25.a: 1992 October 13.0 TD: apparent RA 198.38083, Dec -7.78507 deg, R 0.99766 au
    ra, dec, distance = sun_equatorial(2448908.5)
    assert ra == pytest.approx(198.38083, abs=1e-4)
    assert dec == pytest.approx(-7.78507, abs=1e-4)
    assert distance / 149_597_870.7 == pytest.approx(0.99766, abs=1e-5)


def test_phase_and_bright_limb_meeus_48a() -> None:
    # Example 48.a: Moon 134.6885, +13.7684 deg, 368410 km; Sun 20.6579, +8.6964 deg,
    # 149971520 km: i = 69.0756 deg, k = 0.6786, chi = 285.0 deg
    i = phase_angle(20.6579, 8.6964, 149971520.0, 134.6885, 13.7684, 368410.0)
    assert i == pytest.approx(69.0756, abs=1e-3)
    assert (1 + math.cos(math.radians(i))) / 2 == pytest.approx(0.6786, abs=1e-4)
    chi = bright_limb_position_angle(20.6579, 8.6964, 134.6885, 13.7684)
    assert chi == pytest.approx(285.0, abs=0.05)


def test_parallactic_angle_is_the_zenith_direction() -> None:
    # q is the position angle (from north through east) of the zenith seen at the body:
    # step from the body toward the zenith and read the step's position angle
    lat = 52.0
    for hour_angle, dec in [(-40.0, 10.0), (30.0, -20.0), (100.0, 60.0), (0.0, 20.0)]:
        h, d, phi = map(math.radians, (hour_angle, dec, lat))
        body = np.array([math.cos(d) * math.cos(-h), math.cos(d) * math.sin(-h), math.sin(d)])
        zenith = np.array([math.cos(phi), 0.0, math.sin(phi)])  # hour angle 0
        north = np.array([0.0, 0.0, 1.0]) - body * body[2]
        east = np.cross(np.array([0.0, 0.0, 1.0]), body)
        toward = zenith - body * float(zenith @ body)
        expected = math.degrees(
            math.atan2(
                float(toward @ east) / np.linalg.norm(east),
                float(toward @ north) / np.linalg.norm(north),
            )
        )
        assert parallactic_angle(hour_angle, dec, lat) == pytest.approx(expected, abs=1e-9)


# --- against PyEphem --------------------------------------------------------------------------


def _instants(n: int) -> list[tuple[datetime, float, float]]:
    rng = np.random.default_rng(1991)
    start = datetime(1990, 1, 1, tzinfo=UTC)
    return [
        (
            start + timedelta(days=float(rng.uniform(0, 50 * 365.25))),
            float(rng.uniform(-180, 180)),
            float(rng.uniform(-60, 70)),
        )
        for _ in range(n)
    ]


def _observer(when: datetime, lon: float, lat: float, refract: bool) -> Any:
    observer = ephem.Observer()
    observer.lon, observer.lat = math.radians(lon), math.radians(lat)
    observer.elevation = 0.0
    observer.date = ephem.Date(when.replace(tzinfo=None))
    observer.pressure = 1010.0 if refract else 0.0
    observer.temp = 10.0
    return observer


def _separation(az1: float, el1: float, az2: float, el2: float) -> float:
    a1, e1, a2, e2 = map(math.radians, (az1, el1, az2, el2))
    cos = math.sin(e1) * math.sin(e2) + math.cos(e1) * math.cos(e2) * math.cos(a1 - a2)
    return math.degrees(math.acos(min(1.0, max(-1.0, cos))))


def test_moon_and_sun_agree_with_ephem() -> None:
    # measured over these 120 instants: Moon 0.007 deg (airless), fraction 0.008,
    # radius 0.15 %, Sun 0.011 deg
    worst = {"moon": 0.0, "moon_refracted": 0.0, "fraction": 0.0, "radius": 0.0, "sun": 0.0}
    for when, lon, lat in _instants(120):
        airless = _observer(when, lon, lat, refract=False)
        moon, sun = ephem.Moon(airless), ephem.Sun(airless)
        state = moon_state(when, lon, lat, refraction=False)
        ref = (math.degrees(moon.az), math.degrees(moon.alt))
        worst["moon"] = max(worst["moon"], _separation(state.azimuth, state.elevation, *ref))
        worst["fraction"] = max(
            worst["fraction"], abs(state.illuminated_fraction - moon.moon_phase)
        )
        worst["radius"] = max(worst["radius"], abs(2 * state.angular_radius * 3600 / moon.size - 1))
        az, el = sun_position(when, lon, lat)
        sun_ref = (math.degrees(sun.az), math.degrees(sun.alt))
        worst["sun"] = max(worst["sun"], _separation(az, el, *sun_ref))
        refracted = ephem.Moon(_observer(when, lon, lat, refract=True))
        if math.degrees(refracted.alt) > 5.0:
            state = moon_state(when, lon, lat)
            ref = (math.degrees(refracted.az), math.degrees(refracted.alt))
            worst["moon_refracted"] = max(
                worst["moon_refracted"], _separation(state.azimuth, state.elevation, *ref)
            )
    assert worst["moon"] < 0.3 and worst["moon_refracted"] < 0.3
    assert worst["fraction"] < 0.02
    assert worst["radius"] < 0.01
    assert worst["sun"] < 0.02


def test_full_and_new_moon() -> None:
    # 2024 January 25, 17:54 UTC full Moon; January 11, 11:57 UTC new Moon (USNO)
    full = moon_state("2024-01-25T17:54:00Z", 24.94, 60.17)
    new = moon_state("2024-01-11T11:57:00Z", 24.94, 60.17)
    assert full.illuminated_fraction > 0.99 and full.phase_angle < 10
    assert new.illuminated_fraction < 0.01 and new.phase_angle > 170
    assert 0.24 < full.angular_radius < 0.28 and 356_000 < full.distance_km < 407_000


def test_bad_site_is_refused() -> None:
    with pytest.raises(InputError, match="lat="):
        moon_state("2024-01-25T17:54:00Z", 24.94, 95.0)
    with pytest.raises(InputError, match="lon="):
        sun_position("2024-01-25T17:54:00Z", float("nan"), 60.0)


# --- Krisciunas & Schaefer (1991) -------------------------------------------------------------


def test_krisciunas_schaefer_by_hand() -> None:
    # Eqs. 15, 20, 21, 3 at rho = 90, Z = Z_m = 0, alpha = 0, k = 0.172:
    # f = 10^5.36 * 1.06 + 10^3.90 = 250,775; I* = 10^-1.536 = 0.029107 fc;
    # 10^(-0.4 * 0.172) = 0.853372; B = f I* 0.853372 (1 - 0.853372) = 913.4 nL
    nanolamberts = 913.4
    luminance = float(krisciunas_schaefer(90.0, 0.0, 0.0, 0.0))
    assert luminance == pytest.approx(nanolamberts * 1e-5 / math.pi, rel=1e-3)
    # about 18.9 V mag arcsec-2 with m = -2.5 log10(L / 1.08e5)
    assert -2.5 * math.log10(luminance / 1.08e5) == pytest.approx(18.93, abs=0.01)


def test_krisciunas_schaefer_phase_and_extinction() -> None:
    # Eq. 20: quarter Moon (alpha = 90) is 10^(-0.4 (2.34 + 0.26244)) = 0.0910 of full
    full = krisciunas_schaefer(60.0, 30.0, 40.0, 0.0)
    quarter = krisciunas_schaefer(60.0, 30.0, 40.0, 90.0)
    assert float(quarter / full) == pytest.approx(10 ** (-0.4 * (2.34 + 4e-9 * 90**4)), rel=1e-9)
    assert float(krisciunas_schaefer(60.0, 30.0, 40.0, 0.0, extinction_coefficient=0.0)) == 0.0
    assert krisciunas_schaefer_airmass([0.0, 90.0]) == pytest.approx([1.0, 5.0])
    with pytest.raises(InputError, match="extinction_coefficient"):
        krisciunas_schaefer(60.0, 30.0, 40.0, 0.0, extinction_coefficient=-0.1)


def test_moon_sky_brightness_on_a_grid() -> None:
    moon = MoonState(
        azimuth=150.0,
        elevation=35.0,
        distance_km=384_400.0,
        angular_radius=0.259,
        phase_angle=20.0,
        illuminated_fraction=0.97,
        position_angle_of_bright_limb=250.0,
    )
    elevation = np.linspace(90.0, -10.0, 101)[:, None]
    azimuth = np.linspace(0.0, 360.0, 181)[None, :]
    sky = moon_sky_brightness(moon, elevation, azimuth)
    assert sky.shape == (101, 181)
    assert np.all(np.isnan(sky[elevation[:, 0] < 0]))
    above = sky[elevation[:, 0] >= 0]
    assert np.all(above > 0)
    row, col = np.unravel_index(np.nanargmax(sky), sky.shape)
    assert abs(elevation[row, 0] - 35.0) <= 1.0 and abs(azimuth[0, col] - 150.0) <= 2.0
    down = MoonState(150.0, -3.0, 384_400.0, 0.259, 20.0, 0.97, 250.0)
    assert np.all(moon_sky_brightness(down, elevation, azimuth)[elevation[:, 0] >= 0] == 0)
    assert moon_sky_brightness(moon, np.empty(0), np.empty(0)).shape == (0,)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(0.0, 360.0),
    st.floats(0.0, 90.0),
    st.floats(0.0, 180.0),
    st.floats(0.5, 179.5),
    st.floats(0.0, 89.0),
)
def test_moonlight_is_positive_and_mirror_symmetric(
    moon_az: float, moon_el: float, phase: float, offset: float, el: float
) -> None:
    # Eq. 15 depends on the sky point only through rho and Z: it is the same on both sides of
    # the Moon's vertical circle, and positive above the horizon while the Moon is up
    moon = MoonState(moon_az, moon_el, 384_400.0, 0.259, phase, 0.5, 0.0)
    sky = moon_sky_brightness(moon, [el, el], [moon_az + offset, moon_az - offset])
    assert np.all(sky > 0)
    assert sky[0] == pytest.approx(sky[1], rel=1e-9)


@pytest.mark.parametrize(
    ("when", "lon", "lat"),
    [
        ("2024-01-18T18:00:00Z", 24.94, 60.17),
        ("2024-01-30T04:00:00Z", 24.94, 60.17),
        ("2024-03-14T19:00:00Z", 151.2, -33.9),
        ("2024-03-28T02:00:00Z", -70.4, -24.6),
    ],
)
def test_bright_limb_faces_the_sun_in_the_picture(when: str, lon: float, lat: float) -> None:
    # the bright limb's midpoint lies on the great circle toward the Sun: its direction in the
    # (azimuth right, elevation up) tangent plane at the Moon is (-sin z, cos z)
    moon = moon_state(when, lon, lat, refraction=False)
    sun_az, sun_el = sun_position(when, lon, lat)

    def unit(az: float, el: float) -> np.ndarray:
        a, e = math.radians(az), math.radians(el)
        return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])

    m, s = unit(moon.azimuth, moon.elevation), unit(sun_az, sun_el)
    a, e = math.radians(moon.azimuth), math.radians(moon.elevation)
    right = np.array([-math.sin(a), math.cos(a), 0.0])
    up = np.array([-math.sin(e) * math.cos(a), -math.sin(e) * math.sin(a), math.cos(e)])
    toward_sun = s - float(s @ m) * m
    seen = math.atan2(float(toward_sun @ right), float(toward_sun @ up))
    z = math.radians(moon.position_angle_of_bright_limb - moon.parallactic_angle)
    predicted = math.atan2(-math.sin(z), math.cos(z))
    difference = (math.degrees(predicted - seen) + 180.0) % 360.0 - 180.0
    assert difference == pytest.approx(0.0, abs=1e-6)
