"""The project file: its tables, their keys and the checks made before any stage runs.

A project is one TOML file (:func:`load_project`). Every table refuses keys it does not know;
stage options carry the command line's names (``along-jitter`` for ``--along-jitter``). After
the tables parse, the project is checked as a whole: exactly one data input, every input file
present, every CRS readable, each stage's upstream product available, observer names that
exist, options that do not contradict each other, and every observer within the kernel's
reach of the data. Each failure is one :class:`ProjectError` line naming the key and, where
there is a choice, the allowed values.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from nightlights.errors import InputError

#: The stages in the order they run; the table names under ``[stages]``.
STAGES = (
    "normalize",
    "sample",
    "place",
    "irradiance",
    "emission",
    "emission-viirs",
    "skyglow",
    "observers",
    "inverse-q",
    "inverse-s",
    "inverse-reduce",
    "darkness",
)
#: Stages that read the streets input, and the product each stage needs from upstream.
STREET_STAGES = ("normalize", "sample", "place", "irradiance", "emission")
UPSTREAM = {
    "sample": "normalize",
    "place": "sample",
    "irradiance": "place",
    "emission": "irradiance",
}
#: Stages that need the emission raster (from ``emission``, ``emission-viirs`` or the input).
SKY_STAGES = ("skyglow", "observers", "inverse-q", "inverse-s", "inverse-reduce", "darkness")
#: Stages computed once per observer.
PER_OBSERVER = ("skyglow", "inverse-q", "inverse-s")
#: The furthest an observer may stand from the data without a ``[kernel]`` table [m]: the
#: largest distance any kernel tabulates (``nightlights.sky.spec.MAX_KERNEL_RANGE``).
MAX_REACH = 300_000.0


class ProjectError(InputError):
    """A project file is malformed, names a missing input or contradicts itself."""


def _dashed(name: str) -> str:
    return name.replace("_", "-")


class _Table(BaseModel):
    """A TOML table: unknown keys refused, keys spelled as on the command line."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, alias_generator=_dashed, populate_by_name=False
    )


PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Fraction = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
Count = Annotated[int, Field(ge=1)]
Bounds = tuple[float, float, float, float]
Projection = Literal["equirectangular", "fisheye"]
#: A Q/S threshold: a value in the unit of the ``by`` raster, or a percentile of its lit cells.
Threshold = (
    Annotated[float, Field(allow_inf_nan=False)] | Annotated[str, Field(pattern=r"^\d+(\.\d+)?%$")]
)


class ProjectTable(_Table):
    """``[project]``: name, output folder (relative to the file) and random seed."""

    name: str = "project"
    output: Path = Path("nightlights-out")
    seed: Annotated[int, Field(ge=0)] | None = None
    #: Data credit printed on the maps.
    credit: str | None = None


class InputsTable(_Table):
    """``[inputs]``: one data source (streets, emission or VIIRS raster) and optional data."""

    streets: Path | None = None
    emission: Path | None = None
    viirs: Path | None = None
    dem: Path | None = None
    mapping: str = "osm"
    network: str | None = None
    catalog: Path | None = None


class ObserversTable(_Table):
    """``[observers]``: named points in any CRS, or a point layer with a name field."""

    crs: str | None = None
    height: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 1.7
    points: dict[str, tuple[float, float]] | None = None
    file: Path | None = None
    layer: str | None = None
    name_field: str = "name"


class AtmosphereTable(_Table):
    """``[atmosphere]``: the aerosol load."""

    turbidity: Annotated[float, Field(ge=1, allow_inf_nan=False)] | None = None


class KernelTable(_Table):
    """``[kernel]``: one kernel for every sky stage (built once, cached)."""

    r_min: PositiveFloat = 10.0
    r_max: Annotated[float, Field(gt=0, le=MAX_REACH, allow_inf_nan=False)] = 100_000.0
    n_distance: Count = 64
    n_elevation: Count = 64
    n_azimuth: Annotated[int, Field(ge=2, multiple_of=2)] = 256
    uplight: bool = True
    nodes: Count = 12


class NormalizeStage(_Table):
    """``[stages.normalize]``: the options of ``streets normalize``."""

    layer: str | None = None
    crs: str | None = None
    target_crs: str | None = None


class SampleStage(_Table):
    """``[stages.sample]``: the options of ``streets sample`` (its seed: ``project.seed``)."""

    candidates: Count = 128
    on_conflict: Literal["error", "relax"] = "error"


class PlaceStage(_Table):
    """``[stages.place]``: the options of ``streets place``."""

    along_jitter: Fraction | None = None
    across_jitter: Annotated[float, Field(ge=0, allow_inf_nan=False)] | None = None
    merge_fraction: Fraction | None = None


class IrradianceStage(_Table):
    """``[stages.irradiance]``: the options of ``irradiance``, and its map."""

    resolution: PositiveFloat
    sensor: list[str] = ["photopic"]
    bounds: Bounds | None = None
    margin: Annotated[float, Field(ge=0, allow_inf_nan=False)] | None = None
    threshold: str = "floor:0.01"
    max_radius: PositiveFloat = 1000.0
    tile_size: Count = 1024
    skip_unknown: bool = False
    #: Also draw ``irradiance.png`` (poles over the illuminance), optionally of a window.
    map: bool = True
    map_window: Bounds | None = None


class EmissionStage(_Table):
    """``[stages.emission]``: the options of ``emission`` (ground light and uplight)."""

    resolution: PositiveFloat
    albedo: Fraction | str
    skip_unknown: bool = False


class EmissionViirsStage(_Table):
    """``[stages.emission-viirs]``: the options of ``emission viirs``."""

    spectrum: str = "LED_4000K"
    resolution: PositiveFloat | None = None
    target_crs: str | None = None
    emission_function: str = "lambertian"


class _SceneGrid(_Table):
    """The grid of a scene kernel (only without a ``[kernel]`` table)."""

    n_azimuth: Annotated[int, Field(ge=2, multiple_of=2)] | None = None
    n_elevation: Count | None = None
    n_distance: Count | None = None


class SkyglowStage(_SceneGrid):
    """``[stages.skyglow]``: the options of ``skyglow``, per observer."""

    observer: str | list[str] | None = None
    mode: Literal["pca", "exact", "naive"] = "pca"
    components: Count | None = None
    png: bool = True
    #: The PNG's projection: one for all, or per observer name (others: equirectangular).
    projection: Projection | dict[str, Projection] = "equirectangular"
    polar_output: bool = False
    bands: Literal["V", "RGB"] = "V"
    spectrum: str = "LED_4000K"


class ObserversStage(_Table):
    """``[stages.observers]``: the options of ``sky observers``."""

    panoramas: bool = False
    top_cells: Annotated[int, Field(ge=0)] = 5
    scheduler: Literal["threads", "processes", "synchronous"] = "threads"


class InverseQStage(_SceneGrid):
    """``[stages.inverse-q]``: the options of ``inverse q``, per observer, and its map."""

    observer: str | list[str] | None = None
    metric: Literal["pca-norm", "zenith", "hemisphere"] = "pca-norm"
    map: bool = True


class InverseSStage(_SceneGrid):
    """``[stages.inverse-s]``: the options of ``inverse s``, per observer, and its map."""

    observer: str | list[str] | None = None
    region: str
    weight: Literal["solid-angle", "pixel"] = "solid-angle"
    method: Literal["pca", "brute"] = "pca"
    components: Count | None = None
    map: bool = True


class InverseReduceStage(_Table):
    """``[stages.inverse-reduce]``: ``inverse dim --by`` the map of a stage."""

    by: Literal["inverse-q", "inverse-s"]
    observer: str | None = None
    qa: Threshold
    qb: Threshold
    gamma: Fraction = 1.0
    png: bool = True


class DarknessStage(_SceneGrid):
    """``[stages.darkness]``: the options of ``darkness``."""

    chunk_size: Count | None = None


class StagesTable(_Table):
    """``[stages]``: a table per stage to run (an empty table runs it with its defaults)."""

    normalize: NormalizeStage | None = None
    sample: SampleStage | None = None
    place: PlaceStage | None = None
    irradiance: IrradianceStage | None = None
    emission: EmissionStage | None = None
    emission_viirs: EmissionViirsStage | None = None
    skyglow: SkyglowStage | None = None
    observers: ObserversStage | None = None
    inverse_q: InverseQStage | None = None
    inverse_s: InverseSStage | None = None
    inverse_reduce: InverseReduceStage | None = None
    darkness: DarknessStage | None = None

    def chosen(self) -> list[str]:
        """The stages given, in running order."""
        return [name for name in STAGES if getattr(self, name.replace("-", "_")) is not None]

    def options(self, stage: str) -> Any:
        """The option table of ``stage`` (None when it is not run)."""
        return getattr(self, stage.replace("-", "_"))


class ProjectFile(_Table):
    """The whole file, as parsed (paths still as written)."""

    project: ProjectTable = ProjectTable()
    inputs: InputsTable
    observers: ObserversTable | None = None
    atmosphere: AtmosphereTable = AtmosphereTable()
    kernel: KernelTable | None = None
    stages: StagesTable


if TYPE_CHECKING:
    from nightlights.sky.observer import Observer as SkyObserver


@dataclass(frozen=True)
class Observer:
    """An observer of the project: its name and position in its CRS.

    Attributes
    ----------
    name
        Unique name (used in output file names).
    x, y
        Position in ``crs`` [m or deg].
    crs
        CRS of the position (text), None for the data's CRS.
    height
        Eye height above the ground [m].
    """

    name: str
    x: float
    y: float
    crs: str | None
    height: float

    def key(self) -> dict[str, Any]:
        """What a cached stage of this observer depends on."""
        return {"name": self.name, "x": self.x, "y": self.y, "crs": self.crs, "h": self.height}

    def sky(self) -> SkyObserver:
        """The observer as the sky stages take it (:class:`nightlights.sky.Observer`)."""
        from nightlights.sky.observer import Observer as SkyObserver

        return SkyObserver(self.x, self.y, self.crs, self.height, self.name)


@dataclass(frozen=True)
class Project:
    """A checked project: the parsed tables, with paths made absolute.

    Attributes
    ----------
    file
        The parsed tables (input paths absolute).
    source
        The project file, or a text saying where the tables came from.
    base
        Folder that relative paths of the file are taken from.
    observers
        The observers, in file order.
    """

    file: ProjectFile
    source: str
    base: Path
    observers: tuple[Observer, ...]

    @property
    def output(self) -> Path:
        """The output folder."""
        return self.file.project.output

    @property
    def stages(self) -> list[str]:
        """The stages to run, in order."""
        return self.file.stages.chosen()

    def options(self, stage: str) -> Any:
        """The option table of ``stage``."""
        return self.file.stages.options(stage)

    def observers_of(self, stage: str) -> tuple[Observer, ...]:
        """The observers a per-observer stage runs for (default: all)."""
        wanted = getattr(self.options(stage), "observer", None)
        if wanted is None:
            return self.observers
        names = [wanted] if isinstance(wanted, str) else list(wanted)
        return tuple(o for o in self.observers if o.name in names)


PathOrMapping = str | os.PathLike[str] | Mapping[str, Any]


def builtin_mappings() -> list[str]:
    """The built-in street mappings (``nightlights.streets.builtin_mappings``), listed without
    importing the streets package."""
    import nightlights

    folder = Path(nightlights.__file__).parent / "streets" / "mappings"
    return sorted(p.name[:-5] for p in folder.glob("*.toml"))


def network_names() -> list[str]:
    """The catalogue networks (``bayesnets.catalog_names``)."""
    from bayesnets import catalog_names

    return list(catalog_names())


def reach(project_file: ProjectFile) -> float:
    """How far from the data an observer may stand [m]: the kernel's range."""
    kernel = project_file.kernel
    return MAX_REACH if kernel is None else min(kernel.r_max, MAX_REACH)
