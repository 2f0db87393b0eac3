"""EN 13201-3 calculation fields laid along the segments of a real street layer.

A street segment (a line in a projected CRS) of length :math:`\\ell`, carriageway width
:math:`W` in :math:`n` lanes (:math:`W_L = W / n`) and luminaire spacing :math:`S` is cut into
:math:`\\max(1, \\lfloor \\ell / S \\rfloor)` sections of length :math:`S`, centred on the
segment. Each section carries the field of :func:`~nightlights.roads.calculation_field`
(rows :math:`D = S/N` apart, three points per lane for luminance, at most 1.5 m apart across
for illuminance) and, for the edge illuminance ratio, four strips of width
:math:`\\min(5\\,\\text{m}, W/2)` inside and outside each carriageway edge laid out by the
illuminance rule. A road-frame point :math:`(x, y)` of a section that starts at arc length
:math:`s_0` stands at

.. math:: p = C(s_0 + x) + (y - W/2)\\, \\hat n(s_0 + x)

with :math:`C` the segment's centreline and :math:`\\hat n` its left normal, so that the
straight-road frame of :mod:`nightlights.roads._field` (``y`` from the right edge, looking
along the line) bends with the street. The observers of a section stand 60 m before it in the
centre of each lane, 1.5 m high, all looking along the line (EN 13201-3:2015, Sec. 7.3);
before the segment's first vertex the centreline is extended straight along its first
tangent.

Modelling choices:

- the road surface is flat at height 0 (the luminaires' mounting heights are above it);
- a segment shorter than its spacing is one section of its own length (flagged by the caller);
- the edge strips stand on both sides whatever the verge: the layer carries no verge width,
  so the strip is :math:`\\min(5\\,\\text{m}, W/2)` (EN 13201-3:2015, Sec. 9.5, with an
  unlimited verge).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.roads._field import (
    LUMINANCE_POINTS_PER_LANE,
    OBSERVER_DISTANCE,
    calculation_field,
)
from nightlights.roads._metrics import edge_strip_width

__all__ = ["FieldPoints", "Observers", "StreetFields", "lay_out"]

#: Step of the centred difference that gives the centreline's tangent [m].
_TANGENT_STEP = 0.5
#: Strips of the edge illuminance ratio, in road-frame order across the road.
STRIPS = ("right_outside", "right_inside", "left_inside", "left_outside")
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class FieldPoints:
    """Points of one kind of field, grouped by section (contiguous, sections increasing).

    Attributes
    ----------
    xy
        Positions (p, 2) in the layer's CRS [m].
    section
        Section of each point (p,).
    row, column
        Indices along and across the section's field (p,); for edge strips ``column`` is the
        strip (an index of :data:`STRIPS`).
    """

    xy: FloatArray
    section: IntArray
    row: IntArray
    column: IntArray

    def __len__(self) -> int:
        return int(self.section.size)


@dataclass(frozen=True)
class Observers:
    """Observers of the luminance sections, grouped by section.

    Attributes
    ----------
    xy
        Eye positions (o, 2) [m]; the eye is 1.5 m above the road.
    direction
        Horizontal unit vectors of the line of sight (o, 2).
    section, lane
        The section each observer rates and the lane it stands in (o,).
    """

    xy: FloatArray
    direction: FloatArray
    section: IntArray
    lane: IntArray

    def __len__(self) -> int:
        return int(self.section.size)


@dataclass(frozen=True)
class StreetFields:
    """Every section's calculation points along a street layer.

    Attributes
    ----------
    segment
        Row of the (exploded) street layer of each section (n_sections,).
    spacing, width, lanes
        Section length S [m], carriageway width W [m] and lanes of each section.
    luminance
        Luminance points of the sections whose class rates luminance.
    observers
        One observer per lane of each luminance section.
    illuminance
        Illuminance points of the sections whose class rates illuminance.
    strips
        Edge-strip points of the luminance sections.
    """

    segment: IntArray
    spacing: FloatArray
    width: FloatArray
    lanes: IntArray
    luminance: FieldPoints
    observers: Observers
    illuminance: FieldPoints
    strips: FieldPoints

    @property
    def n_sections(self) -> int:
        """Number of sections."""
        return int(self.segment.size)

    def lane_centre(self) -> NDArray[np.bool_]:
        """Whether each luminance point lies on its lane's centre line."""
        return self.luminance.column % LUMINANCE_POINTS_PER_LANE == 1


def along(
    lines: NDArray[np.object_], which: IntArray, s: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Position and unit tangent at arc length ``s`` on ``lines[which]``.

    Beyond either end the line is extended straight along its end tangent.

    Returns
    -------
    xy, tangent : numpy.ndarray
        Positions (m, 2) [m] and unit tangents (m, 2).
    """
    geometry = lines[which]
    length = shapely.length(geometry)
    inside = np.clip(s, 0.0, length)
    step = np.minimum(_TANGENT_STEP, length / 2.0)
    ahead = shapely.get_coordinates(
        shapely.line_interpolate_point(geometry, np.minimum(inside + step, length))
    )
    behind = shapely.get_coordinates(
        shapely.line_interpolate_point(geometry, np.maximum(inside - step, 0.0))
    )
    tangent = ahead - behind
    tangent /= np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-12)[:, None]
    xy = shapely.get_coordinates(shapely.line_interpolate_point(geometry, inside))
    xy = xy + (s - inside)[:, None] * tangent
    return xy, tangent


def _place(
    lines: NDArray[np.object_],
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    section: IntArray,
    x: FloatArray,
    y: FloatArray,
) -> FloatArray:
    """World positions of road-frame points (x, y) of sections (module docstring)."""
    xy, tangent = along(lines, segment[section], start[section] + x)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    return xy + (y - width[section] / 2.0)[:, None] * normal


def _grid(
    rows: list[FloatArray], columns: list[FloatArray], sections: IntArray
) -> tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray]:
    """Flatten per-section (rows x columns) grids into point arrays."""
    section, row, column, x, y = [], [], [], [], []
    for s, xs, ys in zip(sections, rows, columns, strict=True):
        r, c = np.meshgrid(np.arange(xs.size), np.arange(ys.size), indexing="ij")
        section.append(np.full(r.size, s, dtype=np.intp))
        row.append(r.ravel())
        column.append(c.ravel())
        x.append(np.repeat(xs, ys.size))
        y.append(np.tile(ys, xs.size))
    if not section:
        empty_i = np.zeros(0, dtype=np.intp)
        return empty_i, empty_i, empty_i, np.zeros(0), np.zeros(0)
    return (
        np.concatenate(section),
        np.concatenate(row).astype(np.intp),
        np.concatenate(column).astype(np.intp),
        np.concatenate(x),
        np.concatenate(y),
    )


def _points(
    lines: NDArray[np.object_],
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    grids: tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray],
) -> FieldPoints:
    section, row, column, x, y = grids
    xy = _place(lines, segment, start, width, section, x, y) if section.size else np.zeros((0, 2))
    return FieldPoints(xy, section, row, column)


def lay_out(
    lines: NDArray[np.object_],
    spacing: FloatArray,
    width: FloatArray,
    lanes: IntArray,
    family: NDArray[np.str_],
) -> StreetFields:
    """Sections and calculation points of every segment (module docstring).

    Parameters
    ----------
    lines
        Shapely line strings in a projected CRS (n,) [m].
    spacing
        Luminaire spacing S per segment (n,) [m].
    width
        Carriageway width W per segment (n,) [m].
    lanes
        Lanes per segment (n,).
    family
        What each segment's class rates: ``"luminance"``, ``"illuminance"`` or ``""``
        (not rated: no sections).

    Returns
    -------
    StreetFields
        The sections (rated segments only) and their points.
    """
    length = shapely.length(lines)
    rated = np.flatnonzero(family != "")
    count = np.maximum(1, np.floor(length[rated] / spacing[rated] + 1e-9)).astype(np.intp)
    segment = np.repeat(rated, count)
    first = np.cumsum(count) - count
    index = np.arange(segment.size) - np.repeat(first, count)
    section_length = np.minimum(spacing[segment], length[segment])
    offset = (length[segment] - count.repeat(count) * section_length) / 2.0
    start = offset + index * section_length
    sec_width = width[segment].astype(float)
    sec_lanes = lanes[segment].astype(np.intp)
    kind = family[segment]
    lum_sections = np.flatnonzero(kind == "luminance")
    ill_sections = np.flatnonzero(kind == "illuminance")

    lum_rows, lum_cols, strip_rows, strip_cols = [], [], [], []
    for s in lum_sections:
        field = calculation_field(section_length[s], sec_width[s] / sec_lanes[s], sec_lanes[s])
        lum_rows.append(np.asarray(field.x))
        lum_cols.append(np.asarray(field.y))
        strip_rows.append(np.asarray(field.x))
        strip_cols.append(np.arange(len(STRIPS), dtype=float))
    ill_rows, ill_cols = [], []
    for s in ill_sections:
        field = calculation_field(
            section_length[s], sec_width[s] / sec_lanes[s], sec_lanes[s], quantity="illuminance"
        )
        ill_rows.append(np.asarray(field.x))
        ill_cols.append(np.asarray(field.y))

    luminance = _points(lines, segment, start, sec_width, _grid(lum_rows, lum_cols, lum_sections))
    illuminance = _points(lines, segment, start, sec_width, _grid(ill_rows, ill_cols, ill_sections))
    strips = _strip_points(lines, segment, start, sec_width, strip_rows, lum_sections)
    observers = _observers(lines, segment, start, sec_width, sec_lanes, lum_sections)
    return StreetFields(
        segment, section_length, sec_width, sec_lanes, luminance, observers, illuminance, strips
    )


def _strip_points(
    lines: NDArray[np.object_],
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    rows: list[FloatArray],
    sections: IntArray,
) -> FieldPoints:
    """Edge-strip points: the illuminance rule across each strip, all strips' points kept
    with ``column`` naming the strip."""
    section, row, column, x, y = [], [], [], [], []
    for s, xs in zip(sections, rows, strict=True):
        w = float(width[s])
        strip = edge_strip_width(w)
        across = calculation_field(1.0, strip, 1, quantity="illuminance").y  # offsets in strip
        offsets = (
            -strip + across,  # right outside
            across,  # right inside
            w - strip + across,  # left inside
            w + across,  # left outside
        )
        for k, ys in enumerate(offsets):
            r = np.repeat(np.arange(xs.size), ys.size)
            section.append(np.full(r.size, s, dtype=np.intp))
            row.append(r)
            column.append(np.full(r.size, k, dtype=np.intp))
            x.append(np.repeat(xs, ys.size))
            y.append(np.tile(ys, xs.size))
    if not section:
        empty = np.zeros(0, dtype=np.intp)
        return FieldPoints(np.zeros((0, 2)), empty, empty, empty)
    grids = (
        np.concatenate(section),
        np.concatenate(row).astype(np.intp),
        np.concatenate(column).astype(np.intp),
        np.concatenate(x),
        np.concatenate(y),
    )
    return _points(lines, segment, start, width, grids)


def _observers(
    lines: NDArray[np.object_],
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    lanes: IntArray,
    sections: IntArray,
) -> Observers:
    per = lanes[sections]
    section = np.repeat(sections, per)
    lane = np.arange(section.size) - np.repeat(np.cumsum(per) - per, per)
    if section.size == 0:
        empty = np.zeros(0, dtype=np.intp)
        return Observers(np.zeros((0, 2)), np.zeros((0, 2)), empty, empty)
    lane_width = width[section] / lanes[section]
    s = start[section] - OBSERVER_DISTANCE
    xy, tangent = along(lines, segment[section], s)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    offset = (lane + 0.5) * lane_width - width[section] / 2.0
    return Observers(xy + offset[:, None] * normal, tangent, section, lane.astype(np.intp))
