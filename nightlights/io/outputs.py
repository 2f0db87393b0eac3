"""All-or-nothing outputs: every location checked first, temporaries, one commit at the end.

A stage that writes several files (a NetCDF and a PNG, a raster and its summary) opens one
:class:`OutputSet` for all of them *before* it computes anything. The set checks every location
at once (the folder exists and takes a file, no output is named twice, no output is a folder,
enough free disk space), hands out a temporary path beside each output, and renames every
temporary onto its output only when the whole block has succeeded. On an error, Ctrl-C or a
``SIGTERM`` from a batch scheduler, every temporary (and the side files GDAL writes beside it,
such as ``.ovr.tmp`` overviews and ``.aux.xml``) is removed and the previous outputs stay as
they were.

``SIGTERM`` is handled only while an output is open and only in the main thread: the handler
raises :class:`Terminated` (a :class:`KeyboardInterrupt`) to unwind the ``with`` blocks; when
the outermost one has cleaned up, the previous handler is restored and the signal is delivered
again, so the process still ends as terminated (exit status 143 from a shell). A signal that
arrives while the outputs are being renamed is held until the renaming is done. Python runs
signal handlers between bytecodes, so a signal that arrives during a long call into GDAL takes
effect when that call returns.

No output replaces an input. A stage names its input files when it opens its outputs
(``OutputSet(..., inputs={"emission": path, "dem": dem})``) and an output that is the same
file as one of them (the same path relative or absolute, through a symbolic link, a hard link
or another spelling on a case-insensitive disk), that would replace a file inside an input
folder, or that is a folder holding an input, is refused before any work, with or without
overwrite (:func:`refuse_replacing_inputs`).

``SIGTERM`` can also be turned into :class:`Terminated` for a whole block that writes through
several output sets in turn (:func:`terminate_cleanly`), so that the clean-up of the block
(a project stage's staging folder) runs between two of them as well.

A writer may leave a style sidecar beside a temporary (a ``.qml`` of the same name, which
QGIS reads as the layer's default style: :data:`SIDECAR_SUFFIXES`); it is renamed onto the
output's sidecar together with the output, and removed with the temporary.
"""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any

from nightlights._resources import format_bytes
from nightlights.errors import OutputError

__all__ = [
    "SIDECAR_SUFFIXES",
    "OutputSet",
    "Terminated",
    "refuse_replacing_inputs",
    "replaced_input",
    "sidecar_paths",
    "terminate_cleanly",
]

PathLike = str | os.PathLike[str]
#: A stage's inputs by name (its parameter, or an option on the command line): a path, None,
#: an in-memory object (skipped: it is no file) or a sequence of them.
Inputs = Mapping[str, object]

#: Side files that travel with an output: the temporary's name with this suffix is renamed
#: onto the output's name with it (QGIS's default-style ``.qml`` beside a raster).
SIDECAR_SUFFIXES = (".qml",)


def sidecar_paths(path: PathLike) -> list[Path]:
    """Where the sidecars of an output go (:data:`SIDECAR_SUFFIXES`), whether or not they exist.

    Code that moves a finished output elsewhere moves the existing ones with it, onto the
    sidecar paths of the destination.

    Examples
    --------
    >>> [p.name for p in sidecar_paths("out/emission.tif")]
    ['emission.qml']
    """
    path = Path(path)
    if path.suffix in SIDECAR_SUFFIXES:
        return []
    return [path.with_suffix(suffix) for suffix in SIDECAR_SUFFIXES]


class Terminated(KeyboardInterrupt):
    """``SIGTERM`` arrived while an output was open; raised to remove the temporaries."""


class _TerminationGuard:
    """Turns ``SIGTERM`` into :class:`Terminated` while outputs are open (main thread only).

    Nested outputs share one handler: the outermost installs it and, on leaving, restores the
    previous handler and delivers a received ``SIGTERM`` to it.
    """

    def __init__(self) -> None:
        self._depth = 0
        self._holds = 0
        self._previous: Any = None
        self._installed = False
        self._received = False
        self._raised = False

    @staticmethod
    def _main_thread() -> bool:
        return threading.current_thread() is threading.main_thread()

    def enter(self) -> None:
        if not self._main_thread():
            return
        if self._depth == 0:
            self._previous = signal.getsignal(signal.SIGTERM)
            self._received = self._raised = False
            # A handler installed outside Python (None) cannot be restored; SIG_IGN is a choice.
            self._installed = self._previous not in (None, signal.SIG_IGN)
            if self._installed:
                signal.signal(signal.SIGTERM, self._handle)
        self._depth += 1

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self._received = True
        if self._holds == 0 and not self._raised:
            self._raised = True
            raise Terminated(f"terminated by signal {signum}")

    @contextlib.contextmanager
    def hold(self, *, deliver: bool = False) -> Iterator[None]:
        """Hold a ``SIGTERM`` until the block (a commit, a clean-up, a reservation) has
        finished; with ``deliver``, raise it as soon as the block ends."""
        if not self._main_thread():
            yield
            return
        self._holds += 1
        try:
            yield
        finally:
            self._holds -= 1
        if deliver and self._holds == 0 and self._received and not self._raised:
            self._raised = True
            raise Terminated(f"terminated by signal {int(signal.SIGTERM)}")

    def exit(self) -> None:
        if not self._main_thread() or self._depth == 0:
            return
        self._depth -= 1
        if self._depth or not self._installed:
            return
        signal.signal(signal.SIGTERM, self._previous)
        self._installed = False
        if self._received:
            self._received = False
            signal.raise_signal(signal.SIGTERM)


_GUARD = _TerminationGuard()


@contextlib.contextmanager
def terminate_cleanly() -> Iterator[None]:
    """Turn ``SIGTERM`` into :class:`Terminated` for the whole block (main thread only).

    Output sets already do so while they are open; a block that writes through several of
    them in turn, and keeps something to clean up between them (a project stage's staging
    folder), wraps them in this so that a ``SIGTERM`` between two outputs unwinds it as
    Ctrl-C does. When the block has been left, the signal is delivered again to the previous
    handler, so the process still ends as terminated (exit status 143 from a shell).

    Examples
    --------
    >>> with terminate_cleanly():
    ...     pass  # SIGTERM here raises Terminated, and the process ends after the clean-up
    """
    _GUARD.enter()
    try:
        yield
    finally:
        _GUARD.exit()


def _reason(exc: OSError) -> str:
    if isinstance(exc, PermissionError):
        return "permission denied"
    return exc.strerror or str(exc)


def _remove_with_side_files(path: Path) -> None:
    """Remove ``path`` and every file whose name starts with its name (GDAL side files)."""
    pattern = os.path.join(glob.escape(str(path.parent)), glob.escape(path.name) + "*")
    for name in {str(path), *glob.glob(pattern)}:
        with contextlib.suppress(FileNotFoundError, IsADirectoryError):
            os.unlink(name)


# --- no output replaces an input -----------------------------------------------------------------


def _input_paths(inputs: Inputs | None) -> list[tuple[str, Path]]:
    """The inputs that are files or folders on disk, with their names."""
    found: list[tuple[str, Path]] = []
    for name, value in (inputs or {}).items():
        values = value if isinstance(value, list | tuple) else [value]
        for item in values:
            if isinstance(item, str | os.PathLike):
                path = Path(item)
                if os.path.exists(path):  # one that does not exist cannot be replaced
                    found.append((name, path))
    return found


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` lies inside ``folder`` (both resolved, links followed)."""
    return Path(os.path.realpath(folder)) in Path(os.path.realpath(path)).parents


def replaced_input(output: PathLike, inputs: Inputs | None) -> str | None:
    """How writing ``output`` would destroy one of ``inputs``, as a phrase; None if it would not.

    Parameters
    ----------
    output
        An output path (file or folder).
    inputs
        The stage's inputs by name (:data:`Inputs`); the name and path of the input at risk
        become part of the phrase.

    Returns
    -------
    str or None
        ``is the input NAME (PATH)``, ``lies in the input folder NAME (PATH) and would replace
        one of its files`` or ``holds the input NAME (PATH) and would replace it``; None when no
        input is at risk.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> emission = pathlib.Path(tempfile.mkdtemp()) / "e.tif"
    >>> _ = emission.write_text("raster")
    >>> replaced_input(emission, {"emission": emission}).startswith("is the input emission")
    True
    >>> replaced_input(emission.with_name("q.tif"), {"emission": emission}) is None
    True
    """
    out = Path(output)
    if not os.path.exists(out):
        return None  # what does not exist is no input (nor holds one)
    for name, path in _input_paths(inputs):
        if os.path.samefile(out, path):
            return f"is the input {name} ({path})"
        if path.is_dir() and _inside(out, path):
            return f"lies in the input folder {name} ({path}) and would replace one of its files"
        if out.is_dir() and _inside(path, out):
            return f"holds the input {name} ({path}) and would replace it"
    return None


def refuse_replacing_inputs(outputs: Iterable[PathLike | None], inputs: Inputs | None) -> None:
    """Refuse any output that would replace (or lie in, or hold) one of the inputs.

    Parameters
    ----------
    outputs
        Output paths; None entries (outputs not asked for) are skipped.
    inputs
        The stage's inputs by name (:data:`Inputs`).

    Raises
    ------
    OutputError
        Naming the output and the input (:func:`replaced_input`), whatever ``overwrite``.
    """
    for output in outputs:
        if output is None:
            continue
        reason = replaced_input(output, inputs)
        if reason is not None:
            raise OutputError(
                f"{output}: {reason}; an output never replaces an input: choose another output path"
            )


class OutputSet:
    """Outputs of one stage: checked up front, written to temporaries, all renamed at the end.

    Parameters
    ----------
    *paths
        Output paths; None entries (outputs not asked for) are skipped.
    overwrite
        Replace existing files. If False an existing output is an error.
    free_bytes
        Estimated size of all outputs together [B]; each output folder must have this much
        free disk space.
    inputs
        The stage's inputs by name (:data:`Inputs`: paths, None or in-memory objects); an
        output that would replace one is refused (:func:`refuse_replacing_inputs`).

    Raises
    ------
    OutputError
        At construction, naming the path: an output that is an input (or lies in an input
        folder), a folder that does not exist, is not a folder or cannot be written to, an
        output that is a folder, exists (``overwrite=False``) or is named twice, too little
        free disk space. On leaving the block: an output the block did
        not write, or a rename that failed (the outputs renamed before it are restored).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with OutputSet(folder / "a.txt", None, folder / "b.txt") as outputs:
    ...     _ = outputs.temporary(folder / "a.txt").write_text("a")
    ...     _ = outputs.temporary(folder / "b.txt").write_text("b")
    >>> sorted(p.name for p in folder.iterdir())
    ['a.txt', 'b.txt']
    """

    def __init__(
        self,
        *paths: PathLike | None,
        overwrite: bool = True,
        free_bytes: float = 0,
        inputs: Inputs | None = None,
    ) -> None:
        self.paths: tuple[Path, ...] = tuple(Path(p) for p in paths if p is not None)
        self.overwrite = overwrite
        self.free_bytes = float(free_bytes)
        self._temporaries: dict[Path, Path] = {}
        self._entered = False
        refuse_replacing_inputs(self.paths, inputs)
        self._check()

    # --- checks made at construction -------------------------------------------------------

    @staticmethod
    def _key(path: PathLike) -> Path:
        return Path(os.path.abspath(os.fspath(path)))

    def _check(self) -> None:
        seen: dict[Path, Path] = {}
        for path in self.paths:
            key = self._key(path)
            if key in seen:
                raise OutputError(
                    f"{path}: given twice as an output; each output needs its own path"
                )
            seen[key] = path
            if path.is_dir():
                raise OutputError(f"{path}: is a folder; expected a file path")
            if path.exists() and not self.overwrite:
                raise OutputError(f"{path}: exists and overwrite is off")
        for folder in dict.fromkeys(self._folder(path) for path in self.paths):
            self._check_folder(folder, next(p for p in self.paths if self._folder(p) == folder))

    @staticmethod
    def _folder(path: Path) -> Path:
        return path.parent if str(path.parent) else Path(".")

    def _check_folder(self, folder: Path, path: Path) -> None:
        if not folder.exists():
            raise OutputError(f"{path}: output folder {folder} does not exist")
        if not folder.is_dir():
            raise OutputError(f"{path}: {folder} is not a folder")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OutputError(f"{path}: cannot write to folder {folder}: permission denied")
        # A real probe (os.access says yes to root and on read-only mounts), made and removed
        # with SIGTERM held so that a signal cannot leave it behind.
        _GUARD.enter()
        try:
            with _GUARD.hold(deliver=True):
                try:
                    fd, probe = tempfile.mkstemp(
                        prefix=f".{path.name}.", suffix=".probe", dir=folder
                    )
                except OSError as exc:
                    raise OutputError(
                        f"{path}: cannot write to folder {folder}: {_reason(exc)}"
                    ) from exc
                try:
                    os.close(fd)
                finally:
                    os.unlink(probe)
        finally:
            _GUARD.exit()
        if self.free_bytes > 0:
            free = shutil.disk_usage(folder).free
            if free < self.free_bytes:
                raise OutputError(
                    f"{path}: the outputs need about {format_bytes(self.free_bytes)} of disk "
                    f"space, only {format_bytes(free)} is free in {folder}"
                )

    # --- the block ---------------------------------------------------------------------------

    def __enter__(self) -> OutputSet:
        if self._entered:
            raise RuntimeError("an OutputSet can be entered only once")
        self._entered = True
        _GUARD.enter()
        try:
            # held: a signal between making a temporary and recording it would orphan it
            with _GUARD.hold(deliver=True):
                for path in self.paths:
                    self._temporaries[self._key(path)] = self._reserve(path)
        except BaseException:
            self._clean()
            _GUARD.exit()
            raise
        return self

    @staticmethod
    def _reserve(path: Path) -> Path:
        folder = OutputSet._folder(path)
        try:
            fd, name = tempfile.mkstemp(
                prefix=f".{path.name}.", suffix=".tmp" + path.suffix, dir=folder
            )
        except OSError as exc:
            raise OutputError(f"{path}: cannot write to folder {folder}: {_reason(exc)}") from exc
        os.close(fd)
        temporary = Path(name)
        temporary.unlink()  # writers (GDAL) want to create the file themselves
        return temporary

    def temporary(self, path: PathLike) -> Path:
        """The temporary path to write ``path`` to (same folder, same suffix).

        Raises
        ------
        KeyError
            ``path`` is not one of the set's outputs, or the block has not been entered.
        """
        try:
            return self._temporaries[self._key(path)]
        except KeyError:
            raise KeyError(
                f"{path} is not an output of this OutputSet (or it is not open)"
            ) from None

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        try:
            with _GUARD.hold():
                try:
                    if exc_type is None:
                        self._commit()
                finally:
                    self._clean()
        finally:
            _GUARD.exit()

    def _commit(self) -> None:
        pairs = [(self._temporaries[self._key(path)], path) for path in self.paths]
        for temporary, path in pairs:
            if not temporary.exists():
                raise OutputError(f"{path}: the writer produced no file")
        pairs += [
            (side, final)
            for temporary, path in list(pairs)
            for side, final in zip(sidecar_paths(temporary), sidecar_paths(path), strict=True)
            if side.exists()
        ]
        backups: dict[Path, Path] = {}
        done: list[Path] = []
        try:
            for _temporary, path in pairs:
                if path.exists():
                    backup = self._backup(path)
                    if backup is not None:
                        backups[path] = backup
            for temporary, path in pairs:
                try:
                    os.replace(temporary, path)
                except OSError as exc:
                    raise OutputError(f"{path}: cannot write: {_reason(exc)}") from exc
                done.append(path)
        except BaseException:
            for path in reversed(done):  # put the previous outputs back
                with contextlib.suppress(OSError):
                    if path in backups:
                        os.replace(backups.pop(path), path)
                    else:
                        os.unlink(path)
            raise
        finally:
            for backup in backups.values():
                with contextlib.suppress(OSError):
                    os.unlink(backup)

    @staticmethod
    def _backup(path: Path) -> Path | None:
        """A hard link to the existing ``path`` (restored if a later rename fails), or None."""
        backup = path.with_name(f".{path.name}.{os.getpid()}.bak")
        with contextlib.suppress(FileNotFoundError):
            backup.unlink()
        try:
            os.link(path, backup)
        except OSError:
            return None  # no hard links here: the rename stays atomic per file
        return backup

    def _clean(self) -> None:
        for temporary in self._temporaries.values():
            _remove_with_side_files(temporary)
            for side in sidecar_paths(temporary):
                with contextlib.suppress(FileNotFoundError, IsADirectoryError):
                    os.unlink(side)
