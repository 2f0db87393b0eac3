"""Learn a street-lighting network from mapped street lamps.

Stage ``streets learn`` (beyond Chuang 2011, whose Fig. 10 weights were counted by hand from
GIS datasets): a street layer and a point layer of real lamps (OpenStreetMap
``highway=street_lamp`` nodes, a municipal inventory) become per-street lighting evidence,
and the tables of a base network are fitted to it with the base as prior
(:func:`bayesnets.fit_network`).

1. **Assignment.** Each lamp goes to one street within ``max_distance``. Junction-aware:
   among the streets in reach, those onto whose *interior* the lamp projects (not onto an
   end point) come first, then the smaller distance, then the higher street class. A lamp
   beside a street near a junction projects onto the interior of the street it stands
   along and onto the end of a side street that stops there, so it goes to the former.
   Streets tagged ``lit=no`` take no lamps.
2. **Evidence per street.** Along-street position and side (left, right, or on the
   centreline within :data:`CENTRE_TOLERANCE`) of each lamp; same-side gaps between
   successive lamps (gaps under :data:`MIN_GAP` are one pole mapped twice and dropped).
   A street with a side holding at least two lamps gives ``arrangement`` (central when
   most lamps stand on the centreline; single-sided when at most
   :data:`STRAY_SHARE` of the others stand on the minority side; opposite when most lamps
   have a lamp across the street within :data:`PAIRING_FRACTION` of the same-side gap;
   staggered otherwise) and ``spacing``: the median gap between successive pole positions
   (lamps closer along the street than that tolerance share a position), i.e. the
   same-side gap of a single-sided, opposite or central row and half of it for a staggered
   one, the spacing of ``streets place``; a spacing outside the usual range of
   :data:`~nightlights.streets.schema.VALUE_RANGES` is not taken as evidence.
   ``occupancy`` is the share of the street's pole positions at that spacing that hold a
   pole: the positions counted over the expected L / s of a street of length L,
   capped at 1 (mapped streets are often lit, or mapped, along part of their length; a
   regular row at the mapped spacing would otherwise carry more lamps than are mapped).
   ``mounting_height`` is the median of the lamps' tagged heights, where tagged.
   ``lit`` is true on a street with a lamp and no ``lit`` tag. Everything else stays
   unobserved: a street without a mapped lamp is *not* evidence of an unlit street (only
   ``lit=no`` is).
3. **Fit.** The network binds ``spacing_ratio = spacing / mounting_height``, and the
   ratio's parents (arrangement, and through the width ratio the width and the mounting
   height) are rarely all observed. Each street's unobserved fields are therefore imputed
   by :data:`IMPUTATION_DRAWS` draws from the network given the street's evidence
   (likelihood weighting, as ``streets sample``; the imputing network's tables floored at
   :data:`IMPUTATION_FLOOR`), ``spacing_ratio`` is the observed spacing over the tagged or
   mean imputed mounting height, and each table is fitted (:func:`bayesnets.fit_network`,
   a Dirichlet prior centred on the base) from the streets where *its own* variable is
   observed, with the parents as observed or imputed. :data:`DEFAULT_ITERATIONS` rounds,
   the first imputing with the base, each further one with the network of the round
   before (stochastic EM). Tables of variables never observed (e.g. mounting height where
   no lamp is tagged) come out as the base's. The spacing ratio's states are widened to
   cover the evidence (:func:`spacing_ratio_states`): the base's design-guide states
   (2.5-4) would clip a city whose lamps stand closer. A base without an occupancy
   variable gets one (:func:`with_occupancy`, given the street class, prior at 1: the
   design guides' pole at every position).

Agreement (how far a street's own lamps support its derived value): the share of its lamps
on the majority side (single-sided), paired (opposite), unpaired (staggered) or on the
centreline (central); the share of its position gaps within :data:`SPACING_AGREEMENT` of
the spacing (spacing, and occupancy, which rests on it); the share of tagged heights within
:data:`SPACING_AGREEMENT` of their median (mounting height). The report gives, per field,
the number of streets with evidence and the share of them whose agreement is at least
:data:`AGREEMENT_THRESHOLD`.

Length: about 1250 lines, because the assignment, the evidence, the agreement and the
iterated fit share one street table and its column names; each step is a function of it.
"""

from __future__ import annotations

import datetime
import json
import os
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely

from bayesnets import BayesNet, fit_network, write_network
from bayesnets.binding import Binding
from bayesnets.errors import BayesNetError, BayesNetWarning
from bayesnets.network import CONFIG_NAME
from nightlights._typing import PathLike
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError, OutputError
from nightlights.io import as_vector, write_gpkg
from nightlights.io.vector import FieldType
from nightlights.streets._checks import finite_vertices, rng_from_seed
from nightlights.streets._fit import network_folder
from nightlights.streets._mapping import parse_length, parse_packed_tags
from nightlights.streets._sample import (
    fill_lighting,
    network_by_location,
    network_for_streets,
    resolve_network,
)
from nightlights.streets.schema import (
    ARRANGEMENTS,
    STREET_CLASSES,
    STREET_FIELDS,
    VALUE_RANGES,
    observed_field,
)

__all__ = [
    "AGREEMENT_THRESHOLD",
    "CENTRE_TOLERANCE",
    "DEFAULT_MAX_DISTANCE",
    "LampAssignment",
    "LearnReport",
    "LearnResult",
    "assign_lamps",
    "learn",
    "learn_lighting_network",
    "spacing_ratio_states",
    "street_lamp_evidence",
    "with_occupancy",
]

#: Default reach of a lamp [m]: half a wide carriageway plus a pavement and a setback.
DEFAULT_MAX_DISTANCE = 25.0
#: Lamps closer than this to the centreline stand on it [m]: span-wire lamps over the
#: carriageway, mapped on the way, and twin-arm poles on a median.
CENTRE_TOLERANCE = 1.5
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
#: A street's evidence agrees when at least this share of its lamps (gaps) agree [1].
AGREEMENT_THRESHOLD = 0.75
#: Rounds of imputation and fitting (stochastic EM) [1].
DEFAULT_ITERATIONS = 5
#: Likelihood-weighting candidates per street when imputing unobserved fields [1].
IMPUTATION_CANDIDATES = 64
#: Imputations per street and round (Monte Carlo E-step) [1]; the mounting height that
#: turns a spacing into a spacing ratio is their mean.
IMPUTATION_DRAWS = 8
#: Floor of every bound table of the imputing network [1]: the base's zeros are design
#: rules (e.g. never single-sided when the road is wider than 1.5 mounting heights), not
#: observations; without a floor, a street that breaks a rule could never be imputed into
#: the parent state the rule forbids, and the fit could never learn that it happens.
IMPUTATION_FLOOR = 0.01
#: Fields of a lamp layer holding the mounting height, in order of preference (OSM
#: ``height`` on a ``highway=street_lamp`` node, in a column or GDAL's ``other_tags``).
HEIGHT_FIELDS = ("mounting_height", "height")

#: Files of the network folder besides the tables: the per-street evidence (layer
#: ``streets``) and the lamps with their streets (layer ``lamps``).
EVIDENCE_FILE = "evidence_streets.gpkg"
LAMPS_FILE = "evidence_lamps.gpkg"
REPORT_FILE = "learn_report.json"

#: Fields of the per-street evidence layer and their types.
#: Lighting fields derived from the lamps, in report order.
DERIVED_FIELDS = ("arrangement", "spacing", "occupancy", "mounting_height")

#: Variable a learned network adds when its base binds no ``occupancy`` field, its parent,
#: and its states [1]: the share of the pole positions at the street's spacing that hold a
#: pole, in tenths. The prior puts every street class at 1, the design guides' assumption
#: of a pole at every position.
OCCUPANCY_VARIABLE = "OCCUPANCY"
OCCUPANCY_PARENT = "STREET_CLASS"
OCCUPANCY_STATES = tuple(round(0.1 * k, 1) for k in range(1, 11))

EVIDENCE_SCHEMA: dict[str, FieldType] = {
    "source_id": "str",
    "street_class": "str",
    "lamps": "int",
    "lamps_left": "int",
    "lamps_right": "int",
    "lamps_centre": "int",
    "same_side_gaps": "int",
    "median_gap": "float",
    "arrangement": "str",
    "spacing": "float",
    "unusual_spacing": "float",
    "positions": "int",
    "occupancy": "float",
    "mounting_height": "float",
    "lit": "bool",
    "arrangement_agreement": "float",
    "spacing_agreement": "float",
    "occupancy_agreement": "float",
    "mounting_height_agreement": "float",
    **{observed_field(name): "bool" for name in DERIVED_FIELDS},
}

#: Fields of the assigned-lamp layer and their types.
LAMP_SCHEMA: dict[str, FieldType] = {
    "street_id": "str",
    "distance": "float",
    "along": "float",
    "offset": "float",
    "side": "str",
    "interior": "bool",
    "height": "float",
}


# --- assignment ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class LampAssignment:
    """Where each lamp stands relative to the street it was assigned to.

    Attributes
    ----------
    street
        Row of the assigned street in the street layer, -1 for a lamp out of reach; shape
        ``(n_lamps,)``.
    distance
        Distance from the lamp to the street [m] (NaN when unassigned).
    along
        Position of the lamp's projection along the street from its first vertex [m].
    offset
        Signed distance from the centreline, positive left of the line direction [m].
    side
        +1 left, -1 right, 0 on the centreline (within the centre tolerance).
    interior
        Whether the lamp projects onto the street's interior (not onto an end point).
    """

    street: np.ndarray
    distance: np.ndarray
    along: np.ndarray
    offset: np.ndarray
    side: np.ndarray
    interior: np.ndarray

    @property
    def assigned(self) -> np.ndarray:
        """``bool`` per lamp: assigned to a street."""
        return self.street >= 0


def assign_lamps(
    lamps: np.ndarray,
    streets: np.ndarray,
    *,
    max_distance: float = DEFAULT_MAX_DISTANCE,
    street_rank: np.ndarray | None = None,
    allowed: np.ndarray | None = None,
    centre_tolerance: float = CENTRE_TOLERANCE,
) -> LampAssignment:
    """Assign each lamp to one street within ``max_distance``, junction-aware.

    Among the streets within reach, a street onto whose interior the lamp projects beats
    one whose nearest point is an end point; then the smaller distance wins; then the
    lower ``street_rank`` (the higher street class); then the first street.

    Parameters
    ----------
    lamps
        Point geometries, shape ``(n_lamps,)``, in a projected CRS [m].
    streets
        LineString geometries, shape ``(n_streets,)``, same CRS [m].
    max_distance
        Largest lamp-to-street distance [m].
    street_rank
        Rank per street, lower first at equal distance (e.g. the index of its class in
        :data:`~nightlights.streets.schema.STREET_CLASSES`); default all equal.
    allowed
        ``bool`` per street: whether it may take lamps (default all).
    centre_tolerance
        Lamps closer than this to the centreline get side 0 [m].

    Returns
    -------
    LampAssignment
        Street, distance, along-street position, signed offset and side per lamp.

    Examples
    --------
    >>> from shapely import LineString, Point
    >>> # a through street (0) and a side street (1) ending at it; the lamp stands beside
    >>> # the through street, 4 m from the side street's end point
    >>> streets = np.array([LineString([(0, 0), (100, 0)]), LineString([(50, 0), (50, 80)])])
    >>> result = assign_lamps(np.array([Point(53, -3)]), streets)
    >>> int(result.street[0]), int(result.side[0])
    (0, -1)
    """
    lamps = np.asarray(lamps, dtype=object)
    streets = np.asarray(streets, dtype=object)
    n = len(lamps)
    street = np.full(n, -1, dtype=np.int64)
    distance = np.full(n, np.nan)
    along = np.full(n, np.nan)
    offset = np.full(n, np.nan)
    side = np.zeros(n, dtype=np.int64)
    interior = np.zeros(n, dtype=bool)
    if n == 0 or len(streets) == 0:
        return LampAssignment(street, distance, along, offset, side, interior)
    tree = shapely.STRtree(streets)
    lamp_index, street_index = tree.query(lamps, predicate="dwithin", distance=max_distance)
    if allowed is not None:
        keep = np.asarray(allowed, dtype=bool)[street_index]
        lamp_index, street_index = lamp_index[keep], street_index[keep]
    if lamp_index.size:
        lines = streets[street_index]
        points = lamps[lamp_index]
        pair_distance = shapely.distance(points, lines)
        pair_along = shapely.line_locate_point(lines, points)
        length = shapely.length(lines)
        end_tolerance = 1e-6 * np.maximum(length, 1.0)
        pair_interior = (pair_along > end_tolerance) & (pair_along < length - end_tolerance)
        rank = (
            np.zeros(len(streets)) if street_rank is None else np.asarray(street_rank, dtype=float)
        )[street_index]
        order = np.lexsort((street_index, rank, pair_distance, ~pair_interior, lamp_index))
        first = order[np.r_[True, lamp_index[order][1:] != lamp_index[order][:-1]]]
        chosen = lamp_index[first]
        street[chosen] = street_index[first]
        distance[chosen] = pair_distance[first]
        along[chosen] = pair_along[first]
        interior[chosen] = pair_interior[first]
        signed = _signed_offset(streets[street_index[first]], lamps[chosen], pair_along[first])
        offset[chosen] = signed
        side[chosen] = np.where(np.abs(signed) < centre_tolerance, 0, np.sign(signed)).astype(
            np.int64
        )
    return LampAssignment(street, distance, along, offset, side, interior)


#: Half-length of the chord giving the local street direction at a lamp's projection [m].
_TANGENT_STEP = 1.0


def _signed_offset(lines: np.ndarray, points: np.ndarray, along: np.ndarray) -> np.ndarray:
    """Distance of ``points`` from ``lines``, positive left of the line direction [m]."""
    length = shapely.length(lines)
    ahead = shapely.line_interpolate_point(lines, np.minimum(along + _TANGENT_STEP, length))
    behind = shapely.line_interpolate_point(lines, np.maximum(along - _TANGENT_STEP, 0.0))
    tangent = shapely.get_coordinates(ahead) - shapely.get_coordinates(behind)
    foot = shapely.get_coordinates(shapely.line_interpolate_point(lines, along))
    relative = shapely.get_coordinates(points)[:, :2] - foot[:, :2]
    cross = tangent[:, 0] * relative[:, 1] - tangent[:, 1] * relative[:, 0]
    norm = np.hypot(tangent[:, 0], tangent[:, 1])
    norm[norm == 0] = 1.0
    return cross / norm


# --- evidence per street ---------------------------------------------------------------------


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
        Lamps assigned to streets (:func:`assign_lamps`).
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


# --- fitting ---------------------------------------------------------------------------------


#: Steps of the widened spacing-ratio grid: (upper end of the range, step) [1]; about 10 %
#: of the ratio, finer than the base's 0.5 so that rounding moves a spacing by at most ~6 %.
_RATIO_STEPS = ((4.0, 0.25), (8.0, 0.5), (16.0, 1.0), (50.0, 2.0))


def spacing_ratio_states(base_states: tuple[float, ...], ratios: np.ndarray) -> tuple[float, ...]:
    """States of the spacing ratio that cover the base's states and the evidence.

    Parameters
    ----------
    base_states
        The base network's spacing-ratio states [1].
    ratios
        Observed spacing ratios [1] (NaN ignored).

    Returns
    -------
    tuple of float
        Sorted states: the base's plus a grid from the smallest to the largest observed
        ratio (step 0.25 up to 4, 0.5 up to 8, 1 up to 16, 2 beyond), within the allowed
        range of :data:`~nightlights.streets.schema.VALUE_RANGES`.

    Examples
    --------
    >>> spacing_ratio_states((2.5, 3.0), np.array([1.6, 2.2, 4.4]))
    (1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5, 3.75, 4.0, 4.5)
    """
    values = np.asarray(ratios, dtype=float)
    values = values[np.isfinite(values)]
    states = set(base_states)
    if values.size:
        low, high = float(values.min()), float(values.max())
        limits = VALUE_RANGES["spacing_ratio"]
        start = 0.0
        for end, step in _RATIO_STEPS:
            grid = np.arange(start, end + step / 2, step)
            lower = np.floor(low / step) * step
            upper = np.ceil(high / step) * step
            grid = grid[(grid >= lower) & (grid <= upper) & (grid >= start)]
            states.update(float(g) for g in grid if not limits.impossible(np.array([g]))[0])
            start = end
    return tuple(sorted(states))


def _widen_spacing_ratio(base: BayesNet, ratios: np.ndarray) -> BayesNet:
    """``base`` with the spacing ratio's states widened (new states with prior weight 0)."""
    variable = next((v for v, b in base.bindings.items() if b.field == "spacing_ratio"), None)
    if variable is None:
        raise BayesNetError(f"network {base.name!r} binds no variable to field 'spacing_ratio'")
    binding = base.bindings[variable]
    if binding.kind not in ("float", "int") or base.children[variable]:
        raise BayesNetError(
            f"network {base.name!r}: variable {variable} (spacing_ratio) must be a numeric "
            "leaf to learn spacing from lamps"
        )
    old = tuple(float(n) for n in binding.numbers)
    numbers = spacing_ratio_states(old, ratios)
    if numbers == tuple(sorted(old)):
        return base
    labels = tuple(f"{n:g}" for n in numbers)
    table = base.tables[variable]
    widened = np.zeros((len(numbers), *table.shape[1:]))
    for row, number in enumerate(old):
        widened[numbers.index(number)] = table[row]
    states = dict(base.states)
    states[variable] = labels
    tables = dict(base.tables)
    tables[variable] = widened
    bindings = dict(base.bindings)
    bindings[variable] = Binding(
        variable, binding.field, "float", labels, numbers, (), nearest=True
    )
    return replace(base, states=states, tables=tables, bindings=bindings)


def with_occupancy(network: BayesNet) -> BayesNet:
    """``network`` with an occupancy variable, if it binds none.

    Parameters
    ----------
    network
        A street-lighting network.

    Returns
    -------
    bayesnets.BayesNet
        ``network`` itself when a variable is bound to the ``occupancy`` field; otherwise a
        copy with :data:`OCCUPANCY_VARIABLE` (states :data:`OCCUPANCY_STATES`, parent
        :data:`OCCUPANCY_PARENT` where the network has it) whose table puts every parent
        state at occupancy 1: the design guides' pole at every position, the prior that
        lamp evidence moves.

    Examples
    --------
    >>> from bayesnets import load_network
    >>> net = with_occupancy(load_network("europe"))
    >>> net.bindings["OCCUPANCY"].field, net.parents["OCCUPANCY"]
    ('occupancy', ('STREET_CLASS',))
    >>> float(net.tables["OCCUPANCY"][-1].min())
    1.0
    """
    if any(binding.field == "occupancy" for binding in network.bindings.values()):
        return network
    if OCCUPANCY_VARIABLE in network.variables:
        raise BayesNetError(
            f"network {network.name!r} has a variable {OCCUPANCY_VARIABLE} not bound to the "
            "occupancy field"
        )
    parents = (OCCUPANCY_PARENT,) if OCCUPANCY_PARENT in network.variables else ()
    labels = tuple(f"{n:g}" for n in OCCUPANCY_STATES)
    table = np.zeros((len(labels), *(len(network.states[p]) for p in parents)))
    table[-1] = 1.0
    return replace(
        network,
        variables=(*network.variables, OCCUPANCY_VARIABLE),
        states={**network.states, OCCUPANCY_VARIABLE: labels},
        parents={**network.parents, OCCUPANCY_VARIABLE: parents},
        tables={**network.tables, OCCUPANCY_VARIABLE: table},
        bindings={
            **network.bindings,
            OCCUPANCY_VARIABLE: Binding(
                OCCUPANCY_VARIABLE, "occupancy", "float", labels, OCCUPANCY_STATES, (), nearest=True
            ),
        },
    )


def learn_lighting_network(
    streets: gpd.GeoDataFrame | pd.DataFrame,
    evidence: pd.DataFrame,
    base: str | os.PathLike[str] | BayesNet | None = None,
    *,
    prior: float = 1.0,
    iterations: int = DEFAULT_ITERATIONS,
    rng: np.random.Generator,
    name: str | None = None,
) -> BayesNet:
    """Fit ``base`` to streets with lamp evidence, imputing unobserved parents.

    Parameters
    ----------
    streets
        Normalised streets: canonical street fields with ``<field>_observed`` flags.
    evidence
        Per-street evidence, same row order (:func:`street_lamp_evidence`, with ``lit``
        and ``lit_observed`` set from the lamps where the layer has no ``lit`` value).
    base
        Base network: structure, states, bindings and prior; None for the catalogue
        network for where the streets lie (the catalogue default for a table without a
        CRS).
    prior
        Prior strength in pseudo-observations per parent combination [1].
    iterations
        Rounds of imputation and fitting [1]: the first imputes with ``base``, each
        further one with the network fitted in the round before (stochastic EM).
    rng
        Random generator for the imputation.
    name
        Name of the learned network (default ``<base>_learned``).

    Returns
    -------
    bayesnets.BayesNet
        The learned network: the base's structure and bindings, the spacing ratio's states
        widened to the evidence.
    """
    net = network_for_streets(streets, base)
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise InputError(f"iterations={iterations!r}; expected an integer >= 1")
    if isinstance(streets, gpd.GeoDataFrame):
        streets = pd.DataFrame(streets.drop(columns=streets.geometry.name))
    layer = streets.reset_index(drop=True)
    known = _known_fields(layer, evidence)
    spacing = pd.to_numeric(evidence["spacing"], errors="coerce").to_numpy(float)
    draw_input = layer.copy()
    for field_name in ("arrangement", "mounting_height", "lit"):
        draw_input[field_name] = known[field_name]
        draw_input[observed_field(field_name)] = known[field_name].notna().to_numpy()
    tagged_height = known["mounting_height"].astype(float).to_numpy()
    draws = IMPUTATION_DRAWS
    stacked_input = pd.concat([draw_input] * draws, ignore_index=True)
    stacked_known = pd.concat([known] * draws, ignore_index=True)
    model, widened = net, None
    for _ in range(iterations):
        with warnings.catch_warnings():
            # evidence impossible under the imputing network is relaxed for the
            # imputation only; the fit still counts the observed value
            warnings.simplefilter("ignore", BayesNetWarning)
            drawn = fill_lighting(
                stacked_input,
                _floored(model),
                candidates=IMPUTATION_CANDIDATES,
                rng=rng,
                on_conflict="relax",
            ).reset_index(drop=True)
        drawn_height = drawn["mounting_height"].to_numpy(float).reshape(draws, -1)
        height = np.where(np.isfinite(tagged_height), tagged_height, drawn_height.mean(axis=0))
        ratio = spacing / height
        stacked_known["spacing_ratio"] = pd.Series(np.tile(ratio, draws), dtype=object).where(
            np.isfinite(np.tile(ratio, draws)), None
        )
        if widened is None:
            widened = with_occupancy(_widen_spacing_ratio(net, ratio))
        # Monte Carlo E-step: every draw is a record; the prior is scaled by the number of
        # draws so that it weighs as much against the data as with one record per street
        model = replace(widened, tables=_fit_tables(stacked_known, drawn, widened, prior * draws))
    assert widened is not None
    return replace(
        model,
        name=name or f"{net.name}_learned",
        description=(
            f"Learned from mapped street lamps on {len(layer)} streets "
            f"({int(evidence['spacing_observed'].sum())} with spacing evidence) with network "
            f"{net.name!r} as prior ({prior:g} pseudo-observations per parent combination)."
        ),
        default=False,
        source=None,
    )


def _floored(network: BayesNet) -> BayesNet:
    """``network`` with each bound variable's table floored at :data:`IMPUTATION_FLOOR`."""
    tables = dict(network.tables)
    for variable in network.bindings:
        table = network.tables[variable] + IMPUTATION_FLOOR
        tables[variable] = table / table.sum(axis=0, keepdims=True)
    return replace(network, tables=tables)


def _fit_tables(
    known: pd.DataFrame, drawn: pd.DataFrame, network: BayesNet, prior: float
) -> dict[str, np.ndarray]:
    """Each bound variable's table from the records where it is observed, its parents
    observed or imputed; the prior is ``network`` (tables of unobserved variables kept)."""
    complete = pd.DataFrame(index=known.index)
    for binding in network.bindings.values():
        imputed = drawn[binding.field].astype(object) if binding.field in drawn else None
        values = known[binding.field] if binding.field in known else None
        if values is None:
            complete[binding.field] = imputed
        elif imputed is None:
            complete[binding.field] = values
        else:
            complete[binding.field] = values.where(values.notna(), imputed)
    tables = dict(network.tables)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNetWarning)  # tables outside the family kept
        for variable, binding in network.bindings.items():
            observed = known[binding.field] if binding.field in known else None
            if observed is None or observed.notna().sum() == 0:
                continue
            fields = _family_fields(network, variable)
            frame = complete[fields].copy()
            frame[binding.field] = observed
            tables[variable] = fit_network(frame, network, prior=prior).tables[variable]
    return tables


def _family_fields(network: BayesNet, variable: str) -> list[str]:
    """Fields that give ``variable`` and its parents (a hidden parent through its own)."""
    fields: list[str] = []
    for member in (variable, *network.parents[variable]):
        bound = network.field_of(member)
        members = [bound] if bound else [network.field_of(p) for p in network.parents[member]]
        fields.extend(f for f in members if f and f not in fields)
    return fields


def _known_fields(layer: pd.DataFrame, evidence: pd.DataFrame) -> pd.DataFrame:
    """Observed values of every street and lighting field (object dtype, None unknown)."""
    known = pd.DataFrame(index=layer.index)
    for name in STREET_FIELDS:
        if name not in layer:
            known[name] = pd.Series([None] * len(layer), dtype=object)
            continue
        flag = observed_field(name)
        seen = layer[name].notna().to_numpy().copy()
        if flag in layer:
            seen &= layer[flag].astype("boolean").fillna(False).to_numpy(bool)
        known[name] = layer[name].astype(object).where(seen, None)
    lamp_lit = evidence["lamps"].to_numpy() > 0
    known["lit"] = known["lit"].where(known["lit"].notna() | ~lamp_lit, True)
    for name in ("arrangement", "mounting_height", "occupancy"):
        if name not in evidence:
            known[name] = pd.Series([None] * len(layer), dtype=object)
            continue
        values = evidence[name].astype(object).reset_index(drop=True)
        known[name] = values.where(evidence[observed_field(name)].to_numpy(bool), None)
    return known


# --- the stage -------------------------------------------------------------------------------


@dataclass
class FieldEvidence:
    """Evidence of one derived field.

    Attributes
    ----------
    streets
        Streets with a derived value [1].
    agreeing
        Of those, streets whose own lamps agree with the value (agreement at least
        :data:`AGREEMENT_THRESHOLD`) [1].
    summary
        Value counts (arrangement) or the 10th, 50th and 90th percentiles [field unit].
    """

    streets: int = 0
    agreeing: int = 0
    summary: dict[str, float] = field(default_factory=dict)

    @property
    def agreement(self) -> float:
        """Share of evidence streets whose lamps agree [1]; NaN without evidence."""
        return self.agreeing / self.streets if self.streets else float("nan")


@dataclass
class LearnReport:
    """What the lamps gave.

    Attributes
    ----------
    lamps
        Lamps in the layer [1].
    assigned
        Lamps assigned to a street within the distance [1].
    interior
        Assigned lamps that project onto their street's interior [1].
    streets
        Streets in the layer [1].
    streets_with_lamps
        Streets with at least one assigned lamp (their ``lit`` is known) [1].
    lit_from_lamps
        Streets whose ``lit`` came from their lamps (no ``lit`` value in the layer) [1].
    unlit_tagged
        Streets tagged ``lit=no``, which take no lamps [1].
    fields
        Derived field -> :class:`FieldEvidence`.
    max_distance
        Reach of a lamp [m].
    """

    lamps: int = 0
    assigned: int = 0
    interior: int = 0
    streets: int = 0
    streets_with_lamps: int = 0
    lit_from_lamps: int = 0
    unlit_tagged: int = 0
    fields: dict[str, FieldEvidence] = field(default_factory=dict)
    max_distance: float = DEFAULT_MAX_DISTANCE

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON-ready values."""
        out: dict[str, Any] = {
            key: getattr(self, key)
            for key in (
                "lamps",
                "assigned",
                "interior",
                "streets",
                "streets_with_lamps",
                "lit_from_lamps",
                "unlit_tagged",
                "max_distance",
            )
        }
        out["fields"] = {
            name: {
                "streets": value.streets,
                "agreeing": value.agreeing,
                "agreement": None if value.streets == 0 else round(value.agreement, 4),
                "summary": value.summary,
            }
            for name, value in self.fields.items()
        }
        return out


@dataclass(frozen=True, eq=False)
class LearnResult:
    """What :func:`learn` returns.

    Attributes
    ----------
    network
        The learned network; ``streets sample`` takes it (or its folder) as ``network``.
    report
        Counts and agreement of the evidence (:class:`LearnReport`).
    evidence
        The streets with their lamp counts and derived fields (see
        :func:`street_lamp_evidence`).
    lamps
        The lamps with the street they were assigned to (``street_id``, empty when out of
        reach), ``distance``, ``along``, ``offset`` [m], ``side`` and ``interior``.
    path
        The network folder written, or None.
    """

    network: BayesNet
    report: LearnReport
    evidence: gpd.GeoDataFrame
    lamps: gpd.GeoDataFrame
    path: Path | None


def learn(
    streets: gpd.GeoDataFrame | PathLike,
    lamps: gpd.GeoDataFrame | PathLike,
    out_dir: PathLike | None = None,
    *,
    network: str | os.PathLike[str] | BayesNet | None = None,
    max_distance: float = DEFAULT_MAX_DISTANCE,
    prior: float = 1.0,
    iterations: int = DEFAULT_ITERATIONS,
    seed: int | None = None,
    lamps_layer: str | None = None,
    name: str | None = None,
    overwrite: bool = False,
) -> LearnResult:
    """Learn a street-lighting network from mapped street lamps.

    Stage ``streets learn``: assign lamps to streets, derive per-street lighting fields
    where the evidence suffices, and fit the base network's tables to them with the base as
    prior (see the module notes for the rules).

    Parameters
    ----------
    streets
        Normalised streets (the result of :func:`~nightlights.streets._normalize`): lines in
        a projected CRS [m] with the canonical fields and their ``_observed`` flags. A
        GeoDataFrame or a vector file path.
    lamps
        Points of real lamps: a GeoDataFrame or any vector file (an OSM file's ``points``
        layer by default). Where the layer has a ``highway`` field (OpenStreetMap), only
        ``highway=street_lamp`` points are lamps. Heights come from a ``mounting_height``
        or ``height`` field, or ``height`` in OSM's ``other_tags``.
    out_dir
        Network folder to write (tables, ``network.toml``, ``learn_report.json``,
        ``evidence_streets.gpkg`` and ``evidence_lamps.gpkg``); must not exist or be
        empty unless ``overwrite``. Written to a temporary folder first and renamed.
        None writes nothing.
    network
        Base network (object, catalogue name or folder); default: the catalogue network for
        where the streets lie (as ``streets sample`` chooses it).
    max_distance
        Largest lamp-to-street distance [m].
    prior
        Prior strength in pseudo-observations per parent combination [1].
    iterations
        Rounds of imputation and fitting (see :func:`learn_lighting_network`) [1].
    seed
        Random seed of the imputation; the same seed gives the same network.
    lamps_layer
        Layer of the lamp file (default: ``points`` for OSM files, else the first).
    name
        Name of the learned network (default: the folder's name, else ``<base>_learned``).
    overwrite
        Replace an existing network folder (one holding ``network.toml``).

    Returns
    -------
    LearnResult
        The network, the report, the evidence layers and the written folder (or None).

    Raises
    ------
    InputError
        ``max_distance`` not positive and finite; layers without a projected CRS (the
        lamps are reprojected to the streets' CRS); a negative seed.
    EmptyInputError
        No streets, no lamps, or no street with enough lamps to derive a field.
    OutputError
        ``out_dir`` exists and is not an empty folder (or, with ``overwrite``, not a network
        folder); its parent folder is missing.
    bayesnets.errors.BayesNetError
        A value the base network cannot map.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import LineString, Point
    >>> from nightlights.streets import learn
    >>> streets = gpd.GeoDataFrame(
    ...     {"source_id": ["a"], "street_class": ["local"], "street_class_observed": [True]},
    ...     geometry=[LineString([(0, 0), (200, 0)])], crs="EPSG:3067")
    >>> lamps = gpd.GeoDataFrame(
    ...     geometry=[Point(x, -6) for x in range(10, 200, 20)], crs="EPSG:3067")
    >>> result = learn(streets, lamps, network="europe", seed=0)
    >>> row = result.evidence.iloc[0]
    >>> row["arrangement"], float(row["spacing"])
    ('single_sided', 20.0)
    >>> result.report.fields["spacing"].streets
    1
    """
    if not (isinstance(max_distance, int | float) and np.isfinite(max_distance)) or (
        max_distance <= 0
    ):
        raise InputError(f"max_distance={max_distance!r}; expected a distance > 0 [m]")
    if not np.isfinite(prior) or prior < 0:
        raise InputError(f"prior={prior!r}; expected a non-negative pseudo-count")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise InputError(f"iterations={iterations!r}; expected an integer >= 1")
    rng = rng_from_seed(seed)
    target = Path(out_dir) if out_dir is not None else None
    if target is not None:
        _check_target(target, overwrite)
    frame, source = as_vector(streets, name="streets")
    if frame.empty:
        raise EmptyInputError(f"{source}: the layer has no streets")
    if frame.crs is None or not frame.crs.is_projected:
        raise InputError(
            f"{source}: streets must be in a projected CRS [m] (run `nightlights streets "
            "normalize` first)"
        )
    points, lamp_source = _read_lamps(lamps, lamps_layer, frame.crs)
    frame = frame.reset_index(drop=True)
    if network is None:
        # the base network for where the streets lie, as streets sample chooses it
        network, _ = network_by_location(frame, source=str(source))
    base = resolve_network(network)
    rank = _street_rank(frame)
    lit = frame["lit"].astype("boolean") if "lit" in frame else pd.Series(pd.NA, index=frame.index)
    unlit = (lit == False).fillna(False).to_numpy(bool)  # noqa: E712 (nullable boolean)
    assignment = assign_lamps(
        points.geometry.to_numpy(),
        frame.geometry.to_numpy(),
        max_distance=float(max_distance),
        street_rank=rank,
        allowed=~unlit,
    )
    evidence = street_lamp_evidence(
        assignment,
        len(frame),
        heights=_lamp_heights(points),
        lengths=shapely.length(frame.geometry.to_numpy()),
    )
    if (
        not evidence["arrangement_observed"].any()
        and not evidence["mounting_height_observed"].any()
    ):
        raise EmptyInputError(
            f"{lamp_source}: no street has two lamps on one side within {max_distance:g} m "
            f"of {source}; nothing to learn from"
        )
    if target is not None and name is None:
        name = target.name
    report = _report(frame, evidence, assignment, unlit, float(max_distance))
    try:
        learned = learn_lighting_network(
            frame, evidence, base, prior=prior, iterations=iterations, rng=rng, name=name
        )
    except BayesNetError as exc:
        raise type(exc)(f"{source}: {exc}") from exc
    learned = replace(
        learned,
        metadata={
            "learned_from_streets": _file_label(source),
            "learned_from_lamps": _file_label(lamp_source),
            "base_network": base.name,
            "base_region": str(base.metadata.get("region", "")),
            "lamps_assigned": report.assigned,
            "streets_with_spacing": report.fields["spacing"].streets,
            "max_distance_m": float(max_distance),
            "prior": float(prior),
            "iterations": iterations,
            "seed": -1 if seed is None else int(seed),
            "learned_on": datetime.date.today().isoformat(),
        },
    )
    evidence_layer = _evidence_layer(frame, evidence)
    lamp_layer = _lamp_layer(points, frame, assignment)
    if target is not None:
        with network_folder(target) as tmp:
            assert tmp is not None  # a folder for a target
            write_network(learned, tmp)
            (tmp / REPORT_FILE).write_text(
                json.dumps(report.as_dict(), indent=2) + "\n", encoding="utf-8"
            )
            write_gpkg(evidence_layer, tmp / EVIDENCE_FILE, layer="streets", schema=EVIDENCE_SCHEMA)
            write_gpkg(lamp_layer, tmp / LAMPS_FILE, layer="lamps", schema=LAMP_SCHEMA)
    return LearnResult(learned, report, evidence_layer, lamp_layer, target)


def _file_label(source: str) -> str:
    """A file's name (no folders: the metadata travels with the network), or the label of an
    in-memory layer."""
    return source if source.startswith("in-memory") else Path(source).name


def _check_target(target: Path, overwrite: bool) -> None:
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{target}: parent folder {parent} does not exist")
    if not target.exists() or (target.is_dir() and not any(target.iterdir())):
        return
    if not target.is_dir():
        raise OutputError(f"{target}: exists and is not a folder")
    if not overwrite:
        raise OutputError(f"{target}: exists and is not an empty folder; give overwrite=True")
    if not (target / CONFIG_NAME).exists():
        raise OutputError(
            f"{target}: not a network folder (no {CONFIG_NAME}); overwrite=True replaces only those"
        )


def _read_lamps(
    lamps: gpd.GeoDataFrame | PathLike, layer: str | None, crs: Any
) -> tuple[gpd.GeoDataFrame, str]:
    """The lamp points in the streets' CRS (OSM: ``highway=street_lamp`` only)."""
    if layer is None and not isinstance(lamps, gpd.GeoDataFrame):
        lower = str(lamps).lower()
        if lower.endswith((".pbf", ".osm", ".osm.gz", ".osm.bz2")):
            layer = "points"
    points, source = as_vector(lamps, layer=layer, name="lamps")
    if points.crs is None:
        raise InputError(f"{source}: the lamp layer has no CRS")
    if "highway" in points:
        points = points.loc[points["highway"].astype(str) == "street_lamp"]
    points = points.loc[~(points.geometry.isna() | points.geometry.is_empty)]
    points = points.explode(index_parts=False)  # a multi-point is one lamp per point
    kept = (points.geometry.geom_type == "Point").to_numpy() & finite_vertices(
        points.geometry.to_numpy()
    )
    if (~kept).any():
        warnings.warn(
            f"{source}: {int((~kept).sum())} lamp feature(s) that are not points with finite "
            "coordinates dropped",
            DataQualityWarning,
            stacklevel=3,
        )
    points = points.loc[kept]
    if points.empty:
        raise EmptyInputError(f"{source}: no lamp points (highway=street_lamp for OSM layers)")
    return points.to_crs(crs).reset_index(drop=True), source


def _lamp_heights(points: gpd.GeoDataFrame) -> np.ndarray:
    """Tagged mounting height per lamp [m], NaN where untagged or implausible."""
    raw = pd.Series([None] * len(points), index=points.index, dtype=object)
    for name in HEIGHT_FIELDS:
        if name in points:
            raw = raw.where(raw.notna(), points[name].astype(object))
    if "other_tags" in points:
        packed = points["other_tags"].map(lambda text: parse_packed_tags(text).get("height"))
        raw = raw.where(raw.notna(), packed)
    heights = np.array([parse_length(v) for v in raw], dtype=float)
    limits = VALUE_RANGES["mounting_height"]
    heights[np.isfinite(heights) & limits.impossible(np.nan_to_num(heights))] = np.nan
    return heights


def _street_rank(frame: pd.DataFrame) -> np.ndarray:
    ranks = {name: rank for rank, name in enumerate(STREET_CLASSES)}
    if "street_class" not in frame:
        return np.zeros(len(frame))
    return frame["street_class"].map(ranks).fillna(len(ranks)).to_numpy(float)


def _report(
    frame: pd.DataFrame,
    evidence: pd.DataFrame,
    assignment: LampAssignment,
    unlit: np.ndarray,
    max_distance: float,
) -> LearnReport:
    has_lamp = evidence["lamps"].to_numpy() > 0
    tagged = frame["lit"].notna().to_numpy() if "lit" in frame else np.zeros(len(frame), dtype=bool)
    report = LearnReport(
        lamps=len(assignment.street),
        assigned=int(assignment.assigned.sum()),
        interior=int((assignment.assigned & assignment.interior).sum()),
        streets=len(frame),
        streets_with_lamps=int(has_lamp.sum()),
        lit_from_lamps=int((has_lamp & ~tagged).sum()),
        unlit_tagged=int(unlit.sum()),
        max_distance=max_distance,
    )
    for name in DERIVED_FIELDS:
        if name not in evidence:
            continue
        seen = evidence[observed_field(name)].to_numpy(bool)
        agreement = evidence[f"{name}_agreement"].to_numpy(float)[seen]
        values = evidence.loc[seen, name]
        if name == "arrangement":
            summary = {a: float((values == a).sum()) for a in ARRANGEMENTS}
        elif seen.any():
            p10, p50, p90 = np.percentile(values.to_numpy(float), [10, 50, 90])
            summary = {
                "p10": round(float(p10), 2),
                "median": round(float(p50), 2),
                "p90": round(float(p90), 2),
            }
        else:
            summary = {}
        report.fields[name] = FieldEvidence(
            streets=int(seen.sum()),
            agreeing=int((agreement >= AGREEMENT_THRESHOLD).sum()),
            summary=summary,
        )
    return report


def _evidence_layer(frame: gpd.GeoDataFrame, evidence: pd.DataFrame) -> gpd.GeoDataFrame:
    out = evidence.copy()
    out.insert(
        0,
        "source_id",
        frame["source_id"].astype(str).to_numpy()
        if "source_id" in frame
        else frame.index.astype(str),
    )
    out.insert(
        1, "street_class", frame["street_class"].to_numpy() if "street_class" in frame else None
    )
    tagged = frame["lit"].astype("boolean") if "lit" in frame else pd.Series(pd.NA, index=out.index)
    out["lit"] = tagged.where(tagged.notna() | (out["lamps"] == 0), True).to_numpy()
    return gpd.GeoDataFrame(out, geometry=frame.geometry.to_numpy(), crs=frame.crs)


def _lamp_layer(
    points: gpd.GeoDataFrame, frame: gpd.GeoDataFrame, assignment: LampAssignment
) -> gpd.GeoDataFrame:
    ids = (
        frame["source_id"].astype(str).to_numpy()
        if "source_id" in frame
        else (frame.index.astype(str).to_numpy())
    )
    street_id = np.where(assignment.assigned, ids[np.maximum(assignment.street, 0)], None)
    side = np.array(["right", "centre", "left"], dtype=object)[assignment.side + 1]
    layer = pd.DataFrame(
        {
            "street_id": street_id,
            "distance": assignment.distance,
            "along": assignment.along,
            "offset": assignment.offset,
            "side": np.where(assignment.assigned, side, None),
            "interior": assignment.interior,
            "height": _lamp_heights(points),
        }
    )
    return gpd.GeoDataFrame(layer, geometry=points.geometry.to_numpy(), crs=frame.crs)
