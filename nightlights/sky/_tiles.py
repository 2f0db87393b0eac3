"""Geometry, reading and storage of the tiles of the tiled darkness map (:mod:`.tiled`).

A tile is a rectangle of the output grid. Its emission is read in a window that reaches at
least the kernel's range beyond it (zero outside the raster) and, on a grid in metres,
convolved with the zenith stencil (:mod:`.darkness`).

- **Projected emission, output on its grid**: the window is the tile plus the stencil radius
  in cells; the convolution is the in-memory map's, window by window.
- **Geographic emission, or another output grid** (``target_crs=``): the tile gets its own
  local metric projection, azimuthal equidistant centred on the tile (Snyder 1987, Sec. 25),
  and a square grid of :math:`c` metres (one for all tiles). Each lit source cell's flux,
  density times its area, is split over :math:`k \\times k` sub-points (:func:`subdivision`)
  that are placed on the local grid (positions interpolated between the projected nodes of a
  lattice, :func:`lattice_step`) and shared bilinearly between the four cell centres around
  each, which conserves the flux exactly and its centroid. The zenith is computed on the local
  grid and sampled bilinearly (luminance is intensive) at the tile's output cell centres.

The flux of a geographic cell is its flux density times its area on the authalic sphere of
WGS84 (Snyder 1987, Eq. 3-12 and p. 16; radius :data:`AUTHALIC_RADIUS`):

.. math:: A = R^2\\, \\Delta\\lambda\\, (\\sin\\varphi_2 - \\sin\\varphi_1) \\quad [\\mathrm{m^2}].

Length: a tile's geometry, its reading, the deposit (compiled, and the numpy reference that
the tests hold it to) and the store of finished tiles are one tile's plumbing, shared by the
local and the distributed engines; split, each part would import most of the others.

References
----------
1. Snyder, J. P. 1987, "Map Projections: A Working Manual", U.S. Geological Survey
   Professional Paper 1395 (authalic radius p. 16; cell area of the sphere, Eq. 3-12 with the
   authalic latitude; azimuthal equidistant projection, Sec. 25).
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import threading
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine
from pyproj import CRS, Transformer
from scipy.ndimage import map_coordinates

from nightlights._typing import FloatArray
from nightlights.errors import InputError, OutputError
from nightlights.sky._deposit_numba import deposit_lattice

#: Radius of the sphere of the same area as the WGS84 ellipsoid [m] (Snyder 1987, p. 16:
#: R_q = 6,371,007.2 m for WGS84's a and e).
AUTHALIC_RADIUS = 6371007.2
#: Most sub-points projected at once while depositing flux: bounds the temporaries of a
#: window's projection (about 60 B per sub-point) [1].
SUBPOINT_BATCH = 2**21
#: Output rows sampled back from the local grid at once [1].
SAMPLE_ROWS = 256
#: Longest side of a lattice cell whose corners are projected exactly; positions between are
#: interpolated bilinearly (:func:`lattice_step`, :func:`deposit`, :func:`sample_back`) [m].
#: The interpolation error of a smooth map on a sphere of radius R is about L^2 / 8R: 1 m at
#: 7 km; measured at most 0.5 m over a 15 arcsec tile and its 300 km halo at 0-80 deg latitude,
#: in a tenth of projecting every sub-point (``benchmarks/bench_darkness_near_field.py``).
LATTICE_SPAN = 7000.0


@functools.lru_cache(maxsize=32)
def _cached_transformer(source: str, target: str, thread: int) -> Transformer:
    return Transformer.from_crs(source, target, always_xy=True)


def _transformer(source: str, target: str) -> Transformer:
    """A (longitude, latitude)-ordered transformer, made once per thread (pyproj's are not
    shared between threads): a tile projects to and from its local grid several times."""
    return _cached_transformer(str(source), str(target), threading.get_ident())


def geographic_cell_areas(transform: Affine, rows: int | np.ndarray) -> FloatArray:
    """Area of the cells of a geographic grid's rows on the authalic sphere [m2].

    .. math:: A = R^2\\, |\\Delta\\lambda|\\, |\\sin\\varphi_2 - \\sin\\varphi_1|

    Parameters
    ----------
    transform
        North-up transform in degrees of longitude and latitude.
    rows
        Row indices (may lie outside the raster) [1].

    Returns
    -------
    numpy.ndarray
        One area per row [m2] (Snyder 1987, Eq. 3-12 on the sphere of radius
        :data:`AUTHALIC_RADIUS`).

    Examples
    --------
    >>> from affine import Affine
    >>> # one degree at the equator: about 111.2 km x 110.6 km on the authalic sphere
    >>> t = Affine(1.0, 0, 0, 0, -1.0, 1.0)
    >>> round(float(geographic_cell_areas(t, 0)[0]) / 1e6)
    12364
    """
    r = np.atleast_1d(np.asarray(rows, dtype=float))
    top = np.radians(np.clip(transform.f + transform.e * r, -90.0, 90.0))
    bottom = np.radians(np.clip(transform.f + transform.e * (r + 1.0), -90.0, 90.0))
    dlon = math.radians(abs(transform.a))
    return np.asarray(AUTHALIC_RADIUS**2 * dlon * np.abs(np.sin(top) - np.sin(bottom)), dtype=float)


def tile_windows(shape: tuple[int, int], edge: int) -> list[tuple[int, int, int, int, int, int]]:
    """The tiles of a grid, row-major: (tile row, tile col, row0, row1, col0, col1).

    Examples
    --------
    >>> [w[2:] for w in tile_windows((3, 5), 2)]
    [(0, 2, 0, 2), (0, 2, 2, 4), (0, 2, 4, 5), (2, 3, 0, 2), (2, 3, 2, 4), (2, 3, 4, 5)]
    """
    rows, cols = shape
    return [
        (i, j, r0, min(r0 + edge, rows), c0, min(c0 + edge, cols))
        for i, r0 in enumerate(range(0, rows, edge))
        for j, c0 in enumerate(range(0, cols, edge))
    ]


def subdivision(source_size: float, local_cell: float) -> int:
    """Sub-points per side of a source cell deposited on a local grid: at least two per local
    cell along the source cell's longer side, so that no sub-point is farther than a quarter
    of a local cell from where its share of the flux really lies on average.

    Parameters
    ----------
    source_size
        The source cell's longer side [m].
    local_cell
        The local grid's cell [m].

    Examples
    --------
    >>> subdivision(463.0, 463.0), subdivision(100.0, 463.0), subdivision(926.0, 463.0)
    (2, 1, 4)
    """
    return max(1, math.ceil(2.0 * source_size / local_cell - 1e-9))


@dataclass(frozen=True)
class Emission:
    """Where a tile reads the flux density: a file (any process can open it) or an array.

    Attributes
    ----------
    path
        The raster file, or None.
    data
        ``(bands, rows, cols)`` flux density [lm m-2] when no file is given, else None.
    transform, crs, shape, bands
        Its grid.
    label
        How it is named in messages.
    """

    path: str | None
    data: np.ndarray | None
    transform: Affine
    crs: str
    shape: tuple[int, int]
    bands: int
    label: str

    @property
    def geographic(self) -> bool:
        """Whether the grid is in degrees."""
        return bool(CRS.from_user_input(self.crs).is_geographic)

    @property
    def wraps(self) -> bool:
        """Whether a geographic grid spans all 360 degrees of longitude (its columns wrap)."""
        span = abs(self.transform.a) * self.shape[1]
        return self.geographic and abs(span - 360.0) < 0.5 * abs(self.transform.a)

    def read(self, r0: int, r1: int, c0: int, c1: int) -> FloatArray:
        """Flux density ``(bands, r1 - r0, c1 - c0)`` [lm m-2], zero outside the raster and
        for nodata (columns taken modulo the width where the grid wraps around the globe);
        a negative or infinite value is an InputError naming the window."""
        width = self.shape[1]
        if self.wraps and (c0 < 0 or c1 > width):
            parts = []
            for start in range(c0 - c0 % width, c1, width):  # whole turns of the globe
                lo, hi = max(c0, start), min(c1, start + width)
                parts.append(self.read(r0, r1, lo - start, hi - start))
            return np.concatenate(parts, axis=2)
        out = np.zeros((self.bands, r1 - r0, c1 - c0))
        rows, cols = self.shape
        a0, a1, b0, b1 = max(r0, 0), min(r1, rows), max(c0, 0), min(c1, cols)
        if a0 >= a1 or b0 >= b1:
            return out
        if self.data is not None:
            values = np.asarray(self.data[:, a0:a1, b0:b1], dtype=float)
        else:
            import rasterio
            from rasterio.windows import Window

            assert self.path is not None
            with rasterio.open(self.path) as dataset:
                window = Window(b0, a0, b1 - b0, a1 - a0)
                read = dataset.read(window=window, masked=True)
                values = np.ma.filled(read.astype(float), np.nan)
        if np.isinf(values).any() or (np.nan_to_num(values) < 0).any():
            raise InputError(
                f"{self.label}: rows {a0}-{a1}, cols {b0}-{b1} hold negative or infinite flux "
                "densities; expected finite values >= 0 [lm m-2] (nodata as NaN)"
            )
        out[:, a0 - r0 : a1 - r0, b0 - c0 : b1 - c0] = np.nan_to_num(values, nan=0.0)
        return out


@dataclass(frozen=True)
class LocalGrid:
    """The local metric grid of one tile (geographic emission or another output grid).

    Attributes
    ----------
    crs
        The azimuthal equidistant projection centred on the tile (PROJ string).
    centre
        Its centre (longitude, latitude) [deg].
    left, top
        Corner of the flux grid [m] in that projection.
    cell
        Its cell [m].
    shape
        (rows, cols) of the flux grid: the interior plus the stencil radius each side.
    interior
        (row0, row1, col0, col1) of the cells sampled back.
    """

    crs: str
    centre: tuple[float, float]
    left: float
    top: float
    cell: float
    shape: tuple[int, int]
    interior: tuple[int, int, int, int]


def aeqd(longitude: float, latitude: float) -> str:
    """PROJ string of the azimuthal equidistant projection centred at a point (WGS84)."""
    return (
        f"+proj=aeqd +lat_0={latitude:.10f} +lon_0={longitude:.10f} +x_0=0 +y_0=0 "
        "+datum=WGS84 +units=m +no_defs"
    )


def _apply(transform: Affine, x: np.ndarray, y: np.ndarray) -> tuple[FloatArray, FloatArray]:
    """An affine transform of arrays of points."""
    a, b, c, d, e, f = tuple(transform)[:6]
    return a * x + b * y + c, d * x + e * y + f


def output_centres(
    transform: Affine, window: tuple[int, int, int, int]
) -> tuple[FloatArray, FloatArray]:
    """Cell centres (x, y) of a window (row0, row1, col0, col1) of a grid [CRS units]."""
    r0, r1, c0, c1 = window
    x = transform.c + transform.a * (np.arange(c0, c1) + 0.5)
    y = transform.f + transform.e * (np.arange(r0, r1) + 0.5)
    return np.meshgrid(x, y)


def local_grid(
    output_crs: str,
    output_transform: Affine,
    window: tuple[int, int, int, int],
    cell: float,
    half: tuple[int, int],
) -> LocalGrid:
    """The local grid of a tile: centred on the tile, covering its cell centres with one cell
    to spare (bilinear sampling) and the stencil radius beyond.

    Parameters
    ----------
    output_crs, output_transform
        The output grid.
    window
        The tile (row0, row1, col0, col1) of the output grid.
    cell
        Local cell [m].
    half
        Stencil radius (rows, cols) [cells].
    """
    r0, r1, c0, c1 = window
    to_geo = _transformer(output_crs, "EPSG:4326")
    cx, cy = output_transform @ ((c0 + c1) / 2.0, (r0 + r1) / 2.0)
    lon0, lat0 = to_geo.transform(cx, cy)
    crs = aeqd(float(lon0), float(lat0))
    xs, ys = _projected_outline(output_crs, output_transform, window, crs)
    left = math.floor(float(xs.min()) / cell - 1.0) * cell
    right = math.ceil(float(xs.max()) / cell + 1.0) * cell
    bottom = math.floor(float(ys.min()) / cell - 1.0) * cell
    top = math.ceil(float(ys.max()) / cell + 1.0) * cell
    rows, cols = round((top - bottom) / cell), round((right - left) / cell)
    a, b = half
    return LocalGrid(
        crs=crs,
        centre=(float(lon0), float(lat0)),
        left=left - b * cell,
        top=top + a * cell,
        cell=cell,
        shape=(rows + 2 * a, cols + 2 * b),
        interior=(a, a + rows, b, b + cols),
    )


def _projected_outline(
    crs: str, transform: Affine, window: tuple[int, int, int, int], target: str
) -> tuple[FloatArray, FloatArray]:
    """The cell centres on a window's outline (every cell), projected to ``target``."""
    r0, r1, c0, c1 = window
    rows = np.arange(r0, r1) + 0.5
    cols = np.arange(c0, c1) + 0.5
    first, last = np.full(cols.size, r0 + 0.5), np.full(cols.size, r1 - 0.5)
    ring_r = np.concatenate([rows, rows, first, last])
    ring_c = np.concatenate(
        [np.full(rows.size, c0 + 0.5), np.full(rows.size, c1 - 0.5), cols, cols]
    )
    x, y = _apply(transform, ring_c, ring_r)
    t = _transformer(crs, target)
    px, py = t.transform(np.asarray(x), np.asarray(y))
    return np.asarray(px, dtype=float), np.asarray(py, dtype=float)


def source_window(emission: Emission, grid: LocalGrid) -> tuple[int, int, int, int]:
    """The emission window (row0, row1, col0, col1) whose cells can deposit flux on a local
    grid: the grid's outline (densified) taken back to the emission's CRS, one cell to spare,
    within the raster's rows and, unless it spans the whole globe (:meth:`Emission.read`
    wraps it), its columns. Longitudes are read around the tile's centre, so a window may
    cross the antimeridian; over a pole it takes every column up to the raster's edge."""
    rows, cols = grid.shape
    n = 64
    u = np.linspace(0.0, 1.0, n)
    xs = grid.left + grid.cell * cols * np.concatenate([u, u, np.zeros(n), np.ones(n)])
    ys = grid.top - grid.cell * rows * np.concatenate([np.zeros(n), np.ones(n), u, u])
    back = _transformer(grid.crs, emission.crs)
    ex, ey = (np.asarray(v, dtype=float) for v in back.transform(xs, ys))
    inverse = ~emission.transform
    height, width = emission.shape
    if emission.geographic:
        centre = grid.centre[0]
        ex = centre + (ex - centre + 180.0) % 360.0 - 180.0
    fc, fr = _apply(inverse, ex, ey)
    r0, r1 = math.floor(float(np.min(fr))) - 1, math.ceil(float(np.max(fr))) + 1
    c0, c1 = math.floor(float(np.min(fc))) - 1, math.ceil(float(np.max(fc))) + 1
    if emission.geographic:
        to_local = _transformer("EPSG:4326", grid.crs)
        for pole, edge in ((90.0, 0), (-90.0, height)):
            px, py = to_local.transform(0.0, pole)
            inside = grid.left <= px <= grid.left + grid.cell * cols
            if inside and grid.top - grid.cell * rows <= py <= grid.top:
                r0, r1 = min(r0, edge), max(r1, edge)
                c0, c1 = 0, width
    r0, r1 = max(r0, 0), min(r1, height)
    if not emission.wraps:
        c0, c1 = max(c0, 0), min(c1, width)
    elif c1 - c0 > width:
        c0, c1 = 0, width
    return r0, max(r1, r0), c0, max(c1, c0)


def _cell_sizes(emission: Emission, row: int) -> tuple[float, float]:
    """East-west and north-south size of a cell of the emission at a row [m]."""
    t = emission.transform
    if not emission.geographic:
        return abs(t.a), abs(t.e)
    lat = t.f + t.e * (row + 0.5)
    ns = AUTHALIC_RADIUS * math.radians(abs(t.e))
    return AUTHALIC_RADIUS * math.radians(abs(t.a)) * math.cos(math.radians(lat)), ns


def cell_flux(emission: Emission, window: tuple[int, int, int, int]) -> FloatArray:
    """Flux per cell ``(bands, rows, cols)`` [lm] of an emission window (density x area)."""
    r0, r1, c0, c1 = window
    density = emission.read(r0, r1, c0, c1)
    if emission.geographic:
        density *= geographic_cell_areas(emission.transform, np.arange(r0, r1))[None, :, None]
    else:
        density *= abs(emission.transform.a * emission.transform.e)
    return density


def lattice_step(cell: float) -> int:
    """Cells between the exactly projected nodes of a lattice over a grid of ``cell`` metres:
    as many as fit in :data:`LATTICE_SPAN`, at least one.

    Examples
    --------
    >>> lattice_step(463.3), lattice_step(100.0), lattice_step(55_000.0)
    (15, 70, 1)
    """
    return max(1, int(LATTICE_SPAN // cell))


def _lattice_nodes(size: int, step: int) -> FloatArray:
    """Edges 0, step, 2 step, ... of ``size`` cells, and ``size``."""
    return np.unique(np.append(np.arange(0, size, step), size)).astype(float)


def _lit_cells(
    emission: Emission, window: tuple[int, int, int, int]
) -> tuple[np.ndarray, np.ndarray, FloatArray, float] | None:
    """The lit cells of a window for :func:`deposit` and :func:`deposit_exact`: their rows and
    columns in the window, their flux ``(bands, n)`` [lm] and the window's largest cell side
    (the row nearest the equator) [m]; None when nothing is lit."""
    r0, r1, _, _ = window
    flux = cell_flux(emission, window)
    lit_r, lit_c = np.nonzero(np.any(flux != 0, axis=0))
    if lit_r.size == 0:
        return None
    values = flux[:, lit_r, lit_c]
    t = emission.transform
    sizes = [_cell_sizes(emission, r) for r in (r0, r1 - 1, _equator_row(t, r0, r1))]
    return lit_r, lit_c, values, max(max(size) for size in sizes)


def deposit(
    emission: Emission, window: tuple[int, int, int, int], grid: LocalGrid
) -> list[FloatArray]:
    """Each band's flux per local cell [lm]: every lit cell of the window split over k x k
    sub-points (:func:`subdivision`, k from the cell's row), each shared bilinearly between the
    four local cell centres around it (which keeps the flux's centroid, so that a source's
    position errs by second order only); shares outside the grid are left out (they lie beyond
    the stencil's reach of every sampled cell).

    The sub-points' local positions are interpolated bilinearly between the projected corners
    of a lattice of :func:`lattice_step` cells (:mod:`._deposit_numba`); :func:`deposit_exact`
    projects every sub-point and is the reference.
    """
    r0, r1, c0, c1 = window
    rows, cols = grid.shape
    lit = _lit_cells(emission, window)
    if lit is None:
        return [np.zeros((rows, cols)) for _ in range(emission.bands)]
    lit_r, lit_c, values, largest = lit
    t = emission.transform
    k = subdivision(largest, grid.cell)
    step = lattice_step(largest)
    node_r, node_c = _lattice_nodes(r1 - r0, step), _lattice_nodes(c1 - c0, step)
    nc, nr = np.meshgrid(c0 + node_c, r0 + node_r)
    x, y = _apply(t, nc, nr)
    px, py = _transformer(emission.crs, grid.crs).transform(x, y)
    gx = (np.asarray(px, dtype=float) - grid.left) / grid.cell
    gy = (grid.top - np.asarray(py, dtype=float)) / grid.cell
    out = deposit_lattice(lit_r, lit_c, values, k, node_r, node_c, gx, gy, (rows, cols))
    return list(out)


def deposit_exact(
    emission: Emission, window: tuple[int, int, int, int], grid: LocalGrid
) -> list[FloatArray]:
    """:func:`deposit` with every sub-point projected by PROJ and binned by numpy: the
    reference (slow: the projection took most of a tile's time)."""
    r0, _, c0, _ = window
    rows, cols = grid.shape
    out = [np.zeros(rows * cols) for _ in range(emission.bands)]
    lit = _lit_cells(emission, window)
    if lit is None:
        return [o.reshape(rows, cols) for o in out]
    lit_r, lit_c, values, largest = lit
    to_local = _transformer(emission.crs, grid.crs)
    t = emission.transform
    k = subdivision(largest, grid.cell)
    offsets = (np.arange(k) + 0.5) / k
    sub_c, sub_r = (a.ravel() for a in np.meshgrid(offsets, offsets))
    per_batch = max(1, SUBPOINT_BATCH // (k * k))
    for start in range(0, lit_r.size, per_batch):
        stop = min(start + per_batch, lit_r.size)
        fr = (r0 + lit_r[start:stop, None]) + sub_r[None, :]
        fc = (c0 + lit_c[start:stop, None]) + sub_c[None, :]
        x, y = _apply(t, fc.ravel(), fr.ravel())
        px, py = to_local.transform(np.asarray(x), np.asarray(y))
        # the sub-point between the four nearest local cell centres, shared bilinearly
        gx = (np.asarray(px) - grid.left) / grid.cell - 0.5
        gy = (grid.top - np.asarray(py)) / grid.cell - 0.5
        col, row = np.floor(gx), np.floor(gy)
        fx, fy = gx - col, gy - row
        for dr, wr in ((0, 1.0 - fy), (1, fy)):
            for dc, wc in ((0, 1.0 - fx), (1, fx)):
                rr, cc = row + dr, col + dc
                inside = (cc >= 0) & (cc < cols) & (rr >= 0) & (rr < rows)
                index = (rr[inside] * cols + cc[inside]).astype(np.int64)
                weight = (wr * wc)[inside]
                for band in range(emission.bands):
                    share = np.repeat(values[band, start:stop] / (k * k), k * k)[inside]
                    out[band] += np.bincount(index, weights=share * weight, minlength=rows * cols)
    return [o.reshape(rows, cols) for o in out]


def _equator_row(transform: Affine, r0: int, r1: int) -> int:
    """The row of ``r0 .. r1 - 1`` nearest the equator (the widest cells of a geographic grid)."""
    rows = np.arange(r0, r1)
    return int(rows[np.argmin(np.abs(transform.f + transform.e * (rows + 0.5)))])


def sample_back(
    values: FloatArray,
    grid: LocalGrid,
    output_crs: str,
    output_transform: Affine,
    window: tuple[int, int, int, int],
) -> FloatArray:
    """Bilinear samples of a local map on the interior (``values``) at a tile's output cell
    centres, a few rows at a time.

    The centres are projected exactly on a lattice of every :func:`lattice_step`-th row and
    column (and the last) and bilinearly in between: the projection is smooth, so that the
    position error is second order in the lattice's span (under a metre), while the projection
    of every centre took most of a tile's time."""
    r0, r1, c0, c1 = window
    a, _, b, _ = grid.interior
    to_local = _transformer(output_crs, grid.crs)
    step = lattice_step(grid.cell)
    lattice_rows = _lattice(r0, r1, step)
    lattice_cols = _lattice(c0, c1, step)
    t = output_transform
    lx, ly = np.meshgrid(lattice_cols + 0.5, lattice_rows + 0.5)
    x, y = _apply(t, lx, ly)
    px, py = (np.asarray(v, dtype=float) for v in to_local.transform(x, y))
    # fractional lattice index of every output row and column
    row_index = np.interp(np.arange(r0, r1), lattice_rows, np.arange(lattice_rows.size))
    col_index = np.interp(np.arange(c0, c1), lattice_cols, np.arange(lattice_cols.size))
    out = np.empty((r1 - r0, c1 - c0))
    for top in range(0, r1 - r0, SAMPLE_ROWS):
        bottom = min(top + SAMPLE_ROWS, r1 - r0)
        rr, cc = np.meshgrid(row_index[top:bottom], col_index, indexing="ij")
        qx = map_coordinates(px, [rr, cc], order=1, mode="nearest")
        qy = map_coordinates(py, [rr, cc], order=1, mode="nearest")
        col = (qx - grid.left) / grid.cell - 0.5 - b
        row = (grid.top - qy) / grid.cell - 0.5 - a
        out[top:bottom] = map_coordinates(values, [row, col], order=1, mode="nearest")
    return out


def _lattice(start: int, stop: int, step: int) -> np.ndarray:
    """Every ``step``-th index of ``start .. stop - 1``, and the last."""
    return np.unique(np.append(np.arange(start, stop, step), stop - 1)).astype(float)


# --- the tile store ----------------------------------------------------------------------------


def content_token(*parts: Any) -> str:
    """A short hash of the plan, the grid and the input's identity [hex]."""
    digest = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(np.ascontiguousarray(part).tobytes())
            digest.update(str(part.shape).encode())
        else:
            digest.update(repr(part).encode())
        digest.update(b"|")
    return digest.hexdigest()[:16]


def file_identity(path: str) -> tuple[str, int, int]:
    """A file's absolute path, size and modification time [ns]: a changed input differs."""
    stat = os.stat(path)
    return str(Path(path).resolve()), stat.st_size, stat.st_mtime_ns


class TileStore:
    """Finished tiles, one ``.npy`` file each, named by the tile index and a content token.

    A folder path or an fsspec URL (``memory://``, ``s3://`` ... where the filesystem is
    installed). Every file is written under a temporary name and renamed, so a tile that is
    there is whole.

    Parameters
    ----------
    location
        Folder or URL.
    token
        The content token (:func:`content_token`) the tiles of this map carry.
    """

    def __init__(self, location: str | os.PathLike[str], token: str) -> None:
        self.location = str(location)
        self.token = token
        self._url = "://" in self.location
        if self._url:
            import fsspec

            self._fs, self._root = fsspec.core.url_to_fs(self.location)
        else:
            self._fs, self._root = None, self.location
        try:
            if self._fs is None:
                Path(self._root).mkdir(parents=True, exist_ok=True)
            else:
                self._fs.makedirs(self._root, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"store={self.location!r}: cannot create it ({exc})") from None

    def name(self, tile: tuple[int, int]) -> str:
        """File name of a tile."""
        return f"tile-{tile[0]:05d}-{tile[1]:05d}-{self.token}.npy"

    def _path(self, name: str) -> str:
        return f"{self._root.rstrip('/')}/{name}"

    def has(self, tile: tuple[int, int]) -> bool:
        """Whether the tile is stored."""
        path = self._path(self.name(tile))
        return os.path.exists(path) if self._fs is None else bool(self._fs.exists(path))

    def write(self, tile: tuple[int, int], values: FloatArray) -> None:
        """Store a tile atomically (float32)."""
        final = self._path(self.name(tile))
        temporary = self._path(f".{self.name(tile)}.{uuid.uuid4().hex}.part")
        data = np.asarray(values, dtype=np.float32)
        if self._fs is None:
            with open(temporary, "wb") as handle:
                np.save(handle, data)
            os.replace(temporary, final)
        else:
            with self._fs.open(temporary, "wb") as handle:
                np.save(handle, data)
            self._fs.mv(temporary, final)

    def read(self, tile: tuple[int, int]) -> FloatArray:
        """A stored tile."""
        path = self._path(self.name(tile))
        if self._fs is None:
            return np.asarray(np.load(path), dtype=float)
        with self._fs.open(path, "rb") as handle:
            return np.asarray(np.load(handle), dtype=float)

    def tiles(self) -> Iterator[str]:
        """Names of the files of this map's tiles in the store."""
        names = (
            os.listdir(self._root)
            if self._fs is None
            else [p.rsplit("/", 1)[-1] for p in self._fs.ls(self._root, detail=False)]
        )
        return (n for n in names if n.startswith("tile-") and n.endswith(f"-{self.token}.npy"))

    def remove(self) -> None:
        """Remove this map's tiles, and the store when nothing else is left in it."""
        for name in list(self.tiles()):
            path = self._path(name)
            if self._fs is None:
                os.remove(path)
            else:
                self._fs.rm(path)
        try:
            if self._fs is None:
                if not os.listdir(self._root):
                    os.rmdir(self._root)
            elif not self._fs.ls(self._root, detail=False):
                self._fs.rmdir(self._root)
        except OSError:
            pass  # another map's tiles (or a file of the user's) keep the folder
