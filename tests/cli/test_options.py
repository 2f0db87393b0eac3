"""nightlights_cli.options: INPUT... OUTPUT and -o/--output, --overwrite, deprecated spellings,
and the library constants the CLI mirrors so that ``nightlights --help`` does not import the
library."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from nightlights_cli import options
from nightlights_cli.main import cli
from nightlights_cli.options import (
    DefaultCommandGroup,
    OutputExistsError,
    deprecated_option,
    one_of,
    resolve_inout,
)
from nightlights_cli.reference import walk

# --- the mirrored constants ---------------------------------------------------------------------


def _library_values() -> list[tuple[str, options.FromLibrary]]:
    """Every library value an option reads: choices, defaults and help values."""
    found = []
    for command, ctx in walk(cli, "nightlights", hidden=True):
        for param in command.params:
            where = f"{ctx.command_path} {param.name}"
            if isinstance(param.type, options.LibraryChoice):
                found.append((where, param.type.source))
            if isinstance(param.default, options.FromLibrary):
                found.append((where, param.default))
            for value in getattr(param, "help_values", {}).values():
                found.append((where, value))
    return found


def test_choices_and_defaults_are_the_library_constants() -> None:
    """The CLI reads its choices and defaults from the library: each reference resolves (a
    moved or renamed constant fails here), and the kernel's defaults are KernelSpec's."""
    from nightlights.sky import KernelSpec
    from nightlights.sky.panorama import MODES

    values = _library_values()
    assert len(values) > 30
    for where, value in values:
        assert value() is not None, where
        assert str(value), where
    build = cli.commands["kernel"].commands["build"]  # type: ignore[attr-defined]
    defaults = {param.name: param.default for param in build.params}
    for name in ("r_min", "r_max", "n_distance", "n_elevation", "n_azimuth", "nodes"):
        assert defaults[name]() == getattr(KernelSpec, name)
    mode = next(p for p in cli.commands["skyglow"].params if p.name == "mode")
    assert mode.type.choices == tuple(MODES)  # type: ignore[attr-defined]


def test_no_option_retypes_a_library_choice() -> None:
    """A plain click.Choice holds choices that the library has no constant for."""
    plain = sorted(
        f"{ctx.command_path} {param.name}"
        for command, ctx in walk(cli, "nightlights", hidden=True)
        for param in command.params
        if isinstance(param.type, click.Choice)
        and not isinstance(param.type, options.LibraryChoice)
    )
    assert plain == ["nightlights skyglow bands"]


def test_help_does_not_import_the_library() -> None:
    code = (
        "import sys; from nightlights_cli.main import cli; "
        "heavy = {'geopandas', 'rasterio', 'xarray', 'numba', 'ies', 'bayesnets', "
        "'nightlights.streets', 'nightlights.ground', 'nightlights.sky'} & set(sys.modules); "
        "assert not heavy, heavy"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(__file__).parents[2])


def test_shared_options_mean_the_same_everywhere() -> None:
    """An option name defined once in nightlights_cli.options has one help text in every command."""
    helps: dict[str, set[str]] = {}
    for command, _ in walk(cli, "nightlights"):
        for param in command.params:
            if isinstance(param, click.Option) and not param.hidden:
                helps.setdefault(param.opts[-1], set()).add(param.help or "")
    shared = ("--output", "--overwrite", "--crs", "--target-crs", "--seed", "--catalog")
    scene = ("--observer-crs", "--observer-height", "--kernel", "--dem")
    grid = ("--components", "--prior", "--num-workers")
    for name in (*shared, *scene, *grid):
        assert len(helps[name]) == 1, (name, helps[name])


# --- INPUT... OUTPUT, -o/--output, --overwrite ----------------------------------------------------


def test_last_positional_is_the_output(tmp_path: Path) -> None:
    a = tmp_path / "a"
    a.touch()
    assert resolve_inout([str(a), "out"], None, inputs=1, usage="A OUT", overwrite=False) == (
        [str(a)],
        "out",
    )


def test_with_output_option_every_positional_is_an_input(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    a.touch()
    b.touch()
    inputs, output = resolve_inout(
        [str(a), str(b)], "out", inputs=(1, 2), usage="A [B] OUT", overwrite=False
    )
    assert inputs == [str(a), str(b)] and output == "out"


@pytest.mark.parametrize(
    ("files", "output", "message"),
    [
        ([], None, "missing OUTPUT"),
        (["out"], None, "expected A OUT"),
        (["missing", "out"], None, "'missing' does not exist"),
        (["x", "y", "out"], None, "expected A OUT"),
    ],
)
def test_wrong_paths_are_usage_errors(
    files: list[str], output: str | None, message: str, tmp_path: Path
) -> None:
    (tmp_path / "x").touch()
    (tmp_path / "y").touch()
    files = [str(tmp_path / f) if f in ("x", "y") else f for f in files]
    with pytest.raises(click.UsageError, match=message):
        resolve_inout(files, output, inputs=1, usage="A OUT", overwrite=False)


def test_existing_output_is_refused_without_overwrite(tmp_path: Path) -> None:
    a, out = tmp_path / "a", tmp_path / "out"
    a.touch()
    out.write_text("keep")
    with pytest.raises(OutputExistsError, match="exists; give --overwrite") as info:
        resolve_inout([str(a), str(out)], None, inputs=1, usage="A OUT", overwrite=False)
    assert info.value.exit_code == 1
    assert resolve_inout([str(a), str(out)], None, inputs=1, usage="A OUT", overwrite=True)[1] == (
        str(out)
    )
    assert out.read_text() == "keep"


# --- deprecated spellings -----------------------------------------------------------------------


@click.group()
@click.option("-q", "--quiet", is_flag=True)
def _root(quiet: bool) -> None:
    pass


@_root.command("cmd")
@click.option("--new", default=None)
@deprecated_option("--old", "old", default=None, replacement="--new")
@click.pass_context
def _cmd(ctx: click.Context, new: str | None, old: str | None) -> None:
    click.echo(one_of(ctx, **{"--new": new, "--old": old}))


def test_deprecated_option_warns_on_stderr_and_still_works() -> None:
    result = CliRunner().invoke(_root, ["cmd", "--old", "x"])
    assert result.exit_code == 0, result.output
    assert result.stdout == "x\n"
    assert result.stderr == "DeprecationWarning: --old is deprecated; use --new.\n"
    quiet = CliRunner().invoke(_root, ["-q", "cmd", "--old", "x"])
    assert quiet.stdout == "x\n" and quiet.stderr == ""
    new = CliRunner().invoke(_root, ["cmd", "--new", "x"])
    assert new.stdout == "x\n" and new.stderr == ""


def test_deprecated_option_is_hidden_and_exclusive_with_its_replacement() -> None:
    assert "--old" not in CliRunner().invoke(_root, ["cmd", "--help"]).output
    both = CliRunner().invoke(_root, ["cmd", "--old", "x", "--new", "y"])
    assert both.exit_code == 2 and "give only one of --new and --old" in both.output


@click.group(cls=DefaultCommandGroup, default_command="a", deprecated_spellings={"--b-from": "b"})
def _group() -> None:
    pass


@_group.command("a")
@click.argument("paths", nargs=-1)
@click.option("--flag", is_flag=True)
def _a(paths: tuple[str, ...], flag: bool) -> None:
    click.echo(f"a {list(paths)} {flag}")


@_group.command("b")
@click.argument("paths", nargs=-1)
@click.option("--flag", is_flag=True)
def _b(paths: tuple[str, ...], flag: bool) -> None:
    click.echo(f"b {list(paths)} {flag}")


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["x", "y"], "a ['x', 'y'] False"),
        (["--flag", "x"], "a ['x'] True"),
        (["a", "x"], "a ['x'] False"),
        (["b", "x", "--flag"], "b ['x'] True"),
        (["--flag", "--b-from", "x", "y"], "b ['x', 'y'] True"),
        (["--b-from=x", "y"], "b ['x', 'y'] False"),
    ],
)
def test_default_command_group(args: list[str], expected: str) -> None:
    result = CliRunner().invoke(_group, args)
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == expected
    assert ("DeprecationWarning" in result.stderr) == any(a.startswith("--b-from") for a in args)


def test_default_command_group_help_is_the_groups() -> None:
    result = CliRunner().invoke(_group, ["--help"])
    assert result.exit_code == 0 and "Commands:" in result.output
