"""The EN 13201-3:2015 calculation field (Sec. 7.2, 7.3, 8.2), expected values by hand.

Rules, as the expected numbers below were worked out:
- longitudinal: N = 10 for S <= 30 m, else the smallest N with S / N <= 3 m; rows at
  (i + 1/2) S / N;
- luminance, across: 3 points per lane at (k + 1/2) W_L / 3;
- illuminance, across: n = max(3, smallest n with W / n <= 1.5 m), points at (k + 1/2) W / n;
- observer per lane: (-60, lane centre, 1.5);
- density k (not the standard's): k times the counts, each point the centre of its cell.
"""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.roads import calculation_field, field_points, longitudinal_point_count

# (S, N): S <= 30 gives 10; 31 / 3 = 10.33 -> 11; 36 / 3 = 12 exactly -> 12; 45 -> 15;
# 45.1 / 3 = 15.03 -> 16; 10 -> 10 (D = 1 m, finer than 3 m: the rule keeps 10).
LONGITUDINAL = [(10.0, 10), (25.0, 10), (30.0, 10), (31.0, 11), (36.0, 12), (45.0, 15), (45.1, 16)]


@pytest.mark.parametrize(("spacing", "rows"), LONGITUDINAL)
def test_longitudinal_count(spacing: float, rows: int) -> None:
    assert longitudinal_point_count(spacing) == rows


# (S, W_L, lanes, first row x, first column y, last column y, n_y)
# S = 30: D = 3, first row 1.5; W_L = 3.5: d = 1.1667, first 0.5833, last 2 * 3.5 - 0.5833.
# S = 40: N = 14, D = 2.857142..., first 1.428571...; W_L = 3.0: d = 1, 0.5, 8.5 for 3 lanes.
# S = 20: D = 2, first 1.0; W_L = 3.75, 1 lane: d = 1.25, 0.625 and 3.125.
LUMINANCE = [
    (30.0, 3.5, 2, 1.5, 3.5 / 6, 7.0 - 3.5 / 6, 6),
    (40.0, 3.0, 3, 40.0 / 28, 0.5, 8.5, 9),
    (20.0, 3.75, 1, 1.0, 0.625, 3.125, 3),
]


@pytest.mark.parametrize(("spacing", "lane", "lanes", "x0", "y0", "y_last", "n_y"), LUMINANCE)
def test_luminance_field(
    spacing: float, lane: float, lanes: int, x0: float, y0: float, y_last: float, n_y: int
) -> None:
    field = calculation_field(spacing, lane, lanes)
    rows = longitudinal_point_count(spacing)
    assert field.shape == (rows, n_y)
    assert field.x[0] == pytest.approx(x0)
    assert field.x[-1] == pytest.approx(spacing - x0)
    assert np.diff(field.x) == pytest.approx(np.full(rows - 1, 2 * x0))
    assert field.y[0] == pytest.approx(y0)
    assert field.y[-1] == pytest.approx(y_last)
    centres = [(j + 0.5) * lane for j in range(lanes)]
    assert field.y[field.lane_centre_columns()] == pytest.approx(centres)
    assert field.observers == pytest.approx(np.array([[-60.0, c, 1.5] for c in centres]))


# (S, W_L, lanes, n_y, first y): W = 7.0: 7 / 1.5 = 4.67 -> 5, d = 1.4, first 0.7;
# W = 4.5: exactly 3 -> 3, d = 1.5, first 0.75; W = 3.0: 2 -> at least 3, d = 1, first 0.5;
# W = 10.5 (3 x 3.5): 7 -> 7, d = 1.5.
ILLUMINANCE = [(30.0, 3.5, 2, 5, 0.7), (30.0, 2.25, 2, 3, 0.75), (30.0, 3.0, 1, 3, 0.5)]
ILLUMINANCE.append((50.0, 3.5, 3, 7, 0.75))


@pytest.mark.parametrize(("spacing", "lane", "lanes", "n_y", "y0"), ILLUMINANCE)
def test_illuminance_field(spacing: float, lane: float, lanes: int, n_y: int, y0: float) -> None:
    field = calculation_field(spacing, lane, lanes, quantity="illuminance")
    assert field.shape == (longitudinal_point_count(spacing), n_y)
    assert field.y[0] == pytest.approx(y0)
    assert field.y[-1] == pytest.approx(lanes * lane - y0)
    assert np.diff(field.y) == pytest.approx(np.full(n_y - 1, 2 * y0))


def test_points_are_the_grid_on_the_road() -> None:
    field = calculation_field(36.0, 3.5, 2)
    points = field_points(field)
    assert points.shape == (12, 6, 3)
    assert points[3, 4].tolist() == pytest.approx([3.5 * 3.0, 4 * 3.5 / 3 + 3.5 / 6, 0.0])


def test_field_arrays_are_frozen() -> None:
    field = calculation_field(30.0, 3.5, 2)
    with pytest.raises(ValueError, match="read-only"):
        field.x[0] = 0.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"spacing": 0.0}, "spacing=0.0 m"),
        ({"lane_width": float("nan")}, "lane_width=nan"),
        ({"lanes": 0}, "lanes=0"),
        ({"lanes": 1.5}, "lanes=1.5"),
        ({"quantity": "glare"}, "quantity='glare'"),
        ({"density": 0}, "density=0"),
        ({"density": 2.5}, "density=2.5"),
    ],
)
def test_bad_input(kwargs: dict[str, object], message: str) -> None:
    arguments: dict[str, object] = {"spacing": 30.0, "lane_width": 3.5, "lanes": 2, **kwargs}
    with pytest.raises(InputError, match=message):
        calculation_field(**arguments)  # type: ignore[arg-type]


def test_illuminance_field_has_no_lane_centre_columns() -> None:
    with pytest.raises(InputError, match="luminance field only"):
        calculation_field(30.0, 3.5, 2, quantity="illuminance").lane_centre_columns()


def test_default_density_is_the_standard_grid() -> None:
    # S = 40 m: N = 14 (40 / 3 = 13.3); 2 lanes of 3.5 m: 6 luminance columns.
    field = calculation_field(40.0, 3.5, 2)
    assert field.density == 1
    assert field.shape == (14, 6)
    assert np.array_equal(field.x, calculation_field(40.0, 3.5, 2, density=1).x)


def test_denser_luminance_field() -> None:
    # k = 3, S = 25 m: 30 rows of 25 / 30 m from 25 / 60 m; 9 points per 3 m lane, 1/3 m apart.
    field = calculation_field(25.0, 3.0, 2, density=3)
    assert field.shape == (30, 18)
    assert field.x[0] == pytest.approx(25.0 / 60.0)
    assert field.x[-1] == pytest.approx(25.0 - 25.0 / 60.0)
    assert np.diff(field.y) == pytest.approx(np.full(17, 1.0 / 3.0))
    assert field.y[0] == pytest.approx(1.0 / 6.0)
    # The lane centres (1.5 m, 4.5 m) are columns 4 and 13 of an odd density.
    assert field.lane_centre_columns() == [4, 13]
    assert field.y[[4, 13]] == pytest.approx([1.5, 4.5])
    # Odd densities keep the standard's points (the centres of the middle sub-cells).
    standard = calculation_field(25.0, 3.0, 2)
    assert field.x[1::3] == pytest.approx(standard.x)
    assert field.y[1::3] == pytest.approx(standard.y)
    assert np.array_equal(field.observers, standard.observers)


def test_denser_illuminance_field() -> None:
    # W = 7 m: n = 5 (7 / 1.5 = 4.67), k = 4: 20 columns of 0.35 m from 0.175 m; S = 31: 44 rows.
    field = calculation_field(31.0, 3.5, 2, quantity="illuminance", density=4)
    assert field.shape == (44, 20)
    assert field.y[0] == pytest.approx(0.175)
    assert np.diff(field.y) == pytest.approx(np.full(19, 0.35))
    assert field.x[0] == pytest.approx(31.0 / 88.0)


def test_even_density_has_no_lane_centre_column() -> None:
    with pytest.raises(InputError, match="density=2: 6 columns per lane straddle"):
        calculation_field(30.0, 3.5, 2, density=2).lane_centre_columns()
