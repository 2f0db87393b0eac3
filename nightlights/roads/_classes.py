"""Lighting classes, their requirements and a section's compliance (EN 13201-2:2015).

EN 13201-2 sets for each lighting class the values a road section must keep, each a minimum
or a maximum of one quality figure of EN 13201-3 (:mod:`nightlights.roads._metrics`): Table 1
for the M classes (motorised traffic: average luminance, overall and longitudinal uniformity,
threshold increment, edge illuminance ratio), Table 2 for the C classes (conflict areas:
average illuminance, overall uniformity) and Table 3 for the P classes (pedestrians and
low-speed traffic: average and minimum illuminance). The tables ship as a TOML file
(``nightlights/roads/data/en13201_2.toml``) that a user may copy and edit, as the street-field
mappings are (:func:`read_requirements`).

ANSI/IES RP-8 (North America) rates a roadway's luminance by the average :math:`L_{avg}`
(a minimum), the uniformity ratios :math:`L_{avg}/L_{min}` and :math:`L_{max}/L_{min}` and the
veiling luminance ratio :math:`L_{v,max}/L_{avg}` (maxima), and its illuminance by
:math:`E_{avg}` (a minimum) and :math:`E_{avg}/E_{min}` (a maximum): ratios of 1 or more, where
EN 13201 states its uniformities as ratios of at most 1. A table can hold these criteria too
(:data:`CRITERIA`). No RP-8 values ship: ``nightlights/roads/data/rp8_example.toml`` has the
classes and criteria with placeholder values and ``placeholder = true``, which
:func:`read_requirements` refuses until a user has copied in the published values and removed
the flag. :func:`requirements_for_region` picks a table for a catalogue region
(:func:`nightlights.streets._location.network_for_location`): EN 13201-2 in Europe, RP-8 in
North America.

Tables may also set the pedestrian figures of EN 13201-3:2015, Sec. 8
(:mod:`nightlights.roads._illuminance`): the average and uniformity of hemispherical
illuminance and the minimum semicylindrical and vertical illuminance; EN 13201-2's HS, SC and
EV tables are not shipped (they were not at hand to check), so a scheme gives them in a copy.

A criterion's margin is relative to its requirement: :math:`m = x / r - 1` for a minimum and
:math:`m = 1 - x / r` for a maximum, so that a section passes a criterion when
:math:`m \\ge 0` and its binding criterion is the one of the least margin.

References
----------
1. EN 13201-2:2015, "Road lighting - Part 2: Performance requirements", Tables 1-3.
2. EN 13201-3:2015, "Road lighting - Part 3: Calculation of performance" (the quality figures).
3. ANSI/IES RP-8, "Recommended Practice: Lighting Roadway and Parking Facilities" (the
   luminance and illuminance criteria and their classes; values not shipped).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import cast

from nightlights.errors import InputError

__all__ = [
    "CRITERIA",
    "REGION_REQUIREMENTS",
    "Compliance",
    "Criterion",
    "class_names",
    "compliance",
    "read_requirements",
    "requirements",
    "requirements_for_region",
]

#: The quality figures a class may require: whether the requirement is a minimum or a maximum,
#: and the figure's unit.
CRITERIA: dict[str, tuple[str, str]] = {
    "average_luminance": ("minimum", "cd m-2"),
    "overall_uniformity": ("minimum", "1"),
    "longitudinal_uniformity": ("minimum", "1"),
    "threshold_increment": ("maximum", "%"),
    "edge_illuminance_ratio": ("minimum", "1"),
    "average_illuminance": ("minimum", "lx"),
    "minimum_illuminance": ("minimum", "lx"),
    # RP-8's roadway luminance and illuminance criteria (ratios of 1 or more).
    "luminance_average_to_minimum": ("maximum", "1"),  # L_avg / L_min
    "luminance_maximum_to_minimum": ("maximum", "1"),  # L_max / L_min
    "veiling_luminance_ratio": ("maximum", "1"),  # L_v,max / L_avg
    "illuminance_average_to_minimum": ("maximum", "1"),  # E_avg / E_min
    # EN 13201-3:2015, Sec. 8: pedestrian figures (EN 13201-2 HS, SC, EV classes).
    "average_hemispherical_illuminance": ("minimum", "lx"),
    "hemispherical_uniformity": ("minimum", "1"),  # E_hs,min / E_hs,av
    "minimum_semicylindrical_illuminance": ("minimum", "lx"),
    "minimum_vertical_illuminance": ("minimum", "lx"),
}
#: Figures that are ratios of two values of the same field, at most 1 [1].
_RATIOS = (
    "overall_uniformity",
    "longitudinal_uniformity",
    "edge_illuminance_ratio",
    "hemispherical_uniformity",
)
#: Figures that are ratios of a larger to a smaller value, at least 1 [1] (RP-8).
_INVERSE_RATIOS = (
    "luminance_average_to_minimum",
    "luminance_maximum_to_minimum",
    "illuminance_average_to_minimum",
)
#: The shipped table (EN 13201-2:2015, Tables 1-3).
_BUNDLED = "en13201_2.toml"
#: The RP-8 schema with placeholder values (refused until a user replaces them).
_RP8_EXAMPLE = "rp8_example.toml"
#: Top-level keys of a requirements file.
_TOP_KEYS = ("standard", "placeholder", "classes")
#: Requirements file for each catalogue region (``nightlights.streets._location``): RP-8 in
#: North America, EN 13201-2 elsewhere. EN 13201-2's classes are CIE 115:2010's, the basis of
#: most national road-lighting rules outside North America, so ``east_asia`` and ``generic``
#: take them too: this project's choice, not a standard's.
REGION_REQUIREMENTS: dict[str, str] = {
    "europe": _BUNDLED,
    "north_america": _RP8_EXAMPLE,
    "east_asia": _BUNDLED,
    "generic": _BUNDLED,
}


def read_requirements(
    source: str | os.PathLike[str] | None = None,
) -> dict[str, dict[str, float]]:
    """The requirements of every lighting class: ``{class: {criterion: value}}``.

    Parameters
    ----------
    source
        A TOML file with a ``[classes.NAME]`` table per class, each criterion of
        :data:`CRITERIA` its key, and optionally ``standard`` (a title) and ``placeholder``;
        None: the shipped EN 13201-2:2015 tables.

    Raises
    ------
    InputError
        No such file, not TOML, an unknown top-level key, ``placeholder`` not false (a table
        of placeholder values, such as the shipped RP-8 example), no ``classes``, an unknown
        criterion, or a value that is not a positive finite number (a uniformity above 1, an
        RP-8 ratio below 1).

    Examples
    --------
    >>> read_requirements()["M3"]["average_luminance"]
    1.0
    """
    label, data = _load(source)
    if data.get("placeholder", False) is not False:
        raise InputError(
            f"{label}: placeholder = {data['placeholder']!r}: its values are placeholders, not "
            "a standard's; copy the file, type in the published values and set "
            "placeholder = false"
        )
    classes = cast(dict[str, object], data["classes"])  # checked by _load
    table: dict[str, dict[str, float]] = {}
    for name, values in classes.items():
        if not isinstance(values, dict) or not values:
            raise InputError(f"{label}: class {name!r} has no requirements")
        checked = {}
        for key, value in values.items():
            if key not in CRITERIA:
                raise InputError(
                    f"{label}: class {name!r}: unknown criterion {key!r}; expected one of "
                    f"{', '.join(CRITERIA)}"
                )
            number = value if isinstance(value, (int, float)) else math.nan
            if isinstance(value, bool) or not (math.isfinite(number) and number > 0):
                raise InputError(
                    f"{label}: class {name!r}: {key} = {value!r}; expected a number > 0 "
                    f"[{CRITERIA[key][1]}]"
                )
            if key in _RATIOS and number > 1:
                raise InputError(f"{label}: class {name!r}: {key} = {value!r}; expected <= 1")
            if key in _INVERSE_RATIOS and number < 1:
                raise InputError(f"{label}: class {name!r}: {key} = {value!r}; expected >= 1")
            checked[key] = float(number)
        table[name.upper()] = checked
    return table


def _load(source: str | os.PathLike[str] | None) -> tuple[str, dict[str, object]]:
    """A requirements file's label and TOML content; None: the shipped EN 13201-2 tables."""
    if source is None:
        label = f"nightlights/roads/data/{_BUNDLED}"
        text = resources.files("nightlights.roads").joinpath("data", _BUNDLED).read_text()
    else:
        path = Path(source)
        label = str(path)
        if not path.is_file():
            raise InputError(f"{label}: no such requirements file")
        text = path.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{label}: not a TOML file ({exc})") from None
    classes = data.get("classes")
    if not isinstance(classes, dict) or not classes:
        raise InputError(f"{label}: no [classes.NAME] tables; expected one per lighting class")
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise InputError(
            f"{label}: unknown key {unknown[0]!r}; expected {', '.join(_TOP_KEYS)} at the top"
        )
    return label, data


def requirements_for_region(
    region: str, source: str | os.PathLike[str] | None = None
) -> dict[str, dict[str, float]]:
    """The requirement table for a catalogue region, or the user's ``source``.

    Parameters
    ----------
    region
        A catalogue region (``europe``, ``north_america``, ``east_asia``, ``generic``; see
        :func:`nightlights.streets._location.network_for_location`); ignored when ``source``
        is given.
    source
        The user's requirements file (:func:`read_requirements`), which wins.

    Raises
    ------
    InputError
        An unknown region, or ``north_america`` without ``source``: the shipped RP-8 file holds
        placeholders, so the user must give the published values.

    Examples
    --------
    >>> requirements_for_region("europe")["P3"]
    {'average_illuminance': 7.5, 'minimum_illuminance': 1.5}
    """
    if source is not None:
        return read_requirements(source)
    if region not in REGION_REQUIREMENTS:
        raise InputError(f"region={region!r}; expected one of {', '.join(REGION_REQUIREMENTS)}")
    if REGION_REQUIREMENTS[region] == _RP8_EXAMPLE:
        raise InputError(
            f"region={region!r} takes ANSI/IES RP-8, whose values do not ship: copy "
            f"nightlights/roads/data/{_RP8_EXAMPLE}, type in the published values, set "
            "placeholder = false and give it as source"
        )
    return read_requirements()


def class_names(source: str | os.PathLike[str] | None = None) -> tuple[str, ...]:
    """The lighting classes a requirements file names (upper case), placeholders or not.

    Examples
    --------
    >>> class_names()[:3]
    ('M1', 'M2', 'M3')
    """
    _, data = _load(source)
    classes = cast(dict[str, object], data["classes"])  # checked by _load
    return tuple(str(name).upper() for name in classes)


def requirements(
    lighting_class: str, table: Mapping[str, Mapping[str, float]] | None = None
) -> dict[str, float]:
    """The requirements of one lighting class (any case), from ``table``
    (:func:`read_requirements`; default the shipped EN 13201-2 tables).

    Examples
    --------
    >>> requirements("p4")
    {'average_illuminance': 5.0, 'minimum_illuminance': 1.0}
    """
    classes = read_requirements() if table is None else table
    key = str(lighting_class).strip().upper()
    if key not in classes:
        raise InputError(
            f"lighting_class={lighting_class!r}; expected one of {', '.join(sorted(classes))}"
        )
    return dict(classes[key])


@dataclass(frozen=True)
class Criterion:
    """One requirement of a class against what a section measured.

    Attributes
    ----------
    name
        The quality figure (a key of :data:`CRITERIA`).
    measured, required
        The section's value and the class's [the figure's unit].
    kind
        ``minimum`` or ``maximum``.
    margin
        x / r - 1 for a minimum, 1 - x / r for a maximum [1]; >= 0 passes.
    """

    name: str
    measured: float
    required: float
    kind: str
    margin: float

    @property
    def passed(self) -> bool:
        """Whether the section keeps this requirement."""
        return self.margin >= 0.0


@dataclass(frozen=True)
class Compliance:
    """A section against its lighting class: every criterion the class sets."""

    lighting_class: str
    criteria: tuple[Criterion, ...]

    @property
    def passed(self) -> bool:
        """Whether every criterion passes."""
        return all(c.passed for c in self.criteria)

    @property
    def binding(self) -> Criterion:
        """The criterion of the least margin (the one that fails first, or most)."""
        return min(self.criteria, key=lambda c: c.margin)


def compliance(
    lighting_class: str,
    measured: Mapping[str, float],
    table: Mapping[str, Mapping[str, float]] | None = None,
) -> Compliance:
    """A section's compliance with its lighting class (EN 13201-2:2015, Tables 1-3).

    Parameters
    ----------
    lighting_class
        The class, e.g. ``M3``, ``C2``, ``P4`` (any case).
    measured
        The section's quality figures by criterion name (:data:`CRITERIA`), e.g. from
        :func:`~nightlights.roads.average_luminance`; figures the class does not set are
        ignored.
    table
        The requirements (:func:`read_requirements`); default the shipped tables.

    Raises
    ------
    InputError
        An unknown class, or a figure the class sets that ``measured`` lacks or holds as a
        negative or non-finite value (+inf is allowed for a maximum, an RP-8 ratio over a
        minimum of 0, and fails it).

    Examples
    --------
    >>> result = compliance("M4", {"average_luminance": 0.8, "overall_uniformity": 0.38,
    ...                            "longitudinal_uniformity": 0.7, "threshold_increment": 12.0,
    ...                            "edge_illuminance_ratio": 0.5})
    >>> result.passed, result.binding.name, round(result.binding.margin, 3)
    (False, 'overall_uniformity', -0.05)
    """
    required = requirements(lighting_class, table)
    criteria = []
    for name, value in required.items():
        if name not in measured:
            raise InputError(
                f"measured has no {name!r}, which class {lighting_class.upper()} requires; "
                f"expected {', '.join(required)}"
            )
        x = float(measured[name])
        kind = CRITERIA[name][0]
        unbounded = kind == "maximum" and x == math.inf  # an RP-8 ratio over a minimum of 0
        if not (math.isfinite(x) and x >= 0) and not unbounded:
            raise InputError(f"measured[{name!r}] = {measured[name]!r}; expected a number >= 0")
        margin = x / value - 1.0 if kind == "minimum" else 1.0 - x / value
        criteria.append(Criterion(name, x, value, kind, margin))
    return Compliance(str(lighting_class).strip().upper(), tuple(criteria))
