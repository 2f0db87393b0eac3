"""The engine of the many-observer stage: what one Dask task computes for a chunk of observers.

:func:`_engine` takes the per-scene work of :func:`~nightlights.sky.observers.observers` out of
the prepared scene once (the lit cells' flux and source-level weights, the kernel's PCA tables
for any eye altitude); an observer then costs one compiled pass over the lit cells
(:func:`~nightlights.sky._polar_numba.polar_flux_levels`), the PCA panorama (Dobashi et al.
2023, Eqs. 7-9), the terrain horizon when a DEM is given, and the lit cells' parts of the zenith
(Eqs. 13-14 with zenith weights), bounded first so that only the candidates for the top cells are
summed exactly (:class:`_Zenith`), and with an instrument the panorama read with its angular
weights (:meth:`~nightlights.sky.instrument_units.InstrumentSky.read`, before its colour
term). :func:`_run` splits the observers into chunks, one Dask task each, on the local threads,
processes, in the calling thread, or on a ``dask.distributed`` cluster.
"""

from __future__ import annotations

import math
import os
import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from affine import Affine
from numpy.typing import NDArray
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from nightlights._typing import FloatArray
from nightlights.emission_functions import kernel_table_names
from nightlights.sky._polar_numba import _CELLS_PER_CHUNK, polar_flux_levels
from nightlights.sky.forward import panorama_zenith
from nightlights.sky.horizon import horizon_elevation
from nightlights.sky.influence import cell_values, region_table, zenith_weights
from nightlights.sky.panorama import KernelLevels, KernelSlice, band_slice, panorama_pca
from nightlights.sky.polar import (
    PolarMap,
    distance_shares,
    lit_polar_cells,
    source_level_weights,
)

#: Local Dask schedulers; a ``distributed.Client`` or a scheduler address also works.
SCHEDULERS = ("threads", "processes", "synchronous")
#: Most observers per Dask task: few enough that the progress bar moves, many enough that a
#: task's overhead (a few ms on the local schedulers) stays below its work [1].
MAX_CHUNK = 64
#: Tasks per worker the observers are split into, so that the workers stay busy to the end [1].
TASKS_PER_WORKER = 4


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
    reading_weights: FloatArray | None = None  # (n_el, n_az) an instrument's angular weights

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
        zenith = panorama_zenith(luminance, below)
        out: dict[str, Any] = {"zenith": zenith, **_brightest(luminance, self.elevation)}
        if self.reading_weights is not None:
            # the angular-weighted artificial sky; hidden pixels (NaN) add nothing
            out["instrument"] = float(np.sum(self.reading_weights * np.nan_to_num(luminance)))
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
        share their flux between, summed. The parts of all cells add up to the binned flux
        times the same table, the panorama's artificial zenith (Eqs. 13-14 are linear), the
        shares' denominator. Every sub-point of a cell lies within half a cell diagonal of its
        centre, so the cell's part lies between its flux times the least and the greatest
        value of the table over that span (read as the sub-points read it, linear in ln r
        between the bin centres: at the span's ends and the centres inside); only the cells
        whose upper bound reaches the ``top_cells``-th largest lower bound are split into
        sub-points (:func:`~nightlights.sky.polar.lit_polar_cells`) and summed exactly, as
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
    low: FloatArray  # (levels, bands, n_r): the least over azimuth of each bin
    high: FloatArray

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
        return cls(tables, least, greatest, low, high)

    def bounds(self, engine: _Engine, xy: tuple[float, float]) -> tuple[FloatArray, FloatArray]:
        """Lower and upper bounds of every lit cell's part of the zenith [cd m-2]."""
        t = engine.transform
        cell = abs(t.a)
        x = t.c + t.a * (engine.cols + 0.5)
        y = t.f + t.e * (engine.rows + 0.5)
        distance = np.hypot(x - xy[0], y - xy[1])
        half = cell / math.sqrt(2.0)  # sub-points lie within half a diagonal of the centre
        n_r = engine.edges.size - 1
        # A sub-point at r reads w z[i] + (1 - w) z[i + 1] (distance_shares), linear in ln r
        # between the bin centres: over [near, far] the least (greatest) of the bins' least
        # (greatest) values so read lies at an end or at a centre in between.
        near = np.maximum(distance - half, 0.0)
        outside = distance + half >= engine.edges[-1]  # some sub-points may lie beyond: 0
        far = np.minimum(distance + half, engine.edges[-1])
        first, w_near = distance_shares(near, engine.edges)
        last, w_far = distance_shares(far, engine.edges)
        first = np.minimum(first, n_r - 1)
        last = np.minimum(last, n_r - 1)

        def read(table: FloatArray, lower: NDArray[np.int64], w: FloatArray) -> FloatArray:
            return w * table[:, :, lower] + (1 - w) * table[:, :, np.minimum(lower + 1, n_r - 1)]

        inner = first + 1 <= last  # bin centres strictly between near and far
        a, b = np.minimum(first + 1, n_r - 1), np.maximum(last, np.minimum(first + 1, n_r - 1))
        least = np.minimum(read(self.low, first, w_near), read(self.low, last, w_far))
        greatest = np.maximum(read(self.high, first, w_near), read(self.high, last, w_far))
        least = np.where(inner, np.minimum(least, self.least[:, :, a, b]), least)
        greatest = np.where(inner, np.maximum(greatest, self.greatest[:, :, a, b]), greatest)
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


def _engine(
    setup: Any, terrain: bool, top_cells: int, keep_panoramas: bool, reader: Any = None
) -> _Engine:
    """The engine of a prepared scene (``reader``: an
    :class:`~nightlights.sky.instrument_units.InstrumentSky`, or None)."""
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
        reading_weights=None
        if reader is None
        else reader.panorama_weights(
            first.elevation, (np.arange(first.n_az) + 0.5) * 360.0 / first.n_az
        ),
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
