"""``nightlights run``: a project file end to end, its cache, --check, --force, bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from nightlights_cli.main import cli

PROJECT = """\
[project]
output = "out"

[inputs]
emission = "emission.tif"

[observers]
points = { centre = [385500.0, 6671500.0] }

[kernel]
r-max = 3000.0
n-distance = 8
n-elevation = 8
n-azimuth = 16
uplight = false

[stages.skyglow]
png = false
"""


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(tmp_path / "cache"))
    data = np.zeros((20, 20), dtype="float32")
    data[8:12, 8:12] = 5.0
    with rasterio.open(
        tmp_path / "emission.tif",
        "w",
        driver="GTiff",
        width=20,
        height=20,
        count=1,
        dtype="float32",
        crs="EPSG:3067",
        transform=from_origin(385000.0, 6672000.0, 50.0, 50.0),
    ) as dst:
        dst.write(data, 1)
    path = tmp_path / "project.toml"
    path.write_text(PROJECT, encoding="utf-8")
    return path


def test_run_then_up_to_date(project: Path) -> None:
    runner = CliRunner()
    first = runner.invoke(cli, ["run", str(project)])
    assert first.exit_code == 0, first.output
    assert "skyglow:centre: " in first.stderr
    assert "zenith sky at centre:" in first.stderr
    assert (project.parent / "out" / "skyglow_centre.nc").is_file()
    second = runner.invoke(cli, ["run", str(project)])
    assert second.exit_code == 0, second.output
    assert "skyglow:centre: up to date" in second.stderr
    assert "ran 0, up to date 1" in second.stderr
    check = runner.invoke(cli, ["run", str(project), "--check"])
    assert check.exit_code == 0
    assert "up to date  skyglow:centre" in check.stderr
    assert f"{project}: valid; 0 of 1 stages would run" in check.stderr
    forced = runner.invoke(cli, ["run", str(project), "--force", "skyglow"])
    assert "ran 1, up to date 0" in forced.stderr


def test_run_into_another_folder(project: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["run", str(project), "-o", str(tmp_path / "other")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "other" / "skyglow_centre.nc").is_file()


def test_a_bad_project_is_one_line_and_runs_nothing(project: Path) -> None:
    project.write_text(PROJECT.replace("png = false", 'png = false\nmode = "fast"'))
    result = CliRunner().invoke(cli, ["run", str(project)])
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: ProjectError: {project}: stages.skyglow.mode = 'fast': not allowed; "
        "allowed: 'pca', 'exact', 'naive'\n"
    )
    assert not (project.parent / "out").exists()


def test_force_of_a_stage_the_project_lacks(project: Path) -> None:
    result = CliRunner().invoke(cli, ["run", str(project), "--force", "darkness"])
    assert result.exit_code == 1
    assert "force 'darkness': not a stage of" in result.stderr
    assert "allowed: skyglow" in result.stderr
    assert not (project.parent / "out").exists()


def test_a_missing_project_file(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["run", str(tmp_path / "none.toml")])
    assert result.exit_code == 1
    assert result.stderr == f"Error: ProjectError: {tmp_path / 'none.toml'}: no such project file\n"


def test_the_help_lists_the_library_stages() -> None:
    from nightlights.project import STAGES

    help_text = CliRunner().invoke(cli, ["run", "--help"], terminal_width=1000).output
    listed = " ".join(help_text.split("Stages: ", 1)[1].split(".", 1)[0].split())
    assert listed == ", ".join(STAGES)
