"""Dask helpers shared by the tiled and chunked stages: progress per task, distributed runs."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dask.callbacks import Callback

__all__ = ["SCHEDULER_TIMEOUT", "TaskProgress", "compute_distributed"]

#: How long to try to reach a ``--scheduler`` address before giving up [s].
SCHEDULER_TIMEOUT = 30.0


class TaskProgress(Callback):
    """A Dask local-scheduler callback that advances a progress bar per finished task.

    Parameters
    ----------
    advance
        Called once per finished task whose key starts with ``prefix``.
    prefix
        Key prefix of the tasks to count.
    """

    def __init__(self, advance: Callable[[], None], prefix: str) -> None:
        super().__init__()
        self._advance = advance
        self._prefix = prefix

    def _posttask(self, key: Any, result: Any, dsk: Any, state: Any, worker_id: Any) -> None:
        name = key[0] if isinstance(key, tuple) else key
        if str(name).startswith(self._prefix):
            self._advance()


def compute_distributed(
    tasks: list[Any],
    scheduler: str | Any,
    advance: Callable[[], None],
    consume: Callable[[int, Any], Any] | None = None,
) -> list[Any]:
    """Compute Dask tasks on a ``dask.distributed`` cluster, in order, with progress.

    Parameters
    ----------
    tasks
        Dask collections or delayed objects.
    scheduler
        A scheduler address (``tcp://...``) or a ``distributed.Client``; a client made from
        an address is closed afterwards. An address that cannot be reached within
        :data:`SCHEDULER_TIMEOUT` is an error.
    advance
        Called once per finished task.
    consume
        Called in this process as ``consume(index, result)`` as each result arrives; its
        return value is kept in place of the result (which is then released).

    Returns
    -------
    list
        The results (or what ``consume`` returned) in the order of ``tasks``; on the first
        failure the rest are cancelled and the exception re-raised.

    Raises
    ------
    InputError
        ``scheduler`` is an address that is malformed or cannot be reached in time.
    """
    from distributed import Client, as_completed

    own_client = not isinstance(scheduler, Client)
    client = _connect(scheduler) if own_client else scheduler
    assert isinstance(client, Client)
    try:
        futures = client.compute(tasks)
        position = {future.key: index for index, future in enumerate(futures)}
        results: list[Any] = [None] * len(futures)
        try:
            for future in as_completed(futures):
                index = position[future.key]
                result = future.result()
                future.release()
                results[index] = result if consume is None else consume(index, result)
                advance()
        except BaseException:
            client.cancel(futures)
            raise
        return results
    finally:
        if own_client:
            client.close()


def _connect(address: str) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or an InputError."""
    from distributed import Client

    from nightlights.errors import InputError

    try:
        return Client(address, set_as_default=False, timeout=SCHEDULER_TIMEOUT)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(
            f"scheduler={address!r}: cannot connect to a dask scheduler: {exc}; expected "
            "the address of a running scheduler, e.g. tcp://host:8786"
        ) from None
