"""The geometry of a sky picture: projections, pixel directions and solid angles.

A :class:`View` (equirectangular, fisheye or perspective) gives every pixel a direction and a
solid angle (:func:`view_pixels`); :meth:`Pixels.locate` takes directions back to fractional
pixels. Used by the composition (:mod:`nightlights.nightsky.render`, which hands these names
on) and the splatting of point sources (:mod:`nightlights.nightsky._splat`).

References
----------
Snyder, J. P. (1987). Map Projections: A Working Manual. USGS PP 1395: azimuthal equidistant
(p. 191) and gnomonic (p. 164) projections.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = ["PROJECTIONS", "Pixels", "View", "view_pixels"]

PROJECTIONS = ("equirectangular", "fisheye", "perspective")


@dataclass(frozen=True)
class View:
    """What part of the sky is drawn and how.

    Attributes
    ----------
    projection
        ``equirectangular`` (azimuth across, 0-360 deg from north through east; elevation
        down, zenith in the first row, horizon in the last), ``fisheye`` (azimuthal
        equidistant, zenith in the centre, north up, east left as seen from below) or
        ``perspective`` (gnomonic, looking toward ``azimuth``, ``elevation``).
    width, height
        Image size [pixel]; a fisheye is ``width`` square.
    azimuth, elevation
        Perspective view direction [deg].
    field_of_view
        Perspective horizontal field of view [deg], below 180.
    """

    projection: str = "equirectangular"
    width: int = 1024
    height: int = 512
    azimuth: float = 180.0
    elevation: float = 30.0
    field_of_view: float = 90.0

    def __post_init__(self) -> None:
        if self.projection not in PROJECTIONS:
            raise InputError(
                f"projection {self.projection!r}; expected one of {', '.join(PROJECTIONS)}"
            )
        if self.width < 2 or self.height < 2:
            raise InputError(f"image {self.width} x {self.height}: expected at least 2 x 2 pixels")
        if not 0.0 < self.field_of_view < 180.0:
            raise InputError(f"field of view {self.field_of_view}: expected 0-180 deg")
        if not -90.0 <= self.elevation <= 90.0:
            raise InputError(f"view elevation {self.elevation}: expected -90 to 90 deg")

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the image."""
        if self.projection == "fisheye":
            return (self.width, self.width)
        return (self.height, self.width)


@dataclass(frozen=True)
class Pixels:
    """Directions and solid angles of a view's pixels.

    Attributes
    ----------
    view
        The view.
    elevation, azimuth
        ``(rows, cols)`` direction of each pixel centre [deg].
    solid_angle
        ``(rows, cols)`` solid angle of each pixel [sr].
    sky
        ``(rows, cols)`` True where the pixel shows the sky (at or above the horizon).
    pixel_size
        Nominal angular size of a pixel [deg].
    """

    view: View
    elevation: FloatArray
    azimuth: FloatArray
    solid_angle: FloatArray
    sky: NDArray[np.bool_]
    pixel_size: float

    def locate(
        self, elevation: ArrayLike, azimuth: ArrayLike
    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """Fractional (row, column) of directions, pixel (0, 0) centred on (0.0, 0.0).

        Parameters
        ----------
        elevation, azimuth
            Directions [deg].

        Returns
        -------
        tuple
            rows, columns and a mask of the directions inside the image and above the horizon.
        """
        return _locate(self.view, np.asarray(elevation, float), np.asarray(azimuth, float))


def view_pixels(view: View) -> Pixels:
    """Pixel directions and solid angles of a view.

    Parameters
    ----------
    view
        The view.

    Returns
    -------
    Pixels
        Geometry of the image; the solid angles of the sky pixels of an equirectangular view
        sum to 2 pi sr exactly.

    References
    ----------
    Snyder 1987 (azimuthal equidistant, gnomonic).
    """
    rows, cols = view.shape
    if view.projection == "equirectangular":
        d_el = 90.0 / rows
        d_az = 360.0 / cols
        el = 90.0 - (np.arange(rows) + 0.5) * d_el
        az = (np.arange(cols) + 0.5) * d_az
        band = np.radians(d_az) * (
            np.sin(np.radians(el + d_el / 2.0)) - np.sin(np.radians(el - d_el / 2.0))
        )
        # read-only broadcast views: every row shares its elevation, every column its azimuth
        elevation = np.broadcast_to(el[:, None], (rows, cols))
        azimuth = np.broadcast_to(az[None, :], (rows, cols))
        solid = np.broadcast_to(band[:, None], (rows, cols))
        sky = np.broadcast_to(np.True_, (rows, cols))
        return Pixels(view, elevation, azimuth, solid, sky, d_az)
    if view.projection == "fisheye":
        step = 180.0 / rows  # zenith angle per pixel [deg]
        dx, dy = np.meshgrid(np.arange(cols) + 0.5 - cols / 2, np.arange(rows) + 0.5 - rows / 2)
        zenith = np.hypot(dx, dy) * step
        # north up (-dy), east left (-dx): the sky seen from below
        azimuth = np.mod(np.degrees(np.arctan2(-dx, -dy)), 360.0)
        z_rad = np.radians(zenith)
        ratio = np.where(z_rad > 0, np.sin(z_rad) / np.where(z_rad > 0, z_rad, 1.0), 1.0)
        solid = ratio * np.radians(step) ** 2
        sky = zenith <= 90.0
        return Pixels(view, 90.0 - zenith, azimuth, solid, sky, step)
    forward, right, up, focal = _camera(view)
    u, w = np.meshgrid(np.arange(cols) + 0.5 - cols / 2, rows / 2 - (np.arange(rows) + 0.5))
    rays = focal * forward + u[..., None] * right + w[..., None] * up
    norm = np.linalg.norm(rays, axis=-1)
    direction = rays / norm[..., None]
    elevation = np.degrees(np.arcsin(np.clip(direction[..., 2], -1.0, 1.0)))
    azimuth = np.mod(np.degrees(np.arctan2(direction[..., 0], direction[..., 1])), 360.0)
    solid = (focal / norm) ** 3 / focal**2
    return Pixels(view, elevation, azimuth, solid, elevation >= 0.0, view.field_of_view / cols)


def _camera(view: View) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Forward, right and up unit vectors (east, north, up) and the focal length [pixel]."""
    el, az = np.radians(view.elevation), np.radians(view.azimuth)
    forward = np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    right = np.array([np.cos(az), -np.sin(az), 0.0])
    up = np.cross(right, forward)
    focal = (view.width / 2.0) / math.tan(math.radians(view.field_of_view) / 2.0)
    return forward, right, up, focal


def _locate(
    view: View, elevation: FloatArray, azimuth: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    rows, cols = view.shape
    above = elevation >= 0.0
    if view.projection == "equirectangular":
        row = (90.0 - elevation) / (90.0 / rows) - 0.5
        col = np.mod(azimuth, 360.0) / (360.0 / cols) - 0.5
        return row, col, above
    if view.projection == "fisheye":
        radius = (90.0 - elevation) / (180.0 / rows)
        az = np.radians(azimuth)
        col = cols / 2 - radius * np.sin(az) - 0.5
        row = rows / 2 - radius * np.cos(az) - 0.5
        return row, col, above
    forward, right, up, focal = _camera(view)
    el, az = np.radians(elevation), np.radians(azimuth)
    vec = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=-1)
    depth = vec @ forward
    safe = np.where(depth > 1e-9, depth, 1.0)
    col = cols / 2 + focal * (vec @ right) / safe - 0.5
    row = rows / 2 - focal * (vec @ up) / safe - 0.5
    inside = (depth > 1e-9) & (col > -0.5) & (col < cols - 0.5) & (row > -0.5) & (row < rows - 0.5)
    return row, col, above & inside
