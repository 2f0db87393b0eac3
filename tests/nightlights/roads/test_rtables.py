"""r-tables: the reader, bilinear interpolation, and road luminance against a double loop.

The tables here are synthetic (analytic forms); no published CIE table is bundled.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.ground.frames import luminaire_rotation
from nightlights.roads import (
    RTable,
    parse_rtable,
    read_rtable,
    reduced_luminance_coefficient,
    road_luminance,
    synthetic_rtable,
)

TEXT = """# a small synthetic table
tan_gamma\\beta, 0, 90, 180
0,   100, 100, 100
0.5,  80,  60,  40
1.0,  70,  30,  10
"""


def test_parse_reads_the_layout() -> None:
    table = parse_rtable(TEXT, source="small")
    assert table.beta.tolist() == [0.0, 90.0, 180.0]
    assert table.tan_gamma.tolist() == [0.0, 0.5, 1.0]
    assert table.r[2].tolist() == [70.0, 30.0, 10.0]
    assert table.name == "small"


def test_read_matches_parse(tmp_path: Path) -> None:
    path = tmp_path / "r.txt"
    path.write_text(TEXT.replace(",", " "), encoding="utf-8")
    assert np.array_equal(read_rtable(path).r, parse_rtable(TEXT).r)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (TEXT.replace("0.5,  80,  60,  40", "0.5, 80, 60"), "line 4: 3 values; expected"),
        (TEXT.replace("80,  60", "eighty, 60"), "line 4: could not convert"),
        (TEXT.replace("0, 90, 180", "0, 190, 180"), "expected at least 2 increasing angles"),
        (TEXT.replace("1.0,", "0.25,"), "increasing values from 0"),
        (TEXT.replace("30,", "-30,"), "negative or non-finite"),
        ("beta 0 180\n0 1 1\n", "2 table lines"),
    ],
)
def test_bad_tables(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        parse_rtable(text, source="bad")


def test_table_shape_is_checked() -> None:
    with pytest.raises(InputError, match=r"r of shape \(2, 2\); expected \(2, 3\)"):
        RTable(np.array([0.0, 90.0, 180.0]), np.array([0.0, 1.0]), np.ones((2, 2)))


def test_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read the r-table"):
        read_rtable(tmp_path / "missing.txt")


def test_interpolation_is_exact_on_nodes_and_bilinear_between() -> None:
    # r = 50 + 0.1 beta + 20 t + 0.05 beta t is bilinear: reproduced exactly everywhere.
    beta = np.array([0.0, 20.0, 90.0, 180.0])
    tan_gamma = np.array([0.0, 0.5, 2.0, 4.0])
    bb, tt = np.meshgrid(beta, tan_gamma)
    table = RTable(beta, tan_gamma, 50 + 0.1 * bb + 20 * tt + 0.05 * bb * tt)
    rng = np.random.default_rng(1)
    b = rng.uniform(0, 180, 200)
    t = rng.uniform(0, 4, 200)
    expected = 50 + 0.1 * b + 20 * t + 0.05 * b * t
    got = reduced_luminance_coefficient(table, b, t, interpolation="bilinear")
    assert got == pytest.approx(expected, rel=1e-12)
    # A bicubic spline reproduces a bilinear function too.
    got = reduced_luminance_coefficient(table, b, t, interpolation="cubic")
    assert got == pytest.approx(expected, rel=1e-9)


def _analytic_r(beta: np.ndarray, t: np.ndarray) -> np.ndarray:
    """synthetic_rtable's formula with its defaults (q0 = 0.07, forward = 1), by hand."""
    return 700.0 * (1 + t * (1 + np.cos(np.radians(beta))) / 2) / (1 + t * t) ** 1.5


@pytest.mark.parametrize(
    ("method", "mean_limit", "max_limit"),
    # The limits bound the errors measured in bench_rtable_interpolation.py (a few % at most
    # for the linear methods, well below 1 % for the spline), with a margin.
    [("bilinear", 2.0, 4.0), ("bilinear_gamma", 2.0, 4.0), ("cubic", 0.1, 0.6)],
)
def test_interpolation_against_the_analytic_function(
    method: str, mean_limit: float, max_limit: float
) -> None:
    table = synthetic_rtable()
    rng = np.random.default_rng(7)
    b = rng.uniform(0, 180, 20_000)
    t = rng.uniform(0, 12, 20_000)
    exact = _analytic_r(b, t)
    got = reduced_luminance_coefficient(table, b, t, interpolation=method)
    error = np.abs(got - exact) / exact.max() * 100
    assert error.mean() < mean_limit / 10
    assert error.max() < max_limit
    # Exact at the nodes.
    bb, tt = np.meshgrid(table.beta, table.tan_gamma)
    nodes = reduced_luminance_coefficient(table, bb, tt, interpolation=method)
    assert nodes == pytest.approx(_analytic_r(bb, tt), rel=1e-9)


def test_cubic_beats_bilinear_in_the_used_range() -> None:
    """Where road lighting uses the table (tan gamma <= 4), the spline is 10 times closer."""
    table = synthetic_rtable()
    rng = np.random.default_rng(8)
    b, t = rng.uniform(0, 180, 5000), rng.uniform(0, 4, 5000)
    exact = _analytic_r(b, t)
    errors = {
        m: np.abs(reduced_luminance_coefficient(table, b, t, interpolation=m) - exact).mean()
        for m in ("bilinear", "cubic")
    }
    assert errors["cubic"] < errors["bilinear"] / 10


def test_cubic_is_the_default_and_never_negative() -> None:
    table = synthetic_rtable()
    b, t = np.array([3.0, 47.0, 100.0]), np.array([0.3, 1.1, 5.2])
    assert np.array_equal(
        reduced_luminance_coefficient(table, b, t),
        reduced_luminance_coefficient(table, b, t, interpolation="cubic"),
    )
    # A step in r makes the spline ring below 0: clipped.
    step = parse_rtable("beta 0 90 180\n0 100 100 100\n1 100 100 100\n2 0 0 0\n3 0 0 0\n4 0 0 0\n")
    ringing = reduced_luminance_coefficient(
        step, 90.0, np.linspace(2, 4, 41), interpolation="cubic"
    )
    assert ringing.min() == 0.0


def test_unknown_interpolation() -> None:
    with pytest.raises(InputError, match="interpolation='nearest'; expected one of"):
        reduced_luminance_coefficient(synthetic_rtable(), 0.0, 1.0, interpolation="nearest")


def test_luminance_interpolation_option() -> None:
    """road_luminance with each method: r of one luminaire by that method, times I / h^2."""
    table = synthetic_rtable()
    light = np.array([[12.0, 3.0, 8.0]])
    point = np.array([0.7, 1.3, 0.0])
    eye = np.array([-60.0, 1.75, 1.5])
    view, to_light = point[:2] - eye[:2], light[0, :2] - point[:2]
    beta = math.degrees(
        math.acos(float(view @ to_light) / (np.linalg.norm(view) * np.linalg.norm(to_light)))
    )
    t = float(np.linalg.norm(to_light)) / 8.0
    for method in ("bilinear", "bilinear_gamma", "cubic"):
        got = road_luminance(
            point, eye, light, np.eye(3), lambda v, h: 0 * v + 1000.0, table, interpolation=method
        )
        r = float(reduced_luminance_coefficient(table, beta, t, interpolation=method))
        assert float(got) == pytest.approx(r * 1e-4 * 1000.0 / 64.0, rel=1e-12)
    exact = float(_analytic_r(np.array(beta), np.array(t))) * 1e-4 * 1000.0 / 64.0
    cubic = road_luminance(point, eye, light, np.eye(3), lambda v, h: 0 * v + 1000.0, table)
    assert float(cubic) == pytest.approx(exact, rel=2e-3)


def test_beta_folds_into_0_180() -> None:
    table = synthetic_rtable()
    folded = reduced_luminance_coefficient(table, [-30.0, 200.0, 390.0], 1.0)
    assert folded == pytest.approx(reduced_luminance_coefficient(table, [30.0, 160.0, 30.0], 1.0))


def test_beyond_the_table() -> None:
    table = parse_rtable(TEXT)
    assert float(reduced_luminance_coefficient(table, 0.0, 1.5)) == 0.0
    assert float(reduced_luminance_coefficient(table, 0.0, 1.5, beyond="last")) == pytest.approx(
        70.0
    )
    with pytest.raises(InputError, match="beyond='nearest'"):
        reduced_luminance_coefficient(table, 0.0, 1.5, beyond="nearest")


def test_synthetic_table_follows_its_formula() -> None:
    table = synthetic_rtable(q0=0.08, forward=0.5)
    i, j = 12, 3  # tan gamma 4.0, beta 10 deg
    t, b = table.tan_gamma[i], math.radians(table.beta[j])
    assert t == 4.0
    expected = 1e4 * 0.08 * (1 + 0.5 * t * (1 + math.cos(b)) / 2) / (1 + t * t) ** 1.5
    assert table.r[i, j] == pytest.approx(expected)
    assert table.r.shape == (29, 20)


def _intensity(vertical: np.ndarray, horizontal: np.ndarray) -> np.ndarray:
    """An asymmetric analytic distribution [cd]: brighter towards C = 90 and V = 60."""
    return (
        800.0
        + 400.0 * np.sin(np.radians(horizontal)) * np.sin(np.radians(vertical)) ** 2
        + (300.0 * np.cos(np.radians(vertical - 60.0)))
    )


def test_specular_luminaire_has_beta_zero() -> None:
    table = synthetic_rtable()
    # Luminaire 10 m beyond the point along the line of sight, 8 m high: beta 0, t = 1.25.
    value = road_luminance(
        [0.0, 0.0, 0.0], [-60.0, 0.0, 1.5], [[10.0, 0.0, 8.0]], np.eye(3), _intensity, table
    )
    v = math.degrees(math.atan2(10.0, 8.0))
    # heading 0 (body = road frame), street C-plane 0 along +y: the light goes towards -x,
    # the body's left, C = 90 (counterclockwise from forward seen from above).
    candela = _intensity(np.array(v), np.array(90.0))
    r = reduced_luminance_coefficient(table, 0.0, 10.0 / 8.0)
    assert float(value) == pytest.approx(float(r * 1e-4 * candela / 64.0), rel=1e-12)


def test_luminance_against_a_double_loop() -> None:
    """Every point and luminaire by hand: angles in each body frame, beta, tan gamma, h."""
    table = synthetic_rtable()
    lights = np.array([[0.0, -1.0, 8.0], [30.0, 8.0, 8.0], [60.0, -1.0, 9.0], [-30.0, 8.0, 8.0]])
    headings = np.array([0.0, 180.0, 0.0, 180.0])
    rotation = luminaire_rotation(headings)
    points = np.array([[x, y, 0.0] for x in (1.5, 10.5, 28.5) for y in (0.6, 3.5, 6.4)])
    observer = np.array([-60.0, 1.75, 1.5])
    got = road_luminance(points, observer, lights, rotation, _intensity, table, street_azimuth=90)
    for p, value in zip(points, got, strict=True):
        total = 0.0
        for q, heading in zip(lights, headings, strict=True):
            dx, dy, dz = p - q
            # Untilted: body (right, forward, up); heading 180 flips right and forward.
            sign = 1.0 if heading == 0.0 else -1.0
            right, forward = sign * dx, sign * dy
            v = math.degrees(math.acos(-dz / math.sqrt(dx * dx + dy * dy + dz * dz)))
            h = (90.0 + math.degrees(math.atan2(-right, forward))) % 360.0
            candela = float(_intensity(np.array(v), np.array(h)))
            height = q[2]
            distance = math.hypot(dx, dy)
            view = p[:2] - observer[:2]
            to_light = q[:2] - p[:2]
            cos_beta = float(view @ to_light) / (np.linalg.norm(view) * distance)
            beta = math.degrees(math.acos(max(-1.0, min(1.0, cos_beta))))
            r = float(reduced_luminance_coefficient(table, beta, distance / height))
            total += r * 1e-4 * candela / height**2
        assert value == pytest.approx(total, rel=1e-9)


def test_luminance_keeps_the_points_shape() -> None:
    points = np.zeros((4, 3, 3))
    points[..., 0] = np.arange(4)[:, None]
    got = road_luminance(
        points, [-60, 0, 1.5], [[0, 0, 10]], np.eye(3), lambda v, h: 0 * v + 500, synthetic_rtable()
    )
    assert got.shape == (4, 3)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"light_points": [[0, 0, 0]]}, "at or below the road"),
        ({"light_points": [[0, 0]]}, r"expected \(n, 3\)"),
        ({"observer": [0, 0]}, "observer of shape"),
        ({"points": [0, 0]}, "points of shape"),
        ({"intensity": [lambda v, h: v, lambda v, h: v]}, "2 distributions for 1 luminaires"),
        ({"intensity": lambda v, h: -v - 1}, "negative or non-finite candela"),
    ],
)
def test_bad_luminance_input(kwargs: dict[str, object], message: str) -> None:
    arguments: dict[str, object] = {
        "points": [1.0, 1.0, 0.0],
        "observer": [-60.0, 0.0, 1.5],
        "light_points": [[0.0, 0.0, 10.0]],
        "rotation": np.eye(3),
        "intensity": lambda v, h: 0 * v + 100.0,
        "table": synthetic_rtable(),
        **kwargs,
    }
    with pytest.raises(InputError, match=message):
        road_luminance(**arguments)  # type: ignore[arg-type]
