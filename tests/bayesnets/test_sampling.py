"""Likelihood-weighted sampling (Chuang 2011, Sec. 3.3) against exact inference."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayesnets import (
    BayesNet,
    evidence_probability,
    exact_marginals,
    likelihood_weighted_sample,
    relax_evidence,
    sample_frame,
)
from bayesnets.errors import EvidenceError, EvidenceRelaxedWarning, ImpossibleEvidenceError
from tests.bayesnets.conftest import toy_network

RECORDS = 20_000


def _code(net: BayesNet, variable: str, state: str) -> int:
    return net.states[variable].index(state)


def _frequencies(codes: np.ndarray, k: int) -> np.ndarray:
    return np.bincount(codes, minlength=k) / len(codes)


def _assert_close_to_exact(
    net: BayesNet, samples: dict[str, np.ndarray], exact: dict[str, np.ndarray], n: int
) -> None:
    # Tolerance: 4 binomial standard errors sqrt(p (1 - p) / n) (false alarm ~6e-5 per
    # state) plus 0.005 for the O(1/N) bias of choosing among N candidates.
    for variable, probabilities in exact.items():
        observed = _frequencies(samples[variable], len(probabilities))
        standard_error = np.sqrt(probabilities * (1 - probabilities) / n)
        np.testing.assert_array_less(
            np.abs(observed - probabilities), 4 * standard_error + 0.005, err_msg=variable
        )


def test_evidence_probability_matches_pgmpy(toy: BayesNet) -> None:
    evidence = {"D": _code(toy, "D", "T"), "B": _code(toy, "B", "b1")}
    # P(D=T, B=b1) = P(B=b1) * P(D=T | B=b1) from pgmpy variable elimination.
    p_b = exact_marginals(toy, {}, ["B"])["B"][evidence["B"]]
    p_d = exact_marginals(toy, {"B": evidence["B"]}, ["D"])["D"][evidence["D"]]
    assert evidence_probability(toy, evidence) == pytest.approx(p_b * p_d, rel=1e-12)
    assert evidence_probability(toy, {}) == 1.0


def test_marginals_without_evidence_match_exact_inference(toy: BayesNet) -> None:
    samples = likelihood_weighted_sample(toy, {}, size=RECORDS, rng=np.random.default_rng(1))
    _assert_close_to_exact(toy, samples, exact_marginals(toy), RECORDS)


@pytest.mark.parametrize(
    "evidence",
    [
        {"D": "T"},  # evidence on a leaf: A, B, C are weighted hidden ancestors
        {"D": "F", "A": "a2"},
        {"C": "c1"},
    ],
)
def test_marginals_with_evidence_match_exact_inference(
    toy: BayesNet, evidence: dict[str, str]
) -> None:
    codes = {v: _code(toy, v, s) for v, s in evidence.items()}
    arrays = {v: np.full(RECORDS, c) for v, c in codes.items()}
    samples = likelihood_weighted_sample(toy, arrays, candidates=200, rng=np.random.default_rng(2))
    for variable, code in codes.items():
        assert np.all(samples[variable] == code)  # evidence is kept
    _assert_close_to_exact(toy, samples, exact_marginals(toy, codes), RECORDS)


def test_one_candidate_is_biased_and_many_are_not(toy: BayesNet) -> None:
    # With one candidate likelihood weighting degenerates to forward sampling with the
    # evidence clamped (zero-weight draws redrawn): P(A | D=T) is missed by far more than
    # the sampling error. With 200 candidates it is reached (documents the knob).
    d_true = np.full(RECORDS, _code(toy, "D", "T"))
    exact = exact_marginals(toy, {"D": d_true[0]}, ["A"])["A"]
    error = {}
    for candidates in (1, 200):
        samples = likelihood_weighted_sample(
            toy, {"D": d_true}, candidates=candidates, rng=np.random.default_rng(3)
        )
        error[candidates] = np.abs(_frequencies(samples["A"], 3) - exact).max()
    standard_error = np.sqrt(0.25 / RECORDS)
    assert error[1] > 6 * standard_error
    assert error[200] < 4 * standard_error + 0.005


def test_same_seed_same_samples(toy: BayesNet) -> None:
    rng = np.random.default_rng(0)
    evidence = {"D": rng.integers(-1, 2, 500), "A": rng.integers(-1, 3, 500)}
    first = likelihood_weighted_sample(
        toy, evidence, rng=np.random.default_rng(42), on_conflict="relax"
    )
    again = likelihood_weighted_sample(
        toy, evidence, rng=np.random.default_rng(42), on_conflict="relax"
    )
    other = likelihood_weighted_sample(
        toy, evidence, rng=np.random.default_rng(43), on_conflict="relax"
    )
    for variable in toy.variables:
        np.testing.assert_array_equal(first[variable], again[variable])
    assert any(not np.array_equal(first[v], other[v]) for v in toy.variables)


def test_grouped_sampling_has_the_per_record_distribution(toy: BayesNet) -> None:
    n = 3000
    evidence = {"D": np.full(n, _code(toy, "D", "T"))}
    grouped = likelihood_weighted_sample(toy, evidence, candidates=8, rng=np.random.default_rng(5))
    single = likelihood_weighted_sample(
        toy, evidence, candidates=8, rng=np.random.default_rng(6), grouped=False
    )
    # Two independent estimates of the same distribution: their difference has standard
    # error sqrt(2 p (1 - p) / n); allow 4 of them.
    for variable in ("A", "B", "C"):
        k = len(toy.states[variable])
        p_grouped = _frequencies(grouped[variable], k)
        p_single = _frequencies(single[variable], k)
        pooled = (p_grouped + p_single) / 2
        tolerance = 4 * np.sqrt(2 * pooled * (1 - pooled) / n) + 1e-9
        np.testing.assert_array_less(np.abs(p_grouped - p_single), tolerance)


def test_impossible_evidence_names_records_and_fields(toy: BayesNet) -> None:
    # D=T is impossible when C=c2 (weight 0 in D.csv).
    n = 10
    c = np.full(n, -1)
    c[[3, 7]] = _code(toy, "C", "c2")
    d = np.full(n, _code(toy, "D", "T"))
    labels = [f"seg{i}" for i in range(n)]
    with pytest.raises(ImpossibleEvidenceError) as info:
        likelihood_weighted_sample(
            toy, {"C": c, "D": d}, rng=np.random.default_rng(0), record_labels=labels
        )
    message = str(info.value)
    assert "2 record(s): seg3, seg7" in message
    assert "c=c2 (C)" in message and "d=T (D)" in message


def test_relax_drops_evidence_and_warns(toy: BayesNet) -> None:
    c = np.array([_code(toy, "C", "c2"), -1])
    d = np.full(2, _code(toy, "D", "T"))
    with pytest.warns(EvidenceRelaxedWarning, match=r"dropped"):
        samples = likelihood_weighted_sample(
            toy, {"C": c, "D": d}, rng=np.random.default_rng(0), on_conflict="relax"
        )
    kept, dropped = relax_evidence(toy, {"C": int(c[0]), "D": int(d[0])})
    assert len(dropped) == 1 and evidence_probability(toy, kept) > 0
    # The relaxed record keeps the evidence that was not dropped.
    survivor = next(iter(kept))
    assert samples[survivor][0] == kept[survivor]
    # The possible record is untouched.
    assert samples["D"][1] == d[1]


def test_rare_but_possible_evidence_is_not_an_error(toy: BayesNet) -> None:
    # A=a2, D=T: C must be c0 or c1, and C=c0 needs B=b1 (prob 0.8); with one candidate
    # some records draw only zero-weight candidates; they are redrawn, not reported.
    n = 2000
    evidence = {"A": np.full(n, _code(toy, "A", "a2")), "D": np.full(n, _code(toy, "D", "T"))}
    samples = likelihood_weighted_sample(toy, evidence, candidates=1, rng=np.random.default_rng(0))
    assert not np.any(samples["C"] == _code(toy, "C", "c2"))


def test_empty_input_and_bad_arguments(toy: BayesNet) -> None:
    empty = likelihood_weighted_sample(toy, {"D": np.zeros(0, int)}, rng=np.random.default_rng())
    assert all(len(v) == 0 for v in empty.values())
    with pytest.raises(EvidenceError, match="unknown variables"):
        likelihood_weighted_sample(toy, {"Q": np.zeros(3, int)}, rng=np.random.default_rng())
    with pytest.raises(EvidenceError, match="codes in"):
        likelihood_weighted_sample(toy, {"A": np.array([0, 5])}, rng=np.random.default_rng())
    with pytest.raises(EvidenceError, match="candidates"):
        likelihood_weighted_sample(toy, {}, size=1, candidates=0, rng=np.random.default_rng())


def test_sample_frame_maps_fields(toy: BayesNet) -> None:
    frame = pd.DataFrame({"a": ["a0", None, "a2"], "d": [True, None, False]}, index=[10, 11, 12])
    out = sample_frame(toy, frame, rng=np.random.default_rng(0))
    assert list(out.columns) == ["a", "c", "d"]
    assert list(out.index) == [10, 11, 12]
    assert out.loc[10, "a"] == "a0" and out.loc[12, "d"] == np.False_
    with pytest.raises(EvidenceError, match=r"field 'a'.*12: 'a9'"):
        sample_frame(toy, frame.assign(a=["a0", None, "a9"]), rng=np.random.default_rng(0))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    a=st.lists(st.integers(-1, 2), min_size=1, max_size=30),
    seed=st.integers(0, 2**32 - 1),
    candidates=st.integers(1, 16),
)
def test_samples_lie_in_the_support(a: list[int], seed: int, candidates: int) -> None:
    # Invariant: evidence is kept and every sampled state has positive probability given
    # its sampled parents, whatever the evidence and candidate count.
    net = toy_network()
    n = len(a)
    d = np.where(np.arange(n) % 2 == 0, net.states["D"].index("T"), -1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EvidenceRelaxedWarning)
        samples = likelihood_weighted_sample(
            net,
            {"A": np.array(a), "D": d},
            candidates=candidates,
            rng=np.random.default_rng(seed),
            on_conflict="relax",
        )
    observed = np.array(a) >= 0
    assert np.all(samples["A"][observed] == np.array(a)[observed])
    for variable in net.variables:
        parents = net.parents[variable]
        index = (samples[variable], *(samples[p] for p in parents))
        assert np.all(net.tables[variable][index] > 0)
