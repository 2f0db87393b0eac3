"""Hemispherical, semicylindrical and vertical illuminance against the flux on small receptor
surfaces integrated by quadrature (no use of the closed forms), and by hand for simple cases."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.roads import (
    hemispherical_illuminance,
    semicylindrical_illuminance,
    vertical_illuminance,
)

#: Receptor size for the quadrature [m]: small against the distances to the lights (a
#: receptor of 1 cm biases the half-cylinder 1 % near the bollard).
SIZE = 1e-4
#: Luminaires (x, y, z) [m]: high, low and behind, one below the 1.5 m receptors (a bollard).
LIGHTS = np.array([[3.0, 1.0, 8.0], [-6.0, 4.0, 10.0], [12.0, -2.0, 6.0], [1.5, -1.0, 1.0]])
#: Points on the road [m].
POINTS = np.array([[0.0, 0.0, 0.0], [2.0, 3.0, 0.0], [-4.0, 1.0, 0.0]])


def _candela(vertical: np.ndarray) -> np.ndarray:
    """An asymmetric-in-V distribution [cd] of the angle from nadir [deg]."""
    return 800.0 + 600.0 * np.cos(np.radians(vertical)) ** 2 + 5.0 * vertical


def _intensity(vertical: np.ndarray, horizontal: np.ndarray) -> np.ndarray:
    return _candela(vertical) + 0.0 * horizontal


def _irradiance(surface: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Irradiance [lx] on surface patches (k, 3) of outward normals (k, 3), all lights:
    I(V) / d^2 * max(0, n . u), V from nadir worked out here (upright luminaires)."""
    total = np.zeros(len(surface))
    for light in LIGHTS:
        ray = light[None, :] - surface
        d = np.linalg.norm(ray, axis=1)
        u = ray / d[:, None]
        # V: the angle of -u (light to patch) from -z (nadir), cos V = (-u) . (-z) = u_z
        vertical = np.degrees(np.arccos(np.clip(u[:, 2], -1, 1)))
        total += _candela(vertical) / d**2 * np.maximum(np.sum(normals * u, axis=1), 0.0)
    return total


def _hemisphere(point: np.ndarray, n: int = 240) -> float:
    theta = (np.arange(n) + 0.5) * (np.pi / 2) / n
    phi = (np.arange(2 * n) + 0.5) * 2 * np.pi / (2 * n)
    t, f = np.meshgrid(theta, phi, indexing="ij")
    normal = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1).reshape(-1, 3)
    area = (SIZE**2 * np.sin(t) * (np.pi / 2 / n) * (2 * np.pi / (2 * n))).ravel()
    flux = np.sum(_irradiance(point + SIZE * normal, normal) * area)
    return float(flux / (2 * np.pi * SIZE**2))


def _half_cylinder(point: np.ndarray, facing: float, n: int = 720) -> float:
    phi = facing + (np.arange(n) + 0.5) * np.pi / n - np.pi / 2
    z = (np.arange(8) + 0.5) * SIZE / 8 - SIZE / 2
    f, h = np.meshgrid(phi, z, indexing="ij")
    normal = np.stack([np.cos(f), np.sin(f), 0 * f], -1).reshape(-1, 3)
    centre = point + np.array([0, 0, 1.5])
    surface = centre + SIZE * normal + np.stack([0 * h, 0 * h, h], -1).reshape(-1, 3)
    flux = np.sum(_irradiance(surface, normal)) * SIZE * (np.pi / n) * (SIZE / 8)
    return float(flux / (np.pi * SIZE * SIZE))


def _plane(point: np.ndarray, facing: float, n: int = 20) -> float:
    normal = np.array([np.cos(facing), np.sin(facing), 0.0])
    side = np.array([-np.sin(facing), np.cos(facing), 0.0])
    s = (np.arange(n) + 0.5) * SIZE / n - SIZE / 2
    a, b = np.meshgrid(s, s, indexing="ij")
    surface = point + [0, 0, 1.5] + a.reshape(-1, 1) * side + b.reshape(-1, 1) * [0, 0, 1]
    return float(np.mean(_irradiance(surface, np.broadcast_to(normal, surface.shape))))


def test_hemispherical_illuminance_is_the_flux_on_a_small_hemisphere() -> None:
    got = hemispherical_illuminance(POINTS, LIGHTS, np.eye(3), _intensity)
    want = [_hemisphere(p) for p in POINTS]
    np.testing.assert_allclose(got, want, rtol=5e-3)


@pytest.mark.parametrize("facing", [0.0, 2.0, -2.8])
def test_semicylindrical_illuminance_is_the_flux_on_a_small_half_cylinder(facing: float) -> None:
    direction = [np.cos(facing), np.sin(facing)]
    got = semicylindrical_illuminance(POINTS, direction, LIGHTS, np.eye(3), _intensity)
    want = [_half_cylinder(p, facing) for p in POINTS]
    np.testing.assert_allclose(got, want, rtol=5e-3)


@pytest.mark.parametrize("facing", [0.0, 2.0, -2.8])
def test_vertical_illuminance_is_the_flux_on_a_small_vertical_square(facing: float) -> None:
    direction = 3.0 * np.array([np.cos(facing), np.sin(facing)])  # any length
    got = vertical_illuminance(POINTS, direction, LIGHTS, np.eye(3), _intensity)
    want = [_plane(p, facing) for p in POINTS]
    np.testing.assert_allclose(got, want, rtol=5e-3)


def test_a_light_straight_above_and_one_at_45_degrees_by_hand() -> None:
    def flat(v: np.ndarray, h: np.ndarray) -> np.ndarray:
        return 1000.0 + 0.0 * v

    # straight above, 8 m over the surface: E_hs = I / (4 h^2) * 2; the 1.5 m receptors see it
    # edge-on: E_sc = E_v = 0.
    assert float(hemispherical_illuminance([0, 0, 0], [[0, 0, 8]], np.eye(3), flat)) == (
        pytest.approx(1000.0 / 128.0, rel=1e-12)
    )
    assert float(
        semicylindrical_illuminance([0, 0, 0], [1, 0], [[0, 0, 8]], np.eye(3), flat)
    ) == pytest.approx(0.0, abs=1e-12)
    assert float(vertical_illuminance([0, 0, 0], [1, 0], [[0, 0, 8]], np.eye(3), flat)) == (
        pytest.approx(0.0, abs=1e-12)
    )
    # 45 degrees up in the facing direction, h = 4 m above the receptor: d^2 = 32, the normal
    # illuminance 1000/32; on the plane times sin 45; on the half-cylinder times
    # sin 45 * (1 + 1) / pi; the hemisphere on the surface sees it at its own angle.
    light = [[4, 0, 5.5]]
    e_n = 1000.0 / 32.0
    assert float(vertical_illuminance([0, 0, 0], [1, 0], light, np.eye(3), flat)) == (
        pytest.approx(e_n / np.sqrt(2), rel=1e-12)
    )
    assert float(semicylindrical_illuminance([0, 0, 0], [1, 0], light, np.eye(3), flat)) == (
        pytest.approx(e_n * np.sqrt(2) / np.pi, rel=1e-12)
    )
    # facing away: the plane is dark, the half-cylinder's curved face still takes
    # sin 45 (1 - 1) = 0; facing sideways (alpha = 90 deg): sin 45 (1 + 0) / pi.
    assert float(vertical_illuminance([0, 0, 0], [-1, 0], light, np.eye(3), flat)) == 0.0
    assert float(semicylindrical_illuminance([0, 0, 0], [0, 1], light, np.eye(3), flat)) == (
        pytest.approx(e_n / np.sqrt(2) / np.pi, rel=1e-12)
    )
    d2 = 16 + 5.5**2
    assert float(hemispherical_illuminance([0, 0, 0], light, np.eye(3), flat)) == (
        pytest.approx(1000.0 / (4 * d2) * (1 + 5.5 / np.sqrt(d2)), rel=1e-12)
    )


def test_shapes_follow_the_points_and_directions_broadcast() -> None:
    grid = np.zeros((2, 3, 3))
    grid[..., 0] = np.arange(3)
    directions = np.zeros((2, 3, 2))
    directions[..., 0] = 1.0
    out = vertical_illuminance(grid, directions, LIGHTS, np.eye(3), _intensity)
    assert out.shape == (2, 3)
    np.testing.assert_allclose(
        out, vertical_illuminance(grid, [1, 0], LIGHTS, np.eye(3), _intensity), rtol=1e-12
    )


@pytest.mark.parametrize(
    ("direction", "match"),
    [([0, 0], "zero"), ([1, 0, 0], "expected"), ([[1, 0], [0, 1]], "broadcast")],
)
def test_bad_directions_are_one_line_errors(direction: list, match: str) -> None:
    with pytest.raises(InputError, match=match) as info:
        vertical_illuminance(POINTS, direction, LIGHTS, np.eye(3), _intensity)
    assert "\n" not in str(info.value)
