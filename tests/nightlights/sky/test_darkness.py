"""The zenith darkness map: equal to the forward panorama's zenith at every cell (flat terrain
and terrain, same kernel), chunked and distributed runs equal to one FFT, scene kernels, output
and one-line errors."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from distributed import Client, LocalCluster

from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import CRSError, DataQualityWarning, InputError, OutputError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
from nightlights.sky.darkness import DarknessResult, darkness, zenith_per_lumen
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.observer import OBSERVER_HEIGHT
from nightlights.sky.panorama import kernel_slice
from nightlights.sky.spec import MAX_KERNEL_RANGE
from nightlights.sky.store import kernel_cache_path

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000)
CRS = "EPSG:32635"
#: Float rounding only: the map and the panorama add the same terms in another order.
SAME_KERNEL_RTOL = 1e-9


def centre(row: int, col: int) -> tuple[float, float]:
    """Cell centre (x, y) [m], computed as the polar map computes it."""
    return (TRANSFORM.c + TRANSFORM.a * (col + 0.5), TRANSFORM.f + TRANSFORM.e * (row + 0.5))


def emission(n: int = 40, bands: int = 1, seed: int = 1) -> Raster:
    """A town block, a single bright cell, a lit corner and a sprinkle of dim cells."""
    rng = np.random.default_rng(seed)
    flux = np.zeros((bands, n, n))
    town = (slice(n // 4, n // 4 + 4), slice(n // 2, n // 2 + 5))  # rows 10-13, cols 20-24 of 40
    flux[0][town] = rng.uniform(0.5, 2.0, (4, 5))
    flux[0, 3 * n // 4, n // 8] = 3.0  # (30, 5) of 40
    flux[0, n - 2 :, n - 2 :] = 0.7
    flux[0] += (rng.random((n, n)) < 0.03) * rng.random((n, n)) * 0.1
    if bands == 2:
        flux[1][town] = 0.2
    return Raster(flux, TRANSFORM, CRS, ("lambertian", "uplight")[:bands])


def hills(n: int = 40, relief: float = 60.0) -> Raster:
    """Terrain around 120 m: ridges of +-``relief`` and a slope of 1.2 m per cell [m]."""
    rows, cols = np.mgrid[0:n, 0:n]
    heights = 120 + relief * np.sin(cols / 6.0) * np.cos(rows / 9.0) + 1.2 * rows
    return Raster(heights, TRANSFORM, CRS)


@pytest.fixture(scope="module")
def kernel() -> xr.Dataset:
    """Flat terrain, Lambertian + uplight, observers at 0 and 10 m."""
    spec = KernelSpec(
        r_max=6000.0,
        n_distance=16,
        n_elevation=8,
        n_azimuth=32,
        uplight=True,
        observer_altitudes=(0.0, 10.0),
    )
    return build_kernel(spec, progress=False).kernel


@pytest.fixture(scope="module")
def terrain_kernel() -> xr.Dataset:
    spec = KernelSpec(
        r_max=6000.0,
        n_distance=16,
        n_elevation=8,
        n_azimuth=32,
        source_altitudes=(40.0, 130.0, 240.0),
        observer_altitudes=(50.0, 150.0, 240.0),
    )
    return build_kernel(spec, progress=False).kernel


def panorama_zenith(
    scene: Scene, cell: tuple[int, int], *, height: float = OBSERVER_HEIGHT, mode: str
) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        sky = skyglow_panorama(
            scene, Observer(*centre(*cell), height=height), mode=mode, progress=False
        )
    return float(sky.panorama.attrs["zenith_luminance_cd_m2"])


# --- the forward panorama's zenith at every cell ------------------------------------------------

#: A lit town cell, the bright cell, corners and edges, a dark interior cell.
CELLS = [(11, 21), (30, 5), (0, 0), (39, 39), (20, 39), (0, 17), (5, 5)]


@pytest.mark.parametrize("observer_height", [0.0, 1.7, 6.0])
def test_flat_map_equals_the_panorama_zenith(kernel: xr.Dataset, observer_height: float) -> None:
    raster = emission(bands=2)
    scene = Scene(raster, kernel=kernel)
    result = darkness(scene, height=observer_height, progress=False)
    zenith = result.raster.data[0]
    for cell in CELLS:
        expected = panorama_zenith(scene, cell, height=observer_height, mode="exact")
        assert zenith[cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL), cell


def test_flat_ground_between_two_source_levels_is_split_as_the_panorama_splits_it() -> None:
    spec = KernelSpec(
        r_max=6000.0, n_distance=16, n_elevation=8, n_azimuth=32, source_altitudes=(-30.0, 20.0)
    )
    straddling = build_kernel(spec, progress=False).kernel
    raster = emission(n=30)
    scene = Scene(raster, kernel=straddling)
    zenith = darkness(scene, height=0.0, progress=False)
    for cell in [(8, 16), (0, 0), (29, 29)]:
        expected = panorama_zenith(scene, cell, height=0.0, mode="exact")
        assert zenith.raster.data[0][cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL)


def test_pca_only_kernel_uses_the_dc_term_and_equals_the_pca_panorama() -> None:
    spec = KernelSpec(r_max=6000.0, n_distance=16, n_elevation=8, n_azimuth=32, store_tables=False)
    pca_only = build_kernel(spec, progress=False).kernel
    raster = emission(n=30)
    scene = Scene(raster, kernel=pca_only)
    zenith = darkness(scene, height=0.0, progress=False).raster.data[0]
    for cell in [(11, 21), (0, 0), (29, 29), (20, 5)]:
        expected = panorama_zenith(scene, cell, height=0.0, mode="pca")
        assert zenith[cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL), cell


def test_zenith_tables_and_their_pca_dc_term_agree(kernel: xr.Dataset) -> None:
    tables = kernel_slice(kernel, observer_altitude=0.0)
    from_tables = zenith_per_lumen(tables)
    without = type(tables)(
        tables.kernel[..., :0],
        tables.coefficient,
        tables.basis_fft,
        tables.distance_edges,
        tables.elevation,
    )
    from_pca = zenith_per_lumen(without)
    assert from_tables.shape == (2, 16)
    # pca_energy 0.999999 of the whole table: the zenith row is within a few 1e-3
    np.testing.assert_allclose(from_pca, from_tables, rtol=5e-3)
    assert np.all(np.diff(from_tables[0]) < 0)  # fainter with distance


def test_terrain_map_equals_per_cell_panoramas_with_the_same_kernel(
    terrain_kernel: xr.Dataset,
) -> None:
    """Source levels and observer-level interpolation are the panorama's: float rounding."""
    raster, dem = emission(), hills()
    scene = Scene(raster, kernel=terrain_kernel, dem=dem)
    zenith = darkness(scene, progress=False).raster.data[0]
    for cell in CELLS:
        expected = panorama_zenith(scene, cell, mode="exact")
        assert zenith[cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL), cell


def test_terrain_map_is_within_a_few_percent_of_per_cell_scene_kernels(tmp_path: Path) -> None:
    """Against each cell's own scene kernel (its exact eye altitude, its own distance bins) the
    map differs by the linear interpolation between observer levels up to 50 m apart, largest
    next to lit cells (a few % within 200 m, as between source levels: see
    bench_sky_source_levels), and by the binning; the benchmark measures default kernels."""
    raster, dem = emission(n=24), hills(n=24, relief=30.0)
    small = {"n_distance": 16, "n_elevation": 8, "n_azimuth": 32, "cache_dir": tmp_path}
    scene = Scene(raster, dem=dem, **small)
    zenith = darkness(scene, progress=False).raster.data[0]
    for cell in [(11, 21), (0, 0), (20, 3)]:
        expected = panorama_zenith(scene, cell, mode="exact")
        assert zenith[cell] == pytest.approx(expected, rel=0.05), cell


# --- chunks and schedulers ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def short_kernel() -> xr.Dataset:
    """A 1.2 km kernel: a 12-cell stencil, so that an 80-cell raster splits into chunks."""
    spec = KernelSpec(
        r_max=1200.0,
        n_distance=12,
        n_elevation=8,
        n_azimuth=32,
        source_altitudes=(40.0, 120.0, 240.0),
        observer_altitudes=(40.0, 140.0, 250.0),
    )
    return build_kernel(spec, progress=False).kernel


@pytest.mark.parametrize("terrain", [False, True])
def test_chunks_equal_one_fft(short_kernel: xr.Dataset, terrain: bool) -> None:
    raster = emission(n=80, seed=3)
    dem = hills(n=80) if terrain else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)  # region wider than the kernel
        scene = Scene(raster, kernel=short_kernel, dem=dem)
        one = darkness(scene, progress=False)
        chunked = darkness(scene, chunk_size=24, progress=False)
    assert "1 chunk(s)" in one.raster.tags["method"]
    assert "9 chunk(s) of 24 cells" in chunked.raster.tags["method"]
    np.testing.assert_allclose(chunked.raster.data[0], one.raster.data[0], rtol=1e-12)


def test_small_chunks_grow_to_twice_the_stencil_radius(short_kernel: xr.Dataset) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = darkness(Scene(emission(n=80), kernel=short_kernel), chunk_size=5, progress=False)
    assert "of 24 cells" in result.raster.tags["method"]  # radius 12 cells


@pytest.mark.parametrize(
    "processes",
    [False, pytest.param(True, marks=pytest.mark.slow)],  # worker processes: ~15 s
)
def test_local_cluster_equals_single_process(short_kernel: xr.Dataset, processes: bool) -> None:
    raster, dem = emission(n=80, seed=5), hills(n=80)
    scene = Scene(raster, kernel=short_kernel, dem=dem)
    options = {"chunk_size": 24, "progress": False}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        local = darkness(scene, **options)
        with (
            LocalCluster(
                n_workers=2, threads_per_worker=1, processes=processes, dashboard_address=None
            ) as cluster,
            Client(cluster) as client,
        ):
            by_address = darkness(scene, scheduler=cluster.scheduler_address, **options)
            by_client = darkness(scene, scheduler=client, **options)
    np.testing.assert_allclose(by_address.raster.data, local.raster.data, rtol=1e-12)
    np.testing.assert_allclose(by_client.raster.data, local.raster.data, rtol=1e-12)
    assert by_client.raster.tags == local.raster.tags


# --- scene kernels ----------------------------------------------------------------------


def test_scene_kernel_covers_the_diagonal_and_the_eye_altitudes(tmp_path: Path) -> None:
    raster, dem = emission(n=20), hills(n=20)
    small = {"n_distance": 8, "n_elevation": 8, "n_azimuth": 16, "cache_dir": tmp_path}
    scene = Scene(raster, dem=dem, **small)
    result = darkness(scene, height=2.0, progress=False)
    cached = list(tmp_path.glob("kernel-*.nc"))
    assert len(cached) == 1
    table = xr.load_dataset(cached[0], engine="h5netcdf")
    assert result.raster.tags["kernel_hash"] == table.attrs["content_hash"]
    assert cached[0] == kernel_cache_path(table.attrs["content_hash"], tmp_path)
    diagonal = np.hypot(20 * CELL, 20 * CELL)
    assert float(table["distance_edges"][-1]) == pytest.approx(1.01 * diagonal)
    observer = table["observer_altitude"].values
    heights = hills(n=20).data[0]
    assert observer.min() == pytest.approx(heights.min() + 2.0)
    assert observer.max() == pytest.approx(heights.max() + 2.0)
    assert np.diff(observer).max() <= 50.0 + 1e-9  # the source-level spacing
    again = darkness(scene, height=2.0, progress=False)
    np.testing.assert_array_equal(again.raster.data, result.raster.data)  # reused


def test_region_beyond_the_largest_kernel_range_warns(tmp_path: Path) -> None:
    flux = np.zeros((1, 4, 4))
    flux[0, 0, 0] = 1.0
    huge = Raster(flux, Affine(100_000, 0, 0, 0, -100_000, 400_000), CRS)
    small = {"n_distance": 4, "n_elevation": 4, "n_azimuth": 8, "cache_dir": tmp_path}
    with pytest.warns(DataQualityWarning, match="left out"):
        result = darkness(Scene(huge, **small), progress=False)
    assert float(result.raster.tags["kernel_range_m"]) == MAX_KERNEL_RANGE
    zenith = result.raster.data[0]
    assert zenith[0, 0] > 0
    assert zenith[3, 3] < 1e-12 * zenith[0, 0]  # 424 km away: beyond the kernel (FFT rounding)


# --- properties ----------------------------------------------------------------------


def test_map_is_linear_symmetric_and_peaks_under_the_light(kernel: xr.Dataset) -> None:
    flux = np.zeros((1, 31, 31))
    flux[0, 15, 15] = 2.0
    one = darkness(Scene(Raster(flux, TRANSFORM, CRS), kernel=kernel), progress=False)
    one = one.raster.data[0]
    double = darkness(Scene(Raster(2 * flux, TRANSFORM, CRS), kernel=kernel), progress=False)
    np.testing.assert_allclose(double.raster.data[0], 2 * one, rtol=1e-12)
    np.testing.assert_allclose(one, one[::-1, :], rtol=1e-9)
    np.testing.assert_allclose(one, one.T, rtol=1e-9)
    assert np.unravel_index(one.argmax(), one.shape) == (15, 15)
    assert np.all(one > 0)  # every cell within the 6 km kernel sees the light


def test_dark_emission_is_refused_not_reported_as_a_dark_sky(kernel: xr.Dataset) -> None:
    for values in (np.nan, 0.0):
        dark = Raster(np.full((1, 10, 10), values), TRANSFORM, CRS)
        with pytest.raises(InputError, match="no lit cell"):
            darkness(Scene(dark, kernel=kernel), progress=False)


def test_infinite_emission_is_refused_with_its_count(kernel: xr.Dataset) -> None:
    flux = emission().data.copy()
    flux[0, 1, 1] = flux[0, 2, 2] = np.inf
    with pytest.raises(InputError, match="2 non-finite"):
        darkness(Scene(Raster(flux, TRANSFORM, CRS), kernel=kernel), progress=False)


def test_grid_options_that_the_kernel_fixes_are_refused(kernel: xr.Dataset) -> None:
    with pytest.raises(InputError, match="n_azimuth=2: the kernel fixes the grid"):
        darkness(Scene(emission(), kernel=kernel, n_azimuth=2), progress=False)


# --- output ----------------------------------------------------------------------


def test_writes_a_two_band_cog_with_its_provenance(kernel: xr.Dataset, tmp_path: Path) -> None:
    out = tmp_path / "zenith.tif"
    result = darkness(Scene(emission(), kernel=kernel), out, height=1.7, progress=False)
    assert isinstance(result, DarknessResult) and result.path == out and result.seconds > 0
    written = Raster.read(out)
    assert written.descriptions == ("zenith_luminance", "zenith_sky_brightness")
    assert written.units == ("cd m-2", "mag arcsec-2")
    assert written.tags["kernel_hash"] == kernel.attrs["content_hash"]
    assert float(written.tags["observer_height_m"]) == 1.7
    assert "FFT convolution" in written.tags["method"]
    np.testing.assert_allclose(written.data[0], result.raster.data[0], rtol=1e-6)  # float32
    np.testing.assert_allclose(
        result.raster.data[1], luminance_to_magnitude(result.raster.data[0]), rtol=1e-12
    )


# --- errors ----------------------------------------------------------------------


def test_errors_are_one_line(kernel: xr.Dataset, tmp_path: Path) -> None:
    raster = emission(n=10)
    # (error, message, scene fields, stage options)
    cases = [
        (CRSError, "projected CRS", {"emission": Raster(raster.data, TRANSFORM, "EPSG:4326")}, {}),
        (InputError, "negative flux", {"emission": Raster(-raster.data, TRANSFORM, CRS)}, {}),
        (InputError, "3 bands", {"emission": Raster(np.ones((3, 5, 5)), TRANSFORM, CRS)}, {}),
        (InputError, "chunk size 0", {}, {"chunk_size": 0}),
        (InputError, "chunk size 2.5", {}, {"chunk_size": 2.5}),
        (InputError, "chunk size True", {}, {"chunk_size": True}),
        (InputError, "height=-1.0 m", {}, {"height": -1.0}),
        (OutputError, "does not exist", {}, {"output": tmp_path / "missing" / "z.tif"}),
        (InputError, "turbidity 5", {"turbidity": 5.0}, {}),
        (InputError, "covering the whole", {"dem": Raster(np.ones((5, 5)), TRANSFORM, CRS)}, {}),
        (CRSError, "DEM", {"dem": Raster(np.ones((10, 10)), TRANSFORM, "EPSG:3067")}, {}),
    ]
    for error, message, fields, options in cases:
        with pytest.raises(error, match=message) as info:
            darkness(
                Scene(**{"emission": raster, "kernel": kernel, **fields}), progress=False, **options
            )
        assert "\n" not in str(info.value)


def test_uplight_band_needs_an_uplight_kernel() -> None:
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    lambertian = build_kernel(spec, progress=False).kernel
    with pytest.raises(InputError, match="no uplight table"):
        darkness(Scene(emission(n=10, bands=2), kernel=lambertian), progress=False)


def test_eyes_outside_the_kernel_levels_warn(kernel: xr.Dataset) -> None:
    with pytest.warns(DataQualityWarning, match="outside the kernel's observer levels"):
        darkness(Scene(emission(n=10), kernel=kernel), height=30.0, progress=False)
