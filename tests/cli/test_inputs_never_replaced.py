"""No command writes over one of its inputs, table-driven over every command and input.

An output that is an input (a positional input or the file of any option: ``--dem``,
``--kernel``, ``--by``, ``--mapping``...), by the same path, a relative one, a symbolic or a
hard link, or that would replace a file in an input folder (``--catalog``, ``--network``) or
a folder holding an input, is refused before any work, with or without ``--overwrite``: one
``Error: OutputError:`` line naming the output and the input, exit status 1, every input as
it was.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import click
import pytest
from click.testing import CliRunner

from nightlights._resources import set_memory_limit
from nightlights_cli._messages import walk
from nightlights_cli.main import cli
from nightlights_cli.options import OUTPUT_PARAMETERS

OBSERVER = ["--observer", "501500,6698500"]
TIME = ["--time", "2024-01-15T22:00:00+00:00"]


@pytest.fixture
def inputs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> SimpleNamespace:
    """One file per kind of input (their content does not matter: nothing reads them before
    the check), a network, a catalogue and a folder that holds a street layer; the current
    folder is ``tmp_path``."""
    monkeypatch.chdir(tmp_path)
    names = {
        "emission": "e.tif",
        "kernel": "k.nc",
        "dem": "dem.tif",
        "q": "q.tif",
        "lights": "lights.gpkg",
        "streets": "streets.gpkg",
        "lamps": "lamps.gpkg",
        "irradiance": "irr.tif",
        "albedo": "albedo.tif",
        "area": "area.gpkg",
        "viirs": "viirs.tif",
        "mapping": "mapping.toml",
        "panorama": "panorama.nc",
        "observers": "observers.gpkg",
        "project": "project.toml",
        "photometry": "lamp.ies",
        "command": "nightlights-bin",
        "max_dimming": "cap.tif",
    }
    found = {key: tmp_path / name for key, name in names.items()}
    for key, path in found.items():
        path.write_bytes(f"input {key}".encode())
    for folder, file in (("network", "street_class.csv"), ("catalog", "systems.csv")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / file).write_text(f"{folder} table")
        found[folder] = tmp_path / folder
    (tmp_path / "holder").mkdir()
    found["held"] = tmp_path / "holder" / "streets.gpkg"
    found["held"].write_text("held streets")
    return SimpleNamespace(**found)


def contents(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (links as their target's content) and its bytes."""
    return {
        str(path.relative_to(folder)): path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


@dataclass(frozen=True)
class Case:
    """A command line whose output is an input: ``args(inputs)``, the output as written, the
    input's label (flag or argument) and how it is at risk."""

    args: Callable[[SimpleNamespace], list]
    output: Callable[[SimpleNamespace], Path]
    label: str
    risk: str = "is the input"
    overwrite: bool = True  # the command has --overwrite


def _case(
    command: list[str], output: str, label: str, extra: list | None = None, **kwargs: object
) -> Case:
    """``command`` with ``{name}`` placeholders for the inputs; ``output`` is the output as
    written: an input's name, or a path relative to the inputs' folder."""

    def args(i: SimpleNamespace) -> list:
        words = [*command, *(extra or [])]
        return [getattr(i, w[1:-1]) if w.startswith("{") else w for w in words]

    def out(i: SimpleNamespace) -> Path:
        return getattr(i, output) if hasattr(i, output) else Path(output)

    return Case(args, out, label, **kwargs)  # type: ignore[arg-type]


CASES: dict[str, Case] = {
    "streets normalize INPUT": _case(
        ["streets", "normalize", "{streets}", "{streets}"], "streets", "INPUT"
    ),
    "streets normalize --mapping": _case(
        ["streets", "normalize", "{streets}", "{mapping}", "--mapping", "{mapping}"],
        "mapping",
        "--mapping",
    ),
    "streets sample INPUT": _case(
        ["streets", "sample", "{streets}", "{streets}"], "streets", "INPUT"
    ),
    "streets sample --network folder": _case(
        ["streets", "sample", "{streets}", "network/street_class.csv", "--network", "{network}"],
        "network/street_class.csv",
        "--network",
        risk="lies in the input folder",
    ),
    "streets fit INPUT": _case(
        ["streets", "fit", "{streets}", "{streets}"], "streets", "INPUT", overwrite=False
    ),
    "streets fit --network": _case(
        ["streets", "fit", "{streets}", "{network}", "--network", "{network}"],
        "network",
        "--network",
        overwrite=False,
    ),
    "streets learn --network": _case(
        ["streets", "learn", "{streets}", "{lamps}", "{network}", "--network", "{network}"],
        "network",
        "--network",
    ),
    "streets learn STREETS inside OUT_DIR": _case(
        ["streets", "learn", "{held}", "{lamps}", "holder"],
        "holder",
        "STREETS",
        risk="holds the input",
    ),
    "streets learn LAMPS": _case(
        ["streets", "learn", "{streets}", "{lamps}", "{lamps}"], "lamps", "LAMPS"
    ),
    "streets place INPUT": _case(
        ["streets", "place", "{streets}", "{streets}"], "streets", "INPUT"
    ),
    "streets place --catalog": _case(
        ["streets", "place", "{streets}", "catalog/systems.csv", "--catalog", "{catalog}"],
        "catalog/systems.csv",
        "--catalog",
        risk="lies in the input folder",
    ),
    "irradiance LIGHTS": _case(
        ["irradiance", "{lights}", "{lights}", "--resolution", "4"], "lights", "LIGHTS"
    ),
    "irradiance --dem": _case(
        ["irradiance", "{lights}", "{dem}", "--resolution", "4", "--dem", "{dem}"], "dem", "--dem"
    ),
    "irradiance --area-sources": _case(
        ["irradiance", "{lights}", "{area}", "--resolution", "4", "--area-sources", "{area}"],
        "area",
        "--area-sources",
    ),
    **{
        f"emission ground {label}": _case(
            ["emission", "ground", "{irradiance}", "{lights}", f"{{{key}}}", "--resolution", "8"],
            key,
            label,
            extra=["--albedo", "{albedo}"],
        )
        for key, label in (
            ("irradiance", "IRRADIANCE"),
            ("lights", "LIGHTS"),
            ("albedo", "--albedo"),
        )
    },
    "emission viirs INPUT": _case(["emission", "viirs", "{viirs}", "{viirs}"], "viirs", "INPUT"),
    **{
        f"{command} {label}": _case(
            [*command.split(), "{emission}", f"{{{key}}}", *extra],
            key,
            label,
            extra=["--kernel", "{kernel}", "--dem", "{dem}"],
        )
        for command, extra in (
            ("skyglow", OBSERVER),
            ("inverse q", OBSERVER),
            ("inverse s", [*OBSERVER, "--region", "zenith:30"]),
            ("inverse dim", ["--by", "{q}", "--qa", "0", "--qb", "1"]),
            (
                "inverse plan",
                [*OBSERVER, "--target-zenith", "22", "--max-dimming", "{max_dimming}"],
            ),
            ("darkness", []),
        )
        for key, label in (("emission", "EMISSION"), ("kernel", "--kernel"), ("dem", "--dem"))
    },
    "skyglow --png": _case(
        ["skyglow", "{emission}", "p.nc", *OBSERVER, "--png", "{emission}"], "emission", "EMISSION"
    ),
    "skyglow --polar-output": _case(
        ["skyglow", "{emission}", "p.nc", *OBSERVER, "--polar-output", "{kernel}"],
        "kernel",
        "--kernel",
        extra=["--kernel", "{kernel}"],
    ),
    "inverse dim --by": _case(
        ["inverse", "dim", "{emission}", "{q}", "--by", "{q}", "--qa", "0", "--qb", "1"],
        "q",
        "--by",
    ),
    "inverse dim --dimming-output": _case(
        ["inverse", "dim", "{emission}", "r.tif", "--by", "{q}", "--qa", "0", "--qb", "1"],
        "emission",
        "EMISSION",
        extra=["--dimming-output", "{emission}"],
    ),
    "inverse dim --summary-output": _case(
        ["inverse", "dim", "{emission}", "r.tif", "--by", "{q}", "--qa", "0", "--qb", "1"],
        "q",
        "--by",
        extra=["--summary-output", "{q}"],
    ),
    "inverse dim --png": _case(
        ["inverse", "dim", "{emission}", "r.tif", "--by", "{q}", "--qa", "0", "--qb", "1"],
        "q",
        "--by",
        extra=["--png", "{q}"],
    ),
    "inverse plan --max-dimming": _case(
        ["inverse", "plan", "{emission}", "{max_dimming}", *OBSERVER, "--target-zenith", "22"],
        "max_dimming",
        "--max-dimming",
        extra=["--max-dimming", "{max_dimming}"],
    ),
    "inverse plan --dimming-output": _case(
        ["inverse", "plan", "{emission}", "r.tif", *OBSERVER, "--target-zenith", "22"],
        "max_dimming",
        "--max-dimming",
        extra=["--max-dimming", "{max_dimming}", "--dimming-output", "{max_dimming}"],
    ),
    **{
        f"sky observers {label}": _case(
            ["sky", "observers", "{emission}", "{observers}", f"{{{key}}}"],
            key,
            label,
            extra=["--kernel", "{kernel}", "--dem", "{dem}"],
        )
        for key, label in (
            ("emission", "EMISSION"),
            ("observers", "OBSERVERS"),
            ("kernel", "--kernel"),
            ("dem", "--dem"),
        )
    },
    "sky render --panorama": _case(
        ["sky", "render", "{panorama}", "--panorama", "{panorama}", *TIME],
        "panorama",
        "--panorama",
    ),
    "photometry info --plot": _case(
        ["photometry", "info", "{photometry}", "--plot", "{photometry}"], "photometry", "FILE"
    ),
    "run PROJECT.toml": _case(
        ["run", "{project}", "{project}"], "project", "PROJECT.toml", overwrite=False
    ),
    "qgis-plugin build --command": _case(
        ["qgis-plugin", "build", "{command}", "--command", "{command}"], "command", "--command"
    ),
}


def _invoke(args: list) -> object:
    result = CliRunner().invoke(cli, [str(a) for a in args])
    set_memory_limit(None)
    return result


def _assert_refused(result: object, output: Path, label: str, risk: str) -> None:
    assert result.exit_code == 1, result.output  # type: ignore[attr-defined]
    lines = result.output.splitlines()  # type: ignore[attr-defined]
    errors = [line for line in lines if line.startswith("Error:")]
    assert len(errors) == 1, result.output  # type: ignore[attr-defined]
    assert "Traceback" not in result.output  # type: ignore[attr-defined]
    error = errors[0]
    assert error.startswith(f"Error: OutputError: {output}: {risk} {label} ("), error
    assert "an output never replaces an input" in error, error


@pytest.mark.parametrize("overwrite", [True, False], ids=["overwrite", "no-overwrite"])
@pytest.mark.parametrize("name", list(CASES))
def test_an_output_that_is_an_input_is_refused(inputs, name: str, overwrite: bool) -> None:
    case = CASES[name]
    if overwrite and not case.overwrite:
        pytest.skip("the command has no --overwrite")
    before = contents(Path.cwd())
    result = _invoke([*case.args(inputs), *(["--overwrite"] if overwrite else [])])
    _assert_refused(result, case.output(inputs), case.label, case.risk)
    assert contents(Path.cwd()) == before


#: Other ways to write the input ``e.tif`` as the output of ``inverse q``.
SPELLINGS: dict[str, Callable[[Path], tuple[list, str]]] = {
    "-o/--output": lambda e: (["-o", e], str(e)),
    "relative path": lambda e: ([os.path.relpath(e)], os.path.relpath(e)),
    "absolute path": lambda e: ([e.resolve()], str(e.resolve())),
    "through ..": lambda e: ([Path("holder") / ".." / e.name], str(Path("holder/..") / e.name)),
    "symbolic link": lambda e: (["link.tif"], "link.tif"),
    "hard link": lambda e: (["hard.tif"], "hard.tif"),
}


@pytest.mark.parametrize("spelling", list(SPELLINGS))
def test_every_spelling_of_the_same_file_is_refused(inputs, spelling: str) -> None:
    Path("link.tif").symlink_to(inputs.emission)
    os.link(inputs.emission, "hard.tif")
    before = contents(Path.cwd())
    tail, shown = SPELLINGS[spelling](Path(inputs.emission.name))
    args = ["inverse", "q", inputs.emission.name, *tail, *OBSERVER, "--kernel", inputs.kernel]
    result = _invoke([*args, "--overwrite"])
    _assert_refused(result, Path(shown), "EMISSION", "is the input")
    assert contents(Path.cwd()) == before


def test_every_path_option_is_an_input_or_an_output() -> None:
    # the check reads every parameter not listed as an output as a possible input: an
    # output option missing from OUTPUT_PARAMETERS would be refused as its own input
    unlisted = []
    for path, command in walk(cli):
        for param in command.params:
            kind = param.type
            if param.name == "files" or not isinstance(kind, click.Path):
                continue
            if not kind.exists and param.name not in OUTPUT_PARAMETERS:
                unlisted.append((" ".join(path), param.name))
    # the photometric file is read (an input); init's PROJECT is written but has no input
    assert sorted(unlisted) == [("init", "project"), ("photometry info", "file")]
