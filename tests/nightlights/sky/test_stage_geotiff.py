"""Panoramas and polar maps written as GeoTIFF by the output's extension, with their style."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
import xarray as xr
from affine import Affine

from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.sky import Observer, Scene, skyglow
from nightlights.sky.polar import PolarMap
from nightlights.sky.stage import panorama_raster, polar_raster


@pytest.fixture
def kernel(small_kernel: xr.Dataset) -> xr.Dataset:
    """The session's small kernel (8 x 32 panorama)."""
    return small_kernel


def _emission() -> Raster:
    flux = np.zeros((1, 20, 20))
    flux[0, 5, 15] = flux[0, 12, 4] = 1.0  # [lm m-2]
    return Raster(flux, Affine(100, 0, 500_000, 0, -100, 6_702_000), "EPSG:32635")


def test_skyglow_writes_a_styled_panorama_and_polar_map_by_extension(
    kernel: xr.Dataset, tmp_path: Path
) -> None:
    result = skyglow(
        Scene(_emission(), kernel=kernel),
        Observer(501_000.0, 6_701_000.0, height=0.0),
        tmp_path / "panorama.tif",
        polar_output=tmp_path / "polar.tif",
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "panorama.qml",
        "panorama.tif",
        "polar.qml",
        "polar.tif",
    ]
    with rasterio.open(tmp_path / "panorama.tif") as dataset:
        assert dataset.descriptions == ("luminance", "sky_brightness")
        assert dataset.units == ("cd m-2", "mag arcsec-2")
        assert dataset.bounds == (0.0, 0.0, 360.0, 90.0)
        assert dataset.res == (360.0 / 32, 90.0 / 8)
        assert "sky of an observer" in dataset.crs.to_wkt()
        np.testing.assert_allclose(
            dataset.read(1), result.panorama["luminance"].values, rtol=1e-6
        )  # float32
    assert "Bortle" in (tmp_path / "panorama.qml").read_text(encoding="utf-8")
    with rasterio.open(tmp_path / "polar.tif") as dataset:
        assert dataset.crs.to_epsg() == 32635
        left, bottom, right, top = dataset.bounds
        assert (left + right) / 2 == pytest.approx(501_000.0)
        assert (bottom + top) / 2 == pytest.approx(6_701_000.0)


def test_a_netcdf_panorama_stays_netcdf(kernel: xr.Dataset, tmp_path: Path) -> None:
    skyglow(
        Scene(_emission(), kernel=kernel),
        Observer(501_000.0, 6_701_000.0, height=0.0),
        tmp_path / "panorama.nc",
    )
    assert [p.name for p in tmp_path.iterdir()] == ["panorama.nc"]


def test_the_polar_raster_keeps_the_flux_of_the_map() -> None:
    """Each cell carries its bin's flux density, so the grid integrates to the map's flux
    (to the pixelation of the bins' edges: 1 % with 400 cells across the radius)."""
    rng = np.random.default_rng(3)
    edges = np.geomspace(50.0, 5000.0, 7)
    flux = rng.uniform(0.5, 2.0, (1, 6, 32))
    polar = PolarMap(flux, edges, 32, np.zeros(1), flux.sum(axis=(1, 2)))
    raster = polar_raster(polar, (0.0, 0.0), "EPSG:32635", half_cells=400)
    total = np.nansum(raster.data) * raster.resolution**2
    assert total == pytest.approx(flux.sum(), rel=0.01)


def test_a_polar_bin_lies_at_its_bearing() -> None:
    flux = np.zeros((1, 1, 4))
    flux[0, 0, 1] = 1.0
    polar = PolarMap(flux, np.array([0.0, 100.0]), 4, np.zeros(1), np.ones(1))
    raster = polar_raster(polar, (0.0, 0.0), "EPSG:32635", half_cells=10)
    rows, cols = np.nonzero(raster.data[0] > 0)
    # bin 1 covers azimuths 90-180 deg: east of the observer and south of it
    assert (cols >= 10).all() and (rows >= 10).all()


def test_a_panorama_with_uneven_rows_is_refused() -> None:
    panorama = xr.Dataset(
        {
            "luminance": (("elevation", "azimuth"), np.ones((2, 4))),
            "sky_brightness": (("elevation", "azimuth"), np.ones((2, 4))),
        },
        coords={"elevation": [80.0, 10.0], "azimuth": [45.0, 135.0, 225.0, 315.0]},
    )
    with pytest.raises(InputError, match="not equally spaced"):
        panorama_raster(panorama)
