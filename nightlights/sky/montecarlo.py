"""Multiple scattering of a ground point source by Monte Carlo: a reference for the kernel.

Photons (1 lm in all) leave a point source on the ground with the angular distribution of
:func:`nightlights.sky.kernel.emission_intensity` and travel through the same atmosphere as the
single-scattering kernel (:class:`~nightlights.sky.atmosphere.Atmosphere`: two exponentially
stratified species over a sphere or a plane, Rayleigh and Henyey-Greenstein phase functions,
aerosol albedo, the top of the model atmosphere at 16 of the largest scale heights). Free
paths are sampled by inverting the optical depth of the straight path, in the closed form of
:func:`~nightlights.sky.kernel.slant_optical_depth`; at each collision the photon keeps the
scattered fraction of its flux (sigma_s / sigma_ext), picks a species by its share of the
scattering and a new direction from its phase function. The ground is black; photons that
reach the top leave.

Estimator (ray-integrated next event). Every scattering event at Q, of order k, is a point
source of intensity w p_mix(Theta) [cd] (w its flux [lm] after the event, p_mix the phase
mixture of the species at Q); the luminance it adds to a view ray at order k + 1 is the same
line-of-sight integral as the kernel's, with that intensity and the optical depth of the chord
from Q:

.. math::
    \\Delta b_{k+1} = w \\int_0^{u_{top}} \\sigma p(\\Theta_P) \\frac{p_{mix}(\\Theta_Q)}
        {|P - Q|^2 + r_0^2} e^{-\\tau(Q \\to P) - \\tau(O \\to P)} \\, du,

integrated with Gauss-Legendre nodes after u = u_p + d tan t on three panels, as in
:func:`~nightlights.sky.kernel.sky_luminance`. Order 1 is the source itself taken as the
first event (its emission intensity, the ray clipped above its tangent plane): the kernel's
integral, without variance. A finite acceptance cone was not used: a collision at distance u
from the observer adds w p / u^2, whose second moment diverges as u -> 0 (the variance of a
point detector), and a cone wide enough to collect many collisions blurs the direction; the
ray integral has no observer singularity, and the 1 / d of a chord passing at miss distance d
from the event only gives a logarithmic growth of the variance, bounded by the softening r0.

Azimuthal splitting (optional, ``split_window``). The atmosphere is horizontally uniform and
the emission symmetric about the source's vertical, so an event rotated about that vertical by
any angle is an event of the same distribution. Far from the source the variance is carried
by rare events that pass a few hundred metres to a few kilometres from a view ray (photons
that reached the observer's neighbourhood); when the event's circle about the vertical passes
within a window of the ray (gap g, a test on the event's radius s and altitude only, not its
azimuth), the estimate is the arc A of that circle nearest the ray (arc length l from its
centre, |l| <= L), sampled at K rotations l_k = g sinh(t_k) with t_k stratified in
[-asinh(L / g), asinh(L / g)] (density 1 / sqrt(g^2 + l^2), the shape of the 1 / d peak),
plus the event itself when it lies outside the arc:

.. math::
    \\hat b = \\frac{1}{2 \\pi s} \\frac{2\\,\\mathrm{asinh}(L / g)}{K}
        \\sum_{k=1}^{K} \\sqrt{g^2 + l_k^2}\\, b(l_k) + b(\\phi_e)\\, [\\phi_e \\notin A],

whose expectation over the event's uniform azimuth phi_e and the stratification offset is the
event's own. The histories are unchanged (the offsets come from a second random stream per
photon).

One set of photon histories serves every observer distance and view direction (the atmosphere
is horizontally uniform, the emission symmetric about the source's vertical). Each photon has
its own random-number stream (SplitMix64 seeded by the seed and the photon's index), so results
do not depend on the number of threads. Standard errors are those of the mean over photons.

References
----------
[1] Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375
    (single and double scattering of city light; the benchmark compares with his factor).
[2] Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution
    for the Night Sky", ACM TOG 42(6) 219, Sec. 3.2 (the single-scattering integral).
[3] Steele, G. L., Lea, D. & Flood, C. H. 2014, "Fast splittable pseudorandom number
    generators", OOPSLA 2014 (SplitMix64).
[4] Marchuk, G. I. et al. 1980, "The Monte Carlo Methods in Atmospheric Optics", Springer
    (local and next-event estimators).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nightlights._signals import held_signals
from nightlights._typing import FloatArray
from nightlights.emission_functions import sampled_shape
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere, smallest_scale_height
from nightlights.sky.geometry import altitude
from nightlights.sky.kernel import (
    UPLIGHT_EXPONENT,
    optical_depth,
    slant_optical_depth,
)
from nightlights.sky.quadrature import gauss_legendre, tangent_panel_nodes

__all__ = [
    "MonteCarloLuminance",
    "monte_carlo_luminance",
    "point_source_luminance",
    "view_directions",
]

_DEFAULT_ATMOSPHERE = Atmosphere()


@dataclass(frozen=True)
class MonteCarloLuminance:
    """Luminance per scattering order from :func:`monte_carlo_luminance`.

    Attributes
    ----------
    luminance
        Shape ``(max_order, n_rays)``: row k - 1 is the luminance of light scattered exactly k
        times [cd m-2 lm-1].
    standard_error
        Same shape: standard error of each row (0 for order 1, which is exact) [cd m-2 lm-1].
    total
        Shape ``(n_rays,)``: all orders up to ``max_order`` [cd m-2 lm-1].
    total_standard_error
        Shape ``(n_rays,)`` [cd m-2 lm-1].
    photons
        Photon histories [1].
    seed
        Seed of the random-number streams.
    flux
        Fractions of the emitted flux that left at the top, reached the ground, were absorbed
        by aerosols, and were still in flight at ``max_order`` scatterings [1].
    events
        Scattering events in all histories [1].
    """

    luminance: FloatArray
    standard_error: FloatArray
    total: FloatArray
    total_standard_error: FloatArray
    photons: int
    seed: int
    flux: dict[str, float]
    events: int

    @property
    def single(self) -> FloatArray:
        """Order-1 luminance, shape ``(n_rays,)`` [cd m-2 lm-1]."""
        return self.luminance[0]

    @property
    def ratio(self) -> FloatArray:
        """All orders over single scattering, shape ``(n_rays,)`` [1]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.total / self.single)

    @property
    def ratio_standard_error(self) -> FloatArray:
        """Standard error of :attr:`ratio` (order 1 has none) [1]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.total_standard_error / self.single)


def view_directions(
    elevation: ArrayLike, relative_azimuth: ArrayLike, distance: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Elevations [deg], azimuths [deg] and distances [m] of the view rays, broadcast together
    and flattened; elevations outside (0, 90] deg are refused."""
    el, az, r = (
        a.ravel().astype(float)
        for a in np.broadcast_arrays(
            np.asarray(elevation, dtype=float),
            np.asarray(relative_azimuth, dtype=float),
            np.asarray(distance, dtype=float),
        )
    )
    if np.any(el <= 0) or np.any(el > 90):
        raise InputError("elevation; expected values in (0, 90] deg")
    return el, az, r


def monte_carlo_luminance(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    *,
    source_altitude: float = 0.0,
    observer_altitude: float = 0.0,
    atmosphere: Atmosphere = _DEFAULT_ATMOSPHERE,
    emission: str = "lambertian",
    photons: int = 10_000,
    max_order: int = 50,
    seed: int = 0,
    nodes: int = 24,
    event_nodes: int = 12,
    core_radius: float = 1.0,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    split_window: float = 0.0,
    split_points: int = 16,
) -> MonteCarloLuminance:
    """Sky luminance per scattering order from a ground point source, by Monte Carlo.

    The view rays are the broadcast of the three array arguments (flattened); every ray is
    estimated from the same photon histories.

    Parameters
    ----------
    elevation
        Elevation of the view ray above the horizon, > 0 [deg].
    relative_azimuth
        Azimuth of the view ray relative to the direction of the source [deg].
    distance
        Ground distance from the observer to the source (arc length at sea level) [m].
    source_altitude
        Altitude of the source above sea level [m].
    observer_altitude
        Altitude of the observer above sea level [m].
    atmosphere
        Atmosphere model; ``extinction`` must be on (scattering removes light from the beam).
    emission
        Angular distribution of the source: a registered shape of a form the Monte Carlo
        samples (:func:`~nightlights.emission_functions.sampled_shape`; the built-in
        :data:`~nightlights.sky.kernel.EMISSION_MODELS`).
    photons
        Number of photon histories [1].
    max_order
        Highest scattering order estimated; 1 gives the kernel's single scattering [1].
    seed
        Seed of the random-number streams (non-negative integer).
    nodes
        Gauss-Legendre nodes per panel of the order-1 integral (as the kernel's) [1].
    event_nodes
        Gauss-Legendre nodes per panel of each scattering event's integral [1].
    core_radius
        Softening radius r0 of the source and of each event [m].
    uplight_exponent
        Exponent of the uplight lobe [1].
    split_window
        Azimuthal splitting: an event whose circle about the source's vertical passes within
        ``split_window`` x (observer distance) of a ray is averaged over ``split_points``
        rotations on the arc near the ray (unbiased; same histories); 0: off [1].
    split_points
        Rotations per split event [1].

    Returns
    -------
    MonteCarloLuminance
        Luminance per order and its standard errors [cd m-2 lm-1].

    References
    ----------
    Marchuk et al. 1980 [4] (next-event estimation); Dobashi et al. 2023 [2], Sec. 3.2 (the ray
    integral).

    Examples
    --------
    >>> mc = monte_carlo_luminance(90.0, 0.0, 10e3, photons=200, max_order=3, seed=1)
    >>> mc.luminance.shape, bool(mc.total[0] > mc.single[0] > 0)
    ((3, 1), True)
    """
    from nightlights.sky import _montecarlo_numba as compiled

    sampled_shape(emission)
    if not atmosphere.extinction:
        raise InputError("atmosphere.extinction is off; multiple scattering needs extinction")
    if photons < 1 or max_order < 1 or nodes < 1 or event_nodes < 1:
        raise InputError(
            f"photons {photons!r}, max_order {max_order!r}, nodes {nodes!r}, "
            f"event_nodes {event_nodes!r}; expected >= 1"
        )
    if not (isinstance(seed, int | np.integer) and 0 <= seed < 2**63):
        raise InputError(f"seed {seed!r}; expected an integer from 0 to 2**63 - 1")
    if not core_radius > 0:
        raise InputError(f"core_radius {core_radius!r} m; expected > 0")
    if not split_window >= 0 or split_points < 1:
        raise InputError(
            f"split_window {split_window!r}, split_points {split_points!r}; expected >= 0, >= 1"
        )
    el, az, r = view_directions(elevation, relative_azimuth, distance)
    if np.any(r < 0) or not np.all(np.isfinite(r)):
        raise InputError("source distance; expected finite values >= 0 m")
    if observer_altitude < 0 or source_altitude < 0:
        raise InputError(
            f"observer_altitude {observer_altitude!r} m, source_altitude {source_altitude!r} m; "
            "expected >= 0 (the ground is at sea level)"
        )
    params, flags = compiled.model_parameters(
        atmosphere, emission, core_radius, uplight_exponent, source_altitude
    )
    rays = compiled.observer_rays(el, az, r, np.full(el.size, float(observer_altitude)), atmosphere)
    x_src, w_src = gauss_legendre(nodes)
    with held_signals():  # a Ctrl-C raised as the compiled call returns would crash it
        order1 = compiled.source_luminance(rays, x_src, w_src, params, flags)
    n_rays = el.size
    luminance = np.zeros((max_order, n_rays))
    error = np.zeros((max_order, n_rays))
    luminance[0] = order1
    budget = np.zeros(4)
    events = 0.0
    total_error = np.zeros(n_rays)
    if max_order > 1:
        x_gl, w_gl = gauss_legendre(event_nodes)
        sums, squares, total_squares, budget, events, _ = compiled.transport(
            int(seed),
            int(photons),
            int(max_order),
            rays,
            x_gl,
            w_gl,
            params,
            flags,
            windows=float(split_window) * r,
            points=int(split_points),
        )
        budget = budget / photons
        mean = sums / photons
        luminance[1:] = mean[2:]
        variance = np.maximum(squares / photons - mean * mean, 0.0)
        error[1:] = np.sqrt(variance[2:] / max(photons - 1, 1))
        multiple = mean[2:].sum(axis=0)
        total_variance = np.maximum(total_squares / photons - multiple * multiple, 0.0)
        total_error = np.sqrt(total_variance / max(photons - 1, 1))
    else:
        budget[3] = 1.0  # every photon is still in flight before its first scattering
    flux = dict(zip(("top", "ground", "absorbed", "in_flight"), map(float, budget), strict=True))
    return MonteCarloLuminance(
        luminance=luminance,
        standard_error=error,
        total=luminance.sum(axis=0),
        total_standard_error=total_error,
        photons=int(photons),
        seed=int(seed),
        flux=flux,
        events=int(events),
    )


def point_source_luminance(
    event: ArrayLike,
    incoming: ArrayLike,
    elevation: float,
    relative_azimuth: float,
    distance: float,
    *,
    observer_altitude: float = 0.0,
    atmosphere: Atmosphere = _DEFAULT_ATMOSPHERE,
    nodes: int = 64,
    leg_nodes: int = 16,
    core_radius: float = 1.0,
) -> float:
    """Luminance along one view ray of light scattered once at a point and once on the ray.

    The numpy reference of the estimator of :func:`monte_carlo_luminance` for one event:
    a unit flux (1 lm) arriving along ``incoming`` scatters at ``event`` with the phase
    mixture of the species there (intensity p_mix [cd lm-1]), and scatters again towards the
    observer along the ray. Optical depths of the chords from the event come from
    :func:`~nightlights.sky.kernel.optical_depth` (Gauss-Legendre), those of the observer's leg
    from :func:`~nightlights.sky.kernel.slant_optical_depth`.

    Parameters
    ----------
    event
        Position of the event in the source-centred frame of the Monte Carlo (source at
        (0, 0, h_c), Earth's centre at (0, 0, -R), observer towards -x), shape ``(3,)`` [m].
    incoming
        Unit direction of the photon before the event, shape ``(3,)`` [1].
    elevation, relative_azimuth
        View direction [deg].
    distance
        Ground distance of the observer from the source [m].
    observer_altitude
        Observer altitude above sea level [m].
    atmosphere
        Atmosphere model.
    nodes
        Gauss-Legendre nodes per panel [1].
    leg_nodes
        Gauss-Legendre nodes along each chord (spherical Earth) [1].
    core_radius
        Softening radius [m].

    Returns
    -------
    float
        Luminance per lumen arriving at the event [cd m-2 lm-1].
    """
    from nightlights.sky._montecarlo_numba import observer_rays

    ray = observer_rays(
        np.array([elevation], dtype=float),
        np.array([relative_azimuth], dtype=float),
        np.array([distance], dtype=float),
        np.array([observer_altitude], dtype=float),
        atmosphere,
    )[0]
    q = np.asarray(event, dtype=float)
    d_in = np.asarray(incoming, dtype=float)
    obs, v = ray[0:3], ray[3:6]
    sin_el, u_top = ray[6], ray[8]
    # altitudes in the source frame: shift to a frame with the Earth's centre below the origin
    radius = atmosphere.earth_radius

    def height(points: FloatArray) -> FloatArray:
        return altitude(points, earth_radius=radius, flat_earth=atmosphere.flat_earth)

    rel = q - obs
    u_p = float(rel @ v)
    miss = float(np.linalg.norm(np.cross(rel, v)))
    d_eff = math.sqrt(miss * miss + core_radius * core_radius)
    split = min(max(u_p, 0.0), u_top)
    length = smallest_scale_height(atmosphere) / max(sin_el, 1e-3)
    knee = min(max(split + max(length, d_eff), split), u_top)
    h_q = float(height(q))
    sig_s = atmosphere.molecular_extinction * math.exp(
        -h_q / atmosphere.molecular_scale_height
    ) + atmosphere.aerosol_albedo * atmosphere.aerosol_extinction * math.exp(
        -h_q / atmosphere.aerosol_scale_height
    )
    total = 0.0
    for lo, hi in ((0.0, split), (split, knee), (knee, u_top)):
        if hi <= lo:
            continue
        u, w = tangent_panel_nodes(lo, hi, u_p, d_eff, nodes)
        points = obs + u[:, None] * v
        to_point = points - q
        s2 = np.einsum("ij,ij->i", to_point, to_point)
        s = np.sqrt(s2)
        mu_in = to_point @ d_in / s
        cos_scatter = -(to_point @ v) / s
        intensity = atmosphere.scattering(h_q, mu_in) / sig_s
        tau = optical_depth(
            np.broadcast_to(q, points.shape), points, atmosphere, leg_nodes=leg_nodes
        ) + slant_optical_depth(ray[7], sin_el, u, atmosphere)
        value = (
            atmosphere.scattering(height(points), cos_scatter) * intensity / (s2 + core_radius**2)
        )
        total += float(np.sum(w * value * np.exp(-tau)))
    return total
