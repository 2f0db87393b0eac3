"""IES LM-63 and EULUMDAT readers: every real file parses, header variants, units, TILT."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ies
from ies.errors import FluxMismatchWarning, PhotometryWarning

from .conftest import ALL_FILES, data_file


@pytest.mark.parametrize("path", ALL_FILES, ids=lambda p: p.name)
def test_every_real_file_parses(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_photometry(path)
    assert photometry.candela.shape == (
        photometry.horizontal_angles.size,
        photometry.vertical_angles.size,
    )
    assert np.all(photometry.candela >= 0)
    assert photometry.luminous_flux() > 0
    if photometry.photometric_type == "C":
        assert photometry.horizontal_angles[0] == 0 and photometry.horizontal_angles[-1] == 360
    # the 360 row repeats the 0 row after unfolding (a measured 0-360 file keeps its own)
    if photometry.photometric_type == "C" and photometry.symmetry != "0-360":
        np.testing.assert_allclose(photometry.candela[0], photometry.candela[-1])


@pytest.mark.parametrize(
    ("name", "version"),
    [
        ("TX033306.ies", "1986"),  # no version line
        ("HellaEcoLight_2070lm_LDT.ies", "1991"),  # IESNA91
        ("imperial_units.ies", "1995"),
        ("test.ies", "2002"),
        ("filegen_accredited.ies", "2019"),  # IES:LM-63-2019
    ],
)
def test_version_from_first_line(name, version):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_ies(data_file(name))
    assert photometry.version == version
    assert photometry.format == f"IES LM-63-{version}"


def test_1986_labels_are_kept():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_ies(data_file("TX033306.ies"))
    assert "TRILUX" in photometry.keywords["LABEL"]
    # multiplier 6.85 turns the cd/klm table into absolute candela for a 6850 lm lamp
    assert photometry.candela_multiplier == pytest.approx(6.85)
    # first value of the file: H = 90, V = 0
    assert float(photometry.intensity(0.0, 90.0)) == pytest.approx(157.94 * 6.85)


def test_more_lines_continue_keywords():
    photometry = ies.read_ies(data_file("label_lines.ies"))
    assert photometry.keywords["MULTILINE"].count("\n") == 2


def test_tilt_in_keyword_value_is_not_the_tilt_line():
    # [LUMINAIRE] TILT=INCLUDE Test Fixture precedes the real TILT=INCLUDE line
    with pytest.warns(FluxMismatchWarning):  # synthetic: 1000 lm declared, ~3227 integrated
        photometry = ies.read_ies(data_file("TILT_TEST_SYNTHETIC.ies"))
    assert photometry.keywords["LUMINAIRE"] == "TILT=INCLUDE Test Fixture"
    assert photometry.tilt_angles == (0.0, 45.0, 90.0, 180.0)
    assert photometry.tilt_factors == (1.0, 0.9, 0.8, 1.0)


def test_tilt_table_scales_lamp_output():
    photometry = ies.read_ies(data_file("tilt_include_v19.ies"))
    assert photometry.tilt_factor(0.0) == 1.0
    tilted = photometry.with_tilt(30.0)  # table: 0.95 at 30 deg
    assert tilted.luminous_flux() == pytest.approx(0.95 * photometry.luminous_flux())
    assert photometry.with_tilt(22.5).tilt_factor(22.5) == pytest.approx(0.965)


def test_file_generation_type_is_not_a_multiplier():
    # filegen_accredited.ies: "1.0 1.10000 100" -> 1.1 is the LM-63-2019 file generation type
    photometry = ies.read_ies(data_file("filegen_accredited.ies"))
    assert photometry.keywords["_FILEGENTYPE"] == "1.1"
    assert photometry.candela.max() == pytest.approx(10000.0)


def test_ballast_lamp_factor_applies_up_to_1995():
    text = "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n0.9 0.5 10\n0 180\n0\n2 2\n"
    photometry = ies.parse_ies(text)
    assert photometry.candela.max() == pytest.approx(2 * 0.9 * 0.5)
    newer = ies.parse_ies(text.replace("1995", "2002"))
    assert newer.candela.max() == pytest.approx(2 * 0.9)


def test_absolute_photometry_has_no_declared_lumens():
    photometry = ies.read_ies(data_file("ITALO_1_5P5_S05_3.140-3M.IES"))
    assert photometry.declared_lumens is None
    assert photometry.is_absolute
    assert photometry.expected_flux() is None


def test_feet_are_converted_to_metres():
    photometry = ies.read_ies(data_file("imperial_units.ies"))
    assert photometry.keywords["_UNITS"] == "feet"
    assert photometry.luminous_opening == pytest.approx(
        (0.12 * 0.3048, 0.34 * 0.3048, 0.56 * 0.3048)
    )


def test_stream_tokenising_crlf_commas_wrapping_and_short_decimals():
    text = (
        "IESNA:LM-63-2002\r\n[LAMP] caf\xe9 TILT lamp\r\nTILT=NONE\r\n1,-1,1 3\r\n1 1 2 0 0"
        "\r\n0\r\n1.0 1 10 0 90\r\n180 0 .5 .5,\r\n.5\r\n"
    )
    photometry = ies.parse_ies(text)
    assert photometry.vertical_angles.tolist() == [0.0, 90.0, 180.0]
    assert photometry.candela.max() == 0.5
    assert photometry.keywords["LAMP"] == "caf\xe9 TILT lamp"


def test_latin1_bytes_are_decoded(tmp_path):
    text = (
        "IESNA:LM-63-2002\n[MANUFAC] Gr\xf6\xdfe\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 1\n"
        "0 180\n0\n1 1\n"
    )
    path = tmp_path / "latin.ies"
    path.write_bytes(text.encode("latin-1"))
    assert ies.read_ies(path).keywords["MANUFAC"] == "Gr\xf6\xdfe"


def test_integer_counts_written_as_floats():
    text = "IESNA:LM-63-2002\nTILT=NONE\n1.0 -1 1 2.0 1.0 1 2 0 0 0\n1 1 1\n0 180\n0\n1 1\n"
    assert ies.parse_ies(text).vertical_angles.size == 2


def test_descending_vertical_angles_are_reversed():
    text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 1\n180 90 0\n0\n0 1 2\n"
    photometry = ies.parse_ies(text)
    assert photometry.vertical_angles.tolist() == [0.0, 90.0, 180.0]
    assert float(photometry.intensity(0.0, 0.0)) == 2.0


@pytest.mark.parametrize(
    ("name", "symmetry"),
    [
        ("MTD0700312.ies", "rotational"),
        ("test.ies", "0-90"),
        ("LLIA001477-003.ies", "0-180"),
        ("TX033306.ies", "90-270"),
        ("HeadLight.ies", "0-360"),
        ("HellaEcoLight_2070lm_LDT.ies", "0-360 (360 missing)"),
        ("symmetry_about_vertical_axis.ldt", "rotational"),
        ("symmetry_to_c0c180.ldt", "0-180"),
        ("symmetry_to_c90c270.ldt", "90-270"),
        ("symmetry_to_c0c90c180c270.ldt", "0-90"),
        ("no_symmetry.ldt", "0-360 (360 missing)"),
    ],
)
def test_symmetry_is_recognised(name, symmetry):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        assert ies.read_photometry(data_file(name)).symmetry == symmetry


@pytest.mark.parametrize(
    ("name", "vertical_range"),
    [
        ("point_opening.ies", (0.0, 90.0)),
        ("HellaEcoLight_2070lm_LDT.ies", (0.0, 130.0)),
        ("OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies", (0.0, 180.0)),
        ("demo_two_lamp_sets.ldt", (0.0, 140.0)),
    ],
)
def test_vertical_ranges(name, vertical_range):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        photometry = ies.read_photometry(data_file(name))
    assert (photometry.vertical_angles[0], photometry.vertical_angles[-1]) == vertical_range
    # no light outside the measured range
    above = min(vertical_range[1] + 1.0, 180.0)
    if above > vertical_range[1]:
        assert float(photometry.intensity(above, 10.0)) == 0.0


def test_upper_hemisphere_only_file():
    text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 1\n90 180\n0\n1 1\n"
    photometry = ies.parse_ies(text)
    assert photometry.downward_flux() == 0.0
    assert photometry.upward_flux() == pytest.approx(2 * np.pi)


def test_type_a_and_b_read_in_their_own_frame():
    type_b = ies.read_ies(data_file("type_b_full.ies"))
    assert type_b.photometric_type == "B"
    assert type_b.horizontal_angles.tolist() == [-90, -67.5, -45, -22.5, 0, 22.5, 45, 67.5, 90]
    # row H=0 of the file peaks at V=0 with 25000 cd; mirrored H gives the same value
    assert float(type_b.intensity(0.0, 0.0)) == 25000.0
    assert float(type_b.intensity(-45.0, 22.5)) == float(type_b.intensity(-45.0, -22.5))
    assert float(type_b.intensity(0.0, 120.0)) == 0.0  # outside the measured frame
    type_a = ies.read_ies(data_file("type_a_symmetric.ies"))
    assert type_a.photometric_type == "A"
    assert float(type_a.intensity(0.0, 0.0)) == 15000.0
    with pytest.raises(ies.PhotometryError, match="type C"):
        type_a.bug_rating()


def test_eulumdat_header_and_lamp_sets():
    photometry = ies.read_ldt(data_file("demo_two_lamp_sets.ldt"))
    assert photometry.format == "EULUMDAT"
    assert photometry.keywords["symmetry_indicator"] == "3"
    assert photometry.keywords["lamp_sets"] == "2"
    assert "10080" in photometry.keywords["lamp_set_2"]
    # the first (standard) lamp set scales the cd/klm table
    assert photometry.declared_lumens == 9408.0
    assert photometry.declared_light_output_ratio == pytest.approx(0.78)


def test_eulumdat_negative_lamp_count_is_absolute():
    absolute = ies.read_ldt(data_file("absolute.ldt"))
    assert absolute.declared_lumens is None
    with pytest.warns(FluxMismatchWarning):
        relative = ies.read_ldt(data_file("relative.ldt"))
    assert relative.declared_lumens == 500.0
    np.testing.assert_allclose(absolute.candela, relative.candela)


def test_dispatch_by_content_for_unknown_suffix(tmp_path, ies_text):
    path = tmp_path / "lamp.txt"
    path.write_text(ies_text)
    assert ies.read_photometry(path).format == "IES LM-63-2002"
    ldt = tmp_path / "lamp.dat"
    ldt.write_bytes(data_file("relative.ldt").read_bytes())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        assert ies.read_photometry(ldt).format == "EULUMDAT"


def test_eulumdat_decimal_commas():
    text = data_file("relative.ldt").read_text()
    lines = text.splitlines()
    # write every decimal of the numeric tail with a comma, as some European tools do
    tail_start = 26 + 6 + 10
    lines[tail_start:] = [line.replace(".", ",") for line in lines[tail_start:]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)
        with_commas = ies.parse_ldt("\n".join(lines))
        reference = ies.read_ldt(data_file("relative.ldt"))
    np.testing.assert_allclose(with_commas.candela, reference.candela)


def test_byte_order_mark_is_ignored(ies_text):
    assert ies.parse_ies("\ufeff" + ies_text).version == "2002"
