"""``nightlights init``: a commented template that the project checks accept."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from click.testing import CliRunner

from nightlights.demo import example_path
from nightlights.io import read_vector
from nightlights.project import load_project
from nightlights_cli.main import cli


def test_init_writes_a_template_that_loads_once_its_input_exists(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, ["init"])
    assert result.exit_code == 0, result.output
    path = tmp_path / "nightlights.toml"
    text = path.read_text(encoding="utf-8")
    assert text.count("\n# ") > 20  # commented
    tables = tomllib.loads(text)
    assert tables["inputs"]["streets"] == "streets.gpkg"
    # the template's streets: the bundled extract's, as a GeoPackage
    read_vector(example_path()).to_file(tmp_path / "streets.gpkg")
    project = load_project(path)
    assert project.stages == [
        "normalize",
        "sample",
        "place",
        "irradiance",
        "emission",
        "skyglow",
    ]
    assert [o.name for o in project.observers] == ["site"]


def test_init_refuses_an_existing_file_without_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "city.toml"
    path.write_text("mine")
    result = CliRunner().invoke(cli, ["init", str(path)])
    assert result.exit_code == 1
    assert result.stderr == f"Error: {path}: exists; give --overwrite to replace it\n"
    assert path.read_text() == "mine"
    assert CliRunner().invoke(cli, ["init", str(path), "--overwrite"]).exit_code == 0
    assert path.read_text().startswith("# nightlights project")
