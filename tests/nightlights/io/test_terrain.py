"""Rasters on a grid and at points (nightlights.io.terrain)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from pyproj import CRS

from nightlights.errors import CRSError, InputError
from nightlights.io import Raster, raster_on_grid, sample_raster

UTM = CRS.from_epsg(32633)


def ramp() -> Raster:
    rows, cols = np.mgrid[0:10, 0:10]
    return Raster((10.0 * cols + rows)[None], Affine(10, 0, 0, 0, -10, 100), UTM)


def test_bilinear_on_a_finer_grid_of_a_plane() -> None:
    """Bilinear resampling reproduces a plane exactly inside the source's pixel centres."""
    grid = raster_on_grid(ramp(), transform=Affine(5, 0, 10, 0, -5, 90), shape=(10, 12), crs=UTM)
    x = 10 + 5 * (np.arange(12) + 0.5)
    y = 90 - 5 * (np.arange(10) + 0.5)
    expected = (x[None, :] - 5) + (100 - y[:, None] - 5) / 10
    np.testing.assert_allclose(grid, expected, rtol=1e-12)


def test_coverage_error_names_the_gap(tmp_path: Path) -> None:
    path = tmp_path / "dem.tif"
    ramp().write(path)
    with pytest.raises(InputError, match=r"dem\.tif: the DEM leaves 96 of 144 pixels"):
        raster_on_grid(
            path, transform=Affine(10, 0, 40, 0, -10, 80), shape=(12, 12), crs=UTM, name="DEM"
        )
    holed = ramp().data.copy()
    holed[0, 5, 5] = np.nan
    with pytest.raises(InputError, match="in-memory albedo raster: the albedo raster leaves"):
        raster_on_grid(
            Raster(holed, ramp().transform, UTM),
            transform=Affine(10, 0, 0, 0, -10, 100),
            shape=(10, 10),
            crs=UTM,
            name="albedo raster",
        )


def test_missing_crs() -> None:
    bare = Raster(ramp().data, ramp().transform, None)
    grid = raster_on_grid(bare, transform=ramp().transform, shape=(10, 10), crs=UTM)
    np.testing.assert_array_equal(grid, ramp().data[0])
    with pytest.raises(CRSError, match="has no CRS"):
        raster_on_grid(bare, transform=ramp().transform, shape=(10, 10), crs=UTM, require_crs=True)


def test_sample_at_points_in_another_crs() -> None:
    points = gpd.GeoSeries.from_xy([15.0, 95.0, 150.0], [85.0, 5.0, 5.0], crs=UTM).to_crs(4326)
    values = sample_raster(ramp().to_xarray(), points)
    np.testing.assert_array_equal(values[:2], [11.0, 99.0])
    assert np.isnan(values[2])
    assert sample_raster(ramp(), gpd.GeoSeries([], crs=UTM)).shape == (0,)
