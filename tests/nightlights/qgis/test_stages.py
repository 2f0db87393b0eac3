"""The plugin's reading of the stage description and its command lines (standard library only, so
it runs here as in QGIS's Python): enum entries, booleans both ways, points and their CRS, a
vector input's layer, repeatable options, a missing required value. (Every real stage's
command line parsed by the command itself: tests/cli/test_qgis_plugin.py.)"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nightlights.qgis.plugin.stages import (
    COMMAND_DEFAULT,
    STAGES_FILE,
    command_line,
    enum_default,
    enum_options,
    enum_value,
    read_stages,
    split_values,
)


def _option(name: str, kind: str, **fields: Any) -> dict[str, Any]:
    entry = {
        "name": name.upper().replace("-", "_"),
        "flag": f"--{name}",
        "type": kind,
        "required": False,
        "default": None,
        "multiple": False,
    }
    return {**entry, **fields}


STAGE = {
    "command": ["sky", "observers"],
    "overwrite": True,
    "parameters": [
        {"name": "EMISSION", "flag": None, "type": "raster", "required": True},
        {
            "name": "OBSERVERS",
            "flag": None,
            "type": "vector",
            "required": True,
            "layer_flag": "--observers-layer",
        },
        {"name": "SUMMARY", "flag": None, "type": "vector", "required": True},
        _option("uplight", "boolean", default=False, off_flag="--no-uplight"),
        _option("store-tables", "boolean", default=True, off_flag="--no-store-tables"),
        _option("flat-earth", "boolean", default=False),
        _option("observer", "point", multiple=True, crs_flag="--observer-crs"),
        _option("lonlat", "point", crs="EPSG:4326"),
        _option("source-altitude", "float", multiple=True),
        _option("network", "enum", choices=["europe", "generic"]),
        _option(
            "sensor", "enum", choices=["photopic", "scotopic"], multiple=True, default=["photopic"]
        ),
        _option("top-cells", "integer", default=5),
    ],
}


def test_only_what_differs_from_the_defaults_is_given() -> None:
    values = {"EMISSION": "e.tif", "OBSERVERS": ("o.gpkg", None), "SUMMARY": "s.gpkg"}
    assert command_line(STAGE, values) == [
        *("sky", "observers", "e.tif", "o.gpkg", "s.gpkg", "--overwrite"),
    ]
    values |= {"UPLIGHT": False, "STORE_TABLES": True, "SENSOR": ["photopic"], "TOP_CELLS": 5}
    assert command_line(STAGE, values)[-1] == "--overwrite"
    assert len(command_line(STAGE, values)) == 6


def test_every_kind_of_value_on_the_command_line() -> None:
    values = {
        "EMISSION": "e.tif",
        "OBSERVERS": ("o.osm.pbf", "points"),
        "SUMMARY": "s.gpkg",
        "UPLIGHT": True,
        "STORE_TABLES": False,
        "FLAT_EARTH": False,
        "OBSERVER": [(500.0, 600.5, "EPSG:3067"), (1, 2, "EPSG:3067")],
        "LONLAT": (24.9, 60.2, None),
        "SOURCE_ALTITUDE": ["0", "250.5"],
        "NETWORK": "europe",
        "SENSOR": ["photopic", "scotopic"],
        "TOP_CELLS": 7,
    }
    assert command_line(STAGE, values) == [
        *("sky", "observers", "e.tif", "o.osm.pbf", "s.gpkg", "--observers-layer", "points"),
        *("--uplight", "--no-store-tables"),
        *("--observer", "500.0,600.5", "--observer", "1.0,2.0", "--observer-crs", "EPSG:3067"),
        *("--lonlat", "24.9,60.2"),
        *("--source-altitude", "0", "--source-altitude", "250.5"),
        *("--network", "europe", "--sensor", "photopic", "--sensor", "scotopic"),
        *("--top-cells", "7", "--overwrite"),
    ]


def test_a_missing_required_value_is_refused() -> None:
    with pytest.raises(ValueError, match="SUMMARY: a value is required"):
        command_line(STAGE, {"EMISSION": "e.tif", "OBSERVERS": "o.gpkg", "SUMMARY": ""})


def test_an_enum_without_a_default_offers_the_commands_default_first() -> None:
    network, sensor = STAGE["parameters"][-3], STAGE["parameters"][-2]
    assert enum_options(network) == [COMMAND_DEFAULT, "europe", "generic"]
    assert enum_default(network) == 0
    assert [enum_value(network, index) for index in range(3)] == [None, "europe", "generic"]
    assert enum_options(sensor) == ["photopic", "scotopic"]
    assert enum_default(sensor) == [0]


def test_repeated_values_typed_in_one_text() -> None:
    assert split_values(" 0 ;12.5,,3 ") == ["0", "12.5", "3"]
    assert split_values("a b:1\n\n c:2 ", lines=True) == ["a b:1", "c:2"]
    assert split_values(None) == []


def test_read_stages_refuses_a_file_without_stages(tmp_path: Path) -> None:
    (tmp_path / STAGES_FILE).write_text(json.dumps({"version": "0"}), encoding="utf-8")
    with pytest.raises(ValueError, match="no list of stages"):
        read_stages(tmp_path)
    with pytest.raises(OSError):
        read_stages(tmp_path / "missing")
