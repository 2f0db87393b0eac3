"""Plausible mounting geometry: the ranges themselves and the luminaire database's checks
(the flux checks of the readers are in test_fuzz_readers.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from ies.errors import LuminaireDatabaseError, PhotometryWarning
from ies.library import load_library
from ies.plausibility import MOUNTING_RANGES, PlausibleRange


def test_ranges_split_impossible_unusual_and_usual() -> None:
    tilt = MOUNTING_RANGES["tilt"]
    values = np.array([np.nan, -91.0, -90.0, 0.0, 45.0, 90.0, 1e6, np.inf])
    assert tilt.impossible(values).tolist() == [True, True, False, False, False, False, True, True]
    assert tilt.unusual(values).tolist() == [False, False, True, False, True, True, False, False]
    arm = MOUNTING_RANGES["arm_length"]
    assert arm.impossible([-50.0, 0.0, 2.0]).tolist() == [True, False, False]
    assert arm.expected == "a number in [0, 15] m"


def test_open_lower_bound_excludes_the_bound() -> None:
    height = PlausibleRange("h", "m", 0.0, 60.0, 2.5, 30.0, low_open=True)
    assert height.impossible([0.0, 1e-9]).tolist() == [True, False]
    assert height.expected.startswith("a number in (0,")


SYSTEM = (
    "[systems.mine]\n"
    'description = "test"\nmounting_height = 6.0\narm_length = 0.5\ntilt = 0.0\n'
    'street_azimuth = 90.0\nphotometry_file = "lamp.ldt"\nspd = "HPS"\n'
    'lumens = 1000.0\nprovenance = "copy"\n'
)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    shutil.copy(load_library().root / "road_luminaire_son_tpp_250w.ldt", tmp_path / "lamp.ldt")
    return tmp_path


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ("tilt = 0.0", "tilt = 1e6", ["tilt = 1000000.0", "[-90, 90] deg"]),
        ("tilt = 0.0", "tilt = nan", ["tilt = nan"]),
        ("arm_length = 0.5", "arm_length = -50", ["arm_length = -50.0", "[0, 15] m"]),
        ("mounting_height = 6.0", "mounting_height = 1e7", ["mounting_height", "(0, 60] m"]),
        ("mounting_height = 6.0", "mounting_height = 0", ["mounting_height = 0.0"]),
        ("street_azimuth = 90.0", "street_azimuth = inf", ["street_azimuth = inf"]),
        ("lumens = 1000.0", "lumens = 1e308", ["lumens = 1e+308", "(0, 1e+07] lm"]),
        ("lumens = 1000.0", "lumens = -5", ["lumens = -5.0"]),
        ("[systems.mine]", "version = 2\n[systems.mine]", ["unknown top-level key 'version'"]),
    ],
)
def test_impossible_systems_are_one_line_errors(folder: Path, old, new, words) -> None:
    (folder / "systems.toml").write_text(SYSTEM.replace(old, new))
    with pytest.raises(LuminaireDatabaseError) as info:
        load_library(folder)
    message = str(info.value)
    assert "\n" not in message and ("'mine'" in message or "top-level" in message)
    for word in words:
        assert word in message


def test_system_that_is_not_a_table(folder: Path) -> None:
    (folder / "systems.toml").write_text("[systems]\nmine = 3\n")
    with pytest.raises(LuminaireDatabaseError, match=r"expected a \[systems\.mine\] table"):
        load_library(folder)


def test_unusual_geometry_is_a_warning(folder: Path) -> None:
    (folder / "systems.toml").write_text(SYSTEM.replace("tilt = 0.0", "tilt = 50.0"))
    with pytest.warns(PhotometryWarning, match="tilt = 50 deg is unusual"):
        database = load_library(folder)
    assert database.get("mine").tilt == 50.0
