"""Ctrl-C while a kernel's multiple-scattering factor is measured (a new turbidity): the
compiled, threaded Monte Carlo ends in the command line's clean "Aborted!" (exit status 1, no
traceback, no crash), at any moment of the measurement, and writes nothing.

A real SIGINT is sent to a subprocess that runs the command. The subprocess measures with
many more photons than a build does (:data:`nightlights.sky.multiple.BUILD_PHOTONS`), so that
the measurement lasts minutes on any machine and the signal lands inside it; it logs (``-v``)
when the kernel's single-scattering images are done, which is when the measurement starts.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from affine import Affine

from nightlights.io import RasterBand, write_cog
from nightlights.sky.montecarlo import monte_carlo_luminance

#: Runs the command with a measurement that lasts (the CLI itself is unchanged).
LAUNCHER = """
import sys
from nightlights.sky import multiple
multiple.BUILD_PHOTONS = 400_000
from nightlights_cli.main import cli
cli.main(args=sys.argv[1:], prog_name="nightlights")
"""
#: The log line after which the multiple-scattering measurement starts.
MEASURING = "kernel images computed"
#: A small kernel grid: the single-scattering images take a moment, the measurement the rest.
GRID = ["--n-distance", "8", "--n-elevation", "8", "--n-azimuth", "16"]
#: Longest wait from the signal to the end of the process [s]: a batch of photons, not the
#: whole measurement (which lasts minutes here).
PROMPT = 30.0


@pytest.fixture(scope="module", autouse=True)
def compiled_transport() -> None:
    """Compile (or load from numba's cache) the photon transport before a subprocess needs it,
    so that the signal reaches the compiled work and not the compiler."""
    monte_carlo_luminance(90.0, 0.0, 1e3, photons=2, max_order=2, split_window=0.25)


def _interrupt(args: list[str], delay: float, folder: Path) -> tuple[int, str, float]:
    """Run ``nightlights -v ARGS``, send SIGINT ``delay`` s into the measurement; return the
    exit status, stderr and the seconds from the signal to the end."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "NIGHTLIGHTS_CACHE": str(folder / "cache")}
    process = subprocess.Popen(
        [sys.executable, "-c", LAUNCHER, "-v", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=folder,
        env=env,
    )
    assert process.stderr is not None
    lines = []
    try:
        for line in process.stderr:
            lines.append(line)
            if MEASURING in line:
                break
        else:
            pytest.fail(f"the command ended before measuring: {''.join(lines)}")
        time.sleep(delay)
        assert process.poll() is None, "the measurement ended before the signal"
        process.send_signal(signal.SIGINT)
        sent = time.monotonic()
        _, rest = process.communicate(timeout=120)
        return process.returncode, "".join(lines) + rest, time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def _assert_aborted(status: int, stderr: str, seconds: float) -> None:
    assert status == 1, (status, stderr)  # -11 was a segmentation fault
    assert stderr.rstrip().endswith("Aborted!"), stderr
    for crash in ("Traceback", "Fatal Python error", "Segmentation fault", "SystemError"):
        assert crash not in stderr, stderr
    assert seconds < PROMPT, seconds


@pytest.fixture
def emission(tmp_path: Path) -> Path:
    """A 3 km x 3 km emission raster with one lit block."""
    path = tmp_path / "emission.tif"
    values = np.zeros((30, 30), np.float32)
    values[10:14, 20:24] = 1.0
    transform = Affine(100, 0, 500_000, 0, -100, 6_700_000)
    write_cog(path, [RasterBand(values, "reflected", "lm m-2")], transform=transform,
              crs="EPSG:32635")  # fmt: skip
    return path


def _kernel_build(folder: Path) -> list[str]:
    return ["kernel", "build", "k.nc", "--turbidity", "3.7", *GRID]


def test_ctrl_c_one_second_into_the_measurement_aborts_cleanly(tmp_path: Path) -> None:
    status, stderr, seconds = _interrupt(_kernel_build(tmp_path), 1.0, tmp_path)
    _assert_aborted(status, stderr, seconds)
    assert not (tmp_path / "k.nc").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.0, 3.0, 5.0])
def test_ctrl_c_at_any_moment_of_the_measurement(tmp_path: Path, delay: float) -> None:
    status, stderr, seconds = _interrupt(_kernel_build(tmp_path), delay, tmp_path)
    _assert_aborted(status, stderr, seconds)
    assert not (tmp_path / "k.nc").exists()


@pytest.mark.slow
def test_ctrl_c_while_skyglow_builds_its_scene_kernel(tmp_path: Path, emission: Path) -> None:
    args = [
        *("skyglow", str(emission), "p.nc", "--observer", "501500,6698500"),
        *("--turbidity", "3.3", *GRID),
    ]
    status, stderr, seconds = _interrupt(args, 3.0, tmp_path)
    _assert_aborted(status, stderr, seconds)
    assert not (tmp_path / "p.nc").exists()
    assert not list((tmp_path / "cache").rglob("*.nc"))  # no scene kernel half-cached
