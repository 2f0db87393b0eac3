"""An emission raster, an observer and a kernel made ready for a panorama or an inverse map.

:func:`prepare_scene` reads and checks the emission, places the observer in its CRS, reads the
terrain, and loads (or builds and caches) the kernel with one slice per source-altitude level at
the observer's altitude, one row per emission band: the mix of kernel shapes of the band's
emission function (band tag ``emission_function``, :func:`band_emission_functions`).
:func:`nightlights.sky.forward.skyglow_panorama` and the inverse maps
(:mod:`nightlights.inverse`) start from its :class:`SceneSetup`.

A stage about one observer may read only the part of a large grid that the kernel reaches
(:func:`reach_window`): cells beyond the kernel's last distance edge add nothing to its sky.

Length: about 690 lines, because every check a scene passes before its kernel is used (the
emission, its bands' emission functions, the observer, the terrain, the reach, the memory) is
shared by the skyglow, inverse and explore stages and kept in one place.
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from affine import Affine
from pyproj import CRS

from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.io import Raster, source_label
from nightlights.io.raster import LitCells, as_lit_cells
from nightlights.sky.horizon import SceneTerrain, horizon_elevation, scene_terrain
from nightlights.sky.observer import Observer
from nightlights.sky.panorama import KernelSlice, band_slice, kernel_levels
from nightlights.sky.polar import (
    PolarCells,
    lit_polar_cells,
    source_level_weights,
    supersampling,
)
from nightlights.sky.scene import (
    EmissionInput,
    RasterInput,
    Scene,
    check_kernel_grid,
    kernel_tables,
)
from nightlights.sky.spec import (
    DEFAULT_EMISSION_FUNCTION,
    EMISSION_FUNCTION_TAG,
    MAX_KERNEL_RANGE,
    EmissionFunction,
    KernelSpec,
    source_levels,
)

__all__ = [
    "EmissionInput",
    "RasterInput",
    "ReachWindow",
    "SceneSetup",
    "band_emission_functions",
    "check_kernel_grid",
    "check_projected",
    "kernel_band_functions",
    "kernel_tables",
    "level_offset",
    "prepare_scene",
    "reach_hint",
    "reach_window",
    "scene_memory",
]

log = logging.getLogger(__name__)


#: Largest absolute coordinates that look like degrees (longitude, latitude) [deg].
_DEGREE_LIKE = (360.0, 90.0)


@dataclass(frozen=True)
class ReachWindow:
    """The part of an emission grid that a kernel reaches from an observer.

    Every cell with a point within ``reach`` of the observer along x and along y: the cells
    beyond the kernel's last distance edge add nothing to the observer's sky, so a stage about
    one observer reads only these.

    Attributes
    ----------
    row, col
        The window's first cell on the grid [cells].
    rows, cols
        Its shape [cells].
    grid_shape
        (rows, cols) of the whole grid [cells].
    grid_transform
        The whole grid's affine transform [m].
    reach
        The kernel's reach it was cut for [m].
    """

    row: int
    col: int
    rows: int
    cols: int
    grid_shape: tuple[int, int]
    grid_transform: Affine
    reach: float

    @property
    def bounds(self) -> tuple[int, int, int, int]:
        """(row, col, rows, cols) [cells]."""
        return (self.row, self.col, self.rows, self.cols)

    @property
    def transform(self) -> Affine:
        """The window's affine transform [m]."""
        return self.grid_transform @ Affine.translation(self.col, self.row)

    @property
    def whole(self) -> bool:
        """Whether the window is the whole grid."""
        return (self.rows, self.cols) == self.grid_shape


def reach_window(
    transform: Affine, shape: tuple[int, int], xy: tuple[float, float], reach: float
) -> ReachWindow:
    """The cells of a north-up grid within ``reach`` of ``xy`` along both axes.

    Parameters
    ----------
    transform
        The grid's affine transform (north up) [m].
    shape
        The grid's (rows, cols) [cells].
    xy
        Observer (x, y) in the grid's CRS [m].
    reach
        The kernel's last distance edge [m].

    Returns
    -------
    ReachWindow
        Empty (``rows`` or ``cols`` 0) when the grid lies beyond the reach.

    Examples
    --------
    >>> from affine import Affine
    >>> window = reach_window(Affine(100, 0, 0, 0, -100, 2000), (20, 30), (1050.0, 950.0), 300.0)
    >>> window.bounds, window.whole
    ((7, 7, 7, 7), False)
    """
    rows, cols = shape
    x, y = xy
    # pixel edges of the square [x - reach, x + reach] x [y - reach, y + reach]
    col_a, row_a = ~transform @ (x - reach, y + reach)
    col_b, row_b = ~transform @ (x + reach, y - reach)
    col0 = min(max(math.floor(min(col_a, col_b)), 0), cols)
    col1 = min(max(math.ceil(max(col_a, col_b)), 0), cols)
    row0 = min(max(math.floor(min(row_a, row_b)), 0), rows)
    row1 = min(max(math.ceil(max(row_a, row_b)), 0), rows)
    return ReachWindow(row0, col0, row1 - row0, col1 - col0, shape, transform, float(reach))


@dataclass(frozen=True)
class SceneSetup:
    """An emission raster, an observer and a kernel made ready for a panorama.

    What :func:`skyglow_panorama` and the inverse quantities (:mod:`nightlights.inverse`)
    share: the checked lit cells of the emission, the observer in its CRS, the terrain, the
    kernel and one kernel slice per source-altitude level at the observer's altitude.
    Altitudes here are the kernel's (shifted by ``offset`` when a given kernel's levels do not
    cover the scene).

    Attributes
    ----------
    label
        How the emission is named in messages.
    emission
        The emission's lit cells, upward flux density [lm m-2] (the raster is never held
        whole).
    xy
        Observer (x, y) in the raster's CRS [m].
    observer_height
        Observer height above the ground [m].
    observer_altitude
        Observer altitude in the kernel's frame [m].
    heights
        Source altitude of every lit cell in the kernel's frame, ``(n_cells,)`` [m].
    offset
        Shift subtracted from all altitudes to fit the kernel's levels [m].
    terrain
        The scene terrain, or None without a DEM.
    table
        The kernel dataset.
    spec
        The scene kernel's specification (None for a given kernel).
    levels
        The kernel's source-altitude levels, increasing [m].
    slices
        One kernel slice per level at the observer's altitude, one row per emission band.
    functions
        The emission function each band was given.
    function_notes
        Where each band's function came from: ``tag``, ``default`` or why another was used.
    scene
        The scene it was prepared from.
    window
        The part of the grid read (:func:`reach_window`), or None: the whole grid.
    """

    label: str
    emission: LitCells
    xy: tuple[float, float]
    observer_height: float
    observer_altitude: float
    heights: FloatArray
    offset: float
    terrain: SceneTerrain | None
    table: xr.Dataset
    spec: KernelSpec | None
    levels: FloatArray
    slices: list[KernelSlice]
    functions: tuple[EmissionFunction, ...] = ()
    function_notes: tuple[str, ...] = ()
    scene: Scene | None = None
    window: ReachWindow | None = None

    @property
    def crs(self) -> CRS:
        """The raster's (projected) CRS."""
        assert self.emission.crs is not None  # checked by prepare_scene
        return self.emission.crs

    @property
    def transform(self) -> Affine:
        """The raster's affine transform [m]."""
        return self.emission.transform

    @property
    def shape(self) -> tuple[int, int]:
        """The raster's (rows, cols)."""
        return self.emission.shape

    def polar_cells(self) -> PolarCells:
        """The lit cells split into the observer's polar bins (:func:`lit_polar_cells`), in
        the order of :attr:`emission`."""
        first = self.slices[0]
        return lit_polar_cells(
            self.emission.rows,
            self.emission.cols,
            self.emission.values,
            self.transform,
            self.xy,
            distance_edges=first.distance_edges,
            n_az=first.n_az,
        )

    def level_weights(self, cells: PolarCells) -> FloatArray:
        """Shape ``(n_levels, n_cells)``: each lit cell's share of every source level [1]."""
        if cells.n_cells != self.heights.size:
            raise InputError(
                f"{cells.n_cells} cells; expected the scene's {self.heights.size} lit cells"
            )
        return source_level_weights(self.heights, self.levels)

    def below_terrain(self) -> np.ndarray:
        """Boolean ``(n_el, n_az)``: True where the terrain hides the sky (all False
        without a DEM)."""
        first = self.slices[0]
        if self.terrain is None:
            return np.zeros((first.elevation.size, first.n_az), dtype=bool)
        horizon = horizon_elevation(
            self.terrain.dem,
            self.terrain.transform,
            self.xy,
            eye_altitude=self.terrain.eye_altitude,
            n_az=first.n_az,
        )
        return first.elevation[:, None] < horizon[None, :]


def prepare_scene(
    scene: Scene,
    observer: Observer,
    *,
    progress: bool = True,
    window: ReachWindow | None = None,
    clouds: bool = False,
) -> SceneSetup:
    """Check a scene's emission and an observer, and find the scene's kernel for them.

    A file is read window by window keeping only its lit cells
    (:func:`~nightlights.io.raster.read_lit_cells`), and only the cells of ``window`` when
    one is given. Refused with a one-line
    :class:`~nightlights.errors.InputError`: infinite or negative flux, no lit cell, an
    observer whose coordinates are not on the Earth in its CRS, an observer farther from every
    lit cell than the kernel reaches (an observer outside the raster within that range is a
    dark site, and legal), and grid options that differ from a given kernel's.

    Parameters
    ----------
    scene
        The emission, terrain, atmosphere and kernel (:class:`~nightlights.sky.scene.Scene`).
    observer
        Who looks (:class:`~nightlights.sky.observer.Observer`).
    progress
        Progress bar while building a kernel.
    window
        The part of the grid the kernel reaches from the observer (:func:`reach_window`),
        read alone; None: the whole grid. A window without a lit cell is refused.
    clouds
        Whether the calling stage reads the scene's cloud deck; a stage that does not refuses
        a scene with one (:meth:`~nightlights.sky.scene.Scene.clear_sky`).

    Returns
    -------
    SceneSetup
        The checked scene with one kernel slice per source level.
    """
    if not clouds:
        scene.clear_sky("this sky stage")
    emission = scene.emission
    label = scene.label
    cells = as_lit_cells(emission, None if window is None else window.bounds)
    check_projected(cells.crs, label)
    if cells.count > 2:
        raise InputError(
            f"{label}: {cells.count} bands; expected 1 or 2 (e.g. Lambertian + uplight)"
        )
    functions, notes = band_emission_functions(emission, cells.count, label=label)
    if window is not None and cells.n_cells == 0 and not cells.infinite_values:
        x, y = observer.position(cells.crs)
        raise InputError(
            f"observer ({x:.1f}, {y:.1f}): no lit cell of {label} within the kernel's range "
            f"({window.reach / 1000:.4g} km) of it: no cell can light its sky"
            + reach_hint((x, y), (observer.x, observer.y), observer.crs)
        )
    _check_flux(cells, label)
    xy = observer.position(cells.crs)
    observer_height = observer.height
    given = (observer.x, observer.y)
    _check_reach(cells, xy, MAX_KERNEL_RANGE, label, given, observer.crs, "any kernel's")
    dem = scene.dem
    terrain = (
        scene_terrain(dem, cells, xy, observer_height, label=source_label(dem, "DEM"))
        if dem is not None
        else None
    )
    # Altitudes above sea level: without terrain the ground is at 0 m.
    observer_altitude = terrain.eye_altitude if terrain is not None else observer_height
    heights = terrain.heights if terrain is not None else np.zeros(cells.n_cells)
    table, spec = scene.find_kernel(
        cells,
        xy,
        observer_altitudes=(observer_altitude,),
        source_altitudes=source_levels(heights),
        functions=functions,
        progress=progress,
    )
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    offset = level_offset(heights, None, levels)
    slices = kernel_levels(table, observer_altitude=observer_altitude - offset)
    functions, notes = kernel_band_functions(functions, notes, slices[0].emissions, label)
    slices = [band_slice(s, functions) for s in slices]
    if spec is None:
        reach = float(slices[0].distance_edges[-1])
        _check_reach(cells, xy, reach, label, given, observer.crs)
    first = slices[0]
    check_memory(
        scene_memory(
            cells,
            xy,
            n_az=first.n_az,
            n_elevation=first.elevation.size,
            n_distance=first.distance_edges.size - 1,
            n_levels=levels.size,
        ),
        f"the polar map and panorama of {cells.n_cells} lit cells ({first.elevation.size} x "
        f"{first.n_az} pixels)",
        option="lower n_azimuth= or n_elevation=, or coarsen the emission raster",
    )
    return SceneSetup(
        label=label,
        emission=cells,
        xy=xy,
        observer_height=float(observer_height),
        observer_altitude=observer_altitude - offset,
        heights=heights - offset,
        offset=offset,
        terrain=terrain,
        table=table,
        spec=spec,
        levels=levels,
        slices=slices,
        functions=functions,
        function_notes=notes,
        scene=scene,
        window=window,
    )


#: Emission functions of the bands of an untagged two-band raster (the emission stage's
#: layout: reflected light, then the luminaires' direct uplight).
TWO_BAND_FUNCTIONS = ("lambertian", "uplight")


def band_emission_functions(
    emission: EmissionInput, count: int, *, label: str = "emission raster"
) -> tuple[tuple[EmissionFunction, ...], tuple[str, ...]]:
    """The emission function of every band: its ``emission_function`` tag, or the default.

    Without the tag, a single band is read as :data:`~nightlights.sky.spec.
    DEFAULT_EMISSION_FUNCTION` (Garstang 1986, F = G = 0.15: a satellite or user raster
    of a city's total upward flux) and the two bands of an untagged two-band raster as
    Lambertian and uplight (the layout of the ``emission`` stage, which tags them). With a
    given kernel that has no ``garstang_lobe`` table, :func:`prepare_scene` reads an untagged
    single band as Lambertian instead (logged; the panorama's attributes say so).

    Parameters
    ----------
    emission
        The emission input: a :class:`~nightlights.io.Raster` (its ``band_tags``), a
        DataArray (its attribute ``emission_function``: one text, or one per band), a path
        (the file's band tags) or :class:`~nightlights.io.raster.LitCells` (no tags).
    count
        Number of bands [1].
    label
        How the emission is named in messages.

    Returns
    -------
    functions : tuple of EmissionFunction
        One per band.
    notes : tuple of str
        ``tag`` or ``default`` per band.

    Raises
    ------
    InputError
        A tag that names no emission function.
    """
    tags = _band_tags(emission, count)
    defaults = (DEFAULT_EMISSION_FUNCTION,) if count == 1 else TWO_BAND_FUNCTIONS
    functions, notes = [], []
    for band in range(count):
        text = tags[band]
        source = f"{label} band {band + 1} tag {EMISSION_FUNCTION_TAG}"
        functions.append(EmissionFunction.parse(text or defaults[band], source=source))
        notes.append("tag" if text else "default")
    return tuple(functions), tuple(notes)


def _band_tags(emission: EmissionInput, count: int) -> list[str | None]:
    """The ``emission_function`` tag of each band, None where there is none."""
    if isinstance(emission, Raster):
        return [emission.band_tags[i].get(EMISSION_FUNCTION_TAG) for i in range(count)]
    if isinstance(emission, xr.DataArray):
        value = emission.attrs.get(EMISSION_FUNCTION_TAG)
        if value is None or isinstance(value, str):
            return [value] * count  # one text: every band
        values: list[str | None] = [str(v) for v in np.ravel(value)]
        return (values + [None] * count)[:count]
    if isinstance(emission, LitCells):
        return [None] * count
    import rasterio

    with rasterio.open(emission) as dataset:
        return [dataset.tags(i + 1).get(EMISSION_FUNCTION_TAG) for i in range(count)]


def kernel_band_functions(
    functions: tuple[EmissionFunction, ...],
    notes: tuple[str, ...],
    available: tuple[str, ...],
    label: str,
) -> tuple[tuple[EmissionFunction, ...], tuple[str, ...]]:
    """The functions a kernel can serve, for :func:`~nightlights.sky.panorama.band_slice`.

    An untagged single band whose default (:data:`~nightlights.sky.spec.
    DEFAULT_EMISSION_FUNCTION`) needs a table the kernel lacks is read as Lambertian, as
    before the default existed (logged, and stated in the outputs' attributes); any other
    missing table is refused by :func:`~nightlights.sky.panorama.band_slice`.

    Parameters
    ----------
    functions, notes
        From :func:`band_emission_functions`.
    available
        The kernel's shapes (``KernelSlice.emissions`` of :func:`kernel_levels`).
    label
        How the emission is named in the log.

    Returns
    -------
    functions, notes
        As given, or with the single band's default replaced.
    """
    if len(functions) != 1 or notes[0] != "default":
        return functions, notes
    missing = [shape for shape in functions[0].shapes if shape not in available]
    if not missing:
        return functions, notes
    log.warning(
        "%s: untagged single band read as lambertian, not the default %s: the kernel has no "
        "%s table",
        label,
        functions[0].tag,
        ", ".join(missing),
    )
    note = f"default {functions[0].tag} needs the kernel's {', '.join(missing)} table: lambertian"
    return (EmissionFunction.parse("lambertian"),), (note,)


#: Bytes per polar sub-point while the cells are split and binned (coordinates, distance,
#: azimuth, bins, shares and the kept arrays of :class:`PolarCells`, whose sub-points mostly
#: hold two entries: their flux shared between two distance bins) [B]; 191-266 B per
#: sub-point measured (tracemalloc peak, 4e5 cells of 10 m, per-cell arrays included).
_SUB_POINT_BYTES = 160
#: Bytes per lit cell besides its sub-points (centres, sub-sampling, level weights) [B].
_CELL_BYTES = 96


def scene_memory(
    cells: LitCells,
    xy: tuple[float, float],
    *,
    n_az: int,
    n_elevation: int,
    n_distance: int,
    n_levels: int,
) -> float:
    """Estimated memory of a panorama or inverse map after the kernel is loaded [B].

    The lit cells' polar sub-points (their number is exact: the sub-sampling of every cell is
    computed from its distance), the polar maps of every source level and the panorama's
    arrays. The raster itself is never held (:func:`~nightlights.io.raster.read_lit_cells`).

    Parameters
    ----------
    cells
        The emission's lit cells.
    xy
        Observer (x, y) [m].
    n_az, n_elevation, n_distance, n_levels
        Kernel azimuths, elevations, distance bins and source levels [1].

    Returns
    -------
    float
        Bytes.
    """
    x, y = cells.centres()
    cell = abs(cells.transform.a)
    samples = supersampling(cell, np.hypot(x - xy[0], y - xy[1]), n_az, max_samples=16)
    n_sub = float(np.sum(samples.astype(float) ** 2))
    per_cell = _CELL_BYTES + 8.0 * cells.count * (1 + n_levels)
    maps = 3 * 8.0 * n_levels * cells.count * n_distance * n_az
    panorama = 16 * 8.0 * n_elevation * n_az
    return _SUB_POINT_BYTES * n_sub + per_cell * cells.n_cells + maps + panorama


def _check_flux(cells: LitCells, label: str) -> None:
    """Refuse infinite or negative flux and a raster without a lit cell."""
    if cells.infinite_values:
        raise InputError(
            f"{label}: {cells.infinite_values} non-finite (inf) values; expected finite flux "
            "densities [lm m-2] (nodata as NaN)"
        )
    finite = cells.values[np.isfinite(cells.values)]
    if finite.size and finite.min() < 0:
        raise InputError(f"{label}: negative flux density {finite.min():g} lm m-2")
    if cells.n_cells == 0:
        rows, cols = cells.shape
        what = "nodata" if cells.nodata_cells == rows * cols else "zero or nodata"
        raise InputError(
            f"{label}: no lit cell (all {rows} x {cols} cells are {what}); nothing lights the sky"
        )


def check_projected(crs: CRS | None, label: str) -> None:
    """Refuse an emission grid without a projected CRS (one line, :class:`CRSError`)."""
    if crs is None or not crs.is_projected:
        raise CRSError(f"{label}: the emission raster needs a projected CRS in metres")


def reach_hint(xy: tuple[float, float], observer: tuple[float, float], observer_crs: Any) -> str:
    """The end of a message about an observer beyond a kernel's reach: what to check."""
    if observer_crs is None and _looks_like_degrees(*xy):
        return (
            f"; ({observer[0]:g}, {observer[1]:g}) look like degrees: give observer_crs='EPSG:4326'"
        )
    return "; check the coordinates and observer_crs="


def _looks_like_degrees(x: float, y: float) -> bool:
    return abs(x) <= _DEGREE_LIKE[0] and abs(y) <= _DEGREE_LIKE[1]


def _check_reach(
    cells: LitCells,
    xy: tuple[float, float],
    reach: float,
    label: str,
    observer: tuple[float, float],
    observer_crs: Any,
    whose: str = "the kernel's",
) -> None:
    """Refuse an observer farther from every lit cell than ``reach``; warn about one outside
    the raster whose coordinates look like degrees without an observer CRS."""
    bounds = cells.lit_bounds()
    if bounds is None:
        return
    left, bottom, right, top = bounds
    x, y = xy
    gap = math.hypot(max(left - x, 0.0, x - right), max(bottom - y, 0.0, y - top))
    hint = reach_hint(xy, observer, observer_crs)
    if gap >= reach:
        raise InputError(
            f"observer ({x:.1f}, {y:.1f}) lies {gap / 1000:.4g} km outside the lit cells of "
            f"{label} ({left:.1f}, {bottom:.1f}, {right:.1f}, {top:.1f}), beyond {whose} "
            f"range ({reach / 1000:.4g} km): no cell can light its sky{hint}"
        )
    r_left, r_bottom, r_right, r_top = cells.bounds
    outside = not (r_left <= x <= r_right and r_bottom <= y <= r_top)
    if outside and observer_crs is None and _looks_like_degrees(x, y):
        warnings.warn(
            f"observer ({x:g}, {y:g}) lies outside {label} ({r_left:.1f}, {r_bottom:.1f}, "
            f"{r_right:.1f}, {r_top:.1f}) and its coordinates look like degrees; if they are "
            "longitude and latitude, give observer_crs='EPSG:4326'",
            DataQualityWarning,
            stacklevel=4,
        )


def level_offset(heights: FloatArray, lit: np.ndarray | None, levels: FloatArray) -> float:
    """Common shift of all altitudes that brings the lit cells within a kernel's source levels.

    A scene kernel always covers them (0 is returned). A given kernel may not (e.g. one built
    with sources at 0 m used over terrain): then observer and sources are shifted together so
    that the observer keeps its height above the sources (the air density is then that of the
    kernel's levels), with a warning.

    Parameters
    ----------
    heights
        Source altitude of every cell, ``(rows, cols)``, or of the lit cells alone [m].
    lit
        Boolean, the shape of ``heights``: the cells with flux (None: every cell of
        ``heights``).
    levels
        The kernel's source-altitude levels [m].

    Returns
    -------
    float
        The shift to subtract from every altitude [m].
    """
    lit_heights = np.asarray(heights, dtype=float)
    if lit is not None:
        lit_heights = lit_heights[lit]
    if not np.isfinite(lit_heights).any():
        return 0.0
    low, high = float(np.nanmin(lit_heights)), float(np.nanmax(lit_heights))
    bottom, top = float(levels.min()), float(levels.max())
    if low >= bottom - 5.0 and high <= top + 5.0:
        return 0.0
    if high - low <= top - bottom:
        offset = low - bottom if low < bottom else high - top
    else:
        offset = 0.5 * (low + high) - 0.5 * (bottom + top)
    warnings.warn(
        f"lit cells stand at {low:g}-{high:g} m but the kernel's source levels span "
        f"{bottom:g}-{top:g} m; observer and sources are shifted by {-offset:+g} m together "
        "(relative heights kept; cells still outside take the nearest level)",
        DataQualityWarning,
        stacklevel=4,
    )
    return offset
