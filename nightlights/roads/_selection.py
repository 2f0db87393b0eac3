"""A street segment's lighting class from its street class and attributes, by editable rules.

EN 13201 chooses a lighting class from a street's parameters (design speed, traffic volume and
composition, separation of carriageways, junctions, parked vehicles, ambient luminance, ...)
as CEN/TR 13201-1:2014 sets out; RP-8 from the road class and its pedestrian conflict area. A
street layer here knows fewer things: the canonical street fields of
:mod:`nightlights.streets.schema` (``street_class``, ``lanes``, ``width``, ``has_median``,
``oneway``, ``lit``). :func:`select_classes` maps them to a class through an ordered list of
rules, a TOML file a user edits as the street-field mappings are
(``nightlights/roads/data/class_selection.toml`` ships this project's defaults, which are a
choice, not a standard's table):

- the first rule a street matches gives its class;
- a rule names one or more street classes and may add conditions (``min_lanes``,
  ``max_lanes``, ``min_width``, ``max_width`` [m], ``has_median``, ``oneway``, ``lit``), all of
  which must hold; a street whose field is null does not match a condition on it;
- a non-empty ``lighting_class`` field on the street layer overrides the rules;
- a street that no rule matches gets no class, with a :class:`DataQualityWarning`.

References
----------
1. CEN/TR 13201-1:2014, "Road lighting - Part 1: Guidelines on selection of lighting classes".
2. EN 13201-2:2015, "Road lighting - Part 2: Performance requirements" (the classes).
"""

from __future__ import annotations

import math
import os
import re
import tomllib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from nightlights.errors import DataQualityWarning, InputError
from nightlights.roads._classes import read_requirements
from nightlights.streets.schema import STREET_CLASSES

__all__ = ["ClassRule", "ClassSelection", "read_class_selection", "select_classes"]

#: The shipped rules (this project's defaults).
_BUNDLED = "class_selection.toml"
#: Conditions a rule may set: key -> (street field, comparison, value type).
CONDITIONS: dict[str, tuple[str, str, str]] = {
    "min_lanes": ("lanes", ">=", "int"),
    "max_lanes": ("lanes", "<=", "int"),
    "min_width": ("width", ">=", "float"),
    "max_width": ("width", "<=", "float"),
    "has_median": ("has_median", "==", "bool"),
    "oneway": ("oneway", "==", "bool"),
    "lit": ("lit", "==", "bool"),
}
#: Keys a rule must have.
_REQUIRED = ("street_class", "class")
#: How many street ids an error message lists before "...".
_SHOWN_IDS = 5


@dataclass(frozen=True)
class ClassRule:
    """One selection rule.

    Attributes
    ----------
    street_classes
        The street classes it applies to.
    lighting_class
        The class it gives (upper case).
    conditions
        ``(key, value)`` pairs of :data:`CONDITIONS`, all of which must hold.
    line
        Line of its ``[[rule]]`` header in the file (0: not from a file).
    """

    street_classes: tuple[str, ...]
    lighting_class: str
    conditions: tuple[tuple[str, float | bool], ...] = ()
    line: int = 0


@dataclass(frozen=True)
class ClassSelection:
    """An ordered list of rules and where it came from."""

    rules: tuple[ClassRule, ...]
    source: str


def read_class_selection(
    path: str | os.PathLike[str] | None = None,
    *,
    requirements: Mapping[str, Mapping[str, float]] | None = None,
) -> ClassSelection:
    """Read and check a class-selection TOML (the format of the module docstring).

    Parameters
    ----------
    path
        The TOML file; None: the shipped defaults (this project's choice).
    requirements
        The requirement table whose classes the rules may give
        (:func:`~nightlights.roads.read_requirements`); default EN 13201-2.

    Raises
    ------
    InputError
        No such file, not TOML, no ``[[rule]]``, or a rule with a missing or unknown key, an
        unknown street class or lighting class, or a value of the wrong type; the message
        names the file, the rule's line and the key.

    Examples
    --------
    >>> selection = read_class_selection()
    >>> selection.rules[0].street_classes, selection.rules[0].lighting_class
    (('motorway',), 'M2')
    """
    if path is None:
        label = f"nightlights/roads/data/{_BUNDLED}"
        text = resources.files("nightlights.roads").joinpath("data", _BUNDLED).read_text()
    else:
        label = str(path)
        if not Path(path).is_file():
            raise InputError(f"{label}: no such class-selection file")
        text = Path(path).read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{label}: not a TOML file ({exc})") from None
    unknown = sorted(set(data) - {"rule"})
    if unknown:
        raise InputError(f"{label}: unknown key {unknown[0]!r}; expected [[rule]] tables only")
    rules = data.get("rule")
    if not isinstance(rules, list) or not rules:
        raise InputError(f"{label}: no [[rule]] tables; expected at least one")
    table = read_requirements() if requirements is None else requirements
    known = {str(name).upper() for name in table}
    lines = [
        i + 1 for i, row in enumerate(text.splitlines()) if re.match(r"\s*\[\[\s*rule\s*\]\]", row)
    ]
    return ClassSelection(
        tuple(
            _rule(rule, f"{label}:{lines[i] if i < len(lines) else '?'}", known, lines, i)
            for i, rule in enumerate(rules)
        ),
        label,
    )


def _rule(rule: object, where: str, known: set[str], lines: list[int], index: int) -> ClassRule:
    """One checked rule; ``where`` is ``file:line`` for messages."""
    if not isinstance(rule, dict):
        raise InputError(f"{where}: rule {index + 1} is not a table")
    for key in rule:
        if key not in _REQUIRED and key not in CONDITIONS:
            raise InputError(
                f"{where}: unknown key {key!r}; expected street_class, class, "
                f"{', '.join(CONDITIONS)}"
            )
    for key in _REQUIRED:
        if key not in rule:
            raise InputError(f"{where}: rule {index + 1} has no {key!r}")
    street = rule["street_class"]
    names = [street] if isinstance(street, str) else street
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise InputError(f"{where}: street_class = {street!r}; expected a name or a list of names")
    for name in names:
        if name.strip().lower() not in STREET_CLASSES:
            raise InputError(
                f"{where}: street_class {name!r}; expected one of {', '.join(STREET_CLASSES)}"
            )
    lighting = rule["class"]
    if not isinstance(lighting, str) or lighting.strip().upper() not in known:
        raise InputError(
            f"{where}: class = {lighting!r}; expected a class of the requirement table: "
            f"{', '.join(sorted(known))}"
        )
    conditions: list[tuple[str, float | bool]] = []
    for key, (_, _, kind) in CONDITIONS.items():
        if key not in rule:
            continue
        value = rule[key]
        if kind == "bool":
            ok = isinstance(value, bool)
        elif kind == "int":
            ok = isinstance(value, int) and not isinstance(value, bool) and value >= 1
        else:
            ok = (
                isinstance(value, (int, float))
                and not isinstance(value, bool)
                and math.isfinite(value)
                and value > 0
            )
        if not ok:
            expected = {"bool": "true or false", "int": "an integer >= 1"}.get(
                kind, "a number > 0 [m]"
            )
            raise InputError(f"{where}: {key} = {value!r}; expected {expected}")
        conditions.append((key, value))
    return ClassRule(
        tuple(n.strip().lower() for n in names),
        lighting.strip().upper(),
        tuple(conditions),
        lines[index] if index < len(lines) else 0,
    )


def select_classes(
    streets: pd.DataFrame,
    selection: ClassSelection | str | os.PathLike[str] | None = None,
    *,
    requirements: Mapping[str, Mapping[str, float]] | None = None,
    class_field: str = "lighting_class",
) -> pd.Series:
    """The lighting class of every street segment (the rules of the module docstring).

    Parameters
    ----------
    streets
        A street layer with the canonical street fields (``street_class`` at least).
    selection
        Rules (:func:`read_class_selection`) or a TOML path; None: the shipped defaults.
    requirements
        The requirement table the classes must belong to (default EN 13201-2); checks the
        rules read from a path and the ``class_field`` overrides.
    class_field
        A field whose non-empty values override the rules.

    Returns
    -------
    pandas.Series
        Class names (upper case) on ``streets``' index, None where no rule matched.

    Raises
    ------
    InputError
        No ``street_class`` field, or a ``class_field`` value that is no class of the table
        (the message names the streets by ``source_id`` when the layer has it).

    Warns
    -----
    DataQualityWarning
        Streets that match no rule, and condition fields the layer lacks.

    Examples
    --------
    >>> streets = pd.DataFrame({"street_class": ["motorway", "arterial", "local"],
    ...                         "lanes": [4, 4, 2], "has_median": [True, False, False],
    ...                         "lighting_class": [None, None, "p2"]})
    >>> select_classes(streets).tolist()
    ['M2', 'M2', 'P2']
    """
    table = read_requirements() if requirements is None else requirements
    if not isinstance(selection, ClassSelection):
        selection = read_class_selection(selection, requirements=table)
    if "street_class" not in streets.columns:
        raise InputError(
            "streets has no 'street_class' field; expected the canonical street fields "
            "(nightlights streets normalize)"
        )
    n = len(streets)
    street_class = streets["street_class"].astype("string").str.strip().str.lower()
    result = np.full(n, None, dtype=object)
    open_rows = np.ones(n, dtype=bool)
    missing_fields: set[str] = set()
    for rule in selection.rules:
        mask = street_class.isin(rule.street_classes).fillna(False).to_numpy(dtype=bool).copy()
        for key, value in rule.conditions:
            field, comparison, _ = CONDITIONS[key]
            if field not in streets.columns:
                if mask.any():
                    missing_fields.add(field)
                mask[:] = False
                break
            mask &= _holds(streets[field], comparison, value)
        take = mask & open_rows
        result[take] = rule.lighting_class
        open_rows &= ~take
    if missing_fields:
        warnings.warn(
            f"streets have no field {', '.join(sorted(missing_fields))}: class-selection rules "
            "on it match no street",
            DataQualityWarning,
            stacklevel=2,
        )
    if class_field in streets.columns:
        given = streets[class_field].astype("string").str.strip().str.upper()
        present = (given.notna() & (given != "")).to_numpy(dtype=bool)
        known = {str(name).upper() for name in table}
        bad = present & ~given.isin(known).fillna(False).to_numpy(dtype=bool)
        if bad.any():
            by_id = "source_id" in streets.columns
            ids = (streets["source_id"] if by_id else streets.index).to_numpy()
            label = "source_id" if by_id else "row"
            listed = [
                f"{given.iloc[i]} ({label} {ids[i]})" for i in np.flatnonzero(bad)[:_SHOWN_IDS]
            ]
            more = ", ..." if bad.sum() > _SHOWN_IDS else ""
            raise InputError(
                f"{class_field}: {int(bad.sum())} streets name unknown classes: "
                f"{', '.join(listed)}{more}; expected one of {', '.join(sorted(known))}"
            )
        result[present] = given.to_numpy(dtype=object)[present]
        open_rows &= ~present
    if open_rows.any():
        unmatched = sorted({str(v) for v in street_class[open_rows].fillna("<null>")})
        warnings.warn(
            f"{int(open_rows.sum())} streets (street_class {', '.join(unmatched)}) match no "
            f"class-selection rule of {selection.source}; their lighting class is None",
            DataQualityWarning,
            stacklevel=2,
        )
    return pd.Series(result, index=streets.index, name=class_field, dtype=object)


def _holds(column: pd.Series, comparison: str, value: float | bool) -> np.ndarray:
    """Rows where ``column comparison value`` holds; null rows never do."""
    if comparison == "==":
        try:
            flags = column.astype("boolean")
        except (TypeError, ValueError):  # text or mixed cells: only true bools count
            flags = column.map(_as_bool)
        return (flags == value).fillna(False).to_numpy(dtype=bool)
    numbers = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
    with np.errstate(invalid="ignore"):
        return numbers >= value if comparison == ">=" else numbers <= value


def _as_bool(value: object) -> bool | None:
    """A bool of a flag field's cell; None for nulls and non-flags."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    return None
