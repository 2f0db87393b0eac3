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
- lighting classes: :func:`read_requirements` (EN 13201-2 tables, or a user's copy),
  :func:`requirements` and :func:`compliance` (each criterion's margin, the binding one);
- energy (EN 13201-5): :func:`burning_intervals` and :func:`annual_burning_hours` of a
  photocell, :class:`DimmingSchedule` (:func:`parse_schedule`, :func:`schedule_level`,
  :func:`scheduled_hours`), :func:`light_power`, :func:`annual_energy`,
  :func:`power_density_indicator`, :func:`energy_consumption_indicator`,
  :func:`co2_emissions`.

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
    Compliance,
    Criterion,
    compliance,
    read_requirements,
    requirements,
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
from nightlights.roads._rtables import (
    BEYOND_RULES,
    RTable,
    parse_rtable,
    read_rtable,
    reduced_luminance_coefficient,
    road_luminance,
    synthetic_rtable,
)

__all__ = [
    "BEYOND_RULES",
    "CIVIL_TWILIGHT",
    "CRITERIA",
    "FIELD_QUANTITIES",
    "SWITCH_ELEVATION",
    "AuditResult",
    "AuditSummary",
    "BurningIntervals",
    "CalculationField",
    "Compliance",
    "Criterion",
    "DimmingSchedule",
    "EnergyOptions",
    "GlareGeometry",
    "RTable",
    "RoadModel",
    "age_factor",
    "annual_burning_hours",
    "annual_energy",
    "audit",
    "average_illuminance",
    "average_luminance",
    "burning_intervals",
    "calculation_field",
    "co2_emissions",
    "compliance",
    "edge_illuminance_ratio",
    "edge_strip_width",
    "energy_consumption_indicator",
    "field_points",
    "full_power_hours",
    "glare_geometry",
    "illuminance_uniformity",
    "light_power",
    "longitudinal_point_count",
    "longitudinal_uniformity",
    "minimum_illuminance",
    "overall_uniformity",
    "parse_rtable",
    "parse_schedule",
    "power_density_indicator",
    "read_requirements",
    "read_rtable",
    "reduced_luminance_coefficient",
    "requirements",
    "road_luminance",
    "road_model",
    "schedule_level",
    "scheduled_hours",
    "sun_elevation",
    "synthetic_rtable",
    "threshold_increment",
    "veiling_luminance",
]
