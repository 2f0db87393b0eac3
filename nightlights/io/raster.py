"""Rasters: float32 Cloud-Optimised GeoTIFF output, atomic, with band metadata."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rasterio
import rasterio.shutil
from affine import Affine
from pyproj import CRS
from rasterio.io import MemoryFile

from nightlights.errors import InputError, OutputError
from nightlights.io.atomic import atomic_output


@dataclass(frozen=True)
class RasterBand:
    """One band of a raster with its metadata.

    Attributes
    ----------
    data
        2-D array (rows, cols).
    description
        Band description shown by QGIS and ``gdalinfo``.
    unit
        Physical unit, e.g. ``lx`` or ``lm m-2``.
    tags
        Extra band metadata.
    """

    data: np.ndarray
    description: str
    unit: str
    tags: Mapping[str, str] = field(default_factory=dict)


def write_cog(
    path: str | os.PathLike[str],
    bands: Sequence[RasterBand],
    *,
    transform: Affine,
    crs: CRS | str,
    nodata: float = np.nan,
    tags: Mapping[str, Any] | None = None,
    compress: str = "DEFLATE",
    blocksize: int = 512,
) -> Path:
    """Write bands to a float32 Cloud-Optimised GeoTIFF, atomically.

    Parameters
    ----------
    path
        Output ``.tif``.
    bands
        Bands of equal shape.
    transform
        Affine transform of the top-left corner (pixel edges).
    crs
        Coordinate reference system of the grid.
    nodata
        Nodata value [same unit as the bands].
    tags
        Dataset-level metadata (model parameters, provenance).
    compress
        GDAL compression (``DEFLATE``, ``ZSTD``, ``LZW``).
    blocksize
        Tile size [pixels].
    """
    if not bands:
        raise OutputError(f"{path}: no bands to write")
    shape = bands[0].data.shape
    if any(band.data.shape != shape for band in bands) or len(shape) != 2:
        raise OutputError(
            f"{path}: bands must be 2-D arrays of one shape, got "
            f"{[band.data.shape for band in bands]}"
        )
    rows, cols = shape
    crs_text = CRS.from_user_input(crs).to_wkt()
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": len(bands),
        "dtype": "float32",
        "crs": crs_text,
        "transform": transform,
        "nodata": nodata,
    }
    with MemoryFile() as memfile, memfile.open(**profile) as mem:
        for index, band in enumerate(bands, start=1):
            mem.write(np.asarray(band.data, dtype=np.float32), index)
            mem.set_band_description(index, band.description)
            mem.update_tags(index, unit=band.unit, **dict(band.tags))
            mem.set_band_unit(index, band.unit)
        if tags:
            mem.update_tags(**{key: str(value) for key, value in tags.items()})
        with atomic_output(path) as tmp:
            rasterio.shutil.copy(
                mem,
                tmp,
                driver="COG",
                COMPRESS=compress,
                BLOCKSIZE=str(blocksize),
                OVERVIEWS="AUTO" if min(rows, cols) > blocksize else "NONE",
                PREDICTOR="YES",
            )
    return Path(path)


def read_raster(path: str | os.PathLike[str]) -> tuple[np.ndarray, dict[str, Any]]:
    """Read every band of a raster as float64 with nodata as NaN.

    Returns
    -------
    data : numpy.ndarray
        Array (bands, rows, cols).
    meta : dict
        ``transform``, ``crs`` (pyproj CRS or None), ``descriptions``, ``units``, ``tags``.
    """
    source = Path(path)
    if not source.exists():
        raise InputError(f"{source}: no such file")
    try:
        with rasterio.open(source) as dataset:
            data = dataset.read(masked=True).astype(np.float64).filled(np.nan)
            meta = {
                "transform": dataset.transform,
                "crs": CRS.from_user_input(dataset.crs.to_wkt()) if dataset.crs else None,
                "descriptions": list(dataset.descriptions),
                "units": list(dataset.units),
                "tags": dataset.tags(),
                "band_tags": [dataset.tags(i) for i in range(1, dataset.count + 1)],
            }
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{source}: cannot read raster: {exc}") from exc
    return data, meta
