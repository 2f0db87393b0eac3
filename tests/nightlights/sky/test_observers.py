"""Many observers at once: each observer's figures equal the single-observer stages'."""

from __future__ import annotations

import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import xarray as xr
from affine import Affine
from distributed import Client, LocalCluster
from shapely.geometry import LineString, Point

from nightlights.errors import CRSError, DataQualityWarning, InputError, OutputExistsError
from nightlights.inverse import inverse_q
from nightlights.io import Raster, RasterBand, write_cog
from nightlights.nightsky.render import zenith_summary
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky import observers as module
from nightlights.sky.influence import cell_values
from nightlights.sky.observers import SUMMARY_FIELDS, SUMMARY_LAYER, observers
from nightlights.sky.polar import lit_polar_cells
from nightlights.sky.setup import prepare_scene

CRS = "EPSG:3067"
CELL = 100.0
T = Affine(CELL, 0, 10_000.0, 0, -CELL, 20_000.0)
#: Observers inside and around the town [m] (the last one 1 km outside the raster).
POINTS = np.array(
    [[11_010.0, 18_990.0], [10_530.0, 19_470.0], [11_955.0, 18_205.0], [13_000.0, 19_000.0]]
)


def town(bands: int = 2, n: int = 20, seed: int = 1) -> Raster:
    """A small lit town: clustered cells, Lambertian + 10 % uplight."""
    rng = np.random.default_rng(seed)
    flux = np.zeros((bands, n, n))
    lit = rng.random((n, n)) < 0.25
    flux[0][lit] = rng.gamma(2.0, 0.5, lit.sum())
    if bands == 2:
        flux[1] = 0.1 * flux[0]
    return Raster(flux, T, CRS)


def sites(
    points=POINTS, *, height: float = 0.0, crs: str | None = None, names=None
) -> list[Observer]:
    """One observer per (x, y) point [m] (in the emission's CRS unless ``crs`` is given)."""
    labels = [None] * len(points) if names is None else names
    return [Observer(x, y, crs, height, name) for (x, y), name in zip(points, labels, strict=True)]


def run(
    raster: Raster, kernel: xr.Dataset | None, people=None, *, dem=None, **options
) -> module.ObserversResult:
    """The stage on a scene of ``raster`` (with ``kernel`` and ``dem``), for ``people``
    (default: an observer at each of :data:`POINTS`, eyes on the ground)."""
    options.setdefault("scheduler", "synchronous")
    scene = Scene(raster, kernel=kernel, dem=dem)
    return observers(scene, sites() if people is None else people, progress=False, **options)


def test_every_observer_sees_what_skyglow_sees(small_kernel: xr.Dataset) -> None:
    raster = town()
    result = run(raster, small_kernel, top_cells=0)
    assert list(result.summary.columns[: len(SUMMARY_FIELDS)]) == list(SUMMARY_FIELDS)
    for row, xy in zip(result.summary.itertuples(), POINTS, strict=True):
        alone = skyglow(Scene(raster, kernel=small_kernel), Observer(*xy, height=0.0))
        luminance = alone.panorama["luminance"].values
        assert row.zenith_artificial == pytest.approx(alone.zenith_luminance, rel=1e-12)
        el, az = np.unravel_index(np.nanargmax(luminance), luminance.shape)
        assert row.brightest_luminance == pytest.approx(luminance[el, az], rel=1e-12)
        assert row.brightest_elevation == alone.panorama["elevation"].values[el]
        assert row.brightest_azimuth == alone.panorama["azimuth"].values[az]
        assert (row.geometry.x, row.geometry.y) == tuple(xy)


def test_natural_and_total_sky_as_the_skyglow_summary(small_kernel: xr.Dataset) -> None:
    summary = run(town(), small_kernel, top_cells=0).summary
    for row in summary.itertuples():
        expected = zenith_summary(row.zenith_artificial)
        assert row.zenith_natural == pytest.approx(expected["zenith_natural_cd_m2"], rel=1e-12)
        assert row.zenith_total == pytest.approx(row.zenith_artificial + row.zenith_natural)
        assert row.zenith_mag == pytest.approx(expected["zenith_sky_brightness"], rel=1e-12)
        assert row.bortle == expected["bortle_class_zenith"]


def test_top_cells_are_the_largest_zenith_parts_of_inverse_q(small_kernel: xr.Dataset) -> None:
    raster = town()
    summary = run(raster, small_kernel, top_cells=4).summary
    for row, xy in zip(summary.itertuples(), POINTS, strict=True):
        q = inverse_q(Scene(raster, kernel=small_kernel), Observer(*xy, height=0.0),
                      metric="zenith", progress=False).raster  # fmt: skip
        values = np.nan_to_num(q.data[0])
        order = np.argsort(-values, axis=None)[:4]
        rows, cols = np.unravel_index(order, values.shape)
        for i, (r, c) in enumerate(zip(rows, cols, strict=True), start=1):
            assert getattr(row, f"top{i}_x") == pytest.approx(T.c + CELL * (c + 0.5))
            assert getattr(row, f"top{i}_y") == pytest.approx(T.f - CELL * (r + 0.5))
            share = values[r, c] / values.sum()
            assert getattr(row, f"top{i}_share") == pytest.approx(share, rel=1e-9)
        # the cells' parts add up to the panorama's zenith
        assert values.sum() == pytest.approx(row.zenith_artificial, rel=1e-9)


def test_top_cells_do_not_change_the_sky(small_kernel: xr.Dataset) -> None:
    raster = town()
    with_cells = run(raster, small_kernel, top_cells=3).summary
    without = run(raster, small_kernel, top_cells=0).summary
    for field in ("zenith_artificial", "brightest_luminance"):
        np.testing.assert_array_equal(with_cells[field], without[field])
    assert "top1_x" not in without


@pytest.mark.parametrize("xy", [tuple(p) for p in POINTS] + [(10_050.0, 19_950.0)])
def test_every_cells_zenith_part_lies_within_its_bounds(small_kernel, xy) -> None:
    """Only cells whose upper bound reaches the n-th largest lower bound are summed exactly:
    the bounds must hold for every cell, near the observer (many sub-points) and far."""
    setup = prepare_scene(
        Scene(town(), kernel=small_kernel), Observer(*xy, height=0.0), progress=False
    )
    engine = module._engine(setup, False, 3, False)
    zenith = module._Levels(engine).zenith(list(engine.slices))
    cells = lit_polar_cells(engine.rows, engine.cols, engine.values, engine.transform, xy,
                            distance_edges=engine.edges, n_az=engine.n_az)  # fmt: skip
    exact = cell_values(cells, engine.level_weights, zenith.tables)
    lower, upper = zenith.bounds(engine, xy)
    tolerance = 1e-12 * exact.max()
    assert np.all(lower <= exact + tolerance) and np.all(exact <= upper + tolerance)
    # the bounds follow the zenith's own change over a cell's span (a sub-point's flux is
    # shared between two distance bins, linear in ln r): few cells are left to sum exactly
    assert np.median((upper - lower) / exact) < 0.3
    threshold = np.sort(lower)[-3]
    assert np.sum(upper >= threshold) < 0.2 * exact.size


def test_fewer_lit_cells_than_asked_leave_nan(small_kernel: xr.Dataset) -> None:
    flux = np.zeros((1, 20, 20))
    flux[0, 3, 4] = 2.0
    result = run(Raster(flux, T, CRS), small_kernel, sites(POINTS[:1]), top_cells=2)
    row = result.summary.iloc[0]
    assert row["top1_share"] == pytest.approx(1.0)
    assert np.isnan(row["top2_x"]) and np.isnan(row["top2_share"])


@pytest.mark.parametrize(
    "scheduler", ["threads", pytest.param("processes", marks=pytest.mark.slow)]
)
def test_local_schedulers_agree(small_kernel: xr.Dataset, scheduler: str) -> None:
    points = np.column_stack([np.linspace(10_100, 11_900, 9), np.linspace(18_100, 19_900, 9)])
    reference = run(town(), small_kernel, sites(points)).summary
    other = run(town(), small_kernel, sites(points), scheduler=scheduler, num_workers=2)
    numeric = reference.columns.drop(["name", "geometry"])
    np.testing.assert_allclose(other.summary[numeric], reference[numeric], rtol=1e-12)
    assert other.summary["name"].tolist() == reference["name"].tolist()


def test_local_cluster_equals_the_local_scheduler(small_kernel: xr.Dataset) -> None:
    reference = run(town(), small_kernel).summary
    numeric = reference.columns.drop(["name", "geometry"])
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,  # fmt: skip
        Client(cluster) as client,
    ):
        by_client = run(town(), small_kernel, scheduler=client).summary
        by_address = run(town(), small_kernel, scheduler=cluster.scheduler_address).summary
    np.testing.assert_allclose(by_client[numeric], reference[numeric], rtol=1e-12)
    np.testing.assert_allclose(by_address[numeric], reference[numeric], rtol=1e-12)


# --- terrain ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def two_eyes() -> xr.Dataset:
    """One band, sources at 100 m, eyes at 101.7 and 301.7 m (observers on a hill)."""
    spec = KernelSpec(r_min=5.0, r_max=5000.0, n_distance=8, n_elevation=8, n_azimuth=16,
                      observer_altitudes=(101.7, 301.7), source_altitudes=(100.0,))  # fmt: skip
    return build_kernel(spec, progress=False).kernel


def hill() -> Raster:
    """100 m plain with a 300 m hill in the north-east and a ridge to the west."""
    heights = np.full((20, 20), 100.0)
    heights[:6, 14:] = 300.0
    heights[:, 1] = 400.0
    return Raster(heights[None], T, CRS)


def test_observers_on_terrain_equal_skyglow_over_the_dem(two_eyes: xr.Dataset) -> None:
    flux = np.zeros((1, 20, 20))
    flux[0, 8:14, 6:12] = 1.0
    raster = Raster(flux, T, CRS)
    points = np.array([[10_950.0, 19_050.0], [11_750.0, 19_750.0], [10_350.0, 18_400.0]])
    result = run(raster, two_eyes, sites(points, height=1.7), dem=hill(), top_cells=0)
    eyes = result.summary["observer_altitude"].to_numpy()
    np.testing.assert_allclose(eyes[:2], [101.7, 301.7])
    for row, xy in zip(result.summary.itertuples(), points, strict=True):
        alone = skyglow(Scene(raster, kernel=two_eyes, dem=hill()), Observer(*xy, height=1.7))
        assert row.zenith_artificial == pytest.approx(alone.zenith_luminance, rel=1e-12)
        luminance = alone.panorama["luminance"].values
        assert row.brightest_luminance == pytest.approx(np.nanmax(luminance), rel=1e-12)


def test_the_scene_kernel_reaches_the_farthest_observer_at_every_eye(
    monkeypatch: pytest.MonkeyPatch, two_eyes: xr.Dataset
) -> None:
    import nightlights.sky.scene as scene_module

    specs = []

    def fake(spec, **_):
        specs.append(spec)
        return scene_module.KernelResult(two_eyes, spec, None)

    monkeypatch.setattr(scene_module, "get_or_build_kernel", fake)
    flux = np.zeros((1, 20, 20))
    flux[0, 8:14, 6:12] = 1.0
    points = np.array([[10_950.0, 19_050.0], [11_750.0, 19_750.0]])
    run(Raster(flux, T, CRS), None, sites(points, height=1.7), dem=hill())
    (spec,) = specs
    assert spec.observer_altitudes == pytest.approx((101.7, 301.7))
    lit = (10_600.0, 18_600.0, 11_200.0, 19_200.0)  # lit cells' bounds
    far = max(np.hypot(x - 11_750.0, y - 19_750.0) for x in lit[::2] for y in lit[1::2])
    assert spec.r_max == pytest.approx(1.01 * far)


def test_the_flat_scene_kernel_reaches_from_the_farthest_observer(
    monkeypatch: pytest.MonkeyPatch, small_kernel: xr.Dataset
) -> None:
    import nightlights.sky.scene as setup_module

    specs = []

    def fake(spec, **_):
        specs.append(spec)
        return setup_module.KernelResult(small_kernel, spec, None)

    monkeypatch.setattr(setup_module, "get_or_build_kernel", fake)
    raster = town()
    run(raster, None, sites(height=0.0))
    (spec,) = specs
    left, bottom, right, top = raster.lit_cells().lit_bounds()
    far = max(
        np.hypot(x - px, y - py) for px, py in POINTS for x in (left, right) for y in (bottom, top)
    )
    assert spec.r_max == pytest.approx(1.01 * far)
    assert spec.observer_altitudes == (0.0,)
    assert (spec.n_elevation, spec.n_azimuth, spec.n_distance) == (64, 256, 64)


def test_an_observer_off_the_dem_is_named(two_eyes: xr.Dataset) -> None:
    flux = np.zeros((1, 20, 20))
    flux[0, 8:14, 6:12] = 1.0
    with pytest.raises(InputError, match=r"observer .far away.*outside the DEM"):
        far = sites([[10_500, 19_000], [9_000, 19_000]], names=["here", "far away"])
        run(Raster(flux, T, CRS), two_eyes, far, dem=hill())


# --- inputs and outputs ------------------------------------------------------------------------


def test_a_point_layer_in_degrees_with_names(tmp_path: Path, small_kernel: xr.Dataset) -> None:
    layer = gpd.GeoDataFrame(
        {"name": ["a", "b"]}, geometry=[Point(p) for p in POINTS[:2]], crs=CRS
    ).to_crs("EPSG:4326")
    path = tmp_path / "observers.gpkg"
    layer.to_file(path, layer="places")
    for source in (layer, path):
        summary = run(town(), small_kernel, Observer.from_layer(source, height=0.0)).summary
        assert summary["name"].tolist() == ["a", "b"]
        assert summary.crs.equals(CRS)
        np.testing.assert_allclose(
            np.column_stack([summary.geometry.x, summary.geometry.y]), POINTS[:2], atol=1e-6
        )
    lonlat = layer.geometry.get_coordinates().to_numpy()
    by_array = run(town(), small_kernel, sites(lonlat, crs="EPSG:4326")).summary
    assert by_array["name"].tolist() == ["observer_1", "observer_2"]
    np.testing.assert_allclose(by_array["zenith_artificial"], summary["zenith_artificial"])


def _layer(points) -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(geometry=[Point(p) for p in points], crs=CRS)


@pytest.mark.parametrize(
    ("people", "options", "error", "message"),
    [
        (lambda: [(1.0, 2.0)], {}, InputError, "expected Observer objects"),
        (lambda: [], {}, InputError, "no observer"),
        (lambda: sites([[np.nan, 1.0]]), {}, InputError, "expected two finite numbers"),
        (lambda: sites(names=["a", "b", "c", "a"]), {}, InputError, "same name 'a'"),
        (lambda: sites(names=["a/b", "a b", "c", "d"]), {}, InputError, "same file name"),
        (
            lambda: Observer.from_layer(_layer(POINTS), names=["a"]),
            {},
            InputError,
            "1 names for 4 observers",
        ),
        (sites, {"scheduler": "fast"}, InputError, "scheduler='fast'; expected one of threads"),
        (sites, {"scheduler": "tcp://127.0.0.1"}, InputError, "no port"),
        (sites, {"top_cells": -1}, InputError, "top_cells=-1"),
        (lambda: sites(height=-2.0), {}, InputError, "observer height -2.0"),
        (
            lambda: sites([[99_000.0, 19_000.0]]),
            {},
            InputError,
            "observer 'observer_1'.*outside",
        ),
        (lambda: sites(crs="EPSG:999999"), {}, CRSError, "is not a CRS"),
    ],
)
def test_bad_inputs_are_one_line_errors(small_kernel, people, options, error, message) -> None:
    with pytest.raises(error, match=message):
        run(town(), small_kernel, people(), **options)


def test_top_cells_up_to_the_geopackage_column_limit(small_kernel, tmp_path) -> None:
    """The summary layer holds MAX_TOP_CELLS top cells (panoramas named too); one more is
    refused before any work, naming the largest allowed value."""
    assert module.MAX_TOP_CELLS == 662
    with pytest.raises(InputError, match=r"top_cells=663: .* at most 662 top cells"):
        run(town(), small_kernel, output=tmp_path / "refused.gpkg", top_cells=663)
    assert not (tmp_path / "refused.gpkg").exists()
    (tmp_path / "panoramas").mkdir()
    out = tmp_path / "s.gpkg"
    run(town(), small_kernel, output=out, top_cells=662, panoramas=tmp_path / "panoramas")
    written = gpd.read_file(out, layer="observers")
    assert "top662_share" in written and "panorama" in written
    # without a file the summary is not limited
    assert "top700_x" in run(town(), small_kernel, top_cells=700).summary


def test_layers_that_are_not_usable_points(small_kernel: xr.Dataset) -> None:
    lines = gpd.GeoDataFrame(geometry=[LineString([(0, 0), (1, 1)])], crs=CRS)
    with pytest.raises(InputError, match="feature 0 is a LineString; expected points"):
        run(town(), small_kernel, lines)
    bare = gpd.GeoDataFrame(geometry=[Point(POINTS[0])])
    with pytest.raises(CRSError, match="no CRS; give crs"):
        run(town(), small_kernel, bare)
    placed_bare = Observer.from_layer(bare, crs=CRS, height=0.0)
    assert len(run(town(), small_kernel, placed_bare).summary) == 1
    placed = bare.set_crs(CRS)
    with pytest.raises(InputError, match="give crs only for a layer without a CRS"):
        run(town(), small_kernel, Observer.from_layer(placed, crs="EPSG:4326", height=0.0))


def test_summary_geopackage_and_panoramas(tmp_path: Path, small_kernel: xr.Dataset) -> None:
    src = tmp_path / "emission.tif"
    write_cog(src, [RasterBand(town(bands=1).data[0].astype(np.float32), "flux", "lm m-2")],
              transform=T, crs=CRS)  # fmt: skip
    out, folder = tmp_path / "summary.gpkg", tmp_path / "skies"
    folder.mkdir()
    names = ["Esplanadi park", "b", "c", "d"]
    result = run(src, small_kernel, sites(names=names), output=out, panoramas=folder, top_cells=2)
    assert result.path == out
    assert SUMMARY_LAYER in pyogrio.list_layers(out)[:, 0].tolist()
    styles = pyogrio.read_dataframe(out, layer="layer_styles")
    assert styles["f_table_name"].tolist() == [SUMMARY_LAYER]
    assert 'attr="zenith_mag"' in styles["styleQML"].iloc[0]
    info = pyogrio.read_info(out, layer=SUMMARY_LAYER)
    types = dict(zip(info["fields"], info["dtypes"], strict=True))
    assert types["bortle"] == "int64" and types["name"] == "object"
    assert types["zenith_mag"] == types["top2_share"] == "float64"
    written = gpd.read_file(out, layer=SUMMARY_LAYER)
    np.testing.assert_allclose(written["zenith_total"], result.summary["zenith_total"])
    assert sorted(result.panoramas) == sorted(names)
    assert result.panoramas["Esplanadi park"] == folder / "Esplanadi_park.nc"
    assert written["panorama"].tolist()[0] == "Esplanadi_park.nc"
    alone = skyglow(Scene(src, kernel=small_kernel), Observer(*POINTS[0], height=0.0))
    with xr.open_dataset(result.panoramas["Esplanadi park"], engine="h5netcdf") as pano:
        np.testing.assert_allclose(
            pano["luminance"].values, alone.panorama["luminance"].values, rtol=1e-12
        )
        for key in ("zenith_luminance_cd_m2", "zenith_natural_cd_m2", "bortle_class_zenith"):
            assert pano.attrs[key] == pytest.approx(alone.panorama.attrs[key])
        assert pano.attrs["observer_x"] == POINTS[0][0]
    with pytest.raises(OutputExistsError, match="exists; give overwrite"):
        run(src, small_kernel, output=out)
    again = run(src, small_kernel, output=out, overwrite=True, top_cells=0)
    assert "top1_x" not in gpd.read_file(out, layer=SUMMARY_LAYER)
    assert again.panoramas == {}


def test_a_missing_panorama_folder_fails_before_any_work(tmp_path: Path, small_kernel) -> None:
    with pytest.raises(InputError, match=r"panorama folder .* does not exist"):
        run(town(), small_kernel, output=tmp_path / "s.gpkg", panoramas=tmp_path / "none")
    assert not (tmp_path / "s.gpkg").exists()


def test_an_observer_beyond_some_cells_still_counts_the_rest(small_kernel) -> None:
    """Cells beyond the kernel's reach are left out with the stage's warning; the others
    light the sky."""
    flux = np.zeros((1, 20, 20))
    flux[0, 0, 0] = flux[0, 19, 19] = 1.0
    raster = Raster(flux, Affine(1500.0, 0, 0, 0, -1500.0, 30_000.0), CRS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        summary = run(raster, small_kernel, sites([[750.0, 29_250.0]])).summary
    assert summary["zenith_artificial"].iloc[0] > 0
    assert summary["top1_share"].iloc[0] == pytest.approx(1.0)
