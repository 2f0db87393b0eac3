"""Class selection: the first matching rule wins, conditions on the street fields, the layer's
own class overrides, unknown classes and bad rule files are one-line errors naming the place."""

from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd
import pytest

from nightlights.errors import DataQualityWarning, InputError
from nightlights.roads import read_class_selection, select_classes

#: The shipped defaults, typed from the file's documented intent: motorway M2; arterial M2 with
#: 4+ lanes or a median, else M3; collector M4; local P3; service P4; path P5.
DEFAULTS = [
    ({"street_class": "motorway", "lanes": 2, "has_median": False}, "M2"),
    ({"street_class": "arterial", "lanes": 4, "has_median": False}, "M2"),
    ({"street_class": "arterial", "lanes": 2, "has_median": True}, "M2"),
    ({"street_class": "arterial", "lanes": 2, "has_median": False}, "M3"),
    ({"street_class": "Arterial ", "lanes": None, "has_median": None}, "M3"),
    ({"street_class": "collector", "lanes": 6, "has_median": True}, "M4"),
    ({"street_class": "local", "lanes": 2, "has_median": False}, "P3"),
    ({"street_class": "service", "lanes": 1, "has_median": False}, "P4"),
    ({"street_class": "path", "lanes": 1, "has_median": False}, "P5"),
]


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "rules.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_shipped_defaults() -> None:
    streets = pd.DataFrame([row for row, _ in DEFAULTS])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = select_classes(streets)
    assert got.tolist() == [cls for _, cls in DEFAULTS]
    assert got.name == "lighting_class"


def test_first_match_wins_and_conditions_must_all_hold(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        """
[[rule]]
street_class = ["arterial", "collector"]
min_lanes = 3
max_width = 12.0
oneway = false
class = "m1"

[[rule]]
street_class = ["arterial", "collector"]
min_width = 12.0
class = "C2"

[[rule]]
street_class = ["arterial", "collector", "local"]
class = "P6"
""",
    )
    streets = pd.DataFrame(
        {
            "street_class": ["arterial", "collector", "collector", "arterial", "local"],
            "lanes": [4, 4, 2, 4, 4],
            "width": [10.0, 14.0, 14.0, 10.0, 30.0],
            "oneway": [False, False, False, True, False],
        }
    )
    # row 3: 2 lanes fail rule 1, width 14 takes rule 2; row 4: oneway fails rule 1 and width
    # 10 < 12 rule 2; row 5: a local street only rule 3 names.
    assert select_classes(streets, path).tolist() == ["M1", "C2", "C2", "P6", "P6"]


def test_the_layer_class_overrides_and_unmatched_streets_warn() -> None:
    streets = pd.DataFrame(
        {
            "street_class": ["motorway", "local", None, "arterial"],
            "lanes": [2, 2, 2, None],
            "has_median": [False, False, False, None],
            "lighting_class": [None, " c3 ", None, ""],
        }
    )
    with pytest.warns(DataQualityWarning, match="1 streets .* match no class-selection rule"):
        got = select_classes(streets)
    assert got.tolist() == ["M2", "C3", None, "M3"]


def test_unknown_layer_classes_name_the_streets() -> None:
    streets = pd.DataFrame(
        {
            "street_class": ["local", "local", "local"],
            "lighting_class": ["M9", None, "Q1"],
            "source_id": ["w11", "w12", "w13"],
        }
    )
    with pytest.raises(InputError, match=r"2 streets .*M9 \(source_id w11\), Q1 \(source_id w13\)"):
        select_classes(streets)


def test_missing_condition_fields_warn_and_match_nothing(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        '[[rule]]\nstreet_class = "local"\nlit = true\nclass = "P1"\n'
        '[[rule]]\nstreet_class = "local"\nclass = "P2"\n',
    )
    with pytest.warns(DataQualityWarning, match="no field lit"):
        got = select_classes(pd.DataFrame({"street_class": ["local"]}), path)
    assert got.tolist() == ["P2"]


def test_rules_may_give_the_classes_of_another_table(tmp_path: Path) -> None:
    table = {"RP8_LOCAL_LOW": {"average_illuminance": 3.0}}
    path = _write(tmp_path, '[[rule]]\nstreet_class = "local"\nclass = "RP8_LOCAL_LOW"\n')
    with pytest.raises(InputError, match="class = 'RP8_LOCAL_LOW'"):
        read_class_selection(path)
    streets = pd.DataFrame({"street_class": ["local"]})
    assert select_classes(streets, path, requirements=table).tolist() == ["RP8_LOCAL_LOW"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('[[rule]]\nstreet_class = "local"\nclass = "M9"\n', r"rules.toml:1: class = 'M9'"),
        (
            '[[rule]]\nstreet_class = "local"\nclass = "P1"\n\n[[rule]]\nstreet_class = "lane"\n'
            'class = "P1"\n',
            r"rules.toml:5: street_class 'lane'",
        ),
        (
            '[[rule]]\nstreet_class = "local"\nclass = "P1"\nmin_lane = 2\n',
            "unknown key 'min_lane'",
        ),
        ('[[rule]]\nstreet_class = "local"\nclass = "P1"\nmin_lanes = 2.5\n', "min_lanes = 2.5"),
        ('[[rule]]\nstreet_class = "local"\nclass = "P1"\nlit = "yes"\n', "lit = 'yes'"),
        ('[[rule]]\nstreet_class = "local"\nclass = "P1"\nmax_width = -1\n', "max_width = -1"),
        ('[[rule]]\nclass = "P1"\n', "rule 1 has no 'street_class'"),
        ('[[rule]]\nstreet_class = 3\nclass = "P1"\n', "street_class = 3"),
        ('rules = 1\n[[rule]]\nstreet_class = "local"\nclass = "P1"\n', "unknown key 'rules'"),
        ("# nothing\n", r"no \[\[rule\]\]"),
        ("[[rule]\n", "not a TOML file"),
    ],
)
def test_bad_rule_files_are_one_line_errors(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(InputError, match=match) as info:
        read_class_selection(_write(tmp_path, text))
    assert "\n" not in str(info.value)


def test_no_street_class_field_and_no_file() -> None:
    with pytest.raises(InputError, match="no 'street_class' field"):
        select_classes(pd.DataFrame({"lanes": [2]}))
    with pytest.raises(InputError, match="no such class-selection file"):
        read_class_selection("/nonexistent/rules.toml")
