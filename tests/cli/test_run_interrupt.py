"""Ctrl-C or SIGTERM during ``nightlights run``: the stage that was running leaves no output,
no record and no staging folder; the stages before it stay complete and are skipped next
time."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from nightlights.demo import example_path

PROJECT = """\
[project]
output = "out"
seed = 3

[inputs]
streets = "{streets}"

[stages.normalize]

[stages.sample]

[stages.place]

[stages.irradiance]
resolution = 0.5
map = false
"""


def _wait_for(pattern: str, folder: Path, process: subprocess.Popen[str], limit: float) -> bool:
    end = time.monotonic() + limit
    while time.monotonic() < end and process.poll() is None:
        if list(folder.glob(pattern)):
            return True
        time.sleep(0.05)
    return False


def test_ctrl_c_leaves_no_output_that_looks_complete(tmp_path: Path) -> None:
    project = tmp_path / "project.toml"
    project.write_text(PROJECT.format(streets=example_path().as_posix()))
    records = tmp_path / "out" / ".nightlights"
    process = subprocess.Popen(
        [sys.executable, "-m", "nightlights_cli", "run", str(project)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert _wait_for("irradiance.*.partial", records, process, 120.0), process.communicate()
        time.sleep(0.5)  # well inside the stage (it takes seconds)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode != 0, stderr
    assert "Aborted" in stderr
    out = tmp_path / "out"
    assert not (out / "irradiance.tif").exists()
    assert not (records / "irradiance.json").exists()
    assert list(records.glob("*.partial")) == []
    assert {p.name for p in records.glob("*.json")} == {
        "normalize.json",
        "sample.json",
        "place.json",
    }
    assert (out / "lights.gpkg").is_file()
    # the next run would skip the three finished stages and run the interrupted one
    from nightlights.project import check

    assert check(project) == [
        ("normalize", True),
        ("sample", True),
        ("place", True),
        ("irradiance", False),
    ]


def test_sigterm_between_two_outputs_of_a_stage_leaves_no_staging_folder(
    tmp_path: Path,
) -> None:
    # the irradiance stage writes irradiance.tif, then draws irradiance.png: between the two
    # no output is open, and SIGTERM (a batch scheduler's) must still clean up the stage
    project = tmp_path / "project.toml"
    text = PROJECT.format(streets=example_path().as_posix()).replace("map = false", "map = true")
    project.write_text(text)
    records = tmp_path / "out" / ".nightlights"
    process = subprocess.Popen(
        [sys.executable, "-m", "nightlights_cli", "run", str(project)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        staged = "irradiance.*.partial/irradiance.tif"
        end = time.monotonic() + 240.0
        while not list(records.glob(staged)):
            assert process.poll() is None and time.monotonic() < end, process.communicate()
            time.sleep(0.01)
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == -signal.SIGTERM, stderr  # 143 from a shell
    assert list(records.glob("*.partial")) == []
    out = tmp_path / "out"
    assert not (out / "irradiance.tif").exists() and not (out / "irradiance.png").exists()
    assert {p.name for p in records.glob("*.json")} == {
        "normalize.json",
        "sample.json",
        "place.json",
    }
