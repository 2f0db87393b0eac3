"""The EN 13201-3 calculation field of a road section between two luminaires.

Road frame: ``x`` along the road [m], 0 at the first luminaire of the section, ``S`` (the
spacing) at the next; ``y`` across the carriageway [m], 0 at its near edge, ``n W_L`` at the
far edge for ``n`` lanes of width ``W_L``; ``z`` up, 0 on the road surface.

Longitudinal rule (EN 13201-3:2015, Sec. 7.2.2 for luminance, Sec. 8.2.2 for illuminance,
the same for both):

.. math:: D = S / N, \\quad N = 10 \\text{ if } S \\le 30\\,\\text{m, else the smallest integer
          with } D \\le 3\\,\\text{m}

and the first transverse row lies :math:`D/2` beyond the first luminaire, so the rows stand at
:math:`x_i = (i + 1/2) D`, :math:`i = 0 \\ldots N-1`.

Transverse rule for luminance (Sec. 7.2.2): three points per lane, :math:`d = W_L / 3`, the
outer points :math:`d/2` from the lane edges (the middle point is the lane centre). Transverse
rule for illuminance (Sec. 8.2.2) over a width :math:`W_r` (the carriageway here):
:math:`d = W_r / n` with :math:`n` the smallest integer giving :math:`d \\le 1.5` m and at least
3, the outer points :math:`d/2` from the edges.

Observer (Sec. 7.3): one per lane, eye 1.5 m above the road, 60 m before the field (whose
start is the first luminaire), i.e. at :math:`x = -60` m, in the centre of the lane:
:math:`y = (j + 1/2) W_L`.

Denser grids (not the standard's): ``density=k`` multiplies the point counts along and across
by k (:math:`kN` rows at :math:`(i + 1/2) D/k`; :math:`3k` points per lane, or :math:`kn`
across the illuminance field, each the centre of a :math:`1/k`-narrower cell), so that the
field's metrics converge to those of the continuous field as k grows; ``density=1`` is the
standard's grid, the regulatory definition. ``benchmarks/bench_road_grid.py`` charts how far
the standard's grid is from the converged metrics.

The rules were transcribed from the standard's text as summarised in its Sec. 7 and 8; the
tests derive the expected counts and positions by hand from the same rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "FIELD_QUANTITIES",
    "CalculationField",
    "calculation_field",
    "field_points",
]

#: The quantities a calculation field is laid out for (EN 13201-3:2015, Sec. 7 and 8).
FIELD_QUANTITIES = ("luminance", "illuminance")
#: Number of longitudinal points for spacings up to SHORT_SPACING (EN 13201-3:2015, 7.2.2).
SHORT_SPACING_POINTS = 10
#: Longest spacing laid out with SHORT_SPACING_POINTS rows (EN 13201-3:2015, 7.2.2) [m].
SHORT_SPACING = 30.0
#: Largest longitudinal point spacing for longer spacings (EN 13201-3:2015, 7.2.2) [m].
MAX_LONGITUDINAL_STEP = 3.0
#: Points per lane of the luminance field (EN 13201-3:2015, 7.2.2).
LUMINANCE_POINTS_PER_LANE = 3
#: Largest transverse point spacing of the illuminance field (EN 13201-3:2015, 8.2.2) [m].
MAX_TRANSVERSE_STEP = 1.5
#: Fewest transverse points of the illuminance field (EN 13201-3:2015, 8.2.2).
MIN_TRANSVERSE_POINTS = 3
#: Observer eye height above the road (EN 13201-3:2015, 7.3) [m].
OBSERVER_EYE_HEIGHT = 1.5
#: Distance of the observer before the field (EN 13201-3:2015, 7.3) [m].
OBSERVER_DISTANCE = 60.0
#: Slack of the "smallest integer with D <= limit" tests, so that S = 45 m gives 15 rows of
#: exactly 3 m despite rounding [m].
_SLACK = 1e-9


@dataclass(frozen=True)
class CalculationField:
    """Grid points and observers of one road section (see the module docstring).

    Attributes
    ----------
    quantity
        ``"luminance"`` or ``"illuminance"``.
    spacing
        Luminaire spacing S along the road [m].
    lane_width
        Width of one lane W_L [m].
    lanes
        Number of lanes.
    density
        Multiple of the standard's point counts along and across (1: the standard's grid).
    x
        Longitudinal positions of the rows, shape (n_x,) [m].
    y
        Transverse positions of the columns, shape (n_y,) [m].
    observers
        Observer eyes (x, y, z), one per lane, shape (lanes, 3) [m].
    """

    quantity: str
    spacing: float
    lane_width: float
    lanes: int
    x: FloatArray
    y: FloatArray
    observers: FloatArray
    density: int = 1

    @property
    def width(self) -> float:
        """Carriageway width, ``lanes * lane_width`` [m]."""
        return self.lanes * self.lane_width

    @property
    def shape(self) -> tuple[int, int]:
        """Grid shape (n_x, n_y)."""
        return (self.x.size, self.y.size)

    def lane_centre_columns(self) -> list[int]:
        """Index in :attr:`y` of each lane's centre line (luminance fields only).

        Raises
        ------
        InputError
            The field is an illuminance field, whose columns need not meet the lane centres,
            or a luminance field of even density, whose columns straddle them.
        """
        if self.quantity != "luminance":
            raise InputError(
                f"quantity={self.quantity!r}: lane centre lines are columns of the luminance "
                "field only"
            )
        per_lane = LUMINANCE_POINTS_PER_LANE * self.density
        if per_lane % 2 == 0:
            raise InputError(
                f"density={self.density}: {per_lane} columns per lane straddle the lane centre "
                "line; expected an odd density"
            )
        return [per_lane * j + per_lane // 2 for j in range(self.lanes)]


def _positive(value: float, name: str) -> float:
    number = float(value)
    if not (math.isfinite(number) and number > 0):
        raise InputError(f"{name}={value!r} m; expected a positive, finite length")
    return number


def longitudinal_point_count(spacing: float) -> int:
    """Rows of the field along the road, N (EN 13201-3:2015, 7.2.2 and 8.2.2).

    Parameters
    ----------
    spacing
        Luminaire spacing S [m].

    Returns
    -------
    int
        10 for S <= 30 m, else the smallest integer N with S / N <= 3 m.

    Examples
    --------
    >>> longitudinal_point_count(30.0), longitudinal_point_count(31.0)
    (10, 11)
    """
    s = _positive(spacing, "spacing")
    if s <= SHORT_SPACING:
        return SHORT_SPACING_POINTS
    return math.ceil(s / MAX_LONGITUDINAL_STEP - _SLACK)


def calculation_field(
    spacing: float,
    lane_width: float,
    lanes: int,
    *,
    quantity: str = "luminance",
    density: int = 1,
) -> CalculationField:
    """The EN 13201-3 calculation field of a section between two luminaires.

    Parameters
    ----------
    spacing
        Luminaire spacing S along the road [m].
    lane_width
        Width of one lane W_L [m].
    lanes
        Number of lanes n (the carriageway is ``lanes * lane_width`` wide).
    quantity
        ``"luminance"`` (three points per lane) or ``"illuminance"`` (at most 1.5 m apart
        across the carriageway, at least three).
    density
        Multiple k of the standard's point counts along and across, each point the centre of
        a cell k times smaller; 1 (the default) is the standard's grid. Denser grids are for
        convergence studies, not for rating a road.

    Returns
    -------
    CalculationField
        Rows ``x``, columns ``y`` and one observer per lane, in the road frame.

    Raises
    ------
    InputError
        A non-positive length, a lane count below 1, a density below 1, or an unknown quantity.

    References
    ----------
    EN 13201-3:2015, Road lighting - Part 3: Calculation of performance, Sec. 7.2 (luminance
    field), 7.3 (observer position), 8.2 (illuminance field).

    Examples
    --------
    >>> field = calculation_field(40.0, 3.5, 2)
    >>> field.shape, round(float(field.x[0]), 4), field.observers[0].tolist()
    ((14, 6), 1.4286, [-60.0, 1.75, 1.5])
    """
    if quantity not in FIELD_QUANTITIES:
        raise InputError(f"quantity={quantity!r}; expected one of {', '.join(FIELD_QUANTITIES)}")
    s = _positive(spacing, "spacing")
    w = _positive(lane_width, "lane_width")
    if isinstance(lanes, bool) or int(lanes) != lanes or lanes < 1:
        raise InputError(f"lanes={lanes!r}; expected a whole number of lanes, at least 1")
    n_lanes = int(lanes)
    if isinstance(density, bool) or int(density) != density or density < 1:
        raise InputError(
            f"density={density!r}; expected a whole multiple of the point counts, >= 1"
        )
    k = int(density)
    n_x = k * longitudinal_point_count(s)
    x = (np.arange(n_x, dtype=float) + 0.5) * (s / n_x)
    width = n_lanes * w
    if quantity == "luminance":
        per_lane = k * LUMINANCE_POINTS_PER_LANE
        y = (np.arange(per_lane * n_lanes, dtype=float) + 0.5) * (w / per_lane)
    else:
        n_y = k * max(MIN_TRANSVERSE_POINTS, math.ceil(width / MAX_TRANSVERSE_STEP - _SLACK))
        y = (np.arange(n_y, dtype=float) + 0.5) * (width / n_y)
    lane_centres = (np.arange(n_lanes) + 0.5) * w
    observers = np.column_stack(
        [
            np.full(n_lanes, -OBSERVER_DISTANCE),
            lane_centres,
            np.full(n_lanes, OBSERVER_EYE_HEIGHT),
        ]
    )
    for array in (x, y, observers):
        array.setflags(write=False)
    return CalculationField(quantity, s, w, n_lanes, x, y, observers, k)


def field_points(field: CalculationField) -> FloatArray:
    """All grid points of a field on the road surface.

    Parameters
    ----------
    field
        The field from :func:`calculation_field`.

    Returns
    -------
    numpy.ndarray
        Points (x, y, z = 0), shape (n_x, n_y, 3), rows along the road [m].

    Examples
    --------
    >>> field_points(calculation_field(30.0, 3.0, 1)).shape
    (10, 3, 3)
    """
    xx, yy = np.meshgrid(field.x, field.y, indexing="ij")
    return np.stack([xx, yy, np.zeros_like(xx)], axis=-1)
