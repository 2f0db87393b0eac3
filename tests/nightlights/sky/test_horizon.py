"""Terrain horizon from a DEM and its use by the skyglow stage."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from affine import Affine

from nightlights.errors import CRSError, InputError
from nightlights.io import RasterBand, write_cog
from nightlights.sky import Observer, Scene, skyglow
from nightlights.sky.horizon import ground_height, horizon_elevation

T = Affine(50.0, 0, 0, 0, -50.0, 8000.0)  # 160 x 160 cells of 50 m


def _ridge_dem() -> np.ndarray:
    dem = np.full((160, 160), 100.0)
    dem[:, 120:125] = 600.0  # a north-south ridge 2 km east of the centre (x = 6000-6250 m)
    return dem


def test_flat_ground_horizon_is_just_below_zero() -> None:
    dem = np.full((160, 160), 100.0)
    horizon = horizon_elevation(dem, T, (4000.0, 4000.0), eye_altitude=101.7, n_az=32)
    assert np.all(horizon < 0) and np.all(horizon > -2.0)


def test_ridge_raises_the_horizon_to_the_east_only() -> None:
    horizon = horizon_elevation(_ridge_dem(), T, (4000.0, 4000.0), eye_altitude=101.7, n_az=32)
    azimuth = (np.arange(32) + 0.5) * 360 / 32
    east = np.abs(azimuth - 90) < 10
    # Ridge top 498.3 m above the eye, 2000 m away: atan(498.3 / 2000) = 14.0 deg.
    assert horizon[east].max() == pytest.approx(np.degrees(np.arctan2(498.3, 2000.0)), abs=0.5)
    west = np.abs(azimuth - 270) < 30
    assert np.all(horizon[west] < 0)


def test_ground_height_and_outside_observer() -> None:
    assert ground_height(_ridge_dem(), T, 4000.0, 4000.0) == pytest.approx(100.0)
    with pytest.raises(InputError, match="outside the DEM"):
        ground_height(_ridge_dem(), T, -500.0, 4000.0)


def test_stage_masks_the_panorama_below_the_terrain(tmp_path, small_kernel) -> None:
    emission = np.zeros((160, 160), np.float32)
    emission[78:82, 140:144] = 1.0  # a town behind the ridge, 3.1 km east
    emission[78:82, 20:24] = 1.0  # and one in the open, 3.1 km west
    src, dem_path = tmp_path / "emission.tif", tmp_path / "dem.tif"
    write_cog(src, [RasterBand(emission, "reflected", "lm m-2")], transform=T, crs="EPSG:3067")
    write_cog(
        dem_path,
        [RasterBand(_ridge_dem().astype(np.float32), "height", "m")],
        transform=T,
        crs="EPSG:3067",
    )
    out = tmp_path / "pano.nc"
    one_band = small_kernel.drop_vars(["kernel_uplight", "coefficient_uplight"])
    skyglow(Scene(src, kernel=one_band, dem=dem_path), Observer(4000.0, 4000.0), out)
    pano = xr.open_dataset(out, engine="h5netcdf")
    mask = pano["terrain_mask"].values.astype(bool)
    azimuth = pano["azimuth"].values
    assert mask[:, np.abs(azimuth - 90) < 10].any()  # low rows to the east are hidden
    assert not mask[:, np.abs(azimuth - 270) < 10].any()
    assert np.isnan(pano["luminance"].values[mask]).all()
    assert np.isfinite(pano["luminance"].values[~mask]).all()
    pano.close()
    wrong_crs = tmp_path / "dem_wrong.tif"
    write_cog(
        wrong_crs,
        [RasterBand(_ridge_dem().astype(np.float32), "height", "m")],
        transform=T,
        crs="EPSG:32635",
    )
    with pytest.raises(CRSError, match="DEM must be in the emission raster's CRS"):
        skyglow(
            Scene(src, kernel=one_band, dem=wrong_crs), Observer(4000.0, 4000.0), tmp_path / "x.nc"
        )
