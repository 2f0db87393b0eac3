"""Natural sky background: van Rhijn brightening, the 22 mag arcsec-2 zenith, the star density
of the Milky Way, Schaefer's twilight."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.nightsky.background import (
    NaturalSky,
    natural_sky_luminance,
    schaefer_twilight,
    starlight_density,
    twilight_phase,
    van_rhijn_factor,
)


def fibonacci_sphere(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nearly uniform directions: elevation, azimuth [deg]."""
    k = np.arange(n) + 0.5
    elevation = np.degrees(np.arcsin(1.0 - 2.0 * k / n))
    azimuth = np.mod(np.degrees(np.pi * (1.0 + 5.0**0.5) * k), 360.0)
    return elevation, azimuth


def test_van_rhijn_zenith_and_horizon() -> None:
    # Krisciunas & Schaefer 1991, Eq. 2: X = (1 - 0.96 sin^2 Z)^-1/2: 1 and 1/sqrt(0.04) = 5
    np.testing.assert_allclose(van_rhijn_factor([90.0, 0.0]), [1.0, 5.0], rtol=1e-12)


def test_natural_zenith_is_22_mag_and_brightens_toward_the_horizon() -> None:
    elevation = np.linspace(90.0, 0.0, 91)
    parts = natural_sky_luminance(elevation)
    assert luminance_to_magnitude(parts["total"][0]) == pytest.approx(22.0, abs=1e-9)
    assert parts["airglow"][0] / parts["total"][0] == pytest.approx(0.6, rel=1e-12)
    assert np.all(np.diff(parts["total"]) > 0)
    # K&S Eq. 2 for the airglow at the horizon: X = 5, extinction 10^(-0.4 k 4)
    expected = 0.6 * parts["total"][0] * 5.0 * 10 ** (-0.4 * 0.172 * 4.0)
    assert parts["airglow"][-1] == pytest.approx(expected, rel=1e-12)


def test_natural_sky_parameters() -> None:
    dark = natural_sky_luminance([90.0], sky=NaturalSky(zenith_magnitude=21.0))["total"]
    assert luminance_to_magnitude(dark[0]) == pytest.approx(21.0, abs=1e-9)
    with pytest.raises(InputError, match="airglow_fraction"):
        NaturalSky(airglow_fraction=1.5)


def test_star_density_of_a_uniform_sky_is_one() -> None:
    star_el, star_az = fibonacci_sphere(6000)
    el, az = np.meshgrid(np.linspace(0, 90, 10), np.linspace(0, 350, 36), indexing="ij")
    density = starlight_density(star_el, star_az, el, az)
    np.testing.assert_allclose(density, 1.0, atol=0.03)


def test_star_density_follows_a_band() -> None:
    star_el, star_az = fibonacci_sphere(6000)
    band = np.abs(star_az - 90.0) < 10.0  # a great circle through the zenith, east-west
    density = starlight_density(
        np.concatenate([star_el, star_el[band]]),
        np.concatenate([star_az, star_az[band]]),
        np.array([45.0, 45.0]),
        np.array([90.0, 0.0]),
    )
    assert density[0] > 1.3 > 1.0 > density[1] > 0.7


def test_twilight_fades_one_magnitude_per_degree() -> None:
    zenith = [
        float(luminance_to_magnitude(schaefer_twilight([90.0], [0.0], -h, 270.0)[0]))
        for h in (6.0, 7.0, 12.0)
    ]
    # Schaefer 1998, VISLIMIT lines 2280-2290: m grows by the depression [deg] plus
    # 2.5 log10 of the growing distance to the Sun (96, 97, 102 deg from the zenith)
    assert zenith[1] - zenith[0] == pytest.approx(1.0 + 2.5 * np.log10(97 / 96), abs=1e-9)
    assert zenith[2] - zenith[0] == pytest.approx(6.0 + 2.5 * np.log10(102 / 96), abs=1e-9)


def test_twilight_is_brightest_toward_the_sun() -> None:
    sky = schaefer_twilight([10.0, 10.0], [270.0, 90.0], -8.0, 270.0)
    assert sky[0] > 3.0 * sky[1]


def test_twilight_refuses_daylight() -> None:
    with pytest.raises(InputError, match="daylight"):
        schaefer_twilight([45.0], [0.0], 2.0, 180.0)


@pytest.mark.parametrize(
    ("sun", "phase"),
    [
        (5.0, "day"),
        (-0.5, "civil twilight"),
        (-6.5, "nautical twilight"),
        (-12.5, "astronomical twilight"),
        (-18.5, "night"),
    ],
)
def test_twilight_phase(sun: float, phase: str) -> None:
    assert twilight_phase(sun) == phase
