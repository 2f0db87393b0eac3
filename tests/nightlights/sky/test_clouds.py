"""The cloudy-sky model against hand calculations, flux closure and its Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from affine import Affine
from scipy.special import expn

from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import (
    CloudLayer,
    cloud_luminance,
    cloud_profiles,
    disc_luminance,
    flux_budget,
    forward_share,
    transport_depth,
    two_stream_reflectance,
)
from nightlights.sky.clouds_montecarlo import cloudy_monte_carlo
from nightlights.sky.cloudy import cloud_cover_at

#: Air that neither scatters nor absorbs.
NO_AIR = Atmosphere(flat_earth=True, rayleigh_optical_depth=0.0, aerosol_optical_depth=0.0)
AIR = Atmosphere(flat_earth=True)


def test_two_stream_reflectance_by_hand() -> None:
    # (1 - g) tau / (2 + (1 - g) tau) with g = 0.85, tau = 20: 3 / 5
    assert float(two_stream_reflectance(20.0, 0.85)) == pytest.approx(0.6)
    deck = CloudLayer(1000.0, optical_depth=20.0)
    assert deck.reflectance + deck.transmittance == pytest.approx(1.0)
    assert CloudLayer(1000.0, albedo=0.3).reflectance == 0.3


def test_forward_share_of_henyey_greenstein_by_quadrature() -> None:
    g = 0.7
    mu = np.linspace(0.0, 1.0, 20001)
    p = 0.5 * (1 - g * g) / (1 + g * g - 2 * g * mu) ** 1.5  # per unit mu, all azimuths
    assert forward_share(g) == pytest.approx(float(np.trapezoid(p, mu)), rel=1e-6)


@pytest.mark.parametrize(
    ("keywords", "match"),
    [
        ({"base_height": -100.0}, "base_height"),
        ({"base_height": 0.0}, "base_height"),
        ({"base_height": 1000.0, "cover": 1.5}, "cover"),
        ({"base_height": 1000.0, "cover": -0.1}, "cover"),
        ({"base_height": 1000.0, "albedo": 1.2}, "albedo"),
        ({"base_height": 1000.0, "ground_albedo": -0.2}, "ground_albedo"),
        ({"base_height": 1000.0, "optical_depth": -1.0}, "optical_depth"),
    ],
)
def test_bad_decks_are_refused(keywords: dict[str, float], match: str) -> None:
    with pytest.raises(InputError, match=match):
        CloudLayer(**keywords)


def test_a_base_below_the_terrain_is_refused() -> None:
    deck = CloudLayer(500.0)
    deck.check_terrain(100.0, 550.0)  # base at 600 m, above a 550 m hill
    with pytest.raises(InputError, match="below the terrain"):
        deck.check_terrain(100.0, 700.0)


def test_cover_raster_is_read_at_the_observer() -> None:
    cover = Raster(np.array([[[0.2, 0.9]]]), Affine(100, 0, 0, 0, -100, 100), "EPSG:32635")
    deck = CloudLayer(1000.0, cover_raster=cover)
    assert cloud_cover_at(deck, (150.0, 50.0)) == 0.9
    with pytest.raises(InputError, match="cover_raster"):
        cloud_cover_at(deck, (500.0, 50.0))


def test_natural_sky_factors() -> None:
    deck = CloudLayer(1000.0, albedo=0.6, cover=0.5)
    assert deck.natural_sky_factor() == pytest.approx(1 - 0.5 * 0.6)
    assert deck.stars_factor() == pytest.approx(0.5)


def test_cloud_base_without_air_is_the_lambertian_reflection_by_hand() -> None:
    # no ground reflection: M_c = R cos^2 / (pi d^2), seen as M_c / pi
    deck = CloudLayer(1000.0, albedo=0.5, ground_albedo=0.0)
    r = 3000.0
    d2 = r * r + 1e6
    expected = 0.5 * (1e6 / d2) / (math.pi * d2) / math.pi
    terms = cloud_luminance(90.0, 0.0, r, deck, NO_AIR, terms=True)
    assert float(terms["cloud"]) == pytest.approx(expected, rel=1e-9)
    assert float(terms["air"]) == 0.0


@pytest.mark.parametrize("albedo", [1.0, 0.6])
def test_flux_closure_of_the_analytic_model(albedo: float) -> None:
    # uniform plane: the series 1 / (1 - R A_g); escaping + ground-absorbed = emitted
    deck = CloudLayer(1000.0, albedo=albedo, ground_albedo=0.3)
    budget = flux_budget(deck, NO_AIR)
    assert budget["to_cloud"] == pytest.approx(1.0 / (1.0 - albedo * 0.3), rel=0.01)
    assert budget["escaping"] + budget["ground_absorbed"] == pytest.approx(1.0, abs=0.01)


def test_uniform_plane_series_with_air_by_hand() -> None:
    # t = 2 E3(tau_t) for a Lambertian beam; to the base t / (1 - R A_g t^2)
    deck = CloudLayer(1000.0, albedo=0.8, ground_albedo=0.2)
    t = 2.0 * float(expn(3, transport_depth(AIR, 1000.0)))
    budget = flux_budget(deck, AIR)
    assert budget["to_cloud"] == pytest.approx(t / (1.0 - 0.8 * 0.2 * t * t), rel=0.01)


def test_profiles_integrate_to_the_plane_value() -> None:
    deck = CloudLayer(2000.0, albedo=0.7, ground_albedo=0.25)
    p = cloud_profiles(deck, NO_AIR)
    integral = float(np.trapezoid(p.exitance * 2 * np.pi * p.rho, p.rho))
    assert integral == pytest.approx(0.7 / (1 - 0.7 * 0.25), rel=0.01)


@pytest.mark.parametrize("albedo", [1.0, 0.6])
def test_flux_closure_of_the_monte_carlo(albedo: float) -> None:
    # non-absorbing air and deck: escaping + ground-absorbed = emitted
    deck = CloudLayer(1000.0, albedo=albedo, ground_albedo=0.3)
    atmosphere = Atmosphere(flat_earth=True, turbidity=4.0)
    mc = cloudy_monte_carlo(90.0, 0.0, 1000.0, deck, atmosphere=atmosphere, photons=3000, seed=2)
    flux = mc.flux
    assert flux["air_absorbed"] == 0.0 and flux["cloud_absorbed"] == 0.0
    total = flux["escaping"] + flux["ground_absorbed"] + flux["in_flight"]
    assert total == pytest.approx(1.0, abs=0.01)
    # without air the escaping share is T / (1 - R A_g) by hand
    plain = cloudy_monte_carlo(90.0, 0.0, 1000.0, deck, atmosphere=NO_AIR, photons=1, seed=0)
    assert plain.flux["escaping"] == pytest.approx((1 - albedo) / (1 - albedo * 0.3), abs=5e-3)


def test_monte_carlo_without_air_is_the_lambertian_reflection_by_hand() -> None:
    deck = CloudLayer(1000.0, albedo=0.5, ground_albedo=0.0)
    r = 3000.0
    d2 = r * r + 1e6
    expected = 0.5 * (1e6 / d2) / (math.pi * d2) / math.pi
    mc = cloudy_monte_carlo(90.0, 0.0, r, deck, atmosphere=NO_AIR, photons=10, core_radius=1e-3)
    assert float(mc.luminance[0]) == pytest.approx(expected, rel=1e-6)


def test_analytic_model_agrees_with_monte_carlo_over_a_city() -> None:
    # a 10 km city (radius 5 km) under a 1 km deck; zenith and 45 deg towards the centre
    deck = CloudLayer(1000.0, optical_depth=15.0)
    profiles = cloud_profiles(deck, AIR)

    def point(e: np.ndarray, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        return np.asarray(cloud_luminance(e, a, r, deck, AIR, profiles=profiles))

    elevation = np.array([90.0, 45.0, 90.0, 45.0])
    distance = np.array([1e3, 1e3, 4e3, 4e3])
    mc = cloudy_monte_carlo(
        elevation, 0.0, distance, deck, atmosphere=AIR, disc_radius=5e3, photons=3000, seed=5
    )
    for i, (e, d) in enumerate(zip(elevation, distance, strict=True)):
        analytic = disc_luminance(point, float(e), 0.0, float(d), 5e3)
        assert analytic == pytest.approx(float(mc.luminance[i]), rel=0.10)
        assert float(mc.standard_error[i]) < 0.07 * float(mc.luminance[i])


def test_the_deck_brightens_the_city_sky_and_dims_it_far_away() -> None:
    # the cloud term dominates under the deck; 30 km out it falls below the clear sky's
    from nightlights.sky.kernel import sky_luminance

    deck = CloudLayer(1000.0, optical_depth=15.0)
    near = float(cloud_luminance(90.0, 0.0, 2e3, deck, AIR))
    far = float(cloud_luminance(90.0, 0.0, 30e3, deck, AIR))
    assert near > 3 * float(sky_luminance(90.0, 0.0, 2e3, atmosphere=AIR)[()])
    assert far < float(sky_luminance(90.0, 0.0, 30e3, atmosphere=AIR)[()])
