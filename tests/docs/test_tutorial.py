"""The tutorial (examples/tutorial.py, shown in docs/tutorial.md) runs as printed."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "examples" / "tutorial.py"

#: Zenith sky brightness over Esplanadi of the demo (`nightlights demo`, seed 2011): the
#: tutorial runs the same stages with the same seed, resolutions, albedo and kernel, so it must
#: find the same sky [mag arcsec-2]; the tolerance covers the last printed digit.
DEMO_ESPLANADI_ZENITH = 18.59
TOLERANCE = 0.015


def test_tutorial_runs_in_memory_and_finds_the_demo_sky(tmp_path: Path) -> None:
    env = {**os.environ, "MPLBACKEND": "Agg", "NIGHTLIGHTS_CACHE": str(tmp_path / "cache")}
    work = tmp_path / "work"
    work.mkdir()
    completed = subprocess.run(
        [sys.executable, str(TUTORIAL)],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr[-4000:]

    # In memory: the only files written are the two pictures the page shows.
    assert sorted(path.name for path in work.iterdir()) == ["irradiance.png", "skyglow.png"]
    for picture in work.iterdir():
        assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    match = re.search(r"zenith (\d+\.\d+) mag arcsec-2", completed.stdout)
    assert match, completed.stdout
    assert abs(float(match.group(1)) - DEMO_ESPLANADI_ZENITH) < TOLERANCE
    assert "Bortle class 7" in completed.stdout
