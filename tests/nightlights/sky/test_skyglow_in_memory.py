"""The in-memory skyglow: a Raster or DataArray in, a panorama out, nothing written; equal to
the file form; a KernelResult accepted as the kernel."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine

from nightlights.io import Raster
from nightlights.sky import KernelResult, KernelSpec, Observer, Scene, skyglow, skyglow_panorama

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000)
OBSERVER = Observer(502_000.0, 6_698_000.0, height=0.0)


def _raster() -> Raster:
    scene = np.zeros((2, 40, 40))
    scene[0, 5, 30] = 1.0
    scene[0, 20:23, 3:6] = 0.25  # float32-exact values: the file form stores float32
    scene[1] = 0.125 * scene[0]
    return Raster(scene, TRANSFORM, "EPSG:32635", ("reflected", "uplight"), ("lm m-2",) * 2)


def _dem() -> Raster:
    heights = np.zeros((1, 40, 40))
    heights[0, :, 10:12] = 200.0  # a ridge between the observer and the town to the west
    return Raster(heights, TRANSFORM, "EPSG:32635", ("height",), ("m",))


def test_raster_dataarray_and_file_give_one_panorama(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, small_kernel: xr.Dataset
) -> None:
    raster = _raster()
    monkeypatch.chdir(tmp_path)
    eye = OBSERVER.replace(height=1.75)
    in_memory = skyglow(Scene(raster, kernel=small_kernel, dem=_dem()), eye)
    assert in_memory.path is None and list(tmp_path.iterdir()) == []
    pure = skyglow_panorama(Scene(raster, kernel=small_kernel, dem=_dem()), eye).panorama
    from_array = skyglow_panorama(
        Scene(raster.to_xarray(), kernel=small_kernel, dem=_dem().to_xarray()), eye
    ).panorama
    assert list(tmp_path.iterdir()) == []
    src, dem = tmp_path / "emission.tif", tmp_path / "dem.tif"
    raster.write(src)
    _dem().write(dem)
    on_disk = skyglow(Scene(src, kernel=small_kernel, dem=dem), eye, tmp_path / "pano.nc")
    assert on_disk.path == tmp_path / "pano.nc"
    written = xr.load_dataset(on_disk.path, engine="h5netcdf")
    assert pure["terrain_mask"].values.any()
    for pano in (in_memory.panorama, from_array, written):
        np.testing.assert_array_equal(pano["luminance"].values, pure["luminance"].values)
        np.testing.assert_array_equal(pano["terrain_mask"].values, pure["terrain_mask"].values)
    assert in_memory.zenith_luminance == pytest.approx(on_disk.zenith_luminance, rel=0)
    assert in_memory.bortle == on_disk.bortle
    assert pure.attrs["emission"] == "in-memory emission raster"
    assert written.attrs["emission"] == str(src)


def test_kernel_result_dataset_and_path_are_one_kernel(
    tmp_path: Path, small_kernel: xr.Dataset
) -> None:
    spec = KernelSpec.from_kernel(small_kernel)
    result = KernelResult(small_kernel, spec, None)
    path = tmp_path / "k.nc"
    small_kernel.to_netcdf(path, engine="h5netcdf")
    panoramas = [
        skyglow_panorama(Scene(_raster(), kernel=kernel), OBSERVER).panorama["luminance"]
        for kernel in (result, small_kernel, path)
    ]
    np.testing.assert_array_equal(panoramas[0], panoramas[1])
    np.testing.assert_allclose(panoramas[2], panoramas[0], rtol=1e-6)


def test_png_and_polar_written_only_when_asked(tmp_path: Path, small_kernel: xr.Dataset) -> None:
    result = skyglow(
        Scene(_raster(), kernel=small_kernel),
        OBSERVER,
        png=tmp_path / "p.png",
        polar_output=tmp_path / "polar.nc",
    )
    assert result.path is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png", "polar.nc"]


def test_summary_adds_the_natural_sky_beside_the_artificial(small_kernel: xr.Dataset) -> None:
    from nightlights.brightness import luminance_to_magnitude

    attrs = skyglow(Scene(_raster(), kernel=small_kernel), OBSERVER).panorama.attrs
    natural, artificial = attrs["zenith_natural_cd_m2"], attrs["zenith_luminance_cd_m2"]
    assert float(luminance_to_magnitude(natural)) == pytest.approx(22.0, abs=0.01)
    total = float(luminance_to_magnitude(natural + artificial))
    assert attrs["zenith_total_sky_brightness"] == pytest.approx(total)
    assert attrs["zenith_total_sky_brightness"] < min(22.0, attrs["zenith_sky_brightness"])
    assert attrs["bortle_class_zenith_total"] >= attrs["bortle_class_zenith"]
