"""Light on the ground and what goes up: ground illuminance and upward emission.

Stages (in-memory objects or paths in, a result object out, a file written on request):

* :func:`irradiance`: a light layer -> ground illuminance per sensor band
  (:class:`IrradianceResult`);
* :func:`emission`: ground illuminance and the lights -> upward flux density, reflected and
  direct (:class:`EmissionResult`);
* :func:`emission_from_viirs`: a VIIRS Day/Night Band radiance raster -> upward flux density;
* :func:`obstacle_rasters`: building footprints -> obstacle height, spacing and filling factor
  (:mod:`~nightlights.ground.footprints`; the obstacle model: :mod:`~nightlights.ground.obstacles`).

The model underneath, one module per job: luminaire frames and candela tables
(:mod:`~nightlights.ground.frames`), light layers to luminaire arrays
(:mod:`~nightlights.ground.luminaires`), regions of influence
(:mod:`~nightlights.ground.influence`), the illuminance kernel
(:mod:`~nightlights.ground.illuminance`: compiled by default, numpy as the reference), grids
and Dask tiles (:mod:`~nightlights.ground.tiles`), area sources
(:mod:`~nightlights.ground.area_lights`) and the upward emission models
(:mod:`~nightlights.ground.upward`).
"""

from nightlights.ground.area_lights import (
    AreaLightOptions,
    PseudoLights,
    area_luminaires,
    lambertian_panel_table,
    pseudo_lights,
    read_area_lights,
    rectangle_illuminance,
)
from nightlights.ground.footprints import land_use_obstacles, obstacle_rasters
from nightlights.ground.frames import (
    FluxProfile,
    IntensityTable,
    PhotometryLike,
    direction_to_photometric,
    flux_profile,
    light_points,
    luminaire_rotation,
    photometric_to_direction,
)
from nightlights.ground.illuminance import ground_illuminance, surface_normals
from nightlights.ground.influence import InfluenceThreshold, influence_radius
from nightlights.ground.luminaires import (
    DatabaseLike,
    LightSystemLike,
    Luminaires,
    band_unit,
    load_database,
    resolve_luminaires,
    sample_elevation,
    sensor_factors,
)
from nightlights.ground.obstacles import (
    LAND_USE_OBSTACLES,
    ObstacleProperties,
    escaping_fraction,
    obstacle_transmission,
)
from nightlights.ground.stage import IrradianceResult, ground_on_grid, irradiance
from nightlights.ground.tiles import (
    ComputedIrradiance,
    RasterGrid,
    Tile,
    assign_to_tiles,
    compute_irradiance,
    compute_tiles,
    grid_from_bounds,
    make_tiles,
)
from nightlights.ground.upward import (
    DEFAULT_VIIRS_SPECTRUM,
    DNB_BAND,
    EmissionResult,
    block_aggregate,
    deposit_flux,
    dnb_luminous_efficacy,
    emission,
    emission_from_viirs,
    flux_density_to_viirs_radiance,
    geographic_cell_areas,
    viirs_radiance_to_flux_density,
)

__all__ = [
    "DEFAULT_VIIRS_SPECTRUM",
    "DNB_BAND",
    "LAND_USE_OBSTACLES",
    "AreaLightOptions",
    "ComputedIrradiance",
    "DatabaseLike",
    "EmissionResult",
    "FluxProfile",
    "InfluenceThreshold",
    "IntensityTable",
    "IrradianceResult",
    "LightSystemLike",
    "Luminaires",
    "ObstacleProperties",
    "PhotometryLike",
    "PseudoLights",
    "RasterGrid",
    "Tile",
    "area_luminaires",
    "assign_to_tiles",
    "band_unit",
    "block_aggregate",
    "compute_irradiance",
    "compute_tiles",
    "deposit_flux",
    "direction_to_photometric",
    "dnb_luminous_efficacy",
    "emission",
    "emission_from_viirs",
    "escaping_fraction",
    "flux_density_to_viirs_radiance",
    "flux_profile",
    "geographic_cell_areas",
    "grid_from_bounds",
    "ground_illuminance",
    "ground_on_grid",
    "influence_radius",
    "irradiance",
    "lambertian_panel_table",
    "land_use_obstacles",
    "light_points",
    "load_database",
    "luminaire_rotation",
    "make_tiles",
    "obstacle_rasters",
    "obstacle_transmission",
    "photometric_to_direction",
    "pseudo_lights",
    "read_area_lights",
    "rectangle_illuminance",
    "resolve_luminaires",
    "sample_elevation",
    "sensor_factors",
    "surface_normals",
    "viirs_radiance_to_flux_density",
]
