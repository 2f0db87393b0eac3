"""Quality figures of every section from the influence matrices, and each segment's rating.

With the dimming :math:`\\delta` of every luminaire, a section's figures are those of
EN 13201-3:2015, Sec. 9 (:mod:`nightlights.roads._metrics`) computed from
:math:`E = \\mathsf E\\,\\delta`, :math:`L = \\mathsf L\\,\\delta`,
:math:`L_v = \\mathsf V\\,\\delta` (:mod:`nightlights.roads._influence`):

- luminance sections: :math:`L_\\text{av}` and :math:`U_o` the least over the section's
  observers, :math:`U_l` the least over its lanes (each lane's centre line seen by the
  observer in that lane), :math:`f_{TI}` the largest over its observers, :math:`R_{EI}` the
  lesser of the two edges' outside-to-inside ratios of average strip illuminance;
- every section: :math:`E_\\text{av}` and :math:`E_\\text{min}` of its horizontal
  illuminance field; the illuminance sections also :math:`U_o = E_\\text{min} / E_\\text{av}`;
- RP-8's ratios (ANSI/IES RP-8): :math:`L_\\text{av}/L_\\text{min}` and
  :math:`L_\\text{max}/L_\\text{min}` the largest over observers,
  :math:`L_{v,\\max}/L_\\text{av}` the largest over observers, and
  :math:`E_\\text{av}/E_\\text{min}`.

A segment takes its worst section on every figure (the least of a minimum criterion, the
largest threshold increment): a street is rated by its weakest span, as an auditor walks it.
A criterion's margin is :math:`x/r - 1` for a minimum and :math:`1 - x/r` for a maximum
(:func:`nightlights.roads.compliance`); a segment passes when every criterion its class sets
has a margin of at least 0, and its binding criterion is the one of the least margin.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nightlights._typing import FloatArray
from nightlights.roads._classes import CRITERIA
from nightlights.roads._influence import RoadInfluence
from nightlights.roads._layout import STRIPS
from nightlights.roads._metrics import TI_LUMINANCE_BREAK

__all__ = ["FIGURES", "rate_segments", "section_figures"]

#: Figures computed per section, each the key of a criterion in :data:`CRITERIA` (the
#: pedestrian hemispherical, semicylindrical and vertical figures are not rated).
FIGURES = (
    "average_luminance",
    "overall_uniformity",
    "longitudinal_uniformity",
    "threshold_increment",
    "edge_illuminance_ratio",
    "average_illuminance",
    "minimum_illuminance",
    "luminance_average_to_minimum",
    "luminance_maximum_to_minimum",
    "veiling_luminance_ratio",
    "illuminance_average_to_minimum",
)
IntArray = NDArray[np.intp]


def _group_reduce(values: FloatArray, group: IntArray, n: int, how: str) -> FloatArray:
    """Reduce ``values`` per group id in [0, n) (NaN for empty groups)."""
    out = np.full(n, np.nan)
    if values.size == 0:
        return out
    if how == "mean":
        total = np.bincount(group, weights=values, minlength=n)
        count = np.bincount(group, minlength=n)
        np.divide(total, count, out=out, where=count > 0)
        return out
    ufunc = np.minimum if how == "min" else np.maximum
    fill = np.inf if how == "min" else -np.inf
    acc = np.full(n, fill)
    known = ~np.isnan(values)
    ufunc.at(acc, group[known], values[known])
    count = np.bincount(group[known], minlength=n)
    return np.where(count > 0, acc, np.nan)


def _ratio(numerator: FloatArray, denominator: FloatArray) -> FloatArray:
    out = np.full(np.shape(numerator), np.nan)
    np.divide(numerator, denominator, out=out, where=denominator > 0)
    return np.where((denominator <= 0) & np.isfinite(denominator), 0.0, out)


def _inverse_ratio(numerator: FloatArray, denominator: FloatArray) -> FloatArray:
    """A ratio over a minimum (RP-8's figures): +inf over a dark point, NaN where unknown."""
    out = np.full(np.shape(numerator), np.nan)
    np.divide(numerator, denominator, out=out, where=denominator > 0)
    dark = (denominator <= 0) & np.isfinite(numerator)
    return np.where(dark, np.where(numerator > 0, np.inf, 1.0), out)


def threshold_increments(veiling: FloatArray, average: FloatArray) -> FloatArray:
    """f_TI [%] for arrays (EN 13201-3:2015, Sec. 9.4; see
    :func:`nightlights.roads.threshold_increment`); NaN where the average is not positive."""
    safe = np.where(average > 0, average, np.nan)
    low = 65.0 * veiling / safe**0.8
    high = 95.0 * veiling / safe**1.05
    return np.where(safe <= TI_LUMINANCE_BREAK, low, high)


def section_figures(
    influence: RoadInfluence, dimming: ArrayLike | None = None
) -> dict[str, FloatArray]:
    """Every section's quality figures (module docstring); NaN where a figure does not apply.

    Parameters
    ----------
    influence
        The matrices of a street layer.
    dimming
        Level of every luminaire (n_lights,) in [0, 1]; default all 1.
    """
    fields = influence.fields
    n = fields.n_sections
    n_lights = influence.luminance.shape[1]
    d = np.ones(n_lights) if dimming is None else np.asarray(dimming, dtype=float)
    figures = {name: np.full(n, np.nan) for name in FIGURES}

    # Luminance sections.
    observers = fields.observers
    n_obs = len(observers)
    if n_obs:
        lum = influence.luminance @ d
        obs = influence.sample_observer
        average_o = _group_reduce(lum, obs, n_obs, "mean")
        minimum_o = _group_reduce(lum, obs, n_obs, "min")
        centre = fields.luminance.column[influence.sample_point] == (3 * observers.lane[obs] + 1)
        line_min = _group_reduce(lum[centre], obs[centre], n_obs, "min")
        line_max = _group_reduce(lum[centre], obs[centre], n_obs, "max")
        veil = influence.veiling @ d
        section = observers.section
        figures["average_luminance"] = _group_reduce(average_o, section, n, "min")
        figures["overall_uniformity"] = _group_reduce(
            _ratio(minimum_o, average_o), section, n, "min"
        )
        figures["longitudinal_uniformity"] = _group_reduce(
            _ratio(line_min, line_max), section, n, "min"
        )
        figures["threshold_increment"] = _group_reduce(
            threshold_increments(veil, average_o), section, n, "max"
        )
        maximum_o = _group_reduce(lum, obs, n_obs, "max")
        figures["luminance_average_to_minimum"] = _group_reduce(
            _inverse_ratio(average_o, minimum_o), section, n, "max"
        )
        figures["luminance_maximum_to_minimum"] = _group_reduce(
            _inverse_ratio(maximum_o, minimum_o), section, n, "max"
        )
        figures["veiling_luminance_ratio"] = _group_reduce(
            _inverse_ratio(veil, average_o), section, n, "max"
        )
        strips = fields.strips
        if len(strips):
            e = influence.strips @ d
            key = strips.section * len(STRIPS) + strips.column
            mean = _group_reduce(e, key, n * len(STRIPS), "mean").reshape(n, len(STRIPS))
            right = _ratio(mean[:, 0], mean[:, 1])
            left = _ratio(mean[:, 3], mean[:, 2])
            figures["edge_illuminance_ratio"] = np.fmin(right, left)

    # Illuminance sections.
    points = fields.illuminance
    if len(points):
        e = influence.illuminance @ d
        average = _group_reduce(e, points.section, n, "mean")
        minimum = _group_reduce(e, points.section, n, "min")
        rates_luminance = np.zeros(n, dtype=bool)
        rates_luminance[observers.section] = True
        is_ill = np.isfinite(average) & ~rates_luminance
        figures["average_illuminance"] = average
        figures["minimum_illuminance"] = minimum
        figures["overall_uniformity"] = np.where(
            is_ill, _ratio(minimum, average), figures["overall_uniformity"]
        )
        figures["illuminance_average_to_minimum"] = _inverse_ratio(average, minimum)
    return figures


def rate_segments(
    figures: Mapping[str, FloatArray],
    section_segment: IntArray,
    n_segments: int,
    classes: pd.Series,
    table: Mapping[str, Mapping[str, float]],
) -> pd.DataFrame:
    """Each segment's worst figures, its requirements, margins, pass/fail and binding criterion.

    Parameters
    ----------
    figures
        Section figures (:func:`section_figures`).
    section_segment
        Segment of each section.
    n_segments
        Number of segments.
    classes
        Lighting class per segment (None where not rated).
    table
        Requirements by class (:func:`nightlights.roads.read_requirements`).

    Returns
    -------
    pandas.DataFrame
        One row per segment: ``lighting_class``, per criterion ``<name>``, ``<name>_required``
        and ``<name>_margin`` (NaN where the class sets none), ``passed`` (None when not
        rated), ``binding`` and ``binding_margin``.
    """
    out = pd.DataFrame({"lighting_class": classes.to_numpy(dtype=object)})
    margins = []
    for name in FIGURES:
        kind = CRITERIA[name][0]
        how = "max" if kind == "maximum" else "min"
        value = _group_reduce(np.asarray(figures[name]), section_segment, n_segments, how)
        required = np.array(
            [
                np.nan if c is None else table.get(str(c), {}).get(name, np.nan)
                for c in out["lighting_class"]
            ],
            dtype=float,
        )
        ratio = value / required
        margin = ratio - 1.0 if kind == "minimum" else 1.0 - ratio
        margin = np.where(np.isfinite(required), margin, np.nan)
        out[name] = value
        out[f"{name}_required"] = required
        out[f"{name}_margin"] = margin
        margins.append(margin)
    stack = np.column_stack(margins) if margins else np.zeros((n_segments, 0))
    required_any = np.isfinite(
        np.column_stack([out[f"{name}_required"].to_numpy() for name in FIGURES])
    )
    # A required figure that could not be computed (no light reaches the section) fails.
    stack = np.where(required_any & ~np.isfinite(stack), -1.0, stack)
    rated = required_any.any(axis=1) & out["lighting_class"].notna().to_numpy()
    filled = np.where(required_any, stack, np.inf)
    least = np.argmin(filled, axis=1) if n_segments else np.zeros(0, dtype=np.intp)
    binding_margin = filled[np.arange(n_segments), least] if n_segments else np.zeros(0)
    out["passed"] = pd.array(np.where(rated, binding_margin >= 0, False), dtype="boolean")
    out.loc[~rated, "passed"] = pd.NA
    out["binding"] = np.where(rated, np.array(FIGURES, dtype=object)[least], None)
    out["binding_margin"] = np.where(rated, binding_margin, np.nan)
    return out
