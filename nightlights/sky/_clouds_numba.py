"""Compiled photon transport under a cloud deck (:mod:`nightlights.sky.clouds_montecarlo`).

Flat, plane-parallel layer between the ground (z = 0) and the cloud base (z = H), two
exponential species. Photons leave a uniform disc (radius 0: a point) with a Lambertian
distribution; free paths are sampled by inverting the chord's optical depth (bisection on the
closed form); at the base the flux is reflected (Lambertian, downwards) with R, transmitted
(counted as escaping) with T; at the ground reflected (Lambertian, upwards) with A_g and
absorbed otherwise. Every event (the emission itself, each collision, each reflection) adds the
expected luminance of its next step to every view ray: the single scattering of its light along
the ray below the base, and its irradiance of the base at the ray's end, reflected with R / pi
and attenuated to the observer.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nightlights._typing import FloatArray
from nightlights.sky._montecarlo_numba import (
    _next,
    _sample_hg,
    _sample_rayleigh,
    _seed_state,
    _turn,
)

# parameter vector
P_BETA_M, P_H_M, P_BETA_A, P_H_A, P_OMEGA_A, P_G = 0, 1, 2, 3, 4, 5
P_HEIGHT, P_R, P_T, P_GROUND, P_DISC, P_CORE, P_ISO = 6, 7, 8, 9, 10, 11, 12
N_PARAMS = 13

_INV_4PI = 1.0 / (4.0 * math.pi)
_ROULETTE = 1e-3  # weight below which a photon plays Russian roulette [1]
_SURVIVE = 0.1  # survival probability of the roulette [1]

KIND_SOURCE, KIND_AIR, KIND_GROUND, KIND_CLOUD = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _mean_density(z1: float, z2: float, h: float) -> float:  # pragma: no cover - compiled
    dz = z2 - z1
    if abs(dz) < 1e-6 * h:
        return math.exp(-0.5 * (z1 + z2) / h)
    return -h * math.exp(-z1 / h) * math.expm1(-dz / h) / dz


@njit(cache=True, inline="always")
def _tau(z1: float, z2: float, length: float, p: FloatArray) -> float:  # pragma: no cover
    """Optical depth of a straight chord of ``length`` between heights z1 and z2."""
    return length * (
        p[P_BETA_M] * _mean_density(z1, z2, p[P_H_M])
        + p[P_BETA_A] * _mean_density(z1, z2, p[P_H_A])
    )


@njit(cache=True, inline="always")
def _column(z: float, p: FloatArray) -> float:  # pragma: no cover - compiled
    """Vertical optical depth from the ground to z."""
    return -p[P_BETA_M] * p[P_H_M] * math.expm1(-z / p[P_H_M]) - p[P_BETA_A] * p[
        P_H_A
    ] * math.expm1(-z / p[P_H_A])


@njit(cache=True, inline="always")
def _phase_mix(z: float, mu: float, p: FloatArray) -> tuple[float, float]:  # pragma: no cover
    """(sigma_s p summed [m-1 sr-1], sigma_s [m-1]) at height z for scattering cosine mu."""
    sm = p[P_BETA_M] * math.exp(-z / p[P_H_M])
    sa = p[P_OMEGA_A] * p[P_BETA_A] * math.exp(-z / p[P_H_A])
    if p[P_ISO] > 0.5:
        pr = _INV_4PI
    else:
        pr = 3.0 / (16.0 * math.pi) * (1.0 + mu * mu)
    g = p[P_G]
    phg = _INV_4PI * (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu) ** 1.5
    return sm * pr + sa * phg, sm + sa


@njit(cache=True, inline="always")
def _intensity(
    kind: int,
    z: float,
    dx: float,
    dy: float,
    dz: float,
    ix: float,
    iy: float,
    iz: float,
    p: FloatArray,
) -> float:  # pragma: no cover - compiled
    """Intensity per unit weight of an event in direction (dx, dy, dz) [cd lm-1]."""
    if kind == KIND_AIR:
        value, sigma = _phase_mix(z, dx * ix + dy * iy + dz * iz, p)
        return value / sigma if sigma > 0 else 0.0
    if kind == KIND_CLOUD:
        return max(-dz, 0.0) / math.pi
    return max(dz, 0.0) / math.pi


@njit(cache=True)
def _event_estimate(
    kind: int,
    qx: float,
    qy: float,
    qz: float,
    ix: float,
    iy: float,
    iz: float,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    out: FloatArray,
    weight: float,
) -> None:  # pragma: no cover - compiled
    """Add an event's next-step luminance to every ray (``out``, per ray)."""
    h = p[P_HEIGHT]
    r0 = p[P_CORE]
    for k in range(rays.shape[0]):
        ox, oy = rays[k, 0], rays[k, 1]
        vx, vy, vz = rays[k, 2], rays[k, 3], rays[k, 4]
        u_b = h / vz
        # single scattering along the ray below the base
        rx, ry, rz = qx - ox, qy - oy, qz
        along = rx * vx + ry * vy + rz * vz
        miss2 = rx * rx + ry * ry + rz * rz - along * along
        d = math.sqrt(max(miss2, 0.0) + r0 * r0)
        u_c = min(max(along, 0.0), u_b)
        total = 0.0
        for panel in range(2):
            lo = 0.0 if panel == 0 else u_c
            hi = u_c if panel == 0 else u_b
            if hi <= lo:
                continue
            ta = math.atan((lo - u_c) / d)
            tb = math.atan((hi - u_c) / d)
            half = 0.5 * (tb - ta)
            mid = 0.5 * (ta + tb)
            for j in range(x_gl.size):
                t = mid + half * x_gl[j]
                u = u_c + d * math.tan(t)
                ct = math.cos(t)
                wj = half * w_gl[j] * d / (ct * ct)
                px, py, pz = ox + u * vx, oy + u * vy, u * vz
                sx, sy, sz = px - qx, py - qy, pz - qz
                s2 = sx * sx + sy * sy + sz * sz
                s = math.sqrt(s2)
                if s <= 0.0:
                    continue
                dxn, dyn, dzn = sx / s, sy / s, sz / s
                inten = _intensity(kind, qz, dxn, dyn, dzn, ix, iy, iz, p)
                if inten <= 0.0:
                    continue
                scat, _ = _phase_mix(pz, -(dxn * vx + dyn * vy + dzn * vz), p)
                tau = _tau(qz, pz, s, p) + _tau(0.0, pz, u, p)
                total += wj * scat * inten / (s2 + r0 * r0) * math.exp(-tau)
        # the base at the ray's end, lit by the event
        if kind != KIND_CLOUD:
            bx, by = ox + u_b * vx, oy + u_b * vy
            sx, sy, sz = bx - qx, by - qy, h - qz
            s2 = sx * sx + sy * sy + sz * sz
            s = math.sqrt(s2)
            inten = _intensity(kind, qz, sx / s, sy / s, sz / s, ix, iy, iz, p)
            irr = inten * (sz / s) / (s2 + r0 * r0) * math.exp(-_tau(qz, h, s, p))
            total += irr * p[P_R] / math.pi * math.exp(-_column(h, p) / vz)
        out[k] += weight * total


@njit(cache=True)
def _height_at(z: float, mu: float, target: float, p: FloatArray) -> float:  # pragma: no cover
    """Height where a chord from z with vertical cosine mu has optical depth ``target``."""
    lo, hi = (z, p[P_HEIGHT]) if mu > 0 else (0.0, z)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        tau = abs(_column(mid, p) - _column(z, p)) / abs(mu)
        if (tau < target) == (mu > 0):
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(cache=True)
def transport(
    seed: int,
    photons: int,
    rays: FloatArray,
    x_gl: FloatArray,
    w_gl: FloatArray,
    p: FloatArray,
    max_events: int,
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Photon histories: per-ray sums and sums of squares, and the flux budget.

    Budget: emitted, escaping (through the deck), ground-absorbed, air-absorbed,
    cloud-absorbed, in flight at ``max_events``, roulette balance (weight won minus lost).
    """
    n_rays = rays.shape[0]
    sums = np.zeros(n_rays)
    squares = np.zeros(n_rays)
    budget = np.zeros(7)
    own = np.zeros(n_rays)
    h = p[P_HEIGHT]
    refl, trans, alb = p[P_R], p[P_T], p[P_GROUND]
    for n in range(photons):
        state = _seed_state(seed, n)
        own[:] = 0.0
        rad = p[P_DISC] * math.sqrt(_next(state))
        ang = 2.0 * math.pi * _next(state)
        x, y, z = rad * math.cos(ang), rad * math.sin(ang), 0.0
        w = 1.0
        budget[0] += 1.0
        _event_estimate(KIND_SOURCE, x, y, z, 0.0, 0.0, 1.0, rays, x_gl, w_gl, p, own, w)
        mu = math.sqrt(_next(state))
        phi = 2.0 * math.pi * _next(state)
        st = math.sqrt(max(1.0 - mu * mu, 0.0))
        dx, dy, dz = st * math.cos(phi), st * math.sin(phi), mu
        alive = True
        for _ in range(max_events):
            target = -math.log(_next(state))
            if dz > 1e-12:
                span = (_column(h, p) - _column(z, p)) / dz
            elif dz < -1e-12:
                span = _column(z, p) / -dz
            else:
                span = 1e300
            if target < span:  # collision in the air
                if abs(dz) > 1e-12:
                    z_new = _height_at(z, dz, target, p)
                    length = (z_new - z) / dz
                else:
                    sigma = p[P_BETA_M] * math.exp(-z / p[P_H_M]) + p[P_BETA_A] * math.exp(
                        -z / p[P_H_A]
                    )
                    length = target / sigma
                    z_new = z
                x, y, z = x + length * dx, y + length * dy, z_new
                sm = p[P_BETA_M] * math.exp(-z / p[P_H_M])
                ea = p[P_BETA_A] * math.exp(-z / p[P_H_A])
                sa = p[P_OMEGA_A] * ea
                keep = (sm + sa) / (sm + ea)
                budget[3] += w * (1.0 - keep)
                w *= keep
                _event_estimate(KIND_AIR, x, y, z, dx, dy, dz, rays, x_gl, w_gl, p, own, w)
                if _next(state) * (sm + sa) < sm:
                    if p[P_ISO] > 0.5:
                        c = 2.0 * _next(state) - 1.0
                    else:
                        c = _sample_rayleigh(_next(state))
                else:
                    c = _sample_hg(_next(state), p[P_G])
                dx, dy, dz = _turn(dx, dy, dz, c, 2.0 * math.pi * _next(state))
            elif dz > 0:  # the cloud base
                x, y, z = x + (h - z) / dz * dx, y + (h - z) / dz * dy, h
                budget[1] += w * trans
                budget[4] += w * (1.0 - refl - trans)
                w *= refl
                if w <= 0.0:
                    alive = False
                    break
                _event_estimate(KIND_CLOUD, x, y, z, 0.0, 0.0, -1.0, rays, x_gl, w_gl, p, own, w)
                mu = math.sqrt(_next(state))
                phi = 2.0 * math.pi * _next(state)
                st = math.sqrt(max(1.0 - mu * mu, 0.0))
                dx, dy, dz = st * math.cos(phi), st * math.sin(phi), -mu
            else:  # the ground
                x, y, z = x + z / -dz * dx, y + z / -dz * dy, 0.0
                budget[2] += w * (1.0 - alb)
                w *= alb
                if w <= 0.0:
                    alive = False
                    break
                _event_estimate(KIND_GROUND, x, y, z, 0.0, 0.0, 1.0, rays, x_gl, w_gl, p, own, w)
                mu = math.sqrt(_next(state))
                phi = 2.0 * math.pi * _next(state)
                st = math.sqrt(max(1.0 - mu * mu, 0.0))
                dx, dy, dz = st * math.cos(phi), st * math.sin(phi), mu
            if w < _ROULETTE:
                if _next(state) < _SURVIVE:
                    budget[6] += w * (1.0 / _SURVIVE - 1.0)
                    w /= _SURVIVE
                else:
                    budget[6] -= w
                    alive = False
                    break
        if alive:
            budget[5] += w
        for k in range(n_rays):
            sums[k] += own[k]
            squares[k] += own[k] * own[k]
    return sums, squares, budget
