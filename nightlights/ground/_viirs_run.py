"""The VIIRS conversion of :func:`~nightlights.ground.upward.emission_from_viirs`: its output
grid, its window loop, its totals and its memory estimate.

The output grid: a projected input keeps its CRS; a geographic input within one UTM zone goes
to the local UTM zone of its centre; a geographic input wider than one zone
(:data:`~nightlights.ground.viirs_input.ZONE_WIDTH`) keeps its own grid, its cells holding
flux density [lm m-2] as a projected grid's do, so that no part of a national mosaic is
stretched by a zone's scale factor (8 % 30 deg from a zone's centre); ``target_crs=`` forces a
projection. The windows themselves are computed by :mod:`nightlights.ground._viirs_windows`.

The flux of a geographic grid is the density times each cell's geodesic area,
:func:`geographic_cell_areas` (Snyder 1987, Eqs. 3-11 to 3-13: the area between two parallels
on the ellipsoid from the authalic latitude), exact on the ellipsoid.

References
----------
Snyder, J. P. (1987). Map Projections: A Working Manual. USGS Prof. Paper 1395, p. 16.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
from affine import Affine
from pyproj import CRS
from rasterio.warp import calculate_default_transform
from shapely.geometry import box

from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError
from nightlights.ground import _viirs_windows
from nightlights.ground._viirs_windows import (
    scan_source,
    window_density,
    window_memory,
    window_progress,
)
from nightlights.ground._windows import (
    BandSource,
    FileSource,
    OutputGrid,
    strips,
    writer_memory,
)
from nightlights.ground.checks import VIIRS_BYTES_PER_CELL, parse_crs
from nightlights.ground.stage import COG_OPTIONS
from nightlights.ground.viirs_input import (
    ZONE_WIDTH,
    RadianceScan,
    RasterMetadata,
    check_radiance_source,
    warn_zone_span,
    zone_length_error,
)
from nightlights.io import Raster, ensure_projected
from nightlights.io.streamed import CogWriter

__all__ = ["FLUX_TAG", "GRID_TAG", "ViirsRun", "geographic_cell_areas"]


def geographic_cell_areas(transform: Affine, rows: int, crs: str | CRS) -> FloatArray:
    """Geodesic area of one cell of each row of a geographic grid, on the CRS's ellipsoid.

    Parameters
    ----------
    transform
        Affine transform of the grid's top-left corner, north up [deg].
    rows
        Rows from the transform's top row [1].
    crs
        The grid's geographic CRS (its ellipsoid is used).

    Returns
    -------
    numpy.ndarray
        (rows,) area of a cell of each row [m2].

    Raises
    ------
    CRSError
        ``crs`` is not geographic, or the transform is rotated.

    Notes
    -----
    A cell between parallels :math:`\\varphi_1 < \\varphi_2` and meridians
    :math:`\\Delta\\lambda` apart has the area of the same cell on the authalic sphere at the
    authalic latitudes :math:`\\beta`:

    .. math:: A = R_q^2 \\Delta\\lambda (\\sin\\beta_2 - \\sin\\beta_1)
        = \\frac{a^2}{2} \\Delta\\lambda (q_2 - q_1),

    .. math:: q(\\varphi) = (1 - e^2) \\left[\\frac{\\sin\\varphi}{1 - e^2\\sin^2\\varphi}
        - \\frac{1}{2e} \\ln\\frac{1 - e \\sin\\varphi}{1 + e \\sin\\varphi}\\right]

    (Snyder 1987, Eqs. 3-11 to 3-13), exact on the ellipsoid; on a sphere (:math:`e = 0`)
    :math:`q = 2 \\sin\\varphi`. WGS84's authalic radius :math:`R_q = a \\sqrt{q_p / 2}` is
    6371007.2 m.

    References
    ----------
    Snyder, J. P. (1987). Map Projections: A Working Manual. USGS Prof. Paper 1395, p. 16
    (Eqs. 3-11, 3-12, 3-13).

    Examples
    --------
    >>> from affine import Affine
    >>> areas = geographic_cell_areas(Affine(1.0, 0, 0, 0, -1.0, 1.0), 1, "EPSG:4326")
    >>> round(float(areas[0]) / 1e6, 1)  # 1 x 1 deg at the equator [km2]
    12308.5
    """
    geographic = CRS.from_user_input(crs)
    if not geographic.is_geographic:
        raise CRSError(f"{geographic.name}: cell areas need a geographic CRS (degrees)")
    if transform.b or transform.d:
        raise CRSError(f"transform {tuple(transform)[:6]} is rotated; expected north up")
    ellipsoid = geographic.ellipsoid
    assert ellipsoid is not None
    a = ellipsoid.semi_major_metre
    flattening = 1.0 / ellipsoid.inverse_flattening if ellipsoid.inverse_flattening else 0.0
    e = math.sqrt(flattening * (2.0 - flattening))
    edges = np.radians(np.clip(transform.f + transform.e * np.arange(rows + 1), -90.0, 90.0))
    sin = np.sin(edges)
    if e == 0.0:
        q = 2.0 * sin
    else:  # Snyder 1987, Eq. 3-12
        q = (1 - e**2) * (
            sin / (1 - e**2 * sin**2) - np.log((1 - e * sin) / (1 + e * sin)) / (2 * e)
        )
    return np.asarray(0.5 * a**2 * math.radians(abs(transform.a)) * np.abs(np.diff(q)))


#: Dataset tag naming the kind of grid of an emission raster: ``geographic`` (cells in
#: degrees, of unequal area) or ``projected``.
GRID_TAG = "grid"
#: Dataset tag naming what an emission raster's cells hold: ``density`` (flux per unit
#: ground area [lm m-2], on either kind of grid; a cell's flux is density x its area, the
#: geodesic area on a geographic grid).
FLUX_TAG = "flux"


def source_crs(crs: CRS | None, label: str) -> CRS:
    """The VIIRS raster's CRS; refuse a raster without one."""
    if crs is None:
        raise CRSError(f"{label}: the VIIRS raster has no CRS; expected e.g. EPSG:4326")
    return crs


@dataclass(frozen=True)
class ViirsRun:
    """One conversion of :func:`emission_from_viirs`: its options and window loop."""

    label: str
    density: Callable[[FloatArray], FloatArray]
    resolution: float | None
    target_crs: CRS | None
    progress: bool

    def prepare(
        self, source: BandSource, metadata: RasterMetadata, *, in_memory: bool
    ) -> OutputGrid:
        """Check the source and the memory; the output grid."""
        check_radiance_source(metadata, self.label)
        rows, cols = source.shape
        bounds = grid_bounds(source.transform, rows, cols)
        target = viirs_target_crs(source.crs, bounds, self.target_crs, self.label)
        grid = viirs_grid(
            source.crs, source.transform, (rows, cols), bounds, target, self.resolution
        )
        if target != source.crs:
            warn_zone_span(source.crs, bounds, target, self.label)
        out = (
            OutputGrid(source.transform, rows, cols, target)
            if grid is None
            else OutputGrid(grid[0], grid[1], grid[2], target)
        )
        check_viirs_memory(
            (rows, cols), out, self.label, kept=out.kept(source), in_memory=in_memory
        )
        return out

    def run(
        self,
        source: BandSource,
        grid: OutputGrid,
        sink: Callable[[FloatArray, int, int], None],
    ) -> float:
        """Compute every window into ``sink``; the total flux [lm]. Warns and raises once."""
        size = _viirs_windows.WINDOW_CELLS
        windows = grid.windows(size)
        kept = grid.kept(source)
        scan = RadianceScan()
        total, lit = 0.0, False
        with window_progress(self.progress) as bar:
            if not kept:  # overlapping windows: the checks count the source once, first
                strips_total = sum(1 for _ in strips(source.shape, size * size))
                task = bar.add_task("checking radiance", total=strips_total)
                scan_source(source, scan, window=size, advance=lambda: bar.advance(task))
                scan.report(self.label, stacklevel=5, negative=True)
            task = bar.add_task("emission windows", total=len(windows))
            for window in windows:
                values = window_density(
                    source, grid, window, scan if kept else RadianceScan(), self.density
                )
                total += window_flux(values, grid, window)
                lit = lit or bool(np.isfinite(values).any())
                sink(values, window[0], window[1])
                bar.advance(task)
        if kept:
            scan.report(self.label, stacklevel=5, negative=True)
        if not lit:
            raise InputError(
                f"{self.label}: no output cell of {abs(grid.transform.a):.4g} "
                f"{'deg' if grid.crs.is_geographic else 'm'} gets a value from the raster "
                f"({source.shape[0]} x {source.shape[1]} pixels); expected a resolution= finer "
                "than the raster's extent"
            )
        return total

    def in_memory(
        self,
        source: BandSource,
        metadata: RasterMetadata,
        tags: dict[str, Any],
        band_tags: dict[str, str],
    ) -> tuple[Raster, float]:
        """The windows assembled in memory: the raster (float32 values) and its flux [lm]."""
        grid = self.prepare(source, metadata, in_memory=True)
        out = np.full((grid.rows, grid.cols), np.nan)

        def sink(values: FloatArray, row: int, col: int) -> None:
            out[row : row + values.shape[0], col : col + values.shape[1]] = values

        total = self.run(source, grid, sink)
        result = Raster(
            as_written(out),
            grid.transform,
            grid.crs,
            descriptions=("upward",),
            units=("lm m-2",),
            tags={key: str(value) for key, value in grid_tags(tags, grid, total).items()},
            band_tags=(band_tags,),
        )
        return result, total

    def streamed(
        self,
        source: FileSource,
        output: Path,
        tags: dict[str, Any],
        band_tags: dict[str, str],
    ) -> tuple[OutputGrid, float]:
        """The windows written to ``output`` as they are done: the grid and its flux [lm]."""
        grid = self.prepare(source, source, in_memory=False)
        writer = CogWriter(
            output,
            shape=(1, grid.rows, grid.cols),
            transform=grid.transform,
            crs=grid.crs,
            descriptions=("upward",),
            units=("lm m-2",),
            band_tags=(band_tags,),
            tags=tags,
            **COG_OPTIONS,
        )
        with writer:
            total = self.run(
                source, grid, lambda values, row, col: writer.write(values[None], row=row, col=col)
            )
            writer.update_tags(**grid_tags({}, grid, total))
        return grid, total


def grid_tags(tags: Mapping[str, Any], grid: OutputGrid, total: float) -> dict[str, Any]:
    """``tags`` with the grid's kind and the total flux."""
    kind = "geographic" if grid.crs.is_geographic else "projected"
    return {**tags, GRID_TAG: kind, "total_upward_lm": total}


def window_flux(values: FloatArray, grid: OutputGrid, window: tuple[int, int, int, int]) -> float:
    """Flux of a window of flux density [lm]: density x cell area, geodesic when geographic."""
    row, _, rows, _ = window
    if grid.crs.is_geographic:
        areas = geographic_cell_areas(grid.transform @ Affine.translation(0, row), rows, grid.crs)
        return float(np.nansum(values, axis=1) @ areas)
    return float(np.nansum(values) * abs(grid.transform.a * grid.transform.e))


def grid_bounds(transform: Affine, rows: int, cols: int) -> tuple[float, float, float, float]:
    """(left, bottom, right, top) of a grid."""
    xs, ys = zip(transform @ (0, 0), transform @ (cols, rows), strict=True)
    return min(xs), min(ys), max(xs), max(ys)


def viirs_grid(
    src_crs: CRS,
    src_transform: Affine,
    shape: tuple[int, int],
    bounds: Sequence[float],
    target: CRS,
    resolution: float | None,
) -> tuple[Affine, int, int] | None:
    """The output transform and shape, or None when the input grid is kept as it is."""
    if target.is_geographic:
        if resolution is not None:
            raise InputError(
                f"resolution={resolution:g} m for a raster that keeps its geographic grid "
                "(it spans more than one UTM zone); expected no resolution=, or a projected "
                "target_crs= with it"
            )
        return None
    if target == src_crs and (resolution is None or math.isclose(resolution, src_transform.a)):
        return None
    if resolution is not None:
        native, cols, rows = calculate_default_transform(
            src_crs.to_wkt(), target.to_wkt(), shape[1], shape[0], *bounds
        )
        width, height = cols * abs(native.a), rows * abs(native.e)
        extent = max(width, height)
        if resolution > extent:
            raise InputError(
                f"resolution={resolution:g} m is larger than the raster's extent (about "
                f"{width:.4g} x {height:.4g} m); expected a resolution= below {extent:.4g} m"
            )
    kwargs = {} if resolution is None else {"resolution": resolution}
    transform, cols, rows = calculate_default_transform(
        src_crs.to_wkt(), target.to_wkt(), shape[1], shape[0], *bounds, **kwargs
    )
    return transform, int(rows), int(cols)


def check_viirs_memory(
    in_shape: tuple[int, int], grid: OutputGrid, label: str, *, kept: bool, in_memory: bool
) -> None:
    """Refuse a VIIRS conversion whose estimated peak memory is over the limit.

    One window's working arrays (:func:`~nightlights.ground._viirs_windows.window_memory`),
    plus the output grid when it is held in memory (the float64 raster and its float32
    round trip, :data:`~nightlights.ground.checks.VIIRS_BYTES_PER_CELL`), or the writer's
    block cache and the style's sample when it is streamed to a file
    (:func:`~nightlights.ground._windows.writer_memory`). On the 14,400 x 8,400
    synthetic mosaic (``benchmarks/_mosaic.py``) the streamed run's peak was 196 MiB above
    the imported modules, this estimate 264 MiB; projected to 500 m (Albers equal-area,
    8,414 x 12,843 cells, windows reprojected) 390 MiB, the estimate 417 MiB.
    """
    cells = float(grid.rows) * grid.cols
    writer = writer_memory(cells)
    window = window_memory(in_shape, grid, window=_viirs_windows.WINDOW_CELLS, kept=kept)
    estimate = window + (cells * VIIRS_BYTES_PER_CELL if in_memory else writer)
    check_memory(
        estimate,
        f"the emission raster of {grid.rows} x {grid.cols} cells from {label}",
        option="use a coarser resolution= or write an output file" if in_memory else None,
    )


def as_written(values: FloatArray) -> FloatArray:
    """The values as the float32 file holds them, so that the in-memory product and the
    file are the same numbers."""
    return values.astype(np.float32).astype(np.float64)


def viirs_target_crs(
    src_crs: CRS,
    bounds: Sequence[float],
    target_crs: str | CRS | None,
    source: str | os.PathLike[str],
) -> CRS:
    if target_crs is not None:
        target = parse_crs(target_crs, option="target_crs")
        assert target is not None
        if not target.is_projected:
            raise CRSError(f"target CRS {target.to_string()} is not projected")
        return target
    if src_crs.is_geographic and zone_length_error(src_crs, bounds, src_crs)[0] > ZONE_WIDTH:
        return src_crs  # its own grid: no single zone fits it
    footprint = gpd.GeoDataFrame(geometry=[box(*bounds)], crs=src_crs)
    projected = ensure_projected(footprint, source=str(source))
    return CRS.from_user_input(projected.crs)
