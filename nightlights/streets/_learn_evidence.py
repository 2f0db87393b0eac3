"""Lighting evidence of each street from the lamps assigned to it.

The second step of stage ``streets learn`` (:mod:`nightlights.streets._learn`), after the
assignment (:mod:`nightlights.streets._learn_assign`). From the along-street position and
side (left, right, or on the centreline) of each lamp: same-side gaps between successive
lamps (gaps under :data:`MIN_GAP` are one pole mapped twice and dropped). A street with a
side holding at least two lamps gives ``arrangement`` (central when most lamps stand on the
centreline; single-sided when at most :data:`STRAY_SHARE` of the others stand on the
minority side; opposite when most lamps have a lamp across the street within
:data:`PAIRING_FRACTION` of the same-side gap; staggered otherwise) and ``spacing``: the
median gap between successive pole positions (lamps closer along the street than that
tolerance share a position), i.e. the same-side gap of a single-sided, opposite or central
row and half of it for a staggered one, the spacing of ``streets place``; a spacing outside
the usual range of :data:`~nightlights.streets.schema.VALUE_RANGES` is not taken as
evidence. ``occupancy`` is the share of the street's pole positions at that spacing that
hold a pole: the positions counted over the expected L / s of a street of length L, capped
at 1 (mapped streets are often lit, or mapped, along part of their length; a regular row at
the mapped spacing would otherwise carry more lamps than are mapped). ``mounting_height`` is
the median of the lamps' tagged heights, where tagged. Everything else stays unobserved: a
street without a mapped lamp is *not* evidence of an unlit street.

Agreement (how far a street's own lamps support its derived value): the share of its lamps
on the majority side (single-sided), paired (opposite), unpaired (staggered) or on the
centreline (central); the share of its position gaps within :data:`SPACING_AGREEMENT` of
the spacing (spacing, and occupancy, which rests on it); the share of tagged heights within
:data:`SPACING_AGREEMENT` of their median (mounting height).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from nightlights.streets._learn_assign import LampAssignment
from nightlights.streets.schema import VALUE_RANGES, observed_field

__all__ = ["DERIVED_FIELDS", "street_lamp_evidence"]

#: Successive lamps on one side closer than this are one pole mapped twice [m].
MIN_GAP = 1.0
#: A lamp is paired when a lamp across the street stands within this fraction of the
#: same-side gap along the street [1]: 0 for opposite pairs, 0.5 for a staggered row.
PAIRING_FRACTION = 0.25
#: Largest share of lamps on the minority side of a single-sided street [1]: one stray
#: lamp among ten (a lamp of a side street or a path) does not make a street two-sided.
STRAY_SHARE = 0.1
#: A gap (a tagged height) agrees with its street's value within this relative distance [1].
SPACING_AGREEMENT = 0.25

#: Lighting fields derived from the lamps, in report order.
DERIVED_FIELDS = ("arrangement", "spacing", "occupancy", "mounting_height")


def street_lamp_evidence(
    assignment: LampAssignment,
    n_streets: int,
    *,
    heights: np.ndarray | None = None,
    lengths: np.ndarray | None = None,
) -> pd.DataFrame:
    """Lighting evidence of each street from its assigned lamps.

    Parameters
    ----------
    assignment
        Lamps assigned to streets (:func:`~nightlights.streets.assign_lamps`).
    n_streets
        Number of streets in the layer [1].
    heights
        Tagged mounting height per lamp [m], NaN where untagged; default none tagged.
    lengths
        Length of each street [m]; without them no occupancy is derived.

    Returns
    -------
    pandas.DataFrame
        One row per street (index ``0 .. n_streets - 1``) with the lamp counts
        (``lamps``, ``lamps_left``, ``lamps_right``, ``lamps_centre``), ``same_side_gaps``
        [1], ``median_gap`` (same-side) [m], ``arrangement``, ``spacing`` [m], ``positions``
        (pole positions the spacing was measured on) [1], ``occupancy`` [1],
        ``mounting_height`` [m] (None/NaN without evidence), their ``<field>_observed`` flags
        and ``<field>_agreement`` [1] (see the module notes); ``unusual_spacing`` [m], a
        spacing outside the usual range that was not taken as evidence.
    """
    frame = pd.DataFrame(index=pd.RangeIndex(n_streets))
    for column in (
        "lamps",
        "lamps_left",
        "lamps_right",
        "lamps_centre",
        "same_side_gaps",
        "positions",
    ):
        frame[column] = 0
    for column in ("median_gap", "spacing", "unusual_spacing", "occupancy", "mounting_height"):
        frame[column] = np.nan
    for name in DERIVED_FIELDS:
        frame[f"{name}_agreement"] = np.nan
    frame["arrangement"] = pd.Series([None] * n_streets, dtype=object)
    lamp_heights = np.full(len(assignment.street), np.nan) if heights is None else heights
    table = pd.DataFrame(
        {
            "street": assignment.street,
            "along": assignment.along,
            "side": assignment.side,
            "height": np.asarray(lamp_heights, dtype=float),
        }
    ).loc[assignment.assigned]
    rows: list[dict[str, Any]] = []
    for street, group in table.groupby("street", sort=True):
        rows.append({"street": int(street), **_one_street(group)})
    if rows:
        found = pd.DataFrame(rows).set_index("street")
        for column in found.columns:
            frame.loc[found.index, column] = found[column].to_numpy()
    if lengths is not None:
        # expected positions on a street of length L at spacing s are L / s (as placed)
        length = np.asarray(lengths, dtype=float)
        spacing = frame["spacing"].to_numpy(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            occupancy = np.minimum(frame["positions"].to_numpy(float) * spacing / length, 1.0)
        seen = np.isfinite(occupancy) & (length > 0)
        frame["occupancy"] = np.where(seen, occupancy, np.nan)
        frame["occupancy_agreement"] = np.where(seen, frame["spacing_agreement"], np.nan)
    for name in DERIVED_FIELDS:
        frame[observed_field(name)] = frame[name].notna()
    return frame


def _one_street(group: pd.DataFrame) -> dict[str, Any]:
    """Counts, gaps, arrangement, spacing and height of one street's lamps."""
    side = group["side"].to_numpy()
    along = group["along"].to_numpy(float)
    result: dict[str, Any] = {
        "lamps": len(group),
        "lamps_left": int((side == 1).sum()),
        "lamps_right": int((side == -1).sum()),
        "lamps_centre": int((side == 0).sum()),
    }
    tagged = group["height"].to_numpy(float)
    tagged = tagged[np.isfinite(tagged)]
    if tagged.size:
        median_height = float(np.median(tagged))
        result["mounting_height"] = median_height
        result["mounting_height_agreement"] = float(
            np.mean(np.abs(tagged - median_height) <= SPACING_AGREEMENT * median_height)
        )
    positions = {s: np.sort(along[side == s]) for s in (-1, 0, 1)}
    gaps = np.concatenate([np.diff(p) for p in positions.values()])
    gaps = gaps[gaps >= MIN_GAP]
    result["same_side_gaps"] = int(gaps.size)
    if not gaps.size:
        return result
    median_gap = float(np.median(gaps))
    result["median_gap"] = median_gap
    arrangement, agreement = _arrangement(positions, median_gap)
    result["arrangement"] = arrangement
    result["arrangement_agreement"] = agreement
    steps = _position_gaps(np.sort(along), max(MIN_GAP, PAIRING_FRACTION * median_gap))
    limits = VALUE_RANGES["spacing"]
    if steps.size:
        spacing = float(np.median(steps))
        if limits.impossible([spacing])[0] or limits.unusual([spacing])[0]:
            result["unusual_spacing"] = spacing
            return result
        result["spacing"] = spacing
        result["positions"] = int(steps.size + 1)
        result["spacing_agreement"] = float(
            np.mean(np.abs(steps - spacing) <= SPACING_AGREEMENT * spacing)
        )
    return result


def _position_gaps(along: np.ndarray, tolerance: float) -> np.ndarray:
    """Gaps between successive pole positions [m]: sorted lamps closer than ``tolerance``
    to the first lamp of the current position share it (a pair across the street, or one
    pole mapped twice)."""
    starts: list[float] = []
    for value in along:
        if not starts or value - starts[-1] >= tolerance:
            starts.append(float(value))
    return np.diff(np.asarray(starts))


def _arrangement(positions: dict[int, np.ndarray], median_gap: float) -> tuple[str, float]:
    """Arrangement of one street's lamps and the share of lamps that agree with it."""
    left, centre, right = positions[1], positions[0], positions[-1]
    total = left.size + centre.size + right.size
    if centre.size * 2 > total:
        return "central", centre.size / total
    sided = left.size + right.size
    minority = min(left.size, right.size)
    if minority <= STRAY_SHARE * sided:
        return "single_sided", 1.0 - minority / sided
    tolerance = PAIRING_FRACTION * median_gap
    paired = np.concatenate(
        [_nearest_distance(left, right) <= tolerance, _nearest_distance(right, left) <= tolerance]
    )
    share = float(paired.mean())
    return ("opposite", share) if share >= 0.5 else ("staggered", 1.0 - share)


def _nearest_distance(points: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Along-street distance from each of ``points`` to the nearest of sorted ``others``."""
    index = np.clip(np.searchsorted(others, points), 1, others.size - 1)
    if others.size == 1:
        return np.abs(points - others[0])
    return np.minimum(np.abs(points - others[index - 1]), np.abs(points - others[index]))
