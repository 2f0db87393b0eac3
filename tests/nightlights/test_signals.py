"""Ctrl-C and SIGTERM held during compiled work and handed on between batches
(``nightlights._signals``)."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator

import pytest

from nightlights._signals import deliver_signals, held_signals


@pytest.fixture
def recorded_sigterm() -> Iterator[list[int]]:
    """A Python SIGTERM handler that records signals (so the test process survives)."""
    received: list[int] = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: received.append(signum))
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_ctrl_c_waits_for_the_end_of_the_batch() -> None:
    handler = signal.getsignal(signal.SIGINT)
    batches: list[int] = []
    with pytest.raises(KeyboardInterrupt):
        with held_signals():
            for batch in range(3):
                if batch == 1:
                    os.kill(os.getpid(), signal.SIGINT)  # arrives inside the batch
                batches.append(batch)  # the batch runs to its end
                deliver_signals()
    assert batches == [0, 1]
    assert signal.getsignal(signal.SIGINT) is handler


def test_a_signal_held_at_the_end_of_the_block_is_handed_on(recorded_sigterm: list[int]) -> None:
    with held_signals():
        with held_signals():  # nested: the outermost restores the handlers
            os.kill(os.getpid(), signal.SIGTERM)
            assert recorded_sigterm == []
        assert recorded_sigterm == []
    assert recorded_sigterm == [signal.SIGTERM]
    deliver_signals()  # outside a block: nothing held, nothing happens
    assert recorded_sigterm == [signal.SIGTERM]


def test_nested_blocks_deliver_between_batches(recorded_sigterm: list[int]) -> None:
    with held_signals():
        with held_signals():
            os.kill(os.getpid(), signal.SIGTERM)
            deliver_signals()
            assert recorded_sigterm == [signal.SIGTERM]


def test_default_and_ignored_actions_are_left_alone() -> None:
    previous = signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        with held_signals():
            assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
            assert signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_worker_thread_holds_nothing() -> None:
    seen: list[object] = []

    def work() -> None:
        with held_signals():
            seen.append(signal.getsignal(signal.SIGINT))
            deliver_signals()

    thread = threading.Thread(target=work)
    thread.start()
    thread.join()
    assert seen == [signal.getsignal(signal.SIGINT)]
