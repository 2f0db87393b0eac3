"""Run the installed ``nightlights`` command in a subprocess: progress, messages, cancel.

This module is imported by QGIS's Python, which must not load the toolkit (its pip wheels of
rasterio and pyogrio bundle their own GDAL, which clashes with the GDAL QGIS has loaded). It
uses the standard library only, as QGIS's GRASS and SAGA providers do with their own tools:
the toolkit runs in its own interpreter, found by :func:`find_command`.

Progress: the commands draw rich progress bars on stderr when it is a terminal. The child is
told that stderr is one (``TTY_COMPATIBLE=1``, ``TTY_INTERACTIVE=1``), so the bars are drawn,
and each redraw (text between carriage returns) is parsed for rich's ``M/N`` or ``P%``
column followed by its elapsed or remaining time (:func:`parse_progress`). Every other line
is a message; the last one of a failing command is its one-line error.

Cancel: the child runs in its own process group; a cancel sends SIGINT to the group (the
toolkit's atomic writes then remove their temporary files, so no output that looks complete
is left), then SIGKILL after :data:`KILL_AFTER` seconds if it has not exited.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

#: File of the plugin folder written by ``nightlights qgis-plugin build``: the command it
#: recorded and the toolkit version.
TOOLKIT_FILE = "toolkit.json"
#: Environment variable naming the ``nightlights`` command (overrides the recorded one).
COMMAND_VARIABLE = "NIGHTLIGHTS_COMMAND"
#: Processing setting naming it (Processing > Options > Providers > nightlights).
COMMAND_SETTING = "NIGHTLIGHTS_COMMAND"
#: Variables of QGIS's process that would point the toolkit's own GDAL, PROJ and Python at
#: QGIS's copies; they are removed from the child's environment.
HOST_VARIABLES = (
    "PYTHONPATH",
    "PYTHONHOME",
    "PYTHONSTARTUP",
    "GDAL_DATA",
    "GDAL_DRIVER_PATH",
    "PROJ_LIB",
    "PROJ_DATA",
)
#: Seconds between checks of the cancel flag [s].
POLL_INTERVAL = 0.1
#: Seconds a cancelled command is given to exit after SIGINT before SIGKILL [s].
KILL_AFTER = 10.0
#: Width of the terminal the child draws for [characters] (wide: messages stay one line).
TERMINAL_COLUMNS = 500

_ANSI = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]|\x1b[@-Z\\-_]")
# rich's MofNCompleteColumn or percentage column, followed by its time column
_STEPS = re.compile(r"(?<![\d/])(\d+)/(\d+)\s+(?:\d+:\d\d:\d\d|-:--:--)")
_PERCENT = re.compile(r"(?<![\d.])(\d{1,3})%\s+(?:\d+:\d\d:\d\d|-:--:--)")
# the estimated time left of a bar that shows one (``eta H:MM:SS``)
_REMAINING = re.compile(r"\beta\s+(\d+:\d\d:\d\d)")


class CommandError(Exception):
    """The command could not be found or started, or it failed (one-line message)."""


class CommandCanceled(Exception):
    """The command was cancelled and has exited."""


class CommandResult(NamedTuple):
    """What a finished command wrote: its message lines (ANSI codes removed)."""

    messages: list[str]


def parse_progress(text: str) -> float | None:
    """The fraction done [0-1] shown by one redraw of a rich progress bar, or None.

    Parameters
    ----------
    text
        One segment of the child's stderr (between carriage returns or newlines).

    Examples
    --------
    >>> parse_progress("irradiance: 4 tiles ━━━━━━━━━━       1/4 0:00:02")
    0.25
    >>> parse_progress("sampling evidence patterns ━━━━━━━━━       40% -:--:--")
    0.4
    >>> parse_progress("1637 street parts from 3818 features -> out.gpkg") is None
    True
    """
    text = _ANSI.sub("", text)
    steps = _STEPS.findall(text)
    if steps:
        done, total = (int(value) for value in steps[-1])
        return min(done / total, 1.0) if total > 0 else None
    percent = _PERCENT.findall(text)
    if percent:
        return min(int(percent[-1]) / 100.0, 1.0)
    return None


def parse_remaining(text: str) -> str | None:
    """The estimated time left (``H:MM:SS``) shown by one redraw of a progress bar, or None
    (no estimate yet, or a bar without one).

    Examples
    --------
    >>> parse_remaining("darkness: 40 tiles ━━━━━       3/40 0:00:12 eta 0:02:28")
    '0:02:28'
    >>> parse_remaining("darkness: 40 tiles ━━━━━       0/40 0:00:00 eta -:--:--") is None
    True
    """
    found = _REMAINING.findall(_ANSI.sub("", text))
    return found[-1] if found else None


def is_progress_line(text: str) -> bool:
    """Whether ``text`` is a redraw of a progress bar (not a message)."""
    return parse_progress(text) is not None


def find_command(
    setting: str | None = None, plugin_dir: str | os.PathLike[str] | None = None
) -> list[str]:
    """The ``nightlights`` command line to run, as a list.

    Looked up in this order: ``setting`` (the provider's setting, when not empty), the
    ``NIGHTLIGHTS_COMMAND`` environment variable, the command recorded in the plugin's
    ``toolkit.json`` by ``nightlights qgis-plugin build``, then ``nightlights`` on ``PATH``.

    Parameters
    ----------
    setting
        The path of the ``nightlights`` executable set by the user, or empty.
    plugin_dir
        The plugin folder holding ``toolkit.json`` (default: this module's folder).

    Raises
    ------
    CommandError
        None of them names an existing command.
    """
    tried: list[str] = []
    for source, value in (
        ("the provider setting", setting),
        (f"${COMMAND_VARIABLE}", os.environ.get(COMMAND_VARIABLE)),
        (TOOLKIT_FILE, recorded_command(plugin_dir)),
    ):
        if value:
            found = shutil.which(value) or (value if Path(value).is_file() else None)
            if found:
                return [found]
            tried.append(f"{value} ({source})")
    found = shutil.which("nightlights")
    if found:
        return [found]
    tried.append("nightlights (PATH)")
    raise CommandError(
        "the nightlights command was not found; tried "
        + ", ".join(tried)
        + ". Install the toolkit (pip install . in its checkout; the distribution is "
        "nightlights-gis) and set its path in Processing > "
        "Options > Providers > nightlights, or rebuild the plugin with "
        "`nightlights qgis-plugin build` from the toolkit's environment"
    )


def recorded_command(plugin_dir: str | os.PathLike[str] | None = None) -> str | None:
    """The command recorded in ``toolkit.json`` of ``plugin_dir``, or None."""
    folder = Path(plugin_dir) if plugin_dir is not None else Path(__file__).resolve().parent
    try:
        record = json.loads((folder / TOOLKIT_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    command = record.get("command") if isinstance(record, dict) else None
    return command if isinstance(command, str) else None


def child_environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of the child: ``base`` without :data:`HOST_VARIABLES`, with rich's
    progress bars forced on and UTF-8 output.

    Examples
    --------
    >>> env = child_environment({"PROJ_LIB": "/usr/share/proj", "HOME": "/home/a"})
    >>> "PROJ_LIB" in env, env["HOME"], env["TTY_COMPATIBLE"]
    (False, '/home/a', '1')
    """
    env = {
        key: value
        for key, value in (os.environ if base is None else base).items()
        if key not in HOST_VARIABLES
    }
    env.update(
        {
            "TTY_COMPATIBLE": "1",
            "TTY_INTERACTIVE": "1",
            "NO_COLOR": "1",
            "COLUMNS": str(TERMINAL_COLUMNS),
            "PYTHONIOENCODING": "utf-8",
            "PYTHONUNBUFFERED": "1",
        }
    )
    return env


def run_command(
    command: Sequence[str],
    *,
    on_progress: Callable[[float], None] = lambda fraction: None,
    on_message: Callable[[str], None] = lambda line: None,
    is_canceled: Callable[[], bool] = lambda: False,
    on_remaining: Callable[[str], None] = lambda text: None,
    env: dict[str, str] | None = None,
    kill_after: float = KILL_AFTER,
) -> CommandResult:
    """Run ``command``, reporting its progress and messages, until it exits or is cancelled.

    Parameters
    ----------
    command
        The command line (the executable first).
    on_progress
        Called with the fraction done [0-1] of each progress-bar redraw.
    on_message
        Called with each line that is not a progress bar (ANSI codes removed).
    is_canceled
        Polled every :data:`POLL_INTERVAL` seconds; True stops the command.
    on_remaining
        Called with the estimated time left (``H:MM:SS``) when a bar that shows one
        changes it (:func:`parse_remaining`).
    env
        Environment of the child (default: :func:`child_environment` of this process's).
    kill_after
        Seconds between SIGINT and SIGKILL on cancel [s].

    Returns
    -------
    CommandResult
        The message lines.

    Raises
    ------
    CommandError
        The command could not start, or exited with a non-zero status (the message is its
        last line, the toolkit's one-line error).
    CommandCanceled
        ``is_canceled`` returned True; the command has been stopped.
    """
    popen_options: dict[str, object] = {}
    if os.name == "posix":
        popen_options["start_new_session"] = True  # its own process group, for the cancel
    else:
        popen_options["creationflags"] = getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0)
    try:
        process = subprocess.Popen(
            list(command),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            env=child_environment() if env is None else env,
            **popen_options,  # type: ignore[call-overload]
        )
    except OSError as exc:
        raise CommandError(f"{command[0]}: cannot start ({exc.strerror or exc})") from exc
    output = _Output()
    reader = threading.Thread(target=_read_output, args=(process, output), daemon=True)
    reader.start()
    canceled = False
    while True:
        finished = _wait(process, POLL_INTERVAL)
        if finished:
            reader.join()
        _report(output, on_progress, on_message, on_remaining)
        if finished:
            break
        if not canceled and is_canceled():
            canceled = True
            _stop(process, kill_after)
    messages = output.messages
    if canceled:
        raise CommandCanceled(f"{Path(command[0]).name} cancelled")
    if process.returncode != 0:
        last = next((line for line in reversed(messages) if line.strip()), "")
        raise CommandError(last or f"{Path(command[0]).name} exited with {process.returncode}")
    return CommandResult(messages)


def _wait(process: subprocess.Popen[bytes], timeout: float) -> bool:
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        return False
    return True


class _Output:
    """The child's output as read so far: message lines and the latest progress fraction,
    shared between the reading thread and the polling one (which does all the reporting)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.messages: list[str] = []
        self.reported = 0
        self.fraction: float | None = None
        self.reported_fraction: float | None = None
        self.remaining: str | None = None
        self.reported_remaining: str | None = None

    def add(self, segments: list[bytes]) -> None:
        for raw in segments:
            text = _ANSI.sub("", raw.decode("utf-8", errors="replace")).rstrip()
            if not text:
                continue
            fraction = parse_progress(text)
            remaining = parse_remaining(text) if fraction is not None else None
            with self.lock:
                if fraction is None:
                    self.messages.append(text)
                else:
                    self.fraction = fraction
                    self.remaining = remaining or self.remaining


def _read_output(process: subprocess.Popen[bytes], output: _Output) -> None:
    """Split the child's output at carriage returns and newlines into ``output``."""
    stream = process.stdout
    assert stream is not None
    pending = b""
    while True:
        chunk = os.read(stream.fileno(), 65536)
        if not chunk:
            break
        *segments, pending = re.split(rb"[\r\n]", pending + chunk)
        output.add(segments)
    output.add([pending])
    stream.close()


def _report(
    output: _Output,
    on_progress: Callable[[float], None],
    on_message: Callable[[str], None],
    on_remaining: Callable[[str], None] = lambda text: None,
) -> None:
    """Pass what arrived since the last call to the callbacks (in the calling thread)."""
    with output.lock:
        fresh = output.messages[output.reported :]
        output.reported = len(output.messages)
        fraction = output.fraction if output.fraction != output.reported_fraction else None
        output.reported_fraction = output.fraction
        remaining = output.remaining if output.remaining != output.reported_remaining else None
        output.reported_remaining = output.remaining
    for line in fresh:
        on_message(line)
    if fraction is not None:
        on_progress(fraction)
    if remaining is not None:
        on_remaining(remaining)


def _stop(process: subprocess.Popen[bytes], kill_after: float) -> None:
    """SIGINT to the child's process group (CTRL_BREAK on Windows), SIGKILL if it lingers."""
    try:
        if os.name == "posix":
            os.killpg(process.pid, signal.SIGINT)
        else:
            process.send_signal(getattr(signal, "CTRL_BREAK_EVENT", signal.SIGTERM))
    except (ProcessLookupError, PermissionError):
        return
    deadline = time.monotonic() + kill_after
    while time.monotonic() < deadline:
        if _wait(process, POLL_INTERVAL):
            return
    try:
        if os.name == "posix":
            os.killpg(process.pid, signal.SIGKILL)
        else:
            process.kill()
    except (ProcessLookupError, PermissionError):
        pass
    process.wait()
