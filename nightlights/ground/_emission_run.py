"""The ground emission of :func:`~nightlights.ground.upward.emission`, one output window at a
time: its grid, its window loop, its checks and its memory estimate.

Each coarse cell of side :math:`\\Delta = f \\delta` (:math:`f` irradiance pixels of side
:math:`\\delta` along each axis) holds the flux density

.. math:: M_\\text{refl} = \\frac{1}{f^2} \\sum_{p \\in \\text{cell}} \\rho_p E_p, \\qquad
    M_\\text{up} = \\frac{1}{\\Delta^2} \\sum_{l \\in \\text{cell}} \\Phi_{\\text{up}, l}

(ground reflection of the photopic illuminance :math:`E` with albedo :math:`\\rho`,
flux-conserving block sums; each luminaire's flux above the horizontal in the cell holding
its light point). Neither needs a halo of irradiance pixels: a cell's sum reads only its own
pixels, so the coarse grid is cut into square windows of :data:`WINDOW_CELLS` cells
(:meth:`~nightlights.ground._windows.OutputGrid.windows`), and each window

1. reads its irradiance pixels in square reads of whole cells, at most :data:`READ_PIXELS`
   pixels each (parts of one cell, where one cell is larger), and sums each read into its
   cells: the sums of whole cells are those of the whole raster (:func:`cell_sums`, the same
   additions in the same order);
2. resamples an albedo raster onto each read's pixels (bilinear, as
   :func:`~nightlights.io.raster_on_grid` does for the whole grid) from a window of the albedo
   raster with a halo covering the bilinear kernel, stretched by GDAL over several albedo
   pixels when the albedo raster is finer (:func:`~nightlights.ground._windows.source_window`);
3. adds the uplight of the lights in its cells (:class:`Uplight`: each light's cell found
   once, the lights sorted by window);
4. hands both bands to a sink (the :class:`~nightlights.io.CogWriter`, or an array).

The checks of the whole raster (no infinite, negative or all-missing illuminance,
:class:`~nightlights.ground.checks.FiniteScan`; an albedo raster that covers the grid with
values in [0, 1]) are counted over the reads and raised after the last window, with the
messages one whole raster gives, before the writer finishes: the output appears complete or
not at all.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from affine import Affine
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS
from rasterio.warp import Resampling, reproject, transform_bounds

from nightlights._progress import progress_bar
from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError
from nightlights.ground._windows import (
    HALO_PIXELS,
    WARP_BYTES,
    ArraySource,
    BandSource,
    FileSource,
    OutputGrid,
    source_window,
    writer_memory,
)
from nightlights.ground.checks import FiniteScan
from nightlights.ground.stage import COG_OPTIONS
from nightlights.ground.tiles import RasterGrid
from nightlights.io import Raster, as_raster, source_label
from nightlights.io.streamed import CACHE_MB, CogWriter
from nightlights.io.terrain import uncovered_error

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "BANDS",
    "READ_PIXELS",
    "WINDOW_CELLS",
    "Albedo",
    "EmissionRun",
    "Uplight",
    "cell_index",
    "cell_sums",
    "check_emission_memory",
    "open_irradiance",
    "output_grid",
]

#: Side of the square output windows [cells]: a multiple of the COG's 512-cell blocks, so
#: that windows fill whole blocks (as ``emission viirs``'s).
WINDOW_CELLS = 2048
#: Irradiance pixels read and summed at a time [1]: 4 Mi pixels, reads of about 2048 x 2048
#: (the irradiance COG's 512-pixel blocks each decompressed about once), about 0.16 GiB of
#: working arrays (:data:`BYTES_PER_READ_PIXEL`).
READ_PIXELS = 1 << 22
#: Bytes per irradiance pixel of a read at its peak [B]: the masked float32 read, its float64
#: copy and the NaN-filled copy (later albedo x E and its NaN-free copy, and an albedo raster
#: resampled onto the read, come after that peak); measured with tracemalloc on reads of
#: 4 Mi pixels of the ~6 x 10^7-pixel irradiance raster of ``docs/scale.md``: 33.0 B
#: aggregated to the pixel size, 38.0 B to ten times it; rounded up.
BYTES_PER_READ_PIXEL = 40
#: Bytes per output cell of a window while its pixels are read [B]: the float64 sums.
BYTES_PER_SUM_CELL = 8
#: Bytes per output cell of a window as it is handed to the sink [B]: the two float64 bands,
#: their stack and its float32 copy for the writer (40.0 B measured as above).
BYTES_PER_WINDOW_CELL = 40
#: Bytes per output cell held when the raster is kept in memory [B]: the two float64 bands
#: and their float32 round trip.
BYTES_PER_CELL = 40
#: Band names of the emission raster, both [lm m-2].
BANDS = ("reflected", "uplight")


def cell_sums(values: FloatArray, factor: int) -> FloatArray:
    """Sums over cells of ``factor`` x ``factor`` pixels, rows first (partial edge cells too).

    Parameters
    ----------
    values
        (rows, cols) pixels, finite.
    factor
        Pixels per cell along each axis [1].

    Returns
    -------
    numpy.ndarray
        (ceil(rows / factor), ceil(cols / factor)) sums [unit of ``values``].

    Examples
    --------
    >>> cell_sums(np.arange(12.0).reshape(3, 4), 2).tolist()
    [[10.0, 18.0], [17.0, 21.0]]
    """
    rows, cols = values.shape
    # sums over runs of ``factor`` rows, then columns: no padded copy, so a factor far larger
    # than the raster costs nothing
    by_rows = np.add.reduceat(values, np.arange(0, rows, factor), axis=0)
    return np.asarray(np.add.reduceat(by_rows, np.arange(0, cols, factor), axis=1))


def cell_index(
    x: ArrayLike, y: ArrayLike, grid: RasterGrid
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]:
    """Row and column of the cell holding each point, and which points fall in the grid.

    Parameters
    ----------
    x, y
        Point positions [m].
    grid
        The grid.
    """
    px, py = (np.asarray(a, dtype=float) for a in (x, y))
    col = np.floor((px - grid.x_min) / grid.resolution).astype(np.int64)
    row = np.floor((grid.y_max - py) / grid.resolution).astype(np.int64)
    inside = (col >= 0) & (col < grid.cols) & (row >= 0) & (row < grid.rows)
    return row, col, inside


def _reads(count: int, factor: int, step: int) -> Iterator[tuple[int, int]]:
    """(first, number) of the reads of ``count`` pixels along an axis: runs of whole cells of
    at most ``step`` pixels, or parts of one cell where ``step`` is below ``factor``."""
    if step >= factor:
        step -= step % factor
        for start in range(0, count, step):
            yield start, min(step, count - start)
        return
    for cell in range(0, count, factor):
        end = min(cell + factor, count)
        for start in range(cell, end, step):
            yield start, min(step, end - start)


@dataclass
class Albedo:
    """The ground albedo on the irradiance grid, one read at a time.

    A number is used as it is; a raster is resampled bilinearly onto each read from a window
    of it, and what it leaves uncovered and its range are counted for :meth:`report`.

    Attributes
    ----------
    label
        The albedo raster's label, for messages.
    value
        A uniform albedo [1], or ``None`` for a raster.
    source
        The albedo raster's band, or ``None`` for a number.
    grid
        The irradiance grid.
    halo
        Albedo pixels read around a read's footprint [pixels]: the warper's
        :data:`~nightlights.ground._windows.HALO_PIXELS` and the bilinear kernel's reach,
        stretched over ``scale`` albedo pixels.
    scale
        Albedo pixels per irradiance pixel along an axis (the larger) [1].
    """

    label: str
    value: float | None
    source: BandSource | None = None
    grid: OutputGrid | None = None
    halo: int = HALO_PIXELS
    scale: float = 1.0
    missing: int = 0
    lowest: float = math.inf
    highest: float = -math.inf

    @classmethod
    def open(
        cls,
        albedo: float | Raster | xr.DataArray | str | os.PathLike[str],
        grid: OutputGrid,
        stack: ExitStack,
    ) -> Albedo:
        """A number (range checked) or a raster (its file kept open in ``stack``)."""
        if isinstance(albedo, (int, float)):
            value = float(albedo)
            if not 0.0 <= value <= 1.0:
                raise InputError(f"albedo={albedo!r}; expected a reflectance in [0, 1]")
            return cls("albedo", value)
        label = source_label(albedo, "albedo raster")
        source: BandSource
        if isinstance(albedo, (str, os.PathLike)):
            import rasterio

            path = Path(albedo)
            if not path.exists():
                raise InputError(f"{path}: no such file")
            try:
                dataset = stack.enter_context(rasterio.open(path))
            except rasterio.errors.RasterioIOError as exc:
                raise InputError(f"{path}: cannot read raster: {exc}") from exc
            if dataset.crs is None:
                raise CRSError(f"{label}: the albedo raster has no CRS")
            crs = CRS.from_user_input(dataset.crs.to_wkt())
            source = FileSource(dataset, dataset.transform, crs)
        else:
            raster = as_raster(albedo)
            if raster.crs is None:
                raise CRSError(f"{label}: the albedo raster has no CRS")
            source = ArraySource(raster.data[0], raster.transform, CRS.from_user_input(raster.crs))
        scale = _scale(source, grid)
        return cls(label, None, source, grid, HALO_PIXELS + math.ceil(scale), scale)

    def on(self, row: int, col: int, rows: int, cols: int) -> float | FloatArray:
        """The albedo of irradiance pixels [row, row + rows) x [col, col + cols) [1]."""
        if self.source is None or self.grid is None:
            assert self.value is not None
            return self.value
        out = np.full((rows, cols), np.nan)
        needed = source_window(self.source, self.grid, (row, col, rows, cols), halo=self.halo)
        if needed is not None:
            src_row, src_col, src_rows, src_cols = needed
            reproject(
                self.source.read(src_row, src_col, src_rows, src_cols),
                out,
                src_transform=self.source.transform @ Affine.translation(src_col, src_row),
                src_crs=self.source.crs.to_wkt(),
                src_nodata=np.nan,
                dst_transform=self.grid.transform @ Affine.translation(col, row),
                dst_crs=self.grid.crs.to_wkt(),
                dst_nodata=np.nan,
                resampling=Resampling.bilinear,
            )
        missing = int(np.isnan(out).sum())
        self.missing += missing
        if missing < out.size:
            self.lowest = min(self.lowest, float(np.nanmin(out)))
            self.highest = max(self.highest, float(np.nanmax(out)))
        return out

    def report(self) -> None:
        """Raise what :func:`~nightlights.io.raster_on_grid` and the range check raise for
        the whole grid: uncovered pixels, values outside [0, 1]."""
        if self.source is None or self.grid is None:
            return
        if self.missing:
            shape = (self.grid.rows, self.grid.cols)
            raise uncovered_error(
                self.label, "albedo raster", self.missing, self.grid.transform, shape
            )
        if not (self.lowest >= 0 and self.highest <= 1 and math.isfinite(self.highest)):
            raise InputError(
                f"{self.label}: albedo values span {self.lowest:.3g}..{self.highest:.3g}; "
                "expected [0, 1]"
            )

    def pixels(self, read_pixels: float) -> float:
        """Albedo raster pixels of a square read of ``read_pixels`` irradiance pixels [1]."""
        if self.source is None:
            return 0.0
        side = math.sqrt(read_pixels) * self.scale + 2 * self.halo + 2
        return min(side * side, float(self.source.shape[0]) * self.source.shape[1])


def _scale(source: BandSource, grid: OutputGrid) -> float:
    """Source pixels per grid pixel along an axis, the larger of the two (above 1 where the
    source is finer than the grid)."""
    corner = grid.transform
    xs, ys = zip(corner @ (0, 0), corner @ (grid.cols, grid.rows), strict=True)
    left, bottom, right, top = transform_bounds(
        grid.crs, source.crs, min(xs), min(ys), max(xs), max(ys), densify_pts=21
    )
    if not all(math.isfinite(b) for b in (left, bottom, right, top)):
        return 1.0
    across = (right - left) / abs(source.transform.a) / grid.cols
    down = (top - bottom) / abs(source.transform.e) / grid.rows
    return max(across, down, 0.0)


class Uplight:
    """The lights' upward flux in the cells of a window.

    Parameters
    ----------
    row, col
        Cell of each light inside the grid [cells].
    flux
        Upward flux of each light [lm].
    grid
        The output grid.
    side
        Window side [cells] (:data:`WINDOW_CELLS`).
    """

    def __init__(
        self, row: ArrayLike, col: ArrayLike, flux: ArrayLike, grid: OutputGrid, side: int
    ) -> None:
        self._side, self._across = side, math.ceil(grid.cols / side)
        rows, cols = np.asarray(row, np.int64), np.asarray(col, np.int64)
        key = (rows // side) * self._across + cols // side
        # stable: the lights of a cell are summed in their order, as one bincount of the
        # whole grid sums them
        order = np.argsort(key, kind="stable")
        self._key, self._row, self._col = key[order], rows[order], cols[order]
        self._flux = np.asarray(flux, dtype=float)[order]
        self._area = abs(grid.transform.a * grid.transform.e)

    def window(self, window: tuple[int, int, int, int]) -> FloatArray:
        """Uplight flux density of a window [lm m-2]."""
        row, col, rows, cols = window
        key = (row // self._side) * self._across + col // self._side
        first, last = np.searchsorted(self._key, [key, key + 1])
        cells = (self._row[first:last] - row) * cols + (self._col[first:last] - col)
        density = np.bincount(cells, weights=self._flux[first:last], minlength=rows * cols)
        return np.asarray(density.reshape(rows, cols) / self._area)


@dataclass
class EmissionRun:
    """One ground emission: its sources, its grid and its window loop.

    Attributes
    ----------
    label
        The irradiance raster's label, for messages.
    source
        Its photopic band [lx].
    factor
        Irradiance pixels per output cell along each axis [1].
    grid
        The output grid.
    albedo
        The albedo.
    side
        Window side [cells] (:data:`WINDOW_CELLS`).
    uplight
        The lights' uplight, or ``None`` for none.
    progress
        Show a progress bar over the windows.
    """

    label: str
    source: BandSource
    factor: int
    grid: OutputGrid
    albedo: Albedo
    side: int
    uplight: Uplight | None = None
    progress: bool = True
    scan: FiniteScan = field(default_factory=FiniteScan)

    def read_pixels(self) -> int:
        """Irradiance pixels per read: :data:`READ_PIXELS`, fewer where the albedo raster is
        finer than the irradiance, so that its pixels of a read stay within the budget."""
        return max(1, int(READ_PIXELS / max(1.0, self.albedo.scale) ** 2))

    def reflected(self, window: tuple[int, int, int, int]) -> FloatArray:
        """albedo x E of a window's cells [lm m-2], its pixels counted for the checks."""
        row, col, rows, cols = window
        factor = self.factor
        height, width = self.source.shape
        top, left = row * factor, col * factor
        budget = self.read_pixels()
        sums = np.zeros((rows, cols))
        down = max(1, math.isqrt(budget))
        for start_row, count_rows in _reads(min(rows * factor, height - top), factor, down):
            # square reads of whole cells: about as many columns as rows
            across = max(1, budget // count_rows)
            for start_col, count_cols in _reads(min(cols * factor, width - left), factor, across):
                first = (top + start_row, left + start_col, count_rows, count_cols)
                illuminance = self.source.read(*first)
                self.scan.add(illuminance)
                # an infinite value is refused after the last window: 0 until then
                product = np.nan_to_num(
                    self.albedo.on(*first) * illuminance, nan=0.0, posinf=0.0, neginf=0.0
                )
                part = cell_sums(product, factor)
                cell_row, cell_col = start_row // factor, start_col // factor
                sums[cell_row : cell_row + part.shape[0], cell_col : cell_col + part.shape[1]] += (
                    part
                )
        return sums / float(factor) ** 2

    def run(self, sink: Callable[[FloatArray, int, int], None]) -> dict[str, float]:
        """Compute every window into ``sink``; the total flux per band [lm]. Raises the
        checks of the whole raster after the last window."""
        windows = self.grid.windows(self.side)
        area = abs(self.grid.transform.a * self.grid.transform.e)
        totals = dict.fromkeys(BANDS, 0.0)
        with progress_bar(self.progress) as bar:
            task = bar.add_task("emission windows", total=len(windows))
            for window in windows:
                reflected = self.reflected(window)
                uplight = (
                    np.zeros_like(reflected)
                    if self.uplight is None
                    else self.uplight.window(window)
                )
                totals["reflected"] += float(reflected.sum() * area)
                totals["uplight"] += float(uplight.sum() * area)
                sink(np.stack([reflected, uplight]), window[0], window[1])
                bar.advance(task)
        self.scan.report(self.label, "illuminance", "lx")
        self.albedo.report()
        return totals

    def in_memory(
        self,
        tags: Callable[[Mapping[str, float]], Mapping[str, Any]],
        band_tags: Sequence[Mapping[str, str]],
    ) -> tuple[Raster, dict[str, float]]:
        """The windows assembled in memory: the raster (float32 values) and its flux [lm]."""
        out = np.zeros((len(BANDS), self.grid.rows, self.grid.cols))

        def sink(values: FloatArray, row: int, col: int) -> None:
            out[:, row : row + values.shape[1], col : col + values.shape[2]] = values

        totals = self.run(sink)
        raster = Raster(
            out.astype(np.float32).astype(np.float64),
            self.grid.transform,
            self.grid.crs,
            descriptions=BANDS,
            units=("lm m-2",) * len(BANDS),
            tags={key: str(value) for key, value in tags(totals).items()},
            band_tags=tuple(band_tags),
        )
        return raster, totals

    def streamed(
        self,
        output: Path,
        tags: Callable[[Mapping[str, float]], Mapping[str, Any]],
        band_tags: Sequence[Mapping[str, str]],
    ) -> dict[str, float]:
        """The windows written to ``output`` as they are done; the flux per band [lm]."""
        writer = CogWriter(
            output,
            shape=(len(BANDS), self.grid.rows, self.grid.cols),
            transform=self.grid.transform,
            crs=self.grid.crs,
            descriptions=BANDS,
            units=("lm m-2",) * len(BANDS),
            band_tags=tuple(band_tags),
            **COG_OPTIONS,
        )
        with writer:
            totals = self.run(lambda values, row, col: writer.write(values, row=row, col=col))
            writer.update_tags(**tags(totals))
        return totals


def open_irradiance(
    irradiance: Raster | xr.DataArray | str | os.PathLike[str], label: str, stack: ExitStack
) -> tuple[BandSource, int]:
    """The photopic band of the irradiance raster (a file kept open in ``stack``, with GDAL's
    block cache limited) and the number of bands of a raster converted in memory (0 for a file
    or a :class:`~nightlights.io.Raster`, whose bands are not copied)."""
    if not isinstance(irradiance, (str, os.PathLike)):
        raster = as_raster(irradiance)
        crs = _grid_crs(raster.transform, raster.crs, label)
        band = _photopic_band(raster.descriptions, raster.band_tags, label)
        copied = 0 if isinstance(irradiance, Raster) else raster.count
        return ArraySource(raster.data[band], raster.transform, crs), copied
    import rasterio

    path = Path(irradiance)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    stack.enter_context(rasterio.Env(GDAL_CACHEMAX=CACHE_MB))
    try:
        dataset = stack.enter_context(rasterio.open(path))
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{path}: cannot read raster: {exc}") from exc
    read = None if dataset.crs is None else CRS.from_user_input(dataset.crs.to_wkt())
    crs = _grid_crs(dataset.transform, read, label)
    file = FileSource(dataset, dataset.transform, crs)
    band = _photopic_band(file.descriptions, file.band_tags, label)
    return FileSource(dataset, dataset.transform, crs, band + 1), 0


def output_grid(source: BandSource, label: str, resolution: float) -> tuple[OutputGrid, int]:
    """The output grid of ``resolution`` cells over the irradiance grid and the irradiance
    pixels per cell along each axis."""
    transform = source.transform
    fine = transform.a
    factor = round(resolution / fine)
    if factor < 1 or not math.isclose(factor * fine, resolution, rel_tol=1e-6):
        raise InputError(
            f"resolution={resolution} m is not an integer multiple of the irradiance pixel "
            f"size {fine} m; expected e.g. {max(1, factor) * fine} m"
        )
    rows, cols = (math.ceil(n / factor) for n in source.shape)
    coarse = RasterGrid(transform.c, transform.f, float(resolution), rows, cols)
    return OutputGrid(coarse.transform, rows, cols, source.crs), factor


def _grid_crs(transform: Affine, crs: CRS | None, label: str) -> CRS:
    """The irradiance grid's CRS, checked with its transform."""
    if crs is None:
        raise CRSError(f"{label}: the irradiance raster has no CRS")
    if crs.is_geographic:
        raise CRSError(
            f"{label}: the irradiance raster is on a geographic grid ({crs.name}); expected a "
            "projected CRS in metres, as the irradiance stage writes"
        )
    if transform.b != 0 or transform.d != 0 or not math.isclose(transform.a, -transform.e):
        raise InputError(f"{label}: expected a north-up grid with square pixels, got {transform}")
    return crs


def _photopic_band(
    descriptions: Sequence[str], band_tags: Sequence[Mapping[str, str]], label: str
) -> int:
    for index, (description, tags) in enumerate(zip(descriptions, band_tags, strict=True)):
        if tags.get("sensor") == "photopic" or description == "photopic":
            return index
    raise InputError(
        f"{label}: no photopic band (band descriptions {list(descriptions)}); "
        "run irradiance with 'photopic' among sensors="
    )


def check_emission_memory(run: EmissionRun, *, in_memory: bool, copied_bands: int = 0) -> None:
    """Refuse a ground emission whose estimated peak memory is over the limit.

    One window at its peak: while its pixels are read, a read's working arrays
    (:data:`READ_PIXELS` irradiance pixels at :data:`BYTES_PER_READ_PIXEL`, or after that peak
    the albedo resampled onto them from an albedo raster's window with GDAL's warp buffers,
    whichever is larger) and the window's sums
    (:data:`BYTES_PER_SUM_CELL`), or its bands handed to the sink
    (:data:`BYTES_PER_WINDOW_CELL`); plus the output grid when it is held in memory
    (:data:`BYTES_PER_CELL`) or the writer's block cache and the style's sample when it is
    streamed to a file (:func:`~nightlights.ground._windows.writer_memory`), and the float64
    bands of an irradiance DataArray converted in memory.

    Parameters
    ----------
    run
        The emission to run.
    in_memory
        Whether the output raster is held in memory (no output file).
    copied_bands
        Bands of the irradiance raster converted to float64 in memory [1].
    """
    height, width = run.source.shape
    pixels = float(min(run.read_pixels(), height * width))
    read = pixels * BYTES_PER_READ_PIXEL
    if run.albedo.source is not None:
        # after the read's peak: the illuminance, the albedo grid, the albedo raster's window
        # and GDAL's warp buffers
        albedo_pixels = run.albedo.pixels(pixels)
        warp = min(WARP_BYTES, albedo_pixels * 8 + pixels * 8)
        read = max(read, pixels * 16 + albedo_pixels * 8 + warp)
    window_cells = float(min(run.side, run.grid.rows)) * min(run.side, run.grid.cols)
    window = max(read + window_cells * BYTES_PER_SUM_CELL, window_cells * BYTES_PER_WINDOW_CELL)
    cells = float(run.grid.rows) * run.grid.cols
    output = cells * BYTES_PER_CELL if in_memory else writer_memory(cells, len(BANDS))
    estimate = window + output + 8.0 * copied_bands * height * width
    check_memory(
        estimate,
        f"emission from {run.label} ({height} x {width} pixels, {run.grid.rows} x "
        f"{run.grid.cols} cells)",
        option="use a coarser resolution= or write an output file" if in_memory else None,
    )
