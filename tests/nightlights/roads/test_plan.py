"""The road dimming plan: every constraint re-checked by the audit, infeasible plans explained,
schedules, bounds and bad input (the sky side: tests/nightlights/inverse/test_road_sky.py)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from affine import Affine

from nightlights import roads
from nightlights.errors import DataQualityWarning, InputError
from nightlights.inverse.road_sky import lights_emission, sky_matrix
from nightlights.io import Raster
from nightlights.sky import Observer, Scene

OBSERVER = Observer(250.0, 50.0)

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


@pytest.fixture
def case(road_plan_case):
    return road_plan_case


@pytest.fixture
def kernel(tiny_sky_kernel):
    return tiny_sky_kernel


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
        ({"coefficient_floor": 1.0}, "coefficient_floor"),
    ],
)
def test_bad_input_is_refused(case, options, match) -> None:
    _, _, _, model = case
    with pytest.raises(InputError, match=match):
        roads.road_plan(model, None, **options)


def test_an_unreachable_sky_is_refused(case, kernel) -> None:
    _, _, _, model = case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.5)
    with pytest.raises(InputError, match="out of reach"):
        roads.road_plan(model, sky, min_dimming=0.8)


def test_lazy_rows_reach_the_full_programs_optimum(road_plan_case, monkeypatch) -> None:
    """Row generation ends at the optimum of the program with every row at once."""
    from nightlights.roads import _plan

    _, _, _, model = road_plan_case
    lazy = roads.road_plan(model, None, min_dimming=0.1, coefficient_floor=0.0)
    monkeypatch.setattr(_plan, "MAX_ROUNDS", 0)  # straight to the full program
    full = roads.road_plan(model, None, min_dimming=0.1, coefficient_floor=0.0)
    assert lazy.cost == pytest.approx(full.cost, rel=1e-6)
    assert bool(lazy.after["passed"].all())


def test_segments_failing_undimmed_are_kept_no_worse(case) -> None:
    lights, streets, _, _ = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        model = roads.road_model(lights, streets)  # the published classes: every segment fails
    before = model.rate()
    assert not before["passed"].any()
    plan = roads.road_plan(model, None)
    assert plan.feasible
    assert sorted(plan.relaxed.tolist()) == list(range(len(streets)))
    after = model.rate(plan.dimming)
    for name in EN_FIGURES:
        kind = roads.CRITERIA[name][0]
        old, new = before[name].to_numpy(float), after[name].to_numpy(float)
        required = before[f"{name}_required"].to_numpy(float)
        # a failing figure may not get worse (beyond the room of 2e-6 the program is given);
        # a passing one must keep its class
        held = np.isfinite(required) & np.isfinite(old)
        if kind == "minimum":
            floor = np.where(old < required, old * (1 - 3e-6), required * (1 - 1e-6))
            assert np.all(new[held] >= floor[held]), name
        else:
            ceiling = np.where(old > required, old * (1 + 3e-6), required * (1 + 1e-6))
            assert np.all(new[held] <= ceiling[held]), name


def test_thinning_drops_small_terms_at_their_worst_and_best_case() -> None:
    """A row 1.0 x0 - 0.0005 x1 + 0.0002 x2 <= 0.5 at floor 1e-3 and x in [0.2, 1]: the worst
    case of the dropped terms moves the bound by -0.0002 (x2 at 1) and +0.0001 (x1 at 0.2),
    the best case by -0.00004 (x2 at 0.2) and +0.0005 (x1 at 1); by hand."""
    import scipy.sparse as sp

    from nightlights.roads import _plan

    a = sp.csr_array(np.array([[1.0, -0.0005, 0.0002], [0.3, 0.0, 0.4]]))
    b = np.array([0.5, 0.7])
    thin, upper = _plan._thin(a, b, 1e-3, 0.2)
    assert thin.toarray().tolist() == [[1.0, 0.0, 0.0], [0.3, 0.0, 0.4]]
    assert upper == pytest.approx([0.5 - 0.0002 + 0.0001, 0.7], abs=1e-15)
    _, relaxed = _plan._thin(a, b, 1e-3, 0.2, relax=True)
    assert relaxed == pytest.approx([0.5 - 0.00004 + 0.0005, 0.7], abs=1e-15)
    # every x in the box that keeps the thinned row keeps the given one (brute force)
    x = np.random.default_rng(0).uniform(0.2, 1.0, (20000, 3))
    keeps = (x @ thin.toarray().T <= upper).all(axis=1)
    assert keeps.any() and (x[keeps] @ a.toarray().T <= b).all()
    given = (x @ a.toarray().T <= b).all(axis=1)
    assert (x[given] @ thin.toarray().T <= relaxed).all()


def test_a_row_full_output_only_just_keeps_is_not_thinned() -> None:
    """1.0 x0 - 0.0005 x1 <= 0.9995 holds at x = 1 with no room; dropping x1 at its worst case
    (x1 = 0.2) would ask x0 <= 0.9996 and close it, so the row stays whole; a row with room
    is thinned."""
    import scipy.sparse as sp

    from nightlights.roads import _plan

    a = sp.csr_array(np.array([[1.0, -0.0005], [1.0, -0.0005]]))
    b = np.array([0.9995, 1.5])
    thin, upper = _plan._thin(a, b, 1e-3, 0.2)
    assert thin.toarray().tolist() == [[1.0, -0.0005], [1.0, 0.0]]
    assert upper == pytest.approx([0.9995, 1.5 + 0.0001], abs=1e-15)


def test_the_coefficient_floor_brackets_the_exact_optimum(road_plan_case) -> None:
    """The default floor's plan keeps every class by re-rating and costs at most 0.1 % more than
    the optimum of every row at once (scipy's HiGHS, no row generation, no floor); the relaxed
    thinned program's optimum lies below it."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    from nightlights.roads import _plan
    from nightlights.roads._plan_rows import road_rows

    _, _, _, model = road_plan_case
    low = 0.1
    w = _plan._weights(model, "energy", None)
    rows = road_rows(model.influence, model.rate())
    a = -(sp.diags_array(1.0 / rows.scale) @ rows.matrix)
    reference = linprog(
        w,
        A_ub=sp.csr_array(a),
        b_ub=-rows.bound / rows.scale - _plan.MARGIN,
        bounds=(low, 1.0),
        method="highs",
    )
    assert reference.status == 0
    fast = roads.road_plan(model, None, min_dimming=low)
    assert bool(fast.after["passed"].all())
    assert reference.fun * (1 - 1e-9) <= fast.cost <= reference.fun * (1 + 1e-3)
    exact = roads.road_plan(model, None, min_dimming=low, coefficient_floor=0.0)
    assert exact.cost == pytest.approx(reference.fun, rel=1e-7)
    bound = _plan._solve(w, None, rows, low, _plan.TOLERANCE, _plan.COEFFICIENT_FLOOR, relax=True)
    assert bound is not None and w @ bound <= reference.fun * (1 + 1e-9)
