"""Line-of-sight quadrature with a peak-flattening substitution.

Along a view ray u (distance from the observer), the light from a point source falls as
1 / s^2 with s^2 = d^2 + (u - u_p)^2, where u_p is the closest approach and d the miss
distance. With u = u_p + d tan t, du / s^2 = dt / d: the peak becomes flat and Gauss-Legendre
nodes in t integrate the remaining smooth factors (density, phase, extinction) accurately.
Each side of the closest approach is one panel (Dobashi 2023, Sec. 3.2 splits the ray at the
same point but steps uniformly by 10 m).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray

__all__ = ["gauss_legendre", "tangent_panel_nodes"]


@lru_cache(maxsize=64)
def _gauss_legendre(n: int) -> tuple[FloatArray, FloatArray]:
    x, w = np.polynomial.legendre.leggauss(n)
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def gauss_legendre(n: int) -> tuple[FloatArray, FloatArray]:
    """Gauss-Legendre nodes and weights on [-1, 1] (cached, read-only).

    Parameters
    ----------
    n
        Number of nodes, >= 1 [1].

    Returns
    -------
    nodes, weights : numpy.ndarray
        Shape ``(n,)`` [1].
    """
    if n < 1:
        raise ValueError(f"number of Gauss nodes {n!r}; expected >= 1")
    return _gauss_legendre(int(n))


def tangent_panel_nodes(
    start: ArrayLike, stop: ArrayLike, centre: ArrayLike, scale: ArrayLike, n: int
) -> tuple[FloatArray, FloatArray]:
    """Nodes and weights on [start, stop] under the substitution u = centre + scale tan t.

    Parameters
    ----------
    start, stop
        Panel ends along the ray, start <= stop [m].
    centre
        Closest-approach distance u_p along the ray [m].
    scale
        Miss distance d > 0 [m].
    n
        Gauss-Legendre nodes in t [1].

    Returns
    -------
    u, weights : numpy.ndarray
        Shapes ``(..., n)``: positions [m] and weights (including du/dt) [m], so that
        sum(weights * f(u)) approximates the integral of f over the panel.

    References
    ----------
    Dobashi et al. 2023, Sec. 3.2 (the integrand, here with a peak-flattening substitution).
    """
    x, w = gauss_legendre(n)
    a = np.asarray(start, dtype=float)[..., None]
    b = np.asarray(stop, dtype=float)[..., None]
    c = np.asarray(centre, dtype=float)[..., None]
    d = np.asarray(scale, dtype=float)[..., None]
    ta = np.arctan((a - c) / d)
    tb = np.arctan((b - c) / d)
    half = 0.5 * (tb - ta)
    t = 0.5 * (ta + tb) + half * x
    u = c + d * np.tan(t)
    cos_t = np.cos(t)
    weights = half * w * d / (cos_t * cos_t)
    return u, weights
