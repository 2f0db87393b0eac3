"""Hemispherical, semicylindrical and vertical illuminance at points (EN 13201-3:2015, Sec. 8).

A luminaire k of intensity :math:`I_k` [cd] towards a point :math:`p` at distance
:math:`d_k = |q_k - p|` gives there the illuminance :math:`E_{n,k} = I_k / d_k^2` on a plane
normal to the ray. Let :math:`\\varepsilon_k` be the angle between the ray towards the
luminaire and the upward vertical (:math:`\\cos\\varepsilon_k = (z_k - z_p)/d_k`) and, for a
receptor facing the horizontal direction :math:`\\mathbf{n}`, :math:`\\alpha_k` the angle
between :math:`\\mathbf{n}` and the horizontal projection of that ray. The receptors are small
convex bodies, so no part of one shades another (CIE 140:2000, Sec. 2; EN 13201-3:2015,
Sec. 8.3-8.5):

- hemispherical illuminance: the flux on a small hemisphere resting on the surface (flat face
  down) over its curved area :math:`2\\pi r^2`; its projected area towards the luminaire is
  :math:`\\tfrac{\\pi r^2}{2}(1 + \\cos\\varepsilon)`, so

  .. math:: E_{hs} = \\sum_k \\frac{I_k}{4 d_k^2} (1 + \\cos\\varepsilon_k);

- semicylindrical illuminance: the flux on the curved face of a small half-cylinder with a
  vertical axis, its curved face towards :math:`\\mathbf{n}`, over that face's area
  :math:`\\pi r H`; its projected area is :math:`r H \\sin\\varepsilon (1 + \\cos\\alpha)`, so

  .. math:: E_{sc} = \\sum_k \\frac{I_k}{\\pi d_k^2} \\sin\\varepsilon_k (1 + \\cos\\alpha_k)

  (with :math:`d_k = h_k / \\cos\\varepsilon_k`, the standard's
  :math:`I (1 + \\cos\\alpha) \\cos^2\\varepsilon \\sin\\varepsilon / (\\pi h^2)`);

- vertical illuminance: on a vertical plane facing :math:`\\mathbf{n}`, lit from its front
  only,

  .. math:: E_v = \\sum_k \\frac{I_k}{d_k^2} \\sin\\varepsilon_k \\max(0, \\cos\\alpha_k).

EN 13201-3 evaluates semicylindrical and vertical illuminance 1.5 m above the surface
(:data:`RECEPTOR_HEIGHT`) and hemispherical illuminance on it; the functions take points on the
surface and add the height. No maintenance factor is applied (scale the intensities).

References
----------
1. EN 13201-3:2015, "Road lighting - Part 3: Calculation of performance", Sec. 8.
2. CIE 140:2000, "Road lighting calculations", Sec. 2 (the quantities' definitions).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.roads._geometry import Intensity, intensities, light_array

__all__ = [
    "RECEPTOR_HEIGHT",
    "hemispherical_illuminance",
    "semicylindrical_illuminance",
    "vertical_illuminance",
]

#: Height above the surface of the semicylindrical and vertical illuminance points [m]
#: (EN 13201-3:2015, Sec. 8.4, 8.5).
RECEPTOR_HEIGHT = 1.5


def _rays(
    points: ArrayLike,
    height: float,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    street_azimuth: ArrayLike,
) -> tuple[FloatArray, FloatArray, tuple[int, ...]]:
    """Normal illuminance I / d^2 (n, m) [lx] and unit vectors to the lights (n, m, 3)."""
    p = np.asarray(points, dtype=float)
    if p.shape[-1:] != (3,):
        raise InputError(f"points of shape {p.shape}; expected (..., 3) points (x, y, z) [m]")
    if not np.all(np.isfinite(p)):
        raise InputError("points hold non-finite coordinates")
    if not (np.isfinite(height) and height >= 0):
        raise InputError(f"height={height!r}; expected a number >= 0 [m]")
    lights, rotations = light_array(light_points, rotation)
    flat = p.reshape(-1, 3) + np.array([0.0, 0.0, height])
    candela = intensities(flat, lights, rotations, intensity, street_azimuth=street_azimuth)
    ray = lights[:, None, :] - flat[None, :, :]
    distance = np.linalg.norm(ray, axis=-1)
    if np.any(distance == 0):
        raise InputError("a luminaire stands at a calculation point; expected d > 0 [m]")
    return candela / distance**2, ray / distance[..., None], p.shape[:-1]


def _facing(direction: ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    """Unit horizontal facing directions broadcast to (m, 2)."""
    n = np.asarray(direction, dtype=float)
    if n.shape[-1:] != (2,):
        raise InputError(
            f"direction of shape {n.shape}; expected (2,) or (..., 2) horizontal (x, y)"
        )
    length = np.hypot(n[..., 0], n[..., 1])
    if not np.all(np.isfinite(length) & (length > 0)):
        raise InputError("direction holds a zero or non-finite vector; expected (x, y) != 0")
    try:
        unit = np.broadcast_to(n / length[..., None], (*shape, 2))
    except ValueError:
        raise InputError(
            f"direction of shape {n.shape} does not broadcast to the points' {shape}"
        ) from None
    return unit.reshape(-1, 2)


def hemispherical_illuminance(
    points: ArrayLike,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    *,
    street_azimuth: ArrayLike = 0.0,
    height: float = 0.0,
) -> FloatArray:
    """Hemispherical illuminance :math:`E_{hs}` at points (module docstring) [lx].

    Parameters
    ----------
    points
        Points on the surface, (..., 3) [m].
    light_points
        Photometric centres of the luminaires, (n, 3) [m].
    rotation
        Body-to-world rotations, (3, 3) or (n, 3, 3).
    intensity
        ``intensity(vertical, horizontal)`` [cd] of type C angles [deg], one for all
        luminaires or one per luminaire.
    street_azimuth
        C-plane of each photometry that faces the street [deg].
    height
        Height of the receptor above the points [m]; EN 13201-3: on the surface (0).

    Returns
    -------
    numpy.ndarray
        :math:`E_{hs}`, shape of ``points`` without the last axis [lx].

    Examples
    --------
    1000 cd straight down from 10 m: :math:`E_{hs} = 1000 / (4 \\cdot 100) \\cdot 2 = 5` lx.

    >>> float(hemispherical_illuminance([0, 0, 0], [[0, 0, 10]], np.eye(3),
    ...                                 lambda v, h: 1000.0 + 0 * v))
    5.0
    """
    normal, unit, shape = _rays(points, height, light_points, rotation, intensity, street_azimuth)
    return np.sum(normal * (1.0 + unit[..., 2]) / 4.0, axis=0).reshape(shape)


def semicylindrical_illuminance(
    points: ArrayLike,
    direction: ArrayLike,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    *,
    street_azimuth: ArrayLike = 0.0,
    height: float = RECEPTOR_HEIGHT,
) -> FloatArray:
    """Semicylindrical illuminance :math:`E_{sc}` at points (module docstring) [lx].

    Parameters
    ----------
    points
        Points on the surface, (..., 3) [m].
    direction
        Horizontal direction (x, y) the curved face looks towards, (2,) or broadcasting to
        the points' shape (..., 2); any length.
    light_points, rotation, intensity, street_azimuth
        As :func:`hemispherical_illuminance`.
    height
        Height of the receptor above the points [m]; EN 13201-3: 1.5 m.

    Returns
    -------
    numpy.ndarray
        :math:`E_{sc}`, shape of ``points`` without the last axis [lx].

    Examples
    --------
    1000 cd from 10 m ahead at the receptor's height: :math:`E_{sc} = 1000/(100\\pi) \\cdot 2`.

    >>> round(float(semicylindrical_illuminance([0, 0, 0], [1, 0], [[10, 0, 1.5]], np.eye(3),
    ...                                         lambda v, h: 1000.0 + 0 * v)), 4)
    6.3662
    """
    normal, unit, shape = _rays(points, height, light_points, rotation, intensity, street_azimuth)
    facing = _facing(direction, shape)
    along = np.einsum("nmi,mi->nm", unit[..., :2], facing)  # sin(eps) cos(alpha)
    sin_eps = np.hypot(unit[..., 0], unit[..., 1])
    return np.sum(normal * (sin_eps + along) / np.pi, axis=0).reshape(shape)


def vertical_illuminance(
    points: ArrayLike,
    direction: ArrayLike,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    *,
    street_azimuth: ArrayLike = 0.0,
    height: float = RECEPTOR_HEIGHT,
) -> FloatArray:
    """Vertical illuminance :math:`E_v` on a plane facing ``direction`` (module docstring) [lx].

    Parameters
    ----------
    points
        Points on the surface, (..., 3) [m].
    direction
        Horizontal normal (x, y) of the lit face of the vertical plane, (2,) or (..., 2).
    light_points, rotation, intensity, street_azimuth
        As :func:`hemispherical_illuminance`.
    height
        Height of the receptor above the points [m]; EN 13201-3: 1.5 m.

    Returns
    -------
    numpy.ndarray
        :math:`E_v`, shape of ``points`` without the last axis [lx].

    Examples
    --------
    1000 cd from 10 m ahead at the plane's height falls on it at normal incidence: 10 lx.

    >>> float(vertical_illuminance([0, 0, 0], [1, 0], [[10, 0, 1.5]], np.eye(3),
    ...                            lambda v, h: 1000.0 + 0 * v))
    10.0
    """
    normal, unit, shape = _rays(points, height, light_points, rotation, intensity, street_azimuth)
    facing = _facing(direction, shape)
    along = np.einsum("nmi,mi->nm", unit[..., :2], facing)
    return np.sum(normal * np.maximum(along, 0.0), axis=0).reshape(shape)
