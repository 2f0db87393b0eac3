"""An emission raster, an observer and a kernel made ready for a panorama or an inverse map.

:func:`prepare_scene` reads and checks the emission, places the observer in its CRS, reads the
terrain, and loads (or builds and caches) the kernel with one slice per source-altitude level at
the observer's altitude. :func:`nightlights.sky.scene.skyglow_panorama` and the inverse maps
(:mod:`nightlights.inverse`) start from its :class:`SceneSetup`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr
from pyproj import CRS, Transformer

from nightlights._typing import FloatArray, PathLike
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.io import Raster, as_raster, source_label
from nightlights.sky.horizon import SceneTerrain, horizon_elevation, scene_terrain
from nightlights.sky.panorama import KernelSlice, kernel_levels
from nightlights.sky.polar import PolarCells, lit_mask, polar_cells, source_level_weights
from nightlights.sky.spec import KernelSpec, scene_kernel_spec, source_levels
from nightlights.sky.store import KernelResult, get_or_build_kernel, load_kernel

__all__ = ["RasterInput", "SceneSetup", "level_offset", "prepare_scene"]

#: What a stage accepts as a raster input.
RasterInput = Raster | xr.DataArray | PathLike


@dataclass(frozen=True)
class SceneSetup:
    """An emission raster, an observer and a kernel made ready for a panorama.

    What :func:`skyglow_panorama` and the inverse quantities (:mod:`nightlights.inverse`)
    share: the checked raster, the observer in its CRS, the terrain, the kernel and one
    kernel slice per source-altitude level at the observer's altitude. Altitudes here are
    the kernel's (shifted by ``offset`` when a given kernel's levels do not cover the scene).

    Attributes
    ----------
    label
        How the emission is named in messages.
    raster
        The emission raster.
    data
        Its ``(bands, rows, cols)`` upward flux density [lm m-2].
    xy
        Observer (x, y) in the raster's CRS [m].
    observer_height
        Observer height above the ground [m].
    observer_altitude
        Observer altitude in the kernel's frame [m].
    heights
        Source altitude of every cell in the kernel's frame, ``(rows, cols)`` [m].
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
        One kernel slice per level at the observer's altitude.
    lit
        Boolean ``(rows, cols)``: the cells with flux (:func:`lit_mask`).
    """

    label: str
    raster: Raster
    data: FloatArray
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
    lit: np.ndarray

    @property
    def crs(self) -> CRS:
        """The raster's (projected) CRS."""
        assert self.raster.crs is not None  # checked by prepare_scene
        return self.raster.crs

    def polar_cells(self) -> PolarCells:
        """The lit cells split into the observer's polar bins (:func:`polar_cells`)."""
        first = self.slices[0]
        return polar_cells(
            self.data,
            self.raster.transform,
            self.xy,
            distance_edges=first.distance_edges,
            n_az=first.n_az,
            lit=self.lit,
        )

    def level_weights(self, cells: PolarCells) -> FloatArray:
        """Shape ``(n_levels, n_cells)``: each lit cell's share of every source level [1]."""
        return source_level_weights(self.heights[cells.rows, cells.cols], self.levels)

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
    emission: RasterInput,
    observer: tuple[float, float],
    kernel: KernelResult | xr.Dataset | PathLike | None = None,
    dem: RasterInput | None = None,
    *,
    observer_crs: str | None = None,
    observer_height: float = 1.7,
    turbidity: float | None = None,
    n_elevation: int = 64,
    n_azimuth: int = 256,
    n_distance: int = 64,
    cache_dir: PathLike | None = None,
    progress: bool = True,
) -> SceneSetup:
    """Check an emission raster and an observer, and load or build the kernel for them.

    Parameters
    ----------
    emission, observer, kernel, dem, observer_crs, observer_height, turbidity
        As :func:`skyglow_panorama`.
    n_elevation, n_azimuth, n_distance, cache_dir, progress
        As :func:`skyglow_panorama`, for a scene kernel.

    Returns
    -------
    SceneSetup
        The checked scene with one kernel slice per source level.
    """
    label = source_label(emission, "emission raster")
    raster = as_raster(emission)
    data = raster.data
    if raster.crs is None or not raster.crs.is_projected:
        raise CRSError(f"{label}: the emission raster needs a projected CRS in metres")
    if data.shape[0] > 2:
        raise InputError(
            f"{label}: {data.shape[0]} bands; expected 1 (Lambertian) or 2 (Lambertian + uplight)"
        )
    if np.isfinite(data).any() and np.nanmin(data) < 0:
        raise InputError(f"{label}: negative flux density {np.nanmin(data):g} lm m-2")
    xy = _observer_xy(observer, observer_crs, raster.crs)
    if observer_height < 0:
        raise InputError(f"observer height {observer_height} m; expected >= 0")
    terrain = (
        scene_terrain(dem, raster, xy, observer_height, label=source_label(dem, "DEM"))
        if dem is not None
        else None
    )
    # Altitudes above sea level: without terrain the ground is at 0 m.
    observer_altitude = terrain.eye_altitude if terrain is not None else observer_height
    heights = terrain.heights if terrain is not None else np.zeros(data.shape[1:])
    lit = lit_mask(data)
    spec: KernelSpec | None = None
    if kernel is not None:
        table = load_kernel(kernel)
    else:
        spec = scene_kernel_spec(
            raster,
            xy,
            observer_altitude=observer_altitude,
            source_altitudes=source_levels(heights[lit]),
            turbidity=2.0 if turbidity is None else turbidity,
            n_elevation=n_elevation,
            n_azimuth=n_azimuth,
            n_distance=n_distance,
            uplight=data.shape[0] == 2,
        )
        table = get_or_build_kernel(spec, cache_dir=cache_dir, progress=progress).kernel
    kernel_turbidity = float(table.attrs.get("turbidity", np.nan))
    if turbidity is not None and kernel is not None and not np.isclose(turbidity, kernel_turbidity):
        raise InputError(
            f"turbidity {turbidity} differs from the kernel's ({kernel_turbidity}); "
            "omit --turbidity or build a kernel for it"
        )
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    offset = level_offset(heights, lit, levels)
    slices = kernel_levels(table, observer_altitude=observer_altitude - offset)
    return SceneSetup(
        label=label,
        raster=raster,
        data=data,
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
        lit=lit,
    )


def level_offset(heights: FloatArray, lit: np.ndarray, levels: FloatArray) -> float:
    """Common shift of all altitudes that brings the lit cells within a kernel's source levels.

    A scene kernel always covers them (0 is returned). A given kernel may not (e.g. one built
    with sources at 0 m used over terrain): then observer and sources are shifted together so
    that the observer keeps its height above the sources (the air density is then that of the
    kernel's levels), with a warning.

    Parameters
    ----------
    heights
        Source altitude of every cell, ``(rows, cols)`` [m].
    lit
        Boolean ``(rows, cols)``: the cells with flux.
    levels
        The kernel's source-altitude levels [m].

    Returns
    -------
    float
        The shift to subtract from every altitude [m].
    """
    if not lit.any():
        return 0.0
    low, high = float(np.nanmin(heights[lit])), float(np.nanmax(heights[lit]))
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


def _observer_xy(
    observer: tuple[float, float], observer_crs: str | None, raster_crs: CRS
) -> tuple[float, float]:
    x, y = (float(v) for v in observer)
    if not (np.isfinite(x) and np.isfinite(y)):
        raise InputError(f"observer {observer!r}; expected two finite numbers")
    if observer_crs is None:
        return x, y
    try:
        source = CRS.from_user_input(observer_crs)
    except Exception as exc:  # pyproj raises its own CRSError
        raise CRSError(f"observer CRS {observer_crs!r} is not a CRS: {exc}") from exc
    transformer = Transformer.from_crs(source, raster_crs, always_xy=True)
    tx, ty = transformer.transform(x, y)
    return float(tx), float(ty)
