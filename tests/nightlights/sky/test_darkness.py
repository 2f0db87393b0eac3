"""The zenith darkness map: equal to the forward panorama's zenith at every cell (flat terrain
and terrain, same kernel), chunked and distributed runs equal to one FFT, scene kernels, output
and one-line errors; in an instrument's units, equal to the panorama read with its angular
weights."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from distributed import Client, LocalCluster

from nightlights.brightness import NATURAL_ZENITH_LUMINANCE, luminance_to_magnitude
from nightlights.errors import CRSError, DataQualityWarning, InputError, OutputError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
from nightlights.sky.darkness import DarknessResult, _Stencil, darkness, zenith_per_lumen
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.instrument_units import DEFAULT_SPECTRUM
from nightlights.sky.instruments import angular_weights, elevation_weights, instrument_luminance
from nightlights.sky.observer import OBSERVER_HEIGHT
from nightlights.sky.panorama import kernel_slice
from nightlights.sky.polar import _nearest_bin, distance_shares
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
    # the exact path: per-level bases by energy (0.999999), whose DC term is the tables'
    spec = KernelSpec.exact(
        r_max=6000.0,
        n_distance=16,
        n_elevation=8,
        n_azimuth=32,
        uplight=True,
        observer_altitudes=(0.0, 10.0),
    )
    return build_kernel(spec, progress=False).kernel


@pytest.fixture(scope="module")
def fine_kernel() -> xr.Dataset:
    """As ``kernel`` with 24 rows of 3.75 deg: fine enough for the lensed instruments' 17-20
    deg responses (the kernel's rows are coarser than half their FWHM otherwise)."""
    spec = KernelSpec(
        r_max=6000.0,
        n_distance=16,
        n_elevation=24,
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


# --- in instrument units ------------------------------------------------------------------------


def instrument_reading(
    scene: Scene, cell: tuple[int, int], instrument: str, *, height: float, mode: str = "exact"
) -> float:
    """The panorama of an observer at a cell centre read with the instrument's angular weights
    (hidden pixels: no artificial light) [cd m-2], before the colour term."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        sky = skyglow_panorama(
            scene, Observer(*centre(*cell), height=height), mode=mode, progress=False
        )
    panorama = sky.panorama
    weights = angular_weights(instrument, panorama["elevation"].values, panorama["azimuth"].values)
    return float(np.sum(weights * np.nan_to_num(panorama["luminance"].values)))


def test_without_weights_the_zenith_table_is_the_top_row_bit_for_bit(kernel: xr.Dataset) -> None:
    tables = kernel_slice(kernel, observer_altitude=0.0)
    np.testing.assert_array_equal(zenith_per_lumen(tables), tables.kernel[:, :, 0, :].mean(-1))
    top = np.zeros(tables.elevation.size)
    top[0] = 1.0  # the kernel's rows descend: the first is the zenith's
    assert tables.elevation[0] == tables.elevation.max()
    np.testing.assert_allclose(zenith_per_lumen(tables, top), zenith_per_lumen(tables), rtol=1e-15)


def test_weighted_tables_and_their_pca_form_agree(kernel: xr.Dataset) -> None:
    tables = kernel_slice(kernel, observer_altitude=0.0)
    weights = elevation_weights("sqm", tables.elevation)
    from_tables = zenith_per_lumen(tables, weights)
    expected = np.einsum("brea,e->br", tables.kernel, weights) / tables.n_az
    np.testing.assert_allclose(from_tables, expected, rtol=1e-12)
    without = type(tables)(
        tables.kernel[..., :0],
        tables.coefficient,
        tables.basis_fft,
        tables.distance_edges,
        tables.elevation,
    )
    # pca_energy 0.999999 of the whole table: the weighted rows are within a few 1e-3
    np.testing.assert_allclose(zenith_per_lumen(without, weights), from_tables, rtol=5e-3)
    with pytest.raises(InputError, match="expected 8 finite weights"):
        zenith_per_lumen(tables, weights[:-1])


@pytest.mark.parametrize(
    ("instrument", "observer_height"), [("sqm", 0.0), ("sqm", 6.0), ("tess-w", 1.7)]
)
def test_flat_map_equals_the_panorama_read_with_the_angular_weights(
    fine_kernel: xr.Dataset, instrument: str, observer_height: float
) -> None:
    """Exact: the panorama's rows are the kernel's, the instrument pointing at the zenith
    weighs every column of a row alike, and the colour term is one factor."""
    scene = Scene(emission(bands=2), kernel=fine_kernel)
    result = darkness(scene, height=observer_height, instrument=instrument, progress=False)
    assert result.instrument == instrument
    assert result.raster.descriptions == ("instrument_luminance", "instrument_sky_brightness")
    factor = float(instrument_luminance(1.0, instrument, DEFAULT_SPECTRUM))
    for cell in CELLS:
        expected = factor * instrument_reading(scene, cell, instrument, height=observer_height)
        assert result.raster.data[0][cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL), cell


def test_pca_only_map_equals_the_pca_panorama_read_with_the_angular_weights() -> None:
    spec = KernelSpec(r_max=6000.0, n_distance=16, n_elevation=8, n_azimuth=32, store_tables=False)
    scene = Scene(emission(n=30), kernel=build_kernel(spec, progress=False).kernel)
    result = darkness(scene, height=0.0, instrument="sqm", progress=False)
    factor = float(instrument_luminance(1.0, "sqm", DEFAULT_SPECTRUM))
    for cell in [(11, 21), (0, 0), (29, 29)]:
        expected = factor * instrument_reading(scene, cell, "sqm", height=0.0, mode="pca")
        assert result.raster.data[0][cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL)


def test_terrain_map_equals_per_cell_panoramas_read_with_the_angular_weights(
    terrain_kernel: xr.Dataset,
) -> None:
    """Over terrain as on flat ground; the hills stay below the panorama's lowest row (5.6 deg),
    so no pixel is hidden that the map would count."""
    raster, dem = emission(), hills()
    scene = Scene(raster, kernel=terrain_kernel, dem=dem)
    result = darkness(scene, instrument="sqm", progress=False)
    factor = float(instrument_luminance(1.0, "sqm", DEFAULT_SPECTRUM))
    for cell in CELLS:
        expected = factor * instrument_reading(scene, cell, "sqm", height=OBSERVER_HEIGHT)
        assert result.raster.data[0][cell] == pytest.approx(expected, rel=SAME_KERNEL_RTOL), cell


def test_a_narrow_instrument_reads_nearly_the_zenith(fine_kernel: xr.Dataset) -> None:
    """The SQM-L's 20 deg response reads within a few % of the zenith luminance (before its
    colour term); the wide SQM takes in the brighter sky towards the lights and the horizon."""
    scene = Scene(emission(), kernel=fine_kernel)
    zenith = darkness(scene, progress=False).raster.data[0]
    narrow = darkness(scene, instrument="sqm-l", progress=False).raster.data[0]
    wide = darkness(scene, instrument="sqm", progress=False).raster.data[0]
    narrow = narrow / float(instrument_luminance(1.0, "sqm-l", DEFAULT_SPECTRUM))
    wide = wide / float(instrument_luminance(1.0, "sqm", DEFAULT_SPECTRUM))
    np.testing.assert_allclose(narrow, zenith, rtol=0.1)
    assert np.median(wide / zenith) > np.median(narrow / zenith)


def test_the_brightness_band_adds_the_natural_sky_in_the_instruments_band(
    kernel: xr.Dataset, tmp_path: Path
) -> None:
    scene = Scene(emission(), kernel=kernel)
    result = darkness(scene, tmp_path / "sqm.tif", instrument="sqm", progress=False)
    natural = float(instrument_luminance(NATURAL_ZENITH_LUMINANCE, "sqm", "natural_sky"))
    reading, magnitude = result.raster.data
    np.testing.assert_allclose(magnitude, luminance_to_magnitude(reading + natural), rtol=1e-12)
    assert np.all(np.isfinite(magnitude)) and magnitude.max() <= float(
        luminance_to_magnitude(natural)
    )
    written = Raster.read(tmp_path / "sqm.tif")
    assert written.descriptions == ("instrument_luminance", "instrument_sky_brightness")
    assert written.units == ("cd m-2", "mag arcsec-2")
    tags = written.tags
    assert (tags["instrument"], tags["instrument_spectrum"]) == ("sqm", DEFAULT_SPECTRUM)
    assert tags["instrument_spectrum_source"] == "default"
    assert float(tags["instrument_natural_cd_m2"]) == pytest.approx(natural, rel=1e-12)
    assert "uniform" in tags["instrument_natural_source"]
    given = darkness(scene, instrument="sqm", natural_luminance=2e-4, progress=False)
    np.testing.assert_allclose(given.raster.data[0], reading, rtol=1e-15)
    np.testing.assert_allclose(
        given.raster.data[1], luminance_to_magnitude(reading + 2e-4), rtol=1e-12
    )


def test_the_spectrum_is_given_else_the_emissions_tag_else_the_default(kernel: xr.Dataset) -> None:
    raster = emission()
    tagged = Raster(raster.data, TRANSFORM, CRS, raster.descriptions, tags={"spectrum": "HPS"})
    plain = darkness(Scene(raster, kernel=kernel), instrument="sqm", progress=False)
    by_tag = darkness(Scene(tagged, kernel=kernel), instrument="sqm", progress=False)
    given = darkness(
        Scene(tagged, kernel=kernel), instrument="sqm", spectrum="LED_3000K", progress=False
    )
    for result, spectrum, source in [
        (plain, DEFAULT_SPECTRUM, "default"),
        (by_tag, "HPS", "emission tag"),
        (given, "LED_3000K", "spectrum="),
    ]:
        assert result.raster.tags["instrument_spectrum"] == spectrum
        assert result.raster.tags["instrument_spectrum_source"] == source
        ratio = float(instrument_luminance(1.0, "sqm", spectrum)) / float(
            instrument_luminance(1.0, "sqm", DEFAULT_SPECTRUM)
        )
        np.testing.assert_allclose(result.raster.data[0], ratio * plain.raster.data[0], rtol=1e-12)


def test_instrument_errors_are_one_line_and_come_before_the_kernel(
    kernel: xr.Dataset, tmp_path: Path
) -> None:
    raster = emission(n=10)
    wrong_tag = Raster(raster.data, TRANSFORM, CRS, tags={"spectrum": "sodium"})
    cases = [
        ({}, {"instrument": "sqm-xl"}, "instrument='sqm-xl'; expected one of sqm"),
        ({}, {"instrument": "sqm", "spectrum": "LED"}, "spectrum='LED': not a known spectrum"),
        ({"emission": wrong_tag}, {"instrument": "sqm"}, "spectrum tag 'sodium'.*spectrum="),
        ({}, {"instrument": "sqm", "natural_luminance": -1.0}, "natural_luminance=-1.0"),
        ({}, {"instrument": "sqm", "natural_luminance": np.nan}, "natural_luminance=nan"),
    ]
    for fields, options, message in cases:
        # no kernel given and none cached: a refusal before the kernel is built
        scene = Scene(**{"emission": raster, "cache_dir": tmp_path, **fields})
        with pytest.raises(InputError, match=message) as info:
            darkness(scene, progress=False, **options)
        assert "\n" not in str(info.value)
    assert not list(tmp_path.glob("kernel-*.nc"))
    # without an instrument the spectrum and the natural sky are not read
    plain = darkness(Scene(wrong_tag, kernel=kernel), progress=False)
    assert plain.instrument is None and "instrument" not in plain.raster.tags


# --- the stencil shares a sub-point between two distance bins, as the polar map does --------


def test_a_lone_sources_zenith_is_smooth_along_the_map() -> None:
    """One lit 100 m cell: the map 3-7 km from it follows a smooth curve in ln r (the stencil
    shares each offset between two distance bins); the former one-bin stencil saws."""
    spec = KernelSpec(r_min=10.0, r_max=30_000.0, n_distance=32, n_elevation=4, n_azimuth=8)
    table = build_kernel(spec, progress=False).kernel
    flux = np.zeros((1, 3, 75))
    flux[0, 1, 0] = 1.0
    zenith = darkness(Scene(Raster(flux, TRANSFORM, CRS), kernel=table), height=0.0, progress=False)
    along = zenith.raster.data[0, 1, 30:71]  # 3-7 km east of the lit cell
    tables = kernel_slice(table, observer_altitude=0.0)
    one_bin = _Stencil(CELL, tables.distance_edges, tables.n_az, (1, 74), bins=_nearest_bin)
    sawing = one_bin.weights(zenith_per_lumen(tables)[0])[1, 74 + 30 : 74 + 71]
    distance = np.arange(30, 71) * CELL

    def deviation(luminance: np.ndarray) -> float:
        x = np.log(distance)
        fit = np.exp(np.polyval(np.polyfit(x, np.log(luminance), 3), x))
        return float(np.max(np.abs(luminance / fit - 1.0)))

    assert deviation(along) < 0.03 < deviation(sawing)


def test_the_stencil_shares_as_the_polar_map() -> None:
    """Offsets of one sub-point: the lower bin and the upper bin's weight of distance_shares."""
    edges = np.geomspace(10.0, 5000.0, 9)
    stencil = _Stencil(CELL, edges, 8, (30, 30))
    r = np.hypot(*np.meshgrid(np.arange(-30, 31) * CELL, np.arange(-30, 31) * CELL))
    lower, weight = distance_shares(r, edges)
    far = np.ones(r.shape, bool)
    far.flat[stencil.near] = False
    np.testing.assert_array_equal(stencil.bins[far], lower[far])
    inside = far & (lower < edges.size - 1)
    np.testing.assert_allclose(stencil.frac[inside], 1.0 - weight[inside], atol=1e-15)
    assert np.all(stencil.frac[far & ~inside] == 0.0)
    np.testing.assert_allclose(stencil.share.sum(axis=1)[stencil.share.sum(axis=1) > 0], 1.0)
