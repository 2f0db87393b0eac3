"""Road lighting to EN 13201: the calculation field, road luminance from r-tables, the metrics.

- :func:`calculation_field`: the EN 13201-3 grid and observers of a section between two
  luminaires;
- :func:`parse_rtable` / :func:`read_rtable`: reduced luminance coefficient tables (CIE 144),
  :func:`reduced_luminance_coefficient` (interpolation) and :func:`road_luminance`;
- the metrics: :func:`average_luminance`, :func:`overall_uniformity`,
  :func:`longitudinal_uniformity`, :func:`veiling_luminance`, :func:`threshold_increment`,
  :func:`edge_illuminance_ratio`, :func:`average_illuminance`, :func:`minimum_illuminance`;
- :func:`audit`: every segment of a street layer against its lighting class (a styled
  GeoPackage and a summary, with energy per segment given :class:`EnergyOptions`);
  :func:`road_model` builds what it rates, for plans;
- energy (EN 13201-5): :func:`burning_intervals` and :func:`annual_burning_hours` of a
  photocell, :class:`DimmingSchedule` (:func:`parse_schedule`, :func:`schedule_level`,
  :func:`scheduled_hours`), :func:`light_power`, :func:`annual_energy`,
  :func:`power_density_indicator`, :func:`energy_consumption_indicator`,
  :func:`co2_emissions`;
- hemispherical, semicylindrical and vertical illuminance (EN 13201-3, Sec. 8):
  :func:`hemispherical_illuminance`, :func:`semicylindrical_illuminance`,
  :func:`vertical_illuminance`;
- lighting classes: :func:`read_requirements` (EN 13201-2 tables, or a user's copy, which
  may hold RP-8's criteria), :func:`requirements_for_region`, :func:`requirements` and
  :func:`compliance` (each criterion's margin, the binding one);
- RP-8's figures: :func:`luminance_average_to_minimum`, :func:`luminance_maximum_to_minimum`,
  :func:`veiling_luminance_ratio`, :func:`illuminance_average_to_minimum`;
- class selection: :func:`read_class_selection` and :func:`select_classes` (a street's class
  from its street fields by editable rules);
- plans: :func:`road_plan` (least-energy dimming under sky targets that keeps every class),
  :func:`road_plan_schedule`, :class:`SkyMatrix` (each light's part of a sky target,
  built by :func:`nightlights.inverse.sky_matrix`).

The metrics are pure functions on arrays in a road frame (see
:mod:`nightlights.roads._field`); :func:`audit` is the stage that reads and writes layers.
"""

from nightlights.roads._audit import (
    AuditResult,
    AuditSummary,
    EnergyOptions,
    RoadModel,
    audit,
    road_model,
)
from nightlights.roads._burning import (
    CIVIL_TWILIGHT,
    SWITCH_ELEVATION,
    BurningIntervals,
    annual_burning_hours,
    burning_intervals,
    sun_elevation,
)
from nightlights.roads._classes import (
    CRITERIA,
    REGION_REQUIREMENTS,
    Compliance,
    Criterion,
    class_names,
    compliance,
    read_requirements,
    requirements,
    requirements_for_region,
)
from nightlights.roads._dimming import (
    DimmingSchedule,
    parse_schedule,
    schedule_level,
    scheduled_hours,
)
from nightlights.roads._energy import (
    annual_energy,
    co2_emissions,
    energy_consumption_indicator,
    full_power_hours,
    light_power,
    power_density_indicator,
)
from nightlights.roads._field import (
    FIELD_QUANTITIES,
    CalculationField,
    calculation_field,
    field_points,
    longitudinal_point_count,
)
from nightlights.roads._illuminance import (
    RECEPTOR_HEIGHT,
    hemispherical_illuminance,
    semicylindrical_illuminance,
    vertical_illuminance,
)
from nightlights.roads._metrics import (
    GlareGeometry,
    age_factor,
    average_illuminance,
    average_luminance,
    edge_illuminance_ratio,
    edge_strip_width,
    glare_geometry,
    illuminance_uniformity,
    longitudinal_uniformity,
    minimum_illuminance,
    overall_uniformity,
    threshold_increment,
    veiling_luminance,
)
from nightlights.roads._plan import (
    OBJECTIVES,
    PlanPeriod,
    RoadPlan,
    SkyMatrix,
    road_plan,
    road_plan_schedule,
)
from nightlights.roads._rp8 import (
    illuminance_average_to_minimum,
    luminance_average_to_minimum,
    luminance_maximum_to_minimum,
    veiling_luminance_ratio,
)
from nightlights.roads._rtables import (
    BEYOND_RULES,
    INTERPOLATIONS,
    RTable,
    parse_rtable,
    read_rtable,
    reduced_luminance_coefficient,
    road_luminance,
    synthetic_rtable,
)
from nightlights.roads._selection import (
    CONDITIONS,
    ClassRule,
    ClassSelection,
    read_class_selection,
    select_classes,
)

__all__ = [
    "BEYOND_RULES",
    "CIVIL_TWILIGHT",
    "CONDITIONS",
    "CRITERIA",
    "FIELD_QUANTITIES",
    "INTERPOLATIONS",
    "OBJECTIVES",
    "RECEPTOR_HEIGHT",
    "REGION_REQUIREMENTS",
    "SWITCH_ELEVATION",
    "AuditResult",
    "AuditSummary",
    "BurningIntervals",
    "CalculationField",
    "ClassRule",
    "ClassSelection",
    "Compliance",
    "Criterion",
    "DimmingSchedule",
    "EnergyOptions",
    "GlareGeometry",
    "PlanPeriod",
    "RTable",
    "RoadModel",
    "RoadPlan",
    "SkyMatrix",
    "age_factor",
    "annual_burning_hours",
    "annual_energy",
    "audit",
    "average_illuminance",
    "average_luminance",
    "burning_intervals",
    "calculation_field",
    "class_names",
    "co2_emissions",
    "compliance",
    "edge_illuminance_ratio",
    "edge_strip_width",
    "energy_consumption_indicator",
    "field_points",
    "full_power_hours",
    "glare_geometry",
    "hemispherical_illuminance",
    "illuminance_average_to_minimum",
    "illuminance_uniformity",
    "light_power",
    "longitudinal_point_count",
    "longitudinal_uniformity",
    "luminance_average_to_minimum",
    "luminance_maximum_to_minimum",
    "minimum_illuminance",
    "overall_uniformity",
    "parse_rtable",
    "parse_schedule",
    "power_density_indicator",
    "read_class_selection",
    "read_requirements",
    "read_rtable",
    "reduced_luminance_coefficient",
    "requirements",
    "requirements_for_region",
    "road_luminance",
    "road_model",
    "road_plan",
    "road_plan_schedule",
    "schedule_level",
    "scheduled_hours",
    "select_classes",
    "semicylindrical_illuminance",
    "sun_elevation",
    "synthetic_rtable",
    "threshold_increment",
    "veiling_luminance",
    "veiling_luminance_ratio",
    "vertical_illuminance",
]
