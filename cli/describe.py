"""The stage commands as data, for the QGIS plugin's Processing algorithms.

The click commands are the one description of each stage's paths and options. From them
:func:`describe_stages` writes, for every stage command, its positional paths (what each names:
:mod:`~nightlights_cli.kinds`) and its options (flag, type, choices, default, range, help,
whether repeatable or required), and how the Processing Toolbox lists it (:data:`TOOLBOX`).
``nightlights qgis-plugin build`` puts it into the plugin as ``stages.json``; the plugin, which
does not import the toolkit, makes one algorithm of each entry and turns the algorithm's values
back into the command line (``nightlights.qgis.plugin.stages``).

Each parameter is named after the command's parameter in upper case (``--observer-height``:
``OBSERVER_HEIGHT``; a positional path: its word of the usage, ``EMISSION``). Not offered as
parameters of their own:

- ``-o/--output``, the other spelling of the last positional path;
- ``--overwrite``, always given (QGIS asks before it names an existing output);
- the option that names the layer of a vector input (``--layer`` of the first vector input,
  ``--NAME-layer`` of the input NAME): the layer chosen in QGIS gives it;
- ``--observer-crs`` of a command that takes ``--observer X,Y``: the CRS of the point picked;
- hidden (deprecated) options and commands.

A string option whose help lists a constant of the library (``--network``, ``--mapping``,
``--sensor``) is offered as a choice among those values.
"""

from __future__ import annotations

import inspect
import numbers
import re
from collections.abc import Iterator
from typing import Any

import click

from .kinds import FilesArgument, KindPath, PathKind
from .library import FromLibrary, LibraryHelpOption
from .options import CRSText, DefaultCommandGroup
from .reference import walk

#: Each stage command's algorithm in the Processing Toolbox: command -> (title, group).
TOOLBOX: dict[str, tuple[str, str]] = {
    "streets normalize": ("Normalize streets", "Streets"),
    "streets sample": ("Sample street lighting", "Streets"),
    "streets place": ("Place streetlights", "Streets"),
    "streets audit": ("Audit street lighting (EN 13201)", "Streets"),
    "streets plan": ("Plan dimming that keeps roads lit", "Streets"),
    "irradiance": ("Ground irradiance", "Light"),
    "emission ground": ("Upward emission", "Light"),
    "emission viirs": ("Upward emission from VIIRS", "Light"),
    "obstacles": ("Obstacles from building footprints", "Light"),
    "kernel build": ("Skyglow kernel", "Sky"),
    "skyglow": ("Skyglow panorama", "Sky"),
    "darkness": ("Zenith darkness map", "Sky"),
    "sky observers": ("Skies of many observers", "Sky"),
    "sky render": ("Night sky picture", "Sky"),
    "inverse q": ("Light pollution by cell", "Inverse"),
    "inverse s": ("Skyglow in a region of the sky by cell", "Inverse"),
    "inverse dim": ("Dim by light pollution (dimming rule)", "Inverse"),
    "inverse plan": ("Least dimming for a sky-brightness target", "Inverse"),
    "validate": ("Validate against photometer readings", "Sky"),
    "run": ("Run a project file", "Project"),
}
#: The commands that are not stages, and why the plugin does not offer them.
NOT_STAGES: dict[str, str] = {
    "streets fit": "writes a network folder for --network, which the plugin offers by name only",
    "streets learn": "writes a network folder for --network, which the plugin offers by name only",
    "photometry info": "prints a report on a photometric file",
    "demo": "runs the bundled example project (run runs any project file)",
    "init": "writes a project template to edit by hand",
    "explore": "serves an interactive page until stopped",
    "qgis-plugin build": "builds this plugin",
}
#: Metavars of the options that take a point, and the CRS of their coordinates (None: the
#: CRS in the command's :data:`POINT_CRS` option).
POINT_METAVARS: dict[str, str | None] = {"X,Y": None, "LON,LAT": "EPSG:4326"}
#: The option that holds the CRS of ``X,Y`` points.
POINT_CRS = "observer_crs"
#: Options that stand for another parameter (the last positional path, always given).
FOLDED = ("output", "overwrite")
#: click's marker of an option without a default (click >= 8.3), else nothing matches it.
_UNSET = getattr(click.core, "UNSET", object())


def describe_stages(root: click.Group) -> list[dict[str, Any]]:
    """The description of every stage command under ``root`` (the ``nightlights`` group).

    Returns
    -------
    list of dict
        One entry per command of :data:`TOOLBOX`, in its order, each with ``id`` (the
        algorithm id), ``command`` (its words), ``title``, ``group``, ``help``, ``overwrite``
        (whether it takes ``--overwrite``) and ``parameters`` (:func:`describe_parameters`).
        JSON-ready.

    Raises
    ------
    ValueError
        A command is neither in :data:`TOOLBOX` nor in :data:`NOT_STAGES`, or one of them is
        not a command of ``root``.
    """
    commands = dict(leaf_commands(root))
    unknown = sorted(set(commands) - set(TOOLBOX) - set(NOT_STAGES))
    missing = sorted((set(TOOLBOX) | set(NOT_STAGES)) - set(commands))
    if unknown or missing:
        raise ValueError(
            f"commands neither stages nor listed as not stages: {unknown}; listed but not "
            f"commands: {missing}"
        )
    stages = []
    for name, (title, group) in TOOLBOX.items():
        command, ctx = commands[name]
        stages.append(
            {
                "id": algorithm_id(ctx),
                "command": name.split(),
                "title": title,
                "group": group,
                "help": f"{_summary(command)} (nightlights {name})",
                "overwrite": any(param.name == "overwrite" for param in command.params),
                "parameters": describe_parameters(command),
            }
        )
    return stages


def leaf_commands(root: click.Group) -> Iterator[tuple[str, tuple[click.Command, click.Context]]]:
    """Every visible command under ``root`` that is not a group: its words without the root's
    name (``"inverse s"``), the command and its context."""
    for command, ctx in walk(root, "nightlights"):
        if not isinstance(command, click.Group):
            yield ctx.command_path.partition(" ")[2], (command, ctx)


def algorithm_id(ctx: click.Context) -> str:
    """The algorithm id of a command: its words run together (``inverse s``: ``inverses``); the
    default command of a group takes the group's (``emission ground``: ``emission``)."""
    parent = ctx.parent
    if parent is not None and isinstance(parent.command, DefaultCommandGroup):
        if parent.command.default_command == ctx.info_name:
            return algorithm_id(parent)
    return "".join(ctx.command_path.split()[1:]).replace("-", "")


def describe_parameters(command: click.Command) -> list[dict[str, Any]]:
    """The parameters of one command: its positional paths, then its options, each a dict with
    ``name``, ``flag`` (None for a positional path), ``type`` (``raster``, ``vector``,
    ``file``, ``folder``, ``integer``, ``float``, ``boolean``, ``enum``, ``string``, ``crs``
    or ``point``), ``label``, ``help``, ``required``, ``default``, ``multiple``, and where
    they apply ``output``, ``geometry``, ``extensions`` (paths), ``layer_flag`` (a vector
    input), ``choices``, ``min``, ``max``, ``off_flag`` (a boolean's ``--no-...``) and
    ``crs``/``crs_flag`` (a point)."""
    params = [param for param in command.params if not getattr(param, "hidden", False)]
    files = [param for param in params if isinstance(param, FilesArgument)]
    others = [param for param in params if isinstance(param, click.Argument)]
    if len(files) > 1 or len(others) > len(files):
        raise ValueError(f"{command.name}: positional arguments other than FILES")
    described: list[dict[str, Any]] = []
    slots = files[0].slots if files else ()
    for index, slot in enumerate(slots):
        output = index == len(slots) - 1
        entry = _path_entry(slot.kind, output)
        entry.update(
            name=slot.name,
            flag=None,
            label=slot.name.replace("_", " ").capitalize(),
            help="",
            required=not slot.optional,
            default=None,
            multiple=False,
        )
        described.append(entry)
    options = [param for param in params if isinstance(param, click.Option)]
    names = {param.name for param in options}
    projected = any(
        option.metavar in POINT_METAVARS and POINT_METAVARS[option.metavar or ""] is None
        for option in options
    )
    folded = {*FOLDED, *([POINT_CRS] if projected else [])}
    for option in options:
        layer_of = _layer_slot(option, described)
        if layer_of is not None:
            layer_of["layer_flag"] = option.opts[-1]
            continue
        if option.name in folded:
            continue
        entry = _option_entry(option)
        if entry["type"] == "point" and entry["crs"] is None:
            if POINT_CRS not in names:
                raise ValueError(f"{command.name} {option.opts[-1]}: no --observer-crs")
            crs = next(param for param in options if param.name == POINT_CRS)
            entry["crs_flag"] = crs.opts[-1]
        described.append(entry)
    return described


def _layer_slot(option: click.Option, described: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The vector input whose layer ``option`` names (``--layer``: the first; ``--NAME-layer``:
    NAME), or None."""
    if option.name is None or not (option.name == "layer" or option.name.endswith("_layer")):
        return None
    inputs = [
        entry
        for entry in described
        if entry["flag"] is None and entry["type"] == "vector" and not entry["output"]
    ]
    if option.name == "layer":
        return inputs[0] if inputs else None
    owner = option.name.removesuffix("_layer").upper()
    return next((entry for entry in inputs if entry["name"] == owner), None)


def _path_entry(kind: PathKind, output: bool) -> dict[str, Any]:
    entry: dict[str, Any] = {"type": kind.kind, "output": output}
    if kind.geometry is not None:
        entry["geometry"] = kind.geometry
    if kind.extensions:
        entry["extensions"] = list(kind.extensions)
    return entry


def _option_entry(option: click.Option) -> dict[str, Any]:
    """The description of one option (see :func:`describe_parameters`)."""
    assert option.name is not None
    text = _help(option)
    entry: dict[str, Any] = {
        "name": option.name.upper(),
        "flag": option.opts[-1],
        "label": _label(text, option.opts[-1]),
        "help": text,
        "required": bool(option.required),
        "multiple": bool(option.multiple),
    }
    default = _default(option)
    kind = option.type
    if isinstance(kind, click.Path):
        path_kind = kind.kind if isinstance(kind, KindPath) else _plain_path_kind(kind)
        entry.update(_path_entry(path_kind, output=not kind.exists))
    elif option.is_flag:
        entry["type"] = "boolean"
        default = bool(default)
        if option.secondary_opts:
            entry["off_flag"] = option.secondary_opts[-1]
    elif isinstance(kind, click.Choice):
        entry.update(type="enum", choices=[str(choice) for choice in kind.choices])
    elif isinstance(kind, click.types.IntParamType | click.types.FloatParamType):
        entry["type"] = "integer" if isinstance(kind, click.types.IntParamType) else "float"
        entry["min"] = getattr(kind, "min", None)
        entry["max"] = getattr(kind, "max", None)
    elif isinstance(kind, CRSText) or option.metavar == "CRS":
        entry["type"] = "crs"
    elif option.metavar in POINT_METAVARS:
        entry.update(type="point", crs=POINT_METAVARS[option.metavar])
    elif _listed_values(option):
        entry.update(type="enum", choices=_listed_values(option))
    else:
        entry["type"] = "string"
    if entry["type"] == "enum":
        values = default if isinstance(default, list) else [default]
        wrong = [value for value in values if value is not None and value not in entry["choices"]]
        if wrong:
            raise ValueError(f"{option.opts[-1]}: default {wrong} not among {entry['choices']}")
    entry["default"] = default
    return entry


def _plain_path_kind(kind: click.Path) -> PathKind:
    """What a :class:`click.Path` that does not say names: a folder, else a file."""
    return PathKind("folder") if not kind.file_okay else PathKind("file")


def _default(option: click.Option) -> Any:
    """The option's default as JSON: a library constant read, a tuple as a list, none as None."""
    default = option.default
    if isinstance(default, FromLibrary):
        default = default()
    if default is _UNSET or callable(default):
        return None
    if isinstance(default, tuple | list):
        return [_plain(value) for value in default] if default else None
    return _plain(default)


def _plain(value: Any) -> Any:
    """A number of the library's (numpy or Python) as a Python number; others unchanged."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return value
    return int(value) if isinstance(value, numbers.Integral) else float(value)


def _listed_values(option: click.Option) -> list[str] | None:
    """The library's values that a string option's help lists (``{networks}``), or None."""
    if not isinstance(option, LibraryHelpOption) or option.type is not click.STRING:
        return None
    for value in option.help_values.values():
        listed = value()
        if isinstance(listed, list | tuple) and all(isinstance(item, str) for item in listed):
            return list(listed)
    return None


def _help(option: click.Option) -> str:
    return " ".join((option.help or "").split())


def _label(text: str, flag: str) -> str:
    """The first sentence of a help (the dialog's label), else the flag.

    Examples
    --------
    >>> _label("Pixel size [m].", "--resolution")
    'Pixel size [m]'
    >>> _label("CRS of an input that has none (e.g. EPSG:3067). More.", "--crs")
    'CRS of an input that has none (e.g. EPSG:3067)'
    """
    depth = 0
    for index, character in enumerate(text):
        depth += {"(": 1, "[": 1, ")": -1, "]": -1}.get(character, 0)
        if character == "." and depth == 0 and text[index + 1 : index + 2] in ("", " "):
            return text[:index]
    return text or flag


def _summary(command: click.Command) -> str:
    """The first paragraph of a command's help, in one line."""
    first = inspect.cleandoc(command.help or "").split("\n\n")[0]
    return re.sub(r"\s+", " ", first).strip()
