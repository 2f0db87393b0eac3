"""Street layers to streetlight layouts (Chuang 2011, Sec. 3).

Five stages, each taking a GeoDataFrame or a vector file and an optional output path:

- :func:`normalize`: map a street layer's fields onto the canonical street fields;
- :func:`sample`: fill missing street fields and add lighting fields from a Bayesian
  network;
- :func:`fit`: estimate such a network from streets whose lighting is known;
- :func:`learn`: estimate one from a street layer and a point layer of mapped lamps;
- :func:`place`: place light systems along the lit streets.

The pure functions they wrap (:func:`normalize_streets`, :func:`fill_lighting`,
:func:`fit_lighting_network`, :func:`place_lights`) work on GeoDataFrames only.
"""

from nightlights.streets._fit import FitResult, fit, fit_lighting_network
from nightlights.streets._learn import (
    LampAssignment,
    LearnReport,
    LearnResult,
    assign_lamps,
    learn,
    learn_lighting_network,
    street_lamp_evidence,
)
from nightlights.streets._mapping import builtin_mappings
from nightlights.streets._normalize import (
    NormalizeReport,
    NormalizeResult,
    normalize,
    normalize_streets,
)
from nightlights.streets._place import PlacementOptions, PlaceResult, place, place_lights
from nightlights.streets._sample import (
    DEFAULT_CANDIDATES,
    SampleResult,
    fill_lighting,
    lighting_summary,
    sample,
)

__all__ = [
    "DEFAULT_CANDIDATES",
    "FitResult",
    "LampAssignment",
    "LearnReport",
    "LearnResult",
    "NormalizeReport",
    "NormalizeResult",
    "PlaceResult",
    "PlacementOptions",
    "SampleResult",
    "assign_lamps",
    "builtin_mappings",
    "fill_lighting",
    "fit",
    "fit_lighting_network",
    "learn",
    "learn_lighting_network",
    "lighting_summary",
    "normalize",
    "normalize_streets",
    "place",
    "place_lights",
    "sample",
    "street_lamp_evidence",
]
