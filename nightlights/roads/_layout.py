"""EN 13201-3 calculation fields laid along the segments of a real street layer.

A street segment (a line in a projected CRS) of length :math:`\\ell`, carriageway width
:math:`W` in :math:`n` lanes (:math:`W_L = W / n`) and luminaire spacing :math:`S` is cut into
:math:`\\max(1, \\lfloor \\ell / S \\rfloor)` sections of length :math:`S`, centred on the
segment. Each section carries the fields of :func:`~nightlights.roads.calculation_field`
(rows :math:`D = S/N` apart, three points per lane for luminance where its class rates
luminance, at most 1.5 m apart across for illuminance on every section: the figures of the
illuminance classes, and the average horizontal illuminance of all for EN 13201-5's power
density) and, for the edge illuminance ratio of the luminance classes, four strips of width
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

__all__ = ["Centrelines", "FieldPoints", "Observers", "StreetFields", "lay_out"]

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
        Horizontal illuminance points of every section (the figures of the classes that
        rate illuminance; the average of the others, for their power density).
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


class Centrelines:
    """Street centrelines prepared for fast position and tangent lookups by arc length."""

    def __init__(self, lines: NDArray[np.object_]) -> None:
        # repeated vertices would make zero-length segments without a direction
        lines = shapely.remove_repeated_points(lines)
        coords, index = shapely.get_coordinates(lines, return_index=True)
        self.start = np.searchsorted(index, np.arange(len(lines) + 1))
        self.coords = coords
        step = coords[1:] - coords[:-1]
        length = np.hypot(step[:, 0], step[:, 1])
        same = index[1:] == index[:-1]
        self.step = step
        self.length = np.where(same, length, 0.0)
        self.cumulative = np.concatenate([[0.0], np.cumsum(self.length)])

    def at(self, which: IntArray, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Position and unit tangent at arc length ``s`` along lines ``which``.

        Beyond either end the line goes on straight along its end segment.

        Returns
        -------
        xy, tangent : numpy.ndarray
            Positions (m, 2) [m] and unit tangents (m, 2).
        """
        first = self.start[which]
        last = self.start[which + 1] - 2  # the line's last segment
        target = self.cumulative[first] + s
        j = np.searchsorted(self.cumulative, target, side="right") - 1
        j = np.clip(j, first, np.maximum(first, last))
        length = self.length[j]
        safe = np.where(length > 0, length, 1.0)
        tangent = self.step[j] / safe[:, None]
        xy = self.coords[j] + ((target - self.cumulative[j]) / safe)[:, None] * self.step[j]
        return xy, tangent


def _place(
    lines: Centrelines,
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    section: IntArray,
    x: FloatArray,
    y: FloatArray,
) -> FloatArray:
    """World positions of road-frame points (x, y) of sections (module docstring)."""
    xy, tangent = lines.at(segment[section], start[section] + x)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    return xy + (y - width[section] / 2.0)[:, None] * normal


def _tiled(
    sections: IntArray,
    keys: list[tuple[float, float, int]],
    local: dict[tuple[float, float, int], tuple[FloatArray, FloatArray, IntArray]],
) -> tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray]:
    """Points of many sections from each distinct section's local grid (rows x, columns y,
    column labels), sorted by section."""
    parts = []
    by_key: dict[tuple[float, float, int], list[int]] = {}
    for s, key in zip(sections, keys, strict=True):
        by_key.setdefault(key, []).append(int(s))
    for key, members in by_key.items():
        xs, ys, labels = local[key]
        m = np.asarray(members, dtype=np.intp)
        per = xs.size * ys.size
        parts.append(
            (
                np.repeat(m, per),
                np.tile(np.repeat(np.arange(xs.size), ys.size), m.size),
                np.tile(np.tile(labels, xs.size), m.size),
                np.tile(np.repeat(xs, ys.size), m.size),
                np.tile(np.tile(ys, xs.size), m.size),
            )
        )
    if not parts:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty, empty, np.zeros(0), np.zeros(0)
    section, row, column, x, y = (np.concatenate(a) for a in zip(*parts, strict=True))
    order = np.argsort(section, kind="stable")
    return (
        section[order].astype(np.intp),
        row[order].astype(np.intp),
        column[order].astype(np.intp),
        x[order],
        y[order],
    )


def _points(
    lines: Centrelines,
    segment: IntArray,
    start: FloatArray,
    width: FloatArray,
    grids: tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray],
) -> FieldPoints:
    section, row, column, x, y = grids
    xy = _place(lines, segment, start, width, section, x, y) if section.size else np.zeros((0, 2))
    return FieldPoints(xy, section, row, column)


def _luminance_grid(key: tuple[float, float, int]) -> tuple[FloatArray, FloatArray, IntArray]:
    length, width, lanes = key
    field = calculation_field(length, width / lanes, lanes)
    return np.asarray(field.x), np.asarray(field.y), np.arange(field.y.size)


def _illuminance_grid(key: tuple[float, float, int]) -> tuple[FloatArray, FloatArray, IntArray]:
    length, width, lanes = key
    field = calculation_field(length, width / lanes, lanes, quantity="illuminance")
    return np.asarray(field.x), np.asarray(field.y), np.arange(field.y.size)


def _strip_grid(key: tuple[float, float, int]) -> tuple[FloatArray, FloatArray, IntArray]:
    """Rows of the luminance field; across, the illuminance rule in each of the four strips
    (labels: the strip's index in :data:`STRIPS`)."""
    length, width, lanes = key
    xs = np.asarray(calculation_field(length, width / lanes, lanes).x)
    strip = edge_strip_width(width)
    across = np.asarray(calculation_field(1.0, strip, 1, quantity="illuminance").y)
    offsets = (-strip + across, across, width - strip + across, width + across)
    ys = np.concatenate(offsets)
    labels = np.repeat(np.arange(len(STRIPS)), across.size)
    return xs, ys, labels


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
    centrelines = Centrelines(lines)
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
    keys = [
        (float(a), float(b), int(c))
        for a, b, c in zip(section_length, sec_width, sec_lanes, strict=True)
    ]
    grids = {}
    for name, builder in (
        ("luminance", _luminance_grid),
        ("illuminance", _illuminance_grid),
        ("strips", _strip_grid),
    ):
        if name == "strips":
            chosen = np.flatnonzero(kind == "luminance")
        elif name == "illuminance":  # every section: the C and P figures, and D_P of all
            chosen = np.flatnonzero(kind != "")
        else:
            chosen = np.flatnonzero(kind == name)
        chosen_keys = [keys[i] for i in chosen]
        local = {key: builder(key) for key in set(chosen_keys)}
        grids[name] = _points(
            centrelines, segment, start, sec_width, _tiled(chosen, chosen_keys, local)
        )
    observers = _observers(
        centrelines, segment, start, sec_width, sec_lanes, np.flatnonzero(kind == "luminance")
    )
    return StreetFields(
        segment,
        section_length,
        sec_width,
        sec_lanes,
        grids["luminance"],
        observers,
        grids["illuminance"],
        grids["strips"],
    )


def _observers(
    lines: Centrelines,
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
    xy, tangent = lines.at(segment[section], s)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    offset = (lane + 0.5) * lane_width - width[section] / 2.0
    return Observers(xy + offset[:, None] * normal, tangent, section, lane.astype(np.intp))
