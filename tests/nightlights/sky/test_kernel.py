"""Single-scattering kernel: analytic cases, symmetry, physical trends, quadrature convergence."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.special import sici

from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.kernel import emission_intensity, sky_luminance
from nightlights.sky.spec import panorama_elevations

AOD = 0.1


def _exact_atmosphere(scale_height: float) -> Atmosphere:
    """No extinction, isotropic phase (HG with g = 0), flat Earth, one exponential species."""
    return Atmosphere(
        rayleigh_optical_depth=0.0,
        aerosol_optical_depth=AOD,
        aerosol_scale_height=scale_height,
        asymmetry=0.0,
        flat_earth=True,
        extinction=False,
    )


def _auxiliary_f(z: np.ndarray) -> np.ndarray:
    si, ci = sici(z)
    return ci * np.sin(z) - (si - math.pi / 2.0) * np.cos(z)


@pytest.mark.parametrize("scale_height", [8000.0, 1200.0])
def test_zenith_of_point_source_matches_exact_solution(scale_height: float) -> None:
    """Validation (1).

    Zenith ray z >= 0 above the observer, isotropic source (1/(2 pi) cd per lm upwards) at
    ground distance D, scattering coefficient sigma0 exp(-z/H), isotropic phase 1/(4 pi):
    L = sigma0 / (8 pi^2) int_0^inf exp(-z/H) / (D^2 + z^2) dz = sigma0 f(D/H) / (8 pi^2 D),
    f(x) = Ci(x) sin x - (Si(x) - pi/2) cos x (Abramowitz & Stegun 5.2.12 / 5.2.13).
    Tolerance 0.5 % from D = 0.5 to 200 km; the kernel reaches ~3e-6.
    """
    atm = _exact_atmosphere(scale_height)
    distance = np.geomspace(500.0, 200_000.0, 15)
    b = sky_luminance(90.0, 0.0, distance, atmosphere=atm, emission="isotropic")
    sigma0 = AOD / scale_height
    exact = sigma0 * _auxiliary_f(distance / scale_height) / (8.0 * math.pi**2 * distance)
    np.testing.assert_allclose(b, exact, rtol=5e-3)
    np.testing.assert_allclose(b, exact, rtol=2e-5)  # what the quadrature actually reaches


@settings(max_examples=20, deadline=None)
@given(st.floats(0.2, 5.0), st.floats(1000.0, 50_000.0))
def test_exact_case_scales_as_inverse_square_of_lengths(factor: float, distance: float) -> None:
    # with sigma0 = AOD / H, scaling D and H by k scales the luminance by 1 / k^2
    one = sky_luminance(
        90.0, 0.0, distance, atmosphere=_exact_atmosphere(2000.0), emission="isotropic"
    )
    scaled = sky_luminance(
        90.0,
        0.0,
        distance * factor,
        atmosphere=_exact_atmosphere(2000.0 * factor),
        emission="isotropic",
        core_radius=factor,
    )
    assert scaled == pytest.approx(one / factor**2, rel=1e-6)


@settings(max_examples=30, deadline=None)
@given(
    st.floats(1.0, 89.0),
    st.floats(0.0, 180.0),
    st.floats(50.0, 200_000.0),
    st.sampled_from([0.0, 300.0]),
    st.sampled_from([0.0, 800.0]),
)
def test_images_symmetric_about_the_source_direction(
    elevation: float, azimuth: float, distance: float, h_c: float, h_o: float
) -> None:
    # validation (3): +a and -a identical
    b = sky_luminance(
        elevation,
        [azimuth, -azimuth, 360.0 - azimuth],
        distance,
        source_altitude=h_c,
        observer_altitude=h_o,
    )
    assert b[0] >= 0
    assert b[1] == pytest.approx(b[0], rel=1e-12, abs=0)
    assert b[2] == pytest.approx(b[0], rel=1e-9, abs=0)


def test_zenith_independent_of_azimuth() -> None:
    azimuth = np.linspace(0.0, 360.0, 13)
    for distance in (30.0, 3000.0, 80_000.0):
        b = sky_luminance(90.0, azimuth, distance, observer_altitude=200.0)
        np.testing.assert_allclose(b, b[0], rtol=1e-9)


def _disc_exponent(atmosphere: Atmosphere, emission: str) -> float:
    """Exponent of the zenith glow of a uniform lit plane from beyond radius d, 10-100 km."""
    distance = np.geomspace(1e3, 1e6, 121)
    b = sky_luminance(90.0, 0.0, distance, atmosphere=atmosphere, emission=emission)
    per_log = b * 2.0 * math.pi * distance**2  # flux per unit ln(r) of a uniform disc
    seg = 0.5 * (per_log[1:] + per_log[:-1]) * np.diff(np.log(distance))
    beyond = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])
    sel = (distance >= 1e4) & (distance <= 1e5)
    return float(np.polyfit(np.log(distance[sel]), np.log(beyond[sel]), 1)[0])


def test_uniform_disc_tail_exponents_order_with_the_physics() -> None:
    """The zenith glow of a uniform lit plane from sources beyond radius d, fitted over
    d = 10-100 km (spherical Earth), falls as d^n.

    Validated against Garstang's published model, reconstructed independently, in
    ``test_garstang.py`` (``test_uniform_disc_tail_exponent_matches_garstang``: within 0.15 in n
    for K = 0.5 and 1). Here the trends every atmosphere must show: extinction and more aerosol
    steepen the tail (no extinction, then turbidity 1, then 2), and the low-angle uplight lobe,
    whose light travels farther, has a shallower tail than the Lambertian source.

    This is not Walker's law, which concerns one source seen 45 deg up towards it
    (``test_validation_slopes.py``).
    """
    atmospheres = (Atmosphere(extinction=False), Atmosphere(turbidity=1.0), Atmosphere())
    exponents = {
        emission: [_disc_exponent(atmosphere, emission) for atmosphere in atmospheres]
        for emission in ("uplight", "lambertian")
    }
    for values in exponents.values():
        assert values[0] > values[1] > values[2]
        assert all(-2.0 < value < -0.3 for value in values)
    assert all(
        up > lam for up, lam in zip(exponents["uplight"], exponents["lambertian"], strict=True)
    )


def test_turbidity_brightens_near_and_darkens_far() -> None:
    # validation (5): more aerosol = more scattering near the source, more extinction far away
    distance = np.array([300.0, 1000.0, 10_000.0, 30_000.0, 100_000.0])
    for emission in ("lambertian", "uplight"):
        clear = sky_luminance(
            90.0, 0.0, distance, atmosphere=Atmosphere(turbidity=2.0), emission=emission
        )
        hazy = sky_luminance(
            90.0, 0.0, distance, atmosphere=Atmosphere(turbidity=5.0), emission=emission
        )
        ratio = hazy / clear
        assert ratio[0] > 1.3 and ratio[1] > 1.1
        assert np.all(ratio[2:] < 0.5)
        assert np.all(np.diff(ratio) < 0)


def test_spherical_and_flat_earth() -> None:
    # validation (6): same nearby, the sphere darkens distant sources (below the tangent plane)
    distance = np.array([300.0, 1000.0, 3000.0, 50_000.0, 100_000.0, 200_000.0])
    for elevation in (90.0, 10.0):
        sphere = sky_luminance(elevation, 0.0, distance)
        flat = sky_luminance(elevation, 0.0, distance, atmosphere=Atmosphere(flat_earth=True))
        ratio = sphere / flat
        np.testing.assert_allclose(ratio[:3], 1.0, rtol=3e-3)
        assert ratio[3] < 0.99 and ratio[4] < 0.95 and ratio[5] < 0.8
        assert np.all(np.diff(ratio) < 0)


def test_quadrature_converges_with_nodes() -> None:
    """16-32 Gauss nodes per panel against 256 (1e-5 relative, Dobashi et al. 2023, Sec. 3.2).

    Sources 100 m to 300 km, observer and source at 0 or 500 m, 16 x 9 directions: 32 nodes
    reach 1e-5 relative everywhere, 16 nodes in the median; nearer sources (observer next to
    a lit cell) converge more slowly (~1e-3 at 16 nodes, 10 m away at 3 deg elevation).
    """
    el = panorama_elevations(16)[:, None, None]
    az = np.linspace(0.0, 180.0, 9)[None, :, None]
    distance = np.geomspace(100.0, 3e5, 8)[None, None, :]
    for h_c, h_o in ((0.0, 0.0), (500.0, 0.0), (0.0, 500.0)):
        kw = {"source_altitude": h_c, "observer_altitude": h_o}
        ref = sky_luminance(el, az, distance, nodes=256, **kw)
        lit = ref > 0  # rays entirely below a distant source's tangent plane see nothing
        assert lit.mean() > 0.95
        err32 = np.abs(sky_luminance(el, az, distance, nodes=32, **kw)[lit] / ref[lit] - 1.0)
        err16 = np.abs(sky_luminance(el, az, distance, nodes=16, **kw)[lit] / ref[lit] - 1.0)
        assert err32.max() < 1e-5
        assert np.median(err16) < 1e-5
        assert err16.max() < 1e-3


@pytest.mark.parametrize("model", ["lambertian", "uplight", "isotropic"])
def test_emission_models_emit_one_lumen_upwards(model: str) -> None:
    flux = 2.0 * math.pi * quad(lambda mu: float(emission_intensity(mu, model)), 0.0, 1.0)[0]
    assert flux == pytest.approx(1.0, rel=1e-9)
    assert float(emission_intensity(-0.3, model)) == 0.0


def test_uplight_lobe_peaks_at_the_horizon() -> None:
    mu = np.cos(np.radians([0.0, 45.0, 80.0, 89.0]))
    intensity = emission_intensity(mu, "uplight")
    assert intensity[0] == 0.0
    assert np.all(np.diff(intensity) > 0)
    # Lambertian peaks at the zenith instead
    assert np.all(np.diff(emission_intensity(mu, "lambertian")) < 0)


def test_ray_through_the_source_is_finite_and_softening_is_local() -> None:
    # source 500 m straight above the observer: the zenith ray passes through it
    through = sky_luminance(90.0, 0.0, 0.0, source_altitude=500.0)
    assert np.isfinite(through) and through > 0
    wider = sky_luminance(90.0, 0.0, 0.0, source_altitude=500.0, core_radius=2.0)
    assert wider < through  # the softened peak scales as 1 / r0
    # beyond 100 m the softening radius changes nothing measurable
    far = [sky_luminance(60.0, 0.0, 1000.0, core_radius=r0) for r0 in (0.5, 1.0, 2.0)]
    assert far[0] == pytest.approx(far[2], rel=1e-5)


def test_rays_at_or_below_the_horizon_are_dark() -> None:
    b = sky_luminance([0.0, -5.0, 5.0], 0.0, 1000.0)
    assert b[0] == 0.0 and b[1] == 0.0 and b[2] > 0


def test_luminance_linear_in_aerosol_amount_without_extinction() -> None:
    def lum(aod: float) -> float:
        atm = Atmosphere(rayleigh_optical_depth=0.0, aerosol_optical_depth=aod, extinction=False)
        return float(sky_luminance(45.0, 30.0, 5000.0, atmosphere=atm))

    assert lum(0.2) == pytest.approx(2.0 * lum(0.1), rel=1e-12)


def test_pure_air_and_empty_atmosphere() -> None:
    empty = Atmosphere(rayleigh_optical_depth=0.0, aerosol_optical_depth=0.0)
    assert float(sky_luminance(45.0, 0.0, 1000.0, atmosphere=empty)) == 0.0
    assert float(sky_luminance(45.0, 0.0, 1000.0, atmosphere=Atmosphere(turbidity=1.0))) > 0


def test_broadcasting_shape_and_non_negative() -> None:
    b = sky_luminance(
        np.array([10.0, 50.0])[:, None, None],
        np.array([0.0, 90.0, 180.0])[None, :, None],
        np.array([10.0, 1e3, 1e5, 1e6])[None, None, :],
    )
    assert b.shape == (2, 3, 4)
    assert np.all(b >= 0)
    assert sky_luminance(45.0, 0.0, np.zeros((0,))).shape == (0,)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"emission": "laser"}, "emission"),
        ({"nodes": 0}, "nodes"),
        ({"core_radius": 0.0}, "core_radius"),
    ],
)
def test_bad_arguments(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        sky_luminance(45.0, 0.0, 1000.0, **kwargs)


def test_negative_distance_rejected() -> None:
    with pytest.raises(InputError, match="distance"):
        sky_luminance(45.0, 0.0, -1.0)


def test_closed_form_leg_depth_matches_quadrature_along_chords() -> None:
    """slant_optical_depth (erfcx form) against 256 Gauss nodes along the exact chord."""
    from nightlights.sky.geometry import altitude
    from nightlights.sky.kernel import optical_depth, slant_optical_depth

    rng = np.random.default_rng(4)
    for atm in (Atmosphere(), Atmosphere(flat_earth=True)):
        start = np.zeros((200, 3))
        start[:, 2] = rng.uniform(0.0, 2000.0, 200)
        zenith = np.radians(rng.uniform(0.0, 89.5, 200))
        length = rng.uniform(10.0, 150_000.0, 200)
        direction = np.stack([np.sin(zenith), np.zeros(200), np.cos(zenith)], axis=-1)
        stop = start + length[:, None] * direction
        exact = optical_depth(start, stop, atm, leg_nodes=256)
        closed = slant_optical_depth(
            altitude(start, earth_radius=atm.earth_radius, flat_earth=atm.flat_earth),
            np.cos(zenith),
            length,
            atm,
        )
        np.testing.assert_allclose(closed, exact, rtol=1e-4, atol=1e-9)


@pytest.mark.parametrize(
    ("elevation", "azimuth", "distance", "h_c"),
    [(30.0, 20.0, 2000.0, 0.0), (5.0, 0.0, 20_000.0, 0.0), (60.0, 150.0, 500.0, 100.0)],
)
def test_substitution_quadrature_matches_adaptive_integration(
    elevation: float, azimuth: float, distance: float, h_c: float
) -> None:
    """The tan-substituted Gauss rule against scipy.integrate.quad on the same integrand."""
    from nightlights.sky.geometry import ray_exit_distance
    from nightlights.sky.kernel import line_of_sight_integrand

    atm = Atmosphere()
    top = float(
        ray_exit_distance(
            elevation, 0.0, atm.top_altitude, earth_radius=atm.earth_radius, flat_earth=False
        )
    )
    closest = distance * math.cos(math.radians(elevation)) * math.cos(math.radians(azimuth))
    breaks = sorted({max(closest, 1.0), 10 * max(closest, 1.0), 1e4, 1e5})
    breaks = [b for b in breaks if b < top]

    def f(u: float) -> float:
        return float(
            line_of_sight_integrand(
                u, elevation, azimuth, distance, source_altitude=h_c, atmosphere=atm
            )
        )

    edges = [0.0, *breaks, top]
    reference = sum(
        quad(f, a, b, limit=400, epsabs=0.0, epsrel=1e-10)[0] for a, b in itertools.pairwise(edges)
    )
    value = float(sky_luminance(elevation, azimuth, distance, source_altitude=h_c, nodes=32))
    assert value == pytest.approx(reference, rel=1e-6)


def test_sources_far_below_the_horizon_fade_out() -> None:
    """Where the method stops mattering: a source 1000 km away sits ~80 km below the
    observer's tangent plane; only rays high in the thin upper atmosphere see its light."""
    near, far = sky_luminance(90.0, 0.0, [100_000.0, 1_000_000.0])
    assert 0 < far < 1e-6 * near
    flat_far = float(sky_luminance(90.0, 0.0, 1_000_000.0, atmosphere=Atmosphere(flat_earth=True)))
    assert far < 1e-3 * flat_far
