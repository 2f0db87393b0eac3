"""Malformed files: errors name the file, the line and the token."""

from __future__ import annotations

import pytest

import ies
from ies.errors import PhotometryError, PhotometryParseError

GOOD = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 2 1 2 0 0 0\n1 1 10\n0 45 90\n0 90\n1 2 3\n4 5 6\n"


def test_good_text_parses():
    assert ies.parse_ies(GOOD, source="good.ies").candela.shape == (5, 3)


@pytest.mark.parametrize(
    ("text", "line", "token", "message"),
    [
        (GOOD.replace("4 5 6\n", "4 5\n"), 8, None, "file ends early"),  # truncated
        (GOOD.replace("1 2 3", "1 -2 3"), 7, "-2", "negative candela"),
        (GOOD.replace("1 2 3", "1 NaN 3"), 7, "NaN", "finite"),
        (GOOD.replace("1 2 3", "1 x 3"), 7, "x", "expected a number"),
        (GOOD.replace("1 -1 1 3 2 1", "1 -1 1 3 2 7"), 3, "7", "photometric type"),
        (GOOD.replace("1 -1 1 3 2 1 2", "1 -1 1 3 2 1 5"), 3, "5", "units"),
        (GOOD.replace("1 -1 1 3 2", "1 -1 1 3.5 2"), 3, "3.5", "integer"),
        (GOOD.replace("1 -1 1 3", "1 -1 0 3"), 3, "0", "multiplier"),
    ],
)
def test_malformed_ies_names_file_line_and_token(text, line, token, message):
    with pytest.raises(PhotometryParseError, match=message) as info:
        ies.parse_ies(text, source="bad.ies")
    error = info.value
    assert error.source == "bad.ies"
    assert error.line == line
    assert error.token == token
    assert str(error).startswith(f"bad.ies, line {line}:")


def test_wrong_counts_leave_values_over_or_run_out():
    # one horizontal angle too many declared: the stream runs out
    with pytest.raises(PhotometryParseError, match="file ends early"):
        ies.parse_ies(GOOD.replace("1 -1 1 3 2", "1 -1 1 3 3"), source="bad.ies")
    # one too few: values remain after the table (a warning, and the rest is read wrongly)
    with pytest.warns(ies.PhotometryWarning, match="ignored"):
        ies.parse_ies(GOOD + "7 8 9\n")


def test_unknown_symmetry_is_an_error():
    text = GOOD.replace("0 90\n", "0 120\n")
    with pytest.raises(PhotometryParseError, match="no LM-63 symmetry") as info:
        ies.parse_ies(text, source="odd.ies")
    assert info.value.line == 6
    assert info.value.token == "0 .. 120"


def test_missing_tilt_line():
    with pytest.raises(PhotometryParseError, match="TILT="):
        ies.parse_ies("IESNA:LM-63-2002\n[TEST] x\n1 2 3\n", source="x.ies")


def test_external_tilt_file_is_refused():
    with pytest.raises(PhotometryParseError, match="separate tilt file") as info:
        ies.parse_ies(GOOD.replace("TILT=NONE", "TILT=lamp.tlt"), source="x.ies")
    assert info.value.line == 2


def test_decreasing_horizontal_angles():
    with pytest.raises(PhotometryParseError, match="horizontal angles must increase"):
        ies.parse_ies(GOOD.replace("0 90\n", "90 0\n"))


def test_empty_text():
    with pytest.raises(PhotometryParseError, match="empty"):
        ies.parse_ies("")


def test_missing_file_is_a_photometry_error(tmp_path):
    with pytest.raises(PhotometryError, match="cannot read"):
        ies.read_photometry(tmp_path / "nope.ies")


LDT_HEADER = (
    ["ACME", "1", "{isym}", "1", "0", "3", "45", "r", "n", "l", "f", "d"]
    + ["0"] * 9
    + ["100", "100", "1", "0", "1", "1", "LED", "1000", "3000", "80", "10"]
    + ["0.5"] * 10
    + ["0", "0", "45", "90"]
)


def _ldt(isym="1", values=("100", "50", "0")):
    return "\n".join([*LDT_HEADER[:2], isym, *LDT_HEADER[3:], *values]) + "\n"


def test_minimal_ldt_parses():
    with pytest.warns(ies.FluxMismatchWarning):  # 1000 lm lamp, LORL 100 %, tiny table
        photometry = ies.parse_ldt(_ldt(), source="m.ldt")
    assert float(photometry.intensity(0.0, 0.0)) == pytest.approx(100.0)


def test_ldt_bad_symmetry_indicator():
    with pytest.raises(PhotometryParseError, match="Isym") as info:
        ies.parse_ldt(_ldt(isym="7"), source="m.ldt")
    assert info.value.line == 3
    assert info.value.token == "7"


def test_ldt_negative_intensity_and_truncation():
    with pytest.raises(PhotometryParseError, match="negative") as info:
        ies.parse_ldt(_ldt(values=("100", "-5", "0")), source="m.ldt")
    assert info.value.token == "-5"
    with pytest.raises(PhotometryParseError, match="file ends early"):
        ies.parse_ldt(_ldt(values=("100",)), source="m.ldt")
    with pytest.raises(PhotometryParseError, match="file ends early"):
        ies.parse_ldt("ACME\n1\n1\n", source="m.ldt")


def test_degenerate_grid_is_refused():
    with pytest.raises(PhotometryError, match="degenerate"):
        ies.Photometry("C", [0.0], [0.0, 360.0], [[1.0], [1.0]])
    with pytest.raises(PhotometryError, match=">= 0"):
        ies.Photometry("C", [0.0, 90.0], [0.0, 360.0], [[1.0, -1.0], [1.0, 1.0]])
