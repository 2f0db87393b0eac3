"""Candela lookups: Chuang Eq. 4, symmetry of unfolded tables, wrap-around, edge cases."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ies
from ies.errors import PhotometryWarning

from .conftest import ALL_FILES, data_file


def _read(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        return ies.read_photometry(data_file(name))


def test_bilinear_matches_chuang_equation_4():
    v_grid, h_grid = np.array([0.0, 10.0, 30.0]), np.array([0.0, 90.0, 360.0])
    table = np.array([[1.0, 2.0, 4.0], [3.0, 5.0, 7.0], [1.0, 2.0, 4.0]])
    photometry = ies.Photometry("C", v_grid, h_grid, table)
    v, h = 20.0, 22.5
    s, t = (v - 10) / 20, (h - 0) / 90  # Chuang 2011, Sec. 4.2, Eq. 4
    expected = (1 - t) * ((1 - s) * 2.0 + s * 4.0) + t * ((1 - s) * 5.0 + s * 7.0)
    assert float(photometry.intensity(v, h)) == pytest.approx(expected)


def test_lookup_is_vectorised_and_broadcasts():
    photometry = _read("OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies")
    v = np.linspace(0, 180, 7)[:, None]
    h = np.linspace(0, 360, 5)[None, :]
    out = photometry.intensity(v, h)
    assert out.shape == (7, 5)
    assert float(out[3, 2]) == float(photometry.intensity(v[3, 0], h[0, 2]))


def test_grid_nodes_are_reproduced_by_both_methods():
    photometry = _read("TX033306.ies")
    v = photometry.vertical_angles[None, :]
    h = photometry.horizontal_angles[:, None]
    np.testing.assert_allclose(photometry.intensity(v, h), photometry.candela, atol=1e-9)
    np.testing.assert_allclose(
        photometry.intensity(v, h, method="cubic"),
        photometry.candela,
        atol=1e-6 * photometry.candela.max(),
    )


def test_horizontal_angles_wrap_modulo_360():
    photometry = _read("HeadLight.ies")
    for method in ("bilinear", "cubic"):
        a = photometry.intensity(40.0, [10.0, 370.0, -350.0, 730.0], method=method)
        np.testing.assert_allclose(a, a[0])


def test_nan_angles_give_nan_and_out_of_range_gives_zero():
    photometry = _read("point_opening.ies")  # 0-90 deg: no upward light
    out = photometry.intensity([np.nan, 120.0, -5.0], [0.0, 0.0, 0.0])
    assert np.isnan(out[0])
    assert out[1] == 0.0 and out[2] == 0.0


def test_unknown_method_is_an_error():
    with pytest.raises(ies.PhotometryError, match="cubic"):
        _read("test.ies").intensity(0.0, 0.0, method="nearest")


@pytest.mark.parametrize(
    ("name", "mirror"),
    [
        ("LLIA001477-003.ies", lambda h: 360.0 - h),  # 0-180: about the 0-180 plane
        ("TX033306.ies", lambda h: 180.0 - h),  # 90-270: about the 90-270 plane
        ("test.ies", lambda h: 180.0 - h),  # 0-90: both planes
        ("symmetry_to_c0c90c180c270.ldt", lambda h: 360.0 - h),
        ("symmetry_to_c90c270.ldt", lambda h: 180.0 - h),
        ("demo_two_lamp_sets.ldt", lambda h: 180.0 - h),  # Isym 3
    ],
)
def test_symmetric_files_give_symmetric_lookups(name, mirror):
    photometry = _read(name)
    rng = np.random.default_rng(7)
    v, h = rng.uniform(0, 180, 2000), rng.uniform(0, 360, 2000)
    for method in ("bilinear", "cubic"):
        np.testing.assert_allclose(
            photometry.intensity(v, h, method=method),
            photometry.intensity(v, mirror(h), method=method),
            rtol=1e-9,
            atol=1e-9 * photometry.candela.max(),
        )


def test_rotationally_symmetric_file_ignores_horizontal_angle():
    photometry = _read("MTD0700312.ies")
    values = photometry.intensity(33.3, np.linspace(0, 360, 50))
    np.testing.assert_allclose(values, values[0])


def test_eulumdat_symmetries_are_rotations_of_each_other():
    # the two files hold the same numbers for C0..C180 and C90..C270
    c0 = _read("symmetry_to_c0c180.ldt")
    c90 = _read("symmetry_to_c90c270.ldt")
    v = np.linspace(0, 180, 37)
    for h in (0.0, 35.0, 90.0, 170.0):
        np.testing.assert_allclose(c90.intensity(v, h + 90.0), c0.intensity(v, h), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    index=st.integers(min_value=0, max_value=len(ALL_FILES) - 1),
    v=st.floats(min_value=-10, max_value=190),
    h=st.floats(min_value=-1000, max_value=1000),
    method=st.sampled_from(["bilinear", "cubic"]),
)
def test_intensity_is_never_negative(index, v, h, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_photometry(ALL_FILES[index])
    assert float(photometry.intensity(v, h, method=method)) >= 0.0


@settings(max_examples=50, deadline=None)
@given(v=st.floats(min_value=0.5, max_value=179.5), h=st.floats(min_value=0, max_value=359.9))
def test_angles_and_directions_round_trip(v, h):
    x, y, z = ies.direction_from_angles(v, h)
    v2, h2 = ies.photometric_angles(x, y, z)
    assert float(v2) == pytest.approx(v, abs=1e-9)
    assert (float(h2) - h + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-7)


def test_nadir_and_street_side_directions():
    v, h = ies.photometric_angles([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0])
    np.testing.assert_allclose(v, [0.0, 90.0, 90.0])
    np.testing.assert_allclose(h[1:], [0.0, 90.0])
