"""The EN 13201 metrics against brute-force loops and hand-evaluated formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.roads import (
    age_factor,
    average_illuminance,
    average_luminance,
    calculation_field,
    edge_illuminance_ratio,
    edge_strip_width,
    field_points,
    glare_geometry,
    illuminance_uniformity,
    longitudinal_uniformity,
    minimum_illuminance,
    overall_uniformity,
    road_luminance,
    synthetic_rtable,
    threshold_increment,
    veiling_luminance,
)


@pytest.fixture
def fields() -> np.ndarray:
    """Luminance for two observers on a 10 x 6 field [cd m-2] (random, seeded)."""
    return np.random.default_rng(7).uniform(0.3, 2.0, (2, 10, 6))


def test_average_and_overall_uniformity_per_observer(fields: np.ndarray) -> None:
    for j in range(2):
        values = [fields[j, i, k] for i in range(10) for k in range(6)]
        mean = sum(values) / len(values)
        assert average_luminance(fields)[j] == pytest.approx(mean, rel=1e-12)
        assert overall_uniformity(fields)[j] == pytest.approx(min(values) / mean, rel=1e-12)


def test_longitudinal_uniformity_is_the_worst_lane(fields: np.ndarray) -> None:
    columns = [1, 4]
    ratios = []
    for j, c in enumerate(columns):
        line = [fields[j, i, c] for i in range(10)]
        ratios.append(min(line) / max(line))
    assert longitudinal_uniformity(fields, columns) == pytest.approx(min(ratios), rel=1e-12)


def test_longitudinal_uniformity_needs_one_field_per_lane(fields: np.ndarray) -> None:
    with pytest.raises(InputError, match="for 3 lanes"):
        longitudinal_uniformity(fields, [1, 4, 7])
    with pytest.raises(InputError, match="expected columns in 0-5"):
        longitudinal_uniformity(fields, [1, 6])


def test_uniformity_of_a_dark_field() -> None:
    with pytest.raises(InputError, match="needs a lit field"):
        overall_uniformity(np.zeros((3, 3)))


# One luminaire at (0, -1, 10) m of 3000 cd in every direction; the eye at (-60, 1.75, 1.5) m.
# By hand: d = sqrt(60^2 + 2.75^2 + 8.5^2) = 60.6615 m; line of sight (cos 1, 0, -sin 1):
# cos theta = (60 cos 1 - 8.5 sin 1) / d, theta = 9.4254 deg; E = 3000 cos theta / d^2 =
# 0.80425 lx; K(23) = 9.86 (1 + (23 / 66.4)^4) = 10.0020; L_v = K E / theta^2 = 0.090549;
# with L_av = 0.75 cd m-2: f_TI = 65 x 0.090549 / 0.75^0.8 = 7.409 %.
TI_BY_HAND = 7.409


def test_threshold_increment_of_one_luminaire_by_hand() -> None:
    glare = glare_geometry(
        [-60.0, 1.75, 1.5], [[0.0, -1.0, 10.0]], np.eye(3), lambda v, h: 0 * v + 3000.0
    )
    assert glare.counted.tolist() == [True]
    assert float(glare.angle[0]) == pytest.approx(9.4254, abs=1e-4)
    assert float(glare.eye_illuminance[0]) == pytest.approx(0.80425, abs=1e-5)
    veiling = veiling_luminance(glare.eye_illuminance, glare.angle)
    assert threshold_increment(veiling, 0.75) == pytest.approx(TI_BY_HAND, abs=0.1)
    assert threshold_increment(veiling, 0.75) == pytest.approx(TI_BY_HAND, abs=1e-3)


def test_threshold_increment_formula_branches() -> None:
    assert threshold_increment(0.2, 5.0) == pytest.approx(65 * 0.2 / 5.0**0.8)
    assert threshold_increment(0.2, 10.0) == pytest.approx(95 * 0.2 / 10.0**1.05)
    assert threshold_increment(0.2, 10.0) == pytest.approx(1.6934, abs=1e-4)


def test_age_factor_grows_with_age() -> None:
    assert age_factor(23.0) == pytest.approx(10.002, abs=1e-3)
    assert age_factor(66.4) == pytest.approx(2 * 9.86)


def test_glare_counts_only_luminaires_in_view() -> None:
    eye = [-60.0, 1.75, 1.5]
    lights = [
        [-80.0, -1.0, 10.0],  # behind the eye
        [-57.0, 1.75, 10.0],  # ahead but 70 deg up: above the car roof
        [0.0, 1.75, 1.5 - 60.0 * math.tan(math.radians(1.0))],  # on the line of sight
        [20.0, -1.0, 10.0],  # counted
    ]
    glare = glare_geometry(eye, lights, np.eye(3), lambda v, h: 0 * v + 1000.0)
    assert glare.counted.tolist() == [False, False, False, True]
    assert float(glare.angle[2]) == pytest.approx(0.0, abs=1e-6)


def test_veiling_luminance_refuses_angles_outside_the_formula() -> None:
    with pytest.raises(InputError, match=r"holds for 1\.5-60\.0 deg"):
        veiling_luminance([1.0, 1.0], [1.0, 10.0])


def test_edge_illuminance_ratio_is_the_lower_side() -> None:
    rng = np.random.default_rng(3)
    inside = [rng.uniform(5, 15, 12), rng.uniform(5, 15, 8)]
    outside = [rng.uniform(2, 8, 12), rng.uniform(2, 8, 8)]
    by_hand = min(sum(o) / len(o) / (sum(i) / len(i)) for i, o in zip(inside, outside, strict=True))
    assert edge_illuminance_ratio(inside, outside) == pytest.approx(by_hand, rel=1e-12)
    with pytest.raises(InputError, match="one of each per side"):
        edge_illuminance_ratio(inside, outside[:1])


def test_edge_strip_width() -> None:
    assert edge_strip_width(7.0) == 3.5
    assert edge_strip_width(14.0) == 5.0
    assert edge_strip_width(14.0, 1.5) == 1.5
    with pytest.raises(InputError, match="expected positive widths"):
        edge_strip_width(0.0)


def test_illuminance_figures() -> None:
    values = np.random.default_rng(5).uniform(3.0, 20.0, (12, 5))
    flat = values.ravel().tolist()
    assert average_illuminance(values) == pytest.approx(sum(flat) / len(flat), rel=1e-12)
    assert minimum_illuminance(values) == min(flat)
    assert illuminance_uniformity(values) == pytest.approx(min(flat) / (sum(flat) / len(flat)))


def test_metrics_of_a_lit_two_lane_section() -> None:
    """Field, luminance and metrics together: a staggered pair of luminaires per spacing."""
    field = calculation_field(30.0, 3.5, 2)
    points = field_points(field)
    lights = np.array([[x, -1.0, 8.0] for x in (-60, -30, 0, 30, 60, 90)], dtype=float)

    def intensity(v: np.ndarray, h: np.ndarray) -> np.ndarray:
        return 2000.0 * np.cos(np.radians(v)).clip(0.05) + 0 * h

    table = synthetic_rtable()
    luminance = np.stack(
        [
            road_luminance(points, eye, lights, np.eye(3), intensity, table)
            for eye in field.observers
        ]
    )
    assert luminance.shape == (2, 10, 6)
    assert np.all(luminance > 0)
    average = average_luminance(luminance)
    assert average[0] != pytest.approx(average[1])  # beta differs between the lanes' observers
    columns = field.lane_centre_columns()
    line = luminance[1, :, columns[1]]
    assert longitudinal_uniformity(luminance, columns) <= line.min() / line.max() + 1e-12
    assert np.all(overall_uniformity(luminance) <= 1.0)
