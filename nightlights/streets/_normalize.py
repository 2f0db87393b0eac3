"""Street-field normalisation (Chuang 2011, Sec. 3.2).

Street datasets name and encode their fields differently. A *mapping* (TOML) says which
input fields feed each canonical field of :mod:`nightlights.streets.schema`, how their values
translate, and which features are not streets. The result holds the canonical fields, a
``<field>_observed`` flag for each, and the source feature id.
"""

from __future__ import annotations

import os
import re
import tomllib
import warnings
from collections import Counter
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from pyproj import CRS

from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, EmptyInputError, MappingError
from nightlights.io import ensure_projected, write_gpkg
from nightlights.io.vector import FieldType
from nightlights.streets._layer import read_layer
from nightlights.streets.schema import STREET_CLASSES, STREET_FIELDS, observed_field

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

#: Field types of the layer :func:`normalize` writes.
OUTPUT_SCHEMA: dict[str, FieldType] = {
    "source_id": "str",
    "name": "str",
    **STREET_FIELDS,
    **{observed_field(name): "bool" for name in STREET_FIELDS},
}

_TRUE_WORDS = frozenset({"yes", "y", "true", "t", "1"})
_FALSE_WORDS = frozenset({"no", "n", "false", "f", "0"})
_FIELD_TYPES = frozenset({"category", "int", "float", "length", "bool"})
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


@dataclass
class NormalizeReport:
    """What normalisation kept, dropped and observed.

    Attributes
    ----------
    input_features
        Features in the input layer [1].
    output_features
        Street parts in the output [1].
    dropped
        Reason -> number of features or parts dropped for it [1].
    observed
        Canonical field -> number of parts where the input gave a value [1].
    unknown_values
        Canonical field -> input values not understood (treated as missing) and their counts.
    crs
        Output CRS, as text.
    """

    input_features: int = 0
    output_features: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    observed: dict[str, int] = field(default_factory=dict)
    unknown_values: dict[str, Counter[str]] = field(default_factory=dict)
    crs: str = ""


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
    fields_table = data.get("fields")
    if not isinstance(fields_table, dict) or not fields_table:
        raise MappingError(f"{source}: needs a [fields.<name>] table for each mapped field")
    rules: dict[str, FieldRule] = {}
    for name, spec in fields_table.items():
        if name not in STREET_FIELDS:
            raise MappingError(
                f"{source}: [fields.{name}] is not a canonical field; "
                f"expected one of {', '.join(STREET_FIELDS)}"
            )
        kind = spec.get("type")
        if kind not in _FIELD_TYPES:
            raise MappingError(
                f"{source}: [fields.{name}] type {kind!r}; expected one of {sorted(_FIELD_TYPES)}"
            )
        sources = spec.get("source")
        if isinstance(sources, str):
            sources = [sources]
        if not sources or not all(isinstance(s, str) for s in sources):
            raise MappingError(f"{source}: [fields.{name}] needs source = [field names]")
        values = {str(k): v for k, v in spec.get("values", {}).items()}
        if name == "street_class":
            bad = sorted({str(v) for v in values.values()} - set(STREET_CLASSES))
            if bad:
                raise MappingError(
                    f"{source}: [fields.street_class.values] maps to unknown classes {bad}; "
                    f"expected {', '.join(STREET_CLASSES)}"
                )
        unit = spec.get("default_unit", "m")
        if unit not in LENGTH_UNITS:
            raise MappingError(f"{source}: [fields.{name}] default_unit {unit!r} is not a unit")
        rules[name] = FieldRule(name, tuple(sources), kind, values, unit)
    keep = data.get("keep", {})
    drops = []
    for index, rule in enumerate(data.get("drop", [])):
        if "field" not in rule or "values" not in rule:
            raise MappingError(f"{source}: [[drop]] rule {index + 1} needs field and values")
        drops.append((str(rule["field"]), frozenset(map(str, rule["values"]))))
    return StreetMapping(
        name=str(data.get("name", source)),
        description=str(data.get("description", "")),
        id_field=data.get("id_field"),
        packed_tags_field=data.get("packed_tags_field"),
        keep_field=keep.get("field"),
        keep_values=frozenset(map(str, keep.get("values", []))),
        drop_rules=tuple(drops),
        rules=rules,
        source=source,
    )


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


def normalize_streets(
    streets: gpd.GeoDataFrame, mapping: StreetMapping, *, source: str = "layer"
) -> tuple[gpd.GeoDataFrame, NormalizeReport]:
    """Map a street layer's fields onto the canonical street fields.

    Parameters
    ----------
    streets
        Input layer in a projected CRS [m].
    mapping
        Field mapping (:func:`load_mapping`).
    source
        Name of the input, used in warnings.

    Returns
    -------
    streets : geopandas.GeoDataFrame
        One row per line part: ``source_id``, ``name`` and each canonical field with its
        ``<field>_observed`` flag. Fields the mapping does not name are missing everywhere.
    report : NormalizeReport
        Counts of kept, dropped (by reason) and observed values.

    Notes
    -----
    Multi-part lines become one row per part (sharing ``source_id``); points, polygons,
    empty and zero-length parts are dropped and counted.
    """
    report = NormalizeReport(input_features=len(streets))
    tags = _tag_table(streets, mapping)
    keep = np.ones(len(streets), dtype=bool)
    if mapping.keep_field is not None:
        column = tags.get(mapping.keep_field)
        values = column.astype(str) if column is not None else pd.Series("", index=tags.index)
        kept = values.isin(mapping.keep_values).to_numpy()
        report.dropped[f"{mapping.keep_field} not a street value"] += int((~kept).sum())
        keep &= kept
    for drop_field, drop_values in mapping.drop_rules:
        if drop_field in tags:
            hit = keep & tags[drop_field].astype(str).isin(drop_values).to_numpy()
            report.dropped[f"{drop_field} in {sorted(drop_values)}"] += int(hit.sum())
            keep &= ~hit
    tags = tags.loc[keep]
    geometry = streets.geometry.to_numpy()[keep]
    if mapping.id_field and mapping.id_field in tags:
        ids = tags[mapping.id_field].astype(str)
    else:
        ids = pd.Series(tags.index.astype(str), index=tags.index)
    out = pd.DataFrame({"source_id": ids.to_numpy()}, index=tags.index)
    out["name"] = tags["name"].to_numpy() if "name" in tags else None
    for name in STREET_FIELDS:
        rule = mapping.rules.get(name)
        if rule is None:
            parsed = pd.Series(np.nan, index=tags.index, dtype=object)
        else:
            raw = _first_present(tags, rule.sources)
            parsed, unknown = _parse_column(raw, rule)
            if unknown:
                report.unknown_values[name] = unknown
        out[name] = parsed.to_numpy()
        out[observed_field(name)] = parsed.notna().to_numpy()
    frame = gpd.GeoDataFrame(out, geometry=geometry, crs=streets.crs)
    frame = _clean_line_geometries(frame, report)
    frame = _cast_street_fields(frame)
    for name in STREET_FIELDS:
        report.observed[name] = int(frame[observed_field(name)].sum())
    report.output_features = len(frame)
    report.crs = frame.crs.to_string() if frame.crs else ""
    for name, unknown in report.unknown_values.items():
        sample = ", ".join(f"{value!r} x{count}" for value, count in unknown.most_common(5))
        warnings.warn(
            f"{source}: field {name}: {sum(unknown.values())} values not understood "
            f"(treated as missing): {sample}",
            DataQualityWarning,
            stacklevel=2,
        )
    return frame.reset_index(drop=True), report


@dataclass(frozen=True, eq=False)
class NormalizeResult:
    """What :func:`normalize` returns.

    Attributes
    ----------
    streets
        Normalised streets (see :func:`normalize_streets`), in a projected CRS [m].
    report
        Counts of kept, dropped and observed features.
    path
        The GeoPackage written, or None when no output was asked for.
    """

    streets: gpd.GeoDataFrame
    report: NormalizeReport
    path: Path | None


def normalize(
    streets: gpd.GeoDataFrame | PathLike,
    output: PathLike | None = None,
    *,
    mapping: str | os.PathLike[str] = "osm",
    layer: str | None = None,
    crs: str | CRS | None = None,
    target_crs: str | CRS | None = None,
) -> NormalizeResult:
    """Map a street layer's fields onto the canonical street fields, in a projected CRS.

    Stage ``streets normalize`` (Chuang 2011, Sec. 3.2): the layer is reprojected to a
    projected CRS in metres, the fields named by ``mapping`` are parsed into the canonical
    fields of :data:`~nightlights.streets.schema.STREET_FIELDS` with their ``<field>_observed``
    flags, and what is not a street is dropped (see :func:`normalize_streets`).

    Parameters
    ----------
    streets
        Street layer: a GeoDataFrame, or any vector file GDAL reads (GeoPackage, Shapefile,
        GeoJSON, FlatGeobuf, OpenStreetMap ``.pbf``/``.osm``/``.osm.gz``).
    output
        GeoPackage to write (layer ``streets``), atomically; None writes nothing.
    mapping
        Built-in mapping name (``osm``, ``municipal``) or TOML path.
    layer
        Layer of the input file (default: the first; ``lines`` for OSM files). Only for a
        path.
    crs
        CRS of an input that has none.
    target_crs
        Projected output CRS in metres (default: the input's if projected, else its local
        UTM zone).

    Returns
    -------
    NormalizeResult
        The normalised streets, the report and the written path (or None).

    Raises
    ------
    EmptyInputError
        The layer has no features, or none is left after filtering.
    CRSError
        The layer has no CRS and ``crs`` is not given, or ``target_crs`` is not projected
        in metres.
    MappingError
        Unknown or malformed mapping.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import LineString
    >>> from nightlights.streets import normalize
    >>> raw = gpd.GeoDataFrame(
    ...     {
    ...         "osm_id": ["1", "2", "3"],
    ...         "highway": ["primary", "residential", "bus_stop"],
    ...         "lit": ["yes", "no", None],
    ...         "width": ["14 m", None, None],
    ...     },
    ...     geometry=[
    ...         LineString([(0, 0), (120, 0)]),
    ...         LineString([(0, 40), (90, 40)]),
    ...         LineString([(10, 5), (12, 5)]),
    ...     ],
    ...     crs="EPSG:3067",
    ... )
    >>> result = normalize(raw)
    >>> result.streets[["source_id", "street_class", "lit", "width"]]
      source_id street_class    lit  width
    0         1     arterial   True   14.0
    1         2        local  False    NaN
    >>> result.report.output_features, result.path
    (2, None)
    """
    rules = load_mapping(mapping)
    frame, source = read_layer(streets, name=layer)
    if frame.empty:
        raise EmptyInputError(f"{source}: the layer has no features")
    frame = ensure_projected(frame, source=source, assume_crs=crs, target_crs=target_crs)
    normalized, report = normalize_streets(frame, rules, source=source)
    if normalized.empty:
        reasons = ", ".join(f"{reason}: {n}" for reason, n in report.dropped.items() if n)
        raise EmptyInputError(
            f"{source}: no street features left after mapping {rules.name!r} ({reasons})"
        )
    path = None
    if output is not None:
        path = write_gpkg(normalized, output, layer="streets", schema=OUTPUT_SCHEMA)
    return NormalizeResult(normalized, report, path)


def _tag_table(streets: gpd.GeoDataFrame, mapping: StreetMapping) -> pd.DataFrame:
    """Columns of the layer plus keys unpacked from the packed-tags field (columns win)."""
    table = pd.DataFrame(streets.drop(columns=streets.geometry.name))
    packed = mapping.packed_tags_field
    if packed and packed in table:
        unpacked = pd.DataFrame.from_records(
            [parse_packed_tags(text) for text in table[packed]], index=table.index
        )
        for column in unpacked.columns:
            if column in table:
                table[column] = table[column].where(table[column].notna(), unpacked[column])
            else:
                table[column] = unpacked[column]
    return table


def _first_present(tags: pd.DataFrame, sources: tuple[str, ...]) -> pd.Series:
    result = pd.Series(None, index=tags.index, dtype=object)
    for name in sources:
        if name in tags:
            column = tags[name].astype(object)
            column = column.where(column.notna() & (column.astype(str).str.strip() != ""))
            result = result.where(result.notna(), column)
    return result


def _parse_column(raw: pd.Series, rule: FieldRule) -> tuple[pd.Series, Counter[str]]:
    unknown: Counter[str] = Counter()
    parsed: list[Any] = []
    for value in raw.tolist():
        if value is None or (isinstance(value, float) and np.isnan(value)):
            parsed.append(None)
            continue
        result = _parse_value(value, rule)
        if result is None:
            unknown[str(value)] += 1
        parsed.append(result)
    return pd.Series(parsed, index=raw.index, dtype=object), unknown


def _parse_value(value: Any, rule: FieldRule) -> Any:
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


def _clean_line_geometries(frame: gpd.GeoDataFrame, report: NormalizeReport) -> gpd.GeoDataFrame:
    geometry = frame.geometry
    missing = geometry.isna() | geometry.is_empty
    report.dropped["empty or missing geometry"] += int(missing.sum())
    frame = frame.loc[~missing]
    lines = frame.geometry.geom_type.isin(["LineString", "MultiLineString", "LinearRing"])
    report.dropped["not a line geometry"] += int((~lines).sum())
    frame = frame.loc[lines].explode(index_parts=False)
    frame = frame.set_geometry(shapely.remove_repeated_points(frame.geometry.to_numpy()))
    coords_ok = np.array(
        [np.isfinite(shapely.get_coordinates(g)).all() for g in frame.geometry], dtype=bool
    )
    report.dropped["non-finite coordinates"] += int((~coords_ok).sum())
    frame = frame.loc[coords_ok]
    zero = ~(frame.geometry.length > 0)
    report.dropped["zero-length line"] += int(zero.sum())
    return frame.loc[~zero]


def _cast_street_fields(frame: gpd.GeoDataFrame) -> gpd.GeoDataFrame:
    frame = frame.copy()
    for name, kind in STREET_FIELDS.items():
        column = frame[name]
        if kind == "float":
            frame[name] = pd.to_numeric(column, errors="coerce").astype("float64")
        elif kind == "int":
            frame[name] = pd.to_numeric(column, errors="coerce").astype("Int64")
        elif kind == "bool":
            frame[name] = column.astype("boolean")
        else:
            frame[name] = column.astype(object)
    return frame
