"""Directions in the luminaire frame and type C photometric angles (Chuang 2011, Eqs. 1-3).

Local luminaire frame used by this package: ``x`` points along the C0 half-plane, ``y``
along C90, ``z`` up. Type C horizontal angles H (C-planes) increase counter-clockwise seen
from above (from x towards y), as in IES LM-63 and CIE 121 / EN 13032-1; the vertical angle
V is measured from nadir (``-z``). Chuang's IES frame (Sec. 4.2, Fig. 12) has z pointing
down; his Eq. 3 maps it to a z-up frame with a sign flip of y, which this module absorbs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def photometric_angles(
    x: ArrayLike, y: ArrayLike, z: ArrayLike, *, x_plane: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Type C angles of direction vectors given in the luminaire frame.

    Parameters
    ----------
    x, y, z : array_like
        Components of directions from the luminaire (need not be unit length), broadcast
        against each other; z up [m] or [1].
    x_plane : array_like, optional
        C-plane angle of the frame's x axis, added to the horizontal angle before it is
        wrapped to [0, 360); 0 for the frame above [deg].

    Returns
    -------
    vertical : ndarray
        Angle from nadir, 0..180 [deg].
    horizontal : ndarray
        C-plane angle counter-clockwise from x seen from above, 0..360 [deg].

    References
    ----------
    Chuang 2011, Sec. 4.2, Eq. 2 (V = arccos z, H = atan2 in the z-down frame).

    Examples
    --------
    >>> v, h = photometric_angles(0.0, 1.0, -1.0)
    >>> round(float(v), 9), round(float(h), 9)
    (45.0, 90.0)
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(c, dtype=float) for c in (x, y, z)))
    length = np.sqrt(x * x + y * y + z * z)
    with np.errstate(invalid="ignore", divide="ignore"):
        vertical = np.degrees(np.arccos(np.clip(-z / length, -1.0, 1.0)))
    horizontal = np.mod(np.degrees(np.arctan2(y, x)) + np.asarray(x_plane, dtype=float), 360.0)
    return vertical, horizontal


def direction_from_angles(
    vertical: ArrayLike, horizontal: ArrayLike, *, x_plane: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Unit direction (x, y, z; z up) of type C angles, the inverse of
    :func:`photometric_angles` (Chuang 2011, Eqs. 1 and 3).

    Parameters
    ----------
    vertical : array_like
        Angle from nadir [deg].
    horizontal : array_like
        C-plane angle [deg].
    x_plane : array_like, optional
        C-plane angle of the frame's x axis [deg].

    Returns
    -------
    tuple of ndarray
        Unit vector components [1].
    """
    v = np.radians(np.asarray(vertical, dtype=float))
    h = np.radians(np.asarray(horizontal, dtype=float) - np.asarray(x_plane, dtype=float))
    return np.sin(v) * np.cos(h), np.sin(v) * np.sin(h), -np.cos(v)
