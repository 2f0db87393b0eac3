"""Fitting tables from data recovers a known network."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from bayesnets import (
    build_network,
    decode_samples,
    fit_network,
    likelihood_weighted_sample,
    load_network,
    parse_table,
    read_network,
    write_network,
)
from bayesnets.errors import BayesNetError, FitWarning
from tests.bayesnets.conftest import TOY_CONFIG, TOY_TABLES

FULL_CONFIG = TOY_CONFIG + '\n[variables.B]\nfield = "b"\nkind = "category"\n'


def _full_toy():
    return build_network(
        [parse_table(text, source=name) for name, text in TOY_TABLES.items()],
        tomllib.loads(FULL_CONFIG),
    )


def test_fit_recovers_tables_within_sampling_error(tmp_path: Path) -> None:
    truth = _full_toy()
    n = 20_000
    codes = likelihood_weighted_sample(truth, {}, size=n, rng=np.random.default_rng(7))
    frame = decode_samples(truth, codes)
    # A flat base network: the estimate must come from the data, not the prior.
    flat = build_network(
        [
            parse_table(text.replace(",0\n", ",1\n"), source=name)
            for name, text in TOY_TABLES.items()
        ],
        tomllib.loads(FULL_CONFIG),
    )
    fitted = fit_network(frame, flat, prior=1.0)
    for variable in truth.variables:
        true = truth.tables[variable]
        parent_counts = _parent_counts(truth, codes, variable)
        # 4 binomial standard errors per parent combination plus the prior's pull 1/n_u.
        tolerance = 4 * np.sqrt(true * (1 - true) / parent_counts) + 1.0 / parent_counts
        assert np.all(np.abs(fitted.tables[variable] - true) <= tolerance + 1e-12), variable
    copy = read_network(write_network(fitted, tmp_path / "fitted"))
    np.testing.assert_allclose(copy.tables["C"], fitted.tables["C"], rtol=1e-5)


def _parent_counts(net, codes, variable):
    parents = net.parents[variable]
    shape = net.tables[variable].shape
    if not parents:
        return np.full(shape, len(codes[variable]), dtype=float)
    index = np.ravel_multi_index([codes[p] for p in parents], shape[1:])
    counts = np.bincount(index, minlength=int(np.prod(shape[1:]))).reshape(shape[1:])
    return np.broadcast_to(counts, shape).astype(float)


def test_prior_zero_is_maximum_likelihood_and_keeps_unseen_columns() -> None:
    truth = _full_toy()
    frame = decode_samples(
        truth,
        likelihood_weighted_sample(truth, {"A": np.zeros(500, int)}, rng=np.random.default_rng(1)),
    )
    with pytest.warns(FitWarning, match="without data keep the base table"):
        fitted = fit_network(frame, truth, prior=0.0)
    a1 = truth.states["A"].index("a1")
    np.testing.assert_array_equal(fitted.tables["B"][:, a1], truth.tables["B"][:, a1])
    counts = (frame["b"] == "b0").mean()
    assert fitted.tables["B"][0, 0] == pytest.approx(counts)


def test_hidden_tables_are_kept_with_a_warning() -> None:
    toy = _full_toy()
    frame = decode_samples(
        toy, likelihood_weighted_sample(toy, {}, size=200, rng=np.random.default_rng(2))
    )
    hidden = build_network(
        [parse_table(text, source=name) for name, text in TOY_TABLES.items()],
        tomllib.loads(TOY_CONFIG),
    )
    with pytest.warns(FitWarning, match="B, C"):
        fitted = fit_network(frame.drop(columns="b"), hidden)
    np.testing.assert_array_equal(fitted.tables["C"], hidden.tables["C"])
    with pytest.raises(BayesNetError, match="prior"):
        fit_network(frame, hidden, prior=-1)


def test_catalogue_fit_derives_the_deterministic_width_ratio() -> None:
    # ARRANGEMENT's parent WIDTH_RATIO is hidden but a 0/1 function of WIDTH and
    # MOUNTING_HEIGHT, so ARRANGEMENT can still be estimated.
    net = load_network("europe")
    codes = likelihood_weighted_sample(net, {}, size=20_000, rng=np.random.default_rng(3))
    frame = decode_samples(net, codes)
    fitted = fit_network(frame, net, prior=1.0)
    counts = _parent_counts(net, codes, "ARRANGEMENT")
    true = net.tables["ARRANGEMENT"]
    tolerance = 4 * np.sqrt(true * (1 - true) / np.maximum(counts, 1)) + 1 / np.maximum(counts, 1)
    assert np.all(np.abs(fitted.tables["ARRANGEMENT"] - true) <= tolerance + 1e-12)
