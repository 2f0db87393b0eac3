"""A VIIRS radiance raster turned into upward flux density one output window at a time.

:func:`~nightlights.ground.upward.emission_from_viirs` never holds a whole national mosaic:
the output grid is cut into square windows of :data:`WINDOW_CELLS` cells, and each window

1. reads the source pixels it needs (a window of the file, or a slice of an in-memory
   raster): the same pixels when the grid is kept, else the footprint of the output window
   transformed into the source CRS (densified edges) plus a halo of :data:`HALO_PIXELS`;
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
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from affine import Affine
from pyproj import CRS
from rasterio.warp import Resampling, reproject, transform_bounds
from rich.progress import Progress

from nightlights._progress import progress_bar
from nightlights._typing import FloatArray
from nightlights.ground.viirs_input import RadianceScan

#: Side of the square output windows [cells]: 4 Mi cells, about 0.3 GiB of working arrays
#: (:data:`BYTES_PER_SOURCE_PIXEL`) when source and output pixels match; a multiple of the
#: COG's 512-cell blocks, so that windows fill whole blocks.
WINDOW_CELLS = 2048
#: Source pixels added around an output window's footprint [pixels]: the footprint's corners
#: are rounded outward and GDAL's warper reads a pixel beyond an edge it touches.
HALO_PIXELS = 2
#: Bytes per source pixel of a window at its peak [B]: the masked float32 read and its
#: float64 copy, the NaN-filled copy, the negatives' mask and the radiance with them at 0, the
#: flux density's temporaries; 33.0 B measured (tracemalloc) on a 2048 x 2048 window of the
#: synthetic mosaic (``benchmarks/_mosaic.py``), rounded up.
BYTES_PER_SOURCE_PIXEL = 36
#: GDAL's warp buffers of a reprojected window [B]: its default warp memory limit (64 MB,
#: ``GDALWarpOptions.dfWarpMemoryLimit``), which ``reproject`` keeps (``warp_mem_limit=0``).
WARP_BYTES = 64 * 2**20
#: Bounding box of a reprojected window's source footprint over its mean side [1].
_FOOTPRINT_MARGIN = 1.2
#: Bytes per output cell of a window [B]: the float64 window, its float32 copy for the writer.
BYTES_PER_WINDOW_CELL = 12


class RadianceSource(Protocol):
    """Band 1 of a VIIRS raster, read by windows (float64 radiance, nodata as NaN)."""

    @property
    def transform(self) -> Affine:
        """Affine transform of the top-left pixel corner."""
        ...

    @property
    def crs(self) -> CRS:
        """The raster's CRS."""
        ...

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) [pixels]."""
        ...

    def read(self, row: int, col: int, rows: int, cols: int) -> FloatArray:
        """Pixels [row, row + rows) x [col, col + cols) [nW cm-2 sr-1]."""
        ...


@dataclass(frozen=True)
class ArraySource:
    """An in-memory band as a :class:`RadianceSource`."""

    values: FloatArray
    transform: Affine
    crs: CRS

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) [pixels]."""
        rows, cols = self.values.shape
        return rows, cols

    def read(self, row: int, col: int, rows: int, cols: int) -> FloatArray:
        """A view of the pixels (the cleaning copies before it changes any)."""
        return self.values[row : row + rows, col : col + cols]


@dataclass(frozen=True)
class FileSource:
    """Band 1 of an open rasterio dataset as a :class:`RadianceSource`."""

    dataset: Any
    transform: Affine
    crs: CRS

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) [pixels]."""
        return int(self.dataset.height), int(self.dataset.width)

    @property
    def count(self) -> int:
        """Bands [1]."""
        return int(self.dataset.count)

    @property
    def descriptions(self) -> tuple[str, ...]:
        """Band names."""
        return tuple(d or "" for d in self.dataset.descriptions)

    @property
    def units(self) -> tuple[str, ...]:
        """Band units."""
        return tuple(u or "" for u in self.dataset.units)

    @property
    def tags(self) -> dict[str, str]:
        """Dataset-level metadata."""
        return dict(self.dataset.tags())

    @property
    def band_tags(self) -> tuple[dict[str, str], ...]:
        """Metadata per band."""
        return tuple(dict(self.dataset.tags(i)) for i in range(1, self.count + 1))

    def read(self, row: int, col: int, rows: int, cols: int) -> FloatArray:
        """The window as float64 with declared nodata as NaN (as :meth:`Raster.read`)."""
        from rasterio.windows import Window

        values = self.dataset.read(1, window=Window(col, row, cols, rows), masked=True)
        return np.asarray(values.astype(np.float64).filled(np.nan))


@dataclass(frozen=True)
class OutputGrid:
    """The output raster's grid.

    Attributes
    ----------
    transform
        Affine transform of the top-left corner.
    rows, cols
        Shape [cells].
    crs
        Its CRS (projected, or geographic when a wide geographic raster keeps its grid).
    """

    transform: Affine
    rows: int
    cols: int
    crs: CRS

    def windows(self, size: int) -> list[tuple[int, int, int, int]]:
        """(row, col, rows, cols) of the windows of ``size`` x ``size`` cells, row-major."""
        return [
            (row, col, min(size, self.rows - row), min(size, self.cols - col))
            for row in range(0, self.rows, size)
            for col in range(0, self.cols, size)
        ]

    def kept(self, source: RadianceSource) -> bool:
        """Whether the grid is the source's own (no reprojection)."""
        return (
            self.crs == source.crs
            and self.transform == source.transform
            and (self.rows, self.cols) == source.shape
        )


def strips(shape: tuple[int, int], pixels: int) -> Iterator[tuple[int, int]]:
    """(first row, rows) of full-width strips of about ``pixels`` pixels."""
    rows, cols = shape
    step = max(1, pixels // max(1, cols))
    for row in range(0, rows, step):
        yield row, min(step, rows - row)


def scan_source(
    source: RadianceSource, scan: RadianceScan, *, window: int, advance: Callable[[], Any]
) -> None:
    """Count what every source pixel holds, in disjoint strips of ``window`` ** 2 pixels."""
    cols = source.shape[1]
    for row, rows in strips(source.shape, window * window):
        scan.clean(source.read(row, 0, rows, cols))
        advance()


def source_window(
    source: RadianceSource, grid: OutputGrid, window: tuple[int, int, int, int]
) -> tuple[int, int, int, int] | None:
    """(row, col, rows, cols) of the source pixels an output window needs, or None."""
    row, col, rows, cols = window
    corner = grid.transform @ Affine.translation(col, row)
    xs, ys = zip(corner @ (0, 0), corner @ (cols, rows), strict=True)
    bounds = transform_bounds(
        grid.crs, source.crs, min(xs), min(ys), max(xs), max(ys), densify_pts=21
    )
    if not all(math.isfinite(b) for b in bounds):
        return 0, 0, *source.shape  # a footprint PROJ cannot bound: read everything
    inverse = ~source.transform
    corners = [inverse @ (x, y) for x in bounds[0::2] for y in bounds[1::2]]
    src_cols = [c for c, _ in corners]
    src_rows = [r for _, r in corners]
    height, width = source.shape
    r0 = max(0, math.floor(min(src_rows)) - HALO_PIXELS)
    r1 = min(height, math.ceil(max(src_rows)) + HALO_PIXELS)
    c0 = max(0, math.floor(min(src_cols)) - HALO_PIXELS)
    c1 = min(width, math.ceil(max(src_cols)) + HALO_PIXELS)
    if r1 <= r0 or c1 <= c0:
        return None
    return r0, c0, r1 - r0, c1 - c0


def window_density(
    source: RadianceSource,
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
