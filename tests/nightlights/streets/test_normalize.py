"""Tests of ``streets normalize`` (Chuang 2011, Sec. 3.2)."""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from nightlights.errors import CRSError, DataQualityWarning, EmptyInputError, MappingError
from nightlights.streets._mapping import (
    builtin_mappings,
    load_mapping,
    parse_length,
    parse_mapping,
    parse_packed_tags,
)
from nightlights.streets._normalize import normalize, normalize_streets
from nightlights.streets.schema import STREET_FIELDS, observed_field

LINE = shapely.LineString([(0, 0), (100, 0)])


@pytest.mark.parametrize(
    ("text", "metres"),
    [
        ("7", 7.0),
        ("7 m", 7.0),
        ("7.5m", 7.5),
        ("3,5", 3.5),
        (".5", 0.5),
        ("23'", 7.0104),
        ("23 ft", 7.0104),
        ("7'6\"", 2.286),
        ("6;8", 6.0),
        ("350 cm", 3.5),
        (12, 12.0),
    ],
)
def test_parse_length_units(text: object, metres: float) -> None:
    assert parse_length(text) == pytest.approx(metres, rel=1e-9)


@pytest.mark.parametrize("text", ["wide", "7 parsecs", "", None, float("nan")])
def test_parse_length_unparseable_is_nan(text: object) -> None:
    assert np.isnan(parse_length(text))


@given(st.floats(min_value=0.01, max_value=1000, allow_nan=False))
def test_parse_length_feet_is_0_3048_metres(feet: float) -> None:
    assert parse_length(f"{feet} ft") == pytest.approx(feet * 0.3048, rel=1e-6)
    assert parse_length(feet, default_unit="ft") == pytest.approx(feet * 0.3048, rel=1e-6)


def test_parse_packed_tags_handles_escaped_quotes() -> None:
    text = '"lanes"=>"2","name:fi"=>"Katu \\"A\\"","lit"=>"yes"'
    assert parse_packed_tags(text) == {"lanes": "2", "name:fi": 'Katu "A"', "lit": "yes"}
    assert parse_packed_tags(None) == {}


def _osm_columns() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {
            "osm_id": ["1", "2", "3", "4", "5"],
            "highway": ["primary", "residential", "footway", "bus_stop", "footway"],
            "lanes": ["4", None, None, None, None],
            "width": ["14 m", None, "2.5", None, None],
            "oneway": ["yes", "-1", None, None, None],
            "lit": ["yes", "no", "24/7", None, None],
            "footway": [None, None, None, None, "sidewalk"],
        },
        geometry=[LINE] * 5,
        crs="EPSG:3067",
    )


def test_osm_tags_as_columns() -> None:
    frame, report = normalize_streets(_osm_columns(), load_mapping("osm"))
    assert list(frame["source_id"]) == ["1", "2", "3"]
    assert list(frame["street_class"]) == ["arterial", "local", "path"]
    assert frame["lanes"].iloc[0] == 4 and frame["lanes"].isna().iloc[1]
    assert frame["width"].iloc[0] == 14.0 and frame["width"].iloc[2] == 2.5
    assert list(frame["oneway"].iloc[:2]) == [True, True]
    assert list(frame["lit"]) == [True, False, True]
    assert list(frame[observed_field("lanes")]) == [True, False, False]
    assert report.dropped["highway not a street value"] == 1
    assert report.dropped["footway in ['crossing', 'sidewalk']"] == 1
    assert report.observed["lit"] == 3


def test_osm_packed_tags_give_the_same_result_as_columns() -> None:
    columns = _osm_columns()
    packed = columns[["osm_id", "highway", "geometry"]].copy()
    packed["other_tags"] = [
        ",".join(
            f'"{key}"=>"{columns.loc[i, key]}"'
            for key in ("lanes", "width", "oneway", "lit", "footway")
            if pd.notna(columns.loc[i, key])
        )
        for i in columns.index
    ]
    a, _ = normalize_streets(columns, load_mapping("osm"))
    b, _ = normalize_streets(gpd.GeoDataFrame(packed, crs=columns.crs), load_mapping("osm"))
    for name in STREET_FIELDS:
        assert a[name].astype(object).equals(b[name].astype(object)), name


def test_municipal_schema_in_feet() -> None:
    layer = gpd.GeoDataFrame(
        {
            "SEGMENT_ID": [10, 11, 12],
            "ROADCLASS": ["Major Arterial", "Local", "Railroad"],
            "NUM_LANES": [6, 2, 0],
            "PAVE_WIDTH": [72.0, 30.0, 10.0],
            "MEDIAN": ["Y", "N", "N"],
            "ONEWAY": ["B", "FT", "B"],
            "LIGHTING": ["Y", None, "N"],
        },
        geometry=[LINE] * 3,
        crs="EPSG:2227",
    )
    frame, report = normalize_streets(layer, load_mapping("municipal"))
    assert list(frame["source_id"]) == ["10", "11"]
    assert frame["width"].tolist() == pytest.approx([72 * 0.3048, 30 * 0.3048])
    assert frame["has_median"].tolist() == [True, False]
    assert frame["oneway"].tolist() == [False, True]
    assert frame["lit"].iloc[0] and frame["lit"].isna().iloc[1]
    assert report.dropped["ROADCLASS not a street value"] == 1


def test_unknown_values_warn_and_become_missing() -> None:
    layer = _osm_columns().iloc[:2].copy()
    layer["lit"] = ["maybe", "yes"]
    with pytest.warns(DataQualityWarning, match="lit.*'maybe' x1"):
        frame, report = normalize_streets(layer, load_mapping("osm"))
    assert frame["lit"].isna().iloc[0] and not frame[observed_field("lit")].iloc[0]
    assert report.unknown_values["lit"]["maybe"] == 1


def test_geometry_cleaning_explodes_multiparts_and_drops_degenerate() -> None:
    multi = shapely.MultiLineString([[(0, 0), (10, 0)], [(0, 5), (10, 5)]])
    zero = shapely.LineString([(3, 3), (3, 3)])
    point = shapely.Point(1, 1)
    layer = gpd.GeoDataFrame(
        {"osm_id": ["m", "z", "p", "e"], "highway": ["residential"] * 4},
        geometry=[multi, zero, point, shapely.LineString()],
        crs="EPSG:3067",
    )
    frame, report = normalize_streets(layer, load_mapping("osm"))
    assert list(frame["source_id"]) == ["m", "m"]
    assert (frame.geometry.geom_type == "LineString").all()
    assert report.dropped["zero-length line"] == 1
    assert report.dropped["not a line geometry"] == 1
    assert report.dropped["empty or missing geometry"] == 1


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("name = 'x'", "needs a \\[fields"),
        ("[fields.colour]\nsource=['c']\ntype='category'", "not a canonical field"),
        ("[fields.lanes]\nsource=['l']\ntype='complex'", "type 'complex'"),
        (
            "[fields.street_class]\nsource=['c']\ntype='category'\nvalues={A='boulevard'}",
            "unknown classes",
        ),
        ("[fields.width]\nsource=['w']\ntype='length'\ndefault_unit='furlong'", "not a unit"),
        ("[fields = broken", "not valid TOML"),
    ],
)
def test_malformed_mapping_is_a_clear_error(text: str, match: str) -> None:
    with pytest.raises(MappingError, match=match):
        parse_mapping(text, source="test.toml")


def test_builtin_mappings_load() -> None:
    assert {"osm", "municipal"} <= set(builtin_mappings())
    for name in builtin_mappings():
        assert load_mapping(name).rules


def test_unknown_mapping_name(tmp_path) -> None:
    with pytest.raises(MappingError, match="neither a built-in mapping"):
        load_mapping("nowhere")


def test_stage_reads_osm_xml_and_writes_projected_gpkg(data_dir, tmp_path) -> None:
    out = tmp_path / "streets.gpkg"
    report = normalize(
        data_dir / "streets" / "berlin-siegessaeule.osm.gz", out, mapping="osm"
    ).report
    frame = gpd.read_file(out)
    assert len(frame) == report.output_features > 50
    assert frame.crs.to_epsg() == 32633  # UTM 33N for Berlin
    assert set(frame["street_class"]) <= {
        "motorway",
        "arterial",
        "collector",
        "local",
        "service",
        "path",
    }
    assert frame.geometry.length.min() > 0


def test_stage_without_crs_is_an_error_and_writes_nothing(tmp_path) -> None:
    src = tmp_path / "nocrs.geojson"
    gpd.GeoDataFrame({"highway": ["residential"]}, geometry=[LINE]).to_file(src)
    out = tmp_path / "out.gpkg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        layer = gpd.read_file(src)
    if layer.crs is not None:  # GeoJSON implies WGS84; use a Shapefile-free path instead
        src = tmp_path / "nocrs.gpkg"
        gpd.GeoDataFrame({"highway": ["residential"]}, geometry=[LINE]).to_file(src)
    with pytest.raises(CRSError, match="no coordinate reference system"):
        normalize(src, out)
    assert not out.exists()
    normalize(src, out, crs="EPSG:3067")
    assert gpd.read_file(out).crs.to_epsg() == 3067


def test_stage_geographic_input_goes_to_utm(tmp_path) -> None:
    src = tmp_path / "wgs84.gpkg"
    gpd.GeoDataFrame(
        {"highway": ["residential"]},
        geometry=[shapely.LineString([(24.94, 60.17), (24.95, 60.17)])],
        crs="EPSG:4326",
    ).to_file(src)
    out = tmp_path / "out.gpkg"
    normalize(src, out)
    frame = gpd.read_file(out)
    assert frame.crs.to_epsg() == 32635
    assert frame.geometry.length.iloc[0] == pytest.approx(555, rel=0.01)


@pytest.mark.parametrize("highways", [[], ["bus_stop", "platform"]])
def test_stage_empty_result_is_an_error(tmp_path, highways: list[str]) -> None:
    src = tmp_path / "in.gpkg"
    gpd.GeoDataFrame(
        {"highway": highways}, geometry=[LINE] * len(highways), crs="EPSG:3067"
    ).to_file(src)
    out = tmp_path / "out.gpkg"
    with pytest.raises(EmptyInputError):
        normalize(src, out)
    assert not out.exists()


def test_curved_geometries_are_linearised(tmp_path) -> None:
    """GDAL curve types (CircularString, CompoundCurve) arrive as LineStrings."""
    import struct

    import pyogrio

    # A half circle of radius 50 m as ISO WKB CircularString (type 8) and inside a
    # CompoundCurve (type 9); shapely cannot build curves, so the bytes are written by hand.
    arc = struct.pack("<BII", 1, 8, 3) + struct.pack("<6d", 0, 0, 50, 50, 100, 0)
    compound = struct.pack("<BII", 1, 9, 1) + arc
    src = tmp_path / "curved.gpkg"
    pyogrio.raw.write(
        src,
        geometry=np.array([arc, compound], dtype=object),
        field_data=[np.array(["residential", "primary"])],
        fields=["highway"],
        geometry_type="Unknown",
        crs="EPSG:3067",
        driver="GPKG",
    )
    out = tmp_path / "out.gpkg"
    normalize(src, out)
    frame = gpd.read_file(out)
    assert (frame.geometry.geom_type == "LineString").all()
    assert frame.geometry.length.to_numpy() == pytest.approx([np.pi * 50] * 2, rel=1e-3)
