"""Stage ``streets fit``: tables recovered from a layer sampled from a known network."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bayesnets import load_network, read_network
from nightlights.errors import OutputError
from nightlights.streets._fit import fit, fit_lighting_network
from nightlights.streets._sample import fill_lighting
from nightlights.streets.schema import STREET_FIELDS, observed_field
from tests.nightlights.streets.conftest import normalized_layer, write_normalized


def test_fit_recovers_arrangement_table(tmp_path: Path) -> None:
    # Synthetic layer sampled from a known network, with every lighting field known.
    truth = load_network("north_america")
    n = 20_000
    rng = np.random.default_rng(11)
    streets = normalized_layer([{}] * n)
    sampled = fill_lighting(streets, truth, rng=rng)
    for name in STREET_FIELDS:
        sampled[observed_field(name)] = True
    fitted = fit_lighting_network(sampled, "europe", prior=1.0)
    # Compare the recovered tables where the synthetic layer has data: counts per parent
    # combination n_u, tolerance 4 binomial standard errors + prior pull 1/n_u.
    for variable in ("MOUNTING_HEIGHT", "SYSTEM", "SPACING_RATIO", "LIT"):
        true = truth.tables[variable]
        parent = truth.parents[variable][0]
        states = truth.states[parent]
        field = truth.field_of(parent)
        values = (
            sampled[field]
            .astype(str)
            .map(lambda v, s=states: s.index(v) if v in s else s.index(f"{float(v):g}"))
        )
        counts = np.bincount(values, minlength=len(states)).astype(float)
        seen = counts > 200
        tolerance = 4 * np.sqrt(true * (1 - true) / np.maximum(counts, 1)) + 1 / np.maximum(
            counts, 1
        )
        diff = np.abs(fitted.tables[variable] - true)
        assert np.all(diff[:, seen] <= tolerance[:, seen] + 1e-12), variable
    out = tmp_path / "fitted_net"
    src = tmp_path / "known.gpkg"
    write_normalized(sampled.iloc[:2000], src)
    fit(src, out, network="north_america", prior=2.0)
    net = read_network(out)
    assert net.name == "fitted_net" and set(net.variables) == set(truth.variables)
    with pytest.raises(OutputError, match="not an empty folder"):
        fit(src, out)
