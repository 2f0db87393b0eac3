"""Scene and Observer: the objects every sky stage takes, their constructors and checks, the
flat keywords they replace (still accepted with a DeprecationWarning, same numbers), and the
scene a product records and the stages that read it back rebuild."""

from __future__ import annotations

import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import xarray as xr
from affine import Affine
from shapely.geometry import LineString, Point

import nightlights as nl
from nightlights.errors import CRSError, InputError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
from nightlights.sky.setup import prepare_scene

CRS = "EPSG:32635"
GRID = {"n_elevation": 8, "n_azimuth": 16, "n_distance": 8}


@pytest.fixture(scope="module")
def raster() -> Raster:
    flux = np.zeros((1, 20, 20))
    flux[0, 5, 15] = flux[0, 12, 3] = flux[0, 9, 11] = 1.0  # [lm m-2]
    return Raster(flux, Affine(100, 0, 0, 0, -100, 2000), CRS)


@pytest.fixture(scope="module")
def kernel() -> nl.KernelResult:
    return build_kernel(KernelSpec(r_max=3000.0, **GRID), progress=False)


# --- Observer -------------------------------------------------------------------------------


def test_an_observer_from_lonlat_is_placed_in_any_crs() -> None:
    site = Observer.from_lonlat(24.95, 60.17, height=2.0, name="Helsinki")
    x, y = site.position(CRS)
    assert 380_000 < x < 390_000 and 6_670_000 < y < 6_680_000
    assert site.lonlat() == (24.95, 60.17) and site.height == 2.0 and site.name == "Helsinki"
    # and back: the observer in metres gives the same longitude and latitude
    again = Observer(x, y, CRS).lonlat()
    np.testing.assert_allclose(again, (24.95, 60.17), atol=1e-9)


def test_an_observer_without_crs_is_in_the_scene_crs() -> None:
    assert Observer(1000.0, 2000.0).position("EPSG:32635") == (1000.0, 2000.0)
    with pytest.raises(CRSError, match="has no CRS"):
        Observer(1000.0, 2000.0).lonlat()


def test_observers_from_points_and_layers() -> None:
    assert Observer.from_point(Point(3.0, 4.0), CRS) == Observer(3.0, 4.0, CRS)
    assert Observer.from_point((3.0, 4.0)).crs is None
    layer = gpd.GeoDataFrame(
        {"name": ["a", "b"]}, geometry=[Point(10.0, 20.0), Point(30.0, 40.0)], crs=CRS
    )
    sites = Observer.from_layer(layer, height=0.5)
    assert [(s.name, s.x, s.y, s.height) for s in sites] == [
        ("a", 10.0, 20.0, 0.5),
        ("b", 30.0, 40.0, 0.5),
    ]
    assert sites[0].crs is not None and sites[0].crs.to_epsg() == 32635
    renamed = Observer.from_layer(layer, names=["x", "y"])
    assert [s.name for s in renamed] == ["x", "y"]


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (lambda: Observer(np.nan, 1.0), InputError, "expected two finite numbers"),
        (lambda: Observer("a", 1.0), InputError, "expected two finite numbers"),
        (lambda: Observer(1.0, 1.0, height=-1.0), InputError, "observer height -1.0 m"),
        (lambda: Observer(1.0, 1.0, height=np.inf), InputError, "observer height inf m"),
        (lambda: Observer(1.0, 1.0, "EPSG:999999"), CRSError, "is not a CRS"),
        (lambda: Observer.from_lonlat(24.0, 95.0), InputError, "latitude within"),
        (lambda: Observer.from_point(LineString([(0, 0), (1, 1)])), InputError, "a point"),
        (lambda: Observer.from_point("here"), InputError, "expected a point"),
        (
            lambda: Observer.from_layer(gpd.GeoDataFrame(geometry=[Point(0, 0)])),
            CRSError,
            "has no CRS; give crs",
        ),
        (
            lambda: Observer.from_layer(
                gpd.GeoDataFrame(geometry=[LineString([(0, 0), (1, 1)])], crs=CRS)
            ),
            InputError,
            "feature 0 is a LineString; expected points",
        ),
        (
            lambda: Observer.from_layer(
                gpd.GeoDataFrame(geometry=[Point(0, 0)], crs=CRS), crs="EPSG:4326"
            ),
            InputError,
            "give crs only for a layer without a CRS",
        ),
        (lambda: Observer.from_layer([(0, 0)]), InputError, "expected a GeoDataFrame"),
    ],
)
def test_bad_observers_are_one_line_errors(make, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        make()


# --- Scene ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"emission": None}, "emission=None"),
        ({"turbidity": -1.0}, "turbidity=-1.0"),
        ({"turbidity": "thick"}, "turbidity='thick'"),
        ({"n_azimuth": 0}, "n_azimuth=0; expected an integer >= 1"),
        ({"n_elevation": 2.5}, "n_elevation=2.5"),
        ({"n_distance": True}, "n_distance=True"),
    ],
)
def test_bad_scenes_are_one_line_errors(raster: Raster, fields: dict, match: str) -> None:
    arguments = {"emission": raster} | fields
    with pytest.raises(InputError, match=match):
        Scene(**arguments)


def test_a_given_kernel_is_loaded_once_and_shared_by_copies(
    raster: Raster, kernel: nl.KernelResult, tmp_path: Path
) -> None:
    from nightlights.sky.store import write_kernel

    path = write_kernel(kernel.kernel, tmp_path / "kernel.nc")
    scene = Scene(raster, kernel=path)
    table = scene.kernel_dataset()
    assert table is not None and scene.kernel_dataset() is table
    assert scene.replace(turbidity=2.0).kernel_dataset() is table
    assert scene.replace(kernel=kernel).kernel_dataset() is not table


def test_a_kernel_with_another_turbidity_is_refused(
    raster: Raster, kernel: nl.KernelResult
) -> None:
    with pytest.raises(InputError, match=r"turbidity 3.0 differs from the kernel's \(2.0\)"):
        prepare_scene(Scene(raster, kernel=kernel, turbidity=3.0), Observer(1000.0, 1000.0))


# --- the flat keywords: same numbers, a DeprecationWarning ------------------------------------


def test_flat_keywords_give_the_same_panorama_with_a_deprecation_warning(
    raster: Raster, kernel: nl.KernelResult
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = nl.skyglow(Scene(raster, kernel=kernel), Observer(1000.0, 1000.0, height=0.0))
    with pytest.warns(DeprecationWarning, match=r"skyglow\(nightlights.Scene"):
        old = nl.skyglow(raster, observer=(1000.0, 1000.0), observer_height=0.0, kernel=kernel)
    np.testing.assert_array_equal(new.panorama["luminance"], old.panorama["luminance"])


def test_flat_keywords_of_every_sky_stage_still_work(
    raster: Raster, kernel: nl.KernelResult
) -> None:
    scene = Scene(raster, kernel=kernel)
    site = Observer(1000.0, 1000.0)
    calls = [
        (
            lambda: nl.inverse_q(scene, site, metric="zenith"),
            lambda: nl.inverse_q(raster, observer=(1000.0, 1000.0), kernel=kernel, metric="zenith"),
        ),
        (
            lambda: nl.inverse_s(scene, site, region="zenith:30"),
            lambda: nl.inverse_s(
                raster, observer=(1000.0, 1000.0), kernel=kernel, region="zenith:30"
            ),
        ),
        (
            lambda: nl.darkness(scene, progress=False),
            lambda: nl.darkness(raster, kernel=kernel, observer_height=1.7, progress=False),
        ),
    ]
    for new, old in calls:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            expected = new()
        with pytest.warns(DeprecationWarning, match="deprecated"):
            got = old()
        np.testing.assert_array_equal(got.raster.data, expected.raster.data)
    plan = nl.least_dimming(scene, [site], target_zenith=23.0)
    with pytest.warns(DeprecationWarning):
        flat = nl.least_dimming(
            raster, observers=[(1000.0, 1000.0)], kernel=kernel, target_zenith=23.0
        )
    np.testing.assert_array_equal(plan.dimming.data, flat.dimming.data)
    summary = nl.observers(scene, [site, Observer(500.0, 500.0)], progress=False).summary
    with pytest.warns(DeprecationWarning):
        old = nl.observers(
            raster, observers=[[1000.0, 1000.0], [500.0, 500.0]], kernel=kernel, progress=False
        ).summary
    np.testing.assert_array_equal(summary["zenith_artificial"], old["zenith_artificial"])


def test_flat_panorama_positional_dem_and_observer_crs(
    raster: Raster, kernel: nl.KernelResult
) -> None:
    """skyglow_panorama's former positional (emission, observer, kernel, dem), with the
    observer's CRS and height as keywords."""
    from nightlights.sky import skyglow_panorama

    ground = Raster(np.zeros((1, 20, 20)), raster.transform, CRS)
    scene = Scene(raster, kernel=kernel, dem=ground)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = skyglow_panorama(scene, Observer(1000.0, 1000.0, CRS, height=0.0), progress=False)
    with pytest.warns(DeprecationWarning, match=r"skyglow_panorama\(emission"):
        old = skyglow_panorama(
            raster, (1000.0, 1000.0), kernel, ground, observer_crs=CRS, observer_height=0.0,
            progress=False,
        )  # fmt: skip
    np.testing.assert_array_equal(new.panorama["luminance"], old.panorama["luminance"])
    np.testing.assert_array_equal(new.panorama["terrain_mask"], old.panorama["terrain_mask"])


def test_flat_dimming_rule_and_explore_session(raster: Raster, kernel: nl.KernelResult) -> None:
    """inverse_reduce(emission, kernel=, ...) and ExploreSession(emission, kernel=,
    observer_height=) as the inverse and explore tests called them."""
    from nightlights.explore import ExploreSession

    scene = Scene(raster, kernel=kernel)
    q = nl.inverse_q(scene, Observer(1000.0, 1000.0), metric="zenith", progress=False).raster
    rule = {"by": q, "qa": float(np.nanmin(q.data)), "qb": float(np.nanmax(q.data))}
    new = nl.inverse_reduce(scene, gamma=0.5, progress=False, **rule)
    with pytest.warns(DeprecationWarning, match=r"inverse_reduce\(emission"):
        old = nl.inverse_reduce(raster, kernel=kernel, gamma=0.5, progress=False, **rule)
    np.testing.assert_array_equal(new.dimming.data, old.dimming.data)
    assert new.summary["observers"] == old.summary["observers"]
    session = ExploreSession(scene, height=0.0, progress=False)
    with pytest.warns(DeprecationWarning, match=r"ExploreSession\(emission"):
        flat = ExploreSession(raster, kernel=kernel, observer_height=0.0, progress=False)
    assert flat.observer_height == 0.0
    np.testing.assert_array_equal(
        flat.panorama(1000.0, 1000.0).luminance, session.panorama(1000.0, 1000.0).luminance
    )


def test_flat_sky_render_output_first_and_lonlat(tmp_path: Path) -> None:
    """sky_render(output, time=, lonlat=): the former call, output first."""
    picture = {"time": "2026-01-25T20:00:00Z", "natural_only": True, "width": 64, "height": 32}
    new = nl.sky_render(Observer.from_lonlat(24.95, 60.17), tmp_path / "new.png", **picture)
    with pytest.warns(DeprecationWarning, match=r"sky_render\(output"):
        old = nl.sky_render(tmp_path / "old.png", lonlat=(24.95, 60.17), **picture)
    assert old.lonlat == new.lonlat == (24.95, 60.17)
    assert old.image.summary == new.image.summary
    assert (tmp_path / "old.png").stat().st_size > 0


def test_flat_observers_as_arrays_names_and_layers(
    raster: Raster, kernel: nl.KernelResult, tmp_path: Path
) -> None:
    """observers(emission, observers=(n, 2) array or layer, observer_crs=, observers_layer=,
    names=): the same observers as Observer objects."""
    sites = [Observer(1000.0, 1000.0, name="a"), Observer(500.0, 500.0, name="b")]
    new = nl.observers(Scene(raster, kernel=kernel), sites, progress=False).summary
    lonlat = np.array([site.lonlat(CRS) for site in sites])
    layer = gpd.GeoDataFrame(
        {"name": ["a", "b"]}, geometry=[Point(s.x, s.y) for s in sites], crs=CRS
    )
    layer.to_file(tmp_path / "sites.gpkg", layer="places")
    flat_calls = [
        {"observers": lonlat, "observer_crs": "EPSG:4326", "names": ["a", "b"]},
        {"observers": tmp_path / "sites.gpkg", "observers_layer": "places"},
    ]
    for flat in flat_calls:
        with pytest.warns(DeprecationWarning, match=r"observers\(emission"):
            old = nl.observers(raster, kernel=kernel, progress=False, **flat).summary
        assert old["name"].tolist() == ["a", "b"]
        np.testing.assert_allclose(old["zenith_artificial"], new["zenith_artificial"], rtol=1e-6)


@pytest.mark.parametrize(
    ("flat", "error", "match"),
    [
        ({"observers": [[1.0, 2.0, 3.0]]}, InputError, r"expected \(n, 2\)"),
        ({"observers": [[np.nan, 1.0]]}, InputError, "observer 0: .*two finite numbers"),
        ({"observers": [[1.0, 2.0]], "names": ["a", "b"]}, InputError, "2 names for 1 obs"),
        ({"observers": [[1.0, 2.0]], "observers_layer": "x"}, InputError, "names a layer"),
        ({"observers": [[1.0, 2.0]], "observer_height": -2.0}, InputError, "height -2.0"),
        ({"observers": [[1.0, 2.0]], "observer_crs": "EPSG:999999"}, CRSError, "not a CRS"),
        (
            {
                "observers": gpd.GeoDataFrame(geometry=[Point(1.0, 2.0)], crs=CRS),
                "observer_crs": "EPSG:4326",
            },
            InputError,
            "give crs only for a layer without a CRS",
        ),
    ],
)
def test_flat_observers_are_checked_as_before(
    raster: Raster, kernel: nl.KernelResult, flat: dict, error: type, match: str
) -> None:
    """The flat observers' own checks (the (n, 2) shape, one name per row), moved from the
    many-observer tests, and the Observer checks they reach."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(error, match=match):
            nl.observers(raster, kernel=kernel, progress=False, **flat)


def test_observers_at_different_heights_without_terrain_are_refused(
    raster: Raster, kernel: nl.KernelResult
) -> None:
    sites = [Observer(1000.0, 1000.0, height=1.7), Observer(500.0, 500.0, height=30.0)]
    with pytest.raises(InputError, match="share one eye height"):
        nl.observers(Scene(raster, kernel=kernel), sites, progress=False)


# --- a product records its scene; the dimming rule rebuilds it ----------------------------------


def test_the_dimming_rule_rebuilds_the_scene_its_q_map_recorded(
    raster: Raster, tmp_path: Path
) -> None:
    """Q at turbidity 3 on a scene kernel, then the dimming rule without a kernel: its
    before/after figures equal those with the turbidity-3 kernel given, and differ from the
    default turbidity's (the figures once fell back to turbidity 2)."""
    site = Observer(1000.0, 1000.0)
    hazy = Scene(raster, turbidity=3.0, cache_dir=tmp_path, **GRID)
    q = nl.inverse_q(hazy, site, progress=False).raster
    assert q.tags["turbidity"] == "3.0" and q.tags["n_azimuth"] == "16"
    qa, qb = float(np.nanmin(q.data)), float(np.nanmax(q.data))
    rule = {"by": q, "qa": qa, "qb": qb, "gamma": 0.5, "progress": False}
    rebuilt = nl.inverse_reduce(Scene(raster, cache_dir=tmp_path), **rule).summary
    table = prepare_scene(hazy, site, progress=False).table
    assert float(table.attrs["turbidity"]) == 3.0
    given = nl.inverse_reduce(Scene(raster, kernel=table), **rule).summary
    assert rebuilt["observers"] == given["observers"]
    clear = nl.inverse_reduce(
        Scene(raster, turbidity=2.0, cache_dir=tmp_path, **GRID), **rule
    ).summary
    assert clear["observers"][0]["zenith"] != given["observers"][0]["zenith"]


def test_a_recorded_kernel_file_is_reused_while_it_has_its_hash(
    raster: Raster, kernel: nl.KernelResult, tmp_path: Path
) -> None:
    from nightlights.sky.store import write_kernel

    path = write_kernel(kernel.kernel, tmp_path / "kernel.nc")
    q = nl.inverse_q(Scene(raster, kernel=path), Observer(1000.0, 1000.0)).raster
    assert q.tags["kernel_file"] == str(path.resolve())
    rebuilt = Scene(raster).recorded(q.tags)
    assert rebuilt.kernel == path.resolve()
    xr.Dataset(attrs={"content_hash": "another"}).to_netcdf(path, engine="h5netcdf")
    assert Scene(raster).recorded(q.tags).kernel is None
