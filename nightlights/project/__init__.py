"""Projects: one TOML file that names the inputs, observers, atmosphere and stages to run.

:func:`load_project` reads and checks a project file before anything runs; :func:`run` runs
its stages, skipping those whose outputs are up to date (content hashes recorded beside the
outputs). ``nightlights run PROJECT.toml`` and ``nightlights init`` are the commands.
"""

from __future__ import annotations

from nightlights.project._load import load_project
from nightlights.project._run import ProjectResult, check, run
from nightlights.project._schema import STAGES, Observer, Project, ProjectError

__all__ = [
    "STAGES",
    "Observer",
    "Project",
    "ProjectError",
    "ProjectResult",
    "check",
    "load_project",
    "run",
]
