"""Many observers' skies at once: one summary point layer, a panorama per observer on request.

The skyglow of an emission raster is computed for tens to thousands of observers in parallel
with Dask. Every per-scene step is done once, as in the interactive session
(:class:`~nightlights.explore.ExploreSession`): the emission and the kernel are checked and
read by :func:`~nightlights.sky.setup.prepare_scene`, the lit cells' flux and source-level
weights are kept, and the kernel's PCA tables are taken out of the dataset
(:class:`~nightlights.sky.panorama.KernelLevels`). An observer then costs one compiled pass
over the lit cells (:func:`~nightlights.sky._polar_numba.polar_flux_levels`), the PCA panorama
(Dobashi et al. 2023, Eqs. 7-9), the terrain horizon when a DEM is given, and the lit cells'
parts of the zenith (Dobashi et al. 2023, Eqs. 13-14 with zenith weights, as
:func:`~nightlights.inverse.inverse_q` with ``metric="zenith"``). The observers are split into
chunks, one Dask task each, run on the local threads, processes, in the calling thread, or on a
``dask.distributed`` cluster.

Every observer becomes one point of the summary layer (:data:`SUMMARY_FIELDS`): the zenith
luminance, artificial, natural and total, its sky brightness and Bortle class, the brightest
direction of the artificial skyglow, and the lit cells that give most of the artificial zenith
luminance, in numbered columns (``top1_x``, ``top1_y``, ``top1_share``, ...: plain numeric
fields that QGIS filters, labels and styles directly).

Length: about 880 lines, a third of them numpydoc, because the stage accepts observers in
every form a user has them (an array in any CRS, a point layer in memory or in a file, with
or without names) and checks each one by name, and its memory, before any work, and because
the engine a Dask task receives, the scheduling and the two outputs (summary layer, panoramas)
share one set of private types that no other module needs.

References
----------
1. Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution
   for the Night Sky", ACM TOG 42(6) 219, Eqs. 7-9 (panorama), 13-14 (a cell's part of a
   region of the sky).
2. Cinzano, P. 2005, "Night sky photometry with Sky Quality Meter", ISTIL Internal Report 9
   (luminance to mag arcsec-2).
3. Bortle, J. E. 2001, "Introducing the Bortle dark-sky scale", Sky & Telescope 101(2), 126.
"""

from __future__ import annotations

import math
import os
import re
import time
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import xarray as xr
from affine import Affine
from pyproj import CRS
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from nightlights._parallel import check_scheduler
from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import bortle_class, luminance_to_magnitude
from nightlights.emission_functions import kernel_table_names
from nightlights.errors import CRSError, InputError, OutputExistsError
from nightlights.io import OutputSet, source_label, write_gpkg
from nightlights.io.raster import as_lit_cells
from nightlights.io.styles import observers_style
from nightlights.sky._flat import flat_keywords
from nightlights.sky._polar_numba import _CELLS_PER_CHUNK, polar_flux_levels
from nightlights.sky.forward import _panorama_dataset
from nightlights.sky.horizon import ground_height, horizon_elevation, scene_terrain
from nightlights.sky.influence import cell_values, region_table, zenith_weights
from nightlights.sky.multiple import scattering_note
from nightlights.sky.observer import Observer, positions
from nightlights.sky.panorama import KernelLevels, KernelSlice, band_slice, panorama_pca
from nightlights.sky.polar import (
    PolarMap,
    lit_polar_cells,
    source_level_weights,
)
from nightlights.sky.scene import Scene
from nightlights.sky.setup import (
    _check_flux,
    _check_reach,
    band_emission_functions,
    prepare_scene,
)
from nightlights.sky.spec import MAX_KERNEL_RANGE, source_levels

__all__ = [
    "MAX_TOP_CELLS",
    "SCHEDULERS",
    "SUMMARY_FIELDS",
    "SUMMARY_LAYER",
    "ObserversResult",
    "observers",
]

#: Local Dask schedulers; a ``distributed.Client`` or a scheduler address also works.
SCHEDULERS = ("threads", "processes", "synchronous")
#: Layer name of the summary GeoPackage.
SUMMARY_LAYER = "observers"
#: Fields of the summary layer, before the ``top<i>_*`` columns, with their units.
SUMMARY_FIELDS: dict[str, str] = {
    "name": "",
    "observer_altitude": "m above sea level (eye)",
    "zenith_artificial": "cd m-2",
    "zenith_natural": "cd m-2",
    "zenith_total": "cd m-2",
    "zenith_mag": "mag arcsec-2 (total)",
    "bortle": "1-9 (total)",
    "brightest_azimuth": "deg clockwise from north",
    "brightest_elevation": "deg",
    "brightest_luminance": "cd m-2 (artificial)",
}
#: Columns of a GeoPackage table at most, its feature id and geometry among them (SQLite's
#: ``SQLITE_MAX_COLUMN``, which GDAL's GeoPackage driver keeps) [1].
GPKG_MAX_COLUMNS = 2000
#: Most lit cells per observer the summary GeoPackage can list: three columns each, beside the
#: feature id, the geometry, :data:`SUMMARY_FIELDS` and ``panorama`` [1].
MAX_TOP_CELLS = (GPKG_MAX_COLUMNS - 2 - len(SUMMARY_FIELDS) - 1) // 3
#: Most observers per Dask task: few enough that the progress bar moves, many enough that a
#: task's overhead (a few ms on the local schedulers) stays below its work [1].
MAX_CHUNK = 64
#: Tasks per worker the observers are split into, so that the workers stay busy to the end [1].
TASKS_PER_WORKER = 4
#: Bytes per panorama pixel held until the files are written (luminance, sky brightness and
#: the terrain mask in the written dataset, plus the array returned by the task) [B].
_PANORAMA_PIXEL_BYTES = 3 * 8 + 1
#: Bytes per lit cell of a task in flight: the cells' distances, centres and polar bins, the
#: masks and the exact parts of the cells near the top (besides 16 B per level and band for
#: the bounds of their parts); 152 B measured per task with one level and band (peak resident
#: memory, 257 400 lit cells, one and two tasks at once) [B].
_TASK_CELL_BYTES = 160.0
#: Bytes per number of the summary: the task's result, the stacked table, the data frame, the
#: GeoDataFrame and the GeoPackage writer's copies; 92 B measured with 200 observers x 600 top
#: cells [B].
_SUMMARY_BYTES = 128.0
#: Characters kept from an observer's name in its panorama's file name.
_SAFE_NAME = re.compile(r"[^A-Za-z0-9._-]+")


@dataclass(frozen=True)
class ObserversResult:
    """What :func:`observers` computed.

    Attributes
    ----------
    summary
        One row per observer (:data:`SUMMARY_FIELDS`, then ``top<i>_x``, ``top<i>_y`` [m] and
        ``top<i>_share`` [1] for i = 1..``top_cells``, and ``panorama``, the file's name,
        when panoramas were written), point geometry in the emission's CRS.
    panoramas
        Observer name -> panorama NetCDF, only when panoramas were asked for.
    seconds
        Wall time of the observers' skies, after the scene and the kernel were ready [s].
    path
        The summary GeoPackage, or None when nothing was written.
    """

    summary: gpd.GeoDataFrame
    panoramas: dict[str, Path]
    seconds: float
    path: Path | None


@dataclass(frozen=True)
class _Engine:
    """Everything an observer's sky needs, computed once; what a Dask task receives.

    Altitudes are the kernel's (shifted by ``offset`` as in
    :class:`~nightlights.sky.setup.SceneSetup`).
    """

    rows: np.ndarray
    cols: np.ndarray
    values: FloatArray  # (bands, n) [lm m-2]
    flux: FloatArray  # (bands, n) [lm]
    level_weights: FloatArray  # (n_levels, n) [1]
    transform: Affine
    edges: FloatArray  # (n_r + 1,) [m]
    n_az: int
    elevation: FloatArray  # (n_el,) [deg]
    offset: float  # [m]
    functions: tuple[Any, ...]
    slices: tuple[KernelSlice, ...] | None  # one eye altitude (no DEM): ready
    table: xr.Dataset | None  # with a DEM: the PCA tables, for any eye altitude
    dem: FloatArray | None
    dem_transform: Affine | None
    natural: float  # natural zenith luminance [cd m-2]
    top_cells: int
    keep_panoramas: bool

    def sky(self, xy: tuple[float, float], eye: float, levels: _Levels) -> dict[str, Any]:
        """One observer's figures (and panorama when kept) at eye altitude ``eye`` [m]."""
        slices = list(self.slices) if self.slices is not None else levels.at(eye - self.offset)
        maps, _ = polar_flux_levels(
            self.rows,
            self.cols,
            self.flux,
            self.level_weights,
            self.transform,
            xy,
            distance_edges=self.edges,
            n_az=self.n_az,
        )
        empty = np.zeros(1)
        polars = [PolarMap(m, self.edges, self.n_az, empty, empty) for m in maps]
        # Eqs. 7-9; PCA truncation can ring slightly below zero
        luminance = np.maximum(panorama_pca(polars, slices), 0.0)
        below = None
        if self.dem is not None:
            assert self.dem_transform is not None
            horizon = horizon_elevation(
                self.dem, self.dem_transform, xy, eye_altitude=eye, n_az=self.n_az
            )
            below = self.elevation[:, None] < horizon[None, :]
            luminance = np.where(below, np.nan, luminance)
        row = luminance[0]
        zenith = float(np.nanmean(row)) if np.isfinite(row).any() else 0.0
        out: dict[str, Any] = {"zenith": zenith, **_brightest(luminance, self.elevation)}
        if self.top_cells:
            out["top"] = self._top_cells(xy, maps, levels.zenith(slices))
        if self.keep_panoramas:
            out["luminance"] = luminance
            out["below"] = below
        return out

    def _top_cells(self, xy: tuple[float, float], maps: FloatArray, zenith: _Zenith) -> FloatArray:
        """``(top_cells, 3)``: x, y [m] and share of the artificial zenith [1] of the lit
        cells that give most of it (NaN rows when fewer cells give any).

        A cell's part is :func:`~nightlights.inverse.inverse_q`'s with ``metric="zenith"``
        (Dobashi et al. 2023, Eqs. 13-14 with the zenith row's weights): its flux on each
        source level times the zenith luminance per lumen of the polar bins its sub-points
        fall in, summed. The parts of all cells add up to the binned flux times the same
        table, the panorama's artificial zenith (Eqs. 13-14 are linear), the shares'
        denominator. Every sub-point of a cell lies within half a cell diagonal of its centre,
        so the cell's part lies between its flux times the least and the greatest value of
        the table over the distance bins of that span; only the cells whose upper bound
        reaches the ``top_cells``-th largest lower bound are split into sub-points
        (:func:`~nightlights.sky.polar.lit_polar_cells`) and summed exactly, as
        :func:`~nightlights.inverse.inverse_q` does for all of them.
        """
        total = float(sum(np.sum(m * t) for m, t in zip(maps, zenith.tables, strict=True)))
        lower, upper = zenith.bounds(self, xy)
        count = min(self.top_cells, lower.size)
        threshold = np.partition(lower, lower.size - count)[lower.size - count]
        chosen = np.nonzero(upper >= threshold)[0]
        cells = lit_polar_cells(
            self.rows[chosen],
            self.cols[chosen],
            self.values[:, chosen],
            self.transform,
            xy,
            distance_edges=self.edges,
            n_az=self.n_az,
        )
        exact = cell_values(cells, self.level_weights[:, chosen], zenith.tables)
        values = np.zeros(lower.size)
        values[chosen] = exact
        out = np.full((self.top_cells, 3), np.nan)
        if not total > 0:
            return out
        order = np.argsort(-values, kind="stable")[:count]
        order = order[values[order] > 0]
        t = self.transform
        out[: order.size, 0] = t.c + t.a * (self.cols[order] + 0.5)
        out[: order.size, 1] = t.f + t.e * (self.rows[order] + 0.5)
        out[: order.size, 2] = values[order] / total
        return out


class _Levels:
    """One task's band slices of a kernel at the eye altitudes it meets (with a DEM)."""

    def __init__(self, engine: _Engine) -> None:
        self._engine = engine
        self._levels: KernelLevels | None = None
        self._slices: dict[float, list[KernelSlice]] = {}
        # keyed by the slices' identity; the slices are kept with their tables
        self._zenith: dict[int, tuple[list[KernelSlice], _Zenith]] = {}

    def at(self, altitude: float) -> list[KernelSlice]:
        """The band slices at an eye altitude in the kernel's frame [m]."""
        if altitude not in self._slices:
            if self._levels is None:
                assert self._engine.table is not None
                self._levels = KernelLevels(self._engine.table, tables=False)
            functions = self._engine.functions
            self._slices[altitude] = [band_slice(s, functions) for s in self._levels.at(altitude)]
        return self._slices[altitude]

    def zenith(self, slices: list[KernelSlice]) -> _Zenith:
        """The zenith tables of the slices (computed once per eye altitude)."""
        key = id(slices[0])
        if key not in self._zenith:
            self._zenith[key] = (slices, _Zenith.of(slices))
        return self._zenith[key][1]


@dataclass(frozen=True)
class _Zenith:
    """Per source level, the artificial zenith luminance per lumen in each polar bin and its
    least and greatest value over every range of distance bins [cd m-2 lm-1]."""

    tables: list[FloatArray]  # (bands, n_r, n_az) per level
    least: FloatArray  # (levels, bands, n_r, n_r): [.., first, last] over bins first..last
    greatest: FloatArray

    @classmethod
    def of(cls, slices: list[KernelSlice]) -> _Zenith:
        weights = zenith_weights(slices[0].elevation.size, slices[0].n_az)
        # region_table of the zenith row (Dobashi et al. 2023, Eqs. 13-14)
        tables = [region_table(t, weights) for t in slices]
        low = np.stack([t.min(axis=-1) for t in tables])  # (levels, bands, n_r)
        high = np.stack([t.max(axis=-1) for t in tables])
        n_r = low.shape[-1]
        least = np.full((*low.shape, n_r), np.inf)
        greatest = np.full((*high.shape, n_r), -np.inf)
        for first in range(n_r):
            least[..., first, first:] = np.minimum.accumulate(low[..., first:], axis=-1)
            greatest[..., first, first:] = np.maximum.accumulate(high[..., first:], axis=-1)
        return cls(tables, least, greatest)

    def bounds(self, engine: _Engine, xy: tuple[float, float]) -> tuple[FloatArray, FloatArray]:
        """Lower and upper bounds of every lit cell's part of the zenith [cd m-2]."""
        t = engine.transform
        cell = abs(t.a)
        x = t.c + t.a * (engine.cols + 0.5)
        y = t.f + t.e * (engine.rows + 0.5)
        distance = np.hypot(x - xy[0], y - xy[1])
        half = cell / math.sqrt(2.0)  # sub-points lie within half a diagonal of the centre
        n_r = engine.edges.size - 1
        # the bins of lit_polar_cells: searchsorted(edges, r, "right") - 1, 0 below the first
        first = np.searchsorted(engine.edges, np.maximum(distance - half, 0.0), "right") - 1
        last = np.searchsorted(engine.edges, distance + half, "right") - 1
        outside = last >= n_r  # some sub-points may lie beyond the kernel: they count 0
        first = np.clip(first, 0, n_r - 1)
        last = np.clip(last, 0, n_r - 1)
        least = self.least[:, :, first, last]  # (levels, bands, n)
        greatest = self.greatest[:, :, first, last]
        least = np.where(outside, np.minimum(least, 0.0), least)
        greatest = np.where(outside, np.maximum(greatest, 0.0), greatest)
        beyond = distance - half >= engine.edges[-1]  # every sub-point beyond the kernel
        least = np.where(beyond, 0.0, least)
        greatest = np.where(beyond, 0.0, greatest)
        weight = engine.level_weights[:, None, :] * engine.flux[None, :, :]  # [lm]
        return np.sum(weight * least, axis=(0, 1)), np.sum(weight * greatest, axis=(0, 1))


def _brightest(luminance: FloatArray, elevation: FloatArray) -> dict[str, float]:
    """Azimuth [deg], elevation [deg] and luminance [cd m-2] of the brightest pixel."""
    filled = np.nan_to_num(luminance, nan=-1.0)
    index = int(np.argmax(filled))
    value = float(filled.flat[index])
    if not value > 0:
        return {"brightest_azimuth": math.nan, "brightest_elevation": math.nan,
                "brightest_luminance": 0.0}  # fmt: skip
    row, col = divmod(index, luminance.shape[1])
    return {
        "brightest_azimuth": (col + 0.5) * 360.0 / luminance.shape[1],
        "brightest_elevation": float(elevation[row]),
        "brightest_luminance": value,
    }


def _observe_chunk(
    engine: _Engine, points: FloatArray, single_thread: bool
) -> list[dict[str, Any]]:
    """The skies of a chunk of observers: rows of (x, y, eye altitude) [m]."""
    import numba

    previous = numba.get_num_threads()
    # The scheduler runs the tasks in parallel; and the compiled scatter uses one thread per
    # _CELLS_PER_CHUNK lit cells at most, so a smaller scene gains nothing from launching more.
    if single_thread or engine.rows.size < 2 * _CELLS_PER_CHUNK:
        numba.set_num_threads(1)
    try:
        levels = _Levels(engine)
        return [engine.sky((float(x), float(y)), float(eye), levels) for x, y, eye in points]
    finally:
        numba.set_num_threads(previous)


@flat_keywords(legacy=("output",), observer="layer")
def observers(
    scene: Scene,
    observers: Sequence[Observer] | gpd.GeoDataFrame | PathLike,
    output: PathLike | None = None,
    *,
    panoramas: PathLike | None = None,
    top_cells: int = 5,
    scheduler: str | Any = "threads",
    num_workers: int | None = None,
    overwrite: bool = False,
    progress: bool = True,
) -> ObserversResult:
    """The skies of many observers in parallel: one summary point layer, panoramas on request.

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2] in a projected CRS, one or two bands, each
        with the emission function of its ``emission_function`` tag, as
        :func:`~nightlights.sky.skyglow` reads it), terrain, atmosphere and kernel
        (:class:`~nightlights.sky.scene.Scene`). Without a kernel: a scene kernel reaching
        from the farthest observer to the farthest lit cell (tabulated at the lowest and
        highest eye altitude over a DEM), built or reused from the cache. Over a DEM each
        observer stands on it and sees its horizon.
    observers
        The observers (:class:`~nightlights.sky.observer.Observer`, e.g. from
        :meth:`Observer.from_layer <nightlights.sky.observer.Observer.from_layer>`), or a
        layer of points (GeoDataFrame or vector file) read with its defaults. Unnamed
        observers are called ``observer_1``, ``observer_2``, ... in their order. Without a
        DEM they must share one eye height.
    output
        Summary GeoPackage (layer :data:`SUMMARY_LAYER`); None writes nothing.
    panoramas
        Folder for one panorama NetCDF per observer (``<name>.nc``, the ``skyglow`` stage's
        format, which ``nightlights sky render --panorama`` reads); None writes none.
    top_cells
        Lit cells listed per observer, by their part of the artificial zenith; with an
        ``output``, at most :data:`MAX_TOP_CELLS` (the GeoPackage's column limit) [1].
    scheduler
        ``threads``, ``processes`` or ``synchronous`` (local Dask schedulers), a
        ``distributed.Client`` or a scheduler address (``tcp://host:8786``).
    num_workers
        Workers of the local ``threads`` and ``processes`` schedulers (default: one per core)
        [1].
    overwrite
        Replace existing outputs.
    progress
        Progress bars (kernel build, observers).

    Returns
    -------
    ObserversResult
        The summary layer, the panorama files and the time taken.

    Raises
    ------
    InputError
        Observers that are not points, have no CRS, repeat a name, stand outside the DEM or
        farther from every lit cell than the kernel reaches; more ``top_cells`` than the
        summary layer holds; a scheduler that is unknown or does not answer; the
        emission refused by :func:`~nightlights.sky.setup.prepare_scene`.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> sites = [Observer(1000.0, 1000.0, height=0.0), Observer(500.0, 500.0, height=0.0)]
    >>> result = observers(Scene(raster, kernel=kernel), sites, top_cells=1, progress=False)
    >>> result.summary["name"].tolist(), result.summary["top1_share"].tolist()
    (['observer_1', 'observer_2'], [1.0, 1.0])
    """
    scheduler = check_scheduler(scheduler, local=SCHEDULERS)  # parsed and probed first
    if not (isinstance(top_cells, int | np.integer) and top_cells >= 0):
        raise InputError(f"top_cells={top_cells!r}; expected an integer >= 0")
    if output is not None and top_cells > MAX_TOP_CELLS:
        raise InputError(
            f"top_cells={top_cells}: the summary GeoPackage holds at most {MAX_TOP_CELLS} top "
            f"cells (3 columns each, {GPKG_MAX_COLUMNS} columns per table); expected 0 to "
            f"{MAX_TOP_CELLS}"
        )
    emission, dem = scene.emission, scene.dem
    label = scene.label
    cells = as_lit_cells(emission)
    if cells.crs is None or not cells.crs.is_projected:
        raise CRSError(f"{label}: the emission raster needs a projected CRS in metres")
    sites = _as_observers(observers)
    xy = positions(sites, cells.crs)
    labels = _names([site.name for site in sites])
    heights = np.array([site.height for site in sites])
    workers = _workers(scheduler, num_workers)
    _check_memory(cells, len(xy), top_cells, workers, levels=1)  # before a kernel is built
    if dem is None and np.ptp(heights) > 0:
        raise InputError(
            f"observers at eye heights {heights.min():g}-{heights.max():g} m; without a DEM "
            "the observers of one call share one eye height (give the scene a DEM, or make "
            "one call per height)"
        )
    folder = Path(panoramas) if panoramas is not None else None
    files = {name: folder / f"{_file_name(name)}.nc" for name in labels} if folder else {}
    if folder is not None and not folder.is_dir():
        raise InputError(f"panorama folder {folder} does not exist or is not a folder")
    for path in [output, *files.values()]:
        if path is not None and not overwrite and Path(path).exists():
            raise OutputExistsError(f"{path}: exists; give overwrite to replace it")
    outputs = OutputSet(output, *files.values())  # locations checked before any work
    given = scene.kernel_dataset()
    # every observer within reach of a lit cell, named, before a kernel is built
    _check_reaches(cells, xy, labels, label, given)
    far = _farthest(cells.lit_bounds(), xy)
    relief = None
    observer_height = float(heights[far])
    eyes = heights.astype(float)
    if dem is not None:
        from nightlights.io import as_raster

        relief = as_raster(dem)
        eyes = _eye_altitudes(relief, xy, labels, heights)
        if given is None:
            _check_flux(cells, label)
            given = _scene_kernel(scene, cells, relief, xy[far], eyes, progress)
    setup = prepare_scene(
        scene.replace(dem=relief, kernel=given) if given is not None else scene,
        Observer(float(xy[far][0]), float(xy[far][1]), height=observer_height),
        progress=progress,
    )
    _check_reaches(setup.emission, xy, labels, label, setup.table)
    _check_memory(setup.emission, len(xy), top_cells, workers, levels=len(setup.levels))
    engine = _engine(setup, relief is not None, top_cells, folder is not None)
    if folder is not None:
        first = setup.slices[0]
        check_memory(
            len(xy) * first.elevation.size * first.n_az * _PANORAMA_PIXEL_BYTES,
            f"{len(xy)} panoramas of {first.elevation.size} x {first.n_az} pixels",
            option="write fewer panoramas at once (split the observers)",
        )
    start = time.perf_counter()
    points = np.column_stack([xy, eyes])
    skies = _run(engine, points, scheduler, num_workers, progress)
    seconds = time.perf_counter() - start
    summary = _summary(skies, xy, eyes, labels, setup.crs, engine, files)
    with outputs:
        for name, path in files.items():
            index = labels.index(name)
            dataset = _panorama(skies[index], setup, xy[index], eyes[index], heights[index], engine)
            dataset.to_netcdf(outputs.temporary(path), engine="h5netcdf")
        if output is not None:
            _write_summary(summary, outputs.temporary(output))
    return ObserversResult(summary, files, seconds, Path(output) if output is not None else None)


# --- inputs -----------------------------------------------------------------------------------


def observers_memory(
    n_cells: int, bands: int, levels: int, n_observers: int, top_cells: int, workers: int
) -> float:
    """Estimated peak memory of :func:`observers` besides the kernel and the panoramas [B].

    The engine every task shares (per lit cell its indices, flux density and flux per band
    and source-level weights), the arrays of each task in flight over every lit cell (its
    distance, polar bins and the bounds of its part of the zenith per level and band:
    :data:`_TASK_CELL_BYTES` and 16 B per level and band), and the summary (per observer its
    fields and ``top_cells`` x 3 numbers, held as results, as a table and as written:
    :data:`_SUMMARY_BYTES` per number).

    Parameters
    ----------
    n_cells
        Lit cells of the emission [1].
    bands
        Emission bands [1].
    levels
        Source levels of the kernel [1].
    n_observers
        Observers [1].
    top_cells
        Lit cells listed per observer [1].
    workers
        Tasks computed at once [1].

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> round(observers_memory(10**6, 1, 1, 1000, 5, 4) / 2**20)
    713
    """
    engine = float(n_cells) * (16.0 + 16.0 * bands + 8.0 * levels)
    tasks = float(workers) * n_cells * (_TASK_CELL_BYTES + 16.0 * levels * bands)
    summary = float(n_observers) * (len(SUMMARY_FIELDS) + 3 + 3 * top_cells) * _SUMMARY_BYTES
    return engine + tasks + summary


def _workers(scheduler: Any, num_workers: int | None) -> int:
    """Tasks that run at once in this process: one for ``synchronous``, the local workers
    for ``threads`` and ``processes`` (each process holds its own), one for a cluster (its
    workers hold theirs)."""
    if scheduler == "synchronous" or not isinstance(scheduler, str) or scheduler not in SCHEDULERS:
        return 1
    return num_workers or os.cpu_count() or 1


def _check_memory(cells: Any, n_observers: int, top_cells: int, workers: int, levels: int) -> None:
    """Refuse a run whose estimate (:func:`observers_memory`) exceeds the limit."""
    check_memory(
        observers_memory(cells.n_cells, cells.count, levels, n_observers, top_cells, workers),
        f"computing the skies of {n_observers} observers over {cells.n_cells} lit cells "
        f"({top_cells} top cells each, {workers} at once)",
        option="give fewer observers or top_cells= at once, or fewer num_workers=",
    )


def _as_observers(source: Any) -> tuple[Observer, ...]:
    """The observers of a call: Observer objects, or a layer (GeoDataFrame or file) of points."""
    if isinstance(source, gpd.GeoDataFrame | str | os.PathLike):
        return Observer.from_layer(source)
    if isinstance(source, Observer):
        return (source,)
    sites = tuple(source)
    if not sites:
        raise InputError("observers: no observer")
    wrong = [type(site).__name__ for site in sites if not isinstance(site, Observer)]
    if wrong:
        raise InputError(
            f"observers of type {wrong[0]}; expected Observer objects (Observer(x, y, crs), "
            "Observer.from_layer(...)) or a layer of points"
        )
    return sites


def _names(given: Sequence[str | None]) -> list[str]:
    """Every observer's name: its own, else ``observer_<n>`` (checked unique as files)."""
    names = [str(v) if v is not None else f"observer_{i + 1}" for i, v in enumerate(given)]
    seen: dict[str, int] = {}
    for index, name in enumerate(names):
        if not name.strip():
            raise InputError(f"observer {index} has an empty name")
        key = _file_name(name).lower()
        if key in seen:
            raise InputError(
                f"observers {seen[key]} and {index} have the same name {name!r} (or names "
                "that make the same file name); expected unique names"
            )
        seen[key] = index
    return names


def _file_name(name: str) -> str:
    """An observer's name as a file name: characters other than letters, digits, ``.``,
    ``_`` and ``-`` become ``_``."""
    return _SAFE_NAME.sub("_", name.strip()).strip(".") or "_"


def _check_reaches(
    cells: Any, xy: FloatArray, names: list[str], label: str, table: xr.Dataset | None
) -> None:
    """Refuse an observer farther from every lit cell than the kernel (or any kernel)
    reaches, naming it."""
    reach = MAX_KERNEL_RANGE if table is None else float(table["distance_edges"][-1])
    whose = "any kernel's" if table is None else "the kernel's"
    for name, point in zip(names, xy, strict=True):
        try:
            _check_reach(cells, (point[0], point[1]), reach, label, point, None, whose)
        except InputError as exc:
            raise InputError(f"observer {name!r}: {exc}") from None


def _farthest(bounds: tuple[float, float, float, float] | None, xy: FloatArray) -> int:
    """The observer farthest from the lit cells' farthest corner: the kernel's reach."""
    if bounds is None:
        return 0
    left, bottom, right, top = bounds
    far = np.zeros(len(xy))
    for cx in (left, right):
        for cy in (bottom, top):
            far = np.maximum(far, np.hypot(xy[:, 0] - cx, xy[:, 1] - cy))
    return int(np.argmax(far))


def _eye_altitudes(relief: Any, xy: FloatArray, names: list[str], eye: FloatArray) -> FloatArray:
    """Eye altitude of each observer above sea level on the DEM [m] (``eye``: each one's
    height above the ground)."""
    heights = relief.data[0]
    out = np.empty(len(xy))
    for index, (name, (x, y)) in enumerate(zip(names, xy, strict=True)):
        try:
            out[index] = ground_height(heights, relief.transform, x, y) + eye[index]
        except InputError as exc:
            raise InputError(f"observer {name!r}: {exc}") from None
    return out


def _scene_kernel(
    scene: Scene, cells: Any, relief: Any, far: FloatArray, eyes: FloatArray, progress: bool
) -> xr.Dataset:
    """A scene kernel over a DEM: from the farthest observer to the farthest lit cell, at the
    lowest and the highest eye altitude (others between them are interpolated)."""
    xy = (float(far[0]), float(far[1]))
    terrain = scene_terrain(relief, cells, xy, 0.0, label=source_label(relief, "DEM"))
    functions, _ = band_emission_functions(scene.emission, cells.count, label=scene.label)
    low, high = float(eyes.min()), float(eyes.max())
    table, _ = scene.find_kernel(
        cells,
        xy,
        observer_altitudes=(low, high) if high > low else (low,),
        source_altitudes=source_levels(terrain.heights),
        functions=functions,
        progress=progress,
    )
    return table


def _engine(setup: Any, terrain: bool, top_cells: int, keep_panoramas: bool) -> _Engine:
    from nightlights.brightness import zenith_summary

    cells = setup.emission
    first = setup.slices[0]
    table = None
    if terrain:
        # the PCA tables alone, in memory: what KernelLevels reads for any eye altitude
        raw = [names[0] for names in kernel_table_names().values() if names[0] in setup.table]
        table = setup.table.drop_vars(raw).load()
    return _Engine(
        rows=np.asarray(cells.rows, dtype=np.int64),
        cols=np.asarray(cells.cols, dtype=np.int64),
        values=np.asarray(cells.values, dtype=float),
        flux=np.nan_to_num(np.asarray(cells.values, dtype=float), nan=0.0)
        * abs(cells.transform.a) ** 2,
        level_weights=source_level_weights(setup.heights, setup.levels),
        transform=cells.transform,
        edges=np.asarray(first.distance_edges, dtype=float),
        n_az=int(first.n_az),
        elevation=np.asarray(first.elevation, dtype=float),
        offset=float(setup.offset),
        functions=tuple(setup.functions),
        slices=None if terrain else tuple(setup.slices),
        table=table,
        dem=setup.terrain.dem if terrain else None,
        dem_transform=setup.terrain.transform if terrain else None,
        natural=float(zenith_summary(0.0)["zenith_natural_cd_m2"]),
        top_cells=int(top_cells),
        keep_panoramas=keep_panoramas,
    )


# --- the computation ----------------------------------------------------------------------------


def _chunks(count: int, workers: int) -> list[slice]:
    size = max(1, min(MAX_CHUNK, math.ceil(count / (TASKS_PER_WORKER * max(workers, 1)))))
    return [slice(start, min(start + size, count)) for start in range(0, count, size)]


def _run(
    engine: _Engine,
    points: FloatArray,
    scheduler: str | Any,
    num_workers: int | None,
    progress: bool,
) -> list[dict[str, Any]]:
    """Every observer's sky, in order, one Dask task per chunk of observers."""
    import dask

    from nightlights._parallel import TaskProgress, compute_distributed

    local = isinstance(scheduler, str) and scheduler in SCHEDULERS
    workers = num_workers or os.cpu_count() or 1
    if scheduler == "synchronous":
        workers = 1
    single_thread = scheduler != "synchronous"
    prefix = f"observers-{uuid.uuid4().hex}"
    shared = dask.delayed(engine, name=f"{prefix}-engine", pure=True)
    tasks = [
        dask.delayed(_observe_chunk, pure=True)(
            shared, points[part], single_thread, dask_key_name=f"{prefix}-chunk-{i}"
        )
        for i, part in enumerate(_chunks(len(points), workers))
    ]
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn())
    with Progress(*columns, TimeElapsedColumn(), transient=True, disable=not progress) as bar:
        task = bar.add_task(f"observers: {len(points)} skies", total=len(tasks))
        if local:
            options: dict[str, Any] = {"scheduler": scheduler}
            if scheduler != "synchronous" and num_workers is not None:
                options["num_workers"] = num_workers
            with TaskProgress(lambda: bar.advance(task), f"{prefix}-chunk"):
                results = dask.compute(*tasks, **options)
        else:
            results = compute_distributed(tasks, scheduler, lambda: bar.advance(task))
    return [sky for chunk in results for sky in chunk]


# --- outputs ------------------------------------------------------------------------------------


def _summary(
    skies: list[dict[str, Any]],
    xy: FloatArray,
    eyes: FloatArray,
    names: list[str],
    crs: CRS,
    engine: _Engine,
    files: dict[str, Path],
) -> gpd.GeoDataFrame:
    artificial = np.array([s["zenith"] for s in skies], dtype=float)
    natural = np.full(artificial.shape, engine.natural)
    total = artificial + natural
    magnitude = luminance_to_magnitude(total)
    columns: dict[str, Any] = {
        "name": names,
        "observer_altitude": eyes,
        "zenith_artificial": artificial,
        "zenith_natural": natural,
        "zenith_total": total,
        "zenith_mag": magnitude,
        "bortle": bortle_class(magnitude).astype(np.int64),
        **{
            field: [s[field] for s in skies]
            for field in ("brightest_azimuth", "brightest_elevation", "brightest_luminance")
        },
    }
    if engine.top_cells:
        top = np.stack([s["top"] for s in skies])  # (n, top_cells, 3)
        for i in range(engine.top_cells):
            for j, what in enumerate(("x", "y", "share")):
                columns[f"top{i + 1}_{what}"] = top[:, i, j]
    if files:
        columns["panorama"] = [files[name].name for name in names]
    frame = pd.DataFrame(columns)
    return gpd.GeoDataFrame(frame, geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=crs)


def _write_summary(summary: gpd.GeoDataFrame, path: Path) -> None:
    """The summary layer with its QGIS style in ``layer_styles``: each point in the Bortle
    colour of its total zenith sky brightness, labelled with its name."""
    schema: dict[str, Any] = {name: "float" for name in summary.columns if name != "geometry"}
    schema.update({"name": "str", "bortle": "int"})
    if "panorama" in summary:
        schema["panorama"] = "str"
    style = observers_style(field="zenith_mag", label_field="name")
    write_gpkg(summary, path, layer=SUMMARY_LAYER, schema=schema, style=style)


def _panorama(
    sky: dict[str, Any],
    setup: Any,
    xy: FloatArray,
    eye: float,
    observer_height: float,
    engine: _Engine,
) -> xr.Dataset:
    """An observer's panorama as the ``skyglow`` stage writes it, natural sky attributes too."""
    from nightlights.brightness import zenith_summary

    luminance = sky["luminance"]
    below = sky["below"]
    if below is None:
        below = np.zeros(luminance.shape, dtype=bool)
    dataset = _panorama_dataset(luminance, below, engine.elevation, None)
    natural = zenith_summary(float(dataset.attrs["zenith_luminance_cd_m2"]))
    dataset.attrs = {
        "observer_x": float(xy[0]),
        "observer_y": float(xy[1]),
        "crs": setup.crs.to_wkt(),
        "observer_height_m": float(observer_height),
        "source_altitude_levels_m": setup.levels,
        "observer_altitude_m": float(eye),
        "kernel_altitude_offset_m": float(setup.offset),
        "turbidity": float(setup.table.attrs.get("turbidity", np.nan)),
        "kernel_hash": str(setup.table.attrs.get("content_hash", "")),
        "mode": "pca",
        "emission": setup.label,
        "emission_functions": "; ".join(f.tag for f in setup.functions),
        "emission_function_sources": "; ".join(setup.function_notes),
        **dataset.attrs,
        "zenith_natural_cd_m2": float(natural["zenith_natural_cd_m2"]),
        "zenith_total_sky_brightness": float(natural["zenith_sky_brightness"]),
        "bortle_class_zenith_total": int(natural["bortle_class_zenith"]),
        "bands": "V",
        "note": "artificial skyglow only (no natural sky background), "
        + scattering_note(setup.table.attrs),
    }
    return dataset
