"""What each luminaire gives each calculation point: sparse matrices, linear in the dimming.

For luminaire :math:`k` at light point :math:`q_k` (height :math:`h_k` above the flat road),
with intensity :math:`I_k` towards a road point :math:`p` at distance :math:`d` and
horizontal distance :math:`\\rho` (EN 13201-3:2015, Sec. 7.1 and 8.1):

.. math:: E_{pk} = I_k\\, h_k / d^3, \\qquad
          L_{pok} = 10^{-4}\\, r(\\beta_{pok}, \\rho / h_k)\\, I_k / h_k^2

where :math:`\\beta_{pok}` is the angle between the horizontal vectors from :math:`p` to the
luminaire and from observer :math:`o` to :math:`p` (:mod:`nightlights.roads._rtables`). The
veiling luminance a luminaire adds at observer :math:`o`'s eye (CIE 140:2000) is

.. math:: V_{ok} = K(A)\\, E_{ok} / \\theta_{ok}^2, \\qquad E_{ok} = I_k \\cos\\theta_{ok} / d^2

with :math:`\\theta` the angle from the line of sight (1 deg below the horizontal along the
road, [deg]), counted when the luminaire is ahead, below the 20 deg screening angle and
:math:`1.5 \\le \\theta \\le 60` deg. A dimming :math:`\\delta_k \\in [0, 1]` scales every
column, so each quality figure's sums are matrix-vector products:
:math:`E = \\mathsf E\\,\\delta`, :math:`L = \\mathsf L\\,\\delta`,
:math:`L_v = \\mathsf V\\,\\delta`.

Modelling choices:

- a luminaire counts at a road point within :data:`REACH_HEIGHTS` of its mounting heights
  (horizontal distance): 12, where the r-tables end (:math:`\\tan\\gamma \\le 12`), so that
  the luminance is the whole sum; the illuminance figures lose at most 0.25 % there, against
  3.5 % (the minima) at 5 heights (``benchmarks/bench_road_audit.py`` charts the reach);
- glare counts luminaires within :data:`GLARE_REACH` of the eye.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from nightlights._typing import FloatArray
from nightlights.ground.frames import direction_to_photometric
from nightlights.ground.luminaires import Luminaires
from nightlights.roads._field import OBSERVER_EYE_HEIGHT
from nightlights.roads._layout import FieldPoints, Observers, StreetFields
from nightlights.roads._metrics import (
    GLARE_ANGLE_RANGE,
    LINE_OF_SIGHT_DEPRESSION,
    REFERENCE_AGE,
    SCREENING_ANGLE,
    age_factor,
)
from nightlights.roads._rtables import R_UNIT, RTable, reduced_luminance_coefficient

__all__ = ["GLARE_REACH", "REACH_HEIGHTS", "RoadInfluence", "road_influence"]

#: Horizontal reach of a luminaire on the road, in its mounting heights: the last tan(gamma)
#: of the r-tables (module docstring; chart: ``benchmarks/bench_road_audit.py``) [1].
REACH_HEIGHTS = 12.0
#: Distance from the eye within which luminaires count for glare [m].
GLARE_REACH = 500.0
#: Point-luminaire pairs handled at once (bounds the working memory to ~0.5 GB).
_CHUNK = 400_000
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class RoadInfluence:
    """Per-luminaire contributions at every calculation point of a street layer.

    Attributes
    ----------
    fields
        The sections and points (:func:`nightlights.roads._layout.lay_out`).
    illuminance
        Horizontal illuminance of the illuminance points, (points, lights) [lx].
    strips
        Horizontal illuminance of the edge-strip points, (points, lights) [lx].
    luminance
        Luminance of (luminance point, observer) samples, (samples, lights) [cd m-2].
    sample_point, sample_observer
        The luminance point and the observer of each sample; samples are grouped by observer
        and observers by section.
    veiling
        Veiling luminance at each observer's eye, (observers, lights) [cd m-2].
    """

    fields: StreetFields
    illuminance: sp.csr_array
    strips: sp.csr_array
    luminance: sp.csr_array
    sample_point: IntArray
    sample_observer: IntArray
    veiling: sp.csr_array


def _chunks(total: int, size: int) -> Iterator[slice]:
    for start in range(0, total, size):
        yield slice(start, min(total, start + size))


def _intensity(lum: Luminaires, light: IntArray, direction: FloatArray) -> FloatArray:
    """Intensity of luminaires ``light`` along world vectors ``direction`` (m, 3) [cd]."""
    vertical, horizontal = direction_to_photometric(
        direction, lum.rotation[light], street_azimuth=lum.street_azimuth[light]
    )
    out = np.empty(light.size)
    table = lum.table_index[light]
    for t in np.unique(table):
        pick = table == t
        out[pick] = lum.tables[t].lookup(vertical[pick], horizontal[pick])
    return out * lum.intensity_scale[light]


def _surface_pairs(
    xy: FloatArray, lum: Luminaires, reach_heights: float
) -> tuple[IntArray, IntArray]:
    """(point, light) pairs within the reach, sorted by point then light."""
    if xy.shape[0] == 0 or len(lum) == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    height = lum.light_point[:, 2]
    reach = reach_heights * height
    lights = cKDTree(lum.light_point[:, :2])
    points, partners = [], []
    for part in _chunks(xy.shape[0], 50_000):
        found = cKDTree(xy[part]).sparse_distance_matrix(
            lights, float(reach.max()), output_type="ndarray"
        )
        keep = found["v"] <= reach[found["j"]]
        points.append(found["i"][keep].astype(np.intp) + part.start)
        partners.append(found["j"][keep].astype(np.intp))
    point = np.concatenate(points)
    light = np.concatenate(partners)
    order = np.lexsort((light, point))
    return point[order], light[order]


def _illuminance(
    points: FieldPoints, lum: Luminaires, reach_heights: float
) -> tuple[sp.csr_array, IntArray, IntArray, FloatArray]:
    """Illuminance matrix and, per pair, the point, light and intensity."""
    point, light = _surface_pairs(points.xy, lum, reach_heights)
    candela = np.empty(point.size)
    value = np.empty(point.size)
    for part in _chunks(point.size, _CHUNK):
        p, k = point[part], light[part]
        direction = np.column_stack([points.xy[p] - lum.light_point[k, :2], -lum.light_point[k, 2]])
        candela[part] = _intensity(lum, k, direction)
        distance = np.linalg.norm(direction, axis=1)
        value[part] = candela[part] * lum.light_point[k, 2] / distance**3
    matrix = sp.csr_array((value, (point, light)), shape=(len(points), len(lum)))
    return matrix, point, light, candela


def _samples(fields: StreetFields) -> tuple[IntArray, IntArray]:
    """(luminance point, observer) samples: each observer with its section's points."""
    observers = fields.observers
    section = fields.luminance.section
    starts = np.searchsorted(section, np.arange(fields.n_sections))
    counts = np.searchsorted(section, np.arange(fields.n_sections), side="right") - starts
    per = counts[observers.section]
    observer = np.repeat(np.arange(len(observers), dtype=np.intp), per)
    first = np.repeat(np.cumsum(per) - per, per)
    point = np.repeat(starts[observers.section], per) + np.arange(observer.size) - first
    return point.astype(np.intp), observer


def _luminance(
    fields: StreetFields,
    lum: Luminaires,
    table: RTable,
    pairs: tuple[IntArray, IntArray, FloatArray],
    beyond: str,
) -> tuple[sp.csr_array, IntArray, IntArray]:
    points = fields.luminance
    point, light, candela = pairs
    sample_point, sample_observer = _samples(fields)
    indptr = np.searchsorted(point, np.arange(len(points) + 1))
    per = indptr[sample_point + 1] - indptr[sample_point]
    rows = np.repeat(np.arange(sample_point.size, dtype=np.intp), per)
    first = np.repeat(np.cumsum(per) - per, per)
    pair = np.repeat(indptr[sample_point], per) + np.arange(rows.size) - first
    value = np.empty(rows.size)
    eye = fields.observers.xy
    for part in _chunks(rows.size, _CHUNK):
        q = pair[part]
        p, k = point[q], light[q]
        at = points.xy[p]
        to_light = lum.light_point[k, :2] - at
        view = at - eye[sample_observer[rows[part]]]
        horizontal = np.hypot(to_light[:, 0], to_light[:, 1])
        cos_beta = np.einsum("ij,ij->i", to_light, view) / np.maximum(
            horizontal * np.hypot(view[:, 0], view[:, 1]), 1e-300
        )
        beta = np.degrees(np.arccos(np.clip(cos_beta, -1.0, 1.0)))
        height = lum.light_point[k, 2]
        r = reduced_luminance_coefficient(table, beta, horizontal / height, beyond=beyond)
        value[part] = r * R_UNIT * candela[q] / height**2
    matrix = sp.csr_array((value, (rows, light[pair])), shape=(sample_point.size, len(lum)))
    return matrix, sample_point, sample_observer


def _veiling(observers: Observers, lum: Luminaires, age: float) -> sp.csr_array:
    if len(observers) == 0 or len(lum) == 0:
        return sp.csr_array((len(observers), len(lum)))
    found = cKDTree(observers.xy).sparse_distance_matrix(
        cKDTree(lum.light_point[:, :2]), GLARE_REACH, output_type="ndarray"
    )
    o, k = found["i"].astype(np.intp), found["j"].astype(np.intp)
    eye = np.column_stack([observers.xy[o], np.full(o.size, OBSERVER_EYE_HEIGHT)])
    to_light = lum.light_point[k] - eye
    distance = np.linalg.norm(to_light, axis=1)
    unit = to_light / distance[:, None]
    depression = np.radians(LINE_OF_SIGHT_DEPRESSION)
    sight = np.column_stack(
        [observers.direction[o] * np.cos(depression), np.full(o.size, -np.sin(depression))]
    )
    cos_theta = np.clip(np.einsum("ij,ij->i", unit, sight), -1.0, 1.0)
    angle = np.degrees(np.arccos(cos_theta))
    elevation = np.degrees(np.arcsin(np.clip(unit[:, 2], -1.0, 1.0)))
    ahead = np.einsum("ij,ij->i", to_light[:, :2], observers.direction[o]) > 0
    low, high = GLARE_ANGLE_RANGE
    keep = ahead & (elevation < SCREENING_ANGLE) & (angle >= low) & (angle <= high)
    o, k = o[keep], k[keep]
    candela = _intensity(lum, k, -to_light[keep])
    eye_illuminance = candela * cos_theta[keep] / distance[keep] ** 2
    value = age_factor(age) * eye_illuminance / angle[keep] ** 2
    return sp.csr_array((value, (o, k)), shape=(len(observers), len(lum)))


def road_influence(
    fields: StreetFields,
    luminaires: Luminaires,
    table: RTable,
    *,
    beyond: str = "zero",
    age: float = REFERENCE_AGE,
    reach_heights: float = REACH_HEIGHTS,
) -> RoadInfluence:
    """The matrices of the module docstring for every section of ``fields``.

    Parameters
    ----------
    fields
        Sections and points (:func:`nightlights.roads._layout.lay_out`).
    luminaires
        The lights (:func:`nightlights.ground.luminaires.resolve_luminaires`), heights above
        the flat road.
    table
        The road surface's r-table.
    beyond
        r beyond the table's last tan(gamma) (:func:`~nightlights.roads.road_luminance`).
    age
        Observer's age for the veiling luminance [year].
    reach_heights
        Reach of a luminaire on the road in mounting heights [1].
    """
    illuminance, *_ = _illuminance(fields.illuminance, luminaires, reach_heights)
    strips, *_ = _illuminance(fields.strips, luminaires, reach_heights)
    _, point, light, candela = _illuminance(fields.luminance, luminaires, reach_heights)
    luminance, sample_point, sample_observer = _luminance(
        fields, luminaires, table, (point, light, candela), beyond
    )
    veiling = _veiling(fields.observers, luminaires, age)
    return RoadInfluence(
        fields, illuminance, strips, luminance, sample_point, sample_observer, veiling
    )
