"""Luminaire coordinate frames (Chuang 2011, Sec. 4.3, Eqs. 5-9).

World frame: projected map coordinates, x east, y north, z up [m]. A luminaire's body frame
starts aligned with the world, facing north (+y forward, +x right, +z up) and is rotated in
ZXY order (Chuang 2011, Eq. 6):

1. heading about the vertical axis, clockwise from north (compass bearing) [deg];
2. tilt (pitch) about the body's lateral axis, positive raising the front (+y) [deg];
3. roll about the body's forward axis, positive lowering the right side [deg].

The photometric frame (IES type C) has its z axis pointing down (vertical angle V = 0 at
nadir, 180 at zenith, Chuang 2011, Sec. 4.3 "T_lobe"). Horizontal (C-plane) angles H
increase counterclockwise when the luminaire is viewed from above, and the light system's
``street_azimuth`` C-plane points along the body's forward axis, i.e. along ``heading``.

The light point (the photometric centre) hangs ``arm_length`` metres from the pole foot
along ``heading``, ``mounting_height`` metres above the ground at the pole foot (Chuang
2011, Eq. 8: a pole translates along z, a mast arm along the facing axis).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "direction_to_photometric",
    "light_points",
    "luminaire_rotation",
    "photometric_to_direction",
]


def luminaire_rotation(
    heading: ArrayLike, tilt: ArrayLike = 0.0, roll: ArrayLike = 0.0
) -> NDArray[np.float64]:
    """Rotation matrices from the luminaire body frame to the world frame.

    Parameters
    ----------
    heading
        Compass bearing the luminaire faces, clockwise from north [deg].
    tilt
        Upward tilt of the luminaire's front about its lateral axis [deg].
    roll
        Roll about the luminaire's forward axis, positive lowering the right side [deg].

    Returns
    -------
    numpy.ndarray
        Array (..., 3, 3); ``R @ body_vector`` gives the world vector. Columns are the
        body's right, forward and up axes in world coordinates.

    Notes
    -----
    .. math:: R = R_z(-\\text{heading})\\, R_x(\\text{tilt})\\, R_y(\\text{roll})

    The ZXY order of Chuang's Eq. 6; the heading enters with a minus sign because compass
    bearings turn clockwise seen from above.

    References
    ----------
    Chuang 2011, Sec. 4.3, Eqs. 6-7.

    Examples
    --------
    >>> R = luminaire_rotation(90.0)
    >>> np.round(R @ [0.0, 1.0, 0.0], 12)  # forward axis now points east
    array([ 1.,  0.,  0.])
    """
    h, t, r = np.broadcast_arrays(
        np.radians(np.asarray(heading, dtype=float)),
        np.radians(np.asarray(tilt, dtype=float)),
        np.radians(np.asarray(roll, dtype=float)),
    )
    ch, sh = np.cos(h), np.sin(h)
    ct, st = np.cos(t), np.sin(t)
    cr, sr = np.cos(r), np.sin(r)
    zeros, ones = np.zeros_like(h), np.ones_like(h)
    # R_z(-heading): compass heading turns the forward axis (+y) clockwise towards +x.
    rz = _stack([[ch, sh, zeros], [-sh, ch, zeros], [zeros, zeros, ones]])
    rx = _stack([[ones, zeros, zeros], [zeros, ct, -st], [zeros, st, ct]])
    ry = _stack([[cr, zeros, sr], [zeros, ones, zeros], [-sr, zeros, cr]])
    return rz @ rx @ ry


def _stack(rows: list[list[NDArray[np.float64]]]) -> NDArray[np.float64]:
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def light_points(
    x: ArrayLike,
    y: ArrayLike,
    heading: ArrayLike,
    *,
    mounting_height: ArrayLike,
    arm_length: ArrayLike = 0.0,
    ground_z: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Photometric centres of luminaires from their pole feet.

    Parameters
    ----------
    x, y
        Pole foot in the projected CRS [m].
    heading
        Compass bearing from the pole towards the carriageway [deg].
    mounting_height
        Height of the luminaire above the ground at the pole foot [m].
    arm_length
        Horizontal distance from the pole to the luminaire along ``heading`` [m].
    ground_z
        Ground elevation at the pole foot [m].

    Returns
    -------
    numpy.ndarray
        Array (..., 3) of light points (x, y, z) [m].

    References
    ----------
    Chuang 2011, Sec. 4.3, Eq. 8 (pole: t_z = height; mast: translation along the arm).
    """
    h = np.radians(np.asarray(heading, dtype=float))
    arm = np.asarray(arm_length, dtype=float)
    px = np.asarray(x, dtype=float) + arm * np.sin(h)
    py = np.asarray(y, dtype=float) + arm * np.cos(h)
    pz = np.asarray(ground_z, dtype=float) + np.asarray(mounting_height, dtype=float)
    return np.stack(np.broadcast_arrays(px, py, pz), axis=-1)


def direction_to_photometric(
    direction: ArrayLike,
    rotation: ArrayLike,
    *,
    street_azimuth: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Photometric angles (V, H) of world directions leaving a luminaire.

    Parameters
    ----------
    direction
        World vectors (..., 3) from the light point towards the lit point; need not be
        unit vectors [m or 1].
    rotation
        Body-to-world rotations (..., 3, 3) from :func:`luminaire_rotation`, broadcast
        against ``direction``.
    street_azimuth
        C-plane of the photometry that faces the street (the body's forward axis) [deg].

    Returns
    -------
    vertical : numpy.ndarray
        Vertical angle, 0 at nadir, 180 at zenith [deg].
    horizontal : numpy.ndarray
        Horizontal angle in [0, 360), counterclockwise seen from above [deg].

    Notes
    -----
    With body coordinates :math:`b = R^T d` (right, forward, up),

    .. math:: V = \\arccos(-b_z / |b|), \\quad
              H = H_\\text{street} + \\operatorname{atan2}(-b_x, b_y)

    References
    ----------
    Chuang 2011, Sec. 4.3, Eq. 5 (world to lobe frame, T_lobe flips z) and Eq. 2.
    """
    d = np.asarray(direction, dtype=float)
    body = np.einsum("...ji,...j->...i", np.asarray(rotation, dtype=float), d)
    norm = np.linalg.norm(body, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_v = np.clip(-body[..., 2] / norm, -1.0, 1.0)
    vertical = np.degrees(np.arccos(np.where(norm > 0, cos_v, 1.0)))
    horizontal = np.degrees(np.arctan2(-body[..., 0], body[..., 1]))
    horizontal = np.mod(horizontal + np.asarray(street_azimuth, dtype=float), 360.0)
    return vertical, horizontal


def photometric_to_direction(
    vertical: ArrayLike,
    horizontal: ArrayLike,
    rotation: ArrayLike,
    *,
    street_azimuth: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """World unit vectors of photometric angles; the inverse of :func:`direction_to_photometric`.

    Parameters
    ----------
    vertical
        Vertical angle, 0 at nadir [deg].
    horizontal
        Horizontal (C-plane) angle, counterclockwise seen from above [deg].
    rotation
        Body-to-world rotations (..., 3, 3).
    street_azimuth
        C-plane facing the street [deg].

    Returns
    -------
    numpy.ndarray
        Unit vectors (..., 3) in the world frame [1].
    """
    v = np.radians(np.asarray(vertical, dtype=float))
    a = np.radians(np.asarray(horizontal, dtype=float) - np.asarray(street_azimuth, dtype=float))
    body = np.stack(
        np.broadcast_arrays(-np.sin(v) * np.sin(a), np.sin(v) * np.cos(a), -np.cos(v)), axis=-1
    )
    return np.einsum("...ij,...j->...i", np.asarray(rotation, dtype=float), body)
