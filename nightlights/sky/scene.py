"""What a sky computation is about: :class:`Scene`, the emission seen through one atmosphere.

A scene holds the upward emission (a raster of flux density, a path or its lit cells), the
terrain it stands on (a DEM, optional), the atmosphere (Preetham's turbidity) and either a
precomputed kernel or the grid of the scene kernel to build (panorama rows and columns,
distance bins), with the folder that caches built kernels. Every sky stage takes one
(``skyglow(scene, observer)``, the inverse maps, the dimming rule and plan, the darkness map,
the many-observer summary, the explore session), as pvlib's stages take a ``Location``.

The scene finds its kernel in exactly one place, :meth:`Scene.find_kernel`: a given kernel is
loaded once and checked against the scene's grid and turbidity; otherwise a kernel is sized to
the scene (:func:`~nightlights.sky.spec.scene_kernel_spec`: distances to the farthest lit
corner, the observers' and sources' altitude levels, the shape tables the bands' emission
functions need) and built or reused from the cache.

A product computed from a scene (the Q, S and dimming rasters) records it in its tags
(:meth:`Scene.record`), and the stages that read such a product back rebuild the same scene
from them (:meth:`Scene.recorded`), so the figures they add are computed in the same atmosphere
on the same grid.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import xarray as xr

from nightlights._typing import FloatArray, PathLike
from nightlights.emission_functions import EMISSION_MODELS, EmissionFunction, emission_shape_names
from nightlights.errors import DataQualityWarning, InputError
from nightlights.io import Raster, source_label
from nightlights.io.raster import LitCells
from nightlights.sky.clouds import CloudLayer
from nightlights.sky.kernel import TABULATED_PREFIX
from nightlights.sky.obstacles import ObstacleInput, obstructed_emission
from nightlights.sky.spec import KernelSpec, scene_kernel_spec
from nightlights.sky.store import KernelResult, get_or_build_kernel, load_kernel

__all__ = [
    "DEFAULT_GRID",
    "DEFAULT_TURBIDITY",
    "EmissionInput",
    "KernelInput",
    "KernelTables",
    "RasterInput",
    "Scene",
    "check_kernel_grid",
    "kernel_tables",
]

#: What a stage accepts as a raster input (an emission may also be given as its lit cells).
RasterInput = Raster | xr.DataArray | PathLike
EmissionInput = Raster | xr.DataArray | PathLike | LitCells


class KernelTables(TypedDict):
    """Which shape tables a scene kernel tabulates (arguments of ``scene_kernel_spec``)."""

    uplight: bool
    garstang_lobe: bool
    tabulated_emission: str | None
    emission_shapes: tuple[str, ...]


def kernel_tables(functions: Sequence[EmissionFunction], label: str) -> KernelTables:
    """The :func:`~nightlights.sky.spec.scene_kernel_spec` arguments that tabulate the
    shapes the bands' emission functions need.

    Parameters
    ----------
    functions
        One emission function per band (:func:`~nightlights.sky.setup.band_emission_functions`).
    label
        How the emission is named in messages.

    Returns
    -------
    dict
        ``uplight``, ``garstang_lobe``, ``tabulated_emission`` (the one tabulated function,
        or None; a kernel holds one, more are refused) and ``emission_shapes`` (the other
        registered shapes, in registration order).
    """
    shapes = {shape for function in functions for shape in function.shapes}
    return KernelTables(
        uplight="uplight" in shapes,
        garstang_lobe="garstang_lobe" in shapes,
        tabulated_emission=_tabulated(shapes, label),
        emission_shapes=tuple(
            name
            for name in emission_shape_names()
            if name in shapes and name not in EMISSION_MODELS
        ),
    )


def _tabulated(shapes: set[str], label: str) -> str | None:
    """The one tabulated function of the bands, None without; a scene kernel holds one."""
    tabulated = sorted(shape for shape in shapes if shape.startswith(TABULATED_PREFIX))
    if len(tabulated) > 1:
        raise InputError(
            f"{label}: {len(tabulated)} different tabulated emission functions; a kernel "
            "tabulates one (give them one table, or compute the bands separately)"
        )
    return tabulated[0] if tabulated else None


def check_kernel_grid(table: xr.Dataset, **given: int | None) -> None:
    """Refuse grid options (``n_elevation``, ``n_azimuth``, ``n_distance``) that differ from
    a given kernel's: the kernel fixes the grid, so they cannot be honoured.

    Parameters
    ----------
    table
        The kernel dataset.
    **given
        Each option's value, None when not given [1].
    """
    n_frequency = int(table.sizes.get("frequency", 0))
    actual = {
        "n_elevation": int(table.sizes["elevation"]),
        "n_azimuth": int(table.sizes.get("azimuth", 2 * (n_frequency - 1))),
        "n_distance": int(table.sizes["distance"]),
    }
    for name, value in given.items():
        if value is not None and int(value) != actual[name]:
            raise InputError(
                f"{name}={value}: the kernel fixes the grid ({actual[name]}); omit "
                f"{name}= with kernel=, or build a kernel with it"
            )


#: What a scene's kernel may be: a built kernel, its dataset or its NetCDF file.
KernelInput = KernelResult | xr.Dataset | PathLike
#: Turbidity of a scene kernel when none is given (Preetham 1999: a clear sky) [1].
DEFAULT_TURBIDITY = 2.0
#: Grid of a scene kernel when none is given: panorama rows, columns, distance bins [1]
#: (the grid every sky stage has always defaulted to).
DEFAULT_GRID = {"n_elevation": 64, "n_azimuth": 256, "n_distance": 64}

#: Tags a product writes to record its scene (:meth:`Scene.record`).
_RECORD_TAGS = ("turbidity", "n_elevation", "n_azimuth", "n_distance", "kernel_hash")


@dataclass(frozen=True, eq=False)
class Scene:
    """An emission raster, its terrain and atmosphere, and the kernel (or its grid).

    Parameters
    ----------
    emission
        Upward flux density [lm m-2] in a projected CRS: a :class:`~nightlights.io.Raster`, a
        DataArray, a path or its :class:`~nightlights.io.raster.LitCells`; one or two bands,
        each with the emission function of its ``emission_function`` tag (untagged: one band
        Garstang's F = G = 0.15, two bands Lambertian + direct uplight).
    dem
        Terrain heights above sea level [m] in the emission's CRS (Raster, DataArray or path):
        observers stand on it, every lit cell emits from its own height, and it hides the sky
        below its horizon. None: flat ground at 0 m.
    turbidity
        Atmospheric turbidity (Preetham 1999) [1]; None: :data:`DEFAULT_TURBIDITY` for a scene
        kernel, the kernel's own with ``kernel``.
    kernel
        A precomputed kernel (:class:`~nightlights.sky.store.KernelResult`, dataset or NetCDF
        path); None: a scene kernel, built for each stage's reach or reused from the cache.
    n_elevation, n_azimuth, n_distance
        Panorama rows and columns and distance bins of a scene kernel (None:
        :data:`DEFAULT_GRID`); with ``kernel`` None or equal to the kernel's own [1].
    cache_dir
        Folder of the kernel cache (None: the default cache folder).
    obstacles
        Obstacles around the lit ground (:mod:`nightlights.sky.obstacles`): uniform
        :class:`~nightlights.ground.obstacles.ObstacleProperties` or a three-band raster
        (height [m], spacing [m], filling factor [1]) on the emission's grid, as written by
        :func:`~nightlights.ground.footprints.obstacle_rasters`. Every sky stage then sees the
        obstructed emission (:func:`~nightlights.sky.obstacles.obstructed_emission`) as
        ``emission``. None (default), or no cell with obstacles: the emission as given.
    clouds
        A cloud deck (:class:`~nightlights.sky.clouds.CloudLayer`); None: a clear sky.
        ``skyglow`` mixes the cloudy panorama of :mod:`nightlights.sky.cloudy` in by the cover
        and dims the natural sky it reports; the other sky stages do not read it yet.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    >>> scene = Scene(raster, kernel=build_kernel(spec, progress=False))
    >>> sky = skyglow(scene, Observer(1000.0, 1000.0, height=0.0))
    >>> sky.panorama["luminance"].shape, 1 <= sky.bortle <= 9
    ((8, 16), True)
    """

    emission: EmissionInput
    dem: RasterInput | None = None
    turbidity: float | None = None
    kernel: KernelInput | None = None
    n_elevation: int | None = None
    n_azimuth: int | None = None
    n_distance: int | None = None
    cache_dir: PathLike | None = None
    obstacles: ObstacleInput | None = None
    clouds: CloudLayer | None = None
    _loaded: dict[str, xr.Dataset] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _given: EmissionInput | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.emission is None:
            raise InputError("emission=None; expected an emission raster (Raster, DataArray, path)")
        if self.clouds is not None and not isinstance(self.clouds, CloudLayer):
            raise InputError(f"clouds={self.clouds!r}; expected a CloudLayer or None")
        if self.turbidity is not None:
            try:
                turbidity = float(self.turbidity)
            except (TypeError, ValueError):
                raise InputError(f"turbidity={self.turbidity!r}; expected a number") from None
            if not (np.isfinite(turbidity) and turbidity > 0):
                raise InputError(f"turbidity={turbidity!r}; expected a finite number > 0")
            object.__setattr__(self, "turbidity", turbidity)
        for name in DEFAULT_GRID:
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise InputError(f"{name}={value!r}; expected an integer >= 1")
            object.__setattr__(self, name, int(value))
        if self.obstacles is not None:
            self._obstruct()

    def _obstruct(self) -> None:
        """Put the obstructed emission in place of the given one (kept as ``_given``)."""
        given, obstacles = self.emission, self.obstacles
        assert obstacles is not None  # called with obstacles
        label = self.label
        if isinstance(given, LitCells):
            raise InputError(
                "obstacles need the emission raster on its grid, not its lit cells; give the "
                "scene a Raster, DataArray or path"
            )
        obstructed = obstructed_emission(given, obstacles, label=label)
        object.__setattr__(self, "_given", given)
        if obstructed is not None:
            object.__setattr__(self, "emission", obstructed)

    @property
    def label(self) -> str:
        """How messages name the emission."""
        emission = self.emission if self._given is None else self._given
        if isinstance(emission, LitCells):
            return "in-memory emission raster"
        return source_label(emission, "emission raster")

    def clear_sky(self, stage: str) -> None:
        """Refuse a cloud deck in a stage that models only a clear sky.

        Raises
        ------
        InputError
            The scene has ``clouds`` and ``stage`` does not read them.
        """
        if self.clouds is not None:
            raise InputError(
                f"clouds={self.clouds!r}: {stage} models a clear sky only (skyglow reads a "
                "cloud deck); give the scene clouds=None"
            )

    def raster_input(self, stage: str) -> RasterInput:
        """The emission as a raster input (a stage that needs the whole grid cannot take the
        lit cells alone).

        Raises
        ------
        InputError
            The emission was given as its lit cells.
        """
        if isinstance(self.emission, LitCells):
            raise InputError(
                f"{stage} needs the emission raster on its grid, not its lit cells; give the "
                "scene a Raster, DataArray or path"
            )
        return self.emission

    @property
    def inputs(self) -> dict[str, Any]:
        """The scene's inputs by parameter (``emission``, ``dem``, ``kernel``): the stages
        refuse an output that would replace one of those given as files
        (:func:`~nightlights.io.outputs.refuse_replacing_inputs`)."""
        emission = self.emission if self._given is None else self._given
        inputs = {"emission": emission, "dem": self.dem, "kernel": self.kernel}
        return inputs if self.obstacles is None else {**inputs, "obstacles": self.obstacles}

    @property
    def grid(self) -> dict[str, int | None]:
        """The grid options as given (None where the default or the kernel's applies)."""
        return {name: getattr(self, name) for name in DEFAULT_GRID}

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (``turbidity=3.0``, ``dem="dem.tif"``); a loaded
        kernel is shared while ``kernel`` stays."""
        if self._given is not None and "emission" not in changes:
            changes = {**changes, "emission": self._given}
        scene = dataclasses.replace(self, **changes)
        if "kernel" not in changes:
            scene._loaded.update(self._loaded)
        return scene

    # --- the kernel: found in one place ------------------------------------------------------

    def kernel_dataset(self) -> xr.Dataset | None:
        """The given kernel's dataset, loaded once (None for a scene kernel)."""
        if self.kernel is None:
            return None
        if "kernel" not in self._loaded:
            self._loaded["kernel"] = load_kernel(self.kernel)
        return self._loaded["kernel"]

    def find_kernel(
        self,
        extent: Raster | LitCells,
        xy: tuple[float, float],
        *,
        observer_altitudes: Sequence[float],
        source_altitudes: FloatArray | Sequence[float],
        functions: Sequence[EmissionFunction],
        progress: bool = True,
    ) -> tuple[xr.Dataset, KernelSpec | None]:
        """The scene's kernel for a reach and altitudes: the given one, checked, or a scene
        kernel built (or reused from the cache) for them.

        Parameters
        ----------
        extent
            The emission raster or its lit cells: with ``xy``, the farthest corner sets the
            scene kernel's range.
        xy
            The point the range is measured from, in the emission's CRS [m].
        observer_altitudes
            Eye altitudes to tabulate, lowest first (one, or the lowest and highest) [m].
        source_altitudes
            Source-altitude levels [m].
        functions
            The bands' emission functions: the shape tables the kernel needs.
        progress
            Progress bar while building.

        Returns
        -------
        table : xarray.Dataset
            The kernel.
        spec : KernelSpec or None
            The scene kernel's specification (None for a given kernel).

        Raises
        ------
        InputError
            Grid options or a turbidity that differ from a given kernel's.
        """
        table = self.kernel_dataset()
        if table is not None:
            check_kernel_grid(table, **self.grid)
            given = float(table.attrs.get("turbidity", np.nan))
            if self.turbidity is not None and not np.isclose(self.turbidity, given):
                raise InputError(
                    f"turbidity {self.turbidity} differs from the kernel's ({given}); omit "
                    "turbidity= or build a kernel for it"
                )
            return table, None
        grid = {name: value or DEFAULT_GRID[name] for name, value in self.grid.items()}
        spec = scene_kernel_spec(
            extent,
            xy,
            observer_altitude=observer_altitudes[0],
            source_altitudes=source_altitudes,
            turbidity=DEFAULT_TURBIDITY if self.turbidity is None else self.turbidity,
            n_elevation=grid["n_elevation"],
            n_azimuth=grid["n_azimuth"],
            n_distance=grid["n_distance"],
            **kernel_tables(functions, self.label),
        )
        if len(observer_altitudes) > 1:
            spec = dataclasses.replace(spec, observer_altitudes=tuple(observer_altitudes))
        return get_or_build_kernel(spec, cache_dir=self.cache_dir, progress=progress).kernel, spec

    # --- recorded in products, rebuilt from them -------------------------------------------

    def record(self, table: xr.Dataset) -> dict[str, str]:
        """Tags that let a stage rebuild this scene from a product computed with ``table``.

        Parameters
        ----------
        table
            The kernel the product was computed with.

        Returns
        -------
        dict
            ``turbidity``, ``n_elevation``, ``n_azimuth``, ``n_distance``, ``kernel_hash``,
            and ``kernel_file`` / ``dem_file`` / ``obstacles_file`` when they were given as
            files.
        """
        n_frequency = int(table.sizes.get("frequency", 0))
        tags = {
            "turbidity": str(table.attrs.get("turbidity", "")),
            "n_elevation": str(int(table.sizes["elevation"])),
            "n_azimuth": str(int(table.sizes.get("azimuth", 2 * (n_frequency - 1)))),
            "n_distance": str(int(table.sizes["distance"])),
            "kernel_hash": str(table.attrs.get("content_hash", "")),
        }
        if isinstance(self.kernel, str | Path):
            tags["kernel_file"] = str(Path(self.kernel).resolve())
        if isinstance(self.dem, str | Path):
            tags["dem_file"] = str(Path(self.dem).resolve())
        if isinstance(self.obstacles, str | Path):
            tags["obstacles_file"] = str(Path(self.obstacles).resolve())
        return tags

    def recorded(self, tags: Mapping[str, Any], label: str = "product") -> Scene:
        """This scene completed with the scene a product recorded (:meth:`record`).

        What this scene leaves open (None) is taken from the tags: the turbidity and grid of
        the product's kernel, its kernel file (when it still exists with the recorded
        content hash), its DEM file and its obstacles file. What this scene gives explicitly
        wins; a turbidity that differs from the recorded one is warned about.

        Parameters
        ----------
        tags
            The product's tags.
        label
            How the product is named in messages.

        Returns
        -------
        Scene
        """
        changes: dict[str, Any] = {}
        recorded_turbidity = _number(tags.get("turbidity"))
        if self.kernel is None:
            kernel_file = tags.get("kernel_file")
            if kernel_file and Path(kernel_file).is_file():
                attrs = xr.open_dataset(kernel_file, engine="h5netcdf").attrs
                if str(attrs.get("content_hash", "")) == str(tags.get("kernel_hash", "")):
                    changes["kernel"] = Path(kernel_file)
            if "kernel" not in changes:
                if self.turbidity is None and recorded_turbidity is not None:
                    changes["turbidity"] = recorded_turbidity
                for name in DEFAULT_GRID:
                    value = _number(tags.get(name))
                    if getattr(self, name) is None and value is not None:
                        changes[name] = int(value)
        if (
            self.turbidity is not None
            and recorded_turbidity is not None
            and not np.isclose(self.turbidity, recorded_turbidity)
        ):
            warnings.warn(
                f"{label} was computed at turbidity {recorded_turbidity:g}, this scene gives "
                f"{self.turbidity:g}; the figures use {self.turbidity:g}",
                DataQualityWarning,
                stacklevel=3,
            )
        dem_file = tags.get("dem_file")
        if self.dem is None and dem_file:
            if Path(dem_file).is_file():
                changes["dem"] = Path(dem_file)
            else:
                warnings.warn(
                    f"{label} was computed over the DEM {dem_file}, which no longer exists; "
                    "the figures use flat ground",
                    DataQualityWarning,
                    stacklevel=3,
                )
        obstacles_file = tags.get("obstacles_file")
        if self.obstacles is None and obstacles_file:
            if Path(obstacles_file).is_file():
                changes["obstacles"] = Path(obstacles_file)
            else:
                warnings.warn(
                    f"{label} was computed with the obstacles {obstacles_file}, which no longer "
                    "exist; the figures use open ground",
                    DataQualityWarning,
                    stacklevel=3,
                )
        return self.replace(**changes) if changes else self


def _number(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if np.isfinite(number) else None
