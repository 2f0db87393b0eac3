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


def terrain_under(
    dem: Raster,
    x: FloatArray,
    y: FloatArray,
    *,
    label: str = "DEM",
    what: str = "lit emission cells",
    expected: str = "a DEM with a height under each",
) -> FloatArray:
    """DEM height under points by bilinear interpolation [m], refusing points without one.

    The one check of every stage that takes a DEM (skyglow, inverse, observers, explore,
    darkness): a point outside the DEM, or whose interpolation gives a nodata pixel a weight,
    has no terrain height, and is refused rather than filled with a guess.

    Parameters
    ----------
    dem
        Terrain heights above sea level [m], nodata as NaN.
    x, y
        Points (cell centres) in the DEM's CRS [m].
    label
        How messages name the DEM.
    what
        What the points are, for messages.
    expected
        What the message asks for instead.

    Returns
    -------
    numpy.ndarray
        Height under each point [m], the shape of ``x``.

    Raises
    ------
    InputError
        Some point lies outside the DEM or on nodata.

    Examples
    --------
    >>> from affine import Affine
    >>> dem = Raster(np.array([[[10.0, 20.0], [np.nan, 40.0]]]), Affine(10, 0, 0, 0, -10, 20),
    ...              "EPSG:32633")
    >>> terrain_under(dem, np.array([5.0, 15.0]), np.array([15.0, 15.0])).tolist()
    [10.0, 20.0]
    >>> terrain_under(dem, np.array([5.0]), np.array([5.0]))
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: DEM: no terrain height under 1 of 1 lit emission cells \
(outside the DEM or nodata; the first at (5.0, 5.0)); expected a DEM with a height under each
    """
    px = np.asarray(x, dtype=float)
    py = np.asarray(y, dtype=float)
    heights = dem.data[0]
    inverse = ~dem.transform
    col = inverse.a * px + inverse.b * py + inverse.c
    row = inverse.d * px + inverse.e * py + inverse.f
    inside = (row >= 0) & (row < heights.shape[0]) & (col >= 0) & (col < heights.shape[1])
    coordinates = [row - 0.5, col - 0.5]
    missing = ~np.isfinite(heights)
    values = map_coordinates(np.where(missing, 0.0, heights), coordinates, order=1, mode="nearest")
    # a nodata pixel that takes part in a point's interpolation (a weight above 0) leaves it
    # without a height; one next to it with no weight does not
    touched = map_coordinates(missing.astype(float), coordinates, order=1, mode="nearest")
    bad = ~inside | (touched > 1e-9) | ~np.isfinite(values)
    if bad.any():
        first = int(np.flatnonzero(bad.ravel())[0])
        raise InputError(
            f"{label}: no terrain height under {int(bad.sum())} of {bad.size} {what} (outside "
            f"the DEM or nodata; the first at ({px.flat[first]:.1f}, {py.flat[first]:.1f})); "
            f"expected {expected}"
        )
    return np.asarray(values, dtype=float)


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

    Raises
    ------
    InputError
        The observer or a lit cell has no terrain height: outside the DEM or on nodata
        (:func:`terrain_under`).
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
        cell_heights = terrain_under(relief, cx, cy, label=label)
        weights = np.abs(flux)
        source_altitude = float(
            np.average(cell_heights, weights=weights) if weights.sum() > 0 else cell_heights.mean()
        )
    return SceneTerrain(
        heights, relief.transform, ground + observer_height, source_altitude, cell_heights
    )
