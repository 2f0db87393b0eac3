"""The library's messages in the command line's words: ``name=`` becomes ``--name``.

The library speaks Python: its errors and warnings name the parameter to change
(``omit turbidity= or build a kernel for it``, ``observer_crs='EPSG:4326'``,
``overwrite=True``). A user of the command reads flags, so the command rewrites each message
it prints with one table, :func:`flag_table`, derived from the click commands' own options:
an option's destination is its library parameter (``--observer-crs`` sets ``observer_crs``; a
repeatable option such as ``--sensor`` sets the list ``sensors``), and options that set a field
of an options object are listed in :data:`FIELD_FLAGS` (``area_options.spectrum=`` is
``--area-spectrum``).

- ``name=`` followed by a value keeps it: ``scheduler='tcp://x'`` -> ``--scheduler='tcp://x'``;
- ``name=`` alone names the option: ``lower n_distance=`` -> ``lower --n-distance``;
- a boolean flag's value picks its spelling: ``overwrite=True`` -> ``--overwrite``,
  ``store_tables=False`` -> ``--no-store-tables``.

The failing command's own options come first; a name it lacks is looked up among every
command's options when one flag alone has that name (``sensors=`` in a message of
``emission`` is ``irradiance --sensor``).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import click

#: Options that set a field of an options object, by the field's dotted name in the library.
FIELD_FLAGS: Mapping[str, str] = {
    "area_options.height": "--area-height",
    "area_options.spacing": "--area-spacing",
    "area_options.spectrum": "--area-spectrum",
    "tone_mapping.mode": "--tone",
    "tone_mapping.exposure": "--exposure",
    "tone_mapping.white_temperature": "--white-temperature",
}

#: Phrases whose command-line form adds an option: the memory limit is also ``--max-memory``.
PHRASES: Mapping[str, str] = {
    "raise the limit with NIGHTLIGHTS_MAX_MEMORY": (
        "raise the limit with --max-memory / NIGHTLIGHTS_MAX_MEMORY"
    ),
}

#: A parameter in a message: ``name=`` or ``object.field=`` (not ``==``, not inside a word).
PARAMETER = re.compile(
    r"(?<![\w.\-])(?P<name>[a-z_][a-z0-9_]*(?:\.[a-z_][a-z0-9_]*)?)=(?!=)"
    r"(?P<boolean>(?:True|False)\b)?(?P<value>[^\s,;)]?)"
)


@dataclass(frozen=True)
class Flag:
    """The command-line spelling of one parameter.

    Parameters
    ----------
    on
        The option (``--kernel``; for a boolean flag, the spelling that sets True).
    off
        A boolean flag's spelling that sets False (``--no-store-tables``), or None.
    boolean
        Whether the option is a flag (it takes no value).
    """

    on: str
    off: str | None = None
    boolean: bool = False


def _long(names: list[str]) -> str | None:
    long = [name for name in names if name.startswith("--")]
    return long[-1] if long else None


def command_flags(command: click.Command) -> dict[str, Flag]:
    """The flags of ``command``'s visible options, by their library parameter."""
    flags: dict[str, Flag] = {}
    for param in command.params:
        if not isinstance(param, click.Option) or param.hidden or param.name is None:
            continue
        on = _long(param.opts)
        if on is None:
            continue
        boolean = bool(param.is_flag)
        flags[param.name] = Flag(on, _long(param.secondary_opts), boolean)
    return flags


def walk(
    command: click.Command, path: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], click.Command]]:
    """Every command under ``command`` (itself first), each with its path of names."""
    yield path, command
    if isinstance(command, click.Group):
        for name, sub in sorted(command.commands.items()):
            yield from walk(sub, (*path, name))


def flag_table(root: click.Command) -> dict[str, Flag]:
    """Library parameter -> flag over every command under ``root``: the parameters that one
    flag alone spells (a name spelled differently by two commands is left out), and
    :data:`FIELD_FLAGS`."""
    spellings: dict[str, set[Flag]] = {}
    for _, command in walk(root):
        for name, flag in command_flags(command).items():
            spellings.setdefault(name, set()).add(flag)
    table = {name: flags.pop() for name, flags in spellings.items() if len(flags) == 1}
    table.update({name: Flag(flag) for name, flag in FIELD_FLAGS.items()})
    return table


@functools.cache
def _root_table(root: click.Command) -> dict[str, Flag]:
    return flag_table(root)


def to_flags(text: str, root: click.Command, command: click.Command | None = None) -> str:
    """``text`` with every library parameter (``name=``) written as its flag.

    Parameters
    ----------
    text
        A message of the library.
    root
        The ``nightlights`` group (whose commands make the table).
    command
        The command that failed: its own options come first.

    Examples
    --------
    >>> from nightlights_cli.main import cli
    >>> to_flags("omit turbidity= or build a kernel for it", cli)
    'omit --turbidity or build a kernel for it'
    >>> to_flags("scheduler='tcp://x': cannot connect; give overwrite=True", cli)
    "--scheduler='tcp://x': cannot connect; give --overwrite"
    """
    table = _root_table(root)
    if command is not None:
        table = {**table, **command_flags(command)}
    for phrase, replacement in PHRASES.items():
        text = text.replace(phrase, replacement)

    def replace(match: re.Match[str]) -> str:
        flag = table.get(match["name"])
        if flag is None:
            return match[0]
        if match["boolean"] and flag.boolean:
            spelling = flag.on if match["boolean"] == "True" else flag.off
            return spelling + match["value"] if spelling else match[0]
        if match["value"]:
            return f"{flag.on}={match['boolean'] or ''}{match['value']}"
        return flag.on + (match["boolean"] or "")

    return PARAMETER.sub(replace, text)
