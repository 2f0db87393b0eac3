"""Rasters read and written by windows: the pieces the out-of-core ground stages share.

The ``emission viirs`` conversion (:mod:`nightlights.ground._viirs_run`) and the ground
emission (:mod:`nightlights.ground._emission_run`) never hold a whole raster: their output
grid (:class:`OutputGrid`) is cut into square windows, each window reads only the source
pixels it needs from a :class:`BandSource` (a window of an open file, or a slice of an
in-memory band) and is handed to a sink as it is done, the streaming writer
(:class:`~nightlights.io.CogWriter`) or an array. Memory is then a window's working arrays and
the writer's block cache (:func:`writer_memory`), whatever the raster's size.

Where a window is resampled from a source on another grid, the source pixels it needs are
the output window's footprint transformed into the source's CRS (densified edges, so a curved
footprint is covered), rounded outward, plus a halo (:func:`source_window`): resampling
:math:`v(x) = \\sum_j w_j(x) s_j` reads every source pixel :math:`s_j` of nonzero weight, so
the halo covers the resampling kernel's reach beyond the footprint (:data:`HALO_PIXELS`, more
for a kernel stretched over several source pixels), and a window then gets exactly the values
the whole raster's resampling gives it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from affine import Affine
from pyproj import CRS
from rasterio.warp import transform_bounds

from nightlights._typing import FloatArray
from nightlights.io.streamed import CACHE_MB
from nightlights.io.styles import SAMPLE_LIMIT

__all__ = [
    "HALO_PIXELS",
    "WARP_BYTES",
    "ArraySource",
    "BandSource",
    "FileSource",
    "OutputGrid",
    "source_window",
    "strips",
    "writer_memory",
]

#: Source pixels added around an output window's footprint [pixels]: the footprint's corners
#: are rounded outward and GDAL's warper reads a pixel beyond an edge it touches.
HALO_PIXELS = 2
#: GDAL's warp buffers of a resampled window [B]: its default warp memory limit (64 MB,
#: ``GDALWarpOptions.dfWarpMemoryLimit``), which ``reproject`` keeps (``warp_mem_limit=0``).
WARP_BYTES = 64 * 2**20
#: Bytes of GDAL's block cache per output cell and band while the output is written, up to
#: :data:`~nightlights.io.streamed.CACHE_MB` (the cache the writer sets, shared by the reads
#: of the input): the scratch file's blocks and the COG's [B].
_CACHE_BYTES_PER_CELL = 8
#: Bytes per value of the style's decimated read (float32, its float64 copy) [B].
_STYLE_BYTES_PER_SAMPLE = 8


class BandSource(Protocol):
    """One band of a raster, read by windows (float64, nodata as NaN)."""

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
        """Pixels [row, row + rows) x [col, col + cols) [band unit]."""
        ...


@dataclass(frozen=True)
class ArraySource:
    """An in-memory band as a :class:`BandSource`."""

    values: FloatArray
    transform: Affine
    crs: CRS

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) [pixels]."""
        rows, cols = self.values.shape
        return rows, cols

    def read(self, row: int, col: int, rows: int, cols: int) -> FloatArray:
        """A view of the pixels (a caller copies before it changes any)."""
        return self.values[row : row + rows, col : col + cols]


@dataclass(frozen=True)
class FileSource:
    """A band of an open rasterio dataset as a :class:`BandSource`.

    Attributes
    ----------
    dataset
        The open dataset.
    transform, crs
        Its grid (the CRS checked by the caller).
    band
        1-based band index read.
    """

    dataset: Any
    transform: Affine
    crs: CRS
    band: int = 1

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

        values = self.dataset.read(self.band, window=Window(col, row, cols, rows), masked=True)
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

    def kept(self, source: BandSource) -> bool:
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


def source_window(
    source: BandSource,
    grid: OutputGrid,
    window: tuple[int, int, int, int],
    *,
    halo: int = HALO_PIXELS,
) -> tuple[int, int, int, int] | None:
    """(row, col, rows, cols) of the source pixels an output window needs, or None.

    Parameters
    ----------
    source
        The source band.
    grid
        The output grid.
    window
        (row, col, rows, cols) of the output window [cells].
    halo
        Source pixels added on each side of the footprint [pixels].
    """
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
    r0 = max(0, math.floor(min(src_rows)) - halo)
    r1 = min(height, math.ceil(max(src_rows)) + halo)
    c0 = max(0, math.floor(min(src_cols)) - halo)
    c1 = min(width, math.ceil(max(src_cols)) + halo)
    if r1 <= r0 or c1 <= c0:
        return None
    return r0, c0, r1 - r0, c1 - c0


def writer_memory(cells: float, bands: int = 1) -> float:
    """Memory of a :class:`~nightlights.io.CogWriter` of ``cells`` cells per band [B].

    GDAL's block cache (the scratch file's blocks and the COG's, up to
    :data:`~nightlights.io.streamed.CACHE_MB`) and the style's decimated read of every band
    (:data:`~nightlights.io.styles.SAMPLE_LIMIT` values each).
    """
    cache = min(CACHE_MB * 2**20, _CACHE_BYTES_PER_CELL * cells * bands)
    return cache + _STYLE_BYTES_PER_SAMPLE * min(cells, SAMPLE_LIMIT) * bands
