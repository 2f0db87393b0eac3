"""Luminaire frames and candela tables (Chuang 2011, Sec. 4.3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nightlights.errors import InputError
from nightlights.ground import (
    IntensityTable,
    direction_to_photometric,
    flux_profile,
    light_points,
    luminaire_rotation,
    photometric_to_direction,
)

angles = st.floats(-360.0, 360.0, allow_nan=False)


def test_rotation_heading_is_a_compass_bearing() -> None:
    forward = np.array([0.0, 1.0, 0.0])
    for heading, expected in [
        (0, (0, 1, 0)),
        (90, (1, 0, 0)),
        (180, (0, -1, 0)),
        (270, (-1, 0, 0)),
    ]:
        np.testing.assert_allclose(luminaire_rotation(heading) @ forward, expected, atol=1e-12)


def test_tilt_raises_the_front_and_roll_lowers_the_right() -> None:
    rotation = luminaire_rotation(0.0, 30.0, 0.0)
    np.testing.assert_allclose(rotation @ [0, 1, 0], [0, np.cos(np.pi / 6), 0.5], atol=1e-12)
    rotation = luminaire_rotation(0.0, 0.0, 30.0)
    np.testing.assert_allclose(rotation @ [1, 0, 0], [np.cos(np.pi / 6), 0, -0.5], atol=1e-12)


@given(angles, angles, angles)
def test_rotation_is_orthonormal(heading: float, tilt: float, roll: float) -> None:
    rotation = luminaire_rotation(heading, tilt, roll)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)


def test_light_point_hangs_on_the_arm() -> None:
    point = light_points(10.0, 20.0, 90.0, mounting_height=8.0, arm_length=2.0, ground_z=5.0)
    np.testing.assert_allclose(point, [12.0, 20.0, 13.0])


def test_photometric_angles_of_untilted_luminaire() -> None:
    rotation = luminaire_rotation(90.0)  # facing east
    vertical, horizontal = direction_to_photometric(
        [[0, 0, -1], [1, 0, -1], [0, 1, -1], [0, 0, 1]], rotation, street_azimuth=90.0
    )
    np.testing.assert_allclose(vertical, [0, 45, 45, 180], atol=1e-12)
    # east = forward = street side (C90); north is to the left: counterclockwise, C180.
    np.testing.assert_allclose(horizontal[1:3], [90, 180], atol=1e-12)


@settings(max_examples=50)
@given(
    angles,
    st.floats(-60, 60),
    st.floats(-30, 30),
    st.floats(0.5, 179.5),
    st.floats(0, 359.9),
    st.floats(0, 359.9),
)
def test_direction_round_trip(
    heading: float, tilt: float, roll: float, vertical: float, horizontal: float, street: float
) -> None:
    rotation = luminaire_rotation(heading, tilt, roll)
    direction = photometric_to_direction(vertical, horizontal, rotation, street_azimuth=street)
    v, h = direction_to_photometric(direction, rotation, street_azimuth=street)
    assert v == pytest.approx(vertical, abs=1e-7)
    assert (h - horizontal + 180) % 360 - 180 == pytest.approx(0.0, abs=1e-6)


def test_table_lookup_reproduces_a_bilinear_function_exactly() -> None:
    # A bilinear function of (V, H) is reproduced exactly by bilinear interpolation.
    def func(v: np.ndarray, h: np.ndarray) -> np.ndarray:
        return 100 + 0.5 * v + 0.1 * h + 0.001 * v * h

    table = IntensityTable.from_function(func, vertical_step=5.0, horizontal_step=15.0)
    rng = np.random.default_rng(1)
    # H below the last table interval, where the table wraps 360 onto 0.
    v, h = rng.uniform(0, 180, 1000), rng.uniform(0, 345, 1000)
    np.testing.assert_allclose(table.lookup(v, h), func(v, h), rtol=1e-12)


def test_table_rejects_negative_candela() -> None:
    with pytest.raises(InputError, match="negative"):
        IntensityTable(90.0, 180.0, -np.ones((3, 3)))


def test_flux_profile_of_isotropic_source_is_4_pi() -> None:
    """4 pi I for an isotropic source; midpoint rule error O(step^2), tolerance 1e-5."""
    table = IntensityTable.from_function(lambda v, h: np.ones_like(v))
    profile = flux_profile(table, tilt=25.0)
    assert profile.total_flux == pytest.approx(4 * np.pi, rel=1e-5)
    assert profile.downward_flux == pytest.approx(2 * np.pi, rel=1e-5)


def test_tilt_moves_lambertian_flux_above_the_horizon() -> None:
    """A cosine lobe tilted by a sends (1 - cos a)/2 of its flux upwards (analytic)."""
    table = IntensityTable.from_function(lambda v, h: np.where(v < 90, np.cos(np.radians(v)), 0.0))
    for tilt in (0.0, 20.0, 45.0):
        profile = flux_profile(table, tilt=tilt)
        expected = np.pi * (1 - np.cos(np.radians(tilt))) / 2
        assert profile.upward_flux == pytest.approx(expected, abs=2e-4 * np.pi)


def test_table_from_type_b_photometry_is_refused() -> None:
    class TypeB:
        photometric_type = "B"
        source = "floodlight.ies"
        vertical_angles = np.array([-90.0, 0.0, 90.0])
        horizontal_angles = np.array([-90.0, 0.0, 90.0])

        def intensity(self, v, h):
            return np.ones_like(v)

    with pytest.raises(InputError, match=r"floodlight\.ies: photometric type B"):
        IntensityTable.from_photometry(TypeB())
