"""Single-scattering sky luminance from a unit ground source (the skyglow kernel).

For a view ray from the observer with direction v, the luminance is the integral along the ray
of the light scattered towards the observer at each point P(u) = O + u v:

.. math::
    b = \\int_0^{u_{top}} \\sum_{s} \\sigma_s(h(u)) \\, p_s(\\Theta)
        \\frac{I(\\theta_e)}{|P - S|^2} e^{-\\tau(S \\to P) - \\tau(O \\to P)} \\, du

with sigma_s the scattering coefficient of molecules and aerosols [m-1], p_s their phase
function [sr-1], I the source intensity per lumen [cd lm-1] in the direction from the source S to
P (angle theta_e from the source's local vertical), and tau the optical depth of each leg. With
I in cd per lm, b is a luminance per lumen [cd m-2 lm-1] (Dobashi et al. 2023, Eqs. 1-2, here in
photometric units).

Numerics (see :mod:`nightlights.sky.quadrature`): the ray is clipped to the part above the
source's tangent plane (the source emits upwards only) and below the top of the model
atmosphere, split at the closest approach to the source, and each side is integrated with
Gauss-Legendre nodes after the substitution u = u_p + d tan t. A ray passing through the source
(miss distance d -> 0) stays finite through a softening radius r0: 1 / s^2 is replaced by
1 / (s^2 + r0^2) (default r0 = 1 m, the size of a luminaire; it changes results by
(r0/d)^2, i.e. < 1e-4 beyond 100 m). Both legs start upwards, so their optical depths come
in closed form (:func:`slant_optical_depth`: exact on a flat Earth, second-order altitude on a
sphere); :func:`optical_depth` integrates a chord with Gauss-Legendre nodes as a reference.

Length: about 850 lines, because the numpy reference of the line-of-sight integral, its
validated helpers and the emission functions it integrates (the named shapes, Garstang's mix,
tabulated functions) belong together; the compiled twin is :mod:`nightlights.sky._kernel_numba`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import erfcx

from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    EMISSION_MODELS,
    GARSTANG_LOBE_NORM,
    TABULATED_PREFIX,
    UPLIGHT_EXPONENT,
    emission_intensity,
    emission_shape,
    garstang_weights,
    parse_tabulated_emission,
    tabulated_emission_intensity,
    tabulated_norm,
)
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere, scattering_species, smallest_scale_height
from nightlights.sky.geometry import altitude, ray_exit_distance, source_frame, view_direction
from nightlights.sky.quadrature import gauss_legendre, tangent_panel_nodes

__all__ = [
    "BACKENDS",
    "EMISSION_MODELS",
    "GARSTANG_LOBE_NORM",
    "TABULATED_PREFIX",
    "UPLIGHT_EXPONENT",
    "emission_intensity",
    "garstang_weights",
    "line_of_sight_integrand",
    "optical_depth",
    "parse_tabulated_emission",
    "sky_luminance",
    "sky_luminance_grid",
    "slant_optical_depth",
    "tabulated_emission_intensity",
    "tabulated_norm",
]

#: Line-of-sight integrators of :func:`sky_luminance` (same model and nodes).
BACKENDS = ("auto", "numba", "numpy")

_DEFAULT_ATMOSPHERE = Atmosphere()
_CHUNK_ELEMENTS = 3_000_000


def slant_optical_depth(
    start_altitude: ArrayLike,
    cos_zenith: ArrayLike,
    length: ArrayLike,
    atmosphere: Atmosphere,
) -> FloatArray:
    r"""Optical depth of a straight upward path, in closed form (exponential-slant model).

    Along a straight path leaving altitude h0 with zenith-angle cosine mu, the altitude on a
    sphere of radius R is h(s) = h0 + mu s + (1 - mu^2) s^2 / (2 (R + h0)) to second order
    (error < 10 m within 300 km). With this quadratic the exponential density integrates to
    error functions:

    .. math::
        \int_0^L e^{-h(s)/H} ds = e^{-h_0/H} \frac{\sqrt{\pi}}{2\sqrt{k}}
        \left[\mathrm{erfcx}(x_0) - \mathrm{erfcx}(x_0 + \sqrt{k} L)
        e^{-(m L + k L^2)}\right],

    k = (1 - mu^2) / (2 (R + h0) H), m = mu / H, x0 = m / (2 sqrt(k)); on a flat Earth (k = 0)
    it is e^{-h0/H} (1 - e^{-m L}) / m. Both legs of the kernel start upwards (the source
    emits above its horizon; view rays have elevation > 0), so mu >= 0.

    Parameters
    ----------
    start_altitude
        Altitude h0 of the lower end above sea level [m].
    cos_zenith
        Cosine of the path's zenith angle at the lower end, clipped to [0, 1] [1].
    length
        Path length L [m].
    atmosphere
        Atmosphere model.

    Returns
    -------
    numpy.ndarray
        Optical depth [1].

    References
    ----------
    Chapman 1931 (grazing-incidence integral of an exponential atmosphere); the erfcx form is
    the standard closed form of the parabolic (second-order) Chapman approximation.
    """
    h0 = np.asarray(start_altitude, dtype=float)
    mu = np.clip(np.asarray(cos_zenith, dtype=float), 0.0, 1.0)
    big_l = np.asarray(length, dtype=float)
    tau = np.zeros(np.broadcast_shapes(h0.shape, mu.shape, big_l.shape))
    if atmosphere.flat_earth:
        for beta, height in scattering_species(atmosphere):
            m_l = mu * big_l / height
            safe = np.where(m_l > 1e-12, m_l, 1.0)
            mean = np.where(m_l > 1e-12, -np.expm1(-safe) / safe, 1.0 - 0.5 * m_l)
            tau += beta * np.exp(-h0 / height) * big_l * mean
        return tau
    # k is floored so that vertical paths (k = 0) take the same branch: erfcx(x) is accurate
    # for huge x and the bracket then reduces to (1 - exp(-m L)) / m
    curvature = np.maximum((1.0 - mu * mu) / (2.0 * (atmosphere.earth_radius + h0)), 1e-30)
    for beta, height in scattering_species(atmosphere):
        k = curvature / height
        sk = np.sqrt(k)
        x0 = (mu / height) / (2.0 * sk)
        x_end = x0 + sk * big_l
        ratio = np.exp(-(mu / height + k * big_l) * big_l)  # exp(-(m L + k L^2))
        bracket = erfcx(x0) - erfcx(x_end) * ratio
        tau += (beta * 0.5 * math.sqrt(math.pi)) * np.exp(-h0 / height) / sk * bracket
    return tau


def optical_depth(
    start: ArrayLike, stop: ArrayLike, atmosphere: Atmosphere, *, leg_nodes: int = 6
) -> FloatArray:
    """Optical depth of the straight segment between two points of the local frame.

    On a flat Earth the exponential density integrates exactly along the segment:
    tau = sum_s beta_s L exp(-h_1/H_s) (1 - exp(-dh/H_s)) / (dh/H_s). On a sphere the altitude
    along a chord is not linear and the density is summed at ``leg_nodes`` Gauss-Legendre nodes.

    Parameters
    ----------
    start, stop
        Points, shape ``(..., 3)`` [m].
    atmosphere
        Atmosphere model.
    leg_nodes
        Gauss-Legendre nodes along the segment (spherical Earth only) [1].

    Returns
    -------
    numpy.ndarray
        Optical depth [1].
    """
    p1 = np.asarray(start, dtype=float)
    p2 = np.asarray(stop, dtype=float)
    seg = p2 - p1
    length = np.sqrt(np.einsum("...i,...i->...", seg, seg))
    species = scattering_species(atmosphere)
    tau = np.zeros(length.shape)
    if not species:
        return tau
    if atmosphere.flat_earth:
        h1 = np.minimum(p1[..., 2], p2[..., 2])
        dh = np.abs(p2[..., 2] - p1[..., 2])
        for beta, height in species:
            x = dh / height
            safe = np.where(x > 1e-12, x, 1.0)
            mean = np.where(x > 1e-12, -np.expm1(-safe) / safe, 1.0 - 0.5 * x)
            tau = tau + beta * length * np.exp(-h1 / height) * mean
        return tau
    # altitude along the chord from |P1 + f (P2 - P1) - C|^2, a quadratic in f
    radius = atmosphere.earth_radius
    centre_to_start = p1.copy()
    centre_to_start[..., 2] += radius
    c0 = np.einsum("...i,...i->...", p1, p1) + 2.0 * radius * p1[..., 2]  # |a|^2 - R^2
    c1 = 2.0 * np.einsum("...i,...i->...", centre_to_start, seg)
    c2 = length * length
    x, w = gauss_legendre(leg_nodes)
    frac = 0.5 * (x + 1.0)
    num = c0[..., None] + frac * (c1[..., None] + frac * c2[..., None])
    h = num / (np.sqrt(num + radius * radius) + radius)
    dens = np.zeros(h.shape)
    for beta, height in species:
        dens += beta * np.exp(-h / height)
    return 0.5 * length * (dens @ w)


def _check_options(
    emission: str, nodes: int, leg_nodes: int | None, core_radius: float, backend: str
) -> None:
    """Validation shared by :func:`sky_luminance` and :func:`sky_luminance_grid`."""
    emission_shape(emission)  # a registered shape or a tabulated function
    if nodes < 1 or (leg_nodes is not None and leg_nodes < 1):
        raise InputError(f"nodes {nodes!r}, leg_nodes {leg_nodes!r}; expected >= 1")
    if not core_radius > 0:
        raise InputError(f"core_radius {core_radius!r} m; expected > 0")
    if backend not in BACKENDS:
        raise InputError(f"backend {backend!r}; expected one of {BACKENDS}")
    if backend == "numba" and leg_nodes is not None:
        raise InputError("backend 'numba' computes closed-form legs only; leg_nodes needs 'numpy'")


def _check_distances(distance: FloatArray) -> None:
    if np.any(distance < 0) or not np.all(np.isfinite(distance)):
        raise InputError("source distance; expected finite values >= 0 m")


def sky_luminance(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    *,
    source_altitude: ArrayLike = 0.0,
    observer_altitude: ArrayLike = 0.0,
    atmosphere: Atmosphere = _DEFAULT_ATMOSPHERE,
    emission: str = "lambertian",
    nodes: int = 24,
    leg_nodes: int | None = None,
    core_radius: float = 1.0,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    backend: str = "auto",
) -> FloatArray:
    """Sky luminance seen along a view ray per lumen emitted upwards by a ground point source.

    All array arguments broadcast together; the result has the broadcast shape.

    Parameters
    ----------
    elevation
        Elevation of the view ray above the horizon; rays at or below 0 give 0 [deg].
    relative_azimuth
        Azimuth of the view ray relative to the direction of the source [deg].
    distance
        Ground distance from the observer to the source (arc length at sea level) [m].
    source_altitude
        Altitude of the source above sea level [m].
    observer_altitude
        Altitude of the observer above sea level [m].
    atmosphere
        Atmosphere model.
    emission
        Angular distribution of the source: a registered shape
        (:func:`~nightlights.emission_functions.emission_shape_names`; the built-in
        :data:`EMISSION_MODELS` and those added by
        :func:`~nightlights.emission_functions.register_emission_shape`) or a tabulated
        function ``tabulated:<json>`` (:func:`parse_tabulated_emission`).
    nodes
        Gauss-Legendre nodes per panel of the line of sight (three panels: before the closest
        approach, after it, and past one density scale length) [1].
    leg_nodes
        None (default): closed-form leg optical depths (:func:`slant_optical_depth`); an
        integer: Gauss-Legendre nodes along each leg instead (:func:`optical_depth`, reference) [1].
    core_radius
        Softening radius r0 of the point source [m].
    uplight_exponent
        Exponent of the uplight lobe (``emission="uplight"``) [1].
    backend
        ``"numba"``: compiled loop over rays (:mod:`nightlights.sky._kernel_numba`, same model
        and nodes, ~10x faster); ``"numpy"``: vectorised reference; ``"auto"`` (default):
        numba unless ``leg_nodes`` is given (leg quadrature is numpy only) [1].

    Returns
    -------
    numpy.ndarray
        Luminance per lumen [cd m-2 lm-1].

    References
    ----------
    Dobashi et al. 2023, Sec. 3.2, Eqs. 1-2 (single scattering, split at closest approach;
    here integrated after the substitution u = u_c + d tan t).

    Examples
    --------
    >>> b = sky_luminance(90.0, 0.0, [1e3, 1e4])
    >>> bool(b[0] > b[1] > 0)
    True
    """
    _check_options(emission, nodes, leg_nodes, core_radius, backend)
    arrays = np.broadcast_arrays(
        np.asarray(elevation, dtype=float),
        np.asarray(relative_azimuth, dtype=float),
        np.asarray(distance, dtype=float),
        np.asarray(source_altitude, dtype=float),
        np.asarray(observer_altitude, dtype=float),
    )
    shape = arrays[0].shape
    flat = [a.ravel() for a in arrays]
    _check_distances(flat[2])
    if backend != "numpy" and leg_nodes is None:
        from nightlights.sky._kernel_numba import luminance_rays

        out = luminance_rays(
            *flat,
            atmosphere=atmosphere,
            emission=emission,
            nodes=nodes,
            core_radius=core_radius,
            uplight_exponent=uplight_exponent,
        )
        return out.reshape(shape)
    out = np.zeros(flat[0].size)
    per_ray = 3 * nodes * (2 * (leg_nodes or 2) + 8)
    chunk = max(1, _CHUNK_ELEMENTS // per_ray)
    for lo in range(0, out.size, chunk):
        sl = slice(lo, lo + chunk)
        out[sl] = _luminance_chunk(
            *(a[sl] for a in flat),
            atmosphere=atmosphere,
            emission=emission,
            nodes=nodes,
            leg_nodes=leg_nodes,
            core_radius=core_radius,
            uplight_exponent=uplight_exponent,
        )
    return out.reshape(shape)


def sky_luminance_grid(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    *,
    source_altitude: float = 0.0,
    observer_altitude: float = 0.0,
    atmosphere: Atmosphere = _DEFAULT_ATMOSPHERE,
    emission: str = "lambertian",
    nodes: int = 24,
    leg_nodes: int | None = None,
    core_radius: float = 1.0,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    backend: str = "auto",
) -> FloatArray:
    """:func:`sky_luminance` on the outer product of three axes, for kernel tables.

    With the numba backend the observer-side factors of each view ray (scattering density
    times the observer leg's transmission) are tabulated once per elevation against altitude
    (uniform in sqrt(h - h_o), 16,385 nodes) and interpolated linearly at the quadrature nodes,
    instead of being evaluated in closed form at every node: within 5e-5 of
    :func:`sky_luminance` (2e-6 at turbidity 2), about 25 % faster. Rows whose table would be
    too coarse (the observer leg's optical depth growing by > 0.01 between nodes: very low rays
    over a flat Earth) use the closed form; with fewer rays per elevation than the table has
    nodes the per-ray path of :func:`sky_luminance` is used.

    Parameters
    ----------
    elevation, relative_azimuth
        1-D axes of view directions [deg].
    distance
        1-D axis of ground distances of the source [m].
    source_altitude, observer_altitude
        Altitudes above sea level [m].
    atmosphere, emission, nodes, leg_nodes, core_radius, uplight_exponent, backend
        As :func:`sky_luminance`.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_el, n_az, n_r)`` [cd m-2 lm-1].
    """
    el = np.asarray(elevation, dtype=float).ravel()
    az = np.asarray(relative_azimuth, dtype=float).ravel()
    r = np.asarray(distance, dtype=float).ravel()
    kwargs = {
        "atmosphere": atmosphere,
        "emission": emission,
        "nodes": nodes,
        "core_radius": core_radius,
        "uplight_exponent": uplight_exponent,
    }
    _check_options(emission, nodes, leg_nodes, core_radius, backend)
    _check_distances(r)
    from nightlights.sky._kernel_numba import OBSERVER_TABLE_SIZE, luminance_grid

    # The observer tables cost one closed-form evaluation per table node and elevation: for a
    # few rays per elevation (supersampled pixels) the per-ray path is cheaper.
    few_rays = az.size * r.size * 3 * nodes < OBSERVER_TABLE_SIZE
    if backend == "numpy" or leg_nodes is not None or few_rays:
        return sky_luminance(
            el[:, None, None],
            az[None, :, None],
            r[None, None, :],
            source_altitude=source_altitude,
            observer_altitude=observer_altitude,
            leg_nodes=leg_nodes,
            backend=backend,
            **kwargs,  # type: ignore[arg-type]
        )
    return luminance_grid(
        el,
        az,
        r,
        source_altitude=float(source_altitude),
        observer_altitude=float(observer_altitude),
        **kwargs,  # type: ignore[arg-type]
    )


def _luminance_chunk(
    el: FloatArray,
    az: FloatArray,
    r: FloatArray,
    h_c: FloatArray,
    h_o: FloatArray,
    *,
    atmosphere: Atmosphere,
    emission: str,
    nodes: int,
    leg_nodes: int | None,
    core_radius: float,
    uplight_exponent: float,
) -> FloatArray:
    flat_earth = atmosphere.flat_earth
    radius = atmosphere.earth_radius
    top = atmosphere.top_altitude
    if top <= 0:
        return np.zeros(el.shape)
    v = view_direction(el, az)
    src, vert = source_frame(r, h_c, earth_radius=radius, flat_earth=flat_earth)
    obs = np.zeros(src.shape)
    obs[:, 2] = h_o
    u_top = ray_exit_distance(el, h_o, top, earth_radius=radius, flat_earth=flat_earth)
    u_top = np.where(el > 0, u_top, 0.0)
    # the source emits upwards only: keep the part of the ray above its tangent plane
    rel = src - obs
    vn = np.einsum("ij,ij->i", v, vert)
    gap = -np.einsum("ij,ij->i", rel, vert)  # height of the observer above that plane
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.where(vn != 0, -gap / np.where(vn != 0, vn, 1.0), np.inf)
    start = np.where(vn > 0, np.clip(cross, 0.0, None), 0.0)
    stop = np.where(vn < 0, np.minimum(u_top, np.where(gap > 0, cross, 0.0)), u_top)
    stop = np.where((vn == 0) & (gap <= 0), 0.0, stop)
    stop = np.maximum(stop, start)
    # closest approach (Dobashi 2023, Sec. 3.2) and softened miss distance
    u_p = np.einsum("ij,ij->i", rel, v)
    miss = np.linalg.norm(np.cross(rel, v), axis=-1)
    d_eff = np.sqrt(miss * miss + core_radius * core_radius)
    split = np.clip(u_p, start, stop)
    # the far side is split again where the density along the ray has fallen by ~e (one
    # aerosol-like scale length H / sin(el) past the closest approach): beyond it the
    # 1 / s^2 substitution alone leaves the density decay in a thin sliver of t
    sin_el = np.maximum(np.sin(np.radians(el)), 1e-3)
    length = smallest_scale_height(atmosphere) / sin_el
    knee = np.clip(split + np.maximum(length, d_eff), split, stop)
    panels = ((start, split, nodes), (split, knee, nodes), (knee, stop, nodes))
    total = np.zeros(el.shape)
    for lo, hi, n in panels:
        u, w = tangent_panel_nodes(lo, hi, u_p, d_eff, n)
        value = _integrand(
            u,
            el,
            h_c,
            h_o,
            v,
            src,
            vert,
            atmosphere=atmosphere,
            emission=emission,
            leg_nodes=leg_nodes,
            core_radius=core_radius,
            uplight_exponent=uplight_exponent,
        )
        total += np.einsum("ij,ij->i", value, w)
    return total


def _integrand(
    u: FloatArray,
    el: FloatArray,
    h_c: FloatArray,
    h_o: FloatArray,
    v: FloatArray,
    src: FloatArray,
    vert: FloatArray,
    *,
    atmosphere: Atmosphere,
    emission: str,
    leg_nodes: int | None,
    core_radius: float,
    uplight_exponent: float,
) -> FloatArray:
    """Scattered luminance per metre of ray at distances u (rays x points) [cd m-3 lm-1]."""
    obs = np.zeros(src.shape)
    obs[:, 2] = h_o
    points = obs[:, None, :] + u[..., None] * v[:, None, :]
    to_point = points - src[:, None, :]
    s2 = np.einsum("ijk,ijk->ij", to_point, to_point)
    s = np.sqrt(s2)
    safe_s = np.where(s > 0, s, 1.0)
    cos_emit = np.einsum("ijk,ik->ij", to_point, vert) / safe_s
    cos_scatter = -np.einsum("ijk,ik->ij", to_point, v) / safe_s
    h = altitude(points, earth_radius=atmosphere.earth_radius, flat_earth=atmosphere.flat_earth)
    value = (
        atmosphere.scattering(h, cos_scatter)
        * emission_intensity(cos_emit, emission, uplight_exponent=uplight_exponent)
        / (s2 + core_radius * core_radius)
    )
    if atmosphere.extinction and leg_nodes is None:
        tau = slant_optical_depth(
            h_o[:, None], np.sin(np.radians(el))[:, None], u, atmosphere
        ) + slant_optical_depth(h_c[:, None], cos_emit, s, atmosphere)
        value = value * np.exp(-tau)
    elif atmosphere.extinction and leg_nodes is not None:
        tau_obs = optical_depth(obs[:, None, :], points, atmosphere, leg_nodes=leg_nodes)
        tau_src = optical_depth(src[:, None, :], points, atmosphere, leg_nodes=leg_nodes)
        value = value * np.exp(-(tau_obs + tau_src))
    return value


def line_of_sight_integrand(
    along_ray: ArrayLike,
    elevation: float,
    relative_azimuth: float,
    distance: float,
    *,
    source_altitude: float = 0.0,
    observer_altitude: float = 0.0,
    atmosphere: Atmosphere = _DEFAULT_ATMOSPHERE,
    emission: str = "lambertian",
    core_radius: float = 1.0,
    uplight_exponent: float = UPLIGHT_EXPONENT,
) -> FloatArray:
    """Integrand of :func:`sky_luminance` along one view ray, for reference integrators.

    Parameters
    ----------
    along_ray
        Distances from the observer along the ray [m].
    elevation, relative_azimuth
        Direction of the ray [deg].
    distance
        Ground distance of the source [m].
    source_altitude, observer_altitude
        Altitudes above sea level [m].
    atmosphere
        Atmosphere model.
    emission
        A registered shape or a tabulated function (as :func:`sky_luminance`).
    core_radius
        Softening radius [m].
    uplight_exponent
        Exponent of the uplight lobe [1].

    Returns
    -------
    numpy.ndarray
        Same shape as ``along_ray`` [cd m-3 lm-1]; 0 above the top of the model atmosphere.
    """
    u = np.asarray(along_ray, dtype=float)
    el = np.array([float(elevation)])
    h_c = np.array([float(source_altitude)])
    h_o = np.array([float(observer_altitude)])
    v = view_direction(el, np.array([float(relative_azimuth)]))
    src, vert = source_frame(
        np.array([float(distance)]),
        h_c,
        earth_radius=atmosphere.earth_radius,
        flat_earth=atmosphere.flat_earth,
    )
    value = _integrand(
        u.reshape(1, -1),
        el,
        h_c,
        h_o,
        v,
        src,
        vert,
        atmosphere=atmosphere,
        emission=emission,
        leg_nodes=None,
        core_radius=core_radius,
        uplight_exponent=uplight_exponent,
    ).reshape(u.shape)
    top = ray_exit_distance(
        el,
        h_o,
        atmosphere.top_altitude,
        earth_radius=atmosphere.earth_radius,
        flat_earth=atmosphere.flat_earth,
    )
    return np.where((u >= 0) & (u <= top[0]) & (el[0] > 0), value, 0.0)
