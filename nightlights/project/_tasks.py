"""The project's tasks: one per stage, or per stage and observer, each calling one stage.

Each task names its outputs (output name -> file name in the output folder) and the outputs
of other tasks it reads; :mod:`nightlights.project._run` orders, caches and runs them
(the stages' tasks are in ``_ground_tasks`` and ``_sky_tasks``). A task's
``compute`` writes into the staging paths it is given and returns its *facts*: the figures
the run reports (zenith brightness, what the inverse maps found), kept in the stage's record
so that a cached stage reports them too.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nightlights.project._schema import Observer, Project


@dataclass
class Context:
    """What the tasks share: the project, progress flag and the kernel (loaded once)."""

    project: Project
    progress: bool
    #: Told when the project's kernel is built: ``("kernel", "start" | "ran", seconds)``.
    notify: Callable[[str, Any, float], None] = lambda name, event, seconds: None
    _kernel: Any = None
    _kernel_loaded: bool = False

    def kernel(self) -> Any:
        """The project's kernel (``[kernel]`` table), built or read from the cache once; None
        when the project has none (each sky stage then uses its scene kernel)."""
        if not self._kernel_loaded:
            spec = kernel_spec(self.project)
            if spec is not None:
                from nightlights.sky.store import get_or_build_kernel, kernel_cache_path

                building = not kernel_cache_path(spec).is_file()
                if building:
                    self.notify("kernel", "start", 0.0)
                started = time.perf_counter()
                self._kernel = get_or_build_kernel(spec, progress=self.progress)
                if building:
                    self.notify("kernel", "ran", time.perf_counter() - started)
            self._kernel_loaded = True
        return self._kernel


Compute = Callable[[Context, dict[str, Path], dict[str, Path]], dict[str, Any]]


@dataclass
class Task:
    """One stage run (for one observer, or for all).

    Attributes
    ----------
    name
        Unique task name (the stage, and the observer after a colon).
    stage
        The stage it runs.
    outputs
        Output name -> file (or folder) name in the output folder.
    needs
        Output names of other tasks (or project inputs) it reads.
    options
        What else its key depends on (JSON-serialisable).
    compute
        The work.
    observer
        The observer it runs for, if any.
    """

    name: str
    stage: str
    outputs: dict[str, str]
    needs: tuple[str, ...]
    options: dict[str, Any]
    compute: Compute
    observer: Observer | None = None
    files: list[str] = field(default_factory=list)


def kernel_spec(project: Project) -> Any:
    """The :class:`~nightlights.sky.spec.KernelSpec` of the ``[kernel]`` table, or None."""
    table = project.file.kernel
    if table is None:
        return None
    from nightlights.sky.atmosphere import Atmosphere
    from nightlights.sky.spec import KernelSpec

    turbidity = project.file.atmosphere.turbidity
    heights = sorted({o.height for o in project.observers}) or [1.7]
    return KernelSpec(
        r_min=table.r_min,
        r_max=table.r_max,
        n_distance=table.n_distance,
        n_elevation=table.n_elevation,
        n_azimuth=table.n_azimuth,
        uplight=table.uplight,
        nodes=table.nodes,
        observer_altitudes=tuple(heights),
        atmosphere=Atmosphere() if turbidity is None else Atmosphere(turbidity=turbidity),
    )


def one(
    stage: str,
    outputs: dict[str, str],
    needs: Any,
    options: dict[str, Any],
    compute: Compute,
) -> list[Task]:
    """The one task of a stage that runs once."""
    return [Task(stage, stage, outputs, tuple(needs), options, compute)]


def dem_needs(project: Project) -> tuple[str, ...]:
    return ("inputs.dem",) if project.file.inputs.dem is not None else ()


def catalog_needs(project: Project) -> tuple[str, ...]:
    return ("inputs.catalog",) if project.file.inputs.catalog is not None else ()


def is_path(value: str | None) -> bool:
    return value is not None and Path(value).is_absolute()


#: Makes a stage's tasks from the project and the stage's options (as JSON).
Builder = Callable[[Project, dict[str, Any]], list[Task]]
