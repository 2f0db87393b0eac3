"""The engine of ``nightlights explore``: one emission raster held in memory, any observer.

Dobashi et al. (2023, Secs. 4-5) make light pollution interactive: move the observer and
see the sky at once, pick part of the sky and see the lights that cause it (Eqs. 10-14),
dim them (Eq. 12) and edit the lights. :class:`ExploreSession` is that loop over the
toolkit's own stages, with every per-scene step done once:

- the emission is read whole and its lit cells, their flux, terrain heights and
  source-level weights are kept (redone only after an edit);
- one kernel serves every observer: the given one, or a scene kernel reaching across the
  whole raster from any cell in it (and tabulated at the lowest and highest eye altitude
  over a DEM), its per-level tables read once (:class:`~nightlights.sky.panorama.KernelLevels`);
- a new observer then costs one compiled pass over the lit cells
  (:func:`~nightlights.sky._polar_numba.polar_flux_levels`) and the PCA panorama (Eqs. 7-9);
  a dimming slider the same pass with each cell's flux scaled by 1 - gamma_i.

The panoramas equal ``skyglow_panorama``'s for the same raster, kernel and observer; the
per-cell Q and S maps and the least-flux dimming are the inverse stage's
(:mod:`nightlights.inverse`). With a street layer, each segment's compliance at the current
emission and a plan that keeps the roads lit (:func:`nightlights.roads.road_plan`) are the
road stage's, read from and written to the emission as :mod:`nightlights.explore._roads`
describes.

Length: about 1500 lines, most of them numpydoc, because the session's state (the emission
in its current and original form, the kernel levels, the per-observer caches) and every query
and file on it are kept in one class, so that no query sees a half-updated state; the views,
the edit history and the road model on the raster are in their own modules.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import warnings
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from affine import Affine
from pyproj import CRS

from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import (
    bortle_class_or_reason,
    luminance_to_magnitude,
    magnitude_to_luminance,
)
from nightlights.errors import InputError, OutputExistsError
from nightlights.explore._edits import PLAN_OP, EmissionEdits, band_share, check_saved_edits
from nightlights.explore._roads import (
    RoadOptions,
    RoadPlanView,
    RoadView,
    SessionRoads,
    no_streets,
)
from nightlights.explore._views import DimmingView, EditView, InfluenceView, PanoramaView
from nightlights.ground.checks import raster_header
from nightlights.inverse._dimming import dimming_fraction, least_flux_dimming
from nightlights.inverse._region import SkyRegion
from nightlights.io import Raster, as_raster, source_label
from nightlights.io.jsonfile import dumps_json
from nightlights.io.outputs import refuse_replacing_inputs
from nightlights.io.raster import LitCells
from nightlights.io.styles import PRODUCT_TAG
from nightlights.sky._flat import SCENE_KEYWORDS
from nightlights.sky._polar_numba import polar_flux_levels
from nightlights.sky.forward import panorama_zenith
from nightlights.sky.horizon import (
    ground_height,
    horizon_elevation,
    scene_terrain,
    terrain_under,
)
from nightlights.sky.influence import (
    cell_values,
    hemisphere_weights,
    pca_norm_table,
    region_table,
    region_weights,
    zenith_weights,
)
from nightlights.sky.observer import OBSERVER_HEIGHT, Observer
from nightlights.sky.panorama import KernelLevels, KernelSlice, band_slice, panorama_pca
from nightlights.sky.polar import PolarMap, lit_mask, lit_polar_cells, source_level_weights
from nightlights.sky.scene import Scene
from nightlights.sky.setup import (
    _check_reach,
    band_emission_functions,
    level_offset,
    prepare_scene,
)
from nightlights.sky.spec import source_levels

__all__ = ["DimmingView", "EditView", "ExploreSession", "InfluenceView", "PanoramaView"]

#: Session file format version.
SESSION_VERSION = 1
#: Observers whose polar geometry and kernel slices are kept (a dragged observer revisits
#: few positions; each entry holds one kernel slice set) [1].
_CACHE_SIZE = 16
#: Most cells one brush stroke may touch (a stroke wider than the raster is refused) [1].
_MAX_BRUSH_CELLS = 16_000_000
#: Undo history kept, all steps together [B].
_HISTORY_BYTES = 512 * 2**20
#: Influence maps kept (each a float64 grid of the raster), all together; the newest is
#: always kept [B].
_INFLUENCE_BYTES = 256 * 2**20
#: Bytes per cell and emission band a session holds: the raster read, the original and the
#: edited copies [B].
BYTES_PER_CELL_BAND = 24.0
#: Bytes per cell besides: the lit-cell states, a dimming's fraction and dimmed copy, the map
#: images' resampling; 26 B measured with the bands' 24 B (peak resident memory over a
#: 40 x 40 session's, a 3000 x 3000 single-band raster, after panoramas, influence maps, a
#: dimming and an edit, the influence maps' grids apart) [B].
BYTES_PER_CELL = 16.0
#: Lights shown on the map at most [1].
MAX_LIGHTS = 100_000
#: Edit operations.
EDIT_OPS = ("paint", "erase", "scale")


@dataclass(frozen=True)
class _Cells:
    """The lit cells of one state of the emission, ready for any observer."""

    rows: np.ndarray
    cols: np.ndarray
    values: FloatArray  # (bands, n) [lm m-2]
    flux: FloatArray  # (bands, n) [lm]
    heights: FloatArray  # (n,) kernel frame [m]
    level_weights: FloatArray  # (n_levels, n)
    offset: float

    @property
    def total(self) -> FloatArray:
        return self.flux.sum(axis=0)


class ExploreSession:
    """An emission raster in memory, ready for interactive forward and inverse queries.

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2] in a projected CRS, one or two bands, each
        with the emission function of its ``emission_function`` tag, as the skyglow stage reads
        them), terrain, atmosphere and kernel (:class:`~nightlights.sky.scene.Scene`). Without
        a kernel: a scene kernel reaching across the raster from any cell in it (cached).
    lights
        Optional luminaire layer (any vector format) shown on the map.
    streets
        Optional street layer (lines with ``width`` [m] and the fields of
        :func:`nightlights.roads.audit`) lit by ``lights``: its segments are rated against
        their lighting classes at the session's dimming (:meth:`roads`), and a plan that keeps
        them lit can be solved (:meth:`road_plan`).
    road_options
        How the road model is built (catalogue, r-table, requirements, class selection;
        default: :func:`nightlights.roads.road_model`'s defaults).
    height
        Eye height above the ground of the observers placed in the session [m].
    components
        PCA bases used for the panoramas (default: all the kernel stores; fewer are faster and
        less accurate, see the benchmarks) [1].
    progress
        Progress bar while a kernel is built.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> session = ExploreSession(Scene(raster, kernel=kernel), height=0.0)
    >>> view = session.panorama(1000.0, 1000.0)
    >>> view.luminance.shape, 1 <= view.bortle <= 9
    ((8, 16), True)
    """

    def __init__(
        self,
        scene: Scene,
        *,
        lights: PathLike | None = None,
        streets: PathLike | None = None,
        road_options: RoadOptions | None = None,
        height: float = OBSERVER_HEIGHT,
        components: int | None = None,
        progress: bool = True,
        **flat: Any,
    ) -> None:
        if not isinstance(scene, Scene):
            scene, height = _flat_session(scene, height, flat)
        elif flat:
            raise TypeError(f"ExploreSession() got unexpected keyword arguments {sorted(flat)}")
        emission, kernel, dem = scene.emission, scene.kernel, scene.dem
        self.scene = scene
        self.label = scene.label
        _check_memory(scene.raster_input("ExploreSession"), dem, self.label)
        raster = as_raster(scene.raster_input("ExploreSession"))
        self._sources: dict[str, Any] = {
            "emission": _path_or_none(emission),
            "kernel": _path_or_none(kernel),
            "dem": _path_or_none(dem),
            "lights": _path_or_none(lights),
            "streets": _path_or_none(streets),
            "turbidity": scene.turbidity,
            "emission_sha256": _file_hash(emission),
        }
        self._raster = raster
        self._observer_height = Observer(0.0, 0.0, height=height).height
        self._dem = as_raster(dem) if dem is not None else None
        centre = _centre(raster)
        # prepare_scene checks the raster, the DEM and the kernel as the skyglow stage does.
        table = scene.kernel_dataset()
        if table is None:
            table = self._scene_kernel(raster, progress)
        setup = prepare_scene(
            scene.replace(emission=raster, dem=self._dem, kernel=table),
            Observer(*centre, height=self._observer_height),
            progress=progress,
        )
        self._table = setup.table
        # each band reads its emission function's mix of the kernel's tables (band_slice)
        self._functions = setup.functions
        stored = int(setup.slices[0].coefficient.shape[-1] // len(setup.slices[0].observer_weights))
        if components is not None and not 1 <= components <= stored:
            raise InputError(f"components={components}; the kernel stores 1-{stored}")
        self._components = components
        self._levels = KernelLevels(setup.table, tables=False)
        first = setup.slices[0]
        self._edges = first.distance_edges
        self._n_az = first.n_az
        self.elevation = first.elevation
        self.azimuth = (np.arange(self._n_az) + 0.5) * 360.0 / self._n_az
        self._original = np.array(raster.data, dtype=float)
        self._data = self._original.copy()
        self._edits = EmissionEdits(self._data, self.transform, band_share(self._original))
        self.edit_version = 0
        self._cells: dict[str, tuple[int, _Cells]] = {}
        self._slices: OrderedDict[float, list[KernelSlice]] = OrderedDict()
        self._horizons: OrderedDict[tuple[float, float, float], FloatArray] = OrderedDict()
        self._skies: OrderedDict[tuple[Any, ...], tuple[_Cells, FloatArray]] = OrderedDict()
        self._influences: OrderedDict[tuple[Any, ...], InfluenceView] = OrderedDict()
        self._influence_version: dict[tuple[Any, ...], int] = {}
        self._in_memory = [
            name
            for name, given in (
                ("emission", emission),
                ("kernel", kernel),
                ("dem", dem),
                ("streets", streets),
            )
            if given is not None and self._sources[name] is None
        ]
        self.saved_observer: list[float] | None = None
        self.lights = _read_lights(lights, raster.crs) if lights is not None else None
        self._roads: SessionRoads | None = None
        self._road_options = road_options or RoadOptions()
        if streets is not None:
            if lights is None:
                raise InputError(
                    f"streets={str(streets)!r} needs lights=, the luminaires that light them"
                )
            if road_options is not None and not isinstance(road_options, RoadOptions):
                raise InputError(f"road_options={road_options!r}; expected RoadOptions or None")
            self._roads = SessionRoads(
                lights,
                streets,
                road_options or RoadOptions(),
                transform=self.transform,
                shape=self.shape,
                crs=self.crs,
                original=np.sum(self._original, axis=0),
            )

    # --- construction ---------------------------------------------------------------------

    def _scene_kernel(self, raster: Raster, progress: bool) -> xr.Dataset:
        """A kernel reaching from any cell of the raster to its farthest corner."""
        left, bottom, _, _ = raster.bounds
        cells = raster.lit_cells()
        heights = np.zeros(cells.n_cells)
        eye = [self._observer_height]
        if self._dem is not None:
            terrain = scene_terrain(self._dem, cells, _centre(raster), self._observer_height)
            heights = terrain.heights
            relief = self._dem.data[0]
            eye = sorted(
                {
                    float(np.nanmin(relief)) + self._observer_height,
                    float(np.nanmax(relief)) + self._observer_height,
                }
            )
        # the tables the bands' emission functions need, as the skyglow stage builds them
        functions, _ = band_emission_functions(raster, raster.count, label=self.label)
        table, _ = self.scene.find_kernel(
            raster,
            (left, bottom),
            observer_altitudes=tuple(eye),
            source_altitudes=source_levels(heights),
            functions=functions,
            progress=progress,
        )
        return table

    @classmethod
    def open(
        cls,
        session_file: PathLike,
        *,
        cache_dir: PathLike | None = None,
        progress: bool = True,
    ) -> ExploreSession:
        """Reopen a session saved with :meth:`save`: its inputs, then its edits replayed.

        Parameters
        ----------
        session_file
            The JSON session file.
        cache_dir, progress
            As the constructor.

        Returns
        -------
        ExploreSession
            The session with the saved edits applied.
        """
        path = Path(session_file)
        try:
            content = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: not a session file ({exc})") from exc
        if not isinstance(content, dict) or content.get("format") != "nightlights-explore":
            raise InputError(f"{path}: not a nightlights explore session file")
        if content.get("version") != SESSION_VERSION:
            raise InputError(f"{path}: session version {content.get('version')!r} unknown")

        def resolve(name: str) -> Path | None:
            value = content.get(name)
            if value is None:
                return None
            found = (path.parent / value).resolve()
            if not found.exists():
                raise InputError(f"{path}: its {name} {found} does not exist")
            return found

        edits = check_saved_edits(content.get("edits", []), str(path))
        observer_height = content.get("observer_height", OBSERVER_HEIGHT)
        if isinstance(observer_height, bool) or not isinstance(observer_height, int | float):
            raise InputError(f"{path}: observer_height {observer_height!r}; expected a number [m]")
        saved_observer = content.get("observer")
        if saved_observer is not None and not (
            isinstance(saved_observer, list)
            and len(saved_observer) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in saved_observer)
        ):
            raise InputError(
                f"{path}: observer {saved_observer!r}; expected null or [x, y] in the raster CRS"
            )
        emission = resolve("emission")
        if emission is None:
            raise InputError(f"{path}: the session names no emission raster")
        saved_hash = content.get("emission_sha256")
        if saved_hash and saved_hash != _file_hash(emission):
            warnings.warn(
                f"{emission} changed since the session was saved; its edits are replayed on "
                "the new contents",
                stacklevel=2,
            )
        session = cls(
            Scene(
                emission,
                kernel=resolve("kernel"),
                dem=resolve("dem"),
                turbidity=content.get("turbidity"),
                cache_dir=cache_dir,
            ),
            lights=resolve("lights"),
            streets=resolve("streets"),
            height=float(observer_height),
            progress=progress,
        )
        for index, op in enumerate(edits):
            try:
                if op["op"] == PLAN_OP:
                    session.apply_dimming(
                        op["dimming"],
                        target=op.get("target", ""),
                        objective=op.get("objective", ""),
                    )
                    continue
                session.edit(op["op"], op["points"], radius=op["radius"], value=op["value"])
            except InputError as exc:
                raise InputError(f"{path}: edit {index + 1} of {len(edits)}: {exc}") from None
        session.saved_observer = saved_observer
        return session

    # --- properties -------------------------------------------------------------------------

    @property
    def crs(self) -> CRS:
        """The raster's projected CRS."""
        assert self._raster.crs is not None  # checked by prepare_scene
        return self._raster.crs

    @property
    def transform(self) -> Affine:
        """The raster's affine transform [m]."""
        return self._raster.transform

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the raster."""
        return self._raster.shape

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(left, bottom, right, top) of the raster [m]."""
        return self._raster.bounds

    @property
    def cell_size(self) -> float:
        """Cell size [m]."""
        return float(abs(self.transform.a))

    @property
    def observer_height(self) -> float:
        """Observer height above the ground [m]."""
        return self._observer_height

    @property
    def has_dem(self) -> bool:
        """Whether a DEM is in use."""
        return self._dem is not None

    @property
    def n_lit(self) -> int:
        """Lit cells of the current emission [1]."""
        return int(self._state("current").rows.size)

    @property
    def total_flux(self) -> float:
        """Upward flux of the current emission [lm]."""
        return float(self._state("current").flux.sum())

    @property
    def can_undo(self) -> bool:
        """Whether an edit can be undone."""
        return self._edits.can_undo

    @property
    def can_redo(self) -> bool:
        """Whether an undone edit can be redone."""
        return self._edits.can_redo

    @property
    def kernel_info(self) -> dict[str, Any]:
        """The kernel's hash, turbidity, stored PCA components and range [m]."""
        return {
            "hash": str(self._table.attrs.get("content_hash", "")),
            "turbidity": float(self._table.attrs.get("turbidity", math.nan)),
            "components": int(self._table.sizes.get("component", 0)),
            "components_used": self._components,
            "range_m": float(self._edges[-1]),
        }

    def emission(self, which: str = "current") -> FloatArray:
        """Upward flux density of all bands together [lm m-2], ``(rows, cols)``.

        Parameters
        ----------
        which
            ``current`` (with the edits) or ``original``.

        Returns
        -------
        numpy.ndarray
            NaN where the raster has no data.
        """
        data = self._data if _which(which) == "current" else self._original
        return np.asarray(np.sum(data, axis=0))

    def to_xy(self, x: float, y: float, crs: str | None = None) -> tuple[float, float]:
        """An observer position in the raster's CRS [m].

        Parameters
        ----------
        x, y
            Position in ``crs`` [m or deg].
        crs
            Its CRS (default: the raster's).

        Returns
        -------
        tuple of float
            (x, y) in the raster's CRS [m].
        """
        return Observer(x, y, crs).position(self.crs)

    # --- forward ----------------------------------------------------------------------------

    def panorama(
        self,
        x: float,
        y: float,
        *,
        crs: str | None = None,
        height: float | None = None,
        which: str = "current",
    ) -> PanoramaView:
        """The skyglow panorama an observer sees (Dobashi et al. 2023, Eqs. 7-9).

        Parameters
        ----------
        x, y
            Observer position in ``crs`` [m or deg].
        crs
            CRS of the position (default: the raster's).
        height
            Observer height above the ground [m] (default: the session's).
        which
            ``current`` (with the edits) or ``original``.

        Returns
        -------
        PanoramaView
            The same luminance as :func:`~nightlights.sky.skyglow_panorama` for this
            emission, kernel and observer.
        """
        start = time.perf_counter()
        cells = self._state(_which(which))
        xy, eye = self._observer(x, y, crs, height, cells)
        luminance = self._luminance(cells, xy, eye, None)
        return self._view(xy, eye, luminance, time.perf_counter() - start, _which(which))

    def _luminance(
        self,
        cells: _Cells,
        xy: tuple[float, float],
        eye: float,
        scale: FloatArray | None,
    ) -> FloatArray:
        if scale is None:
            # the undimmed sky of an observer is asked again by every slider move
            key = (id(cells), xy, eye)
            kept = self._skies.get(key)
            if kept is not None and kept[0] is cells:
                return kept[1]
            luminance = self._luminance_of(cells, xy, eye, None)
            luminance.flags.writeable = False  # shared by the views that return it
            self._remember(self._skies, key, (cells, luminance))
            return luminance
        return self._luminance_of(cells, xy, eye, scale)

    def _luminance_of(
        self,
        cells: _Cells,
        xy: tuple[float, float],
        eye: float,
        scale: FloatArray | None,
    ) -> FloatArray:
        slices = self._slices_at(eye - cells.offset)
        maps, _ = polar_flux_levels(
            cells.rows,
            cells.cols,
            cells.flux,
            cells.level_weights,
            self.transform,
            xy,
            distance_edges=self._edges,
            n_az=self._n_az,
            scale=scale,
        )
        empty = np.zeros(1)
        polars = [PolarMap(m, self._edges, self._n_az, empty, empty) for m in maps]
        components = self._components
        if components is not None:
            # an observer between two kernel levels has both levels' bases, interleaved
            components *= len(slices[0].observer_weights)
        luminance = np.maximum(panorama_pca(polars, slices, components=components), 0.0)
        below = self._below_terrain(xy, eye)
        return np.where(below, np.nan, luminance) if below is not None else luminance

    def _view(
        self,
        xy: tuple[float, float],
        eye: float,
        luminance: FloatArray,
        seconds: float,
        source: str,
        dimming: FloatArray | None = None,
    ) -> PanoramaView:
        # The zenith figures of skyglow_panorama's dataset: the mean of the top row's open
        # sky; a sky that is not finite has no brightness and no class (null, with the reason).
        zenith = panorama_zenith(luminance, self._below_terrain(xy, eye))
        magnitude = float(luminance_to_magnitude(zenith))
        bortle, reason = bortle_class_or_reason(magnitude)
        return PanoramaView(
            x=xy[0],
            y=xy[1],
            observer_altitude=eye,
            elevation=self.elevation,
            azimuth=self.azimuth,
            luminance=luminance,
            zenith_luminance=zenith,
            zenith_magnitude=magnitude,
            bortle=bortle,
            seconds=seconds,
            source=source,
            dimming=dimming,
            bortle_reason=reason,
        )

    # --- inverse ----------------------------------------------------------------------------

    def influence(
        self,
        x: float,
        y: float,
        *,
        kind: str = "q",
        metric: str = "pca-norm",
        region: SkyRegion | Sequence[Sequence[float]] | str | None = None,
        crs: str | None = None,
        height: float | None = None,
        which: str = "current",
    ) -> InfluenceView:
        """Each lit cell's part of the sky: Q (Eqs. 10-11) or S of a region (Eqs. 13-14).

        Parameters
        ----------
        x, y, crs, height, which
            The observer and the emission, as :meth:`panorama`.
        kind
            ``q`` or ``s``.
        metric
            For ``q``: ``pca-norm``, ``zenith`` or ``hemisphere``
            (see :func:`~nightlights.inverse.inverse_q`).
        region
            For ``s``: the sky region, a :class:`~nightlights.inverse.SkyRegion`, its text
            form, or a closed polygon of (azimuth, elevation) vertices [deg].

        Returns
        -------
        InfluenceView
            The values per lit cell and as a grid [cd m-2].
        """
        start = time.perf_counter()
        which = _which(which)
        cells = self._state(which)
        xy, eye = self._observer(x, y, crs, height, cells)
        sky_region = _region(region) if kind == "s" else None
        if kind not in ("q", "s"):
            raise InputError(f"kind {kind!r}; expected q or s")
        if kind == "q" and metric not in ("pca-norm", "zenith", "hemisphere"):
            raise InputError(f"metric {metric!r}; expected pca-norm, zenith or hemisphere")
        key = (xy, eye, kind, metric if kind == "q" else "region", _region_key(sky_region), which)
        cached = self._influences.get(key)
        if cached is not None and cached.values.size == cells.rows.size:
            if which == "original" or self._influence_version.get(key) == self.edit_version:
                return cached
        slices = self._slices_at(eye - cells.offset)
        polar = lit_polar_cells(
            cells.rows,
            cells.cols,
            cells.values,
            self.transform,
            xy,
            distance_edges=self._edges,
            n_az=self._n_az,
        )
        below = self._below_terrain(xy, eye)
        below_mask = np.zeros((self.elevation.size, self._n_az), bool) if below is None else below
        weights: FloatArray | None = None
        if kind == "s":
            assert sky_region is not None
            mask = sky_region.mask(self.elevation, self.azimuth) & ~below_mask
            weights = region_weights(mask, self.elevation, weight="solid-angle")
            metric_name = "region"
        elif metric == "pca-norm":
            metric_name = metric
        elif metric == "zenith":
            weights = zenith_weights(self.elevation.size, self._n_az)
            metric_name = metric
        else:
            weights = hemisphere_weights(below_mask, self.elevation)
            metric_name = metric
        if weights is None:
            tables = [pca_norm_table(t) for t in slices]
        else:
            tables = [region_table(t, weights) for t in slices]
        values = cell_values(polar, cells.level_weights, tables)
        panorama_value = math.nan
        if weights is not None:
            panorama_value = float(np.nansum(weights * self._luminance(cells, xy, eye, None)))
        grid = np.full(self.shape, np.nan)
        grid[cells.rows, cells.cols] = values
        view = InfluenceView(
            kind=kind,
            metric=metric_name,
            grid=grid,
            values=values,
            total=float(values.sum()),
            panorama_value=panorama_value,
            seconds=time.perf_counter() - start,
        )
        self._remember(self._influences, key, view)
        while len(self._influences) > 1 and _INFLUENCE_BYTES < sum(
            kept.grid.nbytes for kept in self._influences.values()
        ):
            self._influences.popitem(last=False)  # the oldest map beyond the budget
        self._influence_version[key] = self.edit_version
        return view

    def dim(
        self,
        x: float,
        y: float,
        *,
        by: str = "q",
        metric: str = "pca-norm",
        region: SkyRegion | Sequence[Sequence[float]] | str | None = None,
        qa: float,
        qb: float,
        gamma: float,
        crs: str | None = None,
        height: float | None = None,
    ) -> DimmingView:
        """Dim every lit cell by its Q or S (Dobashi et al. 2023, Eq. 12) and see the sky.

        Parameters
        ----------
        x, y, crs, height
            The observer, as :meth:`panorama`.
        by, metric, region
            The influence dimmed by, as :meth:`influence` (``by`` is its ``kind``).
        qa, qb, gamma
            Eq. 12: cells below ``qa`` keep their flux, cells above ``qb`` lose the fraction
            ``gamma`` [cd m-2, cd m-2, 1].

        Returns
        -------
        DimmingView
            The dimming fraction, the sky before and after, the flux removed.
        """
        start = time.perf_counter()
        influence = self.influence(x, y, kind=by, metric=metric, region=region, crs=crs,
                                   height=height)  # fmt: skip
        fraction = dimming_fraction(influence.values, qa, qb, gamma)
        params = {"by": by, "metric": influence.metric, "qa": qa, "qb": qb, "gamma": gamma}
        if by == "s":
            params["region"] = _region(region).text
        return self._dimmed(x, y, crs, height, fraction, "eq12", params, start)

    def least_dimming(
        self,
        x: float,
        y: float,
        *,
        target_zenith: float | None = None,
        region: SkyRegion | Sequence[Sequence[float]] | str | None = None,
        target_region: float | None = None,
        max_dimming: float = 1.0,
        crs: str | None = None,
        height: float | None = None,
    ) -> DimmingView:
        """The dimming that darkens the zenith or a region to a target with the least flux.

        Parameters
        ----------
        x, y, crs, height
            The observer, as :meth:`panorama`.
        target_zenith
            Zenith sky brightness to reach [mag arcsec-2].
        region, target_region
            A sky region (as :meth:`influence`) and the brightness of its solid-angle mean
            luminance to reach [mag arcsec-2].
        max_dimming
            Largest fraction of any cell's flux removed [1].

        Returns
        -------
        DimmingView
            The plan; :class:`~nightlights.inverse.InfeasibleTargetError` when the target
            cannot be reached.
        """
        start = time.perf_counter()
        if (target_zenith is None) == (target_region is None):
            raise InputError("give one target: a zenith brightness or a region's brightness")
        if target_zenith is not None:
            influence = self.influence(x, y, kind="q", metric="zenith", crs=crs, height=height)
            target = float(target_zenith)
            params: dict[str, Any] = {"target": "zenith"}
        else:
            influence = self.influence(x, y, kind="s", region=region, crs=crs, height=height)
            target = float(target_region)  # type: ignore[arg-type]
            params = {"target": "region", "region": _region(region).text}
        if not math.isfinite(target):
            raise InputError(f"target brightness {target}; expected a finite mag arcsec-2")
        cells = self._state("current")
        plan = least_flux_dimming(
            np.maximum(influence.values, 0.0),
            cells.total,
            [influence.panorama_value],
            [float(magnitude_to_luminance(target))],
            max_dimming=max_dimming,
        )
        params.update({"brightness": target, "max_dimming": max_dimming})
        return self._dimmed(x, y, crs, height, plan.fraction, plan.method, params, start)

    def _dimmed(
        self,
        x: float,
        y: float,
        crs: str | None,
        height: float | None,
        fraction: FloatArray,
        method: str,
        params: dict[str, Any],
        start: float,
    ) -> DimmingView:
        cells = self._state("current")
        xy, eye = self._observer(x, y, crs, height, cells)
        before = self._view(xy, eye, self._luminance(cells, xy, eye, None), 0.0, "current")
        after = self._luminance(cells, xy, eye, 1.0 - fraction)
        removed = float(np.sum(cells.total * fraction))
        total = float(cells.total.sum())
        seconds = time.perf_counter() - start
        return DimmingView(
            cells=fraction,
            rows=cells.rows,
            cols=cells.cols,
            shape=self.shape,
            panorama=self._view(xy, eye, after, seconds, "dimmed", fraction),
            before=before,
            flux_removed=removed,
            flux_removed_percent=100.0 * removed / total if total > 0 else 0.0,
            method=method,
            seconds=seconds,
            params=params,
        )

    # --- roads ------------------------------------------------------------------------------

    @property
    def has_streets(self) -> bool:
        """Whether a street layer is rated (``streets`` given)."""
        return self._roads is not None

    def light_levels(self) -> FloatArray:
        """Level of every light of the road model at the current emission [1]
        (:mod:`nightlights.explore._roads`); InputError without ``streets``."""
        if self._roads is None:
            raise no_streets()
        return self._roads.levels(self.emission("current"), self._edits.extra)

    def roads(self) -> RoadView:
        """The street segments rated against their classes at the current emission.

        Returns
        -------
        RoadView
            Status, binding criterion and margin per segment, the share of length compliant
            (:meth:`nightlights.roads.RoadModel.rate` at :meth:`light_levels`).
        """
        if self._roads is None:
            raise no_streets()
        return self._roads.view(self.light_levels())

    def road_plan(
        self,
        x: float | None = None,
        y: float | None = None,
        *,
        target_zenith: float | None = None,
        region: SkyRegion | Sequence[Sequence[float]] | str | None = None,
        target_region: float | None = None,
        objective: str = "energy",
        min_dimming: float = 0.0,
        hours: float = math.nan,
        apply: bool = True,
        crs: str | None = None,
        height: float | None = None,
    ) -> RoadPlanView:
        """The least-energy per-light dimming that meets a sky target and keeps every road lit.

        :func:`nightlights.roads.road_plan` with the target of :meth:`least_dimming` as a
        per-light matrix (:mod:`nightlights.explore._roads`); a feasible plan is applied to
        the emission as one edit (undo takes it back).

        Parameters
        ----------
        x, y, crs, height
            The observer of the target, as :meth:`panorama` (not needed without a target).
        target_zenith, region, target_region
            The sky target, as :meth:`least_dimming`; neither: the road minima alone.
        objective
            ``energy`` (the lights' power) or ``flux``.
        min_dimming
            Lowest level any light may take [1].
        hours
            Hours a year the plan runs [h], for the energy saved (NaN: not given).
        apply
            Apply a feasible plan to the session.

        Returns
        -------
        RoadPlanView
            The plan, the sky and the compliance before and after (recomputed), the energy
            saved, the cost of safety; the binding segments when no plan meets both.
        """
        from nightlights.inverse import InfeasibleTargetError
        from nightlights.roads import road_plan

        if self._roads is None:
            raise no_streets()
        roads = self._roads
        before = roads.view(self.light_levels())
        sky, target, goal, sky_before = None, "roads only", math.nan, math.nan
        options: dict[str, Any] = {}
        if target_zenith is not None and target_region is not None:
            raise InputError("give one target: a zenith brightness or a region's brightness")
        if target_zenith is not None or target_region is not None:
            if x is None or y is None:
                raise InputError("x, y: missing; a sky target needs its observer")
            brightness = float(target_zenith if target_zenith is not None else target_region)  # type: ignore[arg-type]
            if not math.isfinite(brightness):
                raise InputError(f"target brightness {brightness}; expected a finite mag arcsec-2")
            if target_zenith is not None:
                options = {"kind": "q", "metric": "zenith"}
                target = "zenith"
            else:
                options = {"kind": "s", "region": region}
                target = f"region {_region(region).text}"
            options.update(crs=crs, height=height)
            now = self.influence(x, y, **options)
            original = self.influence(x, y, which="original", **options)
            sky_before = now.panorama_value
            goal = float(magnitude_to_luminance(brightness))
            xy = self.to_xy(x, y, crs)
            target = f"{target} at ({xy[0]:.1f}, {xy[1]:.1f})"
            sky = roads.sky_matrix(original.grid, now.grid, sky_before, goal, target)
            best = float(sky.fixed[0] + min_dimming * sky.contribution.sum())
            if best > goal:
                raise InfeasibleTargetError(
                    f"{target}: {goal:.4g} cd m-2 is out of reach of the street lights; at "
                    f"min_dimming={min_dimming:g} the sky keeps {best:.4g} cd m-2",
                    label=target,
                    target=goal,
                    best=best,
                )
        if not (math.isnan(hours) or 0.0 <= hours <= 8784.0):
            raise InputError(f"hours={hours!r}; expected the hours of a year, 0 to 8784 [h]")
        plan = road_plan(
            roads.model, sky, objective=objective, min_dimming=min_dimming, hours=hours
        )
        applied = bool(apply and plan.feasible)
        sky_after = math.nan
        if applied:
            self.apply_dimming(plan.dimming, target=target, objective=objective)
            if sky is not None:
                assert x is not None and y is not None
                sky_after = self.influence(x, y, **options).panorama_value
            after = roads.view(self.light_levels())
        else:
            after = roads.view(plan.dimming)
        return RoadPlanView(plan, applied, sky_before, sky_after, goal, target, before, after)

    def apply_dimming(
        self, dimming: Sequence[float] | FloatArray, *, target: str = "", objective: str = ""
    ) -> EditView:
        """Set every light of the road model to a level, as one undoable edit
        (:mod:`nightlights.explore._roads`: each cell holding lights takes its original flux
        times the lights' emission-weighted mean level).

        Parameters
        ----------
        dimming
            Level of every light of the road model [1], in [0, 1].
        target, objective
            What the levels meet, for the session file.

        Returns
        -------
        EditView
            The emission's state after the step.
        """
        if self._roads is None:
            raise no_streets()
        roads = self._roads
        levels = np.asarray(dimming, dtype=float)
        if levels.shape != (roads.n_lights,) or not np.all((levels >= 0) & (levels <= 1)):
            raise InputError(
                f"dimming of shape {levels.shape}; expected {roads.n_lights} levels in [0, 1], "
                "one per light of the street layer's lights"
            )
        rows, cols, values = roads.cell_values(levels, self._original)
        state = roads.after_plan(levels, rows, cols, values)
        op = {"op": PLAN_OP, "dimming": levels.tolist(), "target": target, "objective": objective}
        self._edits.set_cells(rows, cols, values, op, extra=state)
        return self._changed(rows.size)

    # --- edits ------------------------------------------------------------------------------

    def edit(
        self,
        op: str,
        points: Sequence[Sequence[float]],
        *,
        radius: float,
        value: float | None = None,
    ) -> EditView:
        """Paint, erase or scale the emission along a brush stroke (Dobashi's add and delete).

        Cells whose centres lie within ``radius`` of the stroke (its points joined by
        segments) change; a step that changes no cell is not recorded.

        Parameters
        ----------
        op
            ``paint``: the cells' flux density becomes ``value`` [lm m-2], split between the
            bands as in the whole original raster; ``erase``: 0; ``scale``: multiplied by
            ``value`` [1].
        points
            The stroke, (x, y) in the raster CRS [m], at least one point.
        radius
            Brush radius [m], > 0.
        value
            Flux density for ``paint`` [lm m-2] or factor for ``scale`` [1], finite, >= 0.

        Returns
        -------
        EditView
            The emission's state after the step.

        Raises
        ------
        InputError
            A bad stroke, or a result that is not finite or above
            :data:`~nightlights._validate.MAX_FLUX_DENSITY`, or a lit cell without a terrain
            height (with a DEM): the emission and the history stay as they were.
        """
        check = self._check_terrain if self._dem is not None else None
        changed = self._edits.apply(op, points, radius=radius, value=value, check=check)
        return self._changed(changed) if changed else self._edit_view(0)

    def _check_terrain(self, window: tuple[slice, slice], after: FloatArray) -> None:
        """Refuse an edit that lights a cell without a terrain height (outside the DEM or on
        nodata), as every stage with a DEM refuses such a lit cell."""
        assert self._dem is not None and self.scene.dem is not None
        rows, cols = np.nonzero(lit_mask(after))
        t = self.transform
        x = t.c + t.a * (cols + window[1].start + 0.5)
        y = t.f + t.e * (rows + window[0].start + 0.5)
        terrain_under(self._dem, x, y, label=source_label(self.scene.dem, "DEM"))

    def undo(self) -> EditView:
        """Undo the last edit.

        Returns
        -------
        EditView
            The state after undoing; InputError when there is nothing to undo.
        """
        return self._changed(self._edits.undo())

    def redo(self) -> EditView:
        """Redo the last undone edit.

        Returns
        -------
        EditView
            The state after redoing; InputError when there is nothing to redo.
        """
        return self._changed(self._edits.redo())

    def _changed(self, changed: int) -> EditView:
        self.edit_version += 1
        self._cells.pop("current", None)
        return self._edit_view(changed)

    def _edit_view(self, changed: int) -> EditView:
        return EditView(
            edit_version=self.edit_version,
            changed_cells=changed,
            n_lit=self.n_lit,
            total_flux=self.total_flux,
            can_undo=self.can_undo,
            can_redo=self.can_redo,
        )

    # --- exports ----------------------------------------------------------------------------

    def current_raster(self) -> Raster:
        """The edited emission as a raster on the original grid [lm m-2]."""
        tags = dict(self._raster.tags)
        tags["explore_edits"] = str(len(self._edits.ops))
        tags[PRODUCT_TAG] = "emission"
        return Raster(
            self._data.copy(),
            self.transform,
            self.crs,
            self._raster.descriptions,
            self._raster.units,
            tags,
            self._raster.band_tags,
        )

    def export_emission(self, path: PathLike, *, overwrite: bool = False) -> Path:
        """Write the edited emission as a COG (atomically).

        Parameters
        ----------
        path
            Output ``.tif``.
        overwrite
            Replace an existing file.

        Returns
        -------
        Path
            The written file.
        """
        self._refuse(path, overwrite)
        return self.current_raster().write(path)

    def export_dimming(self, path: PathLike, view: DimmingView, *, overwrite: bool = False) -> Path:
        """Write a dimming plan as a one-band COG of the dimming fraction [1] (atomically).

        Parameters
        ----------
        path
            Output ``.tif``.
        view
            The dimming (:meth:`dim` or :meth:`least_dimming`).
        overwrite
            Replace an existing file.

        Returns
        -------
        Path
            The written file.
        """
        self._refuse(path, overwrite)
        tags = {
            PRODUCT_TAG: "dimming",
            "observer_x": repr(view.panorama.x),
            "observer_y": repr(view.panorama.y),
            "flux_removed_lm": repr(view.flux_removed),
            "flux_removed_percent": repr(view.flux_removed_percent),
            "method": view.method,
            "params": dumps_json(view.params),
            "reference": "Dobashi et al. 2023, ACM TOG 42(6) 219, Sec. 4.1, Eq. 12",
        }
        raster = Raster(view.fraction[None], self.transform, self.crs, ("dimming",), ("1",), tags)
        return raster.write(path)

    def export_panorama(
        self,
        view: PanoramaView,
        *,
        nc: PathLike | None = None,
        png: PathLike | None = None,
        projection: str = "equirectangular",
        overwrite: bool = False,
    ) -> list[Path]:
        """Write a panorama as ``nightlights skyglow`` does: NetCDF and/or PNG, together.

        The panorama is recomputed by :func:`~nightlights.sky.skyglow` on the emission the
        view was made from (original, edited or dimmed), so the files are the stage's own.

        Parameters
        ----------
        view
            A panorama of this session.
        nc, png
            Output paths (at least one).
        projection
            ``equirectangular`` or ``fisheye`` for the PNG.
        overwrite
            Replace existing files.

        Returns
        -------
        list of Path
            The written files.
        """
        from nightlights.sky.stage import skyglow

        if nc is None and png is None:
            raise InputError("give a NetCDF or a PNG path for the panorama")
        for path in (nc, png):
            if path is not None:
                self._refuse(path, overwrite)
        data = self._original if view.source == "original" else self._data.copy()
        if view.source == "dimmed" and view.dimming is not None:
            cells = self._state("current")
            data[:, cells.rows, cells.cols] *= 1.0 - view.dimming[None, :]
        raster = Raster(data, self.transform, self.crs, self._raster.descriptions,
                        self._raster.units)  # fmt: skip
        height = view.observer_altitude - self._ground(view.x, view.y)
        result = skyglow(
            Scene(raster, dem=self._dem, kernel=self._table),
            Observer(view.x, view.y, height=height),
            nc,
            png=png,
            projection=projection,
            progress=False,
        )
        del result
        return [Path(p) for p in (nc, png) if p is not None]

    def save(
        self,
        path: PathLike,
        *,
        overwrite: bool = False,
        observer: tuple[float, float] | None = None,
    ) -> Path:
        """Write the session file (JSON): the inputs, the edits and the observer.

        Parameters
        ----------
        path
            Output ``.json``.
        overwrite
            Replace an existing file.
        observer
            The observer to reopen at, in the raster CRS [m].

        Returns
        -------
        Path
            The written file; :meth:`open` reopens it.
        """
        from nightlights.io import atomic_output

        target = Path(path)
        self._refuse(target, overwrite)
        if self._in_memory:
            raise InputError(
                f"a session of an in-memory {', '.join(self._in_memory)} cannot be saved: "
                "open it from files"
            )
        if self._road_options != RoadOptions():
            raise InputError(
                "a session with road_options cannot be saved yet: the file keeps the streets "
                "and reopens them with the defaults"
            )
        folder = target.resolve().parent

        def relative(value: Path | None) -> str | None:
            if value is None:
                return None
            try:
                return str(value.resolve().relative_to(folder))
            except ValueError:
                return str(value.resolve())

        content = {
            "format": "nightlights-explore",
            "version": SESSION_VERSION,
            "emission": relative(self._sources["emission"]),
            "emission_sha256": self._sources["emission_sha256"],
            "kernel": relative(self._sources["kernel"]),
            "dem": relative(self._sources["dem"]),
            "lights": relative(self._sources["lights"]),
            "streets": relative(self._sources["streets"]),
            "turbidity": self._sources["turbidity"],
            "observer_height": self._observer_height,
            "observer": list(observer) if observer is not None else None,
            "edits": self._edits.ops,
        }
        with atomic_output(target) as tmp:
            Path(tmp).write_text(dumps_json(content, indent=1))
        return target

    def _refuse(self, path: PathLike, overwrite: bool) -> None:
        """Refuse a file the session was opened from (whatever ``overwrite``), then an
        existing file without ``overwrite``."""
        names = ("emission", "kernel", "dem", "lights", "streets")
        inputs = {name: self._sources[name] for name in names}
        refuse_replacing_inputs([path], inputs)
        _refuse_existing(path, overwrite)

    # --- state ------------------------------------------------------------------------------

    def _state(self, which: str) -> _Cells:
        cached = self._cells.get(which)
        if cached is not None and (which == "original" or cached[0] == self.edit_version):
            return cached[1]
        data = self._data if which == "current" else self._original
        rows, cols = np.nonzero(lit_mask(data))
        values = data[:, rows, cols]
        area = self.cell_size**2
        flux = np.nan_to_num(values, nan=0.0) * area
        heights = np.zeros(rows.size)
        if self._dem is not None and rows.size:
            lit = LitCells(rows, cols, values, self.transform, self.crs, self.shape)
            heights = scene_terrain(self._dem, lit, _centre(self._raster), 0.0).heights
        levels = self._levels.levels
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the shift was reported when the session opened
            offset = level_offset(heights, None, levels) if rows.size else 0.0
        cells = _Cells(
            rows=rows,
            cols=cols,
            values=values,
            flux=flux,
            heights=heights - offset,
            level_weights=source_level_weights(heights - offset, levels),
            offset=offset,
        )
        self._cells[which] = (self.edit_version, cells)
        return cells

    def _observer(
        self,
        x: float,
        y: float,
        crs: str | None,
        height: float | None,
        cells: _Cells,
    ) -> tuple[tuple[float, float], float]:
        """The observer in the raster CRS and its eye altitude above sea level [m]."""
        xy = self.to_xy(x, y, crs)
        h = self._observer_height if height is None else float(height)
        if not (math.isfinite(h) and h >= 0):
            raise InputError(f"observer height {h} m; expected a finite value >= 0")
        if cells.rows.size:
            lit = LitCells(cells.rows, cells.cols, cells.values, self.transform, self.crs,
                           self.shape)  # fmt: skip
            _check_reach(lit, xy, float(self._edges[-1]), self.label, (x, y), crs)
        return xy, self._ground(*xy) + h

    def _ground(self, x: float, y: float) -> float:
        if self._dem is None:
            return 0.0
        return float(ground_height(self._dem.data[0], self._dem.transform, x, y))

    def _slices_at(self, altitude: float) -> list[KernelSlice]:
        key = float(altitude)
        if key not in self._slices:
            slices = [band_slice(s, self._functions) for s in self._levels.at(key)]
            self._remember(self._slices, key, slices)
        return self._slices[key]

    def _below_terrain(self, xy: tuple[float, float], eye: float) -> np.ndarray | None:
        if self._dem is None:
            return None
        key = (xy[0], xy[1], eye)
        if key not in self._horizons:
            horizon = horizon_elevation(
                self._dem.data[0], self._dem.transform, xy, eye_altitude=eye, n_az=self._n_az
            )
            self._remember(self._horizons, key, horizon)
        return self.elevation[:, None] < self._horizons[key][None, :]

    @staticmethod
    def _remember(cache: OrderedDict[Any, Any], key: Any, value: Any) -> None:
        cache[key] = value
        cache.move_to_end(key)
        while len(cache) > _CACHE_SIZE:
            cache.popitem(last=False)


# --- helpers ----------------------------------------------------------------------------------


def session_memory(shape: tuple[int, int], bands: int, dem_cells: int = 0) -> float:
    """Estimated memory an explore session holds for a raster [B]: per cell
    :data:`BYTES_PER_CELL_BAND` per band and :data:`BYTES_PER_CELL`, the DEM, the influence
    maps it keeps (up to 16 grids, at most :data:`_INFLUENCE_BYTES`) and its undo history
    (up to a before and after copy of every cell, at most ``_HISTORY_BYTES``).

    Parameters
    ----------
    shape
        Raster (rows, cols) [cells].
    bands
        Emission bands [1].
    dem_cells
        Cells of the DEM, read whole [1].

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> round(session_memory((1000, 1000), 1) / 2**20)
    175
    """
    cells = float(shape[0]) * float(shape[1])
    influence = min(_CACHE_SIZE * 8.0 * cells, float(_INFLUENCE_BYTES))
    history = min(16.0 * bands * cells, float(_HISTORY_BYTES))
    per_cell = BYTES_PER_CELL_BAND * bands + BYTES_PER_CELL
    return cells * per_cell + 8.0 * dem_cells + influence + history


def _check_memory(emission: Any, dem: Any, label: str) -> None:
    """Refuse a session whose estimate (:func:`session_memory`) exceeds the limit, from the
    rasters' headers, before either is read or a kernel is built."""
    header = raster_header(emission)
    if header is None:
        return  # the reader names what is wrong with it
    dem_header = raster_header(dem) if dem is not None else None
    dem_cells = 0 if dem_header is None else dem_header.rows * dem_header.cols
    check_memory(
        session_memory((header.rows, header.cols), header.count, dem_cells),
        f"an explore session of the {header.rows} x {header.cols} cells of {label}",
        option="coarsen or crop the emission raster",
    )


def _which(which: str) -> str:
    if which not in ("current", "original"):
        raise InputError(f"which {which!r}; expected current or original")
    return which


def _centre(raster: Raster) -> tuple[float, float]:
    left, bottom, right, top = raster.bounds
    return 0.5 * (left + right), 0.5 * (bottom + top)


def _region(region: SkyRegion | Sequence[Sequence[float]] | str | None) -> SkyRegion:
    if region is None:
        raise InputError("S needs a sky region: a closed polygon of (azimuth, elevation) pairs")
    if isinstance(region, SkyRegion):
        return region
    if isinstance(region, str):
        return SkyRegion.parse(region)
    vertices = np.asarray(region, dtype=float)
    if vertices.ndim != 2 or vertices.shape[1] != 2 or vertices.shape[0] < 3:
        raise InputError("a sky region needs at least 3 (azimuth, elevation) vertices")
    if not np.isfinite(vertices).all():
        raise InputError("sky region vertices must be finite numbers")
    if not np.array_equal(vertices[0], vertices[-1]):
        vertices = np.vstack([vertices, vertices[:1]])  # the page sends the ring unclosed
    text = " ".join(f"{az!r},{el!r}" for az, el in vertices.tolist())
    return SkyRegion.parse(text)


def _region_key(region: SkyRegion | None) -> str:
    return "" if region is None else region.text


def _path_or_none(source: Any) -> Path | None:
    if isinstance(source, str | Path):
        return Path(source).resolve()
    return None


def _file_hash(source: Any) -> str | None:
    path = _path_or_none(source)
    if path is None or not path.is_file():
        return None
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(2**20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _refuse_existing(path: PathLike, overwrite: bool) -> None:
    if not overwrite and Path(path).exists():
        raise OutputExistsError(f"{path}: exists; give overwrite to replace it")


def _read_lights(path: PathLike, crs: CRS | None) -> Any:
    """The luminaire layer as points in the raster CRS (polygons by their centroids)."""
    from nightlights.io import read_vector

    layer = read_vector(path)
    if layer.crs is None:
        raise InputError(f"{path}: the lights layer has no CRS")
    layer = layer.to_crs(crs)
    if not layer.geom_type.isin(["Point"]).all():
        layer = layer.set_geometry(layer.geometry.representative_point())
    if len(layer) > MAX_LIGHTS:
        warnings.warn(
            f"{path}: {len(layer)} lights; the map shows the first {MAX_LIGHTS}", stacklevel=3
        )
        layer = layer.iloc[:MAX_LIGHTS]
    return layer


def _flat_session(emission: Any, height: float, flat: dict[str, Any]) -> tuple[Scene, float]:
    """The scene and eye height of the former flat call ``ExploreSession(emission, kernel=,
    dem=, observer_height=, turbidity=, cache_dir=)``, with a DeprecationWarning."""
    unknown = sorted(set(flat) - {*SCENE_KEYWORDS, "observer_height"})
    if unknown:
        raise TypeError(f"ExploreSession() got unexpected keyword arguments {unknown}")
    warnings.warn(
        "ExploreSession(emission, kernel=, dem=, observer_height=, ...) with flat keywords is "
        "deprecated and goes in the next release: call ExploreSession(nightlights.Scene("
        "emission, ...), height=...)",
        DeprecationWarning,
        stacklevel=3,
    )
    height = flat.pop("observer_height", height)
    return Scene(emission, **flat), height
