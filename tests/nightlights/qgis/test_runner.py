"""The plugin's command runner (standard library only, so it runs here as in QGIS's Python):
progress parsed from rich's bars, messages, the failing command's one-line error, cancel."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from nightlights.qgis.plugin import runner
from nightlights.qgis.plugin.runner import (
    CommandCanceled,
    CommandError,
    child_environment,
    find_command,
    parse_progress,
    parse_remaining,
    run_command,
)


def _script(tmp_path: Path, body: str) -> list[str]:
    """A command line running ``body`` in this Python."""
    path = tmp_path / "child.py"
    path.write_text(textwrap.dedent(body), encoding="utf-8")
    return [sys.executable, str(path)]


def test_progress_of_a_real_rich_bar(tmp_path: Path) -> None:
    """A rich progress bar drawn as the commands draw theirs (transient, M/N column) is read
    back step by step, and the lines printed around it are messages."""
    command = _script(
        tmp_path,
        """
        import time
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn
        from rich.progress import TimeElapsedColumn
        console = Console(stderr=True)
        console.print("starting [bold]4[/] tiles")
        columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn())
        with Progress(*columns, transient=True, console=console) as bar:
            task = bar.add_task("irradiance: 4 tiles", total=4)
            for _ in range(4):
                time.sleep(0.3)
                bar.advance(task)
                bar.refresh()
        console.print("4 tiles -> out.tif")
        """,
    )
    progress: list[float] = []
    messages: list[str] = []
    result = run_command(command, on_progress=progress.append, on_message=messages.append)
    assert messages == ["starting 4 tiles", "4 tiles -> out.tif"] == result.messages
    assert progress == sorted(progress)
    assert {0.25, 0.5, 0.75, 1.0} <= set(progress)


def test_the_toolkits_bar_passes_its_estimated_time_left(tmp_path: Path) -> None:
    """The bar of the tiled stages (:func:`nightlights._progress.progress_bar`) is read for
    its fraction and, once rich has an estimate, its time left."""
    command = _script(
        tmp_path,
        """
        import time
        from nightlights._progress import progress_bar
        with progress_bar(True) as bar:
            task = bar.add_task("darkness: 6 tiles", total=6)
            for _ in range(6):
                time.sleep(0.3)
                bar.advance(task)
                bar.refresh()
        """,
    )
    progress: list[float] = []
    left: list[str] = []
    run_command(command, on_progress=progress.append, on_remaining=left.append)
    assert {0.5, 1.0} <= set(progress)
    assert left, "no time left was passed on"
    assert all(parse_remaining(f"1/6 0:00:01 eta {text}") == text for text in left)
    assert all(text.startswith("0:00:0") for text in left)  # 6 x 0.3 s in all


def test_parse_remaining_reads_the_eta_column_only() -> None:
    assert parse_remaining("\x1b[2Kdarkness ━━━━  3/40 0:00:12 eta 0:02:28") == "0:02:28"
    assert parse_remaining("darkness ━━━━  0/40 0:00:00 eta -:--:--") is None
    assert parse_remaining("kernel ━━━━  1/2 0:00:05") is None  # elapsed time only
    assert parse_remaining("beta 0:00:01") is None


def test_parse_progress_reads_both_rich_columns_and_nothing_else() -> None:
    assert parse_progress("\x1b[2Kkernel ━━━━━━━━━━━━━━━━━━━━    1/2 0:00:05") == 0.5
    assert parse_progress("sampling evidence patterns   0% -:--:--") == 0.0
    assert parse_progress("darkness: one FFT ━━━━━━━━━━ 1/1 0:00:00") == 1.0
    assert parse_progress("zenith over 40 x 27 cells: brightest 18.61 -> dark.tif") is None
    assert parse_progress("ratio 3/4 of the streets") is None  # no time column after it
    assert parse_progress("tiles 0/0 0:00:00") is None


def test_a_failing_command_reports_its_last_line(tmp_path: Path) -> None:
    command = _script(
        tmp_path,
        """
        import sys
        print("working", file=sys.stderr)
        print("Error: InputError: lights.gpkg: no luminaires", file=sys.stderr)
        sys.exit(1)
        """,
    )
    with pytest.raises(CommandError, match=r"^Error: InputError: lights.gpkg: no luminaires$"):
        run_command(command)


def test_a_missing_executable_is_a_command_error(tmp_path: Path) -> None:
    with pytest.raises(CommandError, match="cannot start"):
        run_command([str(tmp_path / "no-such-command")])


@pytest.mark.skipif(os.name != "posix", reason="process groups and SIGINT are POSIX")
def test_cancel_interrupts_the_command_and_its_children(tmp_path: Path) -> None:
    """Cancel sends SIGINT to the command's process group: the command's cleanup runs (as the
    toolkit's atomic writes remove their temporaries), and a child it started stops too."""
    marker = tmp_path / "cleaned"
    child_pid = tmp_path / "child.pid"
    command = _script(
        tmp_path,
        f"""
        import subprocess, sys, time
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
        open({str(child_pid)!r}, "w").write(str(child.pid))
        print("started", flush=True)
        try:
            time.sleep(60)
        except KeyboardInterrupt:
            open({str(marker)!r}, "w").write("yes")
            raise
        """,
    )
    messages: list[str] = []
    start = time.monotonic()
    with pytest.raises(CommandCanceled):
        run_command(
            command,
            on_message=messages.append,
            is_canceled=lambda: "started" in messages,
            kill_after=5.0,
        )
    assert time.monotonic() - start < 10.0
    assert marker.read_text() == "yes"
    pid = int(child_pid.read_text())
    deadline = time.monotonic() + 5.0
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(pid)


@pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")
def test_a_command_that_ignores_sigint_is_killed(tmp_path: Path) -> None:
    command = _script(
        tmp_path,
        """
        import signal, time
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("started", flush=True)
        time.sleep(60)
        """,
    )
    messages: list[str] = []
    start = time.monotonic()
    with pytest.raises(CommandCanceled):
        run_command(
            command,
            on_message=messages.append,
            is_canceled=lambda: "started" in messages,
            kill_after=0.5,
        )
    assert time.monotonic() - start < 10.0


def _alive(pid: int) -> bool:
    done = subprocess.run(["ps", "-o", "stat=", "-p", str(pid)], capture_output=True, text=True)
    state = done.stdout.strip()
    return bool(state) and not state.startswith("Z")


def test_child_environment_drops_qgis_paths_and_forces_the_bars() -> None:
    host = {
        "PATH": "/usr/bin",
        "PYTHONPATH": "/usr/share/qgis/python",
        "GDAL_DATA": "/usr/share/gdal",
        "PROJ_LIB": "/usr/share/proj",
        "PROJ_DATA": "/usr/share/proj",
    }
    env = child_environment(host)
    assert env["PATH"] == "/usr/bin"
    assert not set(runner.HOST_VARIABLES) & set(env)
    assert env["TTY_COMPATIBLE"] == env["TTY_INTERACTIVE"] == "1"
    assert env["PYTHONIOENCODING"] == "utf-8"


def _executable(path: Path) -> Path:
    path.write_text("#!/bin/sh\n", encoding="utf-8")
    path.chmod(0o755)
    return path


def test_find_command_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    setting = _executable(tmp_path / "from-setting")
    variable = _executable(tmp_path / "from-variable")
    recorded = _executable(tmp_path / "recorded")
    on_path = tmp_path / "bin"
    on_path.mkdir()
    _executable(on_path / "nightlights")
    plugin = tmp_path / "plugin"
    plugin.mkdir()
    (plugin / runner.TOOLKIT_FILE).write_text(json.dumps({"command": str(recorded)}))
    monkeypatch.setenv("PATH", str(on_path))
    monkeypatch.setenv(runner.COMMAND_VARIABLE, str(variable))
    assert find_command(str(setting), plugin) == [str(setting)]
    assert find_command("", plugin) == [str(variable)]
    monkeypatch.delenv(runner.COMMAND_VARIABLE)
    assert find_command(None, plugin) == [str(recorded)]
    recorded.unlink()
    assert find_command(None, plugin) == [str(on_path / "nightlights")]


def test_find_command_names_what_it_tried(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv(runner.COMMAND_VARIABLE, raising=False)
    missing = str(tmp_path / "gone" / "nightlights")
    with pytest.raises(CommandError, match=r"was not found; tried .*gone/nightlights .*PATH"):
        find_command(missing, tmp_path)
