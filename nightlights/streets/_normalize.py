"""Street-field normalisation (Chuang 2011, Sec. 3.2).

Street datasets name and encode their fields differently. A *mapping* (TOML) says which
input fields feed each canonical field of :mod:`nightlights.streets.schema`, how their values
translate, and which features are not streets. The result holds the canonical fields, a
``<field>_observed`` flag for each, and the source feature id.
"""

from __future__ import annotations

import os
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from pyproj import CRS

from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, EmptyInputError
from nightlights.io import as_vector, ensure_projected, write_gpkg
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import streets_style
from nightlights.io.vector import FieldType
from nightlights.streets._checks import finite_vertices
from nightlights.streets._mapping import (
    FieldRule,
    StreetMapping,
    load_mapping,
    parse_packed_tags,
    parse_value,
)
from nightlights.streets.schema import ARRANGEMENTS, STREET_FIELDS, VALUE_RANGES, observed_field

#: Field types of the layer :func:`normalize` writes.
OUTPUT_SCHEMA: dict[str, FieldType] = {
    "source_id": "str",
    "name": "str",
    **STREET_FIELDS,
    **{observed_field(name): "bool" for name in STREET_FIELDS},
}


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
    implausible_values
        Canonical field -> values outside the allowed range of
        :data:`~nightlights.streets.schema.VALUE_RANGES` (treated as missing) and their counts.
    unusual_values
        Canonical field -> allowed values outside the usual range (kept) and their counts.
    crs
        Output CRS, as text.
    """

    input_features: int = 0
    output_features: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    observed: dict[str, int] = field(default_factory=dict)
    unknown_values: dict[str, Counter[str]] = field(default_factory=dict)
    implausible_values: dict[str, Counter[str]] = field(default_factory=dict)
    unusual_values: dict[str, Counter[str]] = field(default_factory=dict)
    crs: str = ""


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
            parsed = _check_range(parsed, raw, name, report)
        out[name] = parsed.to_numpy()
        out[observed_field(name)] = parsed.notna().to_numpy()
    frame = gpd.GeoDataFrame(out, geometry=geometry, crs=streets.crs)
    frame = _clean_line_geometries(frame, report)
    frame = _cast_street_fields(frame)
    for name in STREET_FIELDS:
        report.observed[name] = int(frame[observed_field(name)].sum())
    report.output_features = len(frame)
    report.crs = frame.crs.to_string() if frame.crs else ""
    _warn_values(report.unknown_values, "values not understood (treated as missing)", source)
    _warn_values(
        report.implausible_values,
        "values outside the allowed range {interval} (treated as missing)",
        source,
    )
    _warn_values(report.unusual_values, "unusual values (usually {usual}; kept)", source)
    non_finite = report.dropped["non-finite coordinates"]
    if non_finite:
        warnings.warn(
            f"{source}: {non_finite} line part(s) with NaN or infinite vertex coordinates dropped",
            DataQualityWarning,
            stacklevel=2,
        )
    return frame.reset_index(drop=True), report


def _warn_values(counts: dict[str, Counter[str]], what: str, source: str) -> None:
    for name, values in counts.items():
        sample = ", ".join(f"{value!r} x{count}" for value, count in values.most_common(5))
        limits = VALUE_RANGES.get(name)
        text = what.format(
            interval=limits.interval if limits else "", usual=limits.usual if limits else ""
        )
        warnings.warn(
            f"{source}: field {name}: {sum(values.values())} {text}: {sample}",
            DataQualityWarning,
            stacklevel=3,
        )


def _check_range(
    parsed: pd.Series, raw: pd.Series, name: str, report: NormalizeReport
) -> pd.Series:
    """Treat values outside the allowed range as missing; count them and unusual ones."""
    limits = VALUE_RANGES.get(name)
    if limits is None:
        return parsed
    numbers = pd.to_numeric(parsed, errors="coerce").to_numpy(float)
    present = ~np.isnan(numbers)
    impossible = present & limits.impossible(numbers)
    unusual = present & limits.unusual(numbers)
    if impossible.any():
        report.implausible_values[name] = Counter(raw[impossible].astype(str))
    if unusual.any():
        report.unusual_values[name] = Counter(raw[unusual].astype(str))
    return parsed.where(~impossible, None)


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
    OutputError
        The output folder is missing or not writable (checked before any work).

    Warns
    -----
    DataQualityWarning
        Values not understood or outside the allowed range (treated as missing), unusual
        values, parts dropped for NaN or infinite vertex coordinates; each counted.

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
    with OutputSet(output, inputs={"streets": streets, "mapping": mapping}) as outputs:
        frame, source = as_vector(streets, layer=layer, name="streets")
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
            temporary = outputs.temporary(output)
            write_gpkg(
                normalized,
                temporary,
                layer="streets",
                schema=OUTPUT_SCHEMA,
                style=streets_style(ARRANGEMENTS),
            )
            path = Path(output)
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
        result = parse_value(value, rule)
        if result is None:
            unknown[str(value)] += 1
        parsed.append(result)
    return pd.Series(parsed, index=raw.index, dtype=object), unknown


def _clean_line_geometries(frame: gpd.GeoDataFrame, report: NormalizeReport) -> gpd.GeoDataFrame:
    geometry = frame.geometry
    missing = geometry.isna() | geometry.is_empty
    report.dropped["empty or missing geometry"] += int(missing.sum())
    frame = frame.loc[~missing]
    lines = frame.geometry.geom_type.isin(["LineString", "MultiLineString", "LinearRing"])
    report.dropped["not a line geometry"] += int((~lines).sum())
    frame = frame.loc[lines].explode(index_parts=False)
    # Before removing repeated points, which silently drops NaN vertices.
    coords_ok = finite_vertices(frame.geometry.to_numpy())
    report.dropped["non-finite coordinates"] += int((~coords_ok).sum())
    frame = frame.loc[coords_ok]
    frame = frame.set_geometry(shapely.remove_repeated_points(frame.geometry.to_numpy()))
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
