"""The observer's terrain horizon from a DEM (beyond Dobashi et al. 2023, which ignores terrain).

For each azimuth the horizon elevation is the largest angle under which the observer sees the
terrain along that azimuth, with the Earth's curvature (and standard refraction, k = 0.13)
lowering distant terrain by d^2 (1 - k) / (2 R). :func:`scene_terrain` reads a scene's DEM:
the observer's eye altitude and the terrain height under every lit emission cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from affine import Affine
from scipy.ndimage import map_coordinates

from nightlights._typing import FloatArray, PathLike
from nightlights.errors import CRSError, InputError
from nightlights.io import Raster, as_raster
from nightlights.io.raster import LitCells

#: Mean Earth radius [m].
EARTH_RADIUS = 6.371e6
#: Coefficient of terrestrial refraction (standard atmosphere; geodetic convention).
REFRACTION_COEFFICIENT = 0.13


def ground_height(dem: FloatArray, transform: Affine, x: float, y: float) -> float:
    """DEM height at a point by bilinear interpolation [m].

    Raises
    ------
    InputError
        The point lies outside the DEM or on nodata.
    """
    inverse = ~transform
    col = inverse.a * x + inverse.b * y + inverse.c
    row = inverse.d * x + inverse.e * y + inverse.f
    value = map_coordinates(dem, [[row - 0.5], [col - 0.5]], order=1, mode="nearest")[0]
    inside = 0 <= row < dem.shape[0] and 0 <= col < dem.shape[1]
    if not inside or not np.isfinite(value):
        raise InputError(f"observer ({x:.1f}, {y:.1f}) is outside the DEM or on nodata")
    return float(value)


def horizon_elevation(
    dem: FloatArray,
    transform: Affine,
    observer: tuple[float, float],
    *,
    eye_altitude: float,
    n_az: int,
    samples_per_bin: int = 4,
    n_distances: int = 400,
) -> FloatArray:
    """Terrain horizon elevation per azimuth bin [deg].

    Parameters
    ----------
    dem
        Terrain height [m], NaN as nodata (ignored).
    transform
        DEM transform (north up) [m].
    observer
        Observer (x, y) [m].
    eye_altitude
        Eye altitude above the DEM datum [m].
    n_az
        Azimuth bins centred on ``(j + 0.5) 360 / n_az`` [deg].
    samples_per_bin
        Rays per azimuth bin; the bin's horizon is the highest [1].
    n_distances
        Log-spaced samples along each ray, from one cell to the DEM's far edge [1].

    Returns
    -------
    numpy.ndarray
        ``(n_az,)`` horizon elevation [deg]; -90 where the DEM shows no terrain.
    """
    cell = abs(transform.a)
    rows, cols = dem.shape
    corners = [
        (transform.c + transform.a * c, transform.f + transform.e * r)
        for c in (0, cols)
        for r in (0, rows)
    ]
    far = max(np.hypot(cx - observer[0], cy - observer[1]) for cx, cy in corners)
    if far <= cell:
        raise InputError("the DEM is too small to give a horizon")
    distance = np.geomspace(cell, far, n_distances)
    azimuth = (np.arange(n_az * samples_per_bin) + 0.5) * 360.0 / (n_az * samples_per_bin)
    az = np.radians(azimuth)[:, None]
    x = observer[0] + distance[None, :] * np.sin(az)
    y = observer[1] + distance[None, :] * np.cos(az)
    inverse = ~transform
    col = inverse.a * x + inverse.b * y + inverse.c
    row = inverse.d * x + inverse.e * y + inverse.f
    inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    filled = np.where(np.isfinite(dem), dem, -1e9)
    height = map_coordinates(
        filled, [row.ravel() - 0.5, col.ravel() - 0.5], order=1, mode="nearest"
    ).reshape(x.shape)
    drop = distance**2 * (1.0 - REFRACTION_COEFFICIENT) / (2.0 * EARTH_RADIUS)
    angle = np.degrees(np.arctan2(height - drop[None, :] - eye_altitude, distance[None, :]))
    angle = np.where(inside & (height > -1e8), angle, -90.0)
    per_ray = angle.max(axis=1)
    return per_ray.reshape(n_az, samples_per_bin).max(axis=1)


@dataclass(frozen=True)
class SceneTerrain:
    """The terrain of a scene: the DEM, the eye altitude and the heights of the lit cells [m]."""

    dem: FloatArray
    transform: Affine
    eye_altitude: float
    source_altitude: float  # flux-weighted mean
    heights: FloatArray  # terrain height under each lit cell, in the order of the LitCells


def scene_terrain(
    dem: Raster | xr.DataArray | PathLike,
    emission: Raster | LitCells,
    xy: tuple[float, float],
    observer_height: float,
    *,
    label: str = "DEM",
) -> SceneTerrain:
    """Read the DEM; eye altitude, terrain height under every lit cell and their mean.

    Parameters
    ----------
    dem
        Terrain heights above sea level [m] in the emission raster's CRS.
    emission
        Emission raster or its lit cells (:class:`~nightlights.io.raster.LitCells`) [lm m-2].
    xy
        Observer (x, y) in the raster's CRS [m].
    observer_height
        Eye height above the ground [m].
    label
        How messages name the DEM.

    Returns
    -------
    SceneTerrain
        DEM, eye altitude [m], flux-weighted source altitude [m], the height under each lit
        cell of ``emission.lit_cells()`` [m].
    """
    cells = emission if isinstance(emission, LitCells) else emission.lit_cells()
    relief = as_raster(dem)
    if relief.crs is None or cells.crs is None or not relief.crs.equals(cells.crs):
        raise CRSError(f"{label}: the DEM must be in the emission raster's CRS")
    heights = relief.data[0]
    ground = ground_height(heights, relief.transform, *xy)
    # Terrain height under each lit emission cell, weighted by its flux.
    flux = np.nansum(np.nan_to_num(cells.values, nan=0.0), axis=0)
    source_altitude = 0.0
    cell_heights = np.zeros(0)
    if cells.n_cells:
        cx, cy = cells.centres()
        inv = ~relief.transform
        dcol = inv.a * cx + inv.b * cy + inv.c
        drow = inv.d * cx + inv.e * cy + inv.f
        cell_heights = map_coordinates(
            np.nan_to_num(heights, nan=ground), [drow - 0.5, dcol - 0.5], order=1, mode="nearest"
        )
        weights = np.abs(flux)
        source_altitude = float(
            np.average(cell_heights, weights=weights) if weights.sum() > 0 else cell_heights.mean()
        )
    return SceneTerrain(
        heights, relief.transform, ground + observer_height, source_altitude, cell_heights
    )
