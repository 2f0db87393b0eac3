"""``nightlights explore``: arguments, the session it builds, the address it listens on, and one
real run that serves until Ctrl-C."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import httpx
import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner, Result

from nightlights import roads
from nightlights.errors import DataQualityWarning
from nightlights.explore import _app
from nightlights_cli.main import cli

from .conftest import Recorder

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """A 20 x 20 emission raster at 50 m with 30 lit cells, a tiny kernel, and a text file."""
    from nightlights.io import Raster
    from nightlights.sky import KernelSpec, build_kernel

    folder = tmp_path_factory.mktemp("explore_cli")
    flux = np.zeros((20, 20))
    flux.flat[np.random.default_rng(1).choice(400, 30, replace=False)] = 2.0  # [lm m-2]
    raster = Raster(flux[None], Affine(50.0, 0, 400_000.0, 0, -50.0, 6_600_000.0), "EPSG:32635")
    emission = raster.write(folder / "emission.tif")
    spec = KernelSpec(r_max=3000.0, n_distance=4, n_elevation=4, n_azimuth=8)
    kernel = build_kernel(spec, folder / "kernel.nc", progress=False).path
    text = folder / "notes.tif"
    text.write_text("not a raster")
    return SimpleNamespace(emission=emission, kernel=kernel, text=text, folder=folder)


@pytest.fixture
def fake_serve(monkeypatch: pytest.MonkeyPatch) -> Recorder:
    """``serve`` replaced by a recorder: the command runs to the point of serving."""
    recorder = Recorder(None)
    monkeypatch.setattr(_app, "serve", recorder)
    return recorder


def invoke(*args: Any) -> Result:
    return CliRunner().invoke(cli, ["explore", *map(str, args)])


def one_line_error(result: Result, exit_code: int, *words: str) -> str:
    assert result.exit_code == exit_code, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    for word in words:
        assert word in errors[0], errors[0]
    return errors[0]


def test_help() -> None:
    result = invoke("--help")
    assert result.exit_code == 0
    for word in ("EMISSION", "--session", "--no-browser", "--export-dir", "--tiles", "--streets"):
        assert word in result.output


def test_serves_the_session_on_loopback(files: SimpleNamespace, fake_serve: Recorder) -> None:
    tiles = "https://tile.example.org/{z}/{x}/{y}.png"
    result = invoke(
        files.emission,
        "--kernel",
        files.kernel,
        "--port",
        0,
        "--no-browser",
        "--tiles",
        tiles,
        "--export-dir",
        files.folder,
        "--observer-height",
        3.0,
    )
    assert result.exit_code == 0, result.output
    assert "Warning" not in result.output
    (session,) = fake_serve.args
    kwargs = fake_serve.kwargs
    assert (session.n_lit, session.shape, session.observer_height) == (30, (20, 20), 3.0)
    assert (kwargs["host"], kwargs["open_browser"], kwargs["tiles"]) == ("127.0.0.1", False, tiles)
    assert kwargs["export_dir"] == str(files.folder)
    assert re.search(rf"http://127\.0\.0\.1:{kwargs['port']}/", result.output), result.output
    assert kwargs["sock"].fileno() == -1  # the command closes the socket it listened on


def test_a_host_other_than_loopback_warns(files: SimpleNamespace, fake_serve: Recorder) -> None:
    result = invoke(files.emission, "--kernel", files.kernel, "--host", "0.0.0.0", "--port", 0)
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("Warning")]
    assert len(warnings) == 1 and "0.0.0.0" in warnings[0] and "not loopback" in warnings[0]
    assert fake_serve.kwargs["host"] == "0.0.0.0"
    assert fake_serve.kwargs["open_browser"] is True
    assert "http://127.0.0.1:" in result.output  # where this machine's browser finds it


def test_a_port_in_use_is_one_line(files: SimpleNamespace, fake_serve: Recorder) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        result = invoke(files.emission, "--kernel", files.kernel, "--port", port, "--no-browser")
    one_line_error(result, 1, "InputError", f"port {port}", "in use")
    assert fake_serve.calls == []


def test_a_session_file(files: SimpleNamespace, fake_serve: Recorder, tmp_path: Path) -> None:
    from nightlights.explore._session import ExploreSession

    session = ExploreSession(files.emission, kernel=files.kernel, progress=False)
    centre = (
        (session.bounds[0] + session.bounds[2]) / 2,
        (session.bounds[1] + session.bounds[3]) / 2,
    )
    session.edit("erase", [centre], radius=300.0)
    saved = session.save(tmp_path / "s.json")
    result = invoke("--session", saved, "--port", 0, "--no-browser")
    assert result.exit_code == 0, result.output
    (opened,) = fake_serve.args
    assert opened.total_flux == pytest.approx(session.total_flux)
    assert opened.n_lit == session.n_lit < 30


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (lambda f: ["missing.tif"], ["missing.tif", "does not exist"]),
        (lambda f: [], ["EMISSION or --session"]),
        (lambda f: [f.emission, "--session", f.emission], ["only one of"]),
        (lambda f: ["--session", f.emission, "--kernel", f.kernel], ["--kernel", "session"]),
        (lambda f: ["--session", f.emission, "--observer-height", 2], ["--observer-height"]),
        (lambda f: ["--session", f.emission, "--streets", f.emission], ["--streets"]),
        (lambda f: [f.emission, "--port", 70000], ["--port", "70000"]),
        (lambda f: [f.emission, "--export-dir", f.folder / "none"], ["--export-dir"]),
    ],
    ids=[
        "missing",
        "none",
        "both",
        "session-fixes-kernel",
        "session-fixes-height",
        "session-fixes-streets",
        "port",
        "dir",
    ],
)
def test_usage_errors(files: SimpleNamespace, fake_serve: Recorder, args, words) -> None:
    one_line_error(invoke(*args(files)), 2, *words)
    assert fake_serve.calls == []


def test_streets_are_rated_in_the_session(
    files: SimpleNamespace, fake_serve: Recorder, road_plan_case: Any, tmp_path: Path
) -> None:
    lights, streets, _, _ = road_plan_case
    lights.to_file(tmp_path / "lights.gpkg")
    streets.to_file(tmp_path / "streets.gpkg")
    args = [files.emission, "--kernel", files.kernel, "--port", 0, "--no-browser"]
    result = invoke(
        *args, "--lights", tmp_path / "lights.gpkg", "--streets", tmp_path / "streets.gpkg"
    )
    assert result.exit_code == 0, result.output
    (session,) = fake_serve.args
    # the lights lie outside this raster: every light keeps its full level
    assert session.has_streets and np.all(session.light_levels() == 1.0)
    # the command's classes and requirements are the defaults: rated as road_model's
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        expected = roads.road_model(lights, streets).rate()["passed"]
    shown = session.roads().segments["status"]
    assert list(shown == "pass") == [p is True for p in expected.astype(object).tolist()]
    assert list(shown == "not rated") == list(expected.isna())
    # streets without the lights that light them: one line, in the command's words
    result = invoke(*args, "--streets", tmp_path / "streets.gpkg")
    one_line_error(result, 1, "--streets", "--lights")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (lambda f: [f.text, "--kernel", f.kernel, "--port", 0], ["notes.tif"]),
        (lambda f: [f.emission, "--tiles", "ftp://x/{z}/{x}/{y}"], ["--tiles", "http"]),
        (lambda f: [f.emission, "--host", "no.such.host.invalid", "--port", 0], ["host"]),
        (lambda f: [f.emission, "--turbidity", "nan"], ["--turbidity=nan", "finite"]),
        (lambda f: ["--session", f.text, "--port", 0], ["notes.tif", "session"]),
    ],
    ids=["not-a-raster", "tiles", "host", "nan", "not-a-session"],
)
def test_errors_are_one_line(files: SimpleNamespace, fake_serve: Recorder, args, words) -> None:
    one_line_error(invoke(*args(files)), 1, *words)
    assert fake_serve.calls == []


GOOD_EDIT = {"op": "erase", "points": [[400_500.0, 6_599_500.0]], "radius": 300.0, "value": None}


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"edits": [{"op": "erase", "points": [[400_500.0, 6_599_500.0]]}]},
         ["edit 1 of 1: missing field 'radius'", "expected op, points, radius and value"]),
        ({"edits": [GOOD_EDIT, {"points": [[1.0, 2.0]], "radius": 5.0}]},
         ["edit 2 of 2: missing field 'op'"]),
        ({"edits": [{**GOOD_EDIT, "op": "burn"}]}, ["edit 1 of 1: op 'burn'", "paint, erase"]),
        ({"edits": [{**GOOD_EDIT, "points": [[1.0]]}]}, ["edit 1 of 1: points [[1.0]]"]),
        ({"edits": [{**GOOD_EDIT, "points": []}]}, ["edit 1 of 1: points []"]),
        ({"edits": [{**GOOD_EDIT, "radius": "wide"}]}, ["edit 1 of 1: radius 'wide'", "> 0"]),
        ({"edits": [{**GOOD_EDIT, "radius": -5}]}, ["edit 1 of 1: radius -5"]),
        ({"edits": [{**GOOD_EDIT, "op": "paint"}]}, ["edit 1 of 1: value None", "paint needs"]),
        ({"edits": [{**GOOD_EDIT, "brush": 3}]}, ["edit 1 of 1: unknown field 'brush'"]),
        ({"edits": [17]}, ["edit 1 of 1: a number"]),
        ({"edits": {"op": "erase"}}, ["edits is a object; expected a list"]),
        ({"observer_height": "tall"}, ["observer_height 'tall'; expected a number"]),
        ({"observer": [1.0]}, ["observer [1.0]; expected null or [x, y]"]),
        ({"edits": [{**GOOD_EDIT, "op": "scale", "value": -1}]},
         ["edit 1 of 1: value -1", "scale needs a number >= 0"]),
        ({"edits": [{**GOOD_EDIT, "radius": float("inf")}]}, ["edit 1 of 1: radius inf"]),
    ],
    ids=["no-radius", "no-op", "op", "point", "no-points", "radius-text", "radius-negative",
         "paint-no-value", "unknown-field", "not-an-object", "edits-object", "height", "observer",
         "scale-negative", "radius-infinity"],
)  # fmt: skip
def test_a_session_file_with_a_bad_edit_names_it(
    files: SimpleNamespace, fake_serve: Recorder, tmp_path: Path, change: dict, words: list
) -> None:
    """Each saved edit is checked field by field (was a KeyError), the rest of the file too."""
    import json
    import shutil

    shutil.copy(files.emission, tmp_path / "emission.tif")
    shutil.copy(files.kernel, tmp_path / "kernel.nc")
    content = {
        "format": "nightlights-explore",
        "version": 1,
        "emission": "emission.tif",
        "kernel": "kernel.nc",
        "edits": [GOOD_EDIT],
        **change,
    }
    saved = tmp_path / "s.json"
    saved.write_text(json.dumps(content))
    one_line_error(invoke("--session", saved, "--port", 0), 1, "InputError", str(saved), *words)
    assert fake_serve.calls == []


def test_serves_until_interrupted(files: SimpleNamespace, tmp_path: Path) -> None:
    """A real run: the URL on stdout answers, Ctrl-C ends it with status 0."""
    command = [sys.executable, "-m", "nightlights_cli", "explore"]
    args = [str(files.emission), "--kernel", str(files.kernel), "--port", "0", "--no-browser"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [*command, *args, "--export-dir", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env=env,
    )
    try:
        assert process.stdout is not None
        line = process.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:\d+/", line)
        assert match, (line, process.stderr.read() if process.poll() is not None else "")
        deadline = time.monotonic() + 30
        while True:
            try:
                info = httpx.get(match.group(0) + "api/info", timeout=5).json()
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline
                time.sleep(0.1)
        assert info["n_lit"] == 30 and info["export_dir"] == str(tmp_path.resolve())
        foreign = httpx.get(match.group(0) + "api/info", headers={"host": "evil.example"})
        assert foreign.status_code == 403
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=30) == 0, process.stderr.read()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
