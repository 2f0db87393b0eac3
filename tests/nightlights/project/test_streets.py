"""The street stages of a project on the bundled extract: a new seed reruns sample and place
(and what follows), not normalize; the force of a stage reruns those downstream of it."""

from __future__ import annotations

from pathlib import Path

from nightlights.demo import example_path
from nightlights.project import load_project, run
from nightlights.project._run import _forced, plan_tasks


def _tables(seed: int) -> dict[str, object]:
    return {
        "project": {"seed": seed},
        "inputs": {"streets": str(example_path())},
        "stages": {"normalize": {}, "sample": {}, "place": {"across-jitter": 0.5}},
    }


def test_a_new_seed_reruns_sample_and_place_only(tmp_path: Path) -> None:
    first = run(_tables(1), tmp_path, progress=False)
    assert first.ran == ["normalize", "sample", "place"]
    assert (tmp_path / "lights.gpkg").is_file()
    again = run(_tables(2), tmp_path, progress=False)
    assert again.cached == ["normalize"] and again.ran == ["sample", "place"]
    assert run(_tables(2), tmp_path, progress=False).ran == []


def test_force_takes_the_stages_downstream_along(tmp_path: Path) -> None:
    project = load_project(_tables(1), base=tmp_path)
    tasks = plan_tasks(project)
    assert _forced(tasks, project, ["sample"]) == {"sample", "place"}
    assert _forced(tasks, project, ["place"]) == {"place"}
    assert _forced(tasks, project, []) == set()
