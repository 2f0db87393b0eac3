"""Ctrl-C and ``SIGTERM`` held while compiled, threaded work runs, handed on between batches.

Python runs a signal handler between two bytecodes of the main thread. During a call into
compiled code (a numba ``parallel=True`` function) there are none, so the handler runs as the
call returns, while numba turns its results into Python objects; the ``KeyboardInterrupt``
that Python's Ctrl-C handler raises there leaves an exception set in the middle of that
conversion, and the process ends in a ``SystemError`` or a segmentation fault instead of the
command line's "Aborted!".

:func:`held_signals` replaces, for the duration of a block, the Python handlers of ``SIGINT``
and ``SIGTERM`` by one that only records the signal. The block runs its compiled work in
batches and calls :func:`deliver_signals` between two of them: a recorded signal is handed
to the handler that was there before (Python's ``KeyboardInterrupt``, the
:class:`~nightlights.io.outputs.Terminated` of an open output), in ordinary Python code. When
the outermost block ends the previous handlers are restored and a signal still held is handed
on. Handlers that are not Python functions (the default action, ignore) are left as they are,
and only the main thread, where Python runs its handlers, holds anything.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Any

__all__ = ["HELD_SIGNALS", "deliver_signals", "held_signals"]

#: The signals held: Ctrl-C and a batch scheduler's ``SIGTERM``.
HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Holder:
    """The handlers replaced and the signals recorded while a block holds them (main thread)."""

    def __init__(self) -> None:
        self.depth = 0
        self.previous: dict[int, Any] = {}
        self.pending: list[tuple[int, FrameType | None]] = []

    def record(self, signum: int, frame: FrameType | None) -> None:
        if all(held != signum for held, _ in self.pending):
            self.pending.append((signum, frame))

    def deliver(self) -> None:
        while self.pending:
            signum, frame = self.pending.pop(0)
            handler = self.previous.get(signum)
            if callable(handler):
                handler(signum, frame)


_HOLDER = _Holder()


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def held_signals() -> Iterator[None]:
    """Hold ``SIGINT`` and ``SIGTERM`` during the block; hand them on at
    :func:`deliver_signals` or when the block ends.

    Blocks nest (the outermost installs and restores the handlers); in a thread other than
    the main thread the block holds nothing.

    Examples
    --------
    >>> with held_signals():
    ...     for batch in range(3):
    ...         pass  # compiled work: a Ctrl-C now waits for the end of the batch
    ...         deliver_signals()  # ... and is raised here as KeyboardInterrupt
    """
    if not _main_thread():
        yield
        return
    if _HOLDER.depth == 0:
        _HOLDER.pending.clear()
        _HOLDER.previous = {}
        for signum in HELD_SIGNALS:
            previous = signal.getsignal(signum)
            if callable(previous):
                _HOLDER.previous[signum] = previous
                signal.signal(signum, _HOLDER.record)
    _HOLDER.depth += 1
    try:
        yield
    finally:
        _HOLDER.depth -= 1
        if _HOLDER.depth == 0:
            for held, handler in _HOLDER.previous.items():
                signal.signal(held, handler)
            _HOLDER.deliver()


def deliver_signals() -> None:
    """Hand a signal held by :func:`held_signals` to its previous handler now (which raises
    ``KeyboardInterrupt`` for Ctrl-C); call it between two batches of compiled work."""
    if _main_thread() and _HOLDER.depth:
        _HOLDER.deliver()
