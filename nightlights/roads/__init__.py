"""Road lighting to EN 13201: the calculation field, road luminance from r-tables, the metrics.

- :func:`calculation_field`: the EN 13201-3 grid and observers of a section between two
  luminaires;
- :func:`parse_rtable` / :func:`read_rtable`: reduced luminance coefficient tables (CIE 144),
  :func:`reduced_luminance_coefficient` (interpolation) and :func:`road_luminance`;
- the metrics: :func:`average_luminance`, :func:`overall_uniformity`,
  :func:`longitudinal_uniformity`, :func:`veiling_luminance`, :func:`threshold_increment`,
  :func:`edge_illuminance_ratio`, :func:`average_illuminance`, :func:`minimum_illuminance`;
- lighting classes: :func:`read_requirements` (EN 13201-2 tables, or a user's copy),
  :func:`requirements` and :func:`compliance` (each criterion's margin, the binding one).

Pure functions on arrays in a road frame (see :mod:`nightlights.roads._field`); no files.
"""

from nightlights.roads._classes import (
    CRITERIA,
    Compliance,
    Criterion,
    compliance,
    read_requirements,
    requirements,
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
    INTERPOLATIONS,
    RTable,
    parse_rtable,
    read_rtable,
    reduced_luminance_coefficient,
    road_luminance,
    synthetic_rtable,
)

__all__ = [
    "BEYOND_RULES",
    "CRITERIA",
    "FIELD_QUANTITIES",
    "INTERPOLATIONS",
    "CalculationField",
    "Compliance",
    "Criterion",
    "GlareGeometry",
    "RTable",
    "age_factor",
    "average_illuminance",
    "average_luminance",
    "calculation_field",
    "compliance",
    "edge_illuminance_ratio",
    "edge_strip_width",
    "field_points",
    "glare_geometry",
    "illuminance_uniformity",
    "longitudinal_point_count",
    "longitudinal_uniformity",
    "minimum_illuminance",
    "overall_uniformity",
    "parse_rtable",
    "read_requirements",
    "read_rtable",
    "reduced_luminance_coefficient",
    "requirements",
    "road_luminance",
    "synthetic_rtable",
    "threshold_increment",
    "veiling_luminance",
]
