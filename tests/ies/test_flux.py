"""Luminous flux integrals: exact cases, declared vs integrated lumens, IES/LDT pairs."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ies
from ies.errors import FluxMismatchWarning, PhotometryWarning

from .conftest import data_file


def test_unit_sphere_file_gives_four_pi():
    # test.ies: every candela is 1 (IESViewer360), so the flux is 4 pi lm exactly
    photometry = ies.read_ies(data_file("test.ies"))
    assert photometry.luminous_flux() == pytest.approx(4 * math.pi, abs=1e-6)
    assert photometry.downward_flux() == pytest.approx(2 * math.pi, abs=1e-6)
    assert photometry.upward_flux() == pytest.approx(2 * math.pi, abs=1e-6)
    # absolute photometry: ULOR is the upward fraction of the integrated flux
    assert photometry.upward_light_output_ratio() == pytest.approx(0.5, abs=1e-9)


def test_integral_is_exact_for_a_linear_profile():
    # I(V) = V [deg] is reproduced exactly by linear interpolation on a 3-node grid, so the
    # flux must equal 2 pi * (180/pi) * integral_0^pi t sin t dt = 2 pi * (180/pi) * pi = 360 pi
    photometry = ies.Photometry(
        "C", [0.0, 90.0, 180.0], [0.0, 360.0], np.array([[0.0, 90.0, 180.0]] * 2)
    )
    assert photometry.luminous_flux() == pytest.approx(360.0 * math.pi, rel=1e-12)


def test_cosine_lobe_converges_to_pi_i0():
    # Lambertian downlight I = I0 cos V (V < 90): flux = pi I0; bilinear error is O(h^2)
    errors = []
    for step in (10.0, 5.0, 2.5):
        v = np.arange(0.0, 90.0 + step / 2, step)
        photometry = ies.Photometry("C", v, [0.0, 360.0], np.array([np.cos(np.radians(v))] * 2))
        errors.append(abs(photometry.luminous_flux() / math.pi - 1))
    assert errors[-1] < 1e-3
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.1)  # second order


@pytest.mark.parametrize(
    ("name", "expected", "tolerance"),
    [
        # declared lumens x lamps x ballast factor (IES); lamp flux x LORL (EULUMDAT)
        ("OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies", 9155.7, 0.02),
        (
            "S01.01.02.354_MAXWELL-8-T4_LUXEON_5050_Square_with_glass-MEASURED_IESNA.ies",
            1000.0,
            0.02,
        ),
        ("demo_two_lamp_sets.ldt", 9408.0 * 0.78, 0.02),
        ("road_luminaire.ldt", 33200.0 * 0.8442, 0.02),
        ("fluorescent_luminaire.ldt", 8100.0 * 0.403, 0.02),
        # absolute files whose [LAMP] line states the luminaire lumens (Opple, DIAL export)
        ("LDP0109501.ies", 1900.0, 0.02),
        ("LTD0110301.ies", 150.0, 0.02),
        ("MTD0700312.ies", 550.0, 0.02),
    ],
)
def test_integrated_flux_matches_declared(name, expected, tolerance):
    photometry = ies.read_photometry(data_file(name))
    assert photometry.luminous_flux() == pytest.approx(expected, rel=tolerance)
    assert photometry.warnings == ()


def test_inconsistent_file_warns_but_reads():
    # HellaEcoLight_2070lm_LDT.ies declares 1000 lm but integrates to about 2075 lm
    with pytest.warns(FluxMismatchWarning, match="2074"):
        photometry = ies.read_ies(data_file("HellaEcoLight_2070lm_LDT.ies"))
    assert photometry.luminous_flux() == pytest.approx(2075.0, rel=0.005)
    assert len(photometry.warnings) == 1


def test_same_luminaire_as_ies_and_ldt():
    # photometric-viewer ships the same dummy luminaire BD0150 as LM-63-1995 (absolute, 1 plane)
    # and as EULUMDAT (Isym 1, 1000 lm, absolute): flux and lookups must agree
    from_ies = ies.read_ies(data_file("point_opening.ies"))
    from_ldt = ies.read_ldt(data_file("symmetry_about_vertical_axis.ldt"))
    assert from_ies.luminous_flux() == pytest.approx(from_ldt.luminous_flux(), rel=1e-12)
    rng = np.random.default_rng(3)
    v, h = rng.uniform(0, 180, 500), rng.uniform(-720, 720, 500)
    np.testing.assert_allclose(from_ies.intensity(v, h), from_ldt.intensity(v, h), rtol=1e-12)
    np.testing.assert_allclose(
        from_ies.intensity(v, h, method="cubic"),
        from_ldt.intensity(v, h, method="cubic"),
        rtol=1e-9,
        atol=1e-9,
    )


def test_zone_fluxes_add_up():
    photometry = ies.read_photometry(
        data_file("OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies")
    )
    total = photometry.luminous_flux()
    assert photometry.downward_flux() + photometry.upward_flux() == pytest.approx(total, rel=1e-12)
    quarters = sum(photometry.zone_flux((0, 180), (a, a + 90)) for a in (45, 135, 225, 315))
    assert quarters == pytest.approx(total, rel=1e-12)
    rating = photometry.bug_rating()
    assert sum(rating.zone_lumens.values()) == pytest.approx(total, rel=1e-12)


def test_relative_file_ulor_uses_lamp_flux():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_ies(data_file("TX033306.ies"))
    assert photometry.upward_light_output_ratio() == pytest.approx(
        photometry.upward_flux() / 6850.0
    )
    assert photometry.light_output_ratio() == pytest.approx(photometry.luminous_flux() / 6850.0)


@settings(max_examples=25, deadline=None)
@given(multiplier=st.floats(min_value=1e-3, max_value=1e3))
def test_flux_scales_linearly_with_the_candela_multiplier(multiplier):
    base = (
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 {m!r} 4 3 1 2 0 0 0\n1 1 10\n0 30 60 90\n"
        "0 90 180\n100 80 40 0\n100 70 30 0\n100 60 20 0\n"
    )
    one = ies.parse_ies(base.format(m=1.0))
    scaled = ies.parse_ies(base.format(m=multiplier))
    assert scaled.luminous_flux() == pytest.approx(multiplier * one.luminous_flux(), rel=1e-12)
    assert scaled.scaled(1 / multiplier).luminous_flux() == pytest.approx(one.luminous_flux())


@pytest.mark.parametrize(
    "name", ["demo_two_lamp_sets.ldt", "road_luminaire.ldt", "projector.ldt", "relative.ldt"]
)
def test_downward_fraction_matches_eulumdat_dff(name):
    # EULUMDAT line 22 states the downward flux fraction DFF [%] computed by the file's author
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_ldt(data_file(name))
    dff = float(photometry.keywords["downward_flux_fraction"])
    assert 100 * photometry.downward_flux() / photometry.luminous_flux() == pytest.approx(
        dff, abs=0.5
    )


def test_multiplier_of_absolute_radiometric_file():
    # B1 module.ies (Ushio, LM-63-2002, feet, lumens -1, multiplier 1.32) states
    # [_TOTALLUMINAIRELUMENS] 91.6 for the unscaled table: the scaled integral is 1.32 x that
    photometry = ies.read_ies(data_file("B1_module.ies"))
    assert photometry.keywords["_UNITS"] == "feet"
    stated = float(photometry.keywords["_TOTALLUMINAIRELUMENS"])
    assert photometry.luminous_flux() == pytest.approx(1.32 * stated, rel=0.01)
