"""The four street stages: in-memory and file forms give the same product.

An in-memory call (GeoDataFrame in, no ``output``) writes nothing and returns what the file
form returns and writes for the same layer and seed.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from geopandas.testing import assert_geodataframe_equal

from bayesnets import write_network
from nightlights.demo import example_path
from nightlights.errors import InputError
from nightlights.io import read_vector, write_gpkg
from nightlights.streets import (
    FitResult,
    NormalizeResult,
    PlacementOptions,
    PlaceResult,
    SampleResult,
    fill_lighting,
    fit,
    normalize,
    place,
    sample,
)
from nightlights.streets._sample import OUTPUT_SCHEMA
from tests.nightlights.streets.conftest import normalized_layer, write_normalized

ROWS = [
    {"street_class": "local", "lanes": 2, "lit": True},
    {"street_class": "arterial", "width": 21.0, "has_median": True},
    {"street_class": "path"},
    {},
]


def _files(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*"))


def _plain(frame: gpd.GeoDataFrame) -> pd.DataFrame:
    """Attribute values as Python objects, None where missing (dtypes differ on disk)."""
    table = pd.DataFrame(frame.drop(columns=frame.geometry.name)).reset_index(drop=True)
    table = table.astype(object)
    return table.where(table.notna(), None)


def _same_layer(memory: gpd.GeoDataFrame, path: Path, layer: str) -> None:
    """The file at ``path`` holds ``memory``: same columns, values, geometry and CRS."""
    written = gpd.read_file(path, layer=layer)
    assert list(_plain(written).columns) == list(_plain(memory).columns)
    assert written.crs == memory.crs
    pd.testing.assert_frame_equal(_plain(written), _plain(memory))
    assert written.geometry.geom_equals_exact(memory.geometry.reset_index(drop=True), 0).all()


def _osm_layer() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {
            "osm_id": ["1", "2", "3", "4"],
            "highway": ["primary", "residential", "footway", "bus_stop"],
            "lanes": ["4", None, None, None],
            "width": ["14 m", None, "2.5", None],
            "lit": ["yes", "no", None, None],
        },
        geometry=[
            shapely.LineString([(24.940, 60.170), (24.945, 60.170)]),
            shapely.LineString([(24.940, 60.171), (24.940, 60.173)]),
            shapely.MultiLineString([[(24.941, 60.172), (24.942, 60.172)]]),
            shapely.LineString([(24.943, 60.171), (24.944, 60.171)]),
        ],
        crs="EPSG:4326",
    )


def _sampled_layer() -> gpd.GeoDataFrame:
    return fill_lighting(normalized_layer(ROWS * 5), "europe", rng=np.random.default_rng(2))


def test_normalize_in_memory_equals_file_form(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    layer = _osm_layer()
    memory = normalize(layer, target_crs="EPSG:3067")
    assert isinstance(memory, NormalizeResult) and memory.path is None
    assert _files(tmp_path) == []
    src = tmp_path / "raw.gpkg"
    layer.to_file(src)
    written = normalize(src, tmp_path / "out.gpkg", target_crs="EPSG:3067")
    assert written.path == tmp_path / "out.gpkg"
    assert_geodataframe_equal(memory.streets, written.streets)
    assert memory.report == written.report
    _same_layer(memory.streets, written.path, "streets")


def test_normalize_crs_names_the_crs_of_a_layer_without_one() -> None:
    layer = _osm_layer().to_crs("EPSG:3067").set_crs(None, allow_override=True)
    result = normalize(layer, crs="EPSG:3067")
    assert result.streets.crs.to_epsg() == 3067 and result.report.output_features == 3


def test_sample_in_memory_equals_file_form(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    layer = normalized_layer(ROWS * 5)
    memory = sample(layer, network="north_america", seed=4)
    assert isinstance(memory, SampleResult) and memory.path is None
    assert _files(tmp_path) == []
    src = write_normalized(layer, tmp_path / "norm.gpkg")
    written = sample(src, tmp_path / "lit.gpkg", network="north_america", seed=4)
    assert written.path == tmp_path / "lit.gpkg"
    # The file form reads typed fields back (Int64, boolean); values and geometry agree.
    pd.testing.assert_frame_equal(_plain(memory.streets), _plain(written.streets))
    assert memory.streets.geometry.geom_equals_exact(written.streets.geometry, 0).all()
    _same_layer(written.streets, written.path, "streets")


def test_fit_in_memory_equals_file_form(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    layer = _sampled_layer()
    memory = fit(layer, network="europe", prior=2.0, name="known")
    assert isinstance(memory, FitResult) and memory.path is None
    assert memory.network.name == "known"
    assert _files(tmp_path) == []
    src = write_normalized(layer, tmp_path / "known.gpkg")
    before = _files(tmp_path)
    written = fit(src, tmp_path / "known", network="europe", prior=2.0)
    assert written.path == tmp_path / "known" and written.network.name == "known"
    assert _files(tmp_path) != before
    for variable, table in memory.network.tables.items():
        np.testing.assert_array_equal(table, written.network.tables[variable])
    expected = tmp_path / "expected"
    write_network(memory.network, expected)
    files = sorted(path.relative_to(expected) for path in _files(expected))
    assert sorted(path.relative_to(written.path) for path in _files(written.path)) == files
    for name in files:
        assert (written.path / name).read_bytes() == (expected / name).read_bytes(), name


def test_fit_without_output_writes_nothing(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = fit(_sampled_layer(), network="europe")
    assert result.path is None and result.network.name == "europe_fitted"
    assert _files(tmp_path) == []


def test_place_in_memory_equals_file_form(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    layer = _sampled_layer()
    memory = place(layer, seed=9)
    assert isinstance(memory, PlaceResult) and memory.path is None and len(memory.lights)
    assert _files(tmp_path) == []
    src = write_gpkg(layer, tmp_path / "lit.gpkg", layer="streets", schema=OUTPUT_SCHEMA)
    written = place(src, tmp_path / "lights.gpkg", seed=9)
    assert written.path == tmp_path / "lights.gpkg"
    assert_geodataframe_equal(memory.lights, written.lights)
    _same_layer(memory.lights, written.path, "lights")


def test_place_knobs_or_options_not_both() -> None:
    layer = _sampled_layer()
    knobs = place(layer, seed=3, along_jitter=0.1, across_jitter=0.5, merge_fraction=0.4)
    options = PlacementOptions(along_jitter=0.1, across_jitter=0.5, merge_fraction=0.4)
    assert_geodataframe_equal(knobs.lights, place(layer, seed=3, options=options).lights)
    with pytest.raises(InputError, match="given twice"):
        place(layer, seed=3, options=options, along_jitter=0.1)
    with pytest.raises(InputError, match="along_jitter"):
        place(layer, along_jitter=0.3)


def test_results_are_frozen() -> None:
    result = place(_sampled_layer(), seed=0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.path = Path("elsewhere.gpkg")  # type: ignore[misc]


def test_bad_inputs_are_clear_errors() -> None:
    with pytest.raises(InputError, match="names a layer inside a file"):
        normalize(_osm_layer(), layer="lines")
    with pytest.raises(InputError, match="expected a GeoDataFrame or a vector file path"):
        sample(pd.DataFrame({"lanes": [2]}))  # type: ignore[arg-type]


def test_in_memory_chain_gives_the_file_chain_lights(tmp_path: Path) -> None:
    """normalize -> sample -> place on the bundled Helsinki extract, read once."""
    raw = read_vector(example_path())
    streets = normalize(raw, mapping="osm").streets
    lit = sample(streets, seed=7).streets
    lights = place(lit, seed=7).lights
    normalize(example_path(), tmp_path / "norm.gpkg", mapping="osm")
    sample(tmp_path / "norm.gpkg", tmp_path / "lit.gpkg", seed=7)
    from_files = place(tmp_path / "lit.gpkg", tmp_path / "lights.gpkg", seed=7)
    assert len(lights) > 1000
    assert_geodataframe_equal(lights, from_files.lights)
    _same_layer(lights, tmp_path / "lights.gpkg", "lights")
