"""Raster grids, tiles, light-to-tile binning and parallel tile execution with Dask.

A raster stage describes its output as a :class:`RasterGrid`, cuts it into :class:`Tile`
windows, assigns each source (a luminaire with a region of influence) to the tiles its
region touches, and runs one task per tile on the local threaded scheduler or on a
``dask.distributed`` cluster (:func:`compute_tiles`). Results come back as numpy arrays;
nothing is written until every tile has succeeded, so a failed tile leaves no output.
:func:`compute_irradiance` runs the illuminance kernel
(:func:`~nightlights.ground.illuminance.ground_illuminance`) this way.
"""

from __future__ import annotations

import logging
import math
import os
import uuid
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import dask
import numpy as np
from affine import Affine
from numpy.typing import NDArray
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from nightlights._parallel import TaskProgress, compute_distributed
from nightlights._typing import FloatArray
from nightlights._validate import check_resolution
from nightlights.errors import DataQualityWarning, InputError
from nightlights.ground import illuminance
from nightlights.ground.luminaires import Luminaires, describe_ids

__all__ = [
    "ComputedIrradiance",
    "RasterGrid",
    "Tile",
    "assign_to_tiles",
    "balanced_tile_size",
    "compute_irradiance",
    "compute_tiles",
    "grid_from_bounds",
    "make_tiles",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RasterGrid:
    """A north-up raster grid.

    Attributes
    ----------
    x_min
        West edge [m].
    y_max
        North edge [m].
    resolution
        Pixel size [m].
    rows, cols
        Grid shape [pixels].
    """

    x_min: float
    y_max: float
    resolution: float
    rows: int
    cols: int

    @classmethod
    def from_transform(cls, transform: Affine, shape: tuple[int, int]) -> RasterGrid:
        """The grid of a north-up transform with square pixels.

        Parameters
        ----------
        transform
            Affine transform of the top-left pixel corner [m].
        shape
            (rows, cols) [pixels].

        Raises
        ------
        InputError
            The transform is rotated or its pixels are not square.
        """
        if transform.b != 0 or transform.d != 0 or not math.isclose(transform.a, -transform.e):
            raise InputError(f"expected a north-up grid with square pixels, got {transform}")
        return cls(transform.c, transform.f, transform.a, *shape)

    @property
    def transform(self) -> Affine:
        """Affine transform of the top-left pixel corner."""
        return Affine(self.resolution, 0.0, self.x_min, 0.0, -self.resolution, self.y_max)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) [m]."""
        return (
            self.x_min,
            self.y_max - self.rows * self.resolution,
            self.x_min + self.cols * self.resolution,
            self.y_max,
        )

    def centres(self, tile: Tile) -> tuple[FloatArray, FloatArray]:
        """Pixel-centre coordinates of a tile: x (cols,) and y (rows,) [m].

        Parameters
        ----------
        tile
            A window of this grid.
        """
        x = self.x_min + (tile.col0 + np.arange(tile.cols) + 0.5) * self.resolution
        y = self.y_max - (tile.row0 + np.arange(tile.rows) + 0.5) * self.resolution
        return x.astype(np.float64), y.astype(np.float64)


@dataclass(frozen=True)
class Tile:
    """A window of a :class:`RasterGrid` (row and column offsets and sizes) [pixels]."""

    row0: int
    col0: int
    rows: int
    cols: int

    @property
    def slices(self) -> tuple[slice, slice]:
        """Row and column slices into the full grid."""
        return slice(self.row0, self.row0 + self.rows), slice(self.col0, self.col0 + self.cols)


def grid_from_bounds(bounds: Sequence[float], resolution: float) -> RasterGrid:
    """Grid covering ``bounds`` with square pixels, grown east and south to whole pixels.

    Parameters
    ----------
    bounds
        (x_min, y_min, x_max, y_max) [m].
    resolution
        Pixel size [m].

    Raises
    ------
    InputError
        Non-positive or non-finite resolution, or empty/inverted bounds.
    """
    resolution = check_resolution(resolution)
    if len(bounds) != 4 or not all(math.isfinite(v) for v in bounds):
        raise InputError(
            f"bounds={tuple(bounds)!r}; expected four finite numbers xmin,ymin,xmax,ymax"
        )
    x_min, y_min, x_max, y_max = (float(v) for v in bounds)
    if x_max <= x_min or y_max <= y_min:
        raise InputError(
            f"bounds={tuple(bounds)!r}; expected xmin < xmax and ymin < ymax (in metres)"
        )
    cols = max(1, math.ceil((x_max - x_min) / resolution - 1e-9))
    rows = max(1, math.ceil((y_max - y_min) / resolution - 1e-9))
    return RasterGrid(x_min, y_max, float(resolution), rows, cols)


def make_tiles(grid: RasterGrid, tile_size: int) -> list[Tile]:
    """Cut ``grid`` into square tiles (smaller at the east and south edges).

    Parameters
    ----------
    grid
        Output grid.
    tile_size
        Tile edge [pixels].

    Returns
    -------
    list of Tile
        Row-major order.
    """
    if tile_size < 1:
        raise InputError(f"tile_size={tile_size}; expected at least 1 pixel")
    return [
        Tile(r, c, min(tile_size, grid.rows - r), min(tile_size, grid.cols - c))
        for r in range(0, grid.rows, tile_size)
        for c in range(0, grid.cols, tile_size)
    ]


def assign_to_tiles(
    grid: RasterGrid,
    tile_size: int,
    x: FloatArray,
    y: FloatArray,
    radius: FloatArray,
) -> list[NDArray[np.intp]]:
    """Indices of the sources whose square region touches each tile of :func:`make_tiles`.

    Binning, not a per-tile search: each source's bounding box is converted to a range of
    tile rows and columns, the (source, tile) pairs are expanded and grouped by tile.

    Parameters
    ----------
    grid
        Output grid.
    tile_size
        Tile size used by :func:`make_tiles` [pixels].
    x, y
        Source positions [m].
    radius
        Region-of-influence radius per source [m].

    Returns
    -------
    list of numpy.ndarray
        One sorted index array per tile, in :func:`make_tiles` order.
    """
    n_tile_rows = math.ceil(grid.rows / tile_size)
    n_tile_cols = math.ceil(grid.cols / tile_size)
    tile_span = tile_size * grid.resolution
    c0 = np.floor((x - radius - grid.x_min) / tile_span)
    c1 = np.floor((x + radius - grid.x_min) / tile_span)
    r0 = np.floor((grid.y_max - (y + radius)) / tile_span)
    r1 = np.floor((grid.y_max - (y - radius)) / tile_span)
    c0 = np.clip(c0, 0, None).astype(np.int64)
    r0 = np.clip(r0, 0, None).astype(np.int64)
    c1 = np.clip(c1, None, n_tile_cols - 1).astype(np.int64)
    r1 = np.clip(r1, None, n_tile_rows - 1).astype(np.int64)
    n_c = np.maximum(c1 - c0 + 1, 0)
    n_r = np.maximum(r1 - r0 + 1, 0)
    counts = n_c * n_r
    source = np.repeat(np.arange(len(x)), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    n_c_pair = n_c[source]
    tile_row = r0[source] + local // np.maximum(n_c_pair, 1)
    tile_col = c0[source] + local % np.maximum(n_c_pair, 1)
    tile_index = tile_row * n_tile_cols + tile_col
    order = np.argsort(tile_index, kind="stable")
    boundaries = np.searchsorted(tile_index[order], np.arange(n_tile_rows * n_tile_cols + 1))
    return [
        source[order[boundaries[i] : boundaries[i + 1]]] for i in range(n_tile_rows * n_tile_cols)
    ]


def compute_tiles(
    function: Callable[..., Any],
    per_tile_args: Sequence[tuple[Any, ...]],
    *,
    shared: Any = None,
    scheduler: str | Any | None = None,
    num_workers: int | None = None,
    description: str = "tiles",
    progress: bool = True,
    sink: Callable[[int, Any], Any] | None = None,
) -> list[Any]:
    """Run ``function(*args, shared)`` for every tile in parallel with Dask.

    Parameters
    ----------
    function
        Module-level (picklable) function computing one tile.
    per_tile_args
        One argument tuple per tile.
    shared
        Object every task receives as its last argument; sent to the workers once.
    scheduler
        ``None``: local threads. A ``dask.distributed`` address (``tcp://...``) or a
        ``distributed.Client``: run on that cluster.
    num_workers
        Threads of the local scheduler (default: Dask's, one per core).
    description
        Label of the progress bar.
    progress
        Show a rich progress bar on stderr.
    sink
        Called as ``sink(index, result)`` as each tile finishes; what it returns is kept in
        place of the result, so that a large result (a tile of a raster being written)
        need not wait for the others. On local threads it runs in the worker thread and
        must be thread-safe; on a cluster it runs in this process.

    Returns
    -------
    list
        Results (or what ``sink`` returned) in the order of ``per_tile_args``. The first
        failing tile's exception is re-raised; remaining tiles are cancelled.
    """
    # unique per call: a cluster shared by several runs takes equal keys for the same task
    prefix = f"tile-{function.__name__}-{uuid.uuid4().hex}"
    shared_key = dask.delayed(shared, name=f"shared-{dask.base.tokenize(shared)}", pure=True)
    local = scheduler is None
    tasks = [
        dask.delayed(_sunk, pure=True)(
            function, sink, index, *args, shared_key, dask_key_name=f"{prefix}-{index}"
        )
        if local and sink is not None
        else dask.delayed(function, pure=True)(*args, shared_key, dask_key_name=f"{prefix}-{index}")
        for index, args in enumerate(per_tile_args)
    ]
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, transient=True, disable=not progress) as bar:
        task_id = bar.add_task(description, total=len(tasks))
        if local:
            with TaskProgress(lambda: bar.advance(task_id), prefix):
                return list(dask.compute(*tasks, scheduler="threads", num_workers=num_workers))
        return compute_distributed(tasks, scheduler, lambda: bar.advance(task_id), sink)


def _sunk(
    function: Callable[..., Any], sink: Callable[[int, Any], Any], index: int, *args: Any
) -> Any:
    """``sink(index, function(*args))``: a local tile handed on as soon as it is done."""
    return sink(index, function(*args))


#: Tiles per worker that :func:`balanced_tile_size` aims for, so that a raster of a few tiles
#: still keeps every core busy [1].
TILES_PER_WORKER = 4
#: Smallest tile edge :func:`balanced_tile_size` goes down to [pixels].
MIN_BALANCED_TILE = 128


def balanced_tile_size(grid: RasterGrid, tile_size: int, workers: int) -> int:
    """The largest of ``tile_size``, ``tile_size / 2``, ... that gives every worker tiles.

    Parameters
    ----------
    grid
        Output grid.
    tile_size
        Largest tile edge [pixels].
    workers
        Tiles computed at once [1].

    Returns
    -------
    int
        Tile edge, at least ``min(tile_size, MIN_BALANCED_TILE)``, halved while the grid has
        fewer than :data:`TILES_PER_WORKER` x ``workers`` tiles [pixels].

    Examples
    --------
    >>> balanced_tile_size(RasterGrid(0.0, 0.0, 1.0, 1000, 1000), 1024, 2)
    256
    >>> balanced_tile_size(RasterGrid(0.0, 0.0, 1.0, 10_000, 10_000), 1024, 2)
    1024
    """

    def count(size: int) -> int:
        return math.ceil(grid.rows / size) * math.ceil(grid.cols / size)

    size = tile_size
    while size // 2 >= MIN_BALANCED_TILE and count(size) < TILES_PER_WORKER * workers:
        size //= 2
    return size


@dataclass(frozen=True)
class ComputedIrradiance:
    """Bands of :func:`compute_irradiance` on the whole grid.

    Attributes
    ----------
    bands
        Array (bands, rows, cols) [band units]; ``None`` when the tiles went to ``write``.
    n_lights
        Lights that light at least one pixel of the grid.
    n_pairs
        Light-pixel evaluations [1].
    lit
        Some pixel of some band is not zero.
    """

    bands: NDArray[np.float32] | None
    n_lights: int
    n_pairs: int
    lit: bool = True


def compute_irradiance(
    grid: RasterGrid,
    luminaires: Luminaires,
    weights: FloatArray,
    radius: FloatArray,
    *,
    ground_z: FloatArray | None = None,
    normals: FloatArray | None = None,
    scheduler: str | Any | None = None,
    tile_size: int = 1024,
    num_workers: int | None = None,
    progress: bool = True,
    backend: str = "numba",
    write: Callable[[Tile, NDArray[np.float32]], None] | None = None,
) -> ComputedIrradiance:
    """Tile ``grid``, bin lights to tiles, run the illuminance kernel per tile with Dask.

    Parameters
    ----------
    grid
        Output grid.
    luminaires
        Lights.
    weights
        Band weights per light (n, bands) [band unit per lx].
    radius
        Region of influence per light [m].
    ground_z, normals
        Ground on the full grid (see
        :func:`~nightlights.ground.illuminance.ground_illuminance`) [m], [1].
    scheduler
        ``None`` (local threads) or a ``dask.distributed`` address/Client.
    tile_size
        Tile edge [pixels]; the compiled kernel halves it (down to
        :data:`MIN_BALANCED_TILE`) until every worker has :data:`TILES_PER_WORKER` tiles
        (:func:`balanced_tile_size`), which its output does not depend on.
    num_workers
        Local threads (default one per core).
    progress
        Show a progress bar.
    backend
        Illuminance kernel, one of :data:`~nightlights.ground.illuminance.BACKENDS`:
        ``"numba"`` (compiled, the default) or ``"numpy"`` (the reference).
    write
        Called as ``write(tile, values)`` with each tile's bands (bands, rows, cols) as soon
        as it is computed, instead of gathering the grid: memory then holds the tiles in
        flight, not the raster (see :class:`~nightlights.io.CogWriter`). On local threads
        it is called from the worker threads and must be thread-safe.

    Notes
    -----
    A pixel's value depends on its index in the grid alone, never on the tile that holds
    it: every backend lights the pixels whose centres lie within a light's radius, by the
    same test, and the compiled backend adds the lights to a pixel in the order of
    ``luminaires``; its output is bit-identical for any ``tile_size`` and scheduler.
    """
    illuminance.check_backend(backend)
    if backend == "numba":
        tile_size = balanced_tile_size(grid, tile_size, num_workers or os.cpu_count() or 1)
    x, y = luminaires.light_point[:, 0], luminaires.light_point[:, 1]
    finite_radius = np.where(
        np.isfinite(radius), radius, 2.0 * (grid.rows + grid.cols) * grid.resolution
    )
    tiles = make_tiles(grid, tile_size)
    members = assign_to_tiles(grid, tile_size, x, y, finite_radius)
    touching = np.zeros(len(luminaires), dtype=bool)
    for index in members:
        touching[index] = True
    if (~touching).any():
        warnings.warn(
            f"{(~touching).sum()} of {len(luminaires)} lights light no pixel of the raster "
            f"(ids {describe_ids(luminaires.light_id[~touching])}); ignored",
            DataQualityWarning,
            stacklevel=3,
        )
    tables: Any = luminaires.tables
    if backend == "numba":
        from nightlights.ground._illuminance_numba import pack_tables

        tables = pack_tables(luminaires.tables)
    per_tile = []
    for tile, index in zip(tiles, members, strict=True):
        rows, cols = tile.slices
        per_tile.append(
            (
                tile,
                luminaires.light_point[index],
                luminaires.rotation[index],
                luminaires.street_azimuth[index],
                luminaires.table_index[index],
                weights[index],
                finite_radius[index],
                None if ground_z is None else ground_z[rows, cols],
                None if normals is None else normals[rows, cols],
            )
        )
    shared = (grid, tables, backend)

    def handed_on(index: int, result: tuple[NDArray[np.float32], int]) -> tuple[None, int, bool]:
        values, pairs = result
        assert write is not None
        write(tiles[index], values)
        return None, pairs, bool(values.any())

    results = compute_tiles(
        _irradiance_tile,
        per_tile,
        shared=shared,
        scheduler=scheduler,
        num_workers=num_workers,
        description=f"irradiance: {len(tiles)} tiles",
        progress=progress,
        sink=None if write is None else handed_on,
    )
    n_pairs = sum(int(result[1]) for result in results)
    if write is not None:
        lit = any(result[2] for result in results)
        return ComputedIrradiance(None, int(touching.sum()), n_pairs, lit)
    bands = np.zeros((weights.shape[1], grid.rows, grid.cols), dtype=np.float32)
    for tile, (values, _) in zip(tiles, results, strict=True):
        rows, cols = tile.slices
        bands[:, rows, cols] = values
    return ComputedIrradiance(bands, int(touching.sum()), n_pairs, bool(bands.any()))


def _irradiance_tile(
    tile: Tile,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.intp],
    weights: FloatArray,
    radius: FloatArray,
    ground_z: FloatArray | None,
    normals: FloatArray | None,
    shared: tuple[RasterGrid, Any, str],
) -> tuple[NDArray[np.float32], int]:
    grid, tables, backend = shared
    # the centre of the grid's pixel (0, 0): pixel centres follow from their grid index
    origin = (grid.x_min + 0.5 * grid.resolution, grid.y_max - 0.5 * grid.resolution)
    values, pairs = illuminance.window_and_pairs(
        (tile.rows, tile.cols),
        origin,
        grid.resolution,
        light_point,
        rotation,
        street_azimuth,
        table_index,
        tables,
        weights,
        radius=radius,
        ground_z=ground_z,
        normals=normals,
        offset=(tile.row0, tile.col0),
        backend=backend,
    )
    return values.astype(np.float32), pairs
