"""Dobashi et al.'s dimming rule (2023, Eq. 12) and the least-flux dimming (greedy and LP)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.inverse import (
    DimmingPlan,
    InfeasibleTargetError,
    _dimming,
    dimming_fraction,
    least_flux_dimming,
)

# --------------------------------------------------------------------------------------------
# Eq. 12


def test_gamma_one_removes_cells_above_qb_and_keeps_those_below_qa() -> None:
    # Dobashi et al. 2023, Sec. 4.1: "When gamma_usr is one, the light sources with Q_i > Q_b
    # are eliminated. The light sources with Q_i < Q_a are ... unchanged."
    influence = np.array([[0.0, 0.9, 1.0, 2.0], [3.0, 3.1, 50.0, np.nan]])
    gamma = dimming_fraction(influence, qa=1.0, qb=3.0, gamma=1.0)
    assert gamma.shape == influence.shape
    above, below = influence > 3.0, influence < 1.0
    assert np.all(gamma[above] == 1.0)
    assert np.all(gamma[below] == 0.0)
    assert gamma[0, 3] == pytest.approx(0.5)  # linear in between
    assert gamma[1, 3] == 0.0  # unlit


@pytest.mark.parametrize("gamma_usr", [0.0, 0.3, 1.0])
def test_gamma_usr_scales_the_rate_and_bounds_it(gamma_usr: float) -> None:
    influence = np.linspace(-1.0, 5.0, 61)
    rate = dimming_fraction(influence, qa=1.0, qb=3.0, gamma=gamma_usr)
    unscaled = dimming_fraction(influence, qa=1.0, qb=3.0, gamma=1.0)
    np.testing.assert_allclose(rate, gamma_usr * unscaled)
    assert rate.min() == 0.0 and rate.max() == pytest.approx(gamma_usr)
    assert np.all(np.diff(rate) >= 0)  # more influence, never less dimming


@pytest.mark.parametrize(
    ("qa", "qb", "gamma", "match"),
    [
        (2.0, 2.0, 1.0, "qa must be below qb"),
        (3.0, 2.0, 1.0, "qa must be below qb"),
        (1.0, 2.0, -0.1, "gamma must be in"),
        (1.0, 2.0, 1.5, "gamma must be in"),
        (np.nan, 2.0, 1.0, "finite"),
        (1.0, np.inf, 1.0, "finite"),
    ],
)
def test_eq12_rejects_bad_parameters(qa: float, qb: float, gamma: float, match: str) -> None:
    with pytest.raises(InputError, match=match):
        dimming_fraction([1.0, 2.0], qa=qa, qb=qb, gamma=gamma)


# --------------------------------------------------------------------------------------------
# Random instances


def instance(
    rng: np.random.Generator, n_targets: int, n_cells: int, *, reach: float = 0.5
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Contributions falling as r^-2 from observers, log-normal flux, reachable targets.

    ``reach``: the fraction of the reducible luminance (every cell at its maximum) each target
    asks to remove.
    """
    cells = rng.uniform(0, 10_000, (n_cells, 2))
    observers = rng.uniform(0, 10_000, (n_targets, 2))
    r = np.hypot(*(cells[None, :, :] - observers[:, None, :]).transpose(2, 0, 1))
    flux = rng.lognormal(np.log(5000.0), 1.0, n_cells)
    contribution = flux * 1e-6 / (r + 100.0) ** 2
    max_dimming = rng.uniform(0.3, 1.0, n_cells)
    before = contribution.sum(axis=1) + rng.uniform(0, 1e-10, n_targets)  # + undimmable part
    target = before - reach * (contribution @ max_dimming)
    return contribution, flux, before, target, max_dimming


def flux_of_least_feasible_scaling(
    contribution: np.ndarray,
    flux: np.ndarray,
    before: np.ndarray,
    target: np.ndarray,
    max_dimming: np.ndarray,
    rng: np.random.Generator,
    samples: int,
) -> np.ndarray:
    """Flux removed by random dimmings min(s u, m), each scaled up until just feasible."""
    u = rng.uniform(0, 1, (samples, flux.size)) * max_dimming
    lo, hi = np.zeros(samples), np.full(samples, (max_dimming / u).max(axis=1))
    for _ in range(60):
        s = (lo + hi) / 2
        x = np.minimum(s[:, None] * u, max_dimming)
        ok = np.all(before - x @ contribution.T <= target, axis=1)
        hi, lo = np.where(ok, s, hi), np.where(ok, lo, s)
    x = np.minimum(hi[:, None] * u, max_dimming)
    assert np.all(before - x @ contribution.T <= target * (1 + 1e-12))
    return x @ flux


def assert_plan_meets(plan: DimmingPlan, contribution, flux, before, target, max_dimming):
    assert np.all(plan.fraction >= 0) and np.all(plan.fraction <= max_dimming)
    np.testing.assert_allclose(plan.after, before - contribution @ plan.fraction, rtol=1e-12)
    assert np.all(plan.after <= target + 1e-9 * (before - target))
    assert plan.removed_flux == pytest.approx(flux @ plan.fraction, rel=1e-12)
    assert plan.total_flux == pytest.approx(flux.sum(), rel=1e-12)
    np.testing.assert_array_equal(plan.before, before)


@pytest.mark.parametrize("seed", range(20))
def test_greedy_meets_its_target_and_equals_the_lp_optimum(seed: int) -> None:
    rng = np.random.default_rng(seed)
    args = instance(rng, 1, int(rng.integers(5, 300)), reach=rng.uniform(0.05, 0.99))
    greedy = least_flux_dimming(*args[:4], max_dimming=args[4])
    lp = least_flux_dimming(*args[:4], max_dimming=args[4], method="lp")
    assert (greedy.method, lp.method) == ("greedy", "lp")
    assert_plan_meets(greedy, *args)
    assert_plan_meets(lp, *args)
    assert greedy.after[0] == pytest.approx(args[3][0], rel=1e-9)  # no more than needed
    assert greedy.removed_flux == pytest.approx(lp.removed_flux, rel=1e-7)
    # at most one cell dimmed part-way (the knapsack's last item)
    x, m = greedy.fraction, args[4]
    assert np.sum((x > 0) & (x < m)) <= 1


@pytest.mark.parametrize(("seed", "n_targets"), [(0, 2), (1, 3), (2, 5), (3, 10)])
def test_lp_meets_every_target_and_no_random_dimming_removes_less(
    seed: int, n_targets: int
) -> None:
    rng = np.random.default_rng(seed)
    args = instance(rng, n_targets, 40, reach=0.6)
    plan = least_flux_dimming(*args[:4], max_dimming=args[4])
    assert plan.method == "lp"
    assert_plan_meets(plan, *args)
    assert np.any(np.isclose(plan.after, args[3], rtol=1e-9))  # some target binds
    feasible = flux_of_least_feasible_scaling(*args, rng, samples=3000)
    assert feasible.min() >= plan.removed_flux * (1 - 1e-9)
    # nor does any random dimming that happens to be feasible
    x = rng.uniform(0, 1, (20_000, args[1].size)) * args[4]
    ok = np.all(args[2] - x @ args[0].T <= args[3], axis=1)
    assert ok.any()
    assert (x[ok] @ args[1]).min() >= plan.removed_flux * (1 - 1e-9)


@pytest.mark.parametrize(("shared_flux", "expected"), [(1.5, [0, 0, 1]), (2.5, [1, 1, 0])])
def test_lp_shares_a_cell_between_targets_when_cheaper(shared_flux, expected) -> None:
    # Two targets each needing 1 unit removed; cells 0 and 1 light one target each (1 lm),
    # cell 2 lights both: it is worth dimming iff its flux is below the 2 lm of the others.
    contribution = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    flux = np.array([1.0, 1.0, shared_flux])
    plan = least_flux_dimming(contribution, flux, [2.0, 2.0], [1.0, 1.0])
    np.testing.assert_allclose(plan.fraction, expected, atol=1e-9)
    assert plan.removed_flux == pytest.approx(min(shared_flux, 2.0))


def test_sparse_and_dense_programs_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    args = instance(np.random.default_rng(7), 4, 200, reach=0.7)
    monkeypatch.setattr(_dimming, "SPARSE_FROM_CELLS", 10**9)
    dense = least_flux_dimming(*args[:4], max_dimming=args[4])
    monkeypatch.setattr(_dimming, "SPARSE_FROM_CELLS", 0)
    sparse = least_flux_dimming(*args[:4], max_dimming=args[4])
    assert sparse.removed_flux == pytest.approx(dense.removed_flux, rel=1e-9)
    assert_plan_meets(sparse, *args)


# --------------------------------------------------------------------------------------------
# Special cells, floors, met and unreachable targets


def test_free_light_first_and_useless_cells_never() -> None:
    # cell 0: light without flux (free); cell 1: no light on the target; cells 2, 3: paid
    contribution = np.array([[1.0, 0.0, 2.0, 1.0]])
    flux = np.array([0.0, 10.0, 4.0, 1.0])
    plan = least_flux_dimming(contribution, flux, [4.0], [1.5])
    # free cell removes 1; then cell 3 (1 per lm) before cell 2 (0.5 per lm): 1 more; 0.5 left
    np.testing.assert_allclose(plan.fraction, [1.0, 0.0, 0.25, 1.0])
    assert plan.removed_flux == pytest.approx(2.0)


@pytest.mark.parametrize("method", ["greedy", "lp"])
def test_scalar_max_dimming_floor_is_respected(method: str) -> None:
    args = instance(np.random.default_rng(3), 1, 50, reach=1.0)
    contribution, flux, before, _, _ = args
    target = before - 0.5 * contribution.sum(axis=1)  # reachable at 0.6, not at 0.4
    plan = least_flux_dimming(contribution, flux, before, target, max_dimming=0.6, method=method)
    assert plan.fraction.max() <= 0.6
    assert plan.fraction.max() == pytest.approx(0.6)  # the floor binds
    assert_plan_meets(plan, contribution, flux, before, target, np.full(50, 0.6))
    with pytest.raises(InfeasibleTargetError):
        least_flux_dimming(contribution, flux, before, target, max_dimming=0.4, method=method)


@pytest.mark.parametrize("n_targets", [1, 3])
def test_per_cell_max_dimming_is_respected(n_targets: int) -> None:
    rng = np.random.default_rng(11)
    contribution, flux, before, _, _ = instance(rng, n_targets, 60)
    max_dimming = np.where(np.arange(60) % 3 == 0, 0.0, 0.8)  # every third cell protected
    target = before - 0.9 * (contribution @ max_dimming)
    plan = least_flux_dimming(contribution, flux, before, target, max_dimming=max_dimming)
    assert np.all(plan.fraction[::3] == 0.0)
    assert_plan_meets(plan, contribution, flux, before, target, max_dimming)


@pytest.mark.parametrize("method", ["auto", "greedy", "lp"])
def test_met_targets_need_no_dimming(method: str) -> None:
    contribution, flux, before, _, _ = instance(np.random.default_rng(5), 1, 30)
    for target in (before, before * 2):
        plan = least_flux_dimming(contribution, flux, before, target, method=method)
        assert np.all(plan.fraction == 0.0) and plan.removed_flux == 0.0
        np.testing.assert_array_equal(plan.after, before)


def test_only_one_unmet_target_of_several_is_solved_greedily() -> None:
    contribution, flux, before, target, m = instance(np.random.default_rng(9), 3, 40)
    target[[0, 2]] = before[[0, 2]] * 1.01
    plan = least_flux_dimming(contribution, flux, before, target, max_dimming=m)
    lp = least_flux_dimming(contribution, flux, before, target, max_dimming=m, method="lp")
    assert (plan.method, lp.method) == ("greedy", "lp")
    assert plan.removed_flux == pytest.approx(lp.removed_flux, rel=1e-7)
    assert_plan_meets(plan, contribution, flux, before, target, m)


@pytest.mark.parametrize("labels", [None, ["Esplanadi zenith", "Suomenlinna east"]])
def test_unreachable_target_names_it_and_the_best_reachable(labels) -> None:
    contribution = np.array([[1e-4, 1e-4], [1e-4, 3e-4]])
    before = np.array([3e-4, 6e-4])  # 1e-4 and 2e-4 come from outside the cells
    target = np.array([1.5e-4, 1.5e-4])  # the first is reachable, the second is not
    with pytest.raises(InfeasibleTargetError) as caught:
        least_flux_dimming(contribution, [10.0, 10.0], before, target, labels=labels)
    error = caught.value
    message = str(error)
    name = "target 1" if labels is None else "Suomenlinna east"
    best = 2e-4
    assert isinstance(error, InputError) and "\n" not in message
    assert message.startswith(name)
    assert (error.label, error.target, error.best) == (name, 1.5e-4, pytest.approx(best))
    for luminance in (1.5e-4, best):
        assert f"{luminance:.4g} cd m-2" in message
        assert f"({float(luminance_to_magnitude(luminance)):.2f} mag arcsec-2)" in message
    # with the second cell protected, the first target is out of reach too: it is named
    first = "target 0" if labels is None else "Esplanadi zenith"
    pattern = re.escape(first) + r" .* is 0\.0002 cd m-2"
    with pytest.raises(InfeasibleTargetError, match=pattern):
        least_flux_dimming(
            contribution, [10.0, 10.0], before, target, max_dimming=[1.0, 0.0], labels=labels
        )


# --------------------------------------------------------------------------------------------
# Validation


GOOD = {
    "contribution": [[1.0, 2.0]],
    "flux": [1.0, 1.0],
    "before": [4.0],
    "target": [2.0],
}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"contribution": [[[1.0, 2.0]]]}, "contribution must be"),
        ({"flux": [1.0, 1.0, 1.0]}, "flux must have shape"),
        ({"before": [4.0, 4.0]}, "before must have shape"),
        ({"target": [[2.0]]}, "target must have shape"),
        ({"contribution": [[-1.0, 2.0]]}, "contribution must be >= 0"),
        ({"flux": [1.0, -3.0]}, "flux must be >= 0"),
        ({"contribution": [[np.nan, 2.0]]}, "contribution must be finite"),
        ({"target": [np.inf]}, "target must be finite"),
        ({"target": [np.nan]}, "target must be finite"),
        ({"max_dimming": 1.2}, "max_dimming must be in"),
        ({"max_dimming": [0.5, -0.1]}, "max_dimming must be in"),
        ({"max_dimming": [0.5]}, "max_dimming must have shape"),
        ({"before": [2.0]}, "less than the sum"),
        ({"method": "simplex"}, "method must be one of"),
        ({"labels": ["a", "b"]}, "labels must name"),
    ],
)
def test_bad_inputs_raise_one_line_input_errors(change: dict, match: str) -> None:
    with pytest.raises(InputError, match=match) as caught:
        least_flux_dimming(**{**GOOD, **change})
    assert "\n" not in str(caught.value)


def test_greedy_refuses_several_targets() -> None:
    with pytest.raises(InputError, match="greedy"):
        least_flux_dimming([[1.0], [1.0]], [1.0], [2.0, 2.0], [1.5, 1.5], method="greedy")


def test_one_target_as_vectors_and_scalars() -> None:
    plan = least_flux_dimming([1.0, 2.0], [1.0, 1.0], 4.0, 2.0)
    np.testing.assert_allclose(plan.fraction, [0.0, 1.0])
    assert plan.after.shape == (1,)
