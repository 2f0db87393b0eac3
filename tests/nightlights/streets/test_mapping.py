"""Mapping TOML: strict keys, clear errors, and property-based fuzzing of the reader (a
malformed mapping raises only :class:`MappingError`; one that parses normalises a layer)."""

from __future__ import annotations

import json
import math
import warnings
from importlib import resources
from typing import Any

import geopandas as gpd
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nightlights.errors import InputError, MappingError
from nightlights.streets._mapping import load_mapping, parse_mapping
from nightlights.streets._normalize import normalize_streets

BUILTIN = {
    name: (resources.files("nightlights.streets") / "mappings" / f"{name}.toml").read_text()
    for name in ("osm", "municipal")
}
MINIMAL = '[fields.lanes]\nsource = ["lanes"]\ntype = "int"\n'


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (MINIMAL + "lanse = 3\n", ["unknown key of [fields.lanes] 'lanse'", "source, type"]),
        ("nmae = 'x'\n" + MINIMAL, ["unknown top-level key 'nmae'", "description, drop, fields"]),
        ("[extra]\n" + MINIMAL, ["unknown top-level key 'extra'"]),
        ("name = 3\n" + MINIMAL, ["name = 3", "expected a string"]),
        ("fields = 3\n", ["needs a [fields.<name>] table"]),
        ("[fields]\nlanes = 3\n", ["fields.lanes = 3", "table"]),
        ("keep = 3\n" + MINIMAL, ["keep must be a [keep] table"]),
        ("[keep]\nfield = 'highway'\nvalues = 3\n" + MINIMAL, ["[keep] values = 3"]),
        ("[keep]\nfeld = 'highway'\n" + MINIMAL, ["unknown key of [keep] 'feld'"]),
        ("drop = 3\n" + MINIMAL, ["drop must be [[drop]] tables"]),
        ("[[drop]]\nfield = 'area'\nvalues = 'yes'\n" + MINIMAL, ["rule 1 values = 'yes'"]),
        ("[[drop]]\nfield = 'area'\n" + MINIMAL, ["rule 1 needs field and values"]),
        (MINIMAL.replace('["lanes"]', "[1]"), ["needs source = [field names]"]),
        (MINIMAL + "values = 3\n", ["values = 3", "[fields.lanes.values] table"]),
        (
            '[fields.lit]\nsource = "lit"\ntype = "bool"\n[fields.lit.values]\nx = "maybe"\n',
            ["'x' must map to true or false"],
        ),
        (MINIMAL.replace('"int"', '"integer"'), ["type 'integer'"]),
        (
            '[fields.lit]\nsource = "lanes"\ntype = "int"\n',
            ["[fields.lit] type 'int'", "expected one of ['bool'] for a bool field"],
        ),
        (MINIMAL + "default_unit = 3\n", ["default_unit 3 is not a unit"]),
        ("[fields.speed]\nsource = 'x'\ntype = 'int'\n", ["[fields.speed] is not a canonical"]),
        ("[fields", ["not valid TOML"]),
    ],
)
def test_malformed_mappings_name_the_key_and_what_is_allowed(text: str, words: list[str]) -> None:
    with pytest.raises(MappingError) as info:
        parse_mapping(text, source="m.toml")
    message = str(info.value)
    assert message.startswith("m.toml: ") and "\n" not in message.strip()
    for word in words:
        assert word in message


def test_builtin_mappings_parse() -> None:
    for name in BUILTIN:
        assert load_mapping(name).rules


# --- fuzzing ------------------------------------------------------------------------------------

_LAYER = gpd.GeoDataFrame(
    {
        "highway": ["primary", "residential", "footway"],
        "lanes": ["2", "1e9", "-1"],
        "width": ["7 m", "1e400", "abc"],
        "lit": ["yes", "24/7", None],
        "oneway": ["-1", "no", "yes"],
        "other_tags": ['"lanes"=>"3"', None, '"width"=>"inf"'],
    },
    geometry=[shapely.LineString([(0, y), (100, y)]) for y in (0, 30, 60)],
    crs="EPSG:3067",
)


def _normalise_if_parsed(text: str) -> None:
    try:
        mapping = parse_mapping(text, source="fuzz.toml")
    except MappingError as exc:
        assert str(exc).startswith("fuzz.toml")
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            streets, report = normalize_streets(_LAYER, mapping, source="layer")
        except InputError:
            return
    assert report.output_features == len(streets) <= len(_LAYER)
    if "lanes" in streets:
        lanes = streets["lanes"].dropna()
        assert ((lanes >= 1) & (lanes <= 30)).all()  # 1e9 lanes never pass


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"


KEYS = [
    "name",
    "description",
    "id_field",
    "packed_tags_field",
    "keep",
    "drop",
    "fields",
    "source",
    "type",
    "values",
    "default_unit",
    "field",
    "lanes",
    "width",
    "lit",
    "street_class",
    "oneway",
    "int",
    "length",
    "bool",
    "category",
    "x",
]
scalars = st.one_of(
    st.booleans(),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([*KEYS, "ft", "m", "yes", "motorway", ""]),
    st.text(max_size=5),
)
values = st.recursive(
    scalars,
    lambda children: st.one_of(
        st.lists(children, max_size=3),
        st.dictionaries(st.sampled_from(KEYS), children, max_size=4),
    ),
    max_leaves=12,
)
documents = st.dictionaries(st.sampled_from(KEYS), values, max_size=6)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(document=documents)
def test_random_documents_raise_only_mapping_errors(document: dict[str, Any]) -> None:
    text = "\n".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in document.items())
    _normalise_if_parsed(text)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(sorted(BUILTIN)),
    edits=st.lists(
        st.tuples(
            st.sampled_from(["delete", "replace", "value"]),
            st.integers(0, 10_000),
            st.one_of(st.sampled_from(["", "[fields.x]", "[[drop]]", "3", "inf", "{}"]), values),
        ),
        min_size=1,
        max_size=3,
    ),
)
def test_mutated_builtin_mappings_raise_only_mapping_errors(name: str, edits) -> None:
    lines = BUILTIN[name].splitlines()
    for kind, where, replacement in edits:
        k = where % len(lines)
        if kind == "delete":
            del lines[k]
        elif kind == "replace":
            lines[k] = replacement if isinstance(replacement, str) else _toml_value(replacement)
        elif "=" in lines[k]:  # keep the key, change the value
            lines[k] = lines[k].split("=", 1)[0] + "= " + _toml_value(replacement)
    _normalise_if_parsed("\n".join(lines) + "\n")


field_specs = st.fixed_dictionaries(
    {
        "source": st.one_of(
            st.sampled_from(["lanes", "width", "lit", "highway", "oneway", "nope"]),
            st.lists(st.sampled_from(["lanes", "width", "lit", "other", ""]), max_size=3),
            values,
        ),
        "type": st.one_of(st.sampled_from(["category", "int", "float", "length", "bool"]), values),
    },
    optional={
        "values": st.one_of(
            st.dictionaries(
                st.sampled_from(["yes", "no", "2", "1e9", "primary", "-1"]),
                st.one_of(st.booleans(), st.sampled_from(["local", "path", "x"]), scalars),
                max_size=3,
            ),
            values,
        ),
        "default_unit": st.one_of(st.sampled_from(["m", "ft", "in", "parsec"]), values),
    },
)
structured = st.fixed_dictionaries(
    {
        "fields": st.dictionaries(
            st.sampled_from(["lanes", "width", "lit", "oneway", "street_class", "has_median"]),
            field_specs,
            min_size=1,
            max_size=4,
        )
    },
    optional={
        "keep": st.one_of(
            st.fixed_dictionaries(
                {"field": st.sampled_from(["highway", "lanes"]), "values": st.lists(scalars)}
            ),
            values,
        ),
        "id_field": st.one_of(st.sampled_from(["osm_id", "highway"]), values),
        "packed_tags_field": st.one_of(st.just("other_tags"), values),
    },
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(document=structured)
def test_structured_documents_parse_or_raise_mapping_errors(document: dict[str, Any]) -> None:
    text = "\n".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in document.items())
    _normalise_if_parsed(text)
