"""nightlights: a GIS toolkit for night-time lighting.

Predicts streetlight layouts from street layers, computes the light they put on the ground
and into the sky, and what an observer sees in the night sky. One function per stage, each
taking in-memory objects or paths and returning a typed result (``.path`` is the file written,
if any)::

    import nightlights as nl

    streets = nl.normalize("city.osm.pbf").streets       # GeoDataFrame
    streets = nl.sample(streets, seed=1).streets          # lighting fields filled
    lights = nl.place(streets, seed=1).lights             # light points
    ground = nl.irradiance(lights, resolution=1.0).raster  # Raster [lx]
    upward = nl.emission(ground, lights=lights, resolution=50.0, albedo=0.15).raster
    scene = nl.Scene(upward, turbidity=2.0)               # emission, terrain, atmosphere
    sky = nl.skyglow(scene, nl.Observer(x, y))            # panorama Dataset

The stages are imported on first use, so ``import nightlights`` stays fast.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from nightlights.errors import (
    CRSError,
    DataQualityWarning,
    EmptyInputError,
    InputError,
    NightlightsError,
    NightlightsWarning,
    OutputError,
)

try:  # the distribution's name: "nightlights" on the package index is another project
    __version__ = version("nightlights-gis")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

#: Public name -> the subpackage that defines it (imported on first access).
_LAZY: dict[str, str] = {
    # streets -> light points
    "normalize": "nightlights.streets",
    "sample": "nightlights.streets",
    "fit": "nightlights.streets",
    "learn": "nightlights.streets",
    "place": "nightlights.streets",
    "NormalizeResult": "nightlights.streets",
    "SampleResult": "nightlights.streets",
    "FitResult": "nightlights.streets",
    "LearnResult": "nightlights.streets",
    "PlaceResult": "nightlights.streets",
    # light on the ground and what goes up
    "irradiance": "nightlights.ground",
    "emission": "nightlights.ground",
    "emission_from_viirs": "nightlights.ground",
    "obstacle_rasters": "nightlights.ground",
    "ObstacleProperties": "nightlights.ground",
    "IrradianceResult": "nightlights.ground",
    "EmissionResult": "nightlights.ground",
    # what a sky computation is about: the scene and who looks at it
    "Scene": "nightlights.sky",
    "Observer": "nightlights.sky",
    # the sky
    "KernelSpec": "nightlights.sky",
    "build_kernel": "nightlights.sky",
    "skyglow": "nightlights.sky",
    "KernelResult": "nightlights.sky",
    "SkyglowResult": "nightlights.sky",
    # the inverse: which lights cause the glow, and how to dim them
    "inverse_q": "nightlights.inverse",
    "inverse_s": "nightlights.inverse",
    "inverse_reduce": "nightlights.inverse",
    "least_dimming": "nightlights.inverse",
    "SkyRegion": "nightlights.inverse",
    "InfluenceResult": "nightlights.inverse",
    "ReduceResult": "nightlights.inverse",
    # road lighting: the street's own standard
    "audit": "nightlights.roads",
    "AuditResult": "nightlights.roads",
    # many observers: the zenith darkness map of a whole region
    "darkness": "nightlights.sky",
    "DarknessResult": "nightlights.sky",
    # interactive: any observer, edits and dimming in memory (and in the browser)
    "ExploreSession": "nightlights.explore",
    # the whole night sky: stars, Moon, natural background, the eye
    "sky_render": "nightlights.nightsky",
    "SkyRenderResult": "nightlights.nightsky",
    # many observers at once: one styled summary point layer
    "observers": "nightlights.sky.observers",
    "ObserversResult": "nightlights.sky.observers",
    # the measured sky: photometer readings, validation and calibration against them
    "read_readings": "nightlights.meter",
    "validate": "nightlights.meter",
    "ValidationResult": "nightlights.meter",
    # projects: one TOML file, every stage, cached
    "run": "nightlights.project",
    "load_project": "nightlights.project",
    "ProjectResult": "nightlights.project",
    # data types
    "Raster": "nightlights.io",
}

if TYPE_CHECKING:
    from nightlights.explore import ExploreSession
    from nightlights.ground import (
        EmissionResult,
        IrradianceResult,
        ObstacleProperties,
        emission,
        emission_from_viirs,
        irradiance,
        obstacle_rasters,
    )
    from nightlights.inverse import (
        InfluenceResult,
        ReduceResult,
        SkyRegion,
        inverse_q,
        inverse_reduce,
        inverse_s,
        least_dimming,
    )
    from nightlights.io import Raster
    from nightlights.meter import ValidationResult, read_readings, validate
    from nightlights.nightsky import SkyRenderResult, sky_render
    from nightlights.project import ProjectResult, load_project, run
    from nightlights.sky import (
        DarknessResult,
        KernelResult,
        KernelSpec,
        Observer,
        Scene,
        SkyglowResult,
        build_kernel,
        darkness,
        skyglow,
    )
    from nightlights.sky.observers import ObserversResult, observers
    from nightlights.streets import (
        FitResult,
        LearnResult,
        NormalizeResult,
        PlaceResult,
        SampleResult,
        fit,
        learn,
        normalize,
        place,
        sample,
    )


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "AuditResult",
    "CRSError",
    "DarknessResult",
    "DataQualityWarning",
    "EmissionResult",
    "EmptyInputError",
    "ExploreSession",
    "FitResult",
    "InfluenceResult",
    "InputError",
    "IrradianceResult",
    "KernelResult",
    "KernelSpec",
    "LearnResult",
    "NightlightsError",
    "NightlightsWarning",
    "NormalizeResult",
    "Observer",
    "ObserversResult",
    "ObstacleProperties",
    "OutputError",
    "PlaceResult",
    "ProjectResult",
    "Raster",
    "ReduceResult",
    "SampleResult",
    "Scene",
    "SkyRegion",
    "SkyRenderResult",
    "SkyglowResult",
    "ValidationResult",
    "__version__",
    "audit",
    "build_kernel",
    "darkness",
    "emission",
    "emission_from_viirs",
    "fit",
    "inverse_q",
    "inverse_reduce",
    "inverse_s",
    "irradiance",
    "learn",
    "least_dimming",
    "load_project",
    "normalize",
    "observers",
    "obstacle_rasters",
    "place",
    "read_readings",
    "run",
    "sample",
    "sky_render",
    "skyglow",
    "validate",
]
