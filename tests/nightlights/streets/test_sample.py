"""Stage ``streets sample`` on hand-made layers (Chuang 2011, Sec. 3.3)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pyogrio
import pytest

from bayesnets.errors import CatalogError, ImpossibleEvidenceError
from nightlights.errors import InputError
from nightlights.streets._sample import fill_lighting, lighting_summary, sample
from nightlights.streets.schema import (
    ARRANGEMENTS,
    LIGHTING_FIELDS,
    STREET_FIELDS,
    observed_field,
)
from tests.nightlights.streets.conftest import normalized_layer, write_normalized

ROWS = [
    {"street_class": "local", "lanes": 2, "lit": True},
    {"street_class": "arterial", "width": 21.0, "has_median": True},
    {"street_class": "path"},
    {},
    {"street_class": "collector", "lanes": 5, "oneway": False},  # 5 -> nearest state
]


def test_fill_lighting_keeps_observed_and_fills_the_rest() -> None:
    streets = normalized_layer(ROWS)
    out = fill_lighting(streets, "europe", rng=np.random.default_rng(0))
    for name in (*STREET_FIELDS, *LIGHTING_FIELDS, "spacing_ratio"):
        assert out[name].notna().all(), name
    for i, row in enumerate(ROWS):
        for name, value in row.items():
            assert out[name].iloc[i] == value  # observed values untouched (lanes 5 too)
            assert out[observed_field(name)].iloc[i]
    assert not out["width_observed"].iloc[0]
    assert set(out["arrangement"]) <= set(ARRANGEMENTS)
    np.testing.assert_allclose(out["spacing"], out["spacing_ratio"] * out["mounting_height"])
    assert out["spacing_ratio"].between(2.5, 4.0).all()
    assert out.loc[2, "mounting_height"] <= 6.0  # footway poles 4.5-6 m
    assert out.loc[1, "arrangement"] != "single_sided"
    assert out.crs == streets.crs and out.geometry.equals(streets.geometry)


def test_fill_lighting_is_deterministic_under_seed() -> None:
    streets = normalized_layer(ROWS * 20)
    first = fill_lighting(streets, rng=np.random.default_rng(5))
    again = fill_lighting(streets, rng=np.random.default_rng(5))
    pd.testing.assert_frame_equal(
        pd.DataFrame(first.drop(columns="geometry")), pd.DataFrame(again.drop(columns="geometry"))
    )


def test_empty_layer_gives_empty_layer_with_columns() -> None:
    out = fill_lighting(normalized_layer([]), rng=np.random.default_rng(0))
    assert len(out) == 0
    assert {*STREET_FIELDS, *LIGHTING_FIELDS, "spacing_ratio"} <= set(out.columns)


def test_sample_streets_end_to_end(tmp_path: Path) -> None:
    src, dst = tmp_path / "norm.gpkg", tmp_path / "lit.gpkg"
    write_normalized(normalized_layer(ROWS * 10), src)
    assert sample(src, dst, network="north_america", seed=3).path == dst
    info = pyogrio.read_info(dst, layer="streets")
    types = dict(zip(info["fields"], info["dtypes"], strict=True))
    assert types["lanes"] == "int64" and types["mounting_height"] == "float64"
    assert types["lit"] == "bool" and types["system_id"] == "object"
    out = gpd.read_file(dst)
    assert out.crs.to_epsg() == 3067 and len(out) == 50
    summary = lighting_summary(out)
    assert sum(summary["arrangement"].values()) == summary["lit"]["lit"]
    again = tmp_path / "again.gpkg"
    sample(src, again, network="north_america", seed=3)
    pd.testing.assert_frame_equal(
        pd.DataFrame(gpd.read_file(again).drop(columns="geometry")),
        pd.DataFrame(out.drop(columns="geometry")),
    )


def test_sample_streets_empty_layer(tmp_path: Path) -> None:
    src, dst = tmp_path / "empty.gpkg", tmp_path / "out.gpkg"
    layer = normalized_layer(ROWS).iloc[:0]
    write_normalized(layer, src)
    sample(src, dst, seed=0)
    out = gpd.read_file(dst)
    assert len(out) == 0 and "system_id" in out.columns


def test_impossible_evidence_leaves_no_output(tmp_path: Path) -> None:
    # A divided 21 m road cannot be single-sided at 5 m (europe ARRANGEMENT table); the
    # lighting fields are given as observed evidence.
    layer = normalized_layer([{"street_class": "local", "width": 21.0, "has_median": True}] * 3)
    layer["mounting_height"] = 5.0
    layer[observed_field("mounting_height")] = True
    layer["arrangement"] = "single_sided"
    layer[observed_field("arrangement")] = True
    src, dst = tmp_path / "bad.gpkg", tmp_path / "out.gpkg"
    write_normalized(layer, src)
    with pytest.raises(ImpossibleEvidenceError, match=r"bad\.gpkg.*3 record\(s\): way/0"):
        sample(src, dst, seed=0)
    assert not dst.exists() and list(tmp_path.iterdir()) == [src]
    with pytest.warns(UserWarning, match="relaxed"):
        sample(src, dst, seed=0, on_conflict="relax")
    assert dst.exists()


def test_unknown_network_lists_catalogue(tmp_path: Path) -> None:
    src = tmp_path / "s.gpkg"
    write_normalized(normalized_layer(ROWS), src)
    with pytest.raises(CatalogError, match="europe, generic, helsinki, north_america"):
        sample(src, tmp_path / "o.gpkg", network="mars")


def test_geographic_input_is_refused(tmp_path: Path) -> None:
    src = tmp_path / "geo.gpkg"
    write_normalized(normalized_layer(ROWS).to_crs(4326), src)
    with pytest.raises(InputError, match="projected CRS"):
        sample(src, tmp_path / "o.gpkg")


def test_pure_functions_take_the_network_for_where_the_layer_lies() -> None:
    helsinki = normalized_layer(ROWS)  # EPSG:3067, Helsinki
    assert (fill_lighting(helsinki, rng=np.random.default_rng(0))["network"] == "europe").all()
    # the same layer moved to New York (UTM 18N)
    new_york = helsinki.copy()
    new_york["geometry"] = gpd.GeoSeries.from_xy([583000.0] * len(ROWS), [4507000.0] * len(ROWS))
    new_york["geometry"] = new_york.geometry.buffer(1.0).boundary
    new_york = new_york.set_crs("EPSG:32618", allow_override=True)
    out = fill_lighting(new_york, rng=np.random.default_rng(0))
    assert (out["network"] == "north_america").all()
    # a table without a CRS has no location: the catalogue default
    table = pd.DataFrame(helsinki.drop(columns="geometry"))
    assert (fill_lighting(table, rng=np.random.default_rng(0))["network"] == "europe").all()
    # an explicit network wins
    assert (
        fill_lighting(new_york, "europe", rng=np.random.default_rng(0))["network"] == "europe"
    ).all()
