"""Field mappings of street layers: TOML rules, tag parsing and value parsing.

A mapping says which input fields feed each canonical street field of
:mod:`nightlights.streets.schema`, how their values translate (categories, numbers, booleans,
lengths with units), and which features are not streets (Chuang 2011, Sec. 3.2).
"""

from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from nightlights.errors import MappingError
from nightlights.streets.schema import STREET_CLASSES, STREET_FIELDS

#: Length units understood in width values, to metres.
LENGTH_UNITS: dict[str, float] = {
    "m": 1.0,
    "meter": 1.0,
    "meters": 1.0,
    "metre": 1.0,
    "metres": 1.0,
    "cm": 0.01,
    "km": 1000.0,
    "ft": 0.3048,
    "feet": 0.3048,
    "foot": 0.3048,
    "'": 0.3048,
    "in": 0.0254,
    '"': 0.0254,
    "yd": 0.9144,
}

_TRUE_WORDS = frozenset({"yes", "y", "true", "t", "1"})
_FALSE_WORDS = frozenset({"no", "n", "false", "f", "0"})
_HSTORE_PAIR = re.compile(r'"((?:[^"\\]|\\.)*)"=>"((?:[^"\\]|\\.)*)"')
_NUMBER = r"[-+]?(?:\d+(?:[.,]\d*)?|[.,]\d+)"
_LENGTH = re.compile(rf"^\s*({_NUMBER})\s*([a-z'\"]*)\s*$")
_FEET_INCHES = re.compile(rf"^\s*({_NUMBER})\s*'\s*({_NUMBER})\s*\"\s*$")


@dataclass(frozen=True)
class FieldRule:
    """How one canonical field is read from the input.

    Attributes
    ----------
    name
        Canonical field name.
    sources
        Input fields tried in order; the first non-empty value wins.
    kind
        ``category``, ``int``, ``float``, ``length`` or ``bool``.
    values
        Input value -> canonical value (categories) or boolean overrides.
    default_unit
        Unit of a length without one (``m``, ``ft`` ...).
    """

    name: str
    sources: tuple[str, ...]
    kind: str
    values: dict[str, Any] = field(default_factory=dict)
    default_unit: str = "m"


@dataclass(frozen=True)
class StreetMapping:
    """A mapping from an input street schema to the canonical fields.

    Attributes
    ----------
    name
        Mapping name.
    description
        One line on the schema it reads.
    id_field
        Input field holding the feature id (``source_id``); None uses the row index.
    packed_tags_field
        Input field with packed ``"key"=>"value"`` tags (GDAL's OSM ``other_tags``).
    keep_field
        Input field whose value says whether a feature is a street.
    keep_values
        Values of ``keep_field`` that are streets.
    drop_rules
        ``(field, values)`` pairs: features with one of these values are dropped.
    rules
        Canonical field name -> how it is read.
    source
        Where the mapping came from, used in messages.
    """

    name: str
    description: str
    id_field: str | None
    packed_tags_field: str | None
    keep_field: str | None
    keep_values: frozenset[str]
    drop_rules: tuple[tuple[str, frozenset[str]], ...]
    rules: dict[str, FieldRule]
    source: str = "<mapping>"


def builtin_mappings() -> list[str]:
    """Names of the mappings shipped with the toolkit.

    Returns
    -------
    list of str
        Sorted names, e.g. ``["municipal", "osm"]``.
    """
    folder = resources.files("nightlights.streets") / "mappings"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_mapping(name_or_path: str | os.PathLike[str]) -> StreetMapping:
    """Load a mapping by built-in name (``osm``, ``municipal``) or TOML file path.

    Parameters
    ----------
    name_or_path
        Built-in mapping name or path of a TOML file.

    Returns
    -------
    StreetMapping
        The parsed mapping.

    Raises
    ------
    MappingError
        Unknown name, unreadable file, or a malformed mapping.
    """
    text_path = str(name_or_path)
    if text_path in builtin_mappings():
        resource = resources.files("nightlights.streets") / "mappings" / f"{text_path}.toml"
        return parse_mapping(resource.read_text(encoding="utf-8"), source=f"mapping {text_path}")
    path = Path(text_path)
    if not path.is_file():
        raise MappingError(
            f"{text_path}: neither a built-in mapping ({', '.join(builtin_mappings())}) "
            "nor a TOML file"
        )
    return parse_mapping(path.read_text(encoding="utf-8"), source=str(path))


def parse_mapping(text: str, *, source: str = "<mapping>") -> StreetMapping:
    """Parse a mapping from TOML text (see ``nightlights/streets/mappings/osm.toml``).

    Parameters
    ----------
    text
        TOML text.
    source
        Where the text came from, used in messages.

    Returns
    -------
    StreetMapping
        The parsed mapping.

    Raises
    ------
    MappingError
        Invalid TOML, an unknown canonical field, field type, street class or unit, or a
        drop rule without field and values.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MappingError(f"{source}: not valid TOML: {exc}") from exc
    _check_keys(data, _TOP_LEVEL_KEYS, source, "top-level key")
    for key in ("name", "description", "id_field", "packed_tags_field"):
        if key in data and not isinstance(data[key], str):
            raise MappingError(f"{source}: {key} = {data[key]!r}; expected a string")
    fields_table = data.get("fields")
    if not isinstance(fields_table, dict) or not fields_table:
        raise MappingError(f"{source}: needs a [fields.<name>] table for each mapped field")
    rules = {name: _field_rule(name, spec, source) for name, spec in fields_table.items()}
    keep = data.get("keep", {})
    if not isinstance(keep, dict):
        raise MappingError(f"{source}: keep must be a [keep] table with field and values")
    _check_keys(keep, frozenset({"field", "values"}), source, "key of [keep]")
    keep_field = keep.get("field")
    if keep_field is not None and not isinstance(keep_field, str):
        raise MappingError(f"{source}: [keep] field = {keep_field!r}; expected a field name")
    keep_values = _string_list(keep.get("values", []), source, "[keep] values")
    drop_table = data.get("drop", [])
    if not isinstance(drop_table, list):
        raise MappingError(f"{source}: drop must be [[drop]] tables with field and values")
    drops = []
    for index, rule in enumerate(drop_table):
        where = f"[[drop]] rule {index + 1}"
        if not isinstance(rule, dict) or "field" not in rule or "values" not in rule:
            raise MappingError(f"{source}: {where} needs field and values")
        _check_keys(rule, frozenset({"field", "values"}), source, f"key of {where}")
        values = _string_list(rule["values"], source, f"{where} values")
        drops.append((str(rule["field"]), frozenset(values)))
    return StreetMapping(
        name=str(data.get("name", source)),
        description=str(data.get("description", "")),
        id_field=data.get("id_field"),
        packed_tags_field=data.get("packed_tags_field"),
        keep_field=keep_field,
        keep_values=frozenset(keep_values),
        drop_rules=tuple(drops),
        rules=rules,
        source=source,
    )


_TOP_LEVEL_KEYS = frozenset(
    {"name", "description", "id_field", "packed_tags_field", "keep", "drop", "fields"}
)
_FIELD_KEYS = frozenset({"source", "type", "values", "default_unit"})
#: Mapping types that can fill a canonical field of each type.
_KINDS_FOR: dict[str, frozenset[str]] = {
    "str": frozenset({"category"}),
    "int": frozenset({"int", "float"}),
    "float": frozenset({"float", "int", "length"}),
    "bool": frozenset({"bool"}),
}


def _check_keys(table: dict[str, Any], allowed: frozenset[str], source: str, what: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise MappingError(
            f"{source}: unknown {what} {unknown[0]!r}; expected one of {', '.join(sorted(allowed))}"
        )


def _string_list(value: object, source: str, where: str) -> list[str]:
    if not isinstance(value, list) or not all(
        isinstance(item, str | int | float | bool) for item in value
    ):
        raise MappingError(f"{source}: {where} = {value!r}; expected a list of values")
    return [str(item) for item in value]


def _field_rule(name: str, spec: object, source: str) -> FieldRule:
    """Check one ``[fields.<name>]`` table and build its rule."""
    if name not in STREET_FIELDS:
        raise MappingError(
            f"{source}: [fields.{name}] is not a canonical field; "
            f"expected one of {', '.join(STREET_FIELDS)}"
        )
    if not isinstance(spec, dict):
        raise MappingError(f"{source}: fields.{name} = {spec!r}; expected a [fields.{name}] table")
    _check_keys(spec, _FIELD_KEYS, source, f"key of [fields.{name}]")
    kind = spec.get("type")
    allowed = _KINDS_FOR[STREET_FIELDS[name]]
    if not isinstance(kind, str) or kind not in allowed:
        raise MappingError(
            f"{source}: [fields.{name}] type {kind!r}; expected one of {sorted(allowed)} "
            f"for a {STREET_FIELDS[name]} field"
        )
    sources = spec.get("source")
    if isinstance(sources, str):
        sources = [sources]
    if (
        not isinstance(sources, list)
        or not sources
        or not all(isinstance(s, str) and s for s in sources)
    ):
        raise MappingError(f"{source}: [fields.{name}] needs source = [field names]")
    raw_values = spec.get("values", {})
    if not isinstance(raw_values, dict):
        raise MappingError(
            f"{source}: [fields.{name}] values = {raw_values!r}; expected a "
            f"[fields.{name}.values] table"
        )
    values = {str(k): v for k, v in raw_values.items()}
    if name == "street_class":
        bad = sorted({str(v) for v in values.values()} - set(STREET_CLASSES))
        if bad:
            raise MappingError(
                f"{source}: [fields.street_class.values] maps to unknown classes {bad}; "
                f"expected {', '.join(STREET_CLASSES)}"
            )
    elif kind == "bool":
        bad = sorted(str(k) for k, v in values.items() if not isinstance(v, bool))
        if bad:
            raise MappingError(
                f"{source}: [fields.{name}.values] {bad[0]!r} must map to true or false"
            )
    unit = spec.get("default_unit", "m")
    if not isinstance(unit, str) or unit not in LENGTH_UNITS:
        raise MappingError(f"{source}: [fields.{name}] default_unit {unit!r} is not a unit")
    return FieldRule(name, tuple(sources), kind, values, unit)


def parse_packed_tags(text: object) -> dict[str, str]:
    """Parse GDAL's OSM ``other_tags`` hstore text (``"k"=>"v","k2"=>"v2"``) into a dict.

    Parameters
    ----------
    text
        Packed tags; anything but a non-empty string gives an empty dict.

    Returns
    -------
    dict of str to str
        Tag key -> value.

    Examples
    --------
    >>> parse_packed_tags('"lanes"=>"2","lit"=>"yes"')
    {'lanes': '2', 'lit': 'yes'}
    """
    if not isinstance(text, str) or not text:
        return {}
    return {
        key.replace('\\"', '"'): value.replace('\\"', '"')
        for key, value in _HSTORE_PAIR.findall(text)
    }


def parse_length(value: object, *, default_unit: str = "m") -> float:
    """Parse a length such as ``7``, ``"7 m"``, ``"3,5"``, ``"23'"`` or ``"7'6\\""`` to metres.

    Multiple values (``"7;6"``) take the first. Unparseable text gives NaN.

    Parameters
    ----------
    value
        Number or text.
    default_unit
        Unit of a bare number.

    Returns
    -------
    float
        Length [m], or NaN.

    Examples
    --------
    >>> round(parse_length("23'"), 4)
    7.0104
    >>> parse_length("7.5 m")
    7.5
    """
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return np.nan
    if isinstance(value, int | float | np.number):
        return float(value) * LENGTH_UNITS[default_unit]
    text = str(value).strip().lower().split(";")[0]
    match = _FEET_INCHES.match(text)
    if match:
        feet, inches = (float(g.replace(",", ".")) for g in match.groups())
        return feet * 0.3048 + inches * 0.0254
    match = _LENGTH.match(text)
    if not match:
        return np.nan
    number, unit = match.groups()
    unit = unit or default_unit
    if unit not in LENGTH_UNITS:
        return np.nan
    return float(number.replace(",", ".")) * LENGTH_UNITS[unit]


def parse_value(value: Any, rule: FieldRule) -> Any:
    text = str(value).strip()
    if rule.kind == "category":
        return rule.values.get(text)
    if rule.kind == "bool":
        if text in rule.values:
            return bool(rule.values[text])
        word = text.lower()
        if word in _TRUE_WORDS:
            return True
        if word in _FALSE_WORDS:
            return False
        return None
    if rule.kind in ("int", "float"):
        try:
            number = float(text.split(";")[0].replace(",", "."))
        except ValueError:
            return None
        if not np.isfinite(number) or number < 0:
            return None
        return round(number) if rule.kind == "int" else number
    length = parse_length(value, default_unit=rule.default_unit)
    return None if not np.isfinite(length) or length <= 0 else length
