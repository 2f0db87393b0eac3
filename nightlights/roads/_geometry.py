"""Luminous intensity of road luminaires towards points, in the ground's luminaire frames.

A luminaire k at light point :math:`q_k` with body-to-world rotation :math:`R_k`
(:func:`nightlights.ground.frames.luminaire_rotation`) sends towards a point :math:`p` the
intensity :math:`I_k(V, H)` [cd] of the photometric angles of :math:`p - q_k` in its frame
(:func:`nightlights.ground.frames.direction_to_photometric`, type C: V from nadir). Road frame
coordinates play the role of the world frame: ``x`` along the road, ``y`` across, ``z`` up, and
a heading is a bearing from ``+y`` towards ``+x``.

An intensity is any callable ``intensity(vertical, horizontal)`` [cd] of angles [deg]: an
analytic distribution, :meth:`ies.Photometry.intensity`, or the ground kernel's
:meth:`nightlights.ground.frames.IntensityTable.lookup`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.ground.frames import direction_to_photometric

#: An intensity distribution: candela [cd] of type C angles (vertical, horizontal) [deg].
Intensity = Callable[[FloatArray, FloatArray], ArrayLike]


def light_array(light_points: ArrayLike, rotation: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Light points (n, 3) and rotations (n, 3, 3) checked and broadcast."""
    points = np.atleast_2d(np.asarray(light_points, dtype=float))
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(
            f"light_points of shape {np.shape(light_points)}; expected (n, 3) points (x, y, z) [m]"
        )
    if not np.all(np.isfinite(points)):
        raise InputError("light_points hold non-finite coordinates")
    if np.any(points[:, 2] <= 0):
        raise InputError(
            f"light_points: {int(np.sum(points[:, 2] <= 0))} luminaires at or below the road "
            "(z <= 0); expected a mounting height above the road surface [m]"
        )
    rotations = np.asarray(rotation, dtype=float)
    if rotations.shape[-2:] != (3, 3):
        raise InputError(f"rotation of shape {rotations.shape}; expected (3, 3) or (n, 3, 3)")
    return points, np.broadcast_to(rotations, (points.shape[0], 3, 3))


def intensities(
    targets: FloatArray,
    light_points: FloatArray,
    rotation: FloatArray,
    intensity: Intensity | Sequence[Intensity],
    *,
    street_azimuth: ArrayLike = 0.0,
) -> FloatArray:
    """Intensity of every luminaire towards every target.

    Parameters
    ----------
    targets
        Points (m, 3) [m].
    light_points
        Light points (n, 3) [m].
    rotation
        Body-to-world rotations (n, 3, 3).
    intensity
        One distribution for all luminaires or one per luminaire [cd].
    street_azimuth
        C-plane facing the street (the body's forward axis), scalar or (n,) [deg].

    Returns
    -------
    numpy.ndarray
        Intensities (n, m) [cd].
    """
    n = light_points.shape[0]
    functions = [intensity] * n if callable(intensity) else list(intensity)
    if len(functions) != n:
        raise InputError(
            f"intensity: {len(functions)} distributions for {n} luminaires; expected one "
            "callable or one per luminaire"
        )
    direction = targets[None, :, :] - light_points[:, None, :]
    azimuth = np.broadcast_to(np.asarray(street_azimuth, dtype=float), (n,))[:, None]
    vertical, horizontal = direction_to_photometric(
        direction, rotation[:, None, :, :], street_azimuth=azimuth
    )
    out = np.empty(direction.shape[:2])
    for k, function in enumerate(functions):
        out[k] = np.broadcast_to(
            np.asarray(function(vertical[k], horizontal[k]), dtype=float), out[k].shape
        )
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise InputError("intensity returned negative or non-finite candela values")
    return out
