"""Reading a project: TOML to checked tables, pydantic's errors as one line naming the key."""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from nightlights.project._checks import check_project
from nightlights.project._schema import (
    PathOrMapping,
    Project,
    ProjectError,
    ProjectFile,
    builtin_mappings,
    network_names,
)


def load_project(
    source: PathOrMapping | Project,
    *,
    base: str | os.PathLike[str] | None = None,
    overrides: Mapping[str, Mapping[str, Any]] | None = None,
) -> Project:
    """Read and check a project before anything runs.

    Parameters
    ----------
    source
        A project TOML file, the same tables as a mapping, or a checked :class:`Project`
        (returned unchanged).
    base
        Folder that relative paths are taken from (default: the file's folder; the current
        folder for a mapping).
    overrides
        Keys to replace before checking, by table (e.g. ``{"project": {"seed": 3}}``).

    Returns
    -------
    Project
        The checked project.

    Raises
    ------
    ProjectError
        One line naming the first bad key (and the allowed values) or contradiction.

    Examples
    --------
    >>> from nightlights.demo import example_path
    >>> project = load_project(example_path("helsinki.toml"))
    >>> project.stages[:4]
    ['normalize', 'sample', 'place', 'irradiance']
    >>> [(o.name, o.crs) for o in project.observers]
    [('esplanadi', 'EPSG:4326'), ('suomenlinna', 'EPSG:4326')]
    """
    if isinstance(source, Project):
        return source
    if isinstance(source, Mapping):
        raw = dict(source)
        label = "project"
        folder = Path(base) if base is not None else Path.cwd()
    else:
        path = Path(source)
        label = str(path)
        if not path.is_file():
            raise ProjectError(f"{path}: no such project file")
        try:
            raw = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ProjectError(f"{path}: not a TOML file: {exc}") from exc
        folder = Path(base) if base is not None else path.parent
    folder = folder.resolve()
    for table, keys in (overrides or {}).items():
        raw[table] = {**dict(raw.get(table, {})), **dict(keys)}
    try:
        parsed = ProjectFile.model_validate(raw)
    except ValidationError as exc:
        raise ProjectError(f"{label}: {_describe(exc, raw)}") from None
    parsed = _absolute(parsed, folder)
    observers = check_project(parsed, label)
    return Project(file=parsed, source=label, base=folder, observers=observers)


def _absolute(parsed: ProjectFile, folder: Path) -> ProjectFile:
    """The tables with every path taken from ``folder``."""

    def fix(path: Path | None) -> Path | None:
        return None if path is None else (folder / path.expanduser()).resolve()

    update: dict[str, Any] = {
        name: fix(getattr(parsed.inputs, name))
        for name in ("streets", "emission", "viirs", "dem", "catalog")
    }
    if parsed.inputs.mapping not in builtin_mappings():
        update["mapping"] = str(fix(Path(parsed.inputs.mapping)))
    network = parsed.inputs.network
    if network is not None and network not in network_names():
        update["network"] = str(fix(Path(network)))
    inputs = parsed.inputs.model_copy(update=update)
    stages = parsed.stages
    emission = stages.emission
    if emission is not None and isinstance(emission.albedo, str):
        albedo = str(fix(Path(emission.albedo)))
        stages = stages.model_copy(
            update={"emission": emission.model_copy(update={"albedo": albedo})}
        )
    observers = parsed.observers
    if observers is not None and observers.file is not None:
        observers = observers.model_copy(update={"file": fix(observers.file)})
    project = parsed.project.model_copy(update={"output": fix(parsed.project.output)})
    return parsed.model_copy(
        update={"inputs": inputs, "observers": observers, "project": project, "stages": stages}
    )


def _where(loc: tuple[int | str, ...]) -> str:
    return ".".join(str(part) for part in loc)


def _allowed(loc: tuple[int | str, ...]) -> list[str]:
    """The keys the table at ``loc`` allows."""
    model: Any = ProjectFile
    for part in loc:
        field = next(
            (f for name, f in model.model_fields.items() if (f.alias or name) == part), None
        )
        if field is None:
            return []
        candidates = [
            t for t in _types(field.annotation) if isinstance(t, type) and issubclass(t, BaseModel)
        ]
        if not candidates:
            return []
        model = candidates[0]
    return [f.alias or name for name, f in model.model_fields.items()]


def _types(annotation: Any) -> list[Any]:
    args = getattr(annotation, "__args__", None)
    return [annotation] if not args else [t for a in args for t in _types(a)]


def _describe(exc: ValidationError, raw: Mapping[str, Any]) -> str:
    """The first error of a pydantic validation as one line naming the key."""
    errors = exc.errors()
    # A union (e.g. a path or a number) reports one error per branch: keep the first key's.
    first = errors[0]
    loc = tuple(part for part in first["loc"] if not _is_branch(part))
    where = _where(loc)
    kind = first["type"]
    if kind == "extra_forbidden":
        parent = loc[:-1]
        allowed = ", ".join(_allowed(parent))
        what = "stage" if parent == ("stages",) else "key"
        table = f"[{_where(parent)}]" if parent else "the file"
        return f"{where}: unknown {what} in {table}; allowed: {allowed}"
    if kind == "missing":
        return f"{where}: missing; this key is required"
    if kind == "literal_error":
        expected = first.get("ctx", {}).get("expected", "")
        return (
            f"{where} = {first['input']!r}: not allowed; allowed: {expected.replace(' or ', ', ')}"
        )
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 and len(loc) < 2 else ""
    return f"{where} = {first['input']!r}: {first['msg'].lower()}{more}"


def _is_branch(part: int | str) -> bool:
    """Whether a location part names a union branch (``float``, ``constrained-str``...)."""
    return isinstance(part, str) and (
        part in {"float", "str", "int", "bool", "list[str]", "path"}
        or part.startswith(("constrained-", "function-", "tuple["))
    )
