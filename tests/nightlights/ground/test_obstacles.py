"""The obstacle model: the canyon floor's sky view factor, exact open ground, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.ground.obstacles import (
    LAND_USE_OBSTACLES,
    ObstacleProperties,
    blocked_intensity,
    escaping_fraction,
    obstacle_transmission,
)


def _canyon_sky_view_factor(aspect: float, n: int = 600) -> float:
    """Flux fraction of a Lambertian floor point (the centre line of an infinite canyon of
    H/W = ``aspect``) that reaches the sky: a midpoint quadrature over the hemisphere of
    cos(theta) / pi, each direction tested against the two walls by ray geometry."""
    theta = (np.arange(n) + 0.5) * (math.pi / 2) / n  # from the vertical
    phi = (np.arange(4 * n) + 0.5) * (2 * math.pi) / (4 * n)  # from the canyon axis
    t, p = np.meshgrid(theta, phi, indexing="ij")
    width, height = 1.0, aspect
    across = np.abs(np.sin(t) * np.sin(p))  # horizontal speed towards a wall
    # Height of the ray when it reaches a wall (W/2 across); open sky above the walls.
    with np.errstate(divide="ignore"):
        at_wall = np.where(across > 0, (width / 2) / across * np.cos(t), np.inf)
    visible = at_wall >= height
    d_omega = np.sin(t) * (math.pi / 2 / n) * (2 * math.pi / (4 * n))
    return float(np.sum(np.cos(t) / math.pi * visible * d_omega))


def test_canyon_floor_sees_the_analytic_sky_view_factor() -> None:
    analytic = math.cos(math.atan(2.0))  # H/W = 1: 0.447
    brute = _canyon_sky_view_factor(1.0)
    assert brute == pytest.approx(analytic, rel=2e-3)  # the reference itself checks out
    model = float(escaping_fraction("lambertian", 10.0, 10.0, 1.0))
    assert model == pytest.approx(analytic, rel=0.02)
    assert model == pytest.approx(brute, rel=0.02)
    assert abs(model - analytic) / analytic < 1e-9  # the quadrature is in fact exact
    # Other aspect ratios: 1 / sqrt(1 + (2 H / W)^2), and a brute force at H/W = 2.
    for aspect in (0.25, 0.5, 2.0, 4.0):
        value = float(escaping_fraction("lambertian", aspect * 10.0, 10.0, 1.0))
        assert value == pytest.approx(1 / math.sqrt(1 + (2 * aspect) ** 2), rel=1e-9)
    assert float(escaping_fraction("lambertian", 20.0, 10.0, 1.0)) == pytest.approx(
        _canyon_sky_view_factor(2.0), rel=5e-3
    )


def test_filling_factor_mixes_open_and_canyon() -> None:
    closed = float(escaping_fraction("garstang_lobe", 10.0, 10.0, 1.0))
    half = float(escaping_fraction("garstang_lobe", 10.0, 10.0, 0.5))
    assert half == pytest.approx(0.5 + 0.5 * closed, rel=1e-12)
    # The low-angle lobe loses more than the Lambertian floor.
    assert closed < float(escaping_fraction("lambertian", 10.0, 10.0, 1.0))


def test_escaping_fraction_is_the_integral_of_the_blocked_intensity() -> None:
    from scipy.integrate import quad

    for shape in ("lambertian", "uplight", "garstang_lobe"):
        exact = (
            2
            * math.pi
            * quad(
                lambda mu, s=shape: float(blocked_intensity(mu, s, 15.0, 12.0, 0.7)),
                0.0,
                1.0,
                points=[math.sin(math.atan(2 * 15.0 / 12.0))],
                limit=200,
            )[0]
        )
        assert float(escaping_fraction(shape, 15.0, 12.0, 0.7)) == pytest.approx(exact, rel=1e-6)


def test_table_interpolation_for_many_cells_matches_direct_quadrature() -> None:
    rng = np.random.default_rng(1)
    h = rng.uniform(0, 40, 3000)
    d = rng.uniform(1, 60, 3000)
    many = escaping_fraction("uplight", h, d, 1.0)
    few = escaping_fraction("uplight", h[:50], d[:50], 1.0)
    np.testing.assert_allclose(many[:50], few, atol=2e-6)


def test_zero_height_or_filling_changes_nothing() -> None:
    out = escaping_fraction("garstang_lobe", np.array([0.0, 5.0, np.nan]), 10.0, [1.0, 0.0, 1.0])
    assert out.tolist() == [1.0, 1.0, 1.0]
    assert obstacle_transmission(2.0, 0.0, 10.0, 1.0) == 1.0
    # Transmission: 1 - f at the horizon, 1 above the obstacle angle (45 deg here).
    assert float(obstacle_transmission(0.0, 10.0, 20.0, 0.6)) == pytest.approx(0.4)
    assert float(obstacle_transmission(46.0, 10.0, 20.0, 0.6)) == 1.0


@pytest.mark.parametrize(
    ("height", "spacing", "filling", "message"),
    [
        (-1.0, 10.0, 0.5, "obstacle height=-1.0 m; expected a finite height >= 0 m"),
        (5.0, -2.0, 0.5, "obstacle spacing=-2.0 m; expected a finite distance >= 0 m"),
        (5.0, 10.0, 1.5, "obstacle filling=1.5; expected a filling factor in [0, 1]"),
        (5.0, 10.0, -0.1, "obstacle filling=-0.1; expected a filling factor in [0, 1]"),
    ],
)
def test_bad_obstacles_are_refused_in_one_line(
    height: float, spacing: float, filling: float, message: str
) -> None:
    with pytest.raises(InputError) as info:
        ObstacleProperties(height, spacing, filling)
    assert str(info.value) == message
    with pytest.raises(InputError, match="at index 1"):
        escaping_fraction("lambertian", [5.0, height], [10.0, spacing], [0.5, filling])


def test_land_use_defaults_follow_their_aspect_ratios() -> None:
    # Stewart & Oke (2012) Table 2 mid-range H/W, recovered as h / d.
    expected = {"compact_midrise": 1.375, "open_lowrise": 0.525, "sparsely_built": 0.175}
    for name, aspect in expected.items():
        props = LAND_USE_OBSTACLES[name]
        assert props.height / props.spacing == pytest.approx(aspect)
    assert LAND_USE_OBSTACLES["open"].height == 0.0
