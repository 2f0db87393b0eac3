"""Street layers to streetlight layouts (Chuang 2011, Sec. 3).

Four stages, each taking a GeoDataFrame or a vector file and an optional output path:

- :func:`normalize`: map a street layer's fields onto the canonical street fields;
- :func:`sample`: fill missing street fields and add lighting fields from a Bayesian
  network;
- :func:`fit`: estimate such a network from streets whose lighting is known;
- :func:`place`: place light systems along the lit streets.

The pure functions they wrap (:func:`normalize_streets`, :func:`fill_lighting`,
:func:`fit_lighting_network`, :func:`place_lights`) work on GeoDataFrames only.
"""

from nightlights.streets.fit import FitResult, fit, fit_lighting_network
from nightlights.streets.normalize import (
    NormalizeReport,
    NormalizeResult,
    normalize,
    normalize_streets,
)
from nightlights.streets.place import PlacementOptions, PlaceResult, place, place_lights
from nightlights.streets.sample import SampleResult, fill_lighting, sample

__all__ = [
    "FitResult",
    "NormalizeReport",
    "NormalizeResult",
    "PlaceResult",
    "PlacementOptions",
    "SampleResult",
    "fill_lighting",
    "fit",
    "fit_lighting_network",
    "normalize",
    "normalize_streets",
    "place",
    "place_lights",
    "sample",
]
