"""Inverse maps of a grid larger than the kernel's reach: only the window it reaches is read.

The reference is the same stage reading the whole grid (its window search switched off): the
values in the window agree to float tolerance (the same arithmetic on the same cells), the lit
cells outside it are 0 there (beyond the kernel's last distance edge) and NaN here.
"""

from __future__ import annotations

from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import rasterio
import rasterio.windows
from affine import Affine

from nightlights._resources import set_memory_limit
from nightlights.errors import CRSError, ResourceError
from nightlights.inverse import inverse_q, inverse_reduce, inverse_s, stage
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 500_000.0, 0, -CELL, 6_000_000.0)
SIZE = 100  # 10 km across, the kernel reaches 3 km
#: An observer in the middle and one near the top-left corner.
OBSERVERS = [Observer(505_050.0, 5_995_050.0), Observer(500_130.0, 5_999_870.0)]


@pytest.fixture(scope="module")
def kernel():
    spec = KernelSpec.exact(
        r_min=10.0, r_max=3000.0, n_distance=12, n_elevation=8, n_azimuth=32, uplight=True
    )
    return build_kernel(spec, progress=False)


@pytest.fixture(scope="module")
def city() -> Raster:
    rng = np.random.default_rng(1)
    data = rng.lognormal(0.0, 1.0, (2, SIZE, SIZE)) * (rng.random((SIZE, SIZE)) < 0.3)
    data[1] *= 0.1
    return Raster(data, TRANSFORM, "EPSG:32635", ("reflected", "uplight"), ("lm m-2",) * 2)


def _whole(function, *args, **kwargs):
    """The stage as before windows: the whole grid read and held."""
    with mock.patch.object(stage, "_reach", return_value=None):
        return function(*args, **kwargs)


def _check_window(result, reference, grid: np.ndarray) -> None:
    window = result.window
    assert window is not None and not window.whole
    rows = slice(window.row, window.row + window.rows)
    inside = (rows, slice(window.col, window.col + window.cols))
    expected = reference.raster.data[0][inside]
    assert result.raster.shape == expected.shape
    assert result.raster.transform.almost_equals(window.transform)
    np.testing.assert_allclose(result.raster.data[0], expected, rtol=1e-12, atol=0.0)
    assert np.array_equal(np.isnan(result.raster.data[0]), np.isnan(expected))
    outside = reference.raster.data[0].copy()
    outside[inside] = np.nan
    assert np.all(outside[np.isfinite(outside)] == 0.0)  # beyond the kernel's reach
    assert result.total == pytest.approx(reference.total, rel=1e-12)
    if np.isfinite(reference.panorama_value):
        assert result.panorama_value == pytest.approx(reference.panorama_value, rel=1e-12)
    # the file: the whole grid, the window's values, NaN outside
    np.testing.assert_allclose(grid[inside], expected.astype(np.float32), rtol=1e-6)
    grid[inside] = np.nan
    assert np.all(np.isnan(grid))


@pytest.mark.parametrize("observer", OBSERVERS, ids=["middle", "edge"])
@pytest.mark.parametrize("metric", ["pca-norm", "zenith"])
def test_q_on_the_window_equals_the_whole_grid(
    kernel, city, tmp_path: Path, observer, metric
) -> None:
    source = city.write(tmp_path / "emission.tif")
    for emission in (city, source):
        result = inverse_q(
            Scene(emission, kernel=kernel), observer, tmp_path / "q.tif", metric=metric
        )
        reference = _whole(inverse_q, Scene(emission, kernel=kernel), observer, metric=metric)
        with rasterio.open(result.path) as written:
            assert written.shape == city.shape and written.transform.almost_equals(TRANSFORM)
            assert written.tags()["metric"] == metric
            grid = written.read(1).astype(float)
        _check_window(result, reference, grid)


@pytest.mark.parametrize("observer", OBSERVERS, ids=["middle", "edge"])
def test_s_on_the_window_equals_the_whole_grid(kernel, city, tmp_path: Path, observer) -> None:
    scene = Scene(city, kernel=kernel)
    result = inverse_s(scene, observer, tmp_path / "s.tif", region="horizon:0,180,40")
    reference = _whole(inverse_s, scene, observer, region="horizon:0,180,40")
    with rasterio.open(result.path) as written:
        grid = written.read(1).astype(float)
    _check_window(result, reference, grid)


def test_a_grid_within_reach_is_computed_whole(kernel, city) -> None:
    small = Raster(city.data[:, :40, :40], TRANSFORM, city.crs, city.descriptions, city.units)
    result = inverse_q(Scene(small, kernel=kernel), Observer(502_050.0, 5_998_050.0))
    assert result.window is None and result.raster.shape == (40, 40)


def test_reduce_by_a_window_equals_reduce_by_the_file(kernel, city, tmp_path: Path) -> None:
    """The dimming rule reads a windowed Q held in memory as the Q file on the whole grid."""
    scene = Scene(city, kernel=kernel)
    q = inverse_q(scene, OBSERVERS[0], tmp_path / "q.tif")
    qa, qb = np.nanpercentile(q.raster.data, [50, 90])
    held = inverse_reduce(scene, by=q.raster, qa=qa, qb=qb, gamma=0.5)
    read = inverse_reduce(scene, by=tmp_path / "q.tif", qa=qa, qb=qb, gamma=0.5)
    assert np.nanmax(held.dimming.data) == 0.5
    np.testing.assert_allclose(held.dimming.data, read.dimming.data, atol=1e-6)
    assert held.summary["flux_removed_percent"] == pytest.approx(
        read.summary["flux_removed_percent"], rel=1e-5
    )


def test_a_failed_write_leaves_nothing(kernel, city, tmp_path: Path) -> None:
    def fail(*args, **kwargs):
        raise RuntimeError("disk gone")

    with mock.patch("nightlights.io.streamed.CogWriter.write", fail), pytest.raises(RuntimeError):
        inverse_q(Scene(city, kernel=kernel), OBSERVERS[0], tmp_path / "q.tif")
    assert list(tmp_path.iterdir()) == []


def test_a_geographic_grid_is_refused_in_one_line(kernel, city) -> None:
    lonlat = Raster(city.data, Affine(0.001, 0, 24.0, 0, -0.001, 60.0), "EPSG:4326")
    with pytest.raises(CRSError, match="needs a projected CRS in metres"):
        inverse_q(Scene(lonlat, kernel=kernel), Observer(24.05, 59.95))


# --- a raster too large to hold ---------------------------------------------------------------

HUGE = 200_000  # cells across: 4e10 cells of 10 m, 2000 km


@pytest.fixture(scope="module")
def huge(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 200 000 x 200 000 GeoTIFF of which one block is written (a few kB on disk)."""
    path = tmp_path_factory.mktemp("huge") / "huge.tif"
    with rasterio.open(
        path, "w", driver="GTiff", width=HUGE, height=HUGE, count=1, dtype="float32",
        crs="EPSG:32635", transform=Affine(10, 0, 300_000, 0, -10, 7_000_000), tiled=True,
        blockxsize=512, blockysize=512, compress="deflate", sparse_ok=True,
    ) as dataset:  # fmt: skip
        block = np.zeros((512, 512), np.float32)
        block[100:103, 200:203] = 1.0  # rows 100_100-100_102, cols 100_200-100_202
        dataset.write(block, 1, window=rasterio.windows.Window(100_000, 100_000, 512, 512))
    return path


def test_a_raster_too_large_to_hold_is_windowed(kernel, huge: Path) -> None:
    """The whole grid would need 800 GB; the window a 3 km kernel reaches, a few MB."""
    observer = Observer(300_000 + 10 * 100_201.5, 7_000_000 - 10 * 100_150.5)
    set_memory_limit("1G")
    try:
        q = inverse_q(Scene(huge, kernel=kernel), observer, metric="zenith")
        with pytest.raises(ResourceError, match=r"the zenith raster of 60001 x 60001 cells"):
            inverse_q(Scene(huge), observer, metric="zenith")  # a scene kernel reaches 300 km
    finally:
        set_memory_limit(None)
    assert q.window is not None and q.window.grid_shape == (HUGE, HUGE)
    assert q.raster.shape == (601, 601)
    assert int(np.isfinite(q.raster.data).sum()) == 9 and q.total > 0


def test_the_estimate_grows_with_the_reach_not_the_raster() -> None:
    small = stage.influence_memory((601, 601), streamed=True)
    large = stage.influence_memory((60_001, 60_001), streamed=True)
    whole = stage.influence_memory((HUGE, HUGE), streamed=False)
    assert small < 200 * 2**20 < 50 * 2**30 < large < whole
