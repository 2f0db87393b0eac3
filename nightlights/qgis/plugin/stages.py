"""The stage commands as the plugin reads them, and their command lines (standard library only).

``nightlights qgis-plugin build`` writes the description of every stage command (its paths and
options, read from the click commands) into the plugin as :data:`STAGES_FILE`; the plugin makes
one Processing algorithm of each stage (``algorithms``) and turns the algorithm's values back
into the command line with :func:`command_line`. Each stage is a dict: ``id``, ``command`` (its
words), ``title``, ``group``, ``help``, ``overwrite`` and ``parameters``, each parameter a dict
with ``name``, ``flag`` (None: a positional path), ``type``, ``label``, ``help``,
``required``, ``default``, ``multiple`` and, where they apply, ``output``, ``geometry``,
``extensions``, ``layer_flag``, ``choices``, ``min``, ``max``, ``off_flag``, ``crs`` and
``crs_flag``.

The values :func:`command_line` takes, by parameter type:

- a path: ``str``; a vector input that has a ``layer_flag``: ``(path, layer)`` too;
- ``integer``, ``float``: a number; ``boolean``: a bool; ``string``, ``crs``: ``str``;
- ``enum``: the choice (``str``), or None for the command's default;
- ``point``: ``(x, y, crs)``, ``crs`` an authority id or WKT, or None;
- a repeatable option: a list of those.

None (or an empty string or list) leaves an option out; an option at its default is left out.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

#: File of the plugin folder with the description of the stages.
STAGES_FILE = "stages.json"
#: The entry of an enum that leaves its option out (for an option without a default).
COMMAND_DEFAULT = "(the command's default)"
#: Path types: positional paths and path options.
PATH_TYPES = ("raster", "vector", "file", "folder")


def read_stages(plugin_dir: str | os.PathLike[str] | None = None) -> list[dict[str, Any]]:
    """The stages described in :data:`STAGES_FILE` of ``plugin_dir`` (default: this folder).

    Raises
    ------
    OSError
        No such file.
    ValueError
        The file is not a description of stages.
    """
    folder = Path(plugin_dir) if plugin_dir is not None else Path(__file__).resolve().parent
    record = json.loads((folder / STAGES_FILE).read_text(encoding="utf-8"))
    stages = record.get("stages") if isinstance(record, dict) else None
    if not isinstance(stages, list):
        raise ValueError(f"{folder / STAGES_FILE}: no list of stages")
    return stages


def enum_options(parameter: Mapping[str, Any]) -> list[str]:
    """The entries of an enum parameter: its choices, after :data:`COMMAND_DEFAULT` for a
    single choice that has no default and may be left out.

    Examples
    --------
    >>> enum_options({"choices": ["a", "b"], "default": None, "required": False,
    ...               "multiple": False})
    ["(the command's default)", 'a', 'b']
    """
    choices = list(parameter["choices"])
    if leaves_out(parameter):
        return [COMMAND_DEFAULT, *choices]
    return choices


def leaves_out(parameter: Mapping[str, Any]) -> bool:
    """Whether an enum parameter's first entry is :data:`COMMAND_DEFAULT`."""
    return not (parameter["required"] or parameter["multiple"] or parameter["default"] is not None)


def enum_value(parameter: Mapping[str, Any], index: int) -> str | None:
    """The choice at ``index`` of :func:`enum_options` (None: the command's default)."""
    entry = enum_options(parameter)[index]
    return None if leaves_out(parameter) and index == 0 else entry


def enum_default(parameter: Mapping[str, Any]) -> int | list[int] | None:
    """The index (indices, for a repeatable option) of the default in :func:`enum_options`."""
    options = enum_options(parameter)
    default = parameter["default"]
    if parameter["multiple"]:
        return [options.index(value) for value in default or ()]
    if default is None:
        return 0 if leaves_out(parameter) else None
    return options.index(default)


def split_values(text: str | None, *, lines: bool = False) -> list[str]:
    """The values of a repeatable option typed in one text: one per line (``lines``), else
    separated by commas, semicolons or spaces.

    Examples
    --------
    >>> split_values("0, 500 1000")
    ['0', '500', '1000']
    >>> split_values("zenith:30:21.5\\nhorizon:0,90,10:20", lines=True)
    ['zenith:30:21.5', 'horizon:0,90,10:20']
    """
    if not text:
        return []
    parts = text.splitlines() if lines else re.split(r"[,;\s]+", text)
    return [part.strip() for part in parts if part.strip()]


def command_line(stage: Mapping[str, Any], values: Mapping[str, Any]) -> list[str]:
    """The command line (without the executable) that runs ``stage`` with ``values``.

    Parameters
    ----------
    stage
        One stage of :func:`read_stages`.
    values
        Parameter name -> value (see the module's docstring); parameters not in it are left
        out.

    Raises
    ------
    ValueError
        A required parameter has no value.

    Examples
    --------
    >>> stage = {"command": ["darkness"], "overwrite": True, "parameters": [
    ...     {"name": "EMISSION", "flag": None, "type": "raster", "required": True},
    ...     {"name": "OUTPUT", "flag": None, "type": "raster", "required": True},
    ...     {"name": "OBSERVER_HEIGHT", "flag": "--observer-height", "type": "float",
    ...      "required": False, "multiple": False, "default": 1.7}]}
    >>> command_line(stage, {"EMISSION": "e.tif", "OUTPUT": "d.tif", "OBSERVER_HEIGHT": 10})
    ['darkness', 'e.tif', 'd.tif', '--observer-height', '10.0', '--overwrite']
    """
    paths: list[str] = []
    options: list[str] = []
    for parameter in stage["parameters"]:
        value = values.get(parameter["name"])
        if _empty(value):
            if parameter["required"]:
                raise ValueError(f"{parameter['name']}: a value is required")
            continue
        if parameter["flag"] is None:
            path, layer = _path_and_layer(value)
            paths.append(path)
            if layer and parameter.get("layer_flag"):
                options += [parameter["layer_flag"], layer]
            continue
        options += _option(parameter, value)
    return [*stage["command"], *paths, *options, *(["--overwrite"] if stage["overwrite"] else [])]


def _empty(value: Any) -> bool:
    return value is None or (isinstance(value, str | list | tuple) and len(value) == 0)


def _path_and_layer(value: Any) -> tuple[str, str | None]:
    if isinstance(value, tuple | list):
        path, layer = value
        return str(path), (str(layer) if layer else None)
    return str(value), None


def _option(parameter: Mapping[str, Any], value: Any) -> list[str]:
    """The arguments of one option given ``value`` (none when at its default)."""
    kind, flag = parameter["type"], parameter["flag"]
    crs_flag = parameter.get("crs_flag")
    if kind == "boolean":
        if bool(value) == bool(parameter["default"]):
            return []
        if value:
            return [flag]
        return [parameter["off_flag"]] if parameter.get("off_flag") else []
    items = list(value) if parameter["multiple"] else [value]
    if kind == "point":
        arguments = [part for x, y, _ in items for part in (flag, f"{float(x)!r},{float(y)!r}")]
        crs = items[0][2]
        return arguments + ([crs_flag, crs] if crs and crs_flag else [])
    texts = [_text(kind, item) for item in items]
    if not parameter["required"] and _at_default(parameter, texts):
        return []
    return [part for text in texts for part in (flag, text)]


def _text(kind: str, value: Any) -> str:
    """A value as the command line spells it (text as typed: the command checks it)."""
    if isinstance(value, str):
        return value
    if kind == "integer":
        return str(int(value))
    if kind == "float":
        return repr(float(value))
    return str(value)


def _at_default(parameter: Mapping[str, Any], texts: Sequence[str]) -> bool:
    default = parameter["default"]
    if default is None:
        return False
    defaults = default if isinstance(default, list) else [default]
    return list(texts) == [_text(parameter["type"], item) for item in defaults]
