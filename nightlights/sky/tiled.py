"""The darkness map of a country or a continent: out of core, geodesically tiled, distributed
and resumable.

:func:`tiled_darkness` computes the map of :mod:`nightlights.sky.darkness` tile by tile: each
tile reads its window of the emission plus a halo of at least the kernel's range (zero
outside the raster), convolves it with the zenith stencil in one FFT (the in-memory map's
plan, built once and shared by all tiles) and writes its interior into the output COG
(:class:`~nightlights.io.streamed.CogWriter`), so no process holds the whole raster.
:func:`~nightlights.sky.darkness.darkness` dispatches here for a geographic emission, a
``target_crs=``, a ``store=``, ``tiled=True``, or an emission file whose in-memory map would
need more than :data:`TILED_ABOVE`.

**Grids.** A projected emission mapped on its own grid is tiled in its cells: the map equals
the in-memory one up to float rounding. A geographic emission (flux density [lm m-2] per cell,
whose flux is the density times the cell's area on the authalic sphere), or an output on
another grid (``target_crs=``), is computed per tile in a local azimuthal equidistant
projection centred on the tile, on a square grid of the input's metres per cell (north-south
for a geographic input, the same for every tile, so one plan serves all); the flux is
deposited there conservatively and the zenith sampled back bilinearly at the output cells
(:mod:`nightlights.sky._tiles`). The output grid is the input's by default (geographic in,
geographic out, like the World Atlas, Falchi et al. 2016) or the grid of ``target_crs`` at
the input's metres per cell. A raster spanning all 360 degrees of longitude wraps.

**Projection error.** The azimuthal equidistant projection keeps distances from its centre
exact; the distance between two other points is stretched across the radius by the
projection's transverse scale :math:`k' = \\rho / (R \\sin(\\rho / R))` at distance
:math:`\\rho` from the centre (Snyder 1987, Eq. 25-2), at most
:math:`\\rho^2 / (6R^2)` for :math:`\\rho \\ll R`. With the default tile (2048 cells of
15 arcsec, 949 km square, half-diagonal 671 km) and a 300 km reach, :math:`\\rho \\le 971`
km: at most 0.39 % in a source's distance (0.10 % for the 1024-cell tile), measured 0.38 %
by pyproj for a point 671 km along the tile's diagonal and one 300 km beyond it, about 0.8 %
in a lone source's zenith contribution there (the zenith falls about as :math:`r^{-2}`);
within a tile's inner half the error is a quarter of that. A single transverse Mercator
(UTM) zone stretched 30 degrees of longitude away is off by 8 %.

**Engines.** Local runs compute the tiles on a thread pool (cores, fewer where the memory of
the tiles in flight would exceed :data:`PROCESS_MEMORY`); ``scheduler=`` runs them as tasks
of a ``dask.distributed`` cluster whose workers read the emission file and write each
finished tile into a tile store (``store=``: a folder or fsspec URL, one ``.npy`` per tile
named by its index and a hash of the plan, the grid and the input file's path, size and
modification time, written atomically); this process writes the COG from the store as tiles
arrive. ``resume=True`` (default) reuses the tiles already in the store, so a rerun after an
interruption computes only the missing ones; a changed input or plan has another hash and
is never reused. The store's tiles are removed once the COG is written unless
``keep_store=True``. A task lost with its worker is rescheduled; ``retries=`` more attempts
are allowed for a tile that raises.

References
----------
1. Snyder, J. P. 1987, "Map Projections: A Working Manual", U.S. Geological Survey
   Professional Paper 1395, Sec. 25 (azimuthal equidistant projection, Eq. 25-2).
2. Falchi, F. et al. 2016, "The new world atlas of artificial night sky brightness", Sci.
   Adv. 2, e1600377 (a geographic grid of 30 arcsec, the whole Earth).
3. Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light
   Pollution for the Night Sky", ACM TOG 42(6) 219 (the zenith kernel).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.fft
from affine import Affine
from pyproj import CRS
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from nightlights._resources import check_memory, memory_limit
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError
from nightlights.io import Raster, as_raster, source_label
from nightlights.io.streamed import CogWriter
from nightlights.sky._tiles import (
    AUTHALIC_RADIUS,
    SUBPOINT_BATCH,
    Emission,
    LocalGrid,
    TileStore,
    cell_flux,
    content_token,
    deposit,
    file_identity,
    local_grid,
    sample_back,
    source_window,
    tile_windows,
)
from nightlights.sky.instrument_units import instrument_sky
from nightlights.sky.instruments import Instrument
from nightlights.sky.scene import Scene
from nightlights.sky.setup import band_emission_functions, level_offset
from nightlights.sky.spec import source_levels

__all__ = [
    "DEFAULT_TILE_SIZE",
    "PROCESS_MEMORY",
    "TILED_ABOVE",
    "ProgressHook",
    "TiledGrid",
    "output_grid",
    "read_overview",
    "tile_memory",
    "tiled_darkness",
]

if TYPE_CHECKING:
    from nightlights.sky.darkness import DarknessResult

#: Tile edge [cells] of the tiled map when ``chunk_size`` is None: with a 300 km reach at
#: 15 arcsec (a stencil radius of 648 cells) a tile's FFT grid is 3375 cells square, about
#: 0.9 GiB with its window, so that tiles of two threads stay within :data:`PROCESS_MEMORY`.
DEFAULT_TILE_SIZE = 2048
#: The memory one process of the tiled map may use at default settings [B] (the target of
#: the country-scale work: 4 GiB per process for any raster size).
PROCESS_MEMORY = 4 * 2**30
#: An emission file whose in-memory map would need more than this (or more than the memory
#: limit) is mapped tile by tile [B].
TILED_ABOVE = PROCESS_MEMORY
#: Resident memory of the process before any tile (interpreter, numpy, GDAL, pyproj, the
#: kernel), counted once per process in :func:`tile_memory`'s total [B]: 0.3 GiB measured
#: (VmRSS after the kernel was loaded) on this toolkit's test machine.
BASE_MEMORY = 0.3 * 2**30

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


def output_grid(
    emission: Emission, target_crs: Any | None
) -> tuple[str, Affine, tuple[int, int], float]:
    """The output grid (CRS, transform, shape) and the local cell [m].

    The input's grid by default; with ``target_crs`` the grid of that CRS covering the
    emission's bounds with cells of the input's metres per cell (a geographic target: its
    degrees of latitude of that many metres).
    """
    t = emission.transform
    cell = (
        AUTHALIC_RADIUS * math.radians(abs(t.e)) if emission.geographic else abs(float(t.a))
    )
    if target_crs is None:
        return emission.crs, t, emission.shape, cell
    try:
        target = CRS.from_user_input(target_crs)
    except Exception as exc:  # pyproj raises its own CRSError for anything unreadable
        raise CRSError(f"target_crs={target_crs!r}: not a CRS ({exc})") from None
    from rasterio.crs import CRS as RasterioCRS
    from rasterio.warp import calculate_default_transform

    rows, cols = emission.shape
    left, top = t.c, t.f
    right, bottom = t.c + t.a * cols, t.f + t.e * rows
    step = math.degrees(cell / AUTHALIC_RADIUS) if target.is_geographic else cell
    transform, width, height = calculate_default_transform(
        RasterioCRS.from_user_input(emission.crs),
        RasterioCRS.from_wkt(target.to_wkt()),
        cols,
        rows,
        left=min(left, right),
        bottom=min(top, bottom),
        right=max(left, right),
        top=max(top, bottom),
        resolution=step,
    )
    return target.to_wkt(), transform, (int(height), int(width)), cell


def tile_luminance(grid: TiledGrid, plan: Any, window: tuple[int, int, int, int]) -> FloatArray:
    """The zenith luminance of one tile [cd m-2] (flat terrain, the plan's levels).

    Parameters
    ----------
    grid
        The map's grids.
    plan
        The shared plan (:class:`nightlights.sky.darkness._Plan`).
    window
        (row0, row1, col0, col1) of the output grid.
    """
    from nightlights.sky.darkness import _convolve

    if grid.delay:
        time.sleep(grid.delay)
    r0, r1, c0, c1 = window
    a, b = plan.depth
    workers = 1 if _in_pool() else -1
    if not grid.local:
        flux = cell_flux(grid.emission, (r0 - a, r1 + a, c0 - b, c1 + b))
        region = (a, a + r1 - r0, b, b + c1 - c0)
        return _convolve(list(flux), plan.flat_source, plan.flat_eye, plan, region, workers)
    local = grid.local_grid(window)
    planes = deposit(grid.emission, source_window(grid.emission, local), local)
    values = _convolve(planes, plan.flat_source, plan.flat_eye, plan, local.interior, workers)
    del planes
    return sample_back(values, local, grid.crs, grid.transform, window)


def _in_pool() -> bool:
    """Whether this thread is one of several computing tiles (then each FFT uses one)."""
    import threading

    return threading.current_thread().name.startswith("darkness-tile")


def compute_tile(
    grid: TiledGrid,
    plan: Any,
    window: tuple[int, int, int, int, int, int],
    location: str,
    token: str,
) -> tuple[int, int]:
    """Compute a tile and store it (a task of a distributed run); its index."""
    tile = (window[0], window[1])
    values = tile_luminance(grid, plan, window[2:])
    TileStore(location, token).write(tile, values)
    return tile


def tile_memory(
    grid: TiledGrid,
    *,
    bands: int,
    planes: int,
    observer_levels: int,
    workers: int = 1,
) -> float:
    """Estimated peak memory of a tiled map in one process [B]: :data:`BASE_MEMORY`, the
    stencil, and per tile in flight its FFT grid (padded inputs, source planes and the spectra
    held at once, as :func:`~nightlights.sky.darkness.darkness_memory`), its emission window
    (float64 and its flux, the read buffer and lit mask) and, on local grids, the sub-points
    of one projection batch and the output's coordinates; largest over the tiles nearest the
    equator and the poles (a geographic window widens with latitude).

    Parameters
    ----------
    grid
        The map's grids.
    bands, planes, observer_levels
        Emission bands, source planes (levels x bands) and observer levels [1].
    workers
        Tiles in flight [1].

    Returns
    -------
    float
        Bytes.
    """
    a, b = grid.half
    stencil = 10.0 * (2 * a + 1) * (2 * b + 1)
    held = min(planes, observer_levels) + 3
    worst = 0.0
    for window in _extreme_tiles(grid):
        r0, r1, c0, c1 = window
        out_cells = float((r1 - r0) * (c1 - c0))
        if grid.local:
            local = grid.local_grid(window)
            rows, cols = local.shape
            w0, w1, v0, v1 = source_window(grid.emission, local)
            window_cells = float(max(w1 - w0, 0) * max(v1 - v0, 0))
            extra = 64.0 * SUBPOINT_BATCH + 56.0 * min(out_cells, 256.0 * (c1 - c0))
            extra += 8.0 * out_cells * 2  # the local interior and the samples
        else:
            rows, cols = r1 - r0 + 2 * a, c1 - c0 + 2 * b
            window_cells = float(rows * cols)
            extra = 0.0
        fft = float(
            scipy.fft.next_fast_len(rows + a + 1, real=True)
            * scipy.fft.next_fast_len(cols + b + 1, real=True)
        )
        per_fft = 8.0 * fft * (held + bands + 2 + planes)
        per_window = window_cells * (bands * 20.0 + 1.0)
        worst = max(worst, per_fft + per_window + extra + 12.0 * out_cells)
    return BASE_MEMORY + stencil + workers * worst


def _extreme_tiles(grid: TiledGrid) -> list[tuple[int, int, int, int]]:
    """Full-size tiles at the top, the bottom and the row nearest the equator."""
    rows, cols = grid.shape
    edge_r, edge_c = min(grid.tile, rows), min(grid.tile, cols)
    starts = {0, rows - edge_r}
    if grid.local and CRS.from_user_input(grid.crs).is_geographic:
        t = grid.transform
        equator = int(np.clip(round(-t.f / t.e), 0, rows - 1)) if t.e else 0
        starts.add(int(np.clip(equator - edge_r // 2, 0, rows - edge_r)))
    return [(r, r + edge_r, 0, edge_c) for r in sorted(starts)]


def tile_workers(per_tile: float, requested: int | None = None) -> int:
    """Tiles computed at once by local threads: the cores, fewer where their memory would
    exceed :data:`PROCESS_MEMORY` or the memory limit, at least one."""
    budget = min(PROCESS_MEMORY, memory_limit()) - BASE_MEMORY
    fit = max(1, int(budget // max(per_tile, 1.0)))
    cores = os.cpu_count() or 1
    return max(1, min(cores, fit, requested or cores))


# --- the run ------------------------------------------------------------------------------------


class _Progress:
    """A rich tile bar with ETA, or the caller's ``hook(done, total)``, or nothing."""

    def __init__(self, progress: bool | ProgressHook, total: int, description: str) -> None:
        self.total, self.done = total, 0
        self._hook = progress if callable(progress) else None
        columns = (
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
        )
        self._bar = Progress(*columns, transient=True, disable=progress is not True)
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
            for future in as_completed(futures):
                tile = future.result()
                future.release()
                finish(futures[future], store.read(tile))
        except BaseException:
            client.cancel(list(futures))
            raise
    finally:
        if own:
            client.close()


def map_token(grid: TiledGrid, plan: Any) -> str:
    """The content hash the map's tiles carry in the store: the plan, the grids and the input
    (a file's path, size and modification time; an array's bytes)."""
    emission = grid.emission
    source: Any = (
        file_identity(emission.path)
        if emission.path is not None
        else content_token(np.asarray(emission.data))
    )
    return content_token(
        source,
        emission.crs,
        tuple(emission.transform)[:6],
        grid.crs,
        tuple(grid.transform)[:6],
        grid.shape,
        grid.local,
        grid.cell,
        grid.half,
        grid.tile,
        np.asarray(plan.zenith),
        plan.source_levels,
        plan.observer_levels,
        plan.flat_source,
        plan.flat_eye,
        plan.stencil.bins,
        np.asarray(plan.stencil.share),
    )


def default_store(output: Path) -> Path:
    """The tile store beside an output: ``OUTPUT.tiles/``."""
    return output.with_name(output.name + ".tiles")


def read_overview(path: str | os.PathLike[str], max_cells: int = 2**20) -> Raster:
    """A map read at about ``max_cells`` cells (every band, nearest, from the COG's overviews):
    the summary of a map too large to hold.

    Parameters
    ----------
    path
        A darkness map (COG).
    max_cells
        Cells to read at most, about [1].

    Returns
    -------
    Raster
        The bands on a decimated grid.
    """
    import rasterio
    from rasterio.enums import Resampling

    with rasterio.open(path) as dataset:
        step = max(1.0, math.sqrt(dataset.height * dataset.width / max_cells))
        shape = (max(1, round(dataset.height / step)), max(1, round(dataset.width / step)))
        data = dataset.read(out_shape=(dataset.count, *shape), resampling=Resampling.nearest)
        transform = dataset.transform * Affine.scale(
            dataset.width / shape[1], dataset.height / shape[0]
        )
        return Raster(
            np.asarray(data, dtype=float),
            transform,
            dataset.crs.to_wkt() if dataset.crs else None,
            descriptions=tuple(d or f"band_{i + 1}" for i, d in enumerate(dataset.descriptions)),
        )


def check_tiled_inputs(emission: Emission) -> None:
    """The checks of an emission before its tiles: a CRS, one or two bands, north-up cells
    (square ones on a projected grid mapped in its own cells)."""
    if not emission.crs:
        raise CRSError(f"{emission.label}: no CRS; expected a projected or geographic CRS")
    if emission.bands > 2:
        raise InputError(
            f"{emission.label}: {emission.bands} bands; expected 1 or 2 (e.g. Lambertian + "
            "uplight)"
        )
    t = emission.transform
    if t.b != 0 or t.d != 0:
        raise InputError(f"{emission.label}: a rotated grid; expected north-up cells")
    if not emission.geographic and not np.isclose(abs(t.a), abs(t.e), rtol=1e-9):
        raise InputError(
            f"{emission.label}: cells of {abs(t.a):g} x {abs(t.e):g} m; expected square cells"
        )


# --- the stage ----------------------------------------------------------------------------------


def tiled_darkness(
    scene: Scene,
    output: Path | None,
    *,
    height: float,
    instrument: str | Instrument | None,
    spectrum: str | None,
    natural_luminance: float | None,
    chunk_size: int | None,
    scheduler: Any | None,
    progress: bool | ProgressHook,
    target_crs: Any | None,
    store: str | os.PathLike[str] | None,
    resume: bool,
    keep_store: bool,
    retries: int,
) -> DarknessResult:
    """The darkness map tile by tile (flat terrain); called by
    :func:`~nightlights.sky.darkness.darkness`, whose parameters these are (``output`` is
    already checked).

    Returns
    -------
    DarknessResult
        ``raster`` None when an ``output`` was written (the map is in the file), else the map
        in memory; ``tiles`` and ``reused_tiles`` count the tiles computed and taken from the
        store.

    Raises
    ------
    InputError
        A ``scheduler`` without an emission file, or without ``output=`` or ``store=`` for the
        tile store; no ``output=`` for a map too large to hold.
    """
    import importlib

    dk = importlib.import_module("nightlights.sky.darkness")  # the package exports the function

    source = scene.raster_input("darkness")
    label = source_label(source, "emission raster")
    emission = _emission(source, label)
    check_tiled_inputs(emission)
    if not (math.isfinite(height) and height >= 0):
        raise InputError(f"height={height!r} m; expected a finite value >= 0")
    if scheduler is not None and emission.path is None:
        raise InputError(
            f"{label}: scheduler= needs the emission as a file its workers can read; give the "
            "scene a path"
        )
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise InputError(f"retries={retries!r}; expected a whole number >= 0")
    edge = DEFAULT_TILE_SIZE if chunk_size is None else dk._check_chunk_size(chunk_size)
    crs, transform, shape, cell = output_grid(emission, target_crs)
    local = emission.geographic or target_crs is not None
    reader = instrument_sky(
        instrument,
        spectrum=spectrum,
        natural_luminance=natural_luminance,
        emission=source,
        label=label,
    )
    functions, notes = band_emission_functions(source, emission.bands, label=label)
    width, depth = _extent_metres(emission)
    proxy = Raster(np.zeros((1, 1, 1)), Affine(width, 0, 0, 0, -depth, depth), "EPSG:3857")
    table, _ = scene.find_kernel(
        proxy,  # a 1-cell stand-in of the region's size in metres: its diagonal sets the range
        (0.0, depth),
        observer_altitudes=tuple(source_levels(np.array([height]))),
        source_altitudes=source_levels(np.zeros(1)),
        functions=functions,
        progress=progress is True,
    )
    start = time.perf_counter()
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    observer_levels = np.sort(np.asarray(table["observer_altitude"].values, dtype=float))
    offset = level_offset(np.zeros(1), None, levels)
    edges = np.asarray(table["distance_edges"].values, dtype=float)
    dk._warn_range((0.0, 0.0, width, depth), edges[-1])
    zenith, n_az, functions, notes = dk._zenith_tables(
        table, observer_levels, functions, notes, reader, emission.bands, label
    )
    radius = math.ceil(edges[-1] / cell)
    rows, cols = emission.shape
    half = (radius, radius) if local else (min(radius, rows - 1), min(radius, cols - 1))
    plan = dk._Plan(
        stencil=dk._Stencil(cell, edges, n_az, half),
        zenith=zenith,
        source_levels=levels,
        observer_levels=observer_levels,
        bands=emission.bands,
        terrain=False,
        flat_source=-offset,
        flat_eye=float(height - offset),
    )
    grid = TiledGrid(emission, crs, transform, shape, local, cell, half, edge, _TILE_DELAY)
    sizes = {"bands": emission.bands, "planes": levels.size * emission.bands}
    sizes["observer_levels"] = observer_levels.size
    per_tile = tile_memory(grid, **sizes, workers=1) - tile_memory(grid, **sizes, workers=0)
    workers = 1 if scheduler is not None else tile_workers(per_tile)
    whole = 0.0 if output is not None else 32.0 * shape[0] * shape[1]
    check_memory(
        tile_memory(grid, **sizes, workers=workers) + whole,
        f"the tiled darkness map of {shape[0]} x {shape[1]} cells",
        option="lower chunk_size=" if output is not None else "give output= (tiles stream there)",
    )
    location = store
    if location is None and scheduler is not None:
        if output is None:
            raise InputError(
                "scheduler= on the tiled map needs output= (its tile store goes beside it) "
                "or store="
            )
        location = default_store(output)
    tiles = None if location is None else TileStore(location, map_token(grid, plan))
    windows = grid.windows()
    layout = (
        f"{len(windows)} tile(s) of {edge} cells"
        + (f", each on a local azimuthal equidistant grid of {cell:g} m" if local else "")
    )
    tags = dk._map_tags(
        label=label,
        functions=functions,
        notes=notes,
        table=table,
        observer_height=height,
        terrain="flat (0 m)",
        levels=levels,
        observer_levels=observer_levels,
        offset=offset,
        layout=layout,
        reader=reader,
    )
    _, descriptions, band_tags = dk._map_bands(reader, np.zeros((1, 1)))
    options = {
        "store": tiles,
        "resume": resume,
        "scheduler": scheduler,
        "workers": workers,
        "retries": retries,
        "progress": progress,
    }
    raster: Raster | None = None
    if output is not None:
        with CogWriter(
            output,
            shape=(2, *shape),
            transform=transform,
            crs=crs,
            descriptions=descriptions,
            units=("cd m-2", "mag arcsec-2"),
            band_tags=band_tags,
            tags=tags,
        ) as writer:

            def write(row: int, col: int, luminance: FloatArray) -> None:
                writer.write(dk._map_bands(reader, luminance)[0], row=row, col=col)

            computed, reused = run_tiles(grid, plan, write, **options)
    else:
        luminance = np.zeros(shape)

        def keep(row: int, col: int, values: FloatArray) -> None:
            luminance[row : row + values.shape[0], col : col + values.shape[1]] = values

        computed, reused = run_tiles(grid, plan, keep, **options)
        bands, _, _ = dk._map_bands(reader, luminance)
        raster = Raster(
            bands,
            transform,
            crs,
            descriptions=descriptions,
            units=("cd m-2", "mag arcsec-2"),
            tags=tags,
            band_tags=band_tags,
        )
    if tiles is not None and not keep_store:
        tiles.remove()
    return dk.DarknessResult(
        raster,
        time.perf_counter() - start,
        output,
        None if reader is None else reader.instrument.name,
        tiles=computed,
        reused_tiles=reused,
    )


def _emission(source: Any, label: str) -> Emission:
    """The emission as tiles read it: a file by its path, else the array."""
    if isinstance(source, (str, os.PathLike)):
        import rasterio

        try:
            with rasterio.open(source) as dataset:
                crs = dataset.crs.to_wkt() if dataset.crs else ""
                return Emission(
                    str(source),
                    None,
                    dataset.transform,
                    crs,
                    (dataset.height, dataset.width),
                    dataset.count,
                    label,
                )
        except rasterio.errors.RasterioError as exc:
            raise InputError(f"{label}: cannot read it ({exc})") from None
    raster = as_raster(source)
    crs = "" if raster.crs is None else CRS.from_user_input(raster.crs).to_wkt()
    data = raster.data
    return Emission(None, data, raster.transform, crs, raster.shape, data.shape[0], label)


def _extent_metres(emission: Emission) -> tuple[float, float]:
    """East-west and north-south extent of the emission [m]: its widest parallel and its
    meridian on the authalic sphere for a geographic grid."""
    rows, cols = emission.shape
    t = emission.transform
    if not emission.geographic:
        return abs(t.a) * cols, abs(t.e) * rows
    lats = np.array([t.f, t.f + t.e * rows])
    nearest = 0.0 if lats.min() <= 0 <= lats.max() else float(np.abs(lats).min())
    radians = math.radians(abs(t.a) * cols)
    width = AUTHALIC_RADIUS * min(radians, math.pi) * math.cos(math.radians(nearest))
    return width, AUTHALIC_RADIUS * math.radians(abs(t.e) * rows)
