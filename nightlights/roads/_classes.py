"""Lighting classes, their requirements and a section's compliance (EN 13201-2:2015).

EN 13201-2 sets for each lighting class the values a road section must keep, each a minimum
or a maximum of one quality figure of EN 13201-3 (:mod:`nightlights.roads._metrics`): Table 1
for the M classes (motorised traffic: average luminance, overall and longitudinal uniformity,
threshold increment, edge illuminance ratio), Table 2 for the C classes (conflict areas:
average illuminance, overall uniformity) and Table 3 for the P classes (pedestrians and
low-speed traffic: average and minimum illuminance). The tables ship as a TOML file
(``nightlights/roads/data/en13201_2.toml``) that a user may copy and edit, as the street-field
mappings are (:func:`read_requirements`).

A criterion's margin is relative to its requirement: :math:`m = x / r - 1` for a minimum and
:math:`m = 1 - x / r` for a maximum, so that a section passes a criterion when
:math:`m \\ge 0` and its binding criterion is the one of the least margin.

References
----------
1. EN 13201-2:2015, "Road lighting - Part 2: Performance requirements", Tables 1-3.
2. EN 13201-3:2015, "Road lighting - Part 3: Calculation of performance" (the quality figures).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from nightlights.errors import InputError

__all__ = [
    "CRITERIA",
    "Compliance",
    "Criterion",
    "compliance",
    "read_requirements",
    "requirements",
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
}
#: Figures that are ratios of two values of the same field, at most 1 [1].
_RATIOS = ("overall_uniformity", "longitudinal_uniformity", "edge_illuminance_ratio")
#: The shipped table (EN 13201-2:2015, Tables 1-3).
_BUNDLED = "en13201_2.toml"


def read_requirements(
    source: str | os.PathLike[str] | None = None,
) -> dict[str, dict[str, float]]:
    """The requirements of every lighting class: ``{class: {criterion: value}}``.

    Parameters
    ----------
    source
        A TOML file with a ``[classes.NAME]`` table per class, each criterion of
        :data:`CRITERIA` its key; None: the shipped EN 13201-2:2015 tables.

    Raises
    ------
    InputError
        No such file, not TOML, no ``classes``, an unknown criterion, or a value that is not a
        positive finite number (a ratio above 1).

    Examples
    --------
    >>> read_requirements()["M3"]["average_luminance"]
    1.0
    """
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
            checked[key] = float(number)
        table[name.upper()] = checked
    return table


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
        non-finite or negative value.

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
        if not (math.isfinite(x) and x >= 0):
            raise InputError(f"measured[{name!r}] = {measured[name]!r}; expected a number >= 0")
        kind = CRITERIA[name][0]
        margin = x / value - 1.0 if kind == "minimum" else 1.0 - x / value
        criteria.append(Criterion(name, x, value, kind, margin))
    return Compliance(str(lighting_class).strip().upper(), tuple(criteria))
