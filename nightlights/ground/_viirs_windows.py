"""A VIIRS radiance raster turned into upward flux density one output window at a time.

:func:`~nightlights.ground.upward.emission_from_viirs` never holds a whole national mosaic:
the output grid is cut into square windows of :data:`WINDOW_CELLS` cells, and each window

1. reads the source pixels it needs (a window of the file, or a slice of an in-memory
   raster): the same pixels when the grid is kept, else the footprint of the output window
   transformed into the source CRS (densified edges) plus a halo of
   :data:`~nightlights.ground._windows.HALO_PIXELS`
   (:func:`~nightlights.ground._windows.source_window`);
2. cleans them (:class:`~nightlights.ground.viirs_input.RadianceScan`: undeclared fill values
   to NaN, negative radiance to 0) and converts radiance to flux density;
3. reprojects them onto the window by the area-weighted average (GDAL's ``average``), as the
   whole raster was reprojected before: each output cell is the mean over the source pixels
   it overlaps, weighted by the overlap, so flux is conserved to the accuracy of that average;
4. hands the window to a sink (the :class:`~nightlights.io.CogWriter`, or an array).

The checks count every pixel once: on a kept grid the windows do not overlap and are counted
as they are converted; with a reprojection the windows' sources overlap (halo, curved
footprints), so the counts come from a first pass over the source in disjoint strips
(:func:`scan_source`), which also refuses a raster (infinite radiance, no radiance) before any
window is computed.

Total flux: density x cell area, the area constant on a projected grid and the geodesic area
of each row's cells on a geographic one
(:func:`~nightlights.ground.upward.geographic_cell_areas`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from affine import Affine
from rasterio.warp import Resampling, reproject
from rich.progress import Progress

from nightlights._progress import progress_bar
from nightlights._typing import FloatArray
from nightlights.ground._windows import (
    HALO_PIXELS,
    WARP_BYTES,
    BandSource,
    OutputGrid,
    source_window,
    strips,
)
from nightlights.ground.viirs_input import RadianceScan

#: Side of the square output windows [cells]: 4 Mi cells, about 0.3 GiB of working arrays
#: (:data:`BYTES_PER_SOURCE_PIXEL`) when source and output pixels match; a multiple of the
#: COG's 512-cell blocks, so that windows fill whole blocks.
WINDOW_CELLS = 2048
#: Bytes per source pixel of a window at its peak [B]: the masked float32 read and its
#: float64 copy, the NaN-filled copy, the negatives' mask and the radiance with them at 0, the
#: flux density's temporaries; 33.0 B measured (tracemalloc) on a 2048 x 2048 window of the
#: synthetic mosaic (``benchmarks/_mosaic.py``), rounded up.
BYTES_PER_SOURCE_PIXEL = 36
#: Bounding box of a reprojected window's source footprint over its mean side [1].
_FOOTPRINT_MARGIN = 1.2
#: Bytes per output cell of a window [B]: the float64 window, its float32 copy for the writer.
BYTES_PER_WINDOW_CELL = 12


def scan_source(
    source: BandSource, scan: RadianceScan, *, window: int, advance: Callable[[], Any]
) -> None:
    """Count what every source pixel holds, in disjoint strips of ``window`` ** 2 pixels."""
    cols = source.shape[1]
    for row, rows in strips(source.shape, window * window):
        scan.clean(source.read(row, 0, rows, cols))
        advance()


def window_density(
    source: BandSource,
    grid: OutputGrid,
    window: tuple[int, int, int, int],
    scan: RadianceScan,
    density: Callable[[FloatArray], FloatArray],
) -> FloatArray:
    """Flux density [lm m-2] of one output window (NaN where no source pixel reaches).

    Parameters
    ----------
    source
        The radiance.
    grid
        The output grid.
    window
        (row, col, rows, cols) of the output window.
    scan
        Where the cleaning counts go (a throw-away one when a first pass counted them).
    density
        Radiance [nW cm-2 sr-1] -> flux density [lm m-2].
    """
    row, col, rows, cols = window
    if grid.kept(source):
        return _density(source.read(row, col, rows, cols), scan, density)
    out = np.full((rows, cols), np.nan)
    needed = source_window(source, grid, window)
    if needed is None:
        return out
    src_row, src_col, src_rows, src_cols = needed
    values = _density(source.read(src_row, src_col, src_rows, src_cols), scan, density)
    reproject(
        values,
        out,
        src_transform=source.transform @ Affine.translation(src_col, src_row),
        src_crs=source.crs.to_wkt(),
        src_nodata=np.nan,
        dst_transform=grid.transform @ Affine.translation(col, row),
        dst_crs=grid.crs.to_wkt(),
        dst_nodata=np.nan,
        resampling=Resampling.average,
    )
    return out


def _density(
    radiance: FloatArray, scan: RadianceScan, density: Callable[[FloatArray], FloatArray]
) -> FloatArray:
    """Cleaned radiance (fill values NaN, negatives 0) as flux density."""
    values = scan.clean(radiance)
    with np.errstate(invalid="ignore"):
        values = np.where(values < 0, 0.0, values)
    return density(values)


def window_progress(progress: bool) -> Progress:
    """A transient rich progress bar with the elapsed and remaining time."""
    return progress_bar(progress)


def window_memory(in_shape: tuple[int, int], grid: OutputGrid, *, window: int, kept: bool) -> float:
    """Working memory of one window [B] (source pixels, output cells, GDAL's warp buffers).

    Parameters
    ----------
    in_shape
        The source raster's (rows, cols) [pixels].
    grid
        The output grid.
    window
        Window side [cells].
    kept
        Whether the grid is the source's own.
    """
    rows, cols = min(window, grid.rows), min(window, grid.cols)
    if kept:
        source_pixels = float(rows) * cols
    else:
        # source pixels per output cell along each axis, the footprint's bounding box (its
        # rotation by the meridians' convergence and its curved edges: a fifth more per side
        # covers a window of a UTM zone) and the halo
        scale = math.sqrt(in_shape[0] * in_shape[1] / (float(grid.rows) * grid.cols))
        side_rows = min(in_shape[0], _FOOTPRINT_MARGIN * rows * scale + 2 * HALO_PIXELS + 2)
        side_cols = min(in_shape[1], _FOOTPRINT_MARGIN * cols * scale + 2 * HALO_PIXELS + 2)
        source_pixels = side_rows * side_cols
    warp = 0 if kept else min(WARP_BYTES, source_pixels * 8 + float(rows) * cols * 8)
    return (
        source_pixels * BYTES_PER_SOURCE_PIXEL + float(rows) * cols * BYTES_PER_WINDOW_CELL + warp
    )
