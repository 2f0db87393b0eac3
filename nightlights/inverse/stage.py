"""File stages of the inverse maps: ``inverse_q`` and ``inverse_s``.

Each computes on the emission raster's grid and writes its raster (COG, NaN where unlit) only
when given a path: the output location is checked before the computation and the file is
written atomically.

Only cells within the kernel's reach (its last distance edge, at most 300 km) add to one
observer's sky. On a grid larger than that reach, only the window of cells within it along
both axes (:func:`~nightlights.sky.setup.reach_window`) is read and computed, with the same
result there as on the whole grid; the map in memory is that window, and the file is written
on the whole grid window by window (:class:`~nightlights.io.streamed.CogWriter`, NaN outside
the window), so that memory grows with the kernel's reach, not with the raster.

- :func:`inverse_q`: each lit cell's light-pollution level for an observer, Q_i (Dobashi et al.
  2023, Eqs. 10-11), or its part of the zenith or hemisphere-mean sky luminance.
- :func:`inverse_s`: each cell's part of the skyglow in a region of the sky, S_i (Eqs. 13-14).

The dimming stages that use them are in :mod:`nightlights.inverse.plan`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from affine import Affine

from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.errors import InputError
from nightlights.ground.checks import raster_header
from nightlights.inverse._clouds import check_deck, deck_tags, overcast_tables, overcast_zenith
from nightlights.inverse._region import SkyRegion
from nightlights.io import Raster
from nightlights.io.outputs import Inputs, OutputSet
from nightlights.io.raster import LitCells
from nightlights.io.streamed import CACHE_MB, CogWriter
from nightlights.io.styles import PRODUCT_TAG
from nightlights.sky._flat import flat_keywords
from nightlights.sky.influence import (
    METRICS,
    cell_values,
    cell_values_brute,
    hemisphere_weights,
    pca_norm_table,
    region_table,
    region_weights,
    zenith_weights,
)
from nightlights.sky.observer import Observer
from nightlights.sky.panorama import panorama_pca
from nightlights.sky.polar import PolarCells, PolarMap, lit_mask
from nightlights.sky.scene import Scene
from nightlights.sky.setup import (
    ReachWindow,
    SceneSetup,
    check_projected,
    prepare_scene,
    reach_hint,
    reach_window,
)
from nightlights.sky.spec import MAX_KERNEL_RANGE
from nightlights.sky.store import KernelResult

__all__ = ["InfluenceResult", "inverse_q", "inverse_s"]

#: What a kernel argument accepts.
KernelInput = KernelResult | xr.Dataset | PathLike | None
#: S methods: PCA with FFT cross-correlation, or each cell's raw kernel image (reference).
S_METHODS = ("pca", "brute")
#: Bytes per cell of an influence map written: the float64 map, its float32 copy, the
#: in-memory GeoTIFF and GDAL's blocks of it [B]. A window of a larger grid
#: (:func:`~nightlights.sky.setup.reach_window`) counts its own cells only.
BYTES_PER_CELL = 20.0
#: Memory of writing a window of a larger grid besides its cells: the streaming writer's
#: GDAL block cache (:data:`~nightlights.io.streamed.CACHE_MB`) [B].
STREAM_BYTES = CACHE_MB * 2**20
#: Rows of a window written to the whole grid's COG at a time (a float32 copy of them) [1].
STREAM_ROWS = 512
#: Memory of an influence map's first calls besides its arrays [B]: the kernel file read
#: (h5py, netCDF), GDAL opening the emission and the COG driver; 40 MiB measured (``VmHWM``
#: over the imports) on a 64 x 64 emission with the 30 km kernel of
#: ``bench_memory_estimates.py``.
FIXED_BYTES = 40 * 2**20

_BAND = {
    "pca-norm": ("q_pca_norm", "light-pollution level Q_i, Dobashi et al. 2023 Eq. 11"),
    "zenith": ("zenith_luminance", "part of the zenith sky luminance"),
    "hemisphere": ("hemisphere_luminance", "part of the mean luminance of the visible sky"),
    "region": ("region_luminance", "part of the sky luminance in the region, Eq. 14"),
}


@dataclass(frozen=True)
class InfluenceResult:
    """What :func:`inverse_q` or :func:`inverse_s` computed.

    Attributes
    ----------
    raster
        One band on the emission grid, NaN where unlit [cd m-2].
    metric
        ``pca-norm``, ``zenith``, ``hemisphere`` or ``region``.
    total
        Sum over the cells [cd m-2].
    panorama_value
        The same quantity from the forward panorama (zenith luminance, hemisphere or region
        mean or sum); NaN for ``pca-norm``, which does not add up to a panorama value [cd m-2].
    seconds
        Time of the per-cell computation after the scene and kernel were ready [s].
    path
        The raster written, or None.
    window
        Where :attr:`raster` sits on the emission grid when it is only the window the
        kernel reaches (:class:`~nightlights.sky.setup.ReachWindow`: its first row and
        column, the whole grid's shape and transform); None: :attr:`raster` is the whole grid.
        The file written is always on the whole grid.
    """

    raster: Raster
    metric: str
    total: float
    panorama_value: float
    seconds: float
    path: Path | None = None
    window: ReachWindow | None = None


@flat_keywords(legacy=("output",), observer="one")
def inverse_q(
    scene: Scene,
    observer: Observer,
    output: PathLike | None = None,
    *,
    metric: str = "pca-norm",
    progress: bool = True,
) -> InfluenceResult:
    """Each lit cell's light-pollution level for an observer (Dobashi et al. 2023, Eqs. 10-11).

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2] in a projected CRS, one or two bands, each
        with the emission function of its ``emission_function`` tag), terrain, atmosphere and
        kernel (:class:`~nightlights.sky.scene.Scene`).
    observer
        Who looks (:class:`~nightlights.sky.observer.Observer`), inside the raster or within
        the kernel's range of it. On a grid larger than the kernel's reach only the window of
        cells within it is read (:class:`InfluenceResult` ``window``).
    output
        Q raster (COG) on the emission's grid, written atomically; None writes nothing. Its
        tags record the observer and the scene (turbidity, grid, kernel), which the dimming
        rule reads back.
    metric
        ``pca-norm``: Q_i = flux_i sqrt(sum_k c_k^2) (Eqs. 10-11), the L2 norm of the cell's
        sky image over the panorama's pixels; ``zenith``: the cell's part of the zenith
        luminance; ``hemisphere``: its part of the solid-angle-weighted mean luminance of the
        visible sky. The last two add up over the cells to the forward panorama's value.
    progress
        Progress bar while building a kernel.

    Returns
    -------
    InfluenceResult
        Band ``q_pca_norm``, ``zenith_luminance`` or ``hemisphere_luminance`` [cd m-2].

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = flux[0, 12, 3] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> scene = Scene(raster, kernel=kernel)
    >>> q = inverse_q(scene, Observer(1000.0, 1000.0), metric="zenith")
    >>> int(np.isfinite(q.raster.data).sum()), bool(np.isclose(q.total, q.panorama_value))
    (2, True)
    """
    if metric not in METRICS:
        raise InputError(f"metric {metric!r}; expected one of {', '.join(METRICS)}")
    _check_outputs(output, inputs=scene.inputs)
    window = _reach(scene, observer)
    _check_grid(_map_shape(scene, window), metric, streamed=window is not None)
    clouds = check_deck(scene, metric)
    setup = prepare_scene(scene, observer, progress=progress, window=window, clouds=clouds)
    start = time.perf_counter()
    cells = setup.polar_cells()
    levels = setup.level_weights(cells)
    weights: FloatArray | None = None
    if metric == "pca-norm":
        tables = [pca_norm_table(t) for t in setup.slices]
    else:
        first = setup.slices[0]
        weights = (
            zenith_weights(first.elevation.size, first.n_az)
            if metric == "zenith"
            else hemisphere_weights(setup.below_terrain(), first.elevation)
        )
        tables = [region_table(t, weights) for t in setup.slices]
    if clouds:
        tables = overcast_tables(setup, tables)
    values = cell_values(cells, levels, tables)
    seconds = time.perf_counter() - start
    panorama_value = math.nan if weights is None else _panorama_value(setup, cells, weights)
    if clouds and weights is not None:
        panorama_value = overcast_zenith(setup, cells, _panorama(setup, cells))
    result = _influence_result(
        setup,
        cells,
        values,
        metric,
        panorama_value,
        seconds,
        {"metric": metric, **deck_tags(scene)},
    )
    return _written(result, output)


@flat_keywords(legacy=("output",), observer="one")
def inverse_s(
    scene: Scene,
    observer: Observer,
    output: PathLike | None = None,
    *,
    region: str | PathLike | SkyRegion,
    weight: str = "solid-angle",
    method: str = "pca",
    components: int | None = None,
    progress: bool = True,
) -> InfluenceResult:
    """Each lit cell's part of the skyglow in a region of the sky (Dobashi et al. 2023, Eq. 14).

    Parameters
    ----------
    scene, observer
        As :func:`inverse_q`.
    output
        S raster (COG) on the emission's grid, written atomically; None writes nothing.
    region
        Region of the sky (:class:`~nightlights.inverse.SkyRegion` or its text:
        ``"az,el az,el ..."`` closed, ``zenith:R``, ``horizon:AZ1,AZ2,EL``, or a GeoJSON/WKT
        file) [deg].
    weight
        ``solid-angle``: S_i is the cell's part of the region's solid-angle-weighted mean
        luminance; ``pixel``: the unweighted sum over the region's pixels (Eq. 14).
    method
        ``pca``: per-basis FFT cross-correlation of the region with the bases (fast);
        ``brute``: each cell's raw kernel image summed over the region (reference).
    components
        PCA bases used (default: all the kernel stores) [1].
    progress
        As :func:`inverse_q`.

    Returns
    -------
    InfluenceResult
        Band ``region_luminance`` [cd m-2]; ``total`` equals the forward panorama's region
        value (``panorama_value``).

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 10, 18] = flux[0, 10, 1] = 1.0  # east, west
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> scene = Scene(raster, kernel=kernel)
    >>> s = inverse_s(scene, Observer(1000.0, 950.0), region="horizon:45,135,30")
    >>> bool(s.raster.data[0, 10, 18] > s.raster.data[0, 10, 1])  # the eastern cell leads
    True
    """
    if method not in S_METHODS:
        raise InputError(f"method {method!r}; expected one of {', '.join(S_METHODS)}")
    sky_region = SkyRegion.parse(region)
    _check_outputs(output, inputs=scene.inputs)
    window = _reach(scene, observer)
    _check_grid(_map_shape(scene, window), "region", streamed=window is not None)
    setup = prepare_scene(scene, observer, progress=progress, window=window)
    weights = _region_weights(setup, sky_region, weight)
    start = time.perf_counter()
    cells = setup.polar_cells()
    levels = setup.level_weights(cells)
    if method == "pca":
        tables = [region_table(t, weights, components) for t in setup.slices]
        values = cell_values(cells, levels, tables)
    else:
        values = cell_values_brute(cells, levels, setup.slices, weights)
    seconds = time.perf_counter() - start
    result = _influence_result(
        setup,
        cells,
        values,
        "region",
        _panorama_value(setup, cells, weights),
        seconds,
        {"region": sky_region.text, "weight": weight, "method": method},
    )
    return _written(result, output)


# --- helpers ----------------------------------------------------------------------------------


def _region_weights(setup: SceneSetup, region: SkyRegion, weight: str) -> FloatArray:
    first = setup.slices[0]
    mask = region.mask(first.elevation, _azimuths(first.n_az)) & ~setup.below_terrain()
    return region_weights(mask, first.elevation, weight=weight)


def _target_weights(setup: SceneSetup, kind: str, region: SkyRegion | None) -> FloatArray:
    first = setup.slices[0]
    if region is None:
        return zenith_weights(first.elevation.size, first.n_az)
    return _region_weights(setup, region, "solid-angle")


def _azimuths(n_az: int) -> FloatArray:
    return (np.arange(n_az) + 0.5) * 360.0 / n_az


def _panorama(setup: SceneSetup, cells: PolarCells, scale: FloatArray | None = None) -> FloatArray:
    """The forward PCA panorama [cd m-2] (cells' flux scaled by ``scale``), NaN under terrain."""
    levels = setup.level_weights(cells)
    maps = []
    for level in levels:
        weight = level if scale is None else level * scale
        maps.append(PolarMap(cells.binned(weight), cells.distance_edges, cells.n_az, *_zeros(2)))
    luminance = np.maximum(panorama_pca(maps, setup.slices), 0.0)
    return np.where(setup.below_terrain(), np.nan, luminance)


def _zeros(count: int) -> tuple[FloatArray, ...]:
    return tuple(np.zeros(1) for _ in range(count))


def _panorama_value(setup: SceneSetup, cells: PolarCells, weights: FloatArray) -> float:
    """sum W L of the forward panorama (what the per-cell values add up to)."""
    return float(np.nansum(weights * _panorama(setup, cells)))


def _influence_result(
    setup: SceneSetup,
    cells: PolarCells,
    values: FloatArray,
    metric: str,
    panorama_value: float,
    seconds: float,
    extra: dict[str, str],
) -> InfluenceResult:
    # the kernel, the lit cells and their polar bins are still held when the map is written
    held = (
        setup.table.nbytes
        + values.nbytes
        + sum(value.nbytes for value in vars(cells).values() if isinstance(value, np.ndarray))
    )
    window = setup.window
    row, col, rows, cols = (0, 0, *setup.shape) if window is None else window.bounds
    _check_grid((rows, cols), metric, held, streamed=window is not None)
    grid = np.full((rows, cols), np.nan)
    grid[cells.rows - row, cells.cols - col] = values
    name, meaning = _BAND[metric]
    tags = {
        PRODUCT_TAG: "influence_s" if metric == "region" else "influence_q",
        "observer_x": f"{setup.xy[0]!r}",
        "observer_y": f"{setup.xy[1]!r}",
        "observer_height_m": f"{setup.observer_height!r}",
        "observer_altitude_m": f"{setup.observer_altitude + setup.offset!r}",
        "metric": metric,
        "total_cd_m2": f"{float(values.sum())!r}",
        "panorama_value_cd_m2": f"{panorama_value!r}",
        **(
            setup.scene.record(setup.table)
            if setup.scene is not None
            else {
                "kernel_hash": str(setup.table.attrs.get("content_hash", "")),
                "turbidity": str(setup.table.attrs.get("turbidity", "")),
            }
        ),
        "emission": setup.label,
        "reference": "Dobashi et al. 2023, ACM TOG 42(6) 219, Sec. 4",
        **extra,
    }
    raster = Raster(
        grid[None],
        setup.transform if window is None else window.transform,
        setup.crs,
        (name,),
        ("cd m-2",),
        tags,
        ({"long_name": meaning},),
    )
    return InfluenceResult(
        raster, metric, float(values.sum()), panorama_value, seconds, window=window
    )


def influence_memory(shape: tuple[int, int], held: float = 0.0, *, streamed: bool) -> float:
    """Estimated memory of an influence map [B].

    The first calls (:data:`FIXED_BYTES`), the arrays ``held`` when the map is made, the map's
    cells (:data:`BYTES_PER_CELL`) and, for a window written into a larger grid's COG, the
    writer's cache (:data:`STREAM_BYTES`).

    Parameters
    ----------
    shape
        (rows, cols) of the map held: the emission grid, or the window the kernel reaches
        [cells].
    held
        Arrays held besides it [B].
    streamed
        Whether the map is a window written into a larger grid.

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> influence_memory((1000, 1000), streamed=False) / 2**20  # [MiB]
    59.073486328125
    """
    rows, cols = shape
    return FIXED_BYTES + held + BYTES_PER_CELL * rows * cols + (STREAM_BYTES if streamed else 0)


def _check_grid(
    shape: tuple[int, int] | None, metric: str, held: float = 0.0, *, streamed: bool = False
) -> None:
    """Refuse a map that would pass the memory limit (:func:`influence_memory`)."""
    if shape is None:
        return  # the reader reports what is wrong with the emission
    rows, cols = shape
    check_memory(
        influence_memory(shape, held, streamed=streamed),
        f"the {metric} raster of {rows} x {cols} cells",
        option="crop the emission raster to the lit region",
    )


def _reach(scene: Scene, observer: Observer) -> ReachWindow | None:
    """The window of the emission grid that the kernel reaches from the observer, read from
    the headers (emission, kernel) before the cells are read; None where it is the whole grid
    (or the header cannot be read: the reader reports why)."""
    emission = scene.emission
    if isinstance(emission, LitCells):
        transform, shape, crs = emission.transform, emission.shape, emission.crs
    else:
        header = raster_header(emission)
        if header is None:
            return None
        transform, shape, crs = header.transform, (header.rows, header.cols), header.crs
    check_projected(crs, scene.label)
    if transform.b != 0 or transform.d != 0:
        return None  # a rotated grid: refused by the polar binning
    xy = observer.position(crs)
    table = scene.kernel_dataset()
    reach = MAX_KERNEL_RANGE if table is None else float(table["distance_edges"].values[-1])
    window = reach_window(transform, shape, xy, reach)
    if window.rows == 0 or window.cols == 0:
        left, bottom, right, top = _grid_bounds(transform, shape)
        gap = math.hypot(
            max(left - xy[0], 0.0, xy[0] - right), max(bottom - xy[1], 0.0, xy[1] - top)
        )
        raise InputError(
            f"observer ({xy[0]:.1f}, {xy[1]:.1f}) lies {gap / 1000:.4g} km outside "
            f"{scene.label} ({left:.1f}, {bottom:.1f}, {right:.1f}, {top:.1f}), beyond the "
            f"kernel's range ({reach / 1000:.4g} km): no cell can light its sky"
            + reach_hint(xy, (observer.x, observer.y), observer.crs)
        )
    return None if window.whole else window


def _grid_bounds(transform: Affine, shape: tuple[int, int]) -> tuple[float, float, float, float]:
    """(left, bottom, right, top) of a north-up grid's pixel edges [m]."""
    x0, y0 = transform @ (0, 0)
    x1, y1 = transform @ (shape[1], shape[0])
    return (min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))


def _map_shape(scene: Scene, window: ReachWindow | None) -> tuple[int, int] | None:
    """The (rows, cols) of the map held: the window, or the emission grid from its header."""
    if window is not None:
        return (window.rows, window.cols)
    if isinstance(scene.emission, LitCells):
        return scene.emission.shape
    header = raster_header(scene.emission)
    return None if header is None else (header.rows, header.cols)


def _written(result: InfluenceResult, output: PathLike | None) -> InfluenceResult:
    if output is None:
        return result
    window = result.window
    if window is None:
        path = result.raster.write(output)
    else:
        path = _stream(result.raster, window, output)
    return InfluenceResult(
        result.raster,
        result.metric,
        result.total,
        result.panorama_value,
        result.seconds,
        path,
        window,
    )


def _stream(raster: Raster, window: ReachWindow, output: PathLike) -> Path:
    """Write a window's map on the whole grid, :data:`STREAM_ROWS` rows at a time (NaN
    outside the window), atomically (:class:`~nightlights.io.streamed.CogWriter`)."""
    assert raster.crs is not None  # a window is only cut from a projected grid
    with CogWriter(
        output,
        shape=(raster.count, *window.grid_shape),
        transform=window.grid_transform,
        crs=raster.crs,
        descriptions=raster.descriptions,
        units=raster.units,
        band_tags=raster.band_tags,
        tags=raster.tags,
    ) as writer:
        for start in range(0, window.rows, STREAM_ROWS):
            part = raster.data[:, start : start + STREAM_ROWS]
            writer.write(part, row=window.row + start, col=window.col)
    return Path(output)


def _check_outputs(*paths: PathLike | None, inputs: Inputs) -> OutputSet:
    """Every output's location checked before any computation (folder exists and is
    writable, no path twice, none of the ``inputs``); the set writes them together
    (:class:`OutputSet`)."""
    return OutputSet(*paths, inputs=inputs)


def _lit(data: FloatArray) -> np.ndarray:
    return lit_mask(data)
