"""BUG ratings (IES TM-15-11 Addendum A) and the forward (street-side) azimuth."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ies
from ies.bug import BUG_ZONES, bug_rating_from_zones, rating_class
from ies.errors import PhotometryWarning
from ies.photometry import forward_azimuth

from .conftest import data_file


def test_zero_light_is_b0_u0_g0():
    assert str(bug_rating_from_zones(dict.fromkeys(BUG_ZONES, 0.0))) == "B0 U0 G0"


@pytest.mark.parametrize(
    ("lumens", "expected"),
    [(0.0, 0), (5.0, 1), (10.0, 1), (10.5, 2), (50.0, 2), (400.0, 3), (1000.0, 4), (1001.0, 5)],
)
def test_uplight_thresholds_of_tm15_table_a2(lumens, expected):
    zones = dict.fromkeys(BUG_ZONES, 0.0) | {"UH": lumens}
    assert bug_rating_from_zones(zones).uplight == expected


def test_backlight_uses_the_worst_zone():
    # TM-15-11 Table A-1: BM 1000 lm alone is B1, but BL 600 lm pushes it to B2
    zones = dict.fromkeys(BUG_ZONES, 0.0) | {"BM": 1000.0}
    assert bug_rating_from_zones(zones).backlight == 1
    assert bug_rating_from_zones(zones | {"BL": 600.0}).backlight == 2


def test_rating_class_above_class_4_is_5():
    assert rating_class({"X": 1e9}, {"X": (0, 1, 2, 3, 4)}) == 5


def test_full_cutoff_roadway_is_u0():
    # AEC ITALO: absolute photometry, no light above 90 deg -> U0 (sanity check)
    photometry = ies.read_ies(data_file("ITALO_1_5P5_S05_3.140-3M.IES"))
    assert photometry.upward_flux() == 0.0
    rating = photometry.bug_rating(street_azimuth=0.0)
    assert rating.uplight == 0
    assert str(rating) == "B2 U0 G2"


def test_uplight_of_a_file_with_light_above_90_deg():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_ies(data_file("HellaEcoLight_2070lm_LDT.ies"))
    rating = photometry.bug_rating(street_azimuth=90.0)
    assert rating.zone_lumens["UL"] + rating.zone_lumens["UH"] == pytest.approx(
        photometry.upward_flux()
    )
    assert rating.uplight == 2  # 20 lm above the horizontal: TM-15 U2 is <= 50 lm


def test_front_and_back_swap_with_the_street_side():
    photometry = ies.read_ies(data_file("ITALO_1_5P5_S05_3.140-3M.IES"))
    front = photometry.bug_rating(street_azimuth=0.0).zone_lumens
    back = photometry.bug_rating(street_azimuth=180.0).zone_lumens
    for zone in ("L", "M", "H", "VH"):
        assert front["F" + zone] == pytest.approx(back["B" + zone])


@pytest.mark.parametrize(
    ("name", "azimuth"),
    [
        ("ITALO_1_5P5_S05_3.140-3M.IES", 0.0),
        ("S01.01.02.354_MAXWELL-8-T4_LUXEON_5050_Square_with_glass-MEASURED_IESNA.ies", 0.0),
        ("road_luminaire.ldt", 90.0),
        ("HellaEcoLight_2070lm_LDT.ies", 90.0),
    ],
)
def test_forward_azimuth_finds_the_street_side(name, azimuth):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_photometry(data_file(name))
    difference = (forward_azimuth(photometry) - azimuth + 180.0) % 360.0 - 180.0
    assert abs(difference) < 10.0


def test_forward_azimuth_of_a_symmetric_lobe_is_undefined():
    assert np.isnan(forward_azimuth(ies.read_ies(data_file("MTD0700312.ies"))))
