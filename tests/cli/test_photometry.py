"""``nightlights photometry info``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nightlights_cli.main import cli

DATA = Path(__file__).resolve().parents[1] / "data" / "ies"
ROADWAY = DATA / "holg__eulumdat-rs" / "OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies"
HELLA = (
    DATA
    / "fglichttechnik__Radiance-RoadLighting-Simulation-Framework"
    / "HellaEcoLight_2070lm_LDT.ies"
)


def test_info_table():
    result = CliRunner().invoke(cli, ["photometry", "info", str(ROADWAY), "--street-azimuth", "0"])
    assert result.exit_code == 0, result.output
    assert "IES LM-63-1995" in result.output
    assert "9,155.5 lm" in result.output
    assert "B2 U2 G2" in result.output


def test_info_json_and_warnings():
    result = CliRunner().invoke(cli, ["photometry", "info", str(HELLA), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["format"] == "IES LM-63-1991"
    assert summary["symmetry"] == "0-360 (360 missing)"
    assert summary["integrated_flux"] == pytest.approx(2075, rel=0.005)
    assert summary["declared_lumens"] == 1000.0
    assert len(summary["warnings"]) == 1
    assert summary["bug_rating"].startswith("B")


def test_info_plot(tmp_path):
    png = tmp_path / "lobe.png"
    result = CliRunner().invoke(
        cli, ["photometry", "info", str(ROADWAY), "--plot", str(png), "--street-azimuth", "0"]
    )
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_file_gives_one_line_error(tmp_path):
    bad = tmp_path / "bad.ies"
    bad.write_text("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 1\n0 180\n0\n1 -1\n")
    result = CliRunner().invoke(cli, ["photometry", "info", str(bad)])
    assert result.exit_code == 1
    assert "PhotometryParseError" in result.output
    assert "line 7" in result.output and "'-1'" in result.output
    assert "Traceback" not in result.output


def test_info_plot_refuses_an_existing_file(tmp_path):
    png = tmp_path / "lobe.png"
    png.write_bytes(b"keep")
    args = ["photometry", "info", str(ROADWAY), "--plot", str(png)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1
    assert result.output == f"Error: {png}: exists; give --overwrite to replace it\n"
    assert png.read_bytes() == b"keep"
    result = CliRunner().invoke(cli, [*args, "--overwrite"])
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
