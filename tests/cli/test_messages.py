"""The library's messages in the command line's words (``nightlights_cli._messages``).

The library names Python parameters (``kernel=``); the command prints its flags (``--kernel``).
"""

from __future__ import annotations

import ast
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

import nightlights as nl
from nightlights.errors import DataQualityWarning, InputError
from nightlights_cli._messages import PARAMETER, flag_table, to_flags
from nightlights_cli.main import cli

ROOT = Path(__file__).resolve().parents[2]
#: Packages whose messages the command may print.
LIBRARY = ("nightlights", "bayesnets", "ies")
#: Where the messages are not the command's: the QGIS plugin's own (it runs the command).
NOT_PRINTED = ("nightlights/qgis/plugin",)
#: Names a message may hold that are parameters of the Python API alone (no command sets them:
#: the kernel's quadrature details, the atmosphere's switches, the night-sky helpers' inputs,
#: an instrument's response and natural sky, the explore page's web API, the road-lighting
#: functions of ``nightlights.roads``, which no command calls yet) or names of an object
#: (``Atmosphere(extinction=True)``).
API_ONLY = {
    "coefficient_floor",
    "hours",
    "min_dimming",
    "objective",
    "periods",
    "tolerance",
    "weights",
    "zenith_reduction",
    "clouds",
    "asymmetry",  # CloudLayer: the droplets' asymmetry g (no command)
    "albedo",
    "observers",
    "energy",
    "age",
    "area",
    "average",
    "beyond",
    "density",
    "interpolation",
    "carriageway_width",
    "lighting_class",
    "lanes",
    "latitude",
    "longitude",
    "quantity",
    "step_minutes",
    "steps",
    "switch_elevation",
    "veiling",
    "verge_width",
    "band",
    "emission",
    "replace",
    "extinction",
    "extinction_coefficient",
    "fwhm",
    "iterations",
    "lat",
    "leg_nodes",
    "lon",
    "max_body",
    "road_options",
    "max_size",
    "name",
    "natural_luminance",
    "options",
    "parts",
    "pointing",
    "pressure_hpa",
    "star",
    "sub_pixels",
    "supersample",
    "tangent_step",
    "temperature_c",
    "vmax",
    "vmin",
    "classes",  # land_use_obstacles: land-use codes to obstacle defaults (no command)
}
#: ``name=value`` in messages that is no parameter: OpenStreetMap tags.
NOT_PARAMETERS = {"highway"}
#: Variables and keywords that hold (part of) a message.
MESSAGE_NAMES = {"hint", "message", "option", "detail", "why", "reason"}


def _message_strings(tree: ast.AST) -> Iterator[str]:
    """String constants in raised exceptions, warnings and message variables of a module."""
    roots: list[ast.AST] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            roots.append(node.exc)
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name == "warn":
                roots.extend(node.args)
            roots.extend(k.value for k in node.keywords if k.arg in MESSAGE_NAMES)
        elif isinstance(node, ast.Assign) and any(
            isinstance(target, ast.Name) and target.id in MESSAGE_NAMES for target in node.targets
        ):
            roots.append(node.value)
    for root in roots:
        for sub in ast.walk(root):
            if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                yield sub.value


def _library_parameters() -> dict[str, str]:
    """Each ``name=`` the library's messages use -> a module that uses it."""
    found: dict[str, str] = {}
    for package in LIBRARY:
        for path in sorted((ROOT / package).rglob("*.py")):
            where = path.relative_to(ROOT).as_posix()
            if where.startswith(NOT_PRINTED):
                continue
            for text in _message_strings(ast.parse(path.read_text(encoding="utf-8"))):
                for match in PARAMETER.finditer(text):
                    found.setdefault(match["name"], where)
    return found


def test_the_library_names_parameters_not_flags() -> None:
    flags = {
        f"{where}: {text!r}"
        for package in LIBRARY
        for path in sorted((ROOT / package).rglob("*.py"))
        if not (where := path.relative_to(ROOT).as_posix()).startswith(NOT_PRINTED)
        for text in _message_strings(ast.parse(path.read_text(encoding="utf-8")))
        if re.search(r"(?<![\w-])--[a-z]", text)
    }
    assert flags == set()


def test_every_parameter_the_library_names_has_a_flag() -> None:
    table = flag_table(cli)
    used = _library_parameters()
    assert {"kernel", "observer_crs", "on_conflict", "turbidity", "n_distance"} <= set(used)
    known = set(table) | API_ONLY | NOT_PARAMETERS
    missing = sorted(f"{name} ({where})" for name, where in used.items() if name not in known)
    assert missing == []
    stale = sorted(API_ONLY - set(used))
    assert stale == [], "API_ONLY names no message uses any more"


@pytest.mark.parametrize(
    ("library", "command_line"),
    [
        ("omit turbidity= or build a kernel for it", "omit --turbidity or build a kernel for it"),
        (
            "lower n_distance=, n_elevation= or n_azimuth=",
            "lower --n-distance, --n-elevation or --n-azimuth",
        ),
        ("give observer_crs='EPSG:4326'", "give --observer-crs='EPSG:4326'"),
        ("exists; give overwrite=True", "exists; give --overwrite"),
        ("(built with store_tables=False)", "(built with --no-store-tables)"),
        ("(name one with area_options.spectrum=)", "(name one with --area-spectrum)"),
        ("margin=nan m", "--margin=nan m"),
        (
            "raise the limit with NIGHTLIGHTS_MAX_MEMORY",
            "raise the limit with --max-memory / NIGHTLIGHTS_MAX_MEMORY",
        ),
        ("lit=no, H=90, a==b, x_kernel=1", "lit=no, H=90, a==b, x_kernel=1"),
    ],
)
def test_parameters_become_flags(library: str, command_line: str) -> None:
    assert to_flags(library, cli) == command_line


def test_the_failing_commands_own_flag_comes_first() -> None:
    sky_render = cli.commands["sky"].commands["render"]  # type: ignore[attr-defined]
    assert to_flags("height=0", cli, sky_render) == "--height=0"
    observers = cli.commands["sky"].commands["observers"]  # type: ignore[attr-defined]
    assert to_flags("observers_layer='x'", cli, observers) == "--observers-layer='x'"


def _emission(tmp_path: Path) -> str:
    path = tmp_path / "emission.tif"
    path.write_bytes(b"")  # the stage is replaced below; the command checks that it exists
    return str(path)


def test_a_library_error_shows_the_flag(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def darkness(*args: object, **kwargs: object) -> None:
        raise InputError(
            "turbidity 3 differs from the kernel's (2); omit turbidity= or build "
            "a kernel for it; or give kernel="
        )

    monkeypatch.setattr(nl, "darkness", darkness)
    result = CliRunner().invoke(cli, ["darkness", _emission(tmp_path), str(tmp_path / "z.tif")])
    assert result.exit_code == 1
    assert result.stderr == (
        "Error: InputError: turbidity 3 differs from the kernel's (2); omit --turbidity or build "
        "a kernel for it; or give --kernel\n"
    )


def test_a_library_warning_shows_the_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def darkness(*args: object, **kwargs: object) -> None:
        warnings.warn(
            "look like degrees: give observer_crs='EPSG:4326'", DataQualityWarning, stacklevel=2
        )
        raise InputError("stop here")

    monkeypatch.setattr(nl, "darkness", darkness)
    with caplog.at_level("WARNING"):
        CliRunner().invoke(cli, ["darkness", _emission(tmp_path), str(tmp_path / "z.tif")])
    assert "DataQualityWarning: look like degrees: give --observer-crs='EPSG:4326'" in caplog.text
