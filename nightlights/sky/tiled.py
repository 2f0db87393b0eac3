"""The darkness map of a country or a continent: out of core, geodesically tiled, distributed
and resumable.

:func:`~nightlights.sky.darkness.darkness` computes its map tile by tile here: each
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
exact; a distance between two other points is stretched across the radius by the transverse
scale :math:`k' = (\rho / R) / \\sin(\rho / R)` at distance :math:`\rho` from the centre
(Snyder 1987, Eq. 25-2), about :math:`1 + \rho^2 / (6R^2)`: an observer at the corner of the
default tile (2048 cells of 15 arcsec, 949 km square at the equator, 671 km from its centre)
sees its sources' distances off by at most 0.19 % (0.05 % for 1024-cell tiles, 335 km), the
worst over directions measured with pyproj for sources 50-300 km away being 0.186 % (0.046 %)
at any latitude; the zenith falls about as :math:`r^{-2}`, so a source's contribution is off
by at most about 0.4 % at the tile's corners and less inside.

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
from pathlib import Path
from typing import Any

import numpy as np
import scipy.fft
from affine import Affine
from pyproj import CRS

from nightlights._resources import memory_limit
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError
from nightlights.io import Raster, as_raster
from nightlights.io.streamed import CACHE_MB
from nightlights.sky._tile_run import ProgressHook, TiledGrid
from nightlights.sky._tiles import (
    AUTHALIC_RADIUS,
    Emission,
    content_token,
    file_identity,
    source_window,
)

__all__ = [
    "DEFAULT_TILE_SIZE",
    "PROCESS_MEMORY",
    "TILED_ABOVE",
    "ProgressHook",
    "TiledGrid",
    "output_grid",
    "read_overview",
    "tile_memory",
]

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
#: Resident memory of the interpreter and the modules a map imports (numpy, GDAL, pyproj,
#: dask, scipy) before it starts [B]: 0.22 GiB measured (``VmRSS`` after ``import
#: nightlights.ground, nightlights.sky``; the baseline of ``bench_memory_estimates.py``). The
#: memory checks leave it out, as every stage's estimate does; :func:`tile_memory`, a whole
#: process's peak, counts it.
IMPORTED_MEMORY = 0.22 * 2**30
#: Memory of a darkness map's first calls besides its arrays, in memory or tiled [B]: the
#: kernel file read (h5py, netCDF), GDAL opening the emission, the zenith tables and the
#: stencil's temporaries; 48 MiB measured (``VmHWM`` over :data:`IMPORTED_MEMORY`, less the
#: kernel's arrays) on a 64 x 64 map with the 30 km kernel of ``bench_memory_estimates.py``.
MAP_FIXED_MEMORY = 48 * 2**20
#: Bytes per cell of the tile being finished in this process, besides its luminance: the
#: float32-rounded copy the store keeps, the two output bands (luminance and magnitude, with
#: the magnitude's temporary) and their float32 copy written [B].
FINISH_BYTES_PER_CELL = 32.0
#: Resident memory of the process before any tile, counted once per process in
#: :func:`tile_memory`'s total [B]: the imports, the first calls and the COG writer's block
#: cache (:data:`nightlights.io.streamed.CACHE_MB`).
BASE_MEMORY = IMPORTED_MEMORY + MAP_FIXED_MEMORY + CACHE_MB * 2**20


def output_grid(
    emission: Emission, target_crs: Any | None
) -> tuple[str, Affine, tuple[int, int], float]:
    """The output grid (CRS, transform, shape) and the local cell [m].

    The input's grid by default; with ``target_crs`` the grid of that CRS covering the
    emission's bounds with cells of the input's metres per cell (a geographic target: its
    degrees of latitude of that many metres).
    """
    t = emission.transform
    cell = AUTHALIC_RADIUS * math.radians(abs(t.e)) if emission.geographic else abs(float(t.a))
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


def tile_memory(
    grid: TiledGrid,
    *,
    bands: int,
    planes: int,
    observer_levels: int,
    workers: int = 1,
) -> float:
    """Estimated peak memory of a tiled map in one process [B]: :data:`BASE_MEMORY`, the
    stencil and the tiles: per tile in flight the larger of its two phases plus its luminance
    (8 B per cell), one of them being finished in this process (:data:`FINISH_BYTES_PER_CELL`
    and its luminance) while the other threads compute theirs. On a local grid the phases
    follow each other: reading and depositing (the window's float32 read, float64 copy and
    flux, 28 B per cell and band, the local planes, the lit cells' indices and fluxes), then
    the FFT (the local planes and the source planes, 8 B per cell each, and on the FFT grid the
    spectra held at once, 8 B per cell each: the fewer of the source planes and the observer
    levels, and three working ones), then the near field on the tile's own cells. On the
    emission's own cells the padded window is read (its float32 read, float64 copy and flux,
    20 B per cell and band) and is the FFT's input: its flux and source planes (8 B per cell
    each) are held through the FFT. Largest over the tiles nearest the equator and the poles
    (a geographic window widens with latitude). Measured (VmHWM) against this estimate:
    ``bench_darkness_tiles.py`` (15 arcsec rasters, the 300 km kernel, local threads and
    worker processes) and ``bench_memory_estimates.py`` (a projected raster, a 30 km kernel).

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
        Bytes, the interpreter and its modules (:data:`IMPORTED_MEMORY`) included.
    """
    a, b = grid.half
    stencil = 18.0 * (2 * a + 1) * (2 * b + 1)  # lower bin (2 B), upper weight (8 B), W (8 B)
    held = min(planes, observer_levels) + 3
    worst = finish = 0.0
    for window in _extreme_tiles(grid):
        r0, r1, c0, c1 = window
        tile_cells = float((r1 - r0) * (c1 - c0))
        finish = max(finish, (FINISH_BYTES_PER_CELL + 8.0) * tile_cells)
        if grid.local:
            local = grid.local_grid(window)
            rows, cols = local.shape
            w0, w1, v0, v1 = source_window(grid.emission, local)
            window_cells = float(max(w1 - w0, 0) * max(v1 - v0, 0))
        else:
            rows, cols = r1 - r0 + 2 * a, c1 - c0 + 2 * b
            window_cells = float(rows * cols)
        # the FFT grid of _convolve: the padded window itself (interior + 2 x radius)
        fft = float(
            scipy.fft.next_fast_len(rows, real=True) * scipy.fft.next_fast_len(cols, real=True)
        )
        spectra = 8.0 * fft * held
        if grid.local:
            read = window_cells * (28.0 * bands + 1.0) + 8.0 * bands * rows * cols
            transform = spectra + 8.0 * rows * cols * (bands + planes)
            # the lit cells' rows, columns (int64) and fluxes, every cell lit at worst
            lit = window_cells * (16.0 + 8.0 * bands)
            # the near field after it: the tile's own cells and a few more, read as above
            near = 1.1 * tile_cells * 28.0 * bands
            per_tile = max(read + lit, transform, near)
        else:
            read = window_cells * 20.0 * bands
            per_tile = max(read, spectra + window_cells * 8.0 * (bands + planes))
        worst = max(worst, per_tile + 8.0 * tile_cells)
    # this process finishes a tile while the other threads compute theirs
    tiles = 0.0 if workers < 1 else (workers - 1) * worst + max(worst, finish)
    return BASE_MEMORY + stencil + tiles


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
        plan.near_radius,
        "deposit: bilinear, lattice",  # how flux reaches a local grid
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
        transform = dataset.transform @ Affine.scale(
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
            f"{emission.label}: {emission.bands} bands; expected 1 or 2 (e.g. Lambertian + uplight)"
        )
    t = emission.transform
    if emission.geographic:
        rows, cols = emission.shape
        lats, lons = (t.f, t.f + t.e * rows), (t.c, t.c + t.a * cols)
        if max(map(abs, lats)) > 90.0 + 1e-9 or max(map(abs, lons)) > 540.0:
            raise CRSError(
                f"{emission.label}: bounds longitude {min(lons):g}..{max(lons):g}, latitude "
                f"{min(lats):g}..{max(lats):g} in a geographic CRS; expected degrees within "
                "the globe (or a projected CRS for a grid in metres)"
            )
    if t.b != 0 or t.d != 0:
        raise InputError(f"{emission.label}: a rotated grid; expected north-up cells")
    if not emission.geographic and not np.isclose(abs(t.a), abs(t.e), rtol=1e-9):
        raise InputError(
            f"{emission.label}: cells of {abs(t.a):g} x {abs(t.e):g} m; expected square cells"
        )


# --- the stage ----------------------------------------------------------------------------------


def _as_stored(luminance: FloatArray) -> FloatArray:
    """A tile's luminance rounded as the store keeps it (float32), so that a resumed map is
    bit for bit the map of one run."""
    return np.asarray(luminance, dtype=np.float32).astype(float)


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
