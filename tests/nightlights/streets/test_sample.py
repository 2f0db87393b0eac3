"""Stage ``streets sample`` and ``streets fit`` on hand-made layers (Chuang 2011, Sec. 3.3)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pyogrio
import pytest
import shapely

from bayesnets import load_network, read_network
from bayesnets.errors import CatalogError, ImpossibleEvidenceError
from nightlights.errors import InputError, OutputError
from nightlights.io import write_gpkg
from nightlights.streets.fit import fit_lighting_network, fit_streets
from nightlights.streets.sample import fill_lighting, lighting_summary, sample_streets
from nightlights.streets.schema import (
    ARRANGEMENTS,
    LIGHTING_FIELDS,
    STREET_FIELDS,
    observed_field,
)


def _write(layer: gpd.GeoDataFrame, path: Path) -> Path:
    """Write like ``streets normalize`` does: explicit (nullable) field types."""
    schema = {"source_id": "str", **STREET_FIELDS}
    schema |= {observed_field(name): "bool" for name in STREET_FIELDS}
    return write_gpkg(layer, path, layer="streets", schema=schema)


def _layer(rows: list[dict]) -> gpd.GeoDataFrame:
    """Normalised streets in EPSG:3067; a field is observed where it is given."""
    n = len(rows)
    data: dict[str, list] = {"source_id": [f"way/{i}" for i in range(n)]}
    for name in STREET_FIELDS:
        data[name] = [row.get(name) for row in rows]
        data[observed_field(name)] = [name in row for row in rows]
    lines = [
        shapely.LineString([(385000 + 50 * i, 6672000), (385000 + 50 * i, 6672120)])
        for i in range(n)
    ]
    return gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067")


ROWS = [
    {"street_class": "local", "lanes": 2, "lit": True},
    {"street_class": "arterial", "width": 21.0, "has_median": True},
    {"street_class": "path"},
    {},
    {"street_class": "collector", "lanes": 5, "oneway": False},  # 5 -> nearest state
]


def test_fill_lighting_keeps_observed_and_fills_the_rest() -> None:
    streets = _layer(ROWS)
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
    streets = _layer(ROWS * 20)
    first = fill_lighting(streets, rng=np.random.default_rng(5))
    again = fill_lighting(streets, rng=np.random.default_rng(5))
    pd.testing.assert_frame_equal(
        pd.DataFrame(first.drop(columns="geometry")), pd.DataFrame(again.drop(columns="geometry"))
    )


def test_empty_layer_gives_empty_layer_with_columns() -> None:
    out = fill_lighting(_layer([]), rng=np.random.default_rng(0))
    assert len(out) == 0
    assert {*STREET_FIELDS, *LIGHTING_FIELDS, "spacing_ratio"} <= set(out.columns)


def test_sample_streets_end_to_end(tmp_path: Path) -> None:
    src, dst = tmp_path / "norm.gpkg", tmp_path / "lit.gpkg"
    _write(_layer(ROWS * 10), src)
    assert sample_streets(src, dst, network="north_america", seed=3) == dst
    info = pyogrio.read_info(dst, layer="streets")
    types = dict(zip(info["fields"], info["dtypes"], strict=True))
    assert types["lanes"] == "int64" and types["mounting_height"] == "float64"
    assert types["lit"] == "bool" and types["system_id"] == "object"
    out = gpd.read_file(dst)
    assert out.crs.to_epsg() == 3067 and len(out) == 50
    summary = lighting_summary(out)
    assert sum(summary["arrangement"].values()) == summary["lit"]["lit"]
    again = tmp_path / "again.gpkg"
    sample_streets(src, again, network="north_america", seed=3)
    pd.testing.assert_frame_equal(
        pd.DataFrame(gpd.read_file(again).drop(columns="geometry")),
        pd.DataFrame(out.drop(columns="geometry")),
    )


def test_sample_streets_empty_layer(tmp_path: Path) -> None:
    src, dst = tmp_path / "empty.gpkg", tmp_path / "out.gpkg"
    layer = _layer(ROWS).iloc[:0]
    _write(layer, src)
    sample_streets(src, dst, seed=0)
    out = gpd.read_file(dst)
    assert len(out) == 0 and "system_id" in out.columns


def test_impossible_evidence_leaves_no_output(tmp_path: Path) -> None:
    # A divided 21 m road cannot be single-sided at 5 m (europe ARRANGEMENT table); the
    # lighting fields are given as observed evidence.
    layer = _layer([{"street_class": "local", "width": 21.0, "has_median": True}] * 3)
    layer["mounting_height"] = 5.0
    layer[observed_field("mounting_height")] = True
    layer["arrangement"] = "single_sided"
    layer[observed_field("arrangement")] = True
    src, dst = tmp_path / "bad.gpkg", tmp_path / "out.gpkg"
    _write(layer, src)
    with pytest.raises(ImpossibleEvidenceError, match=r"bad\.gpkg.*3 record\(s\): way/0"):
        sample_streets(src, dst, seed=0)
    assert not dst.exists() and list(tmp_path.iterdir()) == [src]
    with pytest.warns(UserWarning, match="relaxed"):
        sample_streets(src, dst, seed=0, on_conflict="relax")
    assert dst.exists()


def test_unknown_network_lists_catalogue(tmp_path: Path) -> None:
    src = tmp_path / "s.gpkg"
    _write(_layer(ROWS), src)
    with pytest.raises(CatalogError, match="europe, north_america"):
        sample_streets(src, tmp_path / "o.gpkg", network="mars")


def test_geographic_input_is_refused(tmp_path: Path) -> None:
    src = tmp_path / "geo.gpkg"
    _write(_layer(ROWS).to_crs(4326), src)
    with pytest.raises(InputError, match="projected CRS"):
        sample_streets(src, tmp_path / "o.gpkg")


def test_fit_recovers_arrangement_table(tmp_path: Path) -> None:
    # Synthetic layer sampled from a known network, with every lighting field known.
    truth = load_network("north_america")
    n = 20_000
    rng = np.random.default_rng(11)
    streets = _layer([{}] * n)
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
    _write(sampled.iloc[:2000], src)
    fit_streets(src, out, network="north_america", prior=2.0)
    net = read_network(out)
    assert net.name == "fitted_net" and set(net.variables) == set(truth.variables)
    with pytest.raises(OutputError, match="not an empty folder"):
        fit_streets(src, out)
