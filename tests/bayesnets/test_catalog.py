"""The catalogue networks load and encode the documented design rules."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import bayesnets
from bayesnets import BayesNet, catalog_names, default_network_name, exact_marginals, load_network
from bayesnets.catalog import catalog_path
from bayesnets.errors import CatalogError

SYSTEM_IDS = {"post_top_led", "street_led_small", "street_led_medium", "road_led_large", "road_hps"}
FIELDS = {
    "street_class",
    "lanes",
    "width",
    "has_median",
    "oneway",
    "lit",
    "mounting_height",
    "arrangement",
    "spacing_ratio",
    "arm_length",
    "setback",
    "tilt",
    "system_id",
}


@pytest.fixture(params=["europe", "north_america", "generic", "east_asia"])
def net(request: pytest.FixtureRequest) -> BayesNet:
    return load_network(request.param)


def _p(net: BayesNet, variable: str, state: str, **parents: str) -> float:
    index = [net.states[variable].index(state)]
    index += [net.states[p].index(parents[p]) for p in net.parents[variable]]
    return float(net.tables[variable][tuple(index)])


def test_catalogue_lists_networks_and_default() -> None:
    assert {"europe", "north_america"} <= set(catalog_names())
    assert default_network_name() == "europe"
    assert load_network().name == "europe"
    with pytest.raises(CatalogError, match="east_asia, europe, generic, helsinki, north_america"):
        load_network("atlantis")


def test_bindings_and_states(net: BayesNet) -> None:
    assert {b.field for b in net.bindings.values()} == FIELDS
    assert net.field_of("WIDTH_RATIO") is None
    assert set(net.states["SYSTEM"]) == SYSTEM_IDS
    assert set(net.states["ARRANGEMENT"]) == {"single_sided", "staggered", "opposite", "central"}
    ratios = [float(s) for s in net.states["SPACING_RATIO"]]
    assert min(ratios) >= 2.5 and max(ratios) <= 4.0  # spacing 2.5-4 x mounting height
    net.to_pgmpy()  # pgmpy accepts the CPDs (check_model)


def test_width_ratio_is_width_over_mounting_height(net: BayesNet) -> None:
    width = net.bindings["WIDTH"]
    for wi, w in enumerate(width.numbers):
        for hi, h in enumerate(float(s) for s in net.states["MOUNTING_HEIGHT"]):
            column = net.tables["WIDTH_RATIO"][:, wi, hi]
            expected = "le1" if w / h <= 1 else ("1to1.5" if w / h <= 1.5 else "gt1.5")
            assert column[net.states["WIDTH_RATIO"].index(expected)] == 1.0


def test_arrangement_follows_width_to_height_rule(net: BayesNet) -> None:
    # One-sided when width <= height, staggered at 1-1.5x, opposite above 1.5x, central on
    # divided roads (the road-lighting arrangement rule cited in bayesnets/catalog/README.md;
    # Chuang 2011 Fig. 10 for the table layout).
    most_likely = {
        ("F", "le1"): "single_sided",
        ("F", "1to1.5"): "staggered",
        ("F", "gt1.5"): "opposite",
        ("T", "le1"): "central",
        ("T", "1to1.5"): "central",
        ("T", "gt1.5"): "central",
    }
    for (median, ratio), arrangement in most_likely.items():
        probabilities = {
            state: _p(net, "ARRANGEMENT", state, HAS_MEDIAN=median, WIDTH_RATIO=ratio)
            for state in net.states["ARRANGEMENT"]
        }
        assert max(probabilities, key=lambda s: probabilities[s]) == arrangement
        if median == "F":
            assert probabilities["central"] == 0.0
        if ratio == "gt1.5":
            assert probabilities["single_sided"] == 0.0


def test_wide_divided_road_never_single_sided_at_5m(net: BayesNet) -> None:
    n = 3000
    frame = pd.DataFrame(
        {"width": [20.0] * n, "has_median": [True] * n, "mounting_height": [5.0] * n}
    )
    out = bayesnets.sample_frame(net, frame, rng=np.random.default_rng(0))
    assert not (out["arrangement"] == "single_sided").any()
    assert (out["arrangement"] == "central").mean() > 0.3


def test_mounting_height_by_class(net: BayesNet) -> None:
    heights = np.array([float(s) for s in net.states["MOUNTING_HEIGHT"]])
    column = {
        c: net.tables["MOUNTING_HEIGHT"][:, net.states["STREET_CLASS"].index(c)]
        for c in net.states["STREET_CLASS"]
    }
    assert column["path"][heights > 6].sum() == 0  # footways 4.5-6 m
    assert column["motorway"][heights < 10].sum() == 0  # wide roads 10-12 m
    assert column["arterial"][heights < 8].sum() == 0
    mean = {c: float(column[c] @ heights) for c in column}
    assert mean["path"] < mean["local"] < mean["collector"] < mean["arterial"] < mean["motorway"]
    assert 8 <= mean["collector"] <= 10  # narrow traffic streets 8-10 m


def test_systems_match_mounting_height(net: BayesNet) -> None:
    for state in net.states["MOUNTING_HEIGHT"]:
        height = float(state)
        column = dict(
            zip(
                net.states["SYSTEM"],
                net.tables["SYSTEM"][:, net.states["MOUNTING_HEIGHT"].index(state)],
                strict=True,
            )
        )
        if height <= 5:
            assert column["post_top_led"] == 1.0
        if height >= 10:
            assert column["post_top_led"] == 0.0 and column["street_led_small"] == 0.0
        if height < 10:
            assert column["road_hps"] == 0.0 and column["road_led_large"] == 0.0
    post_top = net.states["SYSTEM"].index("post_top_led")
    assert net.tables["ARM_LENGTH"][net.states["ARM_LENGTH"].index("0"), post_top] == 1.0


def test_north_america_has_more_high_pressure_sodium() -> None:
    share = {
        name: exact_marginals(load_network(name), {}, ["SYSTEM"])["SYSTEM"]
        for name in ("europe", "north_america")
    }
    hps = load_network("europe").states["SYSTEM"].index("road_hps")
    assert share["north_america"][hps] > 2 * share["europe"][hps]


# CJJ 45-2015 (Standard for lighting design of urban road), cut-off luminaires: least
# mounting height H per effective road width W_eff for each arrangement, H >= k W_eff, i.e.
# W_eff / H <= 1 / k; spacing S <= 3 H (semi-cut-off: k = 1.2, 0.8, 0.6 and S <= 3.5 H).
CJJ_45_CUT_OFF_K = {"single_sided": 1.0, "staggered": 0.7, "opposite": 0.5}
# Lower bound of W / H in each WIDTH_RATIO class.
RATIO_CLASS_LOWER = {"le1": 0.0, "1to1.5": 1.0, "gt1.5": 1.5}


def test_east_asia_follows_the_cjj_45_arrangement_table() -> None:
    """README (east_asia): an arrangement has weight only where the CJJ 45 rule can hold."""
    net = load_network("east_asia")
    for median in ("F", "T"):
        for ratio, lower in RATIO_CLASS_LOWER.items():
            for arrangement, k in CJJ_45_CUT_OFF_K.items():
                p = _p(net, "ARRANGEMENT", arrangement, HAS_MEDIAN=median, WIDTH_RATIO=ratio)
                # some W / H of the class meets H >= k W_eff, or the arrangement gets none
                assert p == 0.0 or lower < 1.0 / k, (median, ratio, arrangement)
    # Concrete streets (W taken as W_eff): 14 m road, 10 m poles (W / H = 1.4 < 1 / 0.7)
    # without median: staggered or opposite, never single-sided; 10 m road with 12 m poles:
    # mostly single-sided; 21 m road with 8 m poles (2.6): opposite, or central on a median.
    frame = pd.DataFrame(
        {
            "width": [14.0] * 1000 + [10.0] * 1000 + [21.0] * 2000,
            "mounting_height": [10.0] * 1000 + [12.0] * 1000 + [8.0] * 2000,
            "has_median": [False] * 3000 + [True] * 1000,
        }
    )
    out = bayesnets.sample_frame(net, frame, rng=np.random.default_rng(45))
    a = out["arrangement"].to_numpy()
    assert set(a[:1000]) == {"staggered", "opposite"}
    assert (a[:1000] == "staggered").mean() > 0.5
    assert (a[1000:2000] == "single_sided").mean() > 0.6
    assert set(a[2000:3000]) == {"opposite"}
    assert set(a[3000:]) == {"opposite", "central"} and (a[3000:] == "central").mean() > 0.5


def test_east_asia_spacing_within_cjj_45_limits() -> None:
    """Cut-off (LED) S <= 3 H for most poles, semi-cut-off S <= 3.5 H for nearly all."""
    net = load_network("east_asia")
    ratios = np.array([float(s) for s in net.states["SPACING_RATIO"]])
    for arrangement in net.states["ARRANGEMENT"]:
        column = net.tables["SPACING_RATIO"][:, net.states["ARRANGEMENT"].index(arrangement)]
        assert column[ratios <= 3.0].sum() >= 0.75, arrangement
        assert column[ratios <= 3.5].sum() >= 0.95, arrangement
    # LED share (README, [J]): more HPS than europe, less than north_america
    hps = net.states["SYSTEM"].index("road_hps")
    share = {
        name: exact_marginals(load_network(name), {}, ["SYSTEM"])["SYSTEM"][hps]
        for name in ("europe", "east_asia", "north_america")
    }
    assert share["europe"] < share["east_asia"] < share["north_america"]


def test_generic_is_the_mean_of_europe_and_north_america() -> None:
    """README: every generic table is the mean of the two conditional probability tables."""
    generic, europe, america = (load_network(n) for n in ("generic", "europe", "north_america"))
    assert generic.states == europe.states == america.states
    assert generic.parents == europe.parents
    for variable, table in generic.tables.items():
        np.testing.assert_allclose(
            table,
            (europe.tables[variable] + america.tables[variable]) / 2,
            atol=1e-5,  # weights are written to 6 significant digits (percent)
            err_msg=variable,
        )
    hps = europe.states["SYSTEM"].index("road_hps")
    share = {
        name: exact_marginals(net, {}, ["SYSTEM"])["SYSTEM"][hps]
        for name, net in (("generic", generic), ("europe", europe), ("north_america", america))
    }
    assert share["europe"] < share["generic"] < share["north_america"]


def test_readme_documents_every_table() -> None:
    readme = (Path(bayesnets.__file__).parent / "catalog" / "README.md").read_text()
    for name in catalog_names():
        for table in catalog_path(name).glob("*.csv"):
            assert table.stem in readme, f"{name}/{table.name} has no source line"
