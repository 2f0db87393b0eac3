"""Rasters that describe the ground (elevation, albedo) on the stages' grids.

Two operations, both on a :class:`~nightlights.io.Raster`, an :class:`xarray.DataArray` or a
path (see :func:`~nightlights.io.as_raster`):

* :func:`raster_on_grid` resamples one band onto a target grid with GDAL's warper and
  refuses a raster that leaves part of the grid uncovered;
* :func:`sample_raster` reads one band at points (the pixel holding each point).

A raster without a CRS is taken to be in the CRS of the grid or points it is used with,
unless the caller requires one.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import geopandas as gpd
import numpy as np
from affine import Affine
from pyproj import CRS
from rasterio.transform import rowcol
from rasterio.warp import Resampling, reproject

from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError
from nightlights.io.raster import Raster, as_raster, source_label

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["raster_on_grid", "sample_raster", "uncovered_error"]


def raster_on_grid(
    source: Raster | xr.DataArray | str | os.PathLike[str],
    *,
    transform: Affine,
    shape: tuple[int, int],
    crs: CRS,
    band: int = 0,
    resampling: Resampling = Resampling.bilinear,
    name: str = "raster",
    require_crs: bool = False,
) -> FloatArray:
    """One band of a raster resampled onto a grid, which it must cover.

    Parameters
    ----------
    source
        The raster: a :class:`~nightlights.io.Raster`, a DataArray or a path.
    transform
        Affine transform of the target grid's top-left pixel corner [m].
    shape
        (rows, cols) of the target grid [pixels].
    crs
        CRS of the target grid; a source without a CRS is taken to be in it.
    band
        0-based band index of ``source``.
    resampling
        GDAL resampling method (default bilinear).
    name
        What the raster is (``DEM``, ``albedo raster``), for messages.
    require_crs
        Refuse a source without a CRS instead of assuming ``crs``.

    Returns
    -------
    numpy.ndarray
        Array (rows, cols) [unit of the band].

    Raises
    ------
    InputError
        The raster cannot be read, has no such band, or leaves pixels of the grid without a
        value (outside it or on nodata).
    CRSError
        ``require_crs`` and the raster has no CRS.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from pyproj import CRS
    >>> dem = Raster(np.full((1, 4, 4), 250.0), Affine(10, 0, 0, 0, -10, 40), "EPSG:32633")
    >>> raster_on_grid(dem, transform=Affine(5, 0, 0, 0, -5, 40), shape=(2, 3),
    ...                crs=CRS.from_epsg(32633), name="DEM").tolist()
    [[250.0, 250.0, 250.0], [250.0, 250.0, 250.0]]
    """
    label = source_label(source, name)
    raster = as_raster(source)
    if raster.crs is None and require_crs:
        raise CRSError(f"{label}: the {name} has no CRS")
    if not 0 <= band < raster.count:
        raise InputError(f"{label}: the {name} has {raster.count} bands; no band {band + 1}")
    target = np.full(shape, np.nan)
    reproject(
        raster.data[band],
        target,
        src_transform=raster.transform,
        src_crs=(raster.crs or crs).to_wkt(),
        src_nodata=np.nan,
        dst_transform=transform,
        dst_crs=crs.to_wkt(),
        dst_nodata=np.nan,
        resampling=resampling,
    )
    missing = int(np.isnan(target).sum())
    if missing:
        raise uncovered_error(label, name, missing, transform, shape)
    return target


def uncovered_error(
    label: str, name: str, missing: int, transform: Affine, shape: tuple[int, int]
) -> InputError:
    """The error of a raster that leaves ``missing`` pixels of a grid without a value.

    Parameters
    ----------
    label, name
        The raster's label and what it is (``albedo raster``), for the message.
    missing
        Pixels of the grid without a value [1].
    transform, shape
        The grid's transform and (rows, cols) [pixels].
    """
    rows, cols = shape
    xs = (transform.c, transform.c + transform.a * cols)
    ys = (transform.f, transform.f + transform.e * rows)
    bounds = (min(xs), min(ys), max(xs), max(ys))
    return InputError(
        f"{label}: the {name} leaves {missing} of {rows * cols} pixels of the grid "
        f"{bounds} without a value; expected it to cover the whole grid"
    )


def sample_raster(
    source: Raster | xr.DataArray | str | os.PathLike[str],
    points: gpd.GeoSeries | gpd.GeoDataFrame,
    *,
    band: int = 0,
    name: str = "raster",
) -> FloatArray:
    """One band of a raster at points: the value of the pixel holding each point.

    Parameters
    ----------
    source
        The raster: a :class:`~nightlights.io.Raster`, a DataArray or a path.
    points
        Point geometries; reprojected to the raster's CRS when both have one.
    band
        0-based band index of ``source``.
    name
        What the raster is, for messages.

    Returns
    -------
    numpy.ndarray
        Array (n,) [unit of the band]; NaN for points outside the raster or on nodata.

    Raises
    ------
    InputError
        The raster cannot be read or has no such band.

    Examples
    --------
    >>> import numpy as np
    >>> import geopandas as gpd
    >>> from affine import Affine
    >>> dem = Raster(np.arange(4.0).reshape(1, 2, 2), Affine(10, 0, 0, 0, -10, 20), "EPSG:32633")
    >>> points = gpd.GeoSeries.from_xy([5.0, 15.0, 99.0], [15.0, 5.0, 5.0], crs="EPSG:32633")
    >>> sample_raster(dem, points).tolist()
    [0.0, 3.0, nan]
    """
    label = source_label(source, name)
    raster = as_raster(source)
    if not 0 <= band < raster.count:
        raise InputError(f"{label}: the {name} has {raster.count} bands; no band {band + 1}")
    geometry = points.geometry if isinstance(points, gpd.GeoDataFrame) else points
    if raster.crs is not None and geometry.crs is not None:
        geometry = geometry.to_crs(raster.crs.to_wkt())
    values = np.full(len(geometry), np.nan)
    if len(geometry) == 0:
        return values
    rows, cols = rowcol(raster.transform, geometry.x.to_numpy(), geometry.y.to_numpy())
    rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
    n_rows, n_cols = raster.shape
    inside = (rows >= 0) & (rows < n_rows) & (cols >= 0) & (cols < n_cols)
    values[inside] = raster.data[band, rows[inside], cols[inside]]
    return values
