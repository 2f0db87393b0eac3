"""Field bindings: observed values to states and states back to values."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bayesnets.binding import MISSING, parse_binding
from bayesnets.errors import BindingError, EvidenceError

WIDTH = parse_binding(
    "WIDTH",
    {
        "field": "width",
        "kind": "bins",
        "edges": [0, 4.75, 6.75, math.inf],
        "values": [3.5, 6.0, 10.0],
    },
    ["3.5", "6", "wide"],
    source="network.toml",
)
LANES = parse_binding(
    "LANES",
    {"field": "lanes", "kind": "int", "nearest": True},
    ["1", "2", "4"],
    source="network.toml",
)


def test_bins_encode_by_interval_and_decode_to_representative() -> None:
    codes = WIDTH.encode([0.0, 4.75, 6.0, None, 30.0])
    assert codes.tolist() == [0, 1, 1, MISSING, 2]
    assert WIDTH.decode(np.array([0, 2])).tolist() == [3.5, 10.0]
    with pytest.raises(EvidenceError, match=r"field 'width'.*r7: -1.0.*\[0.0, inf\)"):
        WIDTH.encode([1.0, -1.0], labels=["r6", "r7"])


def test_int_nearest_and_exact() -> None:
    assert LANES.encode(pd.Series([1, 3, 5, np.nan])).tolist() == [0, 1, 2, MISSING]
    exact = parse_binding("LANES", {"field": "lanes", "kind": "int"}, ["1", "2"], source="n.toml")
    with pytest.raises(EvidenceError, match="nearest"):
        exact.encode([3])
    assert LANES.decode(np.array([2])).dtype == np.int64


def test_bool_and_category() -> None:
    lit = parse_binding("LIT", {"field": "lit", "kind": "bool"}, ["T", "F"], source="n")
    assert lit.encode([True, False, None, "yes", np.True_]).tolist() == [0, 1, -1, 0, 0]
    assert lit.decode(np.array([1, 0])).tolist() == [False, True]
    kind = parse_binding("K", {"field": "k"}, ["x", "y"], source="n")
    with pytest.raises(EvidenceError, match=r"'z'.*expected one of \['x', 'y'\]"):
        kind.encode(["x", "z"])


def test_malformed_bindings() -> None:
    with pytest.raises(BindingError, match="increasing edges"):
        parse_binding("W", {"field": "w", "kind": "bins", "edges": [0, 1]}, ["a", "b"], source="n")
    with pytest.raises(BindingError, match="kind 'colour'"):
        parse_binding("W", {"field": "w", "kind": "colour"}, ["a"], source="n")
    with pytest.raises(BindingError, match="bool variable"):
        parse_binding("W", {"field": "w", "kind": "bool"}, ["yes", "no"], source="n")


@pytest.mark.parametrize(
    ("spec", "states", "words"),
    [
        ({"kind": "bins", "edges": ["a", "b", "c"]}, ["x", "y"], "edges = ['a', 'b', 'c']"),
        ({"kind": "bins", "edges": 3}, ["x"], "edges = 3; expected a list of numbers"),
        ({"kind": "bins", "edges": [0, float("nan"), 2]}, ["x", "y"], "increasing edges"),
        ({"kind": "bins", "edges": [0, 1], "values": ["1"]}, ["x"], "values = ['1']"),
        ({"kind": "bins", "edges": [0, 1], "values": [float("inf")]}, ["x"], "finite numbers"),
        ({"kind": "float"}, ["1", "nan"], "state 'nan' is not a finite number"),
        ({"kind": "int"}, ["1", "inf"], "state 'inf' is not a finite number"),
    ],
)
def test_non_numeric_or_non_finite_numbers_are_binding_errors(spec, states, words) -> None:
    with pytest.raises(BindingError) as info:
        parse_binding("W", {"field": "w", **spec}, states, source="net.toml")
    assert str(info.value).startswith("net.toml, [variables.W]: ") and words in str(info.value)


@given(st.lists(st.floats(0, 1e4, allow_nan=False), min_size=1, max_size=50))
def test_bins_round_trip_lands_in_the_observed_bin(widths: list[float]) -> None:
    codes = WIDTH.encode(widths)
    again = WIDTH.encode(WIDTH.decode(codes))
    np.testing.assert_array_equal(codes, again)
