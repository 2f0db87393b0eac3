"""Multiple-scattering Monte Carlo: order 1 against the kernel, one photon's bookkeeping
against the numpy reference, sampling checks within 3 standard errors, flux conservation,
seeding."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.sky import _montecarlo_numba as compiled
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere
from nightlights.sky.geometry import altitude
from nightlights.sky.kernel import (
    emission_intensity,
    optical_depth,
    sky_luminance,
    slant_optical_depth,
)
from nightlights.sky.montecarlo import monte_carlo_luminance, point_source_luminance
from nightlights.sky.quadrature import gauss_legendre, tangent_panel_nodes

DISTANCES = np.array([1e3, 3e3, 10e3, 30e3, 50e3])
SPHERE = Atmosphere()
FLAT = Atmosphere(flat_earth=True)


@pytest.mark.parametrize("atmosphere", [SPHERE, FLAT], ids=["sphere", "flat"])
@pytest.mark.parametrize("emission", ["lambertian", "uplight", "garstang_lobe"])
@pytest.mark.parametrize("elevation", [90.0, 45.0])
def test_order_one_is_the_kernel(atmosphere: Atmosphere, emission: str, elevation: float) -> None:
    # order 1 takes the source as the first event of the ray-integrated estimator: the
    # kernel's integral with its nodes, so it has no variance and must agree to round-off
    # (the erfcx of the compiled kernel is tabulated: 1e-8)
    mc = monte_carlo_luminance(
        elevation, 0.0, DISTANCES, atmosphere=atmosphere, emission=emission, max_order=1
    )
    kernel = sky_luminance(elevation, 0.0, DISTANCES, atmosphere=atmosphere, emission=emission)
    np.testing.assert_allclose(mc.single, kernel, rtol=1e-7)
    assert np.all(mc.standard_error == 0.0)


def test_order_one_off_the_source_plane_and_raised() -> None:
    el, az = np.array([20.0, 60.0, 10.0]), np.array([90.0, 180.0, 30.0])
    r = np.array([5e3, 20e3, 40e3])
    kwargs = {"source_altitude": 200.0, "observer_altitude": 500.0, "emission": "isotropic"}
    mc = monte_carlo_luminance(el, az, r, max_order=1, **kwargs)  # type: ignore[arg-type]
    kernel = sky_luminance(el, az, r, **kwargs)  # type: ignore[arg-type]
    np.testing.assert_allclose(mc.single, kernel, rtol=1e-7)


def _rays(el: list[float], r: list[float], atmosphere: Atmosphere) -> np.ndarray:
    n = len(el)
    return compiled.observer_rays(
        np.array(el), np.zeros(n), np.array(r), np.zeros(n), atmosphere=atmosphere
    )


@pytest.mark.parametrize("atmosphere", [SPHERE, FLAT], ids=["sphere", "flat"])
def test_one_photon_against_numpy_reference(atmosphere: Atmosphere) -> None:
    # replay a recorded history: the optical depth between events is the sampled one, the
    # weights follow the albedo, and each event's estimate is the numpy integral
    atm = Atmosphere(
        turbidity=4.0, aerosol_albedo=0.9, flat_earth=atmosphere.flat_earth, asymmetry=0.6
    )
    el, r = [90.0, 45.0, 20.0], [10e3, 3e3, 30e3]
    rays = _rays(el, r, atm)
    params, flags = compiled.model_parameters(atm, "uplight", 1.0, 4.0, 0.0)
    x_gl, w_gl = gauss_legendre(12)
    for photon in range(200):  # the first photon that scatters at least three times
        record, tally, budget = compiled.trace_photon(7, photon, 8, rays, x_gl, w_gl, params, flags)
        if len(record) >= 3:
            break
    assert len(record) >= 3
    previous = np.array([0.0, 0.0, 0.0])
    weight = 1.0
    for k, row in enumerate(record):
        position, incoming, before, tau_star = row[:3], row[3:6], row[6], row[7]
        # the flight ended where its optical depth (Gauss-Legendre chord) reached the sample
        tau = optical_depth(previous, position, atm, leg_nodes=64)
        assert tau == pytest.approx(tau_star, rel=2e-4)
        assert before == pytest.approx(weight, rel=1e-12)
        h = float(altitude(position, earth_radius=atm.earth_radius, flat_earth=atm.flat_earth))
        sig_m = atm.molecular_extinction * math.exp(-h / atm.molecular_scale_height)
        sig_a = atm.aerosol_extinction * math.exp(-h / atm.aerosol_scale_height)
        weight = before * (sig_m + 0.9 * sig_a) / (sig_m + sig_a)
        for j in range(len(el)):
            reference = weight * point_source_luminance(
                position, incoming, el[j], 0.0, r[j], atmosphere=atm, nodes=48, leg_nodes=32
            )
            assert tally[k + 2, j] == pytest.approx(reference, rel=2e-3)
        previous = position
    assert budget.sum() == pytest.approx(1.0, rel=1e-12)


def _escape_probability(atmosphere: Atmosphere, emission: str) -> float:
    """Fraction of the flux leaving through the top unscattered: int I exp(-tau) dOmega."""
    mu, w = gauss_legendre(400)
    mu = 0.5 * (mu + 1.0)
    top = atmosphere.top_altitude
    radius = atmosphere.earth_radius
    length = np.sqrt((radius * mu) ** 2 + top * (2 * radius + top)) - radius * mu
    if atmosphere.flat_earth:
        length = top / mu
    tau = slant_optical_depth(0.0, mu, length, atmosphere)
    return float(np.sum(0.5 * w * 2 * math.pi * emission_intensity(mu, emission) * np.exp(-tau)))


@pytest.mark.parametrize("emission", ["lambertian", "uplight", "garstang_lobe"])
@pytest.mark.parametrize("atmosphere", [SPHERE, FLAT], ids=["sphere", "flat"])
def test_first_flights_within_three_standard_errors(atmosphere: Atmosphere, emission: str) -> None:
    # sampling of the emission and of the free path: with max_order = 2 a photon stops at its
    # first event, so the flux still in flight is the collided fraction
    photons = 20_000
    mc = monte_carlo_luminance(
        90.0, 0.0, 1e3, atmosphere=atmosphere, emission=emission, photons=photons, max_order=2
    )
    expected = _escape_probability(atmosphere, emission)
    escaped = mc.flux["top"] + mc.flux["ground"]
    assert mc.flux["ground"] == 0.0  # the source emits upwards from sea level
    error = math.sqrt(expected * (1 - expected) / photons)
    assert abs(escaped - expected) < 3 * error


@pytest.mark.parametrize("atmosphere", [SPHERE, FLAT], ids=["sphere", "flat"])
def test_flux_is_conserved(atmosphere: Atmosphere) -> None:
    atm = Atmosphere(turbidity=6.0, aerosol_albedo=0.8, flat_earth=atmosphere.flat_earth)
    mc = monte_carlo_luminance(45.0, 0.0, 5e3, atmosphere=atm, photons=4000, max_order=60)
    assert sum(mc.flux.values()) == pytest.approx(1.0, abs=1e-12)
    assert mc.flux["in_flight"] < 1e-3
    assert mc.flux["absorbed"] > 0 and mc.flux["ground"] > 0 and mc.flux["top"] > 0


def test_phase_sampling_within_three_standard_errors() -> None:
    # Rayleigh: <mu^2> = 2/5; Henyey-Greenstein: <mu> = g
    u = (np.arange(20_000) + 0.5) / 20_000
    rng = np.random.default_rng(3)
    u = rng.permutation(u)
    rayleigh = np.array([compiled._sample_rayleigh(x) for x in u])
    assert np.all(np.abs(rayleigh) <= 1.0 + 1e-12)
    assert np.mean(rayleigh**2) == pytest.approx(0.4, abs=3 * np.std(rayleigh**2) / 141)
    for g in (0.7, -0.3):
        hg = np.array([compiled._sample_hg(x, g) for x in rng.random(20_000)])
        assert abs(np.mean(hg) - g) < 3 * np.std(hg) / math.sqrt(hg.size)


def test_seeded_and_reproducible() -> None:
    kwargs = {"photons": 500, "max_order": 10}
    a = monte_carlo_luminance([90.0, 45.0], 0.0, 10e3, seed=11, **kwargs)  # type: ignore[arg-type]
    b = monte_carlo_luminance([90.0, 45.0], 0.0, 10e3, seed=11, **kwargs)  # type: ignore[arg-type]
    c = monte_carlo_luminance([90.0, 45.0], 0.0, 10e3, seed=12, **kwargs)  # type: ignore[arg-type]
    np.testing.assert_array_equal(a.luminance, b.luminance)
    np.testing.assert_array_equal(a.standard_error, b.standard_error)
    assert not np.array_equal(a.luminance, c.luminance)
    # the photon streams do not depend on how photons are shared among blocks (threads)
    rays = _rays([90.0], [10e3], SPHERE)
    params, flags = compiled.model_parameters(SPHERE, "lambertian", 1.0, 4.0, 0.0)
    x_gl, w_gl = gauss_legendre(12)
    one = compiled.transport(5, 300, 10, rays, x_gl, w_gl, params, flags, blocks=1)
    many = compiled.transport(5, 300, 10, rays, x_gl, w_gl, params, flags, blocks=7)
    np.testing.assert_allclose(one[0], many[0], rtol=1e-12)


def test_multiple_scattering_adds_light_with_errors() -> None:
    mc = monte_carlo_luminance([90.0, 45.0], 0.0, 10e3, photons=2000, max_order=20, seed=2)
    assert np.all(mc.ratio > 1.0)
    assert np.all(mc.ratio_standard_error > 0) and np.all(mc.ratio_standard_error < 0.2)
    assert np.all(mc.luminance >= 0)


def test_invalid_input() -> None:
    with pytest.raises(InputError, match="extinction"):
        monte_carlo_luminance(90.0, 0.0, 1e3, atmosphere=Atmosphere(extinction=False))
    with pytest.raises(InputError, match="elevation"):
        monte_carlo_luminance(0.0, 0.0, 1e3)
    with pytest.raises(InputError, match="seed"):
        monte_carlo_luminance(90.0, 0.0, 1e3, seed=-1)
    with pytest.raises(InputError, match="emission"):
        monte_carlo_luminance(90.0, 0.0, 1e3, emission="laser")


def test_turned_direction_keeps_the_scattering_angle() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if rng.random() < 0.1:
            d = np.array([0.0, 0.0, rng.choice([-1.0, 1.0])])
        mu, phi = rng.uniform(-1, 1), rng.uniform(0, 2 * math.pi)
        new = np.array(compiled._turn(*d, mu, phi))
        assert np.linalg.norm(new) == pytest.approx(1.0, abs=1e-12)
        assert float(new @ d) == pytest.approx(mu, abs=1e-9)


@pytest.mark.parametrize("emission", ["lambertian", "uplight", "garstang_lobe", "isotropic"])
def test_emission_sampling_within_three_standard_errors(emission: str) -> None:
    # the sampled emission cosines have the moments of 2 pi I(mu) dmu
    params, flags = compiled.model_parameters(SPHERE, emission, 1.0, 4.0, 0.0)
    state = compiled._seed_state(9, 0)
    mu = np.array(
        [
            compiled._sample_emission(state, int(flags[compiled._F_EMISSION]), params)
            for _ in range(20_000)
        ]
    )
    x, w = gauss_legendre(200)
    x = 0.5 * (x + 1.0)
    density = 0.5 * w * 2 * math.pi * emission_intensity(x, emission)
    assert float(np.sum(density)) == pytest.approx(1.0, rel=1e-6)
    for power in (1, 2):
        expected = float(np.sum(density * x**power))
        sample = mu**power
        assert abs(sample.mean() - expected) < 3 * sample.std() / math.sqrt(sample.size)


def _order_two_backward(
    atm: Atmosphere, elevation: float, distance: float, emission: str, directions: int
) -> tuple[float, float]:
    """Order 2 over a flat Earth by an independent route: Gauss-Legendre along the view ray,
    random directions at each node (angle from the source direction uniform in [0, pi], which
    cancels the 1 / angle peak of the singly scattered light), and at each direction the
    single-scattered radiance by Gauss-Legendre along the backward ray; numpy only."""
    rng = np.random.default_rng(0)
    el = math.radians(elevation)
    obs = np.array([-distance, 0.0, 0.0])  # the source at the origin
    v = np.array([math.cos(el), 0.0, math.sin(el)])
    top = atm.top_altitude
    u_top = top / math.sin(el)
    u_p = float(-obs @ v)
    miss = math.sqrt(float(np.sum(np.cross(-obs, v) ** 2)) + 1.0)
    split = min(max(u_p, 0.0), u_top)
    knee = min(split + max(atm.aerosol_scale_height / math.sin(el), miss), u_top)
    total = variance = 0.0
    for lo, hi in ((0.0, split), (split, knee), (knee, u_top)):
        if hi <= lo:
            continue
        for u, weight in zip(*tangent_panel_nodes(lo, hi, u_p, miss, 16), strict=True):
            p = obs + u * v
            axis = p / np.linalg.norm(p)  # from the source to the point
            e1 = np.cross(axis, [0.0, 1.0, 0.0])
            e1 /= np.linalg.norm(e1)
            e2 = np.cross(axis, e1)
            theta = rng.uniform(0, math.pi, directions)
            phi = rng.uniform(0, 2 * math.pi, directions)
            om = (  # propagation directions of the light arriving at p
                np.cos(theta)[:, None] * axis
                + (np.sin(theta) * np.cos(phi))[:, None] * e1
                + (np.sin(theta) * np.sin(phi))[:, None] * e2
            )
            dz = -om[:, 2]  # the backward ray p - t om climbs where dz > 0
            t_max = np.where(dz > 0, (top - p[2]) / np.where(dz > 0, dz, 1), p[2] / np.abs(dz))
            t_c = np.clip(om @ p, 0, t_max)  # closest approach to the source
            d_c = np.sqrt(np.sum(np.cross(p, om) ** 2, axis=1) + 1.0)
            edges = [0 * t_c, t_c, np.minimum(t_c + np.maximum(d_c, 2e3), t_max)]
            edges += [np.minimum(t_c + 2e4, t_max), t_max]
            radiance = np.zeros(directions)
            for a, b in itertools.pairwise(edges):
                t, wt = tangent_panel_nodes(a, np.maximum(a, b), t_c, d_c, 24)
                q = p - t[..., None] * om[:, None, :]
                s2 = np.sum(q * q, axis=-1)
                s = np.sqrt(s2)
                cos_q = np.einsum("ijk,ik->ij", q, om) / s
                source = atm.scattering(q[..., 2], cos_q) * emission_intensity(
                    q[..., 2] / s, emission
                )
                tau = slant_optical_depth(0.0, np.clip(q[..., 2] / s, 0, 1), s, atm)
                tau += optical_depth(q, np.broadcast_to(p, q.shape), atm)
                radiance += np.sum(wt * source / (s2 + 1.0) * np.exp(-tau), axis=1)
            pdf = 1.0 / (2 * math.pi**2 * np.sin(theta))
            sample = atm.scattering(p[2], om @ -v) * radiance / pdf
            factor = weight * math.exp(-float(slant_optical_depth(0.0, math.sin(el), u, atm)))
            total += factor * sample.mean()
            variance += factor**2 * sample.var() / directions
    return total, math.sqrt(variance)


@pytest.mark.parametrize(
    ("clarity", "emission", "elevation", "distance"),
    [(None, "lambertian", 45.0, 3e3), (1.0, "garstang_lobe", 90.0, 30e3)],
)
def test_order_two_against_backward_integral(
    clarity: float | None, emission: str, elevation: float, distance: float
) -> None:
    # the forward photons' order 2 against an independent numpy estimate, within 3 combined
    # standard errors (T = 2, and Garstang's K = 1 with its albedo 0.94 and g = 0.687)
    atm = (
        Atmosphere(flat_earth=True)
        if clarity is None
        else garstang_atmosphere(1.0, flat_earth=True)
    )
    backward, backward_se = _order_two_backward(atm, elevation, distance, emission, 128)
    mc = monte_carlo_luminance(
        elevation, 0.0, distance, atmosphere=atm, emission=emission, photons=20_000, max_order=2
    )
    forward, forward_se = mc.luminance[1, 0], mc.standard_error[1, 0]
    assert backward_se < 0.15 * backward and forward_se < 0.15 * forward
    assert abs(forward - backward) < 3 * math.hypot(forward_se, backward_se)


@pytest.mark.parametrize("atmosphere", [SPHERE, FLAT], ids=["sphere", "flat"])
@pytest.mark.parametrize(("elevation", "azimuth"), [(90.0, 0.0), (45.0, 180.0), (8.0, 0.0)])
def test_azimuthal_splitting_averages_the_event_over_its_circle(
    atmosphere: Atmosphere, elevation: float, azimuth: float
) -> None:
    # an event at a uniformly random azimuth about the source's vertical: the split estimate,
    # averaged over that azimuth and the stratification offset, is the plain estimate's
    # azimuthal average (both by midpoint quadrature); the event's circle passes the ray
    # within the window, on an arc shorter than the circle (both parts of the estimator count)
    ray = compiled.observer_rays(
        np.array([elevation]), np.array([azimuth]), np.array([5e3]), np.zeros(1), atmosphere
    )[0]
    params, flags = compiled.model_parameters(atmosphere, "lambertian", 1.0, 4.0, 0.0)
    x_gl, w_gl = gauss_legendre(12)
    s, h, radius = 5.2e3, 400.0, atmosphere.earth_radius
    z = h if atmosphere.flat_earth else math.sqrt((radius + h) ** 2 - s * s) - radius
    incoming = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])

    def event(phi: float) -> tuple[float, ...]:
        c, si = math.cos(phi), math.sin(phi)
        d = incoming
        return (s * c, s * si, z, d[0] * c - d[1] * si, d[0] * si + d[1] * c, d[2])

    phis = (np.arange(2048) + 0.5) * 2 * math.pi / 2048
    plain = np.mean(
        [
            compiled._ray_integral(
                *event(phi)[:3], False, *event(phi)[3:], ray, x_gl, w_gl, params, flags
            )
            for phi in phis
        ]
    )
    shifts = (np.arange(8) + 0.5) / 8
    split = np.mean(
        [
            compiled._event_estimate(*event(phi), ray, 1.25e3, 16, u, x_gl, w_gl, params, flags)
            for phi in phis[::4]
            for u in shifts
        ]
    )
    assert plain > 0
    assert split == pytest.approx(plain, rel=2e-3)


def test_azimuthal_splitting_keeps_the_histories_and_the_mean() -> None:
    # same histories (flux budget, events); the totals differ by less than 4 times the sum of
    # their standard errors (which bounds the paired difference's), and the split ones are the
    # less noisy
    el = np.array([90.0, 45.0, 45.0, 20.0])
    az = np.array([0.0, 0.0, 180.0, 90.0])
    r = np.array([3e3, 10e3, 20e3, 40e3])
    kwargs = {"photons": 3000, "max_order": 20, "seed": 3, "emission": "garstang_lobe"}
    plain = monte_carlo_luminance(el, az, r, **kwargs)  # type: ignore[arg-type]
    split = monte_carlo_luminance(el, az, r, split_window=0.25, **kwargs)  # type: ignore[arg-type]
    assert plain.flux == split.flux and plain.events == split.events
    np.testing.assert_array_equal(plain.single, split.single)
    bound = 4 * (plain.total_standard_error + split.total_standard_error)
    assert np.all(np.abs(split.total - plain.total) <= bound), split.total / plain.total - 1
    assert np.all(split.total_standard_error < plain.total_standard_error)


@pytest.mark.parametrize("photons", [1, 63, 130, 700])
def test_batches_do_not_change_the_numbers(monkeypatch, photons: int) -> None:
    # the histories run in batches (a Ctrl-C is raised between two); every block adds its
    # photons in the same order whatever the batch size, so the sums are bit for bit equal
    rays = _rays([90.0, 20.0], [3e3, 30e3], SPHERE)
    params, flags = compiled.model_parameters(SPHERE, "lambertian", 1.0, 4.0, 0.0)
    x_gl, w_gl = gauss_legendre(12)
    windows = np.array([750.0, 7500.0])
    runs = []
    for batch_blocks in (1, compiled.BATCH_BLOCKS, 10**6):
        monkeypatch.setattr(compiled, "BATCH_BLOCKS", batch_blocks)
        run = compiled.transport(
            7, photons, 12, rays, x_gl, w_gl, params, flags, blocks=8, windows=windows, points=4
        )
        runs.append(run)
    for run in runs[1:]:
        for got, expected in zip(run, runs[0], strict=True):
            np.testing.assert_array_equal(got, expected)
