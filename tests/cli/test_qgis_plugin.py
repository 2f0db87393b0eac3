"""``nightlights qgis-plugin build``: the plugin zip, its default name, --overwrite, --command;
the description of the stage commands it carries, which covers every command and every option
(each parameter's value makes a command line that the command parses back to that value); and
the plugin reading what a command prints."""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import click
import pytest
from click.testing import CliRunner, Result

from nightlights.qgis import PLUGIN_FOLDER, toolkit_command
from nightlights.qgis.plugin.messages import parse_zenith
from nightlights.qgis.plugin.stages import STAGES_FILE, command_line
from nightlights_cli import qgis
from nightlights_cli.describe import NOT_STAGES, TOOLBOX, describe_stages, leaf_commands
from nightlights_cli.main import cli


def _build(*args: str) -> Result:
    return CliRunner().invoke(cli, ["qgis-plugin", "build", *args])


def test_build_writes_the_default_zip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = _build()
    assert result.exit_code == 0, result.output
    path = tmp_path / qgis.plugin_zip()
    assert path.name == f"{PLUGIN_FOLDER}.zip"
    with zipfile.ZipFile(path) as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
        stages = json.loads(archive.read(f"{PLUGIN_FOLDER}/{STAGES_FILE}"))["stages"]
    assert record["command"] == str(toolkit_command().absolute())
    assert stages == describe_stages(cli)
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


# --- the description of the stages ------------------------------------------------------------

#: The algorithm ids of the stages (those of earlier versions unchanged: models name them).
STAGE_IDS = {
    "streetsnormalize",
    "streetssample",
    "streetsplace",
    "streetsaudit",
    "streetsplan",
    "irradiance",
    "emission",
    "emissionviirs",
    "obstacles",
    "skyglow",
    "validate",
    "inverseq",
    "darkness",
    "inverses",
    "inversedim",
    "inverseplan",
    "kernelbuild",
    "skyrender",
    "skyobservers",
    "run",
}
#: Options a parameter stands for (the last positional path, --overwrite always given).
FOLDED = {"output"}


def test_every_command_is_a_stage_or_says_why_not() -> None:
    """A new command fails here until it is a stage (TOOLBOX) or listed in NOT_STAGES."""
    commands = {name for name, _ in leaf_commands(cli)}
    assert set(TOOLBOX) | set(NOT_STAGES) == commands
    assert not set(TOOLBOX) & set(NOT_STAGES)
    stages = describe_stages(cli)
    assert {stage["id"] for stage in stages} == STAGE_IDS
    assert len(stages) == len(STAGE_IDS)
    emission = next(stage for stage in stages if stage["id"] == "emission")
    assert emission["command"] == ["emission", "ground"]  # the group's default command


def _command(words: list[str]) -> click.Command:
    command: click.Command = cli
    for word in words:
        assert isinstance(command, click.Group)
        command = command.commands[word]
    return command


def _number(parameter: dict[str, Any]) -> float:
    """A value of a number parameter other than its default, within its range."""
    low, high, default = parameter["min"], parameter["max"], parameter["default"]
    if low is not None and high is not None:
        return (low + high) / 2
    return (default if default is not None else (low or 0)) + 1.5


def _sample(parameter: dict[str, Any], folder: Path) -> tuple[Any, Any]:
    """A value of ``parameter`` other than its default, and the value the command parses."""
    kind, default = parameter["type"], parameter["default"]
    many = parameter["multiple"]
    if kind in ("raster", "vector", "file", "folder"):
        extension = (parameter.get("extensions") or ["tif"])[0]
        path = folder / f"{parameter['name'].lower()}.{extension}"
        if not parameter["output"] and parameter["flag"] is not None:  # checked by click
            path.mkdir() if kind == "folder" else path.touch()
        return str(path), str(path)
    if kind == "boolean":
        return not default, not default
    if kind == "enum":
        choices = parameter["choices"]
        if many:
            picked = choices[:2] if choices[:2] != default else choices[1:3]
            return picked, tuple(picked)
        picked = choices[-1] if choices[-1] != default else choices[0]
        return picked, picked
    if kind == "crs":
        return "EPSG:3067", "EPSG:3067"
    if kind == "point":
        crs = "EPSG:3067" if parameter.get("crs_flag") else None
        points = [(1.5, 2.5, crs), (3.5, 4.5, crs)]
        if many:
            return points, ("1.5,2.5", "3.5,4.5")
        return points[0], "1.5,2.5"
    if kind in ("integer", "float"):
        number = _number(parameter)
        if kind == "integer":
            number = int(number)
        if many:
            return [str(number), str(number + 1)], (number, number + 1)
        return number, number
    if many:
        return ["zenith:30:21.5", "horizon:0,90,10:20"], ("zenith:30:21.5", "horizon:0,90,10:20")
    if parameter["flag"] == "--scheduler":  # an address is parsed by the option itself
        return "tcp://127.0.0.1:8786", "tcp://127.0.0.1:8786"
    if parameter["flag"] == "--max-memory":  # a size, parsed to bytes
        return "2G", 2 * 1024**3
    return "text", "text"


@pytest.mark.parametrize("stage", describe_stages(cli), ids=lambda stage: stage["id"])
def test_each_parameter_reaches_its_option(stage: dict[str, Any], tmp_path: Path) -> None:
    """Every visible option of the command is a parameter (or given by one: a vector input's
    layer, a point's CRS, --overwrite): a value other than the default of each makes a command
    line that the command parses back to those values."""
    values: dict[str, Any] = {}
    expected: dict[str, Any] = {}
    paths = []
    for parameter in stage["parameters"]:
        value, parsed = _sample(parameter, tmp_path)
        if parameter["flag"] is None:
            paths.append(parsed)
            if parameter.get("layer_flag"):
                value = (value, "layer_of_" + parameter["name"].lower())
                expected[parameter["layer_flag"]] = value[1]
        else:
            expected[parameter["flag"]] = parsed
            if parameter["type"] == "point" and parameter.get("crs_flag"):
                expected[parameter["crs_flag"]] = "EPSG:3067"
        values[parameter["name"]] = value
    line = command_line(stage, values)
    assert line[: len(stage["command"])] == stage["command"]
    command = _command(stage["command"])
    ctx = command.make_context(stage["command"][-1], line[len(stage["command"]) :])
    if stage["overwrite"]:
        expected["--overwrite"] = True
    flags = {param.opts[-1]: param for param in command.params if isinstance(param, click.Option)}
    assert ctx.params["files"] == tuple(paths)
    for flag, value in expected.items():
        if flags[flag].expose_value:
            assert ctx.params[flags[flag].name] == value, flag
    if "--max-memory" in expected:  # its callback set the limit: the command's own, while it runs
        from nightlights import _resources

        assert _resources.memory_limit() == expected["--max-memory"]
    ctx.close()  # puts the memory limit back
    visible = {
        flag for flag, param in flags.items() if not param.hidden and param.name not in FOLDED
    }
    assert set(expected) == visible


@pytest.mark.parametrize("stage", describe_stages(cli), ids=lambda stage: stage["id"])
def test_values_at_their_defaults_are_left_out(stage: dict[str, Any], tmp_path: Path) -> None:
    """The command line names the options the user changed (and the required ones), no
    others."""
    values = {parameter["name"]: parameter["default"] for parameter in stage["parameters"]}
    required = [parameter for parameter in stage["parameters"] if parameter["required"]]
    for parameter in required:
        values[parameter["name"]] = _sample(parameter, tmp_path)[0]
    given = [part for part in command_line(stage, values) if part.startswith("--")]
    flags = [parameter["flag"] for parameter in required if parameter["flag"] is not None]
    flags += [parameter["crs_flag"] for parameter in required if parameter.get("crs_flag")]
    flags += ["--overwrite"] if stage["overwrite"] else []
    assert sorted(given) == sorted(flags)


def test_the_description_names_what_each_path_is() -> None:
    """Inputs and outputs of the sky stages, as the plugin offers them."""
    stages = {stage["id"]: stage for stage in describe_stages(cli)}
    kinds = {
        stage_id: [
            (p["name"], p["type"], p.get("output"))
            for p in stage["parameters"]
            if p["type"] in ("raster", "vector", "file", "folder")
        ]
        for stage_id, stage in stages.items()
    }
    assert kinds["skyobservers"][:3] == [
        ("EMISSION", "raster", False),
        ("OBSERVERS", "vector", False),
        ("SUMMARY", "vector", True),
    ]
    assert ("KERNEL", "file", False) in kinds["inverses"]
    assert kinds["kernelbuild"] == [("OUTPUT", "file", True)]
    observer = next(p for p in stages["inverses"]["parameters"] if p["name"] == "OBSERVER")
    assert (observer["type"], observer["crs_flag"], observer["required"]) == (
        "point",
        "--observer-crs",
        True,
    )
    normalize = stages["streetsnormalize"]["parameters"]
    assert normalize[0]["layer_flag"] == "--layer"
    assert "LAYER" not in {p["name"] for p in normalize}
    network = next(p for p in stages["streetssample"]["parameters"] if p["name"] == "NETWORK")
    assert network["type"] == "enum" and "europe" in network["choices"]
    assert not any(
        p["name"].startswith("OLD_") or p["flag"] in ("--workers", "--layer")
        for stage in stages.values()
        for p in stage["parameters"]
    )


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
