"""Geometry of the skyglow kernel: observer, source and view rays over a flat or spherical Earth.

Local Cartesian frame [m]: origin at sea level below the observer, z up, x pointing towards the
source (relative azimuth 0), y to the right (relative azimuth +90 deg). The spherical Earth has its
centre at (0, 0, -R). A source at ground distance r (arc length along the sea-level sphere) sits
at angle r / R from the observer around the centre, so that distant sources lie below the
observer's tangent plane and their local vertical is tilted away from the observer's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray

__all__ = [
    "altitude",
    "ray_exit_distance",
    "source_frame",
    "view_direction",
]


def view_direction(elevation: ArrayLike, relative_azimuth: ArrayLike) -> FloatArray:
    """Unit vector of a view ray.

    Parameters
    ----------
    elevation
        Elevation above the horizon [deg].
    relative_azimuth
        Azimuth relative to the direction of the source, clockwise [deg].

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``, components (x, y, z) [1].
    """
    el = np.radians(np.asarray(elevation, dtype=float))
    az = np.radians(np.asarray(relative_azimuth, dtype=float))
    el, az = np.broadcast_arrays(el, az)
    ce = np.cos(el)
    return np.stack([ce * np.cos(az), ce * np.sin(az), np.sin(el)], axis=-1)


def source_frame(
    distance: ArrayLike, source_altitude: ArrayLike, *, earth_radius: float, flat_earth: bool
) -> tuple[FloatArray, FloatArray]:
    """Position and local vertical of a ground source.

    Parameters
    ----------
    distance
        Ground distance from the observer (arc length at sea level) [m].
    source_altitude
        Altitude of the source above sea level [m].
    earth_radius
        Earth radius R [m].
    flat_earth
        Flat Earth: the source sits at (r, 0, h_c) with vertical (0, 0, 1).

    Returns
    -------
    position, vertical : numpy.ndarray
        Shapes ``(..., 3)`` [m] and [1].
    """
    r, h = np.broadcast_arrays(
        np.asarray(distance, dtype=float), np.asarray(source_altitude, dtype=float)
    )
    if flat_earth:
        position = np.stack([r, np.zeros_like(r), h], axis=-1)
        vertical = np.stack([np.zeros_like(r), np.zeros_like(r), np.ones_like(r)], axis=-1)
        return position, vertical
    angle = r / earth_radius
    s, c = np.sin(angle), np.cos(angle)
    rad = earth_radius + h
    # z = (R + h) cos(a) - R, written to keep precision for small angles
    z = h * c - earth_radius * 2.0 * np.sin(angle / 2.0) ** 2
    position = np.stack([rad * s, np.zeros_like(r), z], axis=-1)
    vertical = np.stack([s, np.zeros_like(r), c], axis=-1)
    return position, vertical


def altitude(points: ArrayLike, *, earth_radius: float, flat_earth: bool) -> FloatArray:
    """Altitude above sea level of points in the local frame.

    Parameters
    ----------
    points
        Shape ``(..., 3)`` [m].
    earth_radius
        Earth radius R [m].
    flat_earth
        Flat Earth: the altitude is z.

    Returns
    -------
    numpy.ndarray
        Altitude [m]; computed as (|P - C|^2 - R^2) / (|P - C| + R) to keep precision.
    """
    p = np.asarray(points, dtype=float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    if flat_earth:
        return z
    rho2 = x * x + y * y + z * z + 2.0 * z * earth_radius
    return rho2 / (np.sqrt(x * x + y * y + (z + earth_radius) ** 2) + earth_radius)


def ray_exit_distance(
    elevation: ArrayLike,
    observer_altitude: ArrayLike,
    top_altitude: float,
    *,
    earth_radius: float,
    flat_earth: bool,
) -> FloatArray:
    """Distance along a view ray to the top of the model atmosphere.

    Parameters
    ----------
    elevation
        Elevation of the ray [deg]; must be > 0 on a flat Earth.
    observer_altitude
        Observer altitude above sea level [m].
    top_altitude
        Top of the atmosphere [m].
    earth_radius
        Earth radius R [m].
    flat_earth
        Flat Earth.

    Returns
    -------
    numpy.ndarray
        Distance [m]; 0 where the observer is above the top, inf for horizontal flat rays.
    """
    sin_el = np.sin(np.radians(np.asarray(elevation, dtype=float)))
    h_o = np.asarray(observer_altitude, dtype=float)
    gap = np.maximum(top_altitude - h_o, 0.0)
    if flat_earth:
        with np.errstate(divide="ignore"):
            return np.where(sin_el > 0, gap / np.where(sin_el > 0, sin_el, 1.0), np.inf)
    ro = earth_radius + h_o
    b = ro * sin_el
    cdiff = gap * (2.0 * earth_radius + top_altitude + h_o)
    root = np.sqrt(b * b + cdiff)
    # u = -b + sqrt(b^2 + c), written as c / (b + sqrt(b^2 + c)) when b > 0
    return np.where(b > 0, cdiff / np.where(b + root > 0, b + root, 1.0), root - b)
