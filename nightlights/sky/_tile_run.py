"""The engines of the tiled darkness map (:mod:`nightlights.sky.tiled`): one tile's zenith,
and every tile on local threads or as tasks of a ``dask.distributed`` cluster, reused from and
written to the tile store, handed to the output as they finish, with progress and ETA.

The near field of a geographic map. Moving flux onto a tile's local grid and the zenith back
places a source within about half a cell, which is a second-order error for distant sources
but not for the nearest ones, whose light falls as a high power of distance: a dark site a
few cells from a village read 23 % low from the lights within 3 km
(``benchmarks/bench_country.py``). So the zenith tables are split between a near and a far
part that add up to the whole table in every distance bin (Dobashi et al. 2023, Eq. 9 is
linear in the tables): weight :math:`w_i = 1` below :math:`R/2`, 0 beyond :math:`R`, linear in
:math:`\\ln r` between, at bin centre :math:`r_i` (:func:`near_taper`). The far part goes
through the local grid; the near part is summed on the output grid itself
(:func:`near_field`), whose cells a few kilometres around an observer are a rectangle of
:math:`R_q \\cos\\varphi\\, \\Delta\\lambda` by :math:`R_q\\, \\Delta\\varphi` metres to
:math:`10^{-6}` (the grid's own geometry, no resampling).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

import numpy as np
from affine import Affine

from nightlights._progress import progress_bar
from nightlights._typing import FloatArray
from nightlights.sky._tiles import (
    AUTHALIC_RADIUS,
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

#: Radius of the near field summed on a geographic output grid itself, in its cells'
#: north-south size (:func:`near_field`) [1]: the least worst-site error of
#: ``benchmarks/bench_darkness_near_field.py`` (0.30 % at 8; 11.6 % without, 0.40 % at 4).
NEAR_CELLS = 8
#: Most relative change of the east-west cell size within a band of output rows whose near
#: field is summed on one cell size (:func:`near_bands`): distances err by half of it [1].
NEAR_SPREAD = 2e-3
#: Most output rows in such a band [1].
NEAR_ROWS = 256

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
    out = sample_back(values, local, grid.crs, grid.transform, window)
    if plan.near_zenith is not None:
        out += near_field(grid.emission, plan, window, workers)
    return out


def near_taper(edges: FloatArray, radius: float) -> FloatArray:
    """The near field's share of each distance bin: 1 at bin centres below ``radius`` / 2, 0
    beyond ``radius``, linear in ln r between.

    Examples
    --------
    >>> near_taper(np.array([100.0, 200.0, 400.0, 800.0, 1600.0]), 800.0).round(3).tolist()
    [1.0, 1.0, 0.5, 0.0]
    """
    centres = np.sqrt(edges[:-1] * edges[1:])
    inner = radius / 2.0
    return np.clip(np.log(radius / centres) / math.log(radius / inner), 0.0, 1.0)


def near_bands(transform: Affine, r0: int, r1: int) -> list[tuple[int, int]]:
    """Bands (row0, row1) of rows ``r0 .. r1 - 1`` of a geographic grid within which the
    east-west cell size, R cos(latitude), changes by at most :data:`NEAR_SPREAD` (and at
    most :data:`NEAR_ROWS` rows).

    Examples
    --------
    >>> from affine import Affine
    >>> len(near_bands(Affine(1 / 240, 0, 0, 0, -1 / 240, 61.0), 0, 480))  # 60-61 N
    32
    """
    bands = []
    top = r0
    step = math.radians(abs(transform.e))
    while top < r1:
        latitude = math.radians(transform.f + transform.e * (top + 0.5))
        slope = abs(math.tan(latitude)) * step  # relative change of cos per row
        rows = NEAR_ROWS if slope == 0 else int(min(NEAR_ROWS, max(1, NEAR_SPREAD / slope)))
        bands.append((top, min(top + rows, r1)))
        top += rows
    return bands


def near_field(
    emission: Emission, plan: Any, window: tuple[int, int, int, int], workers: int
) -> FloatArray:
    """The near field's zenith [cd m-2] on a window of a geographic emission's own grid, band
    by band (:func:`near_bands`), each on cells of its centre row's size."""
    r0, r1, c0, c1 = window
    t = emission.transform
    north = AUTHALIC_RADIUS * math.radians(abs(t.e))
    plans = []
    for top, bottom in near_bands(t, r0, r1):
        latitude = math.radians(t.f + t.e * 0.5 * (top + bottom))
        east = max(AUTHALIC_RADIUS * math.radians(abs(t.a)) * math.cos(latitude), 1e-3 * north)
        plans.append((top, bottom, plan.near_plan((east, north))))
    a = max(p.depth[0] for *_, p in plans)
    b = max(p.depth[1] for *_, p in plans)
    flux = cell_flux(emission, (r0 - a, r1 + a, c0 - b, c1 + b))  # read once for the tile
    out = np.empty((r1 - r0, c1 - c0))
    for top, bottom, near in plans:
        da, db = near.depth
        rows = slice(top - r0 + a - da, bottom - r0 + a + da)
        part = [band[rows, b - db : b + c1 - c0 + db] for band in flux]
        region = (da, da + bottom - top, db, db + c1 - c0)
        out[top - r0 : bottom - r0] = near.convolve(
            part, near.flat_source, near.flat_eye, region, workers
        )
    return out


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
