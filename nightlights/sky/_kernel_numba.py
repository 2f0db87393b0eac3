"""Compiled (numba) line-of-sight integration of the skyglow kernel.

The same model and the same quadrature as the numpy path of
:func:`nightlights.sky.kernel.sky_luminance` (which stays the reference the tests compare this
to), written as one loop per view ray so that no temporaries are made and the
per-ray constants (view direction, source frame, panel ends, the observer leg's closed-form
terms) are computed once per ray instead of once per node. Rays run in parallel (``prange``).

Only the closed-form leg optical depths are compiled; ``leg_nodes`` (Gauss quadrature of the
legs, a reference) stays on the numpy path.

Length: about 800 lines, because one compiled ray loop and the closed-form leg optical
depths it inlines are kept together so that numba compiles them as one unit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray
from scipy.special import beta as beta_function
from scipy.special import erfcx

from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    COSINE_FORM,
    GARSTANG_LOBE_NORM,
    PSI4_LOBE_FORM,
    SINE_POWER_FORM,
    TABLE_FORM,
    emission_shape,
)
from nightlights.sky.atmosphere import Atmosphere, smallest_scale_height
from nightlights.sky.quadrature import gauss_legendre

__all__ = ["luminance_grid", "luminance_rays", "model_parameters"]

_SQRT_PI = math.sqrt(math.pi)
_INV_SQRT_PI = 1.0 / _SQRT_PI

#: Largest growth of the observer leg's optical depth between two nodes of its table [1].
_MAX_TABLE_STEP_TAU = 0.01

# layout of the float parameter vector passed to the compiled code
_P_BETA_M, _P_H_M, _P_BETA_A, _P_H_A, _P_ALBEDO, _P_G = 0, 1, 2, 3, 4, 5
_P_RADIUS, _P_TOP, _P_CORE, _P_HALF_N, _P_UP_NORM, _P_MIN_H = 6, 7, 8, 9, 10, 11
_P_LOBE_NORM = 12  # (module constants are frozen into numba's cache: pass them in)
# layout of the integer flags
_F_FLAT, _F_EXTINCTION, _F_EMISSION, _F_ISOTROPIC_MOLECULES = 0, 1, 2, 3


def emission_table(emission: str) -> FloatArray:
    """Shape (2, m): a table-form shape's angles [rad] and intensities [cd lm-1]
    (normalised), read by the compiled table branch; a dummy for the others
    (:meth:`~nightlights.emission_functions.EmissionShape.compiled_table`)."""
    return emission_shape(emission).compiled_table()


def model_parameters(
    atmosphere: Atmosphere, emission: str, core_radius: float, uplight_exponent: float
) -> tuple[FloatArray, NDArray[np.int64]]:
    """Pack the model into the float and integer vectors read by :func:`luminance_rays`
    (a table-form emission's table: :func:`emission_table`); the emission's compiled form and
    sine exponent come from its registry row
    (:func:`~nightlights.emission_functions.emission_shape`)."""
    shape = emission_shape(emission)
    exponent = shape.sine_exponent(uplight_exponent)
    params = np.zeros(13)
    params[_P_BETA_M] = atmosphere.molecular_extinction
    params[_P_H_M] = atmosphere.molecular_scale_height
    params[_P_BETA_A] = atmosphere.aerosol_extinction
    params[_P_H_A] = atmosphere.aerosol_scale_height
    params[_P_ALBEDO] = atmosphere.aerosol_albedo
    params[_P_G] = atmosphere.asymmetry
    params[_P_RADIUS] = atmosphere.earth_radius
    params[_P_TOP] = atmosphere.top_altitude
    params[_P_CORE] = core_radius
    params[_P_HALF_N] = exponent / 2.0
    params[_P_UP_NORM] = math.pi * float(beta_function(0.5, exponent / 2.0 + 1.0))
    params[_P_MIN_H] = smallest_scale_height(atmosphere)
    params[_P_LOBE_NORM] = GARSTANG_LOBE_NORM
    flags = np.zeros(4, dtype=np.int64)
    flags[_F_FLAT] = int(atmosphere.flat_earth)
    flags[_F_EXTINCTION] = int(atmosphere.extinction)
    flags[_F_EMISSION] = shape.code
    flags[_F_ISOTROPIC_MOLECULES] = int(atmosphere.molecular_phase == "isotropic")
    return params, flags


#: Nodes of the tabulated erfcx: g(y) = sqrt(pi) erfcx(x) / y on y = 1 / (1 + x) in [0, 1],
#: linear interpolation (max relative error 7e-9 for x < 26; the asymptotic series beyond).
ERFCX_TABLE_SIZE = 4096
_ERFCX_SERIES_FROM = 26.0


def erfcx_table(size: int = ERFCX_TABLE_SIZE) -> FloatArray:
    """Table of g(y) = sqrt(pi) erfcx(x) / y, y = 1 / (1 + x), on ``size + 1`` nodes in [0, 1]."""
    y = np.linspace(0.0, 1.0, size + 1)
    with np.errstate(divide="ignore"):
        x = 1.0 / y - 1.0
    g = np.ones_like(y)  # y -> 0: erfcx(x) ~ 1 / (sqrt(pi) x)
    g[1:] = _SQRT_PI * erfcx(x[1:]) / y[1:]
    return g


@njit(cache=True, inline="always")
def _erfcx(x: float, table: FloatArray) -> float:  # pragma: no cover - compiled
    """Scaled complementary error function exp(x^2) erfc(x) for x >= 0."""
    if x < _ERFCX_SERIES_FROM:
        y = 1.0 / (1.0 + x)
        pos = y * (table.size - 1)
        i = min(int(pos), table.size - 2)
        frac = pos - i
        return (table[i] + frac * (table[i + 1] - table[i])) * y * _INV_SQRT_PI
    # asymptotic series (Abramowitz & Stegun 7.1.23); next term < 3e-13 at x = 26
    inv = 1.0 / x
    inv2 = inv * inv
    return (1.0 - inv2 * (0.5 - inv2 * (0.75 - inv2 * (1.875 - 6.5625 * inv2)))) * (
        inv * _INV_SQRT_PI
    )


@njit(cache=True, inline="always")
def _flat_tau(
    h0_density: float, mu: float, length: float, beta: float, height: float
) -> float:  # pragma: no cover - compiled
    """One species' optical depth of an upward straight path over a flat Earth."""
    if beta <= 0.0:
        return 0.0
    mu = min(max(mu, 0.0), 1.0)
    m_l = mu * length / height
    mean = -math.expm1(-m_l) / m_l if m_l > 1e-12 else 1.0 - 0.5 * m_l
    return beta * h0_density * length * mean


@njit(cache=True, inline="always")
def _sphere_tau(
    h0_density: float,
    mu: float,
    root_curvature: float,
    inverse_root_curvature: float,
    length: float,
    beta: float,
    inverse_height: float,
    root_height: float,
    inverse_root_height: float,
    table: FloatArray,
) -> float:  # pragma: no cover - compiled
    """One species' optical depth of an upward straight path over a sphere.

    Closed form of :func:`nightlights.sky.kernel.slant_optical_depth` with the factors that do
    not change along a ray passed in: h0_density = exp(-h0 / H), root_curvature =
    sqrt(max((1 - mu^2) / (2 (R + h0)), 1e-30)) and its inverse (shared by the species),
    1 / H, sqrt(H) and 1 / sqrt(H): products instead of divisions (the same values to
    rounding).
    """
    if beta <= 0.0:
        return 0.0
    sk = root_curvature * inverse_root_height
    inverse_sk = root_height * inverse_root_curvature
    slope = mu * inverse_height
    x0 = 0.5 * slope * inverse_sk
    x_end = x0 + sk * length
    ratio = math.exp(-(slope + sk * sk * length) * length)
    bracket = _erfcx(x0, table) - _erfcx(x_end, table) * ratio
    return beta * 0.5 * _SQRT_PI * h0_density * inverse_sk * bracket


@njit(cache=True, inline="always")
def _observer_constants(
    se: float,
    h_o: float,
    radius: float,
    beta_m: float,
    h_m: float,
    beta_a: float,
    h_a: float,
    obs_m: float,
    obs_a: float,
    table: FloatArray,
) -> tuple[float, ...]:  # pragma: no cover - compiled
    """Per-ray constants of the observer leg's closed form (mu = sin(elevation)), packed for
    :func:`_observer_tau`."""
    root_curv_o = math.sqrt(max((1.0 - se * se) / (2.0 * (radius + h_o)), 1e-30))
    sk_om = root_curv_o / math.sqrt(h_m)
    sk_oa = root_curv_o / math.sqrt(h_a)
    x0_om = (se / h_m) / (2.0 * sk_om)
    x0_oa = (se / h_a) / (2.0 * sk_oa)
    e0_om = _erfcx(x0_om, table)
    e0_oa = _erfcx(x0_oa, table)
    pref_om = beta_m * obs_m * 0.5 * _SQRT_PI / sk_om
    pref_oa = beta_a * obs_a * 0.5 * _SQRT_PI / sk_oa
    return (
        beta_m,
        h_m,
        beta_a,
        h_a,
        obs_m,
        obs_a,
        sk_om,
        sk_oa,
        x0_om,
        x0_oa,
        e0_om,
        e0_oa,
        pref_om,
        pref_oa,
    )


@njit(cache=True, inline="always")
def _observer_tau(
    u: float, se: float, flat: bool, leg: tuple[float, ...], table: FloatArray
) -> float:  # pragma: no cover - compiled
    """Optical depth from the observer to distance u along the view ray (``leg`` from
    :func:`_observer_constants`)."""
    beta_m, h_m, beta_a, h_a, obs_m, obs_a = leg[0], leg[1], leg[2], leg[3], leg[4], leg[5]
    sk_om, sk_oa, x0_om, x0_oa = leg[6], leg[7], leg[8], leg[9]
    e0_om, e0_oa, pref_om, pref_oa = leg[10], leg[11], leg[12], leg[13]
    if flat:
        return _flat_tau(obs_m, se, u, beta_m, h_m) + _flat_tau(obs_a, se, u, beta_a, h_a)
    tau = 0.0
    if beta_m > 0.0:
        ratio = math.exp(-(se / h_m + sk_om * sk_om * u) * u)
        tau += pref_om * (e0_om - _erfcx(x0_om + sk_om * u, table) * ratio)
    if beta_a > 0.0:
        ratio = math.exp(-(se / h_a + sk_oa * sk_oa * u) * u)
        tau += pref_oa * (e0_oa - _erfcx(x0_oa + sk_oa * u, table) * ratio)
    return tau


@njit(cache=True, inline="always")
def _view(el_deg: float, az_deg: float) -> tuple[float, float, float]:  # pragma: no cover
    """Unit view direction (x towards the source, z up) of a ray (geometry.view_direction)."""
    el = math.radians(el_deg)
    az = math.radians(az_deg)
    ce = math.cos(el)
    return ce * math.cos(az), ce * math.sin(az), math.sin(el)


@njit(cache=True, inline="always")
def _source(
    r: float, h_c: float, radius: float, flat: bool
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """Source position (x, z) and local vertical (x, z) in the observer's frame
    (geometry.source_frame)."""
    if flat:
        return r, h_c, 0.0, 1.0
    ang = r / radius
    sa, ca = math.sin(ang), math.cos(ang)
    half = math.sin(ang / 2.0)
    return (radius + h_c) * sa, h_c * ca - radius * 2.0 * half * half, sa, ca


@njit(cache=True, inline="always")
def _top_distance(
    se: float, h_o: float, top: float, radius: float, flat: bool
) -> float:  # pragma: no cover - compiled
    """Distance along a ray of elevation sine ``se`` to the top of the model atmosphere
    (geometry.ray_exit_distance)."""
    gap_top = max(top - h_o, 0.0)
    if flat:
        return gap_top / se
    b = (radius + h_o) * se
    cdiff = gap_top * (2.0 * radius + top + h_o)
    root = math.sqrt(b * b + cdiff)
    return cdiff / (b + root) if b + root > 0.0 else root - b


@njit(cache=True, inline="always")
def _pair_constants(
    h_c: float, h_o: float, p: FloatArray
) -> tuple[float, ...]:  # pragma: no cover - compiled
    """Factors of both legs' closed forms that depend on the altitude pair alone: exp(-h_c / H)
    of each species, 1 / (2 (R + h_c)), sqrt(H), 1 / H and 1 / sqrt(H) of each species."""
    h_m, h_a = p[_P_H_M], p[_P_H_A]
    root_h_m = math.sqrt(h_m)
    root_h_a = math.sqrt(h_a)
    return (
        math.exp(-h_c / h_m),
        math.exp(-h_c / h_a),
        1.0 / (2.0 * (p[_P_RADIUS] + h_c)),
        root_h_m,
        root_h_a,
        1.0 / h_m,
        1.0 / h_a,
        1.0 / root_h_m,
        1.0 / root_h_a,
    )


@njit(cache=True, inline="always")
def _leg(
    se: float, h_o: float, p: FloatArray, table: FloatArray
) -> tuple[float, ...]:  # pragma: no cover - compiled
    """:func:`_observer_constants` of a ray of elevation sine ``se``."""
    h_m, h_a = p[_P_H_M], p[_P_H_A]
    return _observer_constants(
        se,
        h_o,
        p[_P_RADIUS],
        p[_P_BETA_M],
        h_m,
        p[_P_BETA_A],
        h_a,
        math.exp(-h_o / h_m),
        math.exp(-h_o / h_a),
        table,
    )


@njit(cache=True)
def _observer_table(
    el_deg: float, h_o: float, p: FloatArray, flags: NDArray[np.int64], table: FloatArray, size: int
) -> tuple[FloatArray, float]:  # pragma: no cover - compiled
    """Observer-side factors of one view ray against altitude, for :func:`_grid`.

    Row 0: beta_m exp(-h / H_m - tau_obs(h)), row 1: sigma_a exp(-h / H_a - tau_obs(h)), with
    tau_obs(h) the optical depth from the observer to the point of the ray at altitude h (0
    without extinction); nodes uniform in z = sqrt(h - h_o) up to the top of the atmosphere,
    dense next to the observer where low rays' tau_obs grows fastest. Returns the table and
    1 / dz; or an empty table (the caller then uses the closed form) where tau_obs grows by more
    than :data:`_MAX_TABLE_STEP_TAU` between two nodes while the transmission is still above
    1e-12 (very low rays over a flat Earth), so that linear interpolation of exp(-tau_obs)
    stays within ~1e-5.
    """
    out = np.zeros((2, size + 1))
    top = p[_P_TOP]
    if top <= h_o or el_deg <= 0.0:
        return out, 0.0
    flat = flags[_F_FLAT] != 0
    extinction = flags[_F_EXTINCTION] != 0
    radius = p[_P_RADIUS]
    beta_m, h_m = p[_P_BETA_M], p[_P_H_M]
    beta_a, h_a = p[_P_BETA_A], p[_P_H_A]
    sigma_a = p[_P_ALBEDO] * beta_a
    se = math.sin(math.radians(el_deg))
    obs_m = math.exp(-h_o / h_m)
    obs_a = math.exp(-h_o / h_a)
    leg = _observer_constants(se, h_o, radius, beta_m, h_m, beta_a, h_a, obs_m, obs_a, table)
    dz = math.sqrt(top - h_o) / size
    b = (radius + h_o) * se
    tau_before = 0.0
    for i in range(size + 1):
        dh = (i * dz) ** 2
        h = h_o + dh
        if flat:
            u = dh / se
        else:
            c = dh * (2.0 * radius + h + h_o)
            u = c / (b + math.sqrt(b * b + c))
        tau = 0.0
        if extinction:
            tau = _observer_tau(u, se, flat, leg, table)
            if tau - tau_before > _MAX_TABLE_STEP_TAU and tau_before < 27.6:  # e^-27.6 = 1e-12
                return np.zeros((2, 0)), 0.0
            tau_before = tau
        if beta_m > 0.0:
            out[0, i] = beta_m * math.exp(-h / h_m - tau)
        if sigma_a > 0.0:
            out[1, i] = sigma_a * math.exp(-h / h_a - tau)
    return out, 1.0 / dz


@njit(cache=True)
def _ray(
    vx: float,
    vy: float,
    vz: float,
    u_top: float,
    sx: float,
    sz: float,
    nx: float,
    nz: float,
    h_c: float,
    h_o: float,
    pair: tuple[float, ...],
    leg: tuple[float, ...],
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
    table: FloatArray,
    observer_table: FloatArray,
    inv_dz: float,
    emission_tab: FloatArray,
) -> float:  # pragma: no cover - compiled
    """Luminance along one ray of upward direction (vx, vy, vz) (:func:`_view`, vz > 0) that
    leaves the atmosphere at ``u_top`` (:func:`_top_distance`), from a source at (sx, 0, sz)
    with local vertical (nx, 0, nz) (:func:`_source`); ``pair`` from :func:`_pair_constants`,
    ``leg`` from :func:`_leg` (read only without the table). ``observer_table`` (2, m) of this
    ray's observer-side factors (:func:`_observer_table`) replaces their closed form when
    m > 0; ``emission_tab`` is the tabulated emission function (:func:`emission_table`). The
    callers compute the factors of each elevation, azimuth, distance and altitude pair once."""
    tabulated = observer_table.shape[1] > 1
    last = observer_table.shape[1] - 1
    flat = flags[_F_FLAT] != 0
    extinction = flags[_F_EXTINCTION] != 0
    emission = flags[_F_EMISSION]
    iso_molecules = flags[_F_ISOTROPIC_MOLECULES] != 0
    radius = p[_P_RADIUS]
    core2 = p[_P_CORE] * p[_P_CORE]
    beta_m, h_m = p[_P_BETA_M], p[_P_H_M]
    beta_a, h_a = p[_P_BETA_A], p[_P_H_A]
    sigma_a = p[_P_ALBEDO] * beta_a
    g = p[_P_G]
    se = vz
    # keep the part of the ray above the source's tangent plane
    relx, relz = sx, sz - h_o
    vn = vx * nx + vz * nz
    gap = -(relx * nx + relz * nz)
    cross = -gap / vn if vn != 0.0 else math.inf
    start = max(cross, 0.0) if vn > 0.0 else 0.0
    if vn < 0.0:
        stop = min(u_top, cross if gap > 0.0 else 0.0)
    else:
        stop = u_top
    if vn == 0.0 and gap <= 0.0:
        stop = 0.0
    stop = max(stop, start)
    if stop <= start:
        return 0.0
    # closest approach (Dobashi 2023, Sec. 3.2) and softened miss distance
    u_p = relx * vx + relz * vz
    cx = -relz * vy
    cy = relz * vx - relx * vz
    cz = relx * vy
    d_eff = math.sqrt(cx * cx + cy * cy + cz * cz + core2)
    split = min(max(u_p, start), stop)
    sin_el = max(se, 1e-3)
    knee = min(max(split + max(p[_P_MIN_H] / sin_el, d_eff), split), stop)
    # the altitude pair's factors of both legs' closed forms
    src_m, src_a, inv_2rc = pair[0], pair[1], pair[2]
    root_h_m, root_h_a, inv_h_m, inv_h_a = pair[3], pair[4], pair[5], pair[6]
    inv_root_h_m, inv_root_h_a = pair[7], pair[8]
    # emission and phase constants
    half_n = p[_P_HALF_N]
    up_norm = p[_P_UP_NORM]
    lobe_norm = p[_P_LOBE_NORM] / (2.0 * math.pi)
    last_tab = emission_tab.shape[1] - 1
    hg_num = (1.0 - g * g) / (4.0 * math.pi)
    hg_a = 1.0 + g * g
    total = 0.0
    n = x_gl.size
    # u = u_p + d tan t (quadrature.tangent_panel_nodes); du = d (1 + tan^2 t) dt; the
    # panels' ends in t, each computed once (split and knee end one panel and start the next)
    t_start = math.atan((start - u_p) / d_eff)
    t_split = math.atan((split - u_p) / d_eff)
    t_knee = math.atan((knee - u_p) / d_eff)
    t_stop = math.atan((stop - u_p) / d_eff)
    for panel in range(3):
        if panel == 0:
            lo, hi, ta, tb = start, split, t_start, t_split
        elif panel == 1:
            lo, hi, ta, tb = split, knee, t_split, t_knee
        else:
            lo, hi, ta, tb = knee, stop, t_knee, t_stop
        if hi <= lo:
            continue
        halfw = 0.5 * (tb - ta)
        mid = 0.5 * (ta + tb)
        for j in range(n):
            tan_t = math.tan(mid + halfw * x_gl[j])
            u = u_p + d_eff * tan_t
            weight = halfw * w_gl[j] * d_eff * (1.0 + tan_t * tan_t)
            px, py, pz = u * vx, u * vy, h_o + u * vz
            tx, ty, tz = px - sx, py, pz - sz
            s2 = tx * tx + ty * ty + tz * tz
            s = math.sqrt(s2)
            inv_s = 1.0 / s if s > 0.0 else 1.0
            cos_emit = (tx * nx + tz * nz) * inv_s
            if cos_emit <= 0.0:
                continue
            # emission (emission_shapes.form_intensity)
            if emission == COSINE_FORM:
                intensity = cos_emit / math.pi
            elif emission == SINE_POWER_FORM:
                sin2 = min(max(1.0 - cos_emit * cos_emit, 0.0), 1.0)
                powered = sin2 * sin2 if half_n == 2.0 else sin2**half_n
                intensity = powered / up_norm
            elif emission == PSI4_LOBE_FORM:
                psi = math.acos(min(cos_emit, 1.0))
                psi2 = psi * psi
                intensity = lobe_norm * psi2 * psi2
            elif emission == TABLE_FORM:
                # linear interpolation in the emission angle (kernel.tabulated_emission_intensity)
                psi = math.acos(min(cos_emit, 1.0))
                k = min(max(np.searchsorted(emission_tab[0], psi) - 1, 0), last_tab - 1)
                span = emission_tab[0, k + 1] - emission_tab[0, k]
                frac = min(max((psi - emission_tab[0, k]) / span, 0.0), 1.0)
                intensity = emission_tab[1, k] + frac * (
                    emission_tab[1, k + 1] - emission_tab[1, k]
                )
            else:  # ISOTROPIC_FORM
                intensity = 1.0 / (2.0 * math.pi)
            cos_sc = -(tx * vx + ty * vy + tz * vz) * inv_s
            # altitude of the scattering point (geometry.altitude)
            if flat:
                h = pz
            else:
                rho2 = px * px + py * py + pz * pz + 2.0 * pz * radius
                h = rho2 / (math.sqrt(px * px + py * py + (pz + radius) ** 2) + radius)
            # scattering (Atmosphere.scattering) times, when tabulated, the observer leg
            if tabulated:
                zpos = math.sqrt(max(h - h_o, 0.0)) * inv_dz
                i = min(int(zpos), last - 1)
                frac = min(zpos - i, 1.0)
                dens_m = observer_table[0, i] + frac * (
                    observer_table[0, i + 1] - observer_table[0, i]
                )
                dens_a = observer_table[1, i] + frac * (
                    observer_table[1, i + 1] - observer_table[1, i]
                )
            else:
                dens_m = beta_m * math.exp(-h / h_m) if beta_m > 0.0 else 0.0
                dens_a = sigma_a * math.exp(-h / h_a) if sigma_a > 0.0 else 0.0
            scat = 0.0
            if beta_m > 0.0:
                phase_m = (
                    1.0 / (4.0 * math.pi)
                    if iso_molecules
                    else 3.0 / (16.0 * math.pi) * (1.0 + cos_sc * cos_sc)
                )
                scat += dens_m * phase_m
            if sigma_a > 0.0:
                base = hg_a - 2.0 * g * cos_sc
                scat += dens_a * hg_num / (base * math.sqrt(base))
            value = scat * intensity / (s2 + core2)
            if extinction:
                tau = 0.0
                if not tabulated:
                    tau = _observer_tau(u, se, flat, leg, table)
                if flat:
                    tau += _flat_tau(src_m, cos_emit, s, beta_m, h_m)
                    tau += _flat_tau(src_a, cos_emit, s, beta_a, h_a)
                else:
                    mu = min(cos_emit, 1.0)
                    root_curv = math.sqrt(max((1.0 - mu * mu) * inv_2rc, 1e-30))
                    inv_root_curv = 1.0 / root_curv
                    tau += _sphere_tau(
                        src_m,
                        mu,
                        root_curv,
                        inv_root_curv,
                        s,
                        beta_m,
                        inv_h_m,
                        root_h_m,
                        inv_root_h_m,
                        table,
                    )
                    tau += _sphere_tau(
                        src_a,
                        mu,
                        root_curv,
                        inv_root_curv,
                        s,
                        beta_a,
                        inv_h_a,
                        root_h_a,
                        inv_root_h_a,
                        table,
                    )
                value *= math.exp(-tau)
            total += value * weight
    return total


@njit(parallel=True, cache=True)
def _rays(
    el: FloatArray,
    az: FloatArray,
    r: FloatArray,
    h_c: FloatArray,
    h_o: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
    table: FloatArray,
    emission_tab: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    none = np.zeros((2, 0))
    flat = flags[_F_FLAT] != 0
    radius, top = p[_P_RADIUS], p[_P_TOP]
    for i in prange(el.size):
        if top <= 0.0 or el[i] <= 0.0:
            out[i] = 0.0
            continue
        vx, vy, vz = _view(el[i], az[i])
        sx, sz, nx, nz = _source(r[i], h_c[i], radius, flat)
        out[i] = _ray(
            vx,
            vy,
            vz,
            _top_distance(vz, h_o[i], top, radius, flat),
            sx,
            sz,
            nx,
            nz,
            h_c[i],
            h_o[i],
            _pair_constants(h_c[i], h_o[i], p),
            _leg(vz, h_o[i], p, table),
            x_gl,
            w_gl,
            p,
            flags,
            table,
            none,
            0.0,
            emission_tab,
        )


@njit(parallel=True, cache=True)
def _grid(
    el: FloatArray,
    az: FloatArray,
    r: FloatArray,
    h_c: float,
    h_o: float,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
    table: FloatArray,
    table_size: int,
    emission_tab: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    flat = flags[_F_FLAT] != 0
    radius, top = p[_P_RADIUS], p[_P_TOP]
    if top <= 0.0:
        return
    # the factors of each azimuth, distance and of the altitude pair, once
    cos_az, sin_az = np.empty(az.size), np.empty(az.size)
    for a in range(az.size):
        azimuth = math.radians(az[a])
        cos_az[a], sin_az[a] = math.cos(azimuth), math.sin(azimuth)
    frames = np.empty((r.size, 4))
    for k in range(r.size):
        sx, sz, nx, nz = _source(r[k], h_c, radius, flat)
        frames[k, 0], frames[k, 1], frames[k, 2], frames[k, 3] = sx, sz, nx, nz
    pair = _pair_constants(h_c, h_o, p)
    for e in prange(el.size):
        if el[e] <= 0.0:
            continue
        observer_table, inv_dz = _observer_table(el[e], h_o, p, flags, table, table_size)
        elevation = math.radians(el[e])
        ce, se = math.cos(elevation), math.sin(elevation)
        u_top = _top_distance(se, h_o, top, radius, flat)
        leg = _leg(se, h_o, p, table)
        for k in range(r.size):
            for a in range(az.size):
                out[e, a, k] = _ray(
                    ce * cos_az[a],
                    ce * sin_az[a],
                    se,
                    u_top,
                    frames[k, 0],
                    frames[k, 1],
                    frames[k, 2],
                    frames[k, 3],
                    h_c,
                    h_o,
                    pair,
                    leg,
                    x_gl,
                    w_gl,
                    p,
                    flags,
                    table,
                    observer_table,
                    inv_dz,
                    emission_tab,
                )


_TABLE = erfcx_table()


def luminance_rays(
    elevation: FloatArray,
    relative_azimuth: FloatArray,
    distance: FloatArray,
    source_altitude: FloatArray,
    observer_altitude: FloatArray,
    *,
    atmosphere: Atmosphere,
    emission: str,
    nodes: int,
    core_radius: float,
    uplight_exponent: float,
) -> FloatArray:
    """Sky luminance per lumen along flat arrays of rays (compiled; see ``sky_luminance``).

    Parameters
    ----------
    elevation, relative_azimuth
        Ray directions, shape ``(n,)`` [deg].
    distance
        Ground distances of the source, shape ``(n,)`` [m].
    source_altitude, observer_altitude
        Altitudes above sea level, shape ``(n,)`` [m].
    atmosphere
        Atmosphere model.
    emission
        Emission model name.
    nodes
        Gauss-Legendre nodes per panel [1].
    core_radius
        Softening radius [m].
    uplight_exponent
        Exponent of the uplight lobe [1].

    Returns
    -------
    numpy.ndarray
        Shape ``(n,)`` [cd m-2 lm-1].
    """
    params, flags = model_parameters(atmosphere, emission, core_radius, uplight_exponent)
    x, w = gauss_legendre(int(nodes))
    el, az, r, h_c, h_o = (
        np.array(a, dtype=np.float64, order="C")  # a writeable copy (inputs may be broadcast)
        for a in (elevation, relative_azimuth, distance, source_altitude, observer_altitude)
    )
    out = np.zeros(el.size)
    if out.size:
        _rays(el, az, r, h_c, h_o, x, w, params, flags, _TABLE, emission_table(emission), out)
    return out


#: Nodes of the observer-side table of :func:`luminance_grid` (uniform in sqrt(h - h_o)):
#: linear interpolation within 2e-5 relative at the lowest rays (see the tests).
OBSERVER_TABLE_SIZE = 16_384


def luminance_grid(
    elevation: FloatArray,
    relative_azimuth: FloatArray,
    distance: FloatArray,
    *,
    source_altitude: float,
    observer_altitude: float,
    atmosphere: Atmosphere,
    emission: str,
    nodes: int,
    core_radius: float,
    uplight_exponent: float,
    table_size: int = OBSERVER_TABLE_SIZE,
) -> FloatArray:
    """Sky luminance per lumen on the outer product of elevations, azimuths and distances.

    The kernel-table form of :func:`luminance_rays` for one source and one observer altitude:
    the observer-side factors of each view ray (density times the observer leg's
    transmission) do not depend on the azimuth or the source, so they are tabulated once per
    elevation against altitude and interpolated at the nodes.

    Parameters
    ----------
    elevation, relative_azimuth, distance
        1-D axes [deg], [deg], [m].
    source_altitude, observer_altitude
        Altitudes above sea level [m].
    atmosphere, emission, nodes, core_radius, uplight_exponent
        As :func:`luminance_rays` [1].
    table_size
        Nodes of the observer-side table [1].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_el, n_az, n_r)`` [cd m-2 lm-1].
    """
    params, flags = model_parameters(atmosphere, emission, core_radius, uplight_exponent)
    x, w = gauss_legendre(int(nodes))
    el, az, r = (
        np.ascontiguousarray(np.ravel(a), dtype=np.float64)
        for a in (elevation, relative_azimuth, distance)
    )
    out = np.zeros((el.size, az.size, r.size))
    if out.size:
        _grid(
            el,
            az,
            r,
            float(source_altitude),
            float(observer_altitude),
            x,
            w,
            params,
            flags,
            _TABLE,
            int(table_size),
            emission_table(emission),
            out,
        )
    return out
