"""The road dimming plan: every constraint re-checked by the audit and by the sky recomputed
from the dimmed lights' emission, infeasible plans explained, bounds and bad input."""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from shapely import LineString

from nightlights import roads
from nightlights.errors import DataQualityWarning, InputError
from nightlights.inverse.road_sky import lights_emission, sky_matrix
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.streets import place

OBSERVER = Observer(250.0, 50.0)


def _streets() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {
            "source_id": ["a", "b", "c"],
            "width": [7.0, 12.0, 6.0],
            "lanes": [2, 4, 2],
            "lit": [True] * 3,
            "arrangement": ["single_sided", "opposite", "staggered"],
            "spacing": [30.0, 40.0, 25.0],
            "mounting_height": [8.0, 10.0, 6.0],
            "system_id": ["street_led_small", "road_led_large", "street_led_small"],
            "lighting_class": ["M4", "M3", "P3"],
        },
        geometry=[
            LineString([(0, 0), (300, 0)]),
            LineString([(0, 100), (200, 150), (400, 100)]),
            LineString([(500, 0), (500, 200)]),
        ],
        crs="EPSG:3067",
    )


#: The EN 13201-2 figures the plan keeps.
EN_FIGURES = (
    "average_luminance",
    "overall_uniformity",
    "longitudinal_uniformity",
    "threshold_increment",
    "edge_illuminance_ratio",
    "average_illuminance",
    "minimum_illuminance",
)


def _lenient(rating) -> dict[str, dict[str, float]]:
    """Requirements every segment meets undimmed with room: 60 % of its minima, 150 % of
    its glare (so that a plan can dim)."""
    table: dict[str, dict[str, float]] = {}
    for _, row in rating.iterrows():
        entry = table.setdefault(str(row["lighting_class"]), {})
        for name in EN_FIGURES:
            kind = roads.CRITERIA[name][0]
            if np.isfinite(row[f"{name}_required"]):
                value = row[name] * (0.6 if kind == "minimum" else 1.5)
                entry[name] = min(entry.get(name, value), value)
    return table


@pytest.fixture(scope="module")
def case():
    streets = _streets()
    lights = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0).lights
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        first = roads.road_model(lights, streets)
        table = _lenient(first.rate())
        model = roads.road_model(lights, streets, requirements=table)
    return lights, streets, table, model


@pytest.fixture(scope="module")
def kernel():
    spec = KernelSpec.exact(
        r_min=10.0, r_max=3000.0, n_distance=12, n_elevation=8, n_azimuth=16, uplight=True
    )
    return build_kernel(spec, progress=False)


def _grid() -> Raster:
    return Raster(np.zeros((1, 8, 12)), Affine(100.0, 0, -300.0, 0, -100.0, 500.0), "EPSG:3067")


def _audit(lights, streets, table, dimming):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        return roads.audit(lights, streets, requirements=table, dimming=dimming)


def test_a_feasible_plan_keeps_every_class_by_the_audit(case) -> None:
    lights, streets, table, model = case
    assert bool(model.rate()["passed"].all())
    plan = roads.road_plan(model, None)
    assert plan.feasible and plan.dimming.max() <= 1.0 and plan.dimming.min() >= 0.0
    assert plan.saved > 0.2 * plan.cost_full  # the lenient classes leave room to dim
    audited = _audit(lights, streets, table, plan.dimming).segments
    assert (audited["status"] == "pass").all()
    for name in EN_FIGURES:
        kind = roads.CRITERIA[name][0]
        value, required = audited[name].to_numpy(), audited[f"{name}_required"].to_numpy()
        known = np.isfinite(required)
        if kind == "minimum":
            assert np.all(value[known] >= required[known] * (1 - 1e-6)), name
        else:
            assert np.all(value[known] <= required[known] * (1 + 1e-6)), name
    # at least one minimum binds: the plan dims as far as the classes allow
    margins = audited[[f"{n}_margin" for n in EN_FIGURES]].to_numpy(float)
    assert np.nanmin(margins) < 1e-4


def test_the_sky_targets_hold_when_the_sky_is_recomputed(case, kernel) -> None:
    lights, streets, table, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.3)
    before = skyglow(scene, OBSERVER).zenith_luminance
    assert sky.before[0] == pytest.approx(before, rel=1e-6)
    plan = roads.road_plan(model, sky)
    assert plan.feasible
    dimmed = Scene(lights_emission(model.luminaires, _grid(), dimming=plan.dimming), kernel=kernel)
    after = skyglow(dimmed, OBSERVER).zenith_luminance
    # per-light approximation against the raster path: lights of two systems share cells
    assert after == pytest.approx(plan.sky["after_cd_m2"].iloc[0], rel=0.02)
    assert after <= 0.7 * before * 1.02
    assert bool(_audit(lights, streets, table, plan.dimming).segments["status"].eq("pass").all())
    # the sky-only plan is never more costly than the joint one
    assert plan.cost_sky_only <= plan.cost + 1e-9 and plan.cost_of_safety >= -1e-9


def test_per_light_sky_matches_the_raster_path_for_random_dimmings(case, kernel) -> None:
    _, _, _, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.5)
    rng = np.random.default_rng(4)
    for _ in range(3):
        delta = rng.random(len(model.luminaires))
        dimmed = Scene(lights_emission(model.luminaires, _grid(), dimming=delta), kernel=kernel)
        raster_path = skyglow(dimmed, OBSERVER).zenith_luminance
        assert sky.after(delta)[0] == pytest.approx(raster_path, rel=0.02)


def test_an_infeasible_plan_names_the_binding_segments(case, kernel) -> None:
    _, _, _, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.97)
    plan = roads.road_plan(model, sky)
    assert not plan.feasible
    assert len(plan.binding) >= 1 and (plan.binding["slack"] > 0).all()
    assert set(plan.binding["segment"]) <= {0, 1, 2}
    assert np.all(plan.dimming == 1.0)
    assert plan.cost_sky_only < plan.cost_full


def test_min_dimming_bounds_every_light(case) -> None:
    _, _, _, model = case
    plan = roads.road_plan(model, None, min_dimming=0.45, objective="flux")
    assert plan.dimming.min() >= 0.45 - 1e-12 and plan.dimming.max() <= 1.0 + 1e-12


def test_a_schedule_solves_each_period(case, kernel) -> None:
    _, _, _, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.3)
    plans = roads.road_plan_schedule(
        model,
        [roads.PlanPeriod("evening", 1500.0), roads.PlanPeriod("after midnight", 2500.0, sky)],
    )
    assert plans[0].cost <= plans[1].cost + 1e-9  # fewer constraints, no more power
    for plan, hours in zip(plans, (1500.0, 2500.0), strict=True):
        assert plan.energy_saved == pytest.approx(plan.saved * hours)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"objective": "carbon"}, "objective"),
        ({"min_dimming": 1.5}, "min_dimming"),
        ({"weights": [1.0, 2.0]}, "weights"),
        ({"tolerance": 0.5}, "tolerance"),
    ],
)
def test_bad_input_is_refused(case, options, match) -> None:
    _, _, _, model = case
    with pytest.raises(InputError, match=match):
        roads.road_plan(model, None, **options)


def test_unreachable_sky_and_bad_targets_are_refused(case, kernel) -> None:
    _, _, _, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    with pytest.raises(InputError, match="zenith_reduction"):
        sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=1.5)
    with pytest.raises(InputError, match="no sky target"):
        sky_matrix(model.luminaires, scene, [OBSERVER])
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.5)
    with pytest.raises(InputError, match="out of reach"):
        roads.road_plan(model, sky, min_dimming=0.8)
