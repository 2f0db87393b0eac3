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
fields that QGIS filters, labels and styles directly). With an instrument (``instrument=``) the
summary adds what it reads pointing at the zenith (:data:`INSTRUMENT_FIELDS`): each observer's
panorama read with its angular weights and colour term, and with the natural sky
(:mod:`nightlights.sky.instrument_units`).

The observers are read by :class:`~nightlights.sky.observer.Observer` (from coordinates in any
CRS or from a point layer); the engine a Dask task receives and the scheduling live in
:mod:`nightlights.sky._observers_engine`; this module checks the inputs, runs the engine and
writes the two outputs (summary layer, panoramas).

Length: a little over 600 lines, because the stage checks every input before any work (the
observers' names, places and reach, the top-cell limit of the GeoPackage, the memory, the
outputs) and writes both outputs, each of which needs those checks' results; the per-observer
computation lives apart, in the engine module.

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

import os
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import xarray as xr
from pyproj import CRS

from nightlights._parallel import check_scheduler
from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import NON_FINITE_SKY, bortle_class, luminance_to_magnitude
from nightlights.errors import CRSError, InputError, OutputExistsError
from nightlights.io import OutputSet, source_label, write_gpkg
from nightlights.io.outputs import refuse_replacing_inputs
from nightlights.io.raster import as_lit_cells
from nightlights.io.styles import observers_style
from nightlights.sky._flat import flat_keywords
from nightlights.sky._observers_engine import MAX_CHUNK as MAX_CHUNK  # re-exported
from nightlights.sky._observers_engine import SCHEDULERS, _Engine, _run
from nightlights.sky._observers_engine import TASKS_PER_WORKER as TASKS_PER_WORKER
from nightlights.sky._observers_engine import _engine as _engine  # for benchmarks and tests
from nightlights.sky._observers_engine import _Levels as _Levels
from nightlights.sky.forward import _panorama_dataset
from nightlights.sky.horizon import ground_height, scene_terrain
from nightlights.sky.instrument_units import InstrumentSky, instrument_sky
from nightlights.sky.instruments import Instrument
from nightlights.sky.multiple import scattering_note
from nightlights.sky.observer import Observer, positions
from nightlights.sky.scene import Scene
from nightlights.sky.setup import (
    _check_flux,
    _check_reach,
    band_emission_functions,
    prepare_scene,
)
from nightlights.sky.spec import MAX_KERNEL_RANGE, source_levels

__all__ = [
    "INSTRUMENT_FIELDS",
    "MAX_TOP_CELLS",
    "SCHEDULERS",
    "SUMMARY_FIELDS",
    "SUMMARY_LAYER",
    "ObserversResult",
    "observers",
]

#: Layer name of the summary GeoPackage.
SUMMARY_LAYER = "observers"
#: Fields of the summary layer, before the ``top<i>_*`` columns, with their units. With an
#: instrument, :data:`INSTRUMENT_FIELDS` follow them.
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
#: Fields the summary layer adds after :data:`SUMMARY_FIELDS` with an instrument
#: (``instrument=``), pointing at the zenith: its reading of the artificial sky (the
#: V-equivalent luminance it stands for, colour term of ``spectrum`` included) and its sky
#: brightness with the natural sky, in its band.
INSTRUMENT_FIELDS: dict[str, str] = {
    "instrument_luminance": "cd m-2 (V-equivalent reading of the artificial sky)",
    "instrument_sky_brightness": "mag arcsec-2 (the instrument's band, artificial + natural)",
}
#: Columns of a GeoPackage table at most, its feature id and geometry among them (SQLite's
#: ``SQLITE_MAX_COLUMN``, which GDAL's GeoPackage driver keeps) [1].
GPKG_MAX_COLUMNS = 2000
#: Most lit cells per observer the summary GeoPackage can list: three columns each, beside the
#: feature id, the geometry, :data:`SUMMARY_FIELDS` and ``panorama`` [1].
MAX_TOP_CELLS = (GPKG_MAX_COLUMNS - 2 - len(SUMMARY_FIELDS) - 1) // 3
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
    instrument: str | Instrument | None = None,
    spectrum: str | None = None,
    natural_luminance: float | None = None,
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
    instrument
        Also report what this instrument reads pointing at the zenith
        (:data:`INSTRUMENT_FIELDS`): a key of :data:`~nightlights.sky.instruments.INSTRUMENTS`
        (``sqm``, ``sqm-l``, ``tess-w``, ``eye``) or an
        :class:`~nightlights.sky.instruments.Instrument`; None: no such columns.
    spectrum
        With an instrument: the artificial light's spectrum for its colour term, a name of
        :data:`ies.spectra.SPDS`; None: the emission raster's ``spectrum`` tag, else
        LED_4000K (:data:`~nightlights.sky.instrument_units.DEFAULT_SPECTRUM`).
    natural_luminance
        With an instrument: the natural sky's reading, V-equivalent with its colour term
        [cd m-2]; None: a uniform moonless sky of 22.0 mag arcsec-2 (V).
    progress
        Progress bars (kernel build, observers).

    Returns
    -------
    ObserversResult
        The summary layer (with an instrument, :data:`INSTRUMENT_FIELDS` too), the panorama
        files and the time taken.

    Raises
    ------
    InputError
        Observers that are not points, have no CRS, repeat a name, stand outside the DEM or
        farther from every lit cell than the kernel reaches; more ``top_cells`` than the
        summary layer holds; a scheduler that is unknown or does not answer; the
        emission refused by :func:`~nightlights.sky.setup.prepare_scene`.
    OutputError
        An output (the summary, a panorama) is one of the inputs (the observers' layer, the
        scene's emission, DEM or kernel file), exists without ``overwrite``, or cannot be
        written.

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
    >>> result.summary["name"].tolist(), result.summary["top1_share"].round(12).tolist()
    (['observer_1', 'observer_2'], [1.0, 1.0])
    """
    scene.clear_sky("the many-observer summary")
    scheduler = check_scheduler(scheduler, local=SCHEDULERS)  # parsed and probed first
    if not (isinstance(top_cells, int | np.integer) and top_cells >= 0):
        raise InputError(f"top_cells={top_cells!r}; expected an integer >= 0")
    emission, dem = scene.emission, scene.dem
    label = scene.label
    reader = instrument_sky(
        instrument,
        spectrum=spectrum,
        natural_luminance=natural_luminance,
        emission=emission,
        label=label,
    )
    most = _max_top_cells(0 if reader is None else len(INSTRUMENT_FIELDS))
    if output is not None and top_cells > most:
        raise InputError(
            f"top_cells={top_cells}: the summary GeoPackage holds at most {most} top "
            f"cells (3 columns each, {GPKG_MAX_COLUMNS} columns per table); expected 0 to "
            f"{most}"
        )
    # no output is an input (the observers' layer, the scene's files), overwrite or not
    inputs = {**scene.inputs, "observers": observers}
    refuse_replacing_inputs([output], inputs)
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
    refuse_replacing_inputs(files.values(), inputs)
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
    engine = _engine(setup, relief is not None, top_cells, folder is not None, reader)
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
    summary = _summary(skies, xy, eyes, labels, setup.crs, engine, files, reader)
    with outputs:
        for name, path in files.items():
            index = labels.index(name)
            dataset = _panorama(skies[index], setup, xy[index], eyes[index], heights[index], engine)
            if reader is not None:
                dataset.attrs.update(reader.summary(float(summary[_READING].iloc[index])))
            dataset.to_netcdf(outputs.temporary(path), engine="h5netcdf")
        if output is not None:
            _write_summary(summary, outputs.temporary(output))
    return ObserversResult(summary, files, seconds, Path(output) if output is not None else None)


#: The summary column of the instrument's reading of the artificial sky.
_READING = "instrument_luminance"


def _max_top_cells(extra_fields: int) -> int:
    """Most top cells the summary GeoPackage holds beside ``extra_fields`` optional fields
    (:data:`MAX_TOP_CELLS` without them) [1]."""
    return (GPKG_MAX_COLUMNS - 2 - len(SUMMARY_FIELDS) - extra_fields - 1) // 3


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


# --- outputs ------------------------------------------------------------------------------------


def _summary(
    skies: list[dict[str, Any]],
    xy: FloatArray,
    eyes: FloatArray,
    names: list[str],
    crs: CRS,
    engine: _Engine,
    files: dict[str, Path],
    reader: InstrumentSky | None = None,
) -> gpd.GeoDataFrame:
    artificial = np.array([s["zenith"] for s in skies], dtype=float)
    broken = [name for name, value in zip(names, artificial, strict=True) if not np.isfinite(value)]
    if broken:
        shown = ", ".join(broken[:5]) + (f" and {len(broken) - 5} more" if len(broken) > 5 else "")
        raise InputError(f"observers {shown}: {NON_FINITE_SKY}")
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
    if reader is not None:
        reading = reader.artificial(np.array([s["instrument"] for s in skies], dtype=float))
        columns[_READING] = reading
        columns["instrument_sky_brightness"] = reader.magnitude(reading)
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
