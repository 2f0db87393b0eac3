"""The engines of the tiled darkness map (:mod:`nightlights.sky.tiled`): one tile's zenith,
and every tile on local threads or as tasks of a ``dask.distributed`` cluster, reused from and
written to the tile store, handed to the output as they finish, with progress and ETA.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

from affine import Affine

from nightlights._progress import progress_bar
from nightlights._typing import FloatArray
from nightlights.sky._tiles import (
    Emission,
    LocalGrid,
    TileStore,
    cell_flux,
    deposit,
    local_grid,
    sample_back,
    source_window,
    tile_windows,
)

#: ``progress=`` as a callable: called ``hook(done, total)`` after every tile [1].
ProgressHook = Callable[[int, int], None]

#: Private hooks for tests: a delay in every tile [s] (travels with the tiles to the
#: workers), and a call after every tile written (in this process).
_TILE_DELAY = 0.0
_AFTER_TILE: Callable[[int], None] | None = None


@dataclass(frozen=True)
class TiledGrid:
    """Everything a tile needs but the plan (picklable, sent to the workers).

    Attributes
    ----------
    emission
        Where the flux density is read.
    crs, transform, shape
        The output grid.
    local
        Whether tiles are computed on local metric grids (geographic emission or another
        output grid), else on the emission's own cells.
    cell
        The local grid's cell, or the emission's [m].
    half
        Stencil radius (rows, cols) [cells].
    tile
        Tile edge [cells of the output grid].
    delay
        Seconds to sleep in every tile (tests only) [s].
    """

    emission: Emission
    crs: str
    transform: Affine
    shape: tuple[int, int]
    local: bool
    cell: float
    half: tuple[int, int]
    tile: int
    delay: float = 0.0

    def windows(self) -> list[tuple[int, int, int, int, int, int]]:
        """The tiles (tile row, tile col, row0, row1, col0, col1)."""
        return tile_windows(self.shape, self.tile)

    def local_grid(self, window: tuple[int, int, int, int]) -> LocalGrid:
        """The local metric grid of a tile."""
        return local_grid(self.crs, self.transform, window, self.cell, self.half)


def tile_luminance(
    grid: TiledGrid, plan: Any, window: tuple[int, int, int, int], fft_workers: int | None = None
) -> FloatArray:
    """The zenith luminance of one tile [cd m-2] (flat terrain, the plan's levels).

    Parameters
    ----------
    grid
        The map's grids.
    plan
        The shared plan (:class:`nightlights.sky.darkness._Plan`).
    window
        (row0, row1, col0, col1) of the output grid.
    fft_workers
        Threads of each FFT; None: one in a pool of tile threads, else all cores [1].
    """
    if grid.delay:
        time.sleep(grid.delay)
    r0, r1, c0, c1 = window
    a, b = plan.depth
    workers = fft_workers if fft_workers is not None else (1 if _in_pool() else -1)
    if not grid.local:
        flux = cell_flux(grid.emission, (r0 - a, r1 + a, c0 - b, c1 + b))
        region = (a, a + r1 - r0, b, b + c1 - c0)
        return plan.convolve(list(flux), plan.flat_source, plan.flat_eye, region, workers)
    local = grid.local_grid(window)
    planes = deposit(grid.emission, source_window(grid.emission, local), local)
    values = plan.convolve(planes, plan.flat_source, plan.flat_eye, local.interior, workers)
    del planes
    return sample_back(values, local, grid.crs, grid.transform, window)


def _in_pool() -> bool:
    """Whether this thread is one of several computing tiles (then each FFT uses one)."""
    return threading.current_thread().name.startswith("darkness-tile")


def compute_tile(
    grid: TiledGrid,
    plan: Any,
    window: tuple[int, int, int, int, int, int],
    location: str,
    token: str,
) -> tuple[int, int]:
    """Compute a tile and store it (a task of a distributed run: one FFT thread, as each of a
    worker's threads runs a tile); its index."""
    tile = (window[0], window[1])
    values = tile_luminance(grid, plan, window[2:], fft_workers=1)
    TileStore(location, token).write(tile, values)
    return tile


# --- the run ------------------------------------------------------------------------------------


class _Progress:
    """A rich tile bar with ETA, or the caller's ``hook(done, total)``, or nothing."""

    def __init__(self, progress: bool | ProgressHook, total: int, description: str) -> None:
        self.total, self.done = total, 0
        self._hook = progress if callable(progress) else None
        self._bar = progress_bar(progress is True)
        self._task = self._bar.add_task(description, total=total)

    def __enter__(self) -> _Progress:
        self._bar.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self._bar.__exit__(None, None, None)

    def advance(self) -> None:
        self.done += 1
        self._bar.advance(self._task)
        if self._hook is not None:
            self._hook(self.done, self.total)


def run_tiles(
    grid: TiledGrid,
    plan: Any,
    write: Callable[[int, int, FloatArray], None],
    *,
    store: TileStore | None,
    resume: bool,
    scheduler: Any | None,
    workers: int,
    retries: int,
    progress: bool | ProgressHook,
) -> tuple[int, int]:
    """Compute every tile (or reuse it from the store) and hand it to ``write(row0, col0,
    luminance)`` in this process; the numbers of tiles computed and reused."""
    windows = grid.windows()
    stored = {w[:2] for w in windows if store is not None and resume and store.has(w[:2])}
    reused = 0
    description = f"darkness: {len(windows)} tiles"
    with _Progress(progress, len(windows), description) as bar:

        def finish(window: tuple[int, int, int, int, int, int], values: FloatArray) -> None:
            write(window[2], window[4], values)
            bar.advance()
            if _AFTER_TILE is not None:
                _AFTER_TILE(bar.done)

        for window in windows:
            if window[:2] in stored:
                assert store is not None
                finish(window, store.read(window[:2]))
                reused += 1
        todo = [w for w in windows if w[:2] not in stored]
        if scheduler is not None:
            assert store is not None
            _distributed(grid, plan, todo, store, scheduler, retries, finish)
        else:
            _threads(grid, plan, todo, store, workers, finish)
    return len(windows) - reused, reused


def _threads(
    grid: TiledGrid,
    plan: Any,
    todo: list[tuple[int, int, int, int, int, int]],
    store: TileStore | None,
    workers: int,
    finish: Callable[[tuple[int, int, int, int, int, int], FloatArray], None],
) -> None:
    """The tiles on a local thread pool (at most ``workers`` in flight, and their results)."""

    def one(window: tuple[int, int, int, int, int, int]) -> FloatArray:
        values = tile_luminance(grid, plan, window[2:])
        if store is not None:
            store.write(window[:2], values)
        return values

    if workers <= 1:
        for window in todo:
            finish(window, one(window))
        return
    with ThreadPoolExecutor(workers, thread_name_prefix="darkness-tile") as pool:
        pending: dict[Future[FloatArray], tuple[int, int, int, int, int, int]] = {}
        queue = list(reversed(todo))
        try:
            while queue or pending:
                while queue and len(pending) < workers:
                    window = queue.pop()
                    pending[pool.submit(one, window)] = window
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    finish(pending.pop(future), future.result())
        except BaseException:
            for future in pending:
                future.cancel()
            raise


def _distributed(
    grid: TiledGrid,
    plan: Any,
    todo: list[tuple[int, int, int, int, int, int]],
    store: TileStore,
    scheduler: Any,
    retries: int,
    finish: Callable[[tuple[int, int, int, int, int, int], FloatArray], None],
) -> None:
    """The tiles as tasks of a ``dask.distributed`` cluster, read back from the store."""
    from distributed import Client, as_completed

    from nightlights._parallel import _connect

    own = not isinstance(scheduler, Client)
    client = _connect(scheduler) if own else scheduler
    try:
        shared = client.scatter(plan, broadcast=True, hash=False)
        futures = {
            client.submit(
                compute_tile,
                grid,
                shared,
                window,
                store.location,
                store.token,
                key=f"darkness-tile-{store.token}-{window[0]}-{window[1]}",
                retries=retries,
                pure=False,
            ): window
            for window in todo
        }
        try:
            for future in as_completed(futures, loop=client.loop):
                tile = future.result()
                future.release()
                finish(futures[future], store.read(tile))
        except BaseException:
            client.cancel(list(futures))
            raise
    finally:
        if own:
            client.close()
