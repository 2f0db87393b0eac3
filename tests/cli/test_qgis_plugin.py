"""``nightlights qgis-plugin build``: the plugin zip, its default name, --overwrite, --command;
and the plugin reading what a command prints."""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from click.testing import CliRunner, Result

from nightlights.qgis import PLUGIN_FOLDER, toolkit_command
from nightlights.qgis.plugin.messages import parse_zenith
from nightlights_cli import qgis
from nightlights_cli.main import cli


def _build(*args: str) -> Result:
    return CliRunner().invoke(qgis.qgis_plugin, ["build", *args])


def test_build_writes_the_default_zip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = _build()
    assert result.exit_code == 0, result.output
    path = tmp_path / qgis.plugin_zip()
    assert path.name == f"{PLUGIN_FOLDER}.zip"
    with zipfile.ZipFile(path) as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
    assert record["command"] == str(toolkit_command().absolute())
    assert f"-> {qgis.plugin_zip()}" in result.output
    assert "Install from ZIP" in result.output


def test_build_refuses_an_existing_zip_without_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "plugin.zip"
    path.write_bytes(b"previous")
    result = _build("-o", str(path))
    assert result.exit_code == 1
    assert "exists; give --overwrite" in result.output
    assert path.read_bytes() == b"previous"
    result = _build(str(path), "--overwrite")
    assert result.exit_code == 0, result.output
    assert zipfile.is_zipfile(path)


@pytest.mark.skipif(os.name != "posix", reason="a shell script as the command")
def test_build_records_a_given_command(tmp_path: Path) -> None:
    command = tmp_path / "nightlights"
    command.write_text("#!/bin/sh\n")
    command.chmod(0o755)
    result = _build(str(tmp_path / "p.zip"), "--command", str(command))
    assert result.exit_code == 0, result.output
    with zipfile.ZipFile(tmp_path / "p.zip") as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
    assert record["command"] == str(command)
    assert f"runs {command}" in result.output


def test_a_missing_command_is_a_usage_error(tmp_path: Path) -> None:
    result = _build(str(tmp_path / "p.zip"), "--command", str(tmp_path / "missing"))
    assert result.exit_code == 2
    assert not (tmp_path / "p.zip").exists()


def test_the_module_exposes_its_group() -> None:
    assert [command.name for command in qgis.commands] == ["qgis-plugin"]


def test_the_plugin_reads_the_zenith_line_skyglow_prints(
    fake_stage: Callable[[str, Any], Any], tmp_path: Path
) -> None:
    """The skyglow algorithm's outputs come from the command's own line, as printed."""
    result = SimpleNamespace(
        zenith_luminance=3.97e-3, zenith_magnitude=18.59, bortle=7, seconds=0.0094
    )
    fake_stage("skyglow", result)
    emission = tmp_path / "emission.tif"
    emission.touch()
    args = ["skyglow", str(emission), str(tmp_path / "sky.nc"), "--observer", "385900,6671800"]
    printed = CliRunner().invoke(cli, args)
    assert printed.exit_code == 0, printed.output
    assert parse_zenith(printed.output.splitlines()) == {
        "ZENITH_LUMINANCE": 3.97e-3,
        "ZENITH_MAGNITUDE": 18.59,
        "BORTLE": 7,
    }


#: (what --command names, relative to the working folder; its mode or None for a folder; exit
#: status; words of the message): only an executable file is recorded, by its absolute path.
COMMANDS = [
    ("notes.txt", 0o644, 1, ["notes.txt", "is not executable"]),
    ("tools", None, 2, ["is a directory"]),
    ("bin/nightlights", 0o755, 0, []),
]


@pytest.mark.skipif(os.name != "posix", reason="execute permissions")
@pytest.mark.parametrize(("given", "mode", "code", "words"), COMMANDS, ids=[c[0] for c in COMMANDS])
def test_the_recorded_command_is_an_absolute_executable(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    given: str,
    mode: int | None,
    code: int,
    words: list[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / given
    path.parent.mkdir(exist_ok=True)
    if mode is None:
        path.mkdir()
    else:
        path.write_text("#!/bin/sh\n")
        path.chmod(mode)
    result = CliRunner().invoke(cli, ["qgis-plugin", "build", "p.zip", "--command", given])
    assert result.exit_code == code, result.output
    for word in words:
        assert word in result.output, result.output
    if code:
        assert not (tmp_path / "p.zip").exists()
        return
    with zipfile.ZipFile(tmp_path / "p.zip") as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
    assert record["command"] == str(path) and Path(record["command"]).is_absolute()
    assert f"runs {path}" in result.output
