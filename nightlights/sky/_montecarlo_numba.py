"""Compiled (numba) photon transport for the multiple-scattering Monte Carlo.

Frame (source-centred, unlike the observer-centred frame of :mod:`nightlights.sky.geometry`):
the source sits at (0, 0, h_c) with vertical (0, 0, 1), the Earth's centre at (0, 0, -R) on a
sphere, and the ground (sea level, black) is the sphere of radius R or the plane z = 0. An
observer at ground distance r sits at angle r / R from the source towards -x, so that the same
photon histories serve every observer distance and view direction (the atmosphere is
horizontally uniform and the emission symmetric about the source's vertical).

Optical depths of straight paths use the closed form of
:func:`nightlights.sky.kernel.slant_optical_depth` (second-order altitude along the path from
its lowest point), so that transport and estimator see the same atmosphere as the kernel; a
chord that dips is split at its lowest point, and one that passes below sea level is blocked.

The numpy reference of this module is :func:`nightlights.sky.montecarlo.point_source_luminance`
(the estimator of one scattering event) together with :func:`nightlights.sky.kernel.optical_depth`
(the free paths of a recorded photon), compared in the tests.

Length: about 910 lines, because the random-number stream, the transport, the
ray-integrated estimator and its azimuthal splitting are one compiled unit that numba inlines
together.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from nightlights._signals import deliver_signals, held_signals
from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    COSINE_FORM,
    ISOTROPIC_FORM,
    PSI4_LOBE_FORM,
    SINE_POWER_FORM,
    sampled_shape,
)
from nightlights.sky._kernel_numba import model_parameters as kernel_model_parameters
from nightlights.sky.atmosphere import Atmosphere

__all__ = ["BATCH_BLOCKS", "model_parameters", "observer_rays", "trace_photon", "transport"]

# layout of the float parameter vector
_P_BETA_M, _P_H_M, _P_BETA_A, _P_H_A, _P_ALBEDO, _P_G = 0, 1, 2, 3, 4, 5
_P_RADIUS, _P_TOP, _P_CORE, _P_HALF_N, _P_UP_NORM, _P_MIN_H, _P_LOBE_NORM = (6, 7, 8, 9, 10, 11, 12)
_P_H_C = 13  # after the kernel's own vector (nightlights.sky._kernel_numba.model_parameters)
# layout of the integer flags (the kernel's; extinction is always on here)
_F_FLAT, _F_EMISSION, _F_ISOTROPIC_MOLECULES = 0, 2, 3
# layout of a ray row: observer position, view direction, sin(elevation), observer altitude,
# distance to the top of the model atmosphere
_R_OX, _R_OY, _R_OZ, _R_VX, _R_VY, _R_VZ, _R_SIN_EL, _R_H_O, _R_U_TOP = range(9)
# flux budget: escaped at the top, absorbed by the ground, absorbed by aerosols, left in flight
_B_TOP, _B_GROUND, _B_ABSORBED, _B_TRUNCATED = range(4)

#: Above this argument erfcx is evaluated by its asymptotic series (relative error < 1e-10).
_ERFCX_SERIES_FROM = 25.0
#: Free-path root finding stops when the optical depth matches within this [1].
_TAU_TOLERANCE = 1e-11
_SQRT_PI = math.sqrt(math.pi)
_TWO_POW_53 = 1.0 / 9007199254740992.0
#: Salt of the second random stream of a photon (the azimuthal splitting's offsets).
_SPLIT_SALT = np.uint64(0x6A09E667F3BCC909)
#: Half-length of the split arc along the event's circle, in windows (at most the circle) [1].
_ARC_WINDOWS = 4.0
#: Photons per block in one compiled call of :func:`transport`, between two looks at a held
#: Ctrl-C: 256 photons with the default 64 blocks, a second or two on two cores [1].
BATCH_BLOCKS = 4


def model_parameters(
    atmosphere: Atmosphere,
    emission: str,
    core_radius: float,
    uplight_exponent: float,
    source_altitude: float,
) -> tuple[FloatArray, NDArray[np.int64]]:
    """The kernel's parameter and flag vectors with the source altitude appended (shapes of
    the forms in :data:`~nightlights.emission_functions.SAMPLED_FORMS` only)."""
    sampled_shape(emission)
    params, flags = kernel_model_parameters(atmosphere, emission, core_radius, uplight_exponent)
    return np.append(params, float(source_altitude)), flags


def observer_rays(
    elevation: FloatArray,
    relative_azimuth: FloatArray,
    distance: FloatArray,
    observer_altitude: FloatArray,
    atmosphere: Atmosphere,
) -> FloatArray:
    """Rows (observer position, view direction, sin el, h_o, u_top) in the source frame.

    Parameters
    ----------
    elevation, relative_azimuth
        View directions, 1-D [deg].
    distance
        Ground distance of the source, 1-D [m].
    observer_altitude
        Observer altitude above sea level, 1-D [m].
    atmosphere
        Atmosphere model.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, 9)``.
    """
    el = np.radians(elevation)
    az = np.radians(relative_azimuth)
    radius = atmosphere.earth_radius
    top = atmosphere.top_altitude
    rows = np.zeros((el.size, 9))
    ce, se = np.cos(el), np.sin(el)
    if atmosphere.flat_earth:
        ang = np.zeros(el.size)
        ox = -distance
        oz = observer_altitude.copy()
    else:
        ang = distance / radius
        ox = -(radius + observer_altitude) * np.sin(ang)
        # z = (R + h) cos(a) - R, as in geometry.source_frame
        oz = observer_altitude * np.cos(ang) - radius * 2.0 * np.sin(ang / 2.0) ** 2
    # observer's vertical (-sin a, 0, cos a), towards the source (cos a, 0, sin a), y kept
    toward_x, toward_z = np.cos(ang), np.sin(ang)
    up_x, up_z = -np.sin(ang), np.cos(ang)
    rows[:, _R_OX] = ox
    rows[:, _R_OZ] = oz
    rows[:, _R_VX] = ce * np.cos(az) * toward_x + se * up_x
    rows[:, _R_VY] = ce * np.sin(az)
    rows[:, _R_VZ] = ce * np.cos(az) * toward_z + se * up_z
    rows[:, _R_SIN_EL] = se
    rows[:, _R_H_O] = observer_altitude
    gap = np.maximum(top - observer_altitude, 0.0)
    if atmosphere.flat_earth:
        rows[:, _R_U_TOP] = np.where(se > 0, gap / np.where(se > 0, se, 1.0), 0.0)
    else:
        ro = radius + observer_altitude
        b = ro * se
        cdiff = gap * (2.0 * radius + top + observer_altitude)
        root = np.sqrt(b * b + cdiff)
        u_top = np.where(b > 0, cdiff / np.where(b + root > 0, b + root, 1.0), root - b)
        rows[:, _R_U_TOP] = np.where(se > 0, u_top, 0.0)
    return rows


# --------------------------------------------------------------------------------------------
# Random numbers: SplitMix64 (Steele, Lea & Flood 2014), one stream per photon


@njit(cache=True, inline="always")
def _next(state: NDArray[np.uint64]) -> float:  # pragma: no cover - compiled
    """Uniform number in (0, 1] from a SplitMix64 stream (advances ``state[0]``)."""
    state[0] += np.uint64(0x9E3779B97F4A7C15)
    z = state[0]
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (float(z >> np.uint64(11)) + 1.0) * _TWO_POW_53


@njit(cache=True)
def _seed_state(seed: int, photon: int) -> NDArray[np.uint64]:  # pragma: no cover - compiled
    """Independent stream of photon ``photon`` under ``seed``."""
    state = np.empty(1, dtype=np.uint64)
    state[0] = np.uint64(seed) * np.uint64(0xD1B54A32D192ED03) + np.uint64(photon)
    _next(state)  # decorrelate neighbouring photons
    return state


# --------------------------------------------------------------------------------------------
# Atmosphere


@njit(cache=True, inline="always")
def _erfcx(x: float) -> float:  # pragma: no cover - compiled
    """Scaled complementary error function exp(x^2) erfc(x) for x >= 0."""
    if x < _ERFCX_SERIES_FROM:
        return math.exp(x * x) * math.erfc(x)
    y = 1.0 / (x * x)
    return (1.0 - 0.5 * y * (1.0 - 1.5 * y * (1.0 - 2.5 * y))) / (x * _SQRT_PI)


@njit(cache=True, inline="always")
def _species_slant(
    beta: float, height: float, h0: float, mu: float, length: float, radius: float, flat: bool
) -> float:  # pragma: no cover - compiled
    """One species' optical depth of an upward path (kernel.slant_optical_depth)."""
    if beta <= 0.0 or length <= 0.0:
        return 0.0
    if flat:
        m_l = mu * length / height
        mean = -math.expm1(-m_l) / m_l if m_l > 1e-12 else 1.0 - 0.5 * m_l
        return beta * math.exp(-h0 / height) * length * mean
    k = max((1.0 - mu * mu) / (2.0 * (radius + h0)), 1e-30) / height
    sk = math.sqrt(k)
    x0 = (mu / height) / (2.0 * sk)
    ratio = math.exp(-(mu / height + k * length) * length)
    bracket = _erfcx(x0) - _erfcx(x0 + sk * length) * ratio
    return beta * 0.5 * _SQRT_PI * math.exp(-h0 / height) / sk * bracket


@njit(cache=True, inline="always")
def _slant(
    h0: float, mu: float, length: float, p: FloatArray, flat: bool
) -> float:  # pragma: no cover
    """Optical depth of an upward path from altitude h0 with zenith cosine mu [1]."""
    mu = min(max(mu, 0.0), 1.0)
    radius = p[_P_RADIUS]
    return _species_slant(p[_P_BETA_M], p[_P_H_M], h0, mu, length, radius, flat) + _species_slant(
        p[_P_BETA_A], p[_P_H_A], h0, mu, length, radius, flat
    )


@njit(cache=True, inline="always")
def _altitude(x: float, y: float, z: float, radius: float, flat: bool) -> float:  # pragma: no cover
    """Altitude above sea level (geometry.altitude)."""
    if flat:
        return z
    rho2 = x * x + y * y + z * z + 2.0 * z * radius
    return rho2 / (math.sqrt(x * x + y * y + (z + radius) ** 2) + radius)


@njit(cache=True)
def _chord_tau(
    x1: float,
    y1: float,
    z1: float,
    x2: float,
    y2: float,
    z2: float,
    p: FloatArray,
    flat: bool,
) -> float:  # pragma: no cover - compiled
    """Optical depth of the straight segment P1 -> P2; inf when it passes below sea level."""
    dx, dy, dz = x2 - x1, y2 - y1, z2 - z1
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length <= 0.0:
        return 0.0
    if flat:
        lo = min(z1, z2)
        if lo < 0.0:
            return math.inf
        tau = 0.0
        dh = abs(z2 - z1)
        for beta, height in ((p[_P_BETA_M], p[_P_H_M]), (p[_P_BETA_A], p[_P_H_A])):
            if beta > 0.0:
                xx = dh / height
                mean = -math.expm1(-xx) / xx if xx > 1e-12 else 1.0 - 0.5 * xx
                tau += beta * length * math.exp(-lo / height) * mean
        return tau
    radius = p[_P_RADIUS]
    dx, dy, dz = dx / length, dy / length, dz / length
    cz1 = z1 + radius
    rho1 = math.sqrt(x1 * x1 + y1 * y1 + cz1 * cz1)
    along = x1 * dx + y1 * dy + cz1 * dz  # (P1 - C) . d
    t_low = -along  # distance to the lowest point of the line
    h1 = _altitude(x1, y1, z1, radius, False)
    if t_low <= 0.0:  # rising all the way
        return _slant(h1, along / rho1, length, p, False)
    h2 = _altitude(x2, y2, z2, radius, False)
    if t_low >= length:  # falling all the way: integrate upwards from P2
        cz2 = z2 + radius
        rho2 = math.sqrt(x2 * x2 + y2 * y2 + cz2 * cz2)
        return _slant(h2, -(x2 * dx + y2 * dy + cz2 * dz) / rho2, length, p, False)
    # dips: split at the lowest point (both halves rise from it horizontally)
    sin2 = max(1.0 - (along / rho1) ** 2, 0.0)
    h_low = (rho1 * rho1 * sin2 - radius * radius) / (rho1 * math.sqrt(sin2) + radius)
    if h_low < 0.0:
        return math.inf
    return _slant(h_low, 0.0, t_low, p, False) + _slant(h_low, 0.0, length - t_low, p, False)


@njit(cache=True, inline="always")
def _coefficients(h: float, p: FloatArray) -> tuple[float, float]:  # pragma: no cover
    """Molecular and aerosol extinction coefficients at altitude h [m-1]."""
    return p[_P_BETA_M] * math.exp(-h / p[_P_H_M]), p[_P_BETA_A] * math.exp(-h / p[_P_H_A])


@njit(cache=True, inline="always")
def _scattering(h: float, mu: float, p: FloatArray, iso: bool) -> float:  # pragma: no cover
    """sigma_R p_R + albedo sigma_A p_HG at altitude h, scattering cosine mu [m-1 sr-1]."""
    sig_m, sig_a = _coefficients(h, p)
    pm = 1.0 / (4.0 * math.pi) if iso else 3.0 / (16.0 * math.pi) * (1.0 + mu * mu)
    g = p[_P_G]
    pa = (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * mu) ** 1.5)
    return sig_m * pm + p[_P_ALBEDO] * sig_a * pa


@njit(cache=True, inline="always")
def _emission(mu: float, code: int, p: FloatArray) -> float:  # pragma: no cover - compiled
    """Intensity per lumen at emission cosine mu (emission_shapes.form_intensity) [cd lm-1]."""
    if mu <= 0.0:
        return 0.0
    if code == COSINE_FORM:
        return mu / math.pi
    if code == SINE_POWER_FORM:
        return max(1.0 - mu * mu, 0.0) ** p[_P_HALF_N] / p[_P_UP_NORM]
    if code == PSI4_LOBE_FORM:  # Garstang's psi^4 lobe, psi the emission zenith angle
        psi = math.acos(min(mu, 1.0))
        return p[_P_LOBE_NORM] * psi**4 / (2.0 * math.pi)
    return 1.0 / (2.0 * math.pi)


# --------------------------------------------------------------------------------------------
# Sampling


@njit(cache=True)
def _sample_emission(
    state: NDArray[np.uint64], code: int, p: FloatArray
) -> float:  # pragma: no cover
    """Cosine of the emission angle from the source's vertical, distributed as I dOmega."""
    if code == COSINE_FORM:
        return math.sqrt(_next(state))  # Lambertian: mu^2 uniform
    if code == ISOTROPIC_FORM:
        return _next(state)
    while True:  # uniform mu accepted with the intensity relative to its peak at the horizon
        mu = _next(state)
        if code == PSI4_LOBE_FORM:
            accept = (math.acos(min(mu, 1.0)) / (0.5 * math.pi)) ** 4
        else:
            accept = max(1.0 - mu * mu, 0.0) ** p[_P_HALF_N]
        if _next(state) <= accept:
            return mu


@njit(cache=True, inline="always")
def _sample_rayleigh(u: float) -> float:  # pragma: no cover - compiled
    """Scattering cosine of the Rayleigh phase function: mu^3 + 3 mu = 8 u - 4 solved exactly."""
    q = 4.0 * u - 2.0
    a = (q + math.sqrt(q * q + 1.0)) ** (1.0 / 3.0)
    return a - 1.0 / a


@njit(cache=True, inline="always")
def _sample_hg(u: float, g: float) -> float:  # pragma: no cover - compiled
    """Scattering cosine of the Henyey-Greenstein phase function (inverse of its CDF)."""
    if abs(g) < 1e-6:
        return 2.0 * u - 1.0
    frac = (1.0 - g * g) / (1.0 - g + 2.0 * g * u)
    return min(max((1.0 + g * g - frac * frac) / (2.0 * g), -1.0), 1.0)


@njit(cache=True, inline="always")
def _turn(
    dx: float, dy: float, dz: float, mu: float, phi: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Direction at angle acos(mu) from (dx, dy, dz), azimuth phi about it."""
    st = math.sqrt(max(1.0 - mu * mu, 0.0))
    cp, sp = math.cos(phi), math.sin(phi)
    if abs(dz) > 0.99999:
        sign = 1.0 if dz > 0 else -1.0
        return st * cp, st * sp, sign * mu
    den = math.sqrt(1.0 - dz * dz)
    nx = st * (dx * dz * cp - dy * sp) / den + dx * mu
    ny = st * (dy * dz * cp + dx * sp) / den + dy * mu
    nz = -st * cp * den + dz * mu
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    return nx / norm, ny / norm, nz / norm


@njit(cache=True)
def _boundary(
    x: float, y: float, z: float, dx: float, dy: float, dz: float, p: FloatArray, flat: bool
) -> tuple[float, int]:  # pragma: no cover - compiled
    """Distance to where the photon leaves: the top (_B_TOP) or the ground (_B_GROUND)."""
    top = p[_P_TOP]
    if flat:
        if dz < 0.0:
            return z / -dz, _B_GROUND
        if dz > 0.0:
            return (top - z) / dz, _B_TOP
        return 1e12, _B_TOP
    radius = p[_P_RADIUS]
    h = _altitude(x, y, z, radius, False)
    b = x * dx + y * dy + (z + radius) * dz
    above_ground = h * (2.0 * radius + h)  # |P - C|^2 - R^2
    if b < 0.0:
        disc = b * b - above_ground
        if disc > 0.0:
            return above_ground / (-b + math.sqrt(disc)), _B_GROUND
    below_top = (h - top) * (2.0 * radius + h + top)  # |P - C|^2 - (R + top)^2 < 0
    root = math.sqrt(b * b - below_top)
    return (-below_top / (b + root) if b > 0.0 else root - b), _B_TOP


@njit(cache=True)
def _free_path(
    x: float,
    y: float,
    z: float,
    dx: float,
    dy: float,
    dz: float,
    tau_star: float,
    s_end: float,
    p: FloatArray,
    flat: bool,
) -> float:  # pragma: no cover - compiled
    """Distance at which the optical depth from (x, y, z) along d reaches tau_star < tau(s_end)."""
    radius = p[_P_RADIUS]
    lo, hi = 0.0, s_end
    sig_m, sig_a = _coefficients(_altitude(x, y, z, radius, flat), p)
    s = min(tau_star / (sig_m + sig_a), 0.5 * s_end)
    for _ in range(200):
        px, py, pz = x + s * dx, y + s * dy, z + s * dz
        f = _chord_tau(x, y, z, px, py, pz, p, flat) - tau_star
        if abs(f) <= _TAU_TOLERANCE * max(tau_star, 1.0):
            return s
        if f > 0.0:
            hi = s
        else:
            lo = s
        sig_m, sig_a = _coefficients(_altitude(px, py, pz, radius, flat), p)
        step = s - f / (sig_m + sig_a)
        s = step if lo < step < hi else 0.5 * (lo + hi)
        if hi - lo < 1e-9 * max(hi, 1.0):
            return s
    return s


# --------------------------------------------------------------------------------------------
# Ray-integrated estimator


@njit(cache=True)
def _ray_integral(
    qx: float,
    qy: float,
    qz: float,
    from_source: bool,
    ix: float,
    iy: float,
    iz: float,
    ray: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
) -> float:  # pragma: no cover - compiled
    """Luminance along one view ray of light scattered once more after a point event at Q.

    ``from_source``: Q is the ground source (intensity :func:`_emission` about its vertical,
    the ray clipped to above its tangent plane, closed-form leg from below); otherwise Q is a
    scattering event of a photon arriving along (ix, iy, iz) with unit flux, whose intensity
    is the phase mixture (:func:`_scattering` at Q divided by the scattering coefficient).
    """
    flat = flags[_F_FLAT] != 0
    iso = flags[_F_ISOTROPIC_MOLECULES] != 0
    code = flags[_F_EMISSION]
    radius = p[_P_RADIUS]
    core2 = p[_P_CORE] * p[_P_CORE]
    ox, oy, oz = ray[_R_OX], ray[_R_OY], ray[_R_OZ]
    vx, vy, vz = ray[_R_VX], ray[_R_VY], ray[_R_VZ]
    se, h_o = ray[_R_SIN_EL], ray[_R_H_O]
    start, stop = 0.0, ray[_R_U_TOP]
    if stop <= 0.0:
        return 0.0
    relx, rely, relz = qx - ox, qy - oy, qz - oz
    h_c = p[_P_H_C]
    if from_source:  # keep the part of the ray above the source's tangent plane z = h_c
        gap = -relz  # height of the observer above that plane
        cross = -gap / vz if vz != 0.0 else math.inf
        if vz > 0.0:
            start = max(cross, 0.0)
        elif vz < 0.0:
            stop = min(stop, cross if gap > 0.0 else 0.0)
        elif gap <= 0.0:
            stop = 0.0
        stop = max(stop, start)
        if stop <= start:
            return 0.0
        sig_sum = 1.0
    else:
        sig_m, sig_a = _coefficients(_altitude(qx, qy, qz, radius, flat), p)
        sig_sum = sig_m + p[_P_ALBEDO] * sig_a
        if sig_sum <= 0.0:
            return 0.0
    u_p = relx * vx + rely * vy + relz * vz
    cx = rely * vz - relz * vy
    cy = relz * vx - relx * vz
    cz = relx * vy - rely * vx
    d_eff = math.sqrt(cx * cx + cy * cy + cz * cz + core2)
    split = min(max(u_p, start), stop)
    length = p[_P_MIN_H] / max(se, 1e-3)
    knee = min(max(split + max(length, d_eff), split), stop)
    h_q = _altitude(qx, qy, qz, radius, flat)
    total = 0.0
    n = x_gl.size
    for panel in range(3):
        lo = start if panel == 0 else (split if panel == 1 else knee)
        hi = split if panel == 0 else (knee if panel == 1 else stop)
        if hi <= lo:
            continue
        ta = math.atan((lo - u_p) / d_eff)
        tb = math.atan((hi - u_p) / d_eff)
        half = 0.5 * (tb - ta)
        mid = 0.5 * (ta + tb)
        for i in range(n):
            t = mid + half * x_gl[i]
            u = u_p + d_eff * math.tan(t)
            ct = math.cos(t)
            weight = half * w_gl[i] * d_eff / (ct * ct)
            px, py, pz = ox + u * vx, oy + u * vy, oz + u * vz
            tx, ty, tz = px - qx, py - qy, pz - qz
            s2 = tx * tx + ty * ty + tz * tz
            s = math.sqrt(s2)
            inv_s = 1.0 / s if s > 0.0 else 0.0
            cos_scatter = -(tx * vx + ty * vy + tz * vz) * inv_s
            h = _altitude(px, py, pz, radius, flat)
            if from_source:
                cos_emit = tz * inv_s  # the source's vertical is (0, 0, 1) in this frame
                intensity = _emission(cos_emit, code, p)
                if intensity <= 0.0:
                    continue
                tau = _slant(h_c, cos_emit, s, p, flat)
            else:
                mu_in = (ix * tx + iy * ty + iz * tz) * inv_s
                intensity = _scattering(h_q, mu_in, p, iso) / sig_sum
                tau = _chord_tau(qx, qy, qz, px, py, pz, p, flat)
                if tau == math.inf:
                    continue
            tau += _slant(h_o, se, u, p, flat)
            value = _scattering(h, cos_scatter, p, iso) * intensity / (s2 + core2)
            total += weight * value * math.exp(-tau)
    return total


@njit(cache=True, inline="always")
def _ray_parameter_at(
    ray: FloatArray, h: float, p: FloatArray, flat: bool
) -> float:  # pragma: no cover
    """Distance along a view ray to where it reaches altitude h, clamped to [0, u_top] [m]."""
    vz, h_o, u_top = ray[_R_VZ], ray[_R_H_O], ray[_R_U_TOP]
    if flat:
        u = (h - h_o) / vz if vz > 0.0 else 0.0
    else:
        radius = p[_P_RADIUS]
        b = ray[_R_OX] * ray[_R_VX] + ray[_R_OY] * ray[_R_VY] + (ray[_R_OZ] + radius) * vz
        c = (h_o - h) * (2.0 * radius + h_o + h)  # |O - C|^2 - (R + h)^2
        disc = b * b - c
        if disc < 0.0:
            u = -b
        elif c < 0.0:
            root = math.sqrt(disc)
            u = -c / (b + root) if b > 0.0 else root - b
        else:
            u = math.sqrt(disc) - b
    return min(max(u, 0.0), u_top)


@njit(cache=True)
def _event_estimate(
    x: float,
    y: float,
    z: float,
    dx: float,
    dy: float,
    dz: float,
    ray: FloatArray,
    window: float,
    points: int,
    shift: float,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
) -> float:  # pragma: no cover - compiled
    """One event's estimate along one ray, averaged over rotations about the source's vertical
    where the event's circle passes near the ray (see :func:`transport`); ``shift`` in (0, 1]
    is the stratification offset of the rotations."""
    if window <= 0.0 or points < 1:
        return _ray_integral(x, y, z, False, dx, dy, dz, ray, x_gl, w_gl, p, flags)
    flat = flags[_F_FLAT] != 0
    s = math.sqrt(x * x + y * y)
    # the arc of the event's circle nearest the ray: centred on the azimuth of the ray's point
    # at the event's altitude, so that it depends on (s, z) and the ray only
    u = _ray_parameter_at(ray, _altitude(x, y, z, p[_P_RADIUS], flat), p, flat)
    ox, oy, oz = ray[_R_OX], ray[_R_OY], ray[_R_OZ]
    vx, vy, vz = ray[_R_VX], ray[_R_VY], ray[_R_VZ]
    centre = math.atan2(oy + u * vy, ox + u * vx)
    qx, qy = s * math.cos(centre), s * math.sin(centre)
    rx, ry, rz = qx - ox, qy - oy, z - oz
    t = min(max(rx * vx + ry * vy + rz * vz, 0.0), ray[_R_U_TOP])
    ex, ey, ez = rx - t * vx, ry - t * vy, rz - t * vz
    gap = math.sqrt(ex * ex + ey * ey + ez * ez)
    if gap >= window or s <= p[_P_CORE]:
        return _ray_integral(x, y, z, False, dx, dy, dz, ray, x_gl, w_gl, p, flags)
    length = min(_ARC_WINDOWS * window, math.pi * s)  # half-length of the arc [m]
    half = length / s
    azimuth = math.atan2(y, x)
    off = (azimuth - centre + math.pi) % (2.0 * math.pi) - math.pi
    total = 0.0
    if abs(off) > half:  # outside the arc: the event itself
        total = _ray_integral(x, y, z, False, dx, dy, dz, ray, x_gl, w_gl, p, flags)
    # arc length l = g sinh(t), t stratified: density 1 / sqrt(g^2 + l^2) along the arc, the
    # shape of the 1 / d peak of an event passing at gap g from the ray
    g = max(gap, p[_P_CORE])
    t_max = math.asinh(length / g)
    step = 2.0 * t_max / points
    part = 0.0
    for k in range(points):
        t = -t_max + (k + shift) * step
        angle = centre + g * math.sinh(t) / s - azimuth  # rotation of the event
        ca, sa = math.cos(angle), math.sin(angle)
        part += (
            g
            * math.cosh(t)
            * _ray_integral(
                x * ca - y * sa,
                x * sa + y * ca,
                z,
                False,
                dx * ca - dy * sa,
                dx * sa + dy * ca,
                dz,
                ray,
                x_gl,
                w_gl,
                p,
                flags,
            )
        )
    return total + part * step / (2.0 * math.pi * s)


@njit(cache=True)
def _source_luminance(
    rays: FloatArray, x_gl: FloatArray, w_gl: FloatArray, p: FloatArray, flags: NDArray[np.int64]
) -> FloatArray:  # pragma: no cover - compiled
    """Single scattering (order 1) along every ray: the source as the first event."""
    out = np.zeros(rays.shape[0])
    for j in range(rays.shape[0]):
        out[j] = _ray_integral(
            0.0, 0.0, p[_P_H_C], True, 0.0, 0.0, 1.0, rays[j], x_gl, w_gl, p, flags
        )
    return out


@njit(cache=True)
def _history(
    seed: int,
    photon: int,
    max_order: int,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
    windows: FloatArray,
    points: int,
    tally: FloatArray,
    budget: FloatArray,
    record: FloatArray,
) -> int:  # pragma: no cover - compiled
    """Follow one photon (1 lm) from the source until it leaves, is absorbed, or scatters
    ``max_order - 1`` times; add each event's estimate of order k + 1 to ``tally[k + 1, :]``
    and its fate to ``budget``. Rows of ``record`` (when it has any) receive, per event:
    position (3), incoming direction (3), weight before the event (1), sampled optical depth
    of the flight that ended there (1). Returns the number of events."""
    flat = flags[_F_FLAT] != 0
    iso = flags[_F_ISOTROPIC_MOLECULES] != 0
    radius = p[_P_RADIUS]
    state = _seed_state(seed, photon)
    split_state = _seed_state(seed, photon)  # a second stream: the histories do not change
    split_state[0] ^= _SPLIT_SALT
    mu = _sample_emission(state, flags[_F_EMISSION], p)
    dx, dy, dz = _turn(0.0, 0.0, 1.0, mu, 2.0 * math.pi * _next(state))
    x, y, z = 0.0, 0.0, p[_P_H_C]
    weight = 1.0
    order = 0
    while True:
        if order + 1 >= max_order:  # further events would only feed orders > max_order
            budget[_B_TRUNCATED] += weight
            return order
        tau_star = -math.log(_next(state))
        s_end, fate = _boundary(x, y, z, dx, dy, dz, p, flat)
        ex, ey, ez = x + s_end * dx, y + s_end * dy, z + s_end * dz
        if tau_star >= _chord_tau(x, y, z, ex, ey, ez, p, flat):
            budget[fate] += weight
            return order
        s = _free_path(x, y, z, dx, dy, dz, tau_star, s_end, p, flat)
        x, y, z = x + s * dx, y + s * dy, z + s * dz
        if order < record.shape[0]:
            row = record[order]
            row[0], row[1], row[2], row[3], row[4], row[5] = x, y, z, dx, dy, dz
            row[6], row[7] = weight, tau_star
        order += 1
        # the mixture's albedo: the photon keeps the scattered part of its flux
        sig_m, sig_a = _coefficients(_altitude(x, y, z, radius, flat), p)
        sig_s = sig_m + p[_P_ALBEDO] * sig_a
        survive = sig_s / (sig_m + sig_a)
        budget[_B_ABSORBED] += weight * (1.0 - survive)
        weight *= survive
        shift = _next(split_state)
        for j in range(rays.shape[0]):
            tally[order + 1, j] += weight * _event_estimate(
                x, y, z, dx, dy, dz, rays[j], windows[j], points, shift, x_gl, w_gl, p, flags
            )
        # new direction: species by its share of scattering, then its phase function
        if _next(state) * sig_s < sig_m:
            mu = 2.0 * _next(state) - 1.0 if iso else _sample_rayleigh(_next(state))
        else:
            mu = _sample_hg(_next(state), p[_P_G])
        dx, dy, dz = _turn(dx, dy, dz, mu, 2.0 * math.pi * _next(state))


@njit(parallel=True, cache=True)
def _transport(
    seed: int,
    first: int,
    last: int,
    max_order: int,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    flags: NDArray[np.int64],
    windows: FloatArray,
    points: int,
    sums: FloatArray,
    squares: FloatArray,
    total_squares: FloatArray,
    budgets: FloatArray,
    events: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Add photons ``first`` to ``last`` - 1 to the per-block sums (block b takes the photons
    b, b + blocks, ... in order; ``first`` is a multiple of the blocks): the order tallies,
    their squares, the squares of the per-photon sum over orders >= 2, the flux budget and the
    event counts, arrays whose first axis is the block."""
    blocks = sums.shape[0]
    n_rays = rays.shape[0]
    no_record = np.zeros((0, 8))
    for b in prange(blocks):
        tally = np.zeros((max_order + 1, n_rays))
        for photon in range(first + b, last, blocks):
            tally[:] = 0.0
            events[b] += _history(
                seed,
                photon,
                max_order,
                rays,
                x_gl,
                w_gl,
                p,
                flags,
                windows,
                points,
                tally,
                budgets[b],
                no_record,
            )
            for k in range(max_order + 1):
                for j in range(n_rays):
                    sums[b, k, j] += tally[k, j]
                    squares[b, k, j] += tally[k, j] * tally[k, j]
            for j in range(n_rays):
                t = 0.0
                for k in range(max_order + 1):
                    t += tally[k, j]
                total_squares[b, j] += t * t


def transport(
    seed: int,
    photons: int,
    max_order: int,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    params: FloatArray,
    flags: NDArray[np.int64],
    blocks: int = 64,
    windows: FloatArray | None = None,
    points: int = 0,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, float, FloatArray]:
    """Run ``photons`` histories; the result does not depend on the number of threads.

    The histories run in batches of ``blocks`` x :data:`BATCH_BLOCKS` photons, with Ctrl-C
    and ``SIGTERM`` held during each batch and raised between two
    (:func:`~nightlights._signals.held_signals`); each block adds its photons in the same
    order whatever the batches, so the sums are those of one run.

    Azimuthal splitting (``windows``, ``points``): the atmosphere and the emission are
    symmetric about the source's vertical, so an event rotated by any angle about it is an
    event of the same distribution. When the circle of an event (its rotations) passes within
    ``windows[j]`` of ray j (the gap g measured at the circle's point at the azimuth of the
    ray's point at the event's altitude: a function of the event's radius and altitude and of
    the ray, not of the event's own azimuth), its estimate is the arc A of half-length
    L = min(4 window, pi s) about that point, sampled at ``points`` rotations with arc length
    g sinh(t), t stratified (density 1 / sqrt(g^2 + l^2) along the arc, weighted by its
    inverse), plus the event itself when it lies outside A. Its expectation is the event's
    (each part is that of a uniform azimuth); the rare events that pass near a ray far from
    the source, which carry most of the variance there, are replaced by an importance-sampled
    average over their arc. The stratification offsets come from a second random stream per
    photon, so the histories are those of the unsplit estimator.

    Parameters
    ----------
    windows
        Per ray: distance from its ray under which an event's circle is split; None or 0:
        no splitting [m].
    points
        Rotations sampled on the arc [1].

    Returns
    -------
    sums, squares : numpy.ndarray
        Shape ``(max_order + 1, n_rays)``: sums over photons of each order's estimate (rows 0
        and 1 stay 0: order 1 is :func:`source_luminance`) and of their squares.
    total_squares : numpy.ndarray
        Shape ``(n_rays,)``: sum over photons of the square of the sum over orders >= 2.
    budget : numpy.ndarray
        Flux [lm] that left at the top, reached the ground, was absorbed, was left in flight.
    events : float
        Number of scattering events.
    order1 : numpy.ndarray
        Order-1 luminance per ray.
    """
    blocks = max(1, min(blocks, photons))
    win = np.zeros(rays.shape[0]) if windows is None else np.asarray(windows, dtype=float)
    n_rays = rays.shape[0]
    sums = np.zeros((blocks, max_order + 1, n_rays))
    squares = np.zeros((blocks, max_order + 1, n_rays))
    total_squares = np.zeros((blocks, n_rays))
    budgets = np.zeros((blocks, 4))
    events = np.zeros(blocks)
    step = blocks * BATCH_BLOCKS
    # Ctrl-C (or SIGTERM) waits for the end of a batch: raised inside the compiled, threaded
    # call it would crash the process; the photons' order in each block, and so every sum,
    # is that of one call
    with held_signals():
        for first in range(0, photons, step):
            _transport(
                int(seed),
                first,
                min(first + step, int(photons)),
                int(max_order),
                rays,
                x_gl,
                w_gl,
                params,
                flags,
                win,
                int(points),
                sums,
                squares,
                total_squares,
                budgets,
                events,
            )
            deliver_signals()
        order1 = _source_luminance(rays, x_gl, w_gl, params, flags)
    return (
        sums.sum(axis=0),
        squares.sum(axis=0),
        total_squares.sum(axis=0),
        budgets.sum(axis=0),
        float(events.sum()),
        order1,
    )


def source_luminance(
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    params: FloatArray,
    flags: NDArray[np.int64],
) -> FloatArray:
    """Order-1 luminance along every ray [cd m-2 lm-1]."""
    return _source_luminance(rays, x_gl, w_gl, params, flags)


def trace_photon(
    seed: int,
    photon: int,
    max_order: int,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    params: FloatArray,
    flags: NDArray[np.int64],
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One photon's history, for the numpy reference.

    Returns
    -------
    record : numpy.ndarray
        Shape ``(events, 8)``: position, incoming direction, weight before the event and the
        optical depth sampled for the flight that ended there.
    tally : numpy.ndarray
        Shape ``(max_order + 1, n_rays)``: the photon's estimate per order.
    budget : numpy.ndarray
        Its fate (see :func:`transport`).
    """
    tally = np.zeros((max_order + 1, rays.shape[0]))
    budget = np.zeros(4)
    record = np.zeros((max_order, 8))
    windows = np.zeros(rays.shape[0])
    n = _history(
        seed, photon, max_order, rays, x_gl, w_gl, params, flags, windows, 0, tally, budget, record
    )
    return record[:n], tally, budget
