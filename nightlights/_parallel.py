"""Dask helpers shared by the tiled and chunked stages: progress per task, distributed runs."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dask.callbacks import Callback

__all__ = ["TaskProgress", "compute_distributed"]


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
    tasks: list[Any], scheduler: str | Any, advance: Callable[[], None]
) -> list[Any]:
    """Compute Dask tasks on a ``dask.distributed`` cluster, in order, with progress.

    Parameters
    ----------
    tasks
        Dask collections or delayed objects.
    scheduler
        A scheduler address (``tcp://...``) or a ``distributed.Client``; a client made from
        an address is closed afterwards.
    advance
        Called once per finished task.

    Returns
    -------
    list
        The results in the order of ``tasks``; on the first failure the rest are cancelled
        and the exception re-raised.
    """
    from distributed import Client, as_completed

    own_client = not isinstance(scheduler, Client)
    client = Client(scheduler, set_as_default=False) if own_client else scheduler
    assert isinstance(client, Client)
    try:
        futures = client.compute(tasks)
        position = {future.key: index for index, future in enumerate(futures)}
        results: list[Any] = [None] * len(futures)
        try:
            for future in as_completed(futures):
                results[position[future.key]] = future.result()
                advance()
        except BaseException:
            client.cancel(futures)
            raise
        return results
    finally:
        if own_client:
            client.close()
