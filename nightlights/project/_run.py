"""Run a project: check it, then run its stages in order, skipping those already done."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from nightlights.errors import OutputError
from nightlights.io.outputs import replaced_input, sidecar_paths, terminate_cleanly
from nightlights.project._cache import StageCache, file_hash, stage_key
from nightlights.project._ground_tasks import GROUND_BUILDERS
from nightlights.project._load import load_project
from nightlights.project._schema import (
    STAGES,
    PathOrMapping,
    Project,
    ProjectError,
)
from nightlights.project._sky_tasks import SKY_BUILDERS
from nightlights.project._tasks import Context, Task

#: What :func:`run` reports for each task: its name, ``"start"``, ``"ran"`` or ``"cached"``,
#: and the seconds it took (0 at its start).
TaskEvent = Literal["start", "ran", "cached"]
TaskCallback = Callable[[str, TaskEvent, float], None]


@dataclass
class ProjectResult:
    """What :func:`run` did.

    Attributes
    ----------
    folder
        The output folder.
    outputs
        Output name -> path, in running order.
    ran
        Tasks computed (a task is a stage, or a stage for one observer: ``skyglow:name``).
    cached
        Tasks skipped because their outputs were up to date.
    zenith
        Zenith sky brightness [mag arcsec-2] and Bortle class per observer (``skyglow``).
    findings
        What the inverse stages found, one line each.
    seconds
        Wall time of the run [s].
    """

    folder: Path
    outputs: dict[str, Path] = field(default_factory=dict)
    ran: list[str] = field(default_factory=list)
    cached: list[str] = field(default_factory=list)
    zenith: dict[str, tuple[float, int]] = field(default_factory=dict)
    findings: list[str] = field(default_factory=list)
    seconds: float = 0.0


def run(
    project: PathOrMapping | Project,
    output: str | os.PathLike[str] | None = None,
    *,
    force: Iterable[str] = (),
    progress: bool = True,
    on_task: TaskCallback | None = None,
) -> ProjectResult:
    """Run a project's stages, reusing those whose inputs and options have not changed.

    The project is checked in full before any stage runs (:func:`load_project`). Each stage
    (each stage and observer for ``skyglow``, ``inverse-q`` and ``inverse-s``) is skipped when
    its outputs exist with the content recorded when it last ran and the content hashes of its
    inputs and its options are unchanged; so changing one observer reruns only that
    observer's sky stages. An interrupted run leaves no output that looks complete.

    Parameters
    ----------
    project
        A project TOML file, its tables as a mapping (relative paths from the current
        folder), or a checked :class:`Project`.
    output
        Output folder (default: ``[project] output``, relative to the project file).
    force
        Stages to run even when up to date; the stages downstream of them run too.
    progress
        Show the stages' progress bars.
    on_task
        Called at the start and end of each task (name, event, seconds), and around the build
        of the project's kernel when it is not cached yet (name ``kernel``).

    Returns
    -------
    ProjectResult
        Outputs, tasks run and skipped, and the figures the stages reported.

    Raises
    ------
    ProjectError
        The project is malformed or contradicts itself, or ``force`` names a stage it does
        not run (nothing runs).

    Examples
    --------
    >>> import nightlights as nl
    >>> from nightlights.demo import example_path
    >>> result = nl.run(example_path("helsinki.toml"), "helsinki-out")  # doctest: +SKIP
    >>> result.zenith["esplanadi"]  # doctest: +SKIP
    (18.68..., 7)
    """
    started = time.perf_counter()
    checked = load_project(project)
    tasks = plan_tasks(checked)
    forced = _forced(tasks, checked, force)
    folder = Path(output).resolve() if output is not None else checked.output
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{folder}: is not a folder; expected the project's output folder")
    files = _Files(checked)
    _refuse_replacing_inputs(tasks, folder, files, checked)
    folder.mkdir(parents=True, exist_ok=True)
    cache = StageCache(folder)
    cache.clean()
    result = ProjectResult(folder=folder)
    notify = on_task or (lambda name, event, seconds: None)
    context = Context(checked, progress, notify)
    # SIGTERM unwinds the stages as Ctrl-C does (a stage writes its outputs one after another
    # into its staging folder, which must go however the run ends)
    with terminate_cleanly():
        for task in tasks:
            _run_task(task, context, cache, files, forced, result)
    result.seconds = time.perf_counter() - started
    return result


def _run_task(
    task: Task,
    context: Context,
    cache: StageCache,
    files: _Files,
    forced: set[str],
    result: ProjectResult,
) -> None:
    """Run ``task`` unless its record is valid; record its outputs and facts in ``result``."""
    key = _key(task, files)
    record = None if task.name in forced else cache.valid(task.name, key)
    if record is None:
        context.notify(task.name, "start", 0.0)
        begun = time.perf_counter()
        cache.forget(task.name, list(task.outputs.values()))
        with cache.staging(task.name) as staging:
            staged = {name: staging / file for name, file in task.outputs.items()}
            inputs = {name: files.path(name) for name in task.needs}
            facts = task.compute(context, staged, inputs)
            for name, path in staged.items():
                if not path.exists():
                    raise OutputError(f"stage {task.name}: wrote no {task.outputs[name]}")
            seconds = time.perf_counter() - begun
            record = cache.commit(task.name, key, staged, facts, seconds)
        result.ran.append(task.name)
        context.notify(task.name, "ran", seconds)
    else:
        result.cached.append(task.name)
        context.notify(task.name, "cached", record.seconds)
    for name, state in record.outputs.items():
        files.add(name, cache.folder / state["file"], state["sha256"])
        result.outputs[name] = cache.folder / state["file"]
    _collect(task, record.facts, result)


def plan_tasks(project: Project) -> list[Task]:
    """The tasks of ``project``, in running order."""
    builders = GROUND_BUILDERS | SKY_BUILDERS
    tasks: list[Task] = []
    for stage in project.stages:
        options = project.options(stage).model_dump(mode="json", by_alias=True)
        tasks.extend(builders[stage](project, options))
    return tasks


def _collect(task: Task, facts: Mapping[str, Any], result: ProjectResult) -> None:
    if "zenith" in facts and task.observer is not None:
        magnitude, bortle = facts["zenith"]
        # a record is strict JSON: its null magnitude is a sky without artificial light
        # (+inf mag arcsec-2); a sky that is not finite is refused before any record is made
        magnitude = math.inf if magnitude is None else float(magnitude)
        result.zenith[task.observer.name] = (magnitude, int(bortle))
    result.findings.extend(facts.get("findings", []))


class _Files:
    """Paths and content hashes of the project's inputs and of the outputs made so far."""

    def __init__(self, project: Project) -> None:
        inputs = project.file.inputs
        self._paths: dict[str, Path] = {}
        for name in ("streets", "emission", "viirs", "dem", "catalog"):
            path = getattr(inputs, name)
            if path is not None:
                self._paths[f"inputs.{name}"] = path
        for name in ("mapping", "network"):
            value = getattr(inputs, name)
            if value is not None and Path(value).is_absolute():
                self._paths[f"inputs.{name}"] = Path(value)
        emission = project.options("emission")
        if emission is not None and isinstance(emission.albedo, str):
            self._paths["stages.emission.albedo"] = Path(emission.albedo)
        observers = project.file.observers
        if observers is not None and observers.file is not None:
            self._paths["observers.file"] = observers.file
        if inputs.emission is not None:
            self._paths["emission"] = inputs.emission
        self._hashes: dict[str, str] = {}

    def inputs(self) -> dict[str, Path]:
        """The project's input files, by key (``inputs.streets``...)."""
        return {name: path for name, path in self._paths.items() if "." in name}

    def add(self, name: str, path: Path, digest: str) -> None:
        self._paths[name] = path
        self._hashes[name] = digest

    def path(self, name: str) -> Path:
        return self._paths[name]

    def hash(self, name: str) -> str:
        if name not in self._hashes:
            self._hashes[name] = file_hash(self._paths[name])
        return self._hashes[name]


def _refuse_replacing_inputs(
    tasks: list[Task], folder: Path, files: _Files, project: Project
) -> None:
    """Refuse an output folder where a stage's output (or the folder itself) would replace one
    of the inputs: the same file by any path or link, a file in an input folder, a folder
    holding an input (:func:`~nightlights.io.outputs.replaced_input`)."""
    inputs = files.inputs()
    for name, path in inputs.items():
        if os.path.exists(folder) and os.path.exists(path) and os.path.samefile(folder, path):
            raise ProjectError(
                f"{project.source}: project.output: the output folder {folder} is {name} "
                f"({path}); choose another output folder"
            )
    for task in tasks:
        for file in task.outputs.values():
            target = folder / file
            for candidate in (target, *sidecar_paths(target)):
                reason = replaced_input(candidate, inputs)
                if reason is not None:
                    raise ProjectError(
                        f"{project.source}: project.output: stage {task.name} would write "
                        f"{candidate}, which {reason}; choose another output folder"
                    )


def _key(task: Task, files: _Files) -> str:
    from nightlights import __version__

    return stage_key(
        {
            "task": task.name,
            "options": task.options,
            "inputs": {name: files.hash(name) for name in task.needs},
            "outputs": task.outputs,
            "version": __version__,
        }
    )


def _forced(tasks: list[Task], project: Project, force: Iterable[str]) -> set[str]:
    """The tasks of the forced stages and every task downstream of them."""
    stages = list(force)
    for stage in stages:
        if stage not in project.stages:
            raise ProjectError(
                f"force {stage!r}: not a stage of {project.source}; allowed: "
                f"{', '.join(project.stages) or 'none'}"
                + ("" if stage in STAGES else f" (stages: {', '.join(STAGES)})")
            )
    forced = {task.name for task in tasks if task.stage in stages}
    made: set[str] = set()
    for task in tasks:
        if task.name in forced or any(need in made for need in task.needs):
            forced.add(task.name)
            made.update(task.outputs)
    return forced


def check(
    project: PathOrMapping | Project,
    output: str | os.PathLike[str] | None = None,
    *,
    force: Iterable[str] = (),
) -> list[tuple[str, bool]]:
    """Check a project and say which tasks :func:`run` would run; run nothing, write nothing.

    Parameters
    ----------
    project, output, force
        As :func:`run`.

    Returns
    -------
    list of (str, bool)
        Each task in running order, and whether it is up to date (would be skipped). A task
        downstream of one that runs counts as running.

    Raises
    ------
    ProjectError
        As :func:`run`.
    """
    checked = load_project(project)
    tasks = plan_tasks(checked)
    forced = _forced(tasks, checked, force)
    folder = Path(output).resolve() if output is not None else checked.output
    files = _Files(checked)
    _refuse_replacing_inputs(tasks, folder, files, checked)
    cache = StageCache(folder) if folder.is_dir() else None
    made: set[str] = set()
    answer = []
    for task in tasks:
        record = None
        if cache is not None and task.name not in forced and not made & set(task.needs):
            record = cache.valid(task.name, _key(task, files))
        if record is None:
            made.update(task.outputs)
        else:
            for name, state in record.outputs.items():
                files.add(name, folder / state["file"], state["sha256"])
        answer.append((task.name, record is not None))
    return answer
