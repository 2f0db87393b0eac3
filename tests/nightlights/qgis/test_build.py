"""The plugin zip: its files, metadata, recorded command and description of the stages; what the
plugin may import. (The description, read from the commands: tests/cli/test_qgis_plugin.py.)"""

from __future__ import annotations

import ast
import json
import os
import shutil
import sys
import zipfile
from importlib import resources
from pathlib import Path
from typing import Any

import pytest

from nightlights import __version__
from nightlights.errors import InputError, OutputError
from nightlights.qgis import PLUGIN_FILES, PLUGIN_FOLDER, build_plugin, toolkit_command
from nightlights.qgis.plugin.stages import STAGES_FILE, read_stages

PLUGIN_SOURCE = Path(str(resources.files("nightlights.qgis.plugin")))
#: What the plugin's modules may import in QGIS's Python: the standard library, QGIS, its
#: Processing plugin and GDAL's bindings (QGIS's own), and the plugin's own modules.
ALLOWED_ROOTS = {"qgis", "processing", "osgeo"}
#: A description of one stage, as ``nightlights qgis-plugin build`` writes them.
STAGES = [
    {
        "id": "darkness",
        "command": ["darkness"],
        "title": "Zenith darkness map",
        "group": "Sky",
        "help": "Zenith sky brightness (nightlights darkness)",
        "overwrite": True,
        "parameters": [
            {"name": "EMISSION", "flag": None, "type": "raster", "output": False},
            {"name": "OUTPUT", "flag": None, "type": "raster", "output": True},
        ],
    }
]


def test_the_zip_holds_the_plugin_folder(tmp_path: Path) -> None:
    path = build_plugin(tmp_path / "plugin.zip", STAGES)
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
        metadata = archive.read(f"{PLUGIN_FOLDER}/metadata.txt").decode()
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
        sources = {name: archive.read(f"{PLUGIN_FOLDER}/{name}").decode() for name in PLUGIN_FILES}
        archive.extractall(tmp_path)
    written = {*PLUGIN_FILES, "toolkit.json", STAGES_FILE}
    assert names == {f"{PLUGIN_FOLDER}/{name}" for name in written}
    # the plugin reads back the description it was built with
    assert read_stages(tmp_path / PLUGIN_FOLDER) == STAGES
    assert f"version={__version__}" in metadata.splitlines()
    assert "hasProcessingProvider=yes" in metadata.splitlines()
    assert "def classFactory(iface" in sources["__init__.py"]
    assert record == {"command": str(toolkit_command().absolute()), "version": __version__}
    for name in PLUGIN_FILES:
        if name != "metadata.txt":
            assert sources[name] == (PLUGIN_SOURCE / name).read_text(encoding="utf-8")


def test_every_plugin_module_is_zipped() -> None:
    modules = {path.name for path in PLUGIN_SOURCE.glob("*.py")}
    assert modules <= set(PLUGIN_FILES)


def test_the_recorded_command_is_this_environments(tmp_path: Path) -> None:
    command = toolkit_command()
    assert command.is_file()
    assert command.name.startswith("nightlights")
    assert command.parent == Path(sys.executable).parent or command.parent.name in {
        "bin",
        "Scripts",
    }


def test_a_given_command_is_recorded(tmp_path: Path) -> None:
    executable = tmp_path / "nightlights"
    executable.write_text("#!/bin/sh\n")
    executable.chmod(0o755)
    with zipfile.ZipFile(build_plugin(tmp_path / "p.zip", STAGES, command=executable)) as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
    assert record["command"] == str(executable)


def test_a_missing_command_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="is not a file"):
        build_plugin(tmp_path / "p.zip", STAGES, command=tmp_path / "missing")
    assert not (tmp_path / "p.zip").exists()


def test_an_existing_zip_is_kept_without_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "p.zip"
    path.write_bytes(b"previous")
    with pytest.raises(OutputError, match="exists"):
        build_plugin(path, STAGES)
    assert path.read_bytes() == b"previous"
    build_plugin(path, STAGES, overwrite=True)
    assert zipfile.is_zipfile(path)


@pytest.mark.parametrize("name", [name for name in PLUGIN_FILES if name.endswith(".py")])
def test_the_plugin_imports_no_toolkit_library(name: str) -> None:
    """QGIS's Python must not load the toolkit or its wheels (another GDAL): the plugin's
    modules import only the standard library, QGIS and each other."""
    tree = ast.parse((PLUGIN_SOURCE / name).read_text(encoding="utf-8"))
    roots = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level:
            roots.add((node.module or "").split(".")[0])
    foreign = roots - ALLOWED_ROOTS - set(sys.stdlib_module_names) - {"__future__"}
    assert foreign == set()


@pytest.mark.skipif(os.name != "posix", reason="execute permissions")
@pytest.mark.parametrize(
    ("given", "expected"),
    [
        ("relative", lambda tmp: str(tmp / "nl")),
        ("name on PATH", lambda tmp: shutil.which("sh")),
        ("not executable", "is not executable"),
    ],
)
def test_the_command_is_recorded_absolute_and_executable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, given: str, expected: Any
) -> None:
    monkeypatch.chdir(tmp_path)
    script = tmp_path / "nl"
    script.write_text("#!/bin/sh\n")
    script.chmod(0o644 if given == "not executable" else 0o755)
    command = "sh" if given == "name on PATH" else "nl"
    if isinstance(expected, str):
        with pytest.raises(InputError, match=expected):
            build_plugin(tmp_path / "p.zip", STAGES, command=command)
        assert not (tmp_path / "p.zip").exists()
        return
    with zipfile.ZipFile(build_plugin(tmp_path / "p.zip", STAGES, command=command)) as archive:
        record = json.loads(archive.read(f"{PLUGIN_FOLDER}/toolkit.json"))
    assert record["command"] == expected(tmp_path)
