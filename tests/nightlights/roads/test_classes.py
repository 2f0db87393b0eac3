"""Lighting classes: the shipped tables hold EN 13201-2:2015's values, a user's copy is read
and checked, and a section's compliance gives each criterion's margin and the binding one."""

from __future__ import annotations

from pathlib import Path

import pytest

from nightlights.errors import InputError
from nightlights.roads import (
    REGION_REQUIREMENTS,
    class_names,
    compliance,
    read_requirements,
    requirements,
    requirements_for_region,
)
from nightlights.streets._location import FALLBACK_NETWORK, REGION_BOXES

#: EN 13201-2:2015 Table 1 (M classes): L_av [cd m-2], U_o, U_l, f_TI [%], R_EI, typed from the
#: standard's table independently of the shipped file.
TABLE_1 = {
    "M1": (2.00, 0.40, 0.70, 10, 0.35),
    "M2": (1.50, 0.40, 0.70, 10, 0.35),
    "M3": (1.00, 0.40, 0.60, 15, 0.30),
    "M4": (0.75, 0.40, 0.60, 15, 0.30),
    "M5": (0.50, 0.35, 0.40, 15, 0.30),
    "M6": (0.30, 0.35, 0.40, 20, 0.30),
}
#: Table 2 (C classes): E_av [lx], U_o; Table 3 (P classes): E_av, E_min [lx].
TABLE_2 = {"C0": 50.0, "C1": 30.0, "C2": 20.0, "C3": 15.0, "C4": 10.0, "C5": 7.5}
TABLE_3 = {
    "P1": (15.0, 3.0),
    "P2": (10.0, 2.0),
    "P3": (7.5, 1.5),
    "P4": (5.0, 1.0),
    "P5": (3.0, 0.6),
    "P6": (2.0, 0.4),
}


def test_the_shipped_tables_are_en_13201_2() -> None:
    table = read_requirements()
    assert set(table) == set(TABLE_1) | set(TABLE_2) | set(TABLE_3)
    for name, (lav, uo, ul, ti, rei) in TABLE_1.items():
        assert table[name] == {
            "average_luminance": lav,
            "overall_uniformity": uo,
            "longitudinal_uniformity": ul,
            "threshold_increment": ti,
            "edge_illuminance_ratio": rei,
        }
    for name, eav in TABLE_2.items():
        assert table[name] == {"average_illuminance": eav, "overall_uniformity": 0.40}
    for name, (eav, emin) in TABLE_3.items():
        assert table[name] == {"average_illuminance": eav, "minimum_illuminance": emin}


def test_compliance_gives_every_margin_and_the_binding_criterion() -> None:
    measured = {
        "average_luminance": 1.2,  # M3 asks 1.0: +20 %
        "overall_uniformity": 0.42,  # 0.40: +5 %
        "longitudinal_uniformity": 0.57,  # 0.60: -5 %
        "threshold_increment": 12.0,  # at most 15: 1 - 12/15 = +20 %
        "edge_illuminance_ratio": 0.30,  # 0.30: exactly kept
        "average_illuminance": 3.0,  # not an M criterion: ignored
    }
    result = compliance("m3", measured)
    margins = {c.name: round(c.margin, 12) for c in result.criteria}
    assert margins == {
        "average_luminance": 0.2,
        "overall_uniformity": 0.05,
        "longitudinal_uniformity": -0.05,
        "threshold_increment": 0.2,
        "edge_illuminance_ratio": 0.0,
    }
    assert not result.passed and result.lighting_class == "M3"
    assert result.binding.name == "longitudinal_uniformity"
    assert [c.passed for c in result.criteria] == [True, True, False, True, True]
    kept = compliance("P5", {"average_illuminance": 3.0, "minimum_illuminance": 0.9})
    assert kept.passed and kept.binding.name == "average_illuminance"


def test_a_users_copy_replaces_the_tables(tmp_path: Path) -> None:
    path = tmp_path / "scheme.toml"
    path.write_text("[classes.town]\naverage_illuminance = 12.5\nminimum_illuminance = 2\n")
    table = read_requirements(path)
    assert requirements("TOWN", table) == {"average_illuminance": 12.5, "minimum_illuminance": 2.0}
    assert compliance(
        "town", {"average_illuminance": 10, "minimum_illuminance": 3}, table
    ).binding.name == ("average_illuminance")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[classes.X]\naverage_luminance = -1\n", "expected a number > 0"),
        ("[classes.X]\noverall_uniformity = 1.5\n", "expected <= 1"),
        ("[classes.X]\nglare = 3\n", "unknown criterion 'glare'"),
        ("[classes.X]\naverage_luminance = true\n", "expected a number > 0"),
        ("[other]\na = 1\n", "no [classes.NAME] tables"),
        ("[classes.X]\n", "has no requirements"),
        ("classes = [", "not a TOML file"),
    ],
)
def test_a_bad_requirements_file_is_refused(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace(".", r"\.")):
        read_requirements(path)


def test_unknown_classes_and_missing_figures_are_named() -> None:
    with pytest.raises(InputError, match="lighting_class='M7'; expected one of C0"):
        requirements("M7")
    with pytest.raises(InputError, match="no 'minimum_illuminance', which class P2 requires"):
        compliance("P2", {"average_illuminance": 12.0})
    with pytest.raises(InputError, match="expected a number >= 0"):
        compliance("C1", {"average_illuminance": float("nan"), "overall_uniformity": 0.5})
    with pytest.raises(InputError, match="no such requirements file"):
        read_requirements("/nonexistent/scheme.toml")


RP8_EXAMPLE = Path(__file__).parents[3] / "nightlights" / "roads" / "data" / "rp8_example.toml"
#: A user's RP-8 table: the criteria of both methods, values invented for the test (not RP-8's).
USER_RP8 = """
standard = "my RP-8 copy"
placeholder = false

[classes.RP8_MAJOR_HIGH]
average_luminance = 1.5
luminance_average_to_minimum = 3.0
luminance_maximum_to_minimum = 5.0
veiling_luminance_ratio = 0.3
average_illuminance = 15.0
illuminance_average_to_minimum = 3.0
"""


def test_the_rp8_example_is_refused_while_it_holds_placeholders(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="placeholder = True: its values are placeholders"):
        read_requirements(RP8_EXAMPLE)
    assert "RP8_FREEWAY_A" in class_names(RP8_EXAMPLE)
    assert len(class_names(RP8_EXAMPLE)) == 14
    # the same file with the flag turned off is read: the schema itself is valid
    copy = tmp_path / "rp8.toml"
    copy.write_text(RP8_EXAMPLE.read_text().replace("placeholder = true", "placeholder = false"))
    assert set(read_requirements(copy)) == set(class_names(RP8_EXAMPLE))


def test_rp8_criteria_are_maxima_of_ratios_at_least_one(tmp_path: Path) -> None:
    path = tmp_path / "rp8.toml"
    path.write_text(USER_RP8)
    table = read_requirements(path)
    measured = {
        "average_luminance": 1.8,  # min 1.5: +20 %
        "luminance_average_to_minimum": 2.4,  # max 3.0: 1 - 2.4/3 = +20 %
        "luminance_maximum_to_minimum": 5.5,  # max 5.0: -10 %
        "veiling_luminance_ratio": 0.27,  # max 0.3: +10 %
        "average_illuminance": 18.0,
        "illuminance_average_to_minimum": 2.0,
    }
    result = compliance("rp8_major_high", measured, table)
    assert not result.passed
    assert result.binding.name == "luminance_maximum_to_minimum"
    assert result.binding.margin == pytest.approx(-0.1, abs=1e-12)
    assert {c.name: c.kind for c in result.criteria}["veiling_luminance_ratio"] == "maximum"
    path.write_text(
        USER_RP8.replace("luminance_average_to_minimum = 3.0", "luminance_average_to_minimum = 0.5")
    )
    with pytest.raises(InputError, match=r"luminance_average_to_minimum = 0.5; expected >= 1"):
        read_requirements(path)


def test_requirements_by_region_and_the_users_table_wins(tmp_path: Path) -> None:
    assert requirements_for_region("europe") == read_requirements()
    assert requirements_for_region("generic")["P3"] == {
        "average_illuminance": 7.5,
        "minimum_illuminance": 1.5,
    }
    with pytest.raises(InputError, match="region='north_america' takes ANSI/IES RP-8"):
        requirements_for_region("north_america")
    path = tmp_path / "rp8.toml"
    path.write_text(USER_RP8)
    assert set(requirements_for_region("north_america", path)) == {"RP8_MAJOR_HIGH"}
    with pytest.raises(InputError, match="region='mars'"):
        requirements_for_region("mars")
    assert set(REGION_REQUIREMENTS) == set(REGION_BOXES) | {FALLBACK_NETWORK}


def test_unknown_top_level_keys_are_errors(tmp_path: Path) -> None:
    path = tmp_path / "t.toml"
    path.write_text("placholder = true\n[classes.X]\naverage_illuminance = 1.0\n")
    with pytest.raises(InputError, match="unknown key 'placholder'"):
        read_requirements(path)


def test_an_infinite_ratio_fails_a_maximum_and_is_refused_for_a_minimum(tmp_path: Path) -> None:
    path = tmp_path / "rp8.toml"
    path.write_text(USER_RP8)
    measured = {
        "average_luminance": 1.8,
        "luminance_average_to_minimum": float("inf"),  # a dark point
        "luminance_maximum_to_minimum": 4.0,
        "veiling_luminance_ratio": 0.2,
        "average_illuminance": 18.0,
        "illuminance_average_to_minimum": 2.0,
    }
    result = compliance("RP8_MAJOR_HIGH", measured, read_requirements(path))
    assert not result.passed
    assert result.binding.name == "luminance_average_to_minimum"
    with pytest.raises(InputError, match="expected a number >= 0"):
        compliance("P1", {"average_illuminance": float("inf"), "minimum_illuminance": 3.0})
