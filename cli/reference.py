"""The command reference (``docs/cli.md``), generated from the click commands.

Regenerate it with::

    python -m nightlights_cli.reference > docs/cli.md

``tests/cli/test_reference.py`` fails when ``docs/cli.md`` is not what :func:`render` gives.
"""

from __future__ import annotations

import inspect
import sys
from collections.abc import Iterator

import click

from .options import DefaultCommandGroup, DeprecatedCommand, DeprecatedOption, FromLibrary

#: click's marker of an option without a default (click >= 8.3), else nothing matches it
_UNSET = getattr(click.core, "UNSET", object())

COMMAND = "python -m nightlights_cli.reference > docs/cli.md"

INTRO = f"""\
# Command reference

Generated from the click commands by `{COMMAND}`; do not edit by hand
(`tests/cli/test_reference.py` fails when this file is not current).

Conventions, as in rasterio's `rio`:

- commands that write a product take their paths as positional `INPUT... OUTPUT`; the output
  may be given with `-o/--output` instead, and then every positional path is an input;
- an existing output is never replaced unless `--overwrite` is given (one-line error, exit
  status 1, nothing written); this covers every file a command writes (`skyglow --png` and
  `--polar-output`, `photometry info --plot`); `streets fit` never replaces a folder that is
  not empty;
- an option name means the same in every command: `--crs` is the CRS of an input that has
  none, `--target-crs` the output CRS, `--dem` terrain heights above sea level [m];
  `kernel build --n-components` is the number of PCA bases stored in a kernel, `skyglow
  --components` the number of stored bases used at run time;
- errors are reported in one line with exit status 1, usage errors (a malformed value, `nan`
  or `inf` for any number) with exit status 2, and no traceback unless `nightlights -v` is
  given (the classes and their messages: [errors](errors.md)); a command that fails leaves no
  file behind and its previous outputs as they were;
- every stage estimates its memory before it allocates and refuses work above the limit set by
  `nightlights --max-memory SIZE`, else `NIGHTLIGHTS_MAX_MEMORY`, else half the machine's
  memory;
- deprecated spellings still work and print a `DeprecationWarning` line on stderr.
"""


def walk(
    command: click.Command,
    name: str,
    parent: click.Context | None = None,
    *,
    hidden: bool = False,
) -> Iterator[tuple[click.Command, click.Context]]:
    """Every command under ``command`` (itself first), each with its context; hidden ones
    (deprecated commands) too when ``hidden``."""
    ctx = click.Context(command, info_name=name, parent=parent)
    yield command, ctx
    if isinstance(command, click.Group):
        for sub_name in sorted(command.commands):
            sub = command.commands[sub_name]
            if hidden or not sub.hidden:
                yield from walk(sub, sub_name, ctx, hidden=hidden)


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _names(option: click.Option) -> str:
    names = ", ".join(f"`{n}`" for n in option.opts)
    if option.secondary_opts:
        names += " / " + ", ".join(f"`{n}`" for n in option.secondary_opts)
    return names


def _value(option: click.Option) -> str:
    if option.is_flag:
        return ""
    if option.count:
        return "(repeatable)"
    if option.metavar:
        return _cell(option.metavar)
    if isinstance(option.type, click.Choice):
        return " \\| ".join(str(c) for c in option.type.choices)
    name = option.type.name.upper()
    return f"{name} (repeatable)" if option.multiple else name


def _default(option: click.Option) -> str:
    if option.required:
        return "required"
    default = option.default
    if option.is_flag or option.count:
        if option.secondary_opts:
            return f"`{option.opts[0] if default else option.secondary_opts[0]}`"
        return ""
    if isinstance(default, FromLibrary):
        default = default()
    if default is None or default is _UNSET or callable(default) or default == ():
        return ""
    if isinstance(default, tuple | list):
        return ", ".join(f"`{v}`" for v in default)
    return f"`{default}`"


def _help(command: click.Command) -> list[str]:
    """The help text as Markdown: ``\\b`` paragraphs become code blocks."""
    lines: list[str] = []
    for paragraph in inspect.cleandoc(command.help or "").split("\n\n"):
        if paragraph.startswith("\b\n"):
            lines += ["```text", paragraph[2:], "```", ""]
        elif paragraph.strip():
            lines += [" ".join(paragraph.split()), ""]
    return lines


def render(root: click.Command | None = None, name: str = "nightlights") -> str:
    """The Markdown command reference of ``root`` (default: the ``nightlights`` group)."""
    if root is None:
        from .main import cli

        root = cli
    commands = list(walk(root, name))
    out = [INTRO, "## Commands", "", "| command | summary |", "|---|---|"]
    for command, ctx in commands[1:]:
        summary = inspect.cleandoc(command.help or "").split("\n\n")[0]
        out.append(f"| `{ctx.command_path}` | {_cell(summary)} |")
    out.append("")
    deprecated: list[tuple[str, str, str]] = [
        (ctx.command_path.rpartition(" ")[0], f"`{ctx.info_name}`", command.replacement)
        for command, ctx in walk(root, name, hidden=True)
        if isinstance(command, DeprecatedCommand)
    ]
    for command, ctx in commands:
        usage = " ".join([ctx.command_path, *command.collect_usage_pieces(ctx)])
        out += [f"## `{ctx.command_path}`", "", f"Usage: `{usage}`", ""]
        out += _help(command)
        if isinstance(command, DefaultCommandGroup):
            out += [
                f"Without a subcommand, `{ctx.command_path}` runs "
                f"`{ctx.command_path} {command.default_command}`.",
                "",
            ]
            for old, new in command.deprecated_spellings.items():
                deprecated.append(
                    (ctx.command_path, f"`{old} INPUT OUTPUT`", f"`{new} INPUT OUTPUT`")
                )
        rows = []
        for param in command.params:
            if not isinstance(param, click.Option):
                continue
            if isinstance(param, DeprecatedOption):
                deprecated.append((ctx.command_path, _names(param), _cell(param.replacement)))
                continue
            if param.hidden:
                continue
            rows.append(
                f"| {_names(param)} | {_value(param)} | {_default(param)} "
                f"| {_cell(param.help or '')} |"
            )
        if rows:
            out += ["| option | value | default | description |", "|---|---|---|---|", *rows, ""]
    out += [
        "## Deprecated spellings",
        "",
        "Still accepted for one release; each use prints a `DeprecationWarning` on stderr.",
        "",
        "| command | deprecated | use instead |",
        "|---|---|---|",
    ]
    out += [f"| `{path}` | {old} | {new} |" for path, old, new in deprecated]
    return "\n".join(out) + "\n"


def main() -> None:
    """Print the reference (``python -m nightlights_cli.reference > docs/cli.md``)."""
    sys.stdout.write(render())


if __name__ == "__main__":
    main()
