"""Mapped street lamps assigned to streets: which street each lamp lights, and where on it.

The first step of stage ``streets learn`` (:mod:`nightlights.streets._learn`). Each lamp
goes to one street within ``max_distance``. Junction-aware: among the streets in reach,
those onto whose *interior* the lamp projects (not onto an end point) come first, then the
smaller distance, then the higher street class. A lamp beside a street near a junction
projects onto the interior of the street it stands along and onto the end of a side street
that stops there, so it goes to the former. Streets may be barred from taking lamps (the
stage bars those tagged ``lit=no``).

Each assigned lamp gets its position along the street (of its projection, from the first
vertex), its signed offset from the centreline (positive left of the line direction, the
direction taken from a short chord through the projection) and its side: left, right, or
on the centreline within :data:`CENTRE_TOLERANCE`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

__all__ = [
    "CENTRE_TOLERANCE",
    "DEFAULT_MAX_DISTANCE",
    "PAIR_BYTES",
    "LampAssignment",
    "assign_lamps",
    "estimate_pairs",
]

#: Default reach of a lamp [m]: half a wide carriageway plus a pavement and a setback.
DEFAULT_MAX_DISTANCE = 25.0
#: Lamps closer than this to the centreline stand on it [m]: span-wire lamps over the
#: carriageway, mapped on the way, and twin-arm poles on a median.
CENTRE_TOLERANCE = 1.5


#: Bytes per (lamp, street) pair within reach while lamps are assigned: the pair indices
#: (found and kept), the geometries gathered, distances, positions, lengths, ranks, the
#: interior mask and the sort order [B].
PAIR_BYTES = 160.0
#: Lamps queried to estimate the pairs within reach of all of them [1].
PAIR_SAMPLE = 256


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


def estimate_pairs(lamps: np.ndarray, streets: np.ndarray, *, max_distance: float) -> float:
    """The number of (lamp, street) pairs within ``max_distance`` that :func:`assign_lamps`
    would hold, estimated from up to :data:`PAIR_SAMPLE` lamps spread over the layer (queried
    a few at a time, so that the estimate itself holds little).

    Parameters
    ----------
    lamps
        Point geometries, shape ``(n_lamps,)`` [m].
    streets
        LineString geometries, shape ``(n_streets,)`` [m].
    max_distance
        Largest lamp-to-street distance [m].

    Returns
    -------
    float
        Estimated pairs [1] (exact when there are at most :data:`PAIR_SAMPLE` lamps).

    Examples
    --------
    >>> from shapely import LineString, Point
    >>> streets = np.array([LineString([(0, 0), (100, 0)]), LineString([(0, 50), (100, 50)])])
    >>> lamps = np.array([Point(x, 5) for x in range(0, 100, 10)])
    >>> estimate_pairs(lamps, streets, max_distance=10.0), estimate_pairs(
    ...     lamps, streets, max_distance=1e9)
    (10.0, 20.0)
    """
    lamps = np.asarray(lamps, dtype=object)
    streets = np.asarray(streets, dtype=object)
    if len(lamps) == 0 or len(streets) == 0:
        return 0.0
    tree = shapely.STRtree(streets)
    sample = np.unique(np.linspace(0, len(lamps) - 1, min(len(lamps), PAIR_SAMPLE)).astype(int))
    step = max(1, min(16, 1_000_000 // len(streets)))
    found = 0
    for start in range(0, sample.size, step):
        pairs, _ = tree.query(
            lamps[sample[start : start + step]], predicate="dwithin", distance=max_distance
        )
        found += pairs.size
    return found / sample.size * len(lamps)


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
