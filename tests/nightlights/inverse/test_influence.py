"""Per-cell influence on an observer's sky: Q_i and S_i (Dobashi et al. 2023, Eqs. 10-14)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from affine import Affine

from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.inverse import (
    InfeasibleTargetError,
    inverse_q,
    inverse_reduce,
    inverse_s,
    least_dimming,
)
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.polar import distance_shares

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 0, 0, -CELL, 4000.0)
OBSERVER = Observer(2050.0, 1950.0)  # centre of cell (row 20, col 20)


@pytest.fixture(scope="module")
def kernel():
    spec = KernelSpec.exact(  # float64 bases, no error target: comparisons to 1e-4
        r_min=10.0, r_max=4000.0, n_distance=16, n_elevation=8, n_azimuth=32, uplight=True
    )
    return build_kernel(spec, progress=False)


@pytest.fixture(scope="module")
def full_kernel():
    """Enough PCA components to reproduce the raw tables (to ~1e-6)."""
    spec = KernelSpec.exact(  # float64 bases, no error target: comparisons to 1e-4
        r_min=10.0,
        r_max=4000.0,
        n_distance=16,
        n_elevation=8,
        n_azimuth=32,
        uplight=True,
        n_components=24,
    )
    return build_kernel(spec, progress=False)


@pytest.fixture(scope="module")
def two_level_kernel():
    spec = KernelSpec.exact(  # float64 bases, no error target: comparisons to 1e-4
        r_min=10.0,
        r_max=4000.0,
        n_distance=12,
        n_elevation=8,
        n_azimuth=32,
        uplight=True,
        observer_altitudes=(1.0, 40.0),
        source_altitudes=(0.0, 30.0),
        n_components=34,
    )
    return build_kernel(spec, progress=False)


def _raster(data: np.ndarray) -> Raster:
    return Raster(data, TRANSFORM, "EPSG:32635", ("reflected", "uplight")[: data.shape[0]])


def _city(seed: int = 3) -> Raster:
    """A lit patchwork with both emission bands, some cells dark."""
    rng = np.random.default_rng(seed)
    data = rng.lognormal(0.0, 1.0, (2, 40, 40)) * (rng.random((40, 40)) < 0.3)
    data[1] *= 0.1
    return _raster(data)


def test_q_falls_with_distance_for_equal_cells(kernel) -> None:
    data = np.zeros((2, 40, 40))
    cols = np.array([21, 22, 24, 28, 36])  # equal cells due east, 100-1600 m, distinct bins
    data[:, 19, cols] = 1.0
    for metric in ("pca-norm", "zenith", "hemisphere"):
        q = inverse_q(Scene(_raster(data), kernel=kernel), OBSERVER, metric=metric)
        values = q.raster.data[0, 19, cols]
        assert np.all(np.isfinite(values)) and np.all(values > 0), metric
        assert np.all(np.diff(values) < 0), (metric, values)


def test_q_is_nan_where_unlit_and_carries_its_observer(kernel) -> None:
    city = _city()
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER)
    lit = np.any(city.data != 0, axis=0)
    assert np.array_equal(np.isfinite(q.raster.data[0]), lit)
    assert q.raster.descriptions == ("q_pca_norm",) and q.raster.units == ("cd m-2",)
    assert float(q.raster.tags["observer_x"]) == OBSERVER.x
    assert np.isnan(q.panorama_value)


def test_pca_norm_is_the_norm_of_the_cell_image(kernel) -> None:
    """Eq. 10 with orthonormal bases: Q = the L2 norm of the kernel image over the pixels."""
    data = np.zeros((1, 40, 40))
    data[0, 10, 33] = 2.0  # one cell, far enough that it is a single sub-point
    q = inverse_q(Scene(_raster(data), kernel=kernel), OBSERVER)
    image = skyglow(Scene(_raster(data), kernel=kernel), OBSERVER.replace(height=1.7))
    norm = np.sqrt(np.sum(image.panorama["luminance"].values ** 2))
    assert q.raster.data[0, 10, 33] == pytest.approx(norm, rel=1e-3)


@pytest.mark.parametrize("metric", ["zenith", "hemisphere"])
def test_physical_metrics_add_up_to_the_forward_panorama(kernel, metric) -> None:
    city = _city()
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER, metric=metric)
    assert q.total == pytest.approx(q.panorama_value, rel=1e-9)
    forward = skyglow(Scene(city, kernel=kernel), OBSERVER)
    if metric == "zenith":
        assert q.total == pytest.approx(forward.zenith_luminance, rel=1e-9)
    else:
        luminance = forward.panorama["luminance"].values
        elevation = np.radians(forward.panorama["elevation"].values)
        step = np.radians(90.0 / elevation.size)
        omega = np.sin(elevation + step / 2) - np.sin(elevation - step / 2)
        mean = np.sum(luminance * omega[:, None]) / (omega.sum() * luminance.shape[1])
        assert q.total == pytest.approx(mean, rel=1e-9)


def test_sums_hold_between_kernel_levels(two_level_kernel) -> None:
    """An observer between two observer levels (interleaved bases), sources between two levels."""
    city = _city(5)
    dem = Raster(
        np.linspace(0.0, 25.0, 1600).reshape(1, 40, 40), TRANSFORM, "EPSG:32635", ("height",)
    )
    scene = Scene(city, kernel=two_level_kernel, dem=dem)
    eye = OBSERVER.replace(height=3.0)
    q = inverse_q(scene, eye, metric="zenith")
    assert q.total == pytest.approx(q.panorama_value, rel=1e-9)
    s = inverse_s(scene, eye, region="horizon:0,180,40")
    brute = inverse_s(scene, eye, region="horizon:0,180,40", method="brute")
    lit = np.isfinite(s.raster.data)
    assert np.allclose(s.raster.data[lit], brute.raster.data[lit], rtol=1e-4, atol=0)


def test_an_observer_outside_the_raster_within_reach_is_fine(kernel) -> None:
    city = _city()
    q = inverse_q(Scene(city, kernel=kernel), Observer(4500.0, 2000.0), metric="zenith")
    assert q.total == pytest.approx(q.panorama_value, rel=1e-9) and q.total > 0


def test_eastern_region_ranks_the_eastern_cell_first(kernel) -> None:
    data = np.zeros((2, 40, 40))
    data[:, 19, 30] = 1.0  # 1 km east
    data[:, 19, 10] = 1.0  # 1 km west
    s = inverse_s(Scene(_raster(data), kernel=kernel), OBSERVER, region="horizon:45,135,30")
    east, west = s.raster.data[0, 19, 30], s.raster.data[0, 19, 10]
    assert east > 5 * west > 0


@pytest.mark.parametrize("weight", ["solid-angle", "pixel"])
def test_s_equals_the_brute_force_and_the_panorama(full_kernel, weight) -> None:
    kernel = full_kernel
    city = _city(7)
    region = "200,10 260,10 260,50 200,50 200,10"
    scene = Scene(city, kernel=kernel)
    fast = inverse_s(scene, OBSERVER, region=region, weight=weight)
    brute = inverse_s(scene, OBSERVER, region=region, weight=weight, method="brute")
    lit = np.isfinite(fast.raster.data)
    assert np.array_equal(lit, np.isfinite(brute.raster.data))
    assert np.allclose(fast.raster.data[lit], brute.raster.data[lit], rtol=1e-4, atol=0)
    assert fast.total == pytest.approx(fast.panorama_value, rel=1e-9)
    assert brute.total == pytest.approx(fast.panorama_value, rel=1e-4)


def test_few_bases_are_worse_than_all(full_kernel) -> None:
    kernel = full_kernel
    city = _city(7)
    region = "zenith:30"
    scene = Scene(city, kernel=kernel)
    brute = inverse_s(scene, OBSERVER, region=region, method="brute")
    lit = np.isfinite(brute.raster.data)
    errors = []
    for components in (1, None):
        s = inverse_s(scene, OBSERVER, region=region, components=components)
        ratio = s.raster.data[lit] / brute.raster.data[lit]
        errors.append(np.max(np.abs(ratio - 1)))
    assert errors[1] < 1e-4 < 1e-2 < errors[0]


def test_dimming_the_top_s_cells_beats_a_uniform_cut(kernel) -> None:
    city = _city(11)
    region = "horizon:250,330,25"
    s = inverse_s(Scene(city, kernel=kernel), OBSERVER, region=region)
    values = np.nan_to_num(s.raster.data[0], nan=-1.0)
    flux = city.data.sum(axis=0)
    top = values >= np.quantile(values[values >= 0], 0.9)
    removed = flux[top].sum()  # the top decile, switched off
    uniform = removed / flux.sum()  # the same flux taken from every cell
    targeted = _raster(city.data * ~top[None])
    even = _raster(city.data * (1.0 - uniform))
    region_of = [
        inverse_s(Scene(r, kernel=kernel), OBSERVER, region=region).panorama_value
        for r in (city, targeted, even)
    ]
    assert region_of[1] < region_of[2] < region_of[0]


def test_reduce_writes_the_dimmed_emission_and_a_summary(kernel, tmp_path: Path) -> None:
    city = _city(13)
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER, tmp_path / "q.tif", metric="zenith")
    lit = np.isfinite(q.raster.data[0])
    qa, qb = np.quantile(q.raster.data[0][lit], [0.5, 0.9])
    result = inverse_reduce(
        Scene(city, kernel=kernel),
        tmp_path / "reduced.tif",
        by=tmp_path / "q.tif",
        qa=qa,
        qb=qb,
        gamma=1.0,
        dimming_output=tmp_path / "dimming.tif",
        summary_output=tmp_path / "summary.json",
        png=tmp_path / "before_after.png",
    )
    values = q.raster.data[0]
    fraction = result.dimming.data[0]
    assert np.all(fraction[lit & (values > qb)] == pytest.approx(1.0))
    assert np.all(fraction[lit & (values < qa)] == 0.0)
    for name in ("reduced.tif", "dimming.tif", "summary.json", "before_after.png"):
        assert (tmp_path / name).stat().st_size > 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    flux = city.data.sum(axis=0) * CELL**2
    assert summary["flux_removed_lm"] == pytest.approx(np.sum(flux * np.nan_to_num(fraction)))
    zenith = summary["observers"][0]["zenith"]
    assert zenith["after_cd_m2"] < zenith["before_cd_m2"]
    assert zenith["before_cd_m2"] == pytest.approx(q.panorama_value, rel=1e-9)
    assert Raster.read(tmp_path / "reduced.tif").data.shape == city.data.shape
    assert (
        summary["dimming_raster"] == "dimming.tif"
    )  # relative to the summary, which moves with it


def test_least_dimming_meets_its_targets(kernel) -> None:
    city = _city(17)
    observers = [OBSERVER, Observer(1050.0, 2950.0)]
    scene = Scene(city, kernel=kernel)
    zenith = [skyglow(scene, o).zenith_magnitude for o in observers]
    target = max(zenith) + 0.5  # half a magnitude darker than the darker of the two
    plan = least_dimming(scene, observers, target_zenith=target, max_dimming=0.9)
    assert plan.summary["plan"]["method"] == "lp"
    for entry in plan.summary["observers"]:
        assert entry["zenith"]["after_mag_arcsec2"] >= target - 1e-6
    fraction = np.nan_to_num(plan.dimming.data[0])
    assert fraction.max() <= 0.9 + 1e-12
    after = [skyglow(Scene(plan.raster, kernel=kernel), o).zenith_magnitude for o in observers]
    assert min(after) >= target - 1e-6


def test_one_target_is_solved_by_the_greedy_rule(kernel) -> None:
    city = _city(19)
    scene = Scene(city, kernel=kernel)
    before = skyglow(scene, OBSERVER).zenith_magnitude
    plan = least_dimming(scene, [OBSERVER], target_region=[("zenith:40", before + 0.3)])
    assert plan.summary["plan"]["method"] == "greedy"
    region = plan.summary["observers"][0]["regions"][0]
    assert region["after_mag_arcsec2"] >= before + 0.3 - 1e-6


def test_infeasible_targets_fail_clearly_and_write_nothing(kernel, tmp_path: Path) -> None:
    city = _city(23)
    with pytest.raises(InfeasibleTargetError, match="reachable"):
        least_dimming(
            Scene(city, kernel=kernel),
            [OBSERVER],
            tmp_path / "reduced.tif",
            target_zenith=30.0,
            max_dimming=0.5,
            summary_output=tmp_path / "summary.json",
        )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"observer": Observer(9000.0, 100.0)}, "outside"),  # 5 km beyond the 4 km kernel
        ({"observer": Observer(2000.0, 3.0e6)}, "outside"),  # a swapped-coordinates mistake
        ({"metric": "brightest"}, "metric"),
    ],
)
def test_q_errors_write_nothing(kernel, tmp_path: Path, options, match) -> None:
    arguments = {"observer": OBSERVER, **options}
    with pytest.raises(InputError, match=match):
        inverse_q(Scene(_city(), kernel=kernel), output=tmp_path / "q.tif", **arguments)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("region", "match"),
    [
        ("10,10 50,10 50,40", "closed|first"),
        ("10,10 50,40 50,10 10,40 10,10", "cross"),
    ],
)
def test_bad_regions_fail_before_any_work(kernel, tmp_path: Path, region, match) -> None:
    with pytest.raises(InputError, match=match):
        inverse_s(Scene(_city(), kernel=kernel), OBSERVER, tmp_path / "s.tif", region=region)
    assert list(tmp_path.iterdir()) == []


def test_reduce_rejects_a_bad_rule(kernel, tmp_path: Path) -> None:
    city = _city()
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER)
    for qa, qb, gamma in ((2.0, 1.0, 1.0), (0.0, 1.0, 1.5)):
        with pytest.raises(InputError):
            inverse_reduce(Scene(city), tmp_path / "r.tif", by=q.raster, qa=qa, qb=qb, gamma=gamma)
    assert list(tmp_path.iterdir()) == []


def test_magnitudes_in_the_summary_are_consistent(kernel) -> None:
    city = _city(29)
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER)
    values = q.raster.data[0][np.isfinite(q.raster.data[0])]
    result = inverse_reduce(
        Scene(city, kernel=kernel), by=q.raster, qa=float(np.median(values)), qb=float(values.max())
    )
    zenith = result.summary["observers"][0]["zenith"]
    assert zenith["after_mag_arcsec2"] == pytest.approx(
        float(luminance_to_magnitude(zenith["after_cd_m2"]))
    )


def test_dimming_refuses_a_raster_larger_than_the_memory_limit(kernel, tmp_path: Path) -> None:
    from nightlights._resources import set_memory_limit
    from nightlights.errors import ResourceError

    city = _city(31)
    q = inverse_q(Scene(city, kernel=kernel), OBSERVER)
    set_memory_limit(100_000)  # [B]: the 40 x 40 grid needs about 0.1 MB
    try:
        with pytest.raises(ResourceError, match="dimming the 40 x 40 emission raster"):
            inverse_reduce(
                Scene(city, kernel=kernel), tmp_path / "r.tif", by=q.raster, qa=0.0, qb=1.0
            )
        with pytest.raises(ResourceError, match="NIGHTLIGHTS_MAX_MEMORY"):
            least_dimming(Scene(city, kernel=kernel), [OBSERVER], target_zenith=25.0)
    finally:
        set_memory_limit(None)
    assert list(tmp_path.iterdir()) == []


def test_each_cells_zenith_part_is_its_own_forward_zenith(kernel) -> None:
    """The inverse is the transpose of the forward map also where a cell's flux is shared
    between two distance bins: Q_i (zenith) of every cell is the zenith of that cell alone."""
    cells = [(19, 31), (8, 27), (33, 12)]  # single sub-points between two bin centres
    edges = kernel.kernel["distance_edges"].values
    data = np.zeros((2, 40, 40))
    for row, col in cells:
        data[:, row, col] = (1.0, 0.3)
        x, y = TRANSFORM.c + CELL * (col + 0.5), TRANSFORM.f - CELL * (row + 0.5)
        r = np.hypot(x - OBSERVER.x, y - OBSERVER.y)
        assert 0.05 < distance_shares(r, edges)[1] < 0.95, r  # shared, not at a centre
    q = inverse_q(Scene(_raster(data), kernel=kernel), OBSERVER, metric="zenith")
    for row, col in cells:
        alone = np.zeros_like(data)
        alone[:, row, col] = data[:, row, col]
        forward = skyglow(Scene(_raster(alone), kernel=kernel), OBSERVER).zenith_luminance
        assert q.raster.data[0, row, col] == pytest.approx(forward, rel=1e-9), (row, col)
