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

- a luminaire counts at a road point within a reach of its mounting heights (horizontal
  distance): for luminance :data:`LUMINANCE_REACH_HEIGHTS` = 12, where the r-tables end
  (:math:`\\tan\\gamma \\le 12`), so that the sum is whole, and for the edge strips
  (:math:`R_{EI}`, a ratio of averages, within 0.2 % there) and the average horizontal
  illuminance of the luminance classes' sections (power density only); for the horizontal
  illuminance of the C and P classes :data:`ILLUMINANCE_REACH_HEIGHTS`, which
  ``benchmarks/bench_road_audit.py`` chose: the minima of dark spots still gain a few per cent
  from luminaires 12-16 heights away;
- glare counts luminaires within :data:`GLARE_REACH` of the eye.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.ground.luminaires import Luminaires
from nightlights.roads._field import OBSERVER_EYE_HEIGHT
from nightlights.roads._influence_numba import (
    RGrid,
    light_grid,
    luminance_rows,
    pack_candela,
    surface_rows,
    veiling_rows,
)
from nightlights.roads._layout import FieldPoints, Observers, StreetFields
from nightlights.roads._metrics import (
    GLARE_ANGLE_RANGE,
    LINE_OF_SIGHT_DEPRESSION,
    REFERENCE_AGE,
    SCREENING_ANGLE,
    age_factor,
)
from nightlights.roads._rtables import (
    BEYOND_RULES,
    DEFAULT_INTERPOLATION,
    RTable,
    reduced_luminance_coefficient,
)

__all__ = [
    "GLARE_REACH",
    "ILLUMINANCE_REACH_HEIGHTS",
    "LUMINANCE_REACH_HEIGHTS",
    "RoadInfluence",
    "road_influence",
]

#: Horizontal reach of a luminaire for road luminance, in its mounting heights: the last
#: tan(gamma) of the r-tables (module docstring) [1].
LUMINANCE_REACH_HEIGHTS = 12.0
#: Horizontal reach of a luminaire for the horizontal illuminance of the C and P classes, in
#: its mounting heights (``benchmarks/bench_road_audit.py``: every figure of a 420-segment
#: grid city within 0.4 % of a 48-height reach, against 2.7 % for E_min at 12 and 0.8 % at
#: 16) [1].
ILLUMINANCE_REACH_HEIGHTS = 24.0
#: Distance from the eye within which luminaires count for glare [m]: the 500 m ahead that
#: EN 13201-3 counts (``benchmarks/bench_road_influence.py``: f_TI within 0.15 percentage
#: points of a 2,000 m reach on a 420-segment district).
GLARE_REACH = 500.0
#: Steps of the regular grid the r-table is resampled on for the compiled kernel [deg], [1]:
#: bilinear reading there differs from the table's own interpolation by less than 1e-4 of
#: the table's largest r (test); every luminance figure within 0.005 % of a grid 8 times
#: finer (``benchmarks/bench_road_influence.py``).
R_BETA_STEP = 0.25
R_TAN_STEP = 0.01
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


def resample_rtable(
    table: RTable, beyond: str, interpolation: str = DEFAULT_INTERPOLATION
) -> RGrid:
    """The r-table on the regular grid of :data:`R_BETA_STEP` x :data:`R_TAN_STEP`, by the
    table's ``interpolation`` (:func:`~nightlights.roads.reduced_luminance_coefficient`), for
    the compiled kernel's bilinear reading."""
    if beyond not in BEYOND_RULES:
        raise InputError(f"beyond={beyond!r}; expected one of {', '.join(BEYOND_RULES)}")
    tan_max = float(table.tan_gamma[-1])
    n_tan = max(2, math.ceil(tan_max / R_TAN_STEP))
    n_beta = max(2, math.ceil(180.0 / R_BETA_STEP))
    tan = np.linspace(0.0, tan_max, n_tan + 1)
    beta = np.linspace(0.0, 180.0, n_beta + 1)
    values = reduced_luminance_coefficient(
        table, beta[None, :], tan[:, None], beyond="last", interpolation=interpolation
    )
    return RGrid(
        np.ascontiguousarray(values, dtype=float),
        tan_max / n_tan,
        180.0 / n_beta,
        tan_max,
        beyond == "zero",
    )


def _csr(
    indptr: NDArray[np.int64], light: NDArray[np.int64], value: FloatArray, n: int
) -> sp.csr_array:
    return sp.csr_array((value, light, indptr), shape=(indptr.size - 1, n))


def _gather(ptr: NDArray[np.int64], light: NDArray[np.int64], rows: IntArray) -> NDArray[np.int64]:
    """The column indices of CSR rows ``rows`` in order (rows may repeat)."""
    per = ptr[rows + 1] - ptr[rows]
    first = np.repeat(np.cumsum(per) - per, per)
    return light[np.repeat(ptr[rows], per) + np.arange(int(per.sum())) - first]


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


class _Lights:
    """The luminaires as the kernels take them."""

    def __init__(self, lum: Luminaires, reach_heights: float) -> None:
        self.n = len(lum)
        self.point = np.ascontiguousarray(lum.light_point, dtype=float)
        self.rotation = np.ascontiguousarray(lum.rotation, dtype=float)
        self.azimuth = np.ascontiguousarray(lum.street_azimuth, dtype=float)
        self.table = np.ascontiguousarray(lum.table_index, dtype=np.int64)
        self.scale = np.ascontiguousarray(lum.intensity_scale, dtype=float)
        self.reach = reach_heights * self.point[:, 2]
        self.packed = pack_candela(lum.tables)
        self.cell = max(float(self.reach.max()), 1.0) if self.n else 1.0
        self.grid = light_grid(self.point[:, :2], self.cell) if self.n else None

    def candela_arguments(self) -> tuple:
        p = self.packed
        return (p.values, p.offset, p.n_v, p.n_h, p.v_step, p.h_step)


def _surface(
    points: FieldPoints, lights: _Lights
) -> tuple[NDArray[np.int64], NDArray[np.int64], FloatArray, FloatArray]:
    if len(points) == 0 or lights.grid is None:
        return np.zeros(len(points) + 1, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    return surface_rows(
        np.ascontiguousarray(points.xy, dtype=float),
        lights.point,
        lights.rotation,
        lights.azimuth,
        lights.table,
        lights.scale,
        lights.reach,
        lights.grid,
        lights.cell,
        *lights.candela_arguments(),
    )


def _illuminance_rows(fields: StreetFields, lit: _Lights, lights: _Lights) -> sp.csr_array:
    """Horizontal illuminance of the illuminance points: the illuminance reach where the class
    rates illuminance, the luminance reach where only the average is kept (power density)."""
    points = fields.illuminance
    rates_luminance = np.zeros(fields.n_sections, dtype=bool)
    rates_luminance[fields.observers.section] = True
    short = rates_luminance[points.section]
    parts, order = [], []
    for pick, reach in ((~short, lit), (short, lights)):
        rows = np.flatnonzero(pick)
        subset = FieldPoints(
            points.xy[rows], points.section[rows], points.row[rows], points.column[rows]
        )
        ptr, light, _, value = _surface(subset, reach)
        parts.append(_csr(ptr, light, value, lights.n))
        order.append(rows)
    stacked = sp.csr_array(sp.vstack(parts, format="csr"))
    where = np.empty(len(points), dtype=np.intp)
    where[np.concatenate(order)] = np.arange(len(points))
    return sp.csr_array(stacked[where])


def _veiling(observers: Observers, lights: _Lights, age: float) -> sp.csr_array:
    if len(observers) == 0 or lights.n == 0:
        return sp.csr_array((len(observers), lights.n))
    low, high = GLARE_ANGLE_RANGE
    grid = light_grid(lights.point[:, :2], GLARE_REACH)
    indptr, light, value = veiling_rows(
        np.ascontiguousarray(observers.xy, dtype=float),
        np.ascontiguousarray(observers.direction, dtype=float),
        OBSERVER_EYE_HEIGHT,
        lights.point,
        lights.rotation,
        lights.azimuth,
        lights.table,
        lights.scale,
        grid,
        GLARE_REACH,
        GLARE_REACH,
        LINE_OF_SIGHT_DEPRESSION,
        SCREENING_ANGLE,
        low,
        high,
        age_factor(age),
        *lights.candela_arguments(),
    )
    return _csr(indptr, light, value, lights.n)


def road_influence(
    fields: StreetFields,
    luminaires: Luminaires,
    table: RTable,
    *,
    beyond: str = "zero",
    age: float = REFERENCE_AGE,
    reach_heights: float | None = None,
    interpolation: str = DEFAULT_INTERPOLATION,
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
        Reach of a luminaire on the road in mounting heights, for luminance and illuminance
        alike [1]; None: :data:`LUMINANCE_REACH_HEIGHTS` and
        :data:`ILLUMINANCE_REACH_HEIGHTS`.
    interpolation
        How r is read between the table's nodes
        (:func:`~nightlights.roads.reduced_luminance_coefficient`).
    """
    lit = _Lights(luminaires, ILLUMINANCE_REACH_HEIGHTS if reach_heights is None else reach_heights)
    lights = _Lights(
        luminaires, LUMINANCE_REACH_HEIGHTS if reach_heights is None else reach_heights
    )
    n = lights.n
    illuminance = _illuminance_rows(fields, lit, lights)
    ptr, light, _, value = _surface(fields.strips, lights)  # R_EI: a ratio of averages
    strips = _csr(ptr, light, value, n)
    ptr, light, candela, _ = _surface(fields.luminance, lights)
    sample_point, sample_observer = _samples(fields)
    if sample_point.size and n:
        grid = resample_rtable(table, beyond, interpolation)
        sample_ptr, values = luminance_rows(
            sample_point.astype(np.int64),
            sample_observer.astype(np.int64),
            np.ascontiguousarray(fields.luminance.xy, dtype=float),
            np.ascontiguousarray(fields.observers.xy, dtype=float),
            ptr,
            light,
            candela,
            lights.point,
            grid.values,
            grid.tan_step,
            grid.beta_step,
            grid.tan_max,
            grid.zero_beyond,
        )
        columns = _gather(ptr, light, sample_point)
        luminance = _csr(sample_ptr, columns, values, n)
    else:
        luminance = sp.csr_array((sample_point.size, n))
    veiling = _veiling(fields.observers, lights, age)
    return RoadInfluence(
        fields, illuminance, strips, luminance, sample_point, sample_observer, veiling
    )
