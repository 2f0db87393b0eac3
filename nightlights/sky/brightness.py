"""Sky brightness in astronomers' units and the Bortle scale, as the sky package has named them.

The units are a leaf of the whole package now (:mod:`nightlights.brightness`), importable from
any layer; this module hands the same objects on under their earlier path.
"""

from __future__ import annotations

from nightlights.brightness import (
    BORTLE_LOWER_EDGES,
    ZERO_POINT_LUMINANCE,
    bortle_class,
    luminance_to_magnitude,
    magnitude_to_luminance,
)

__all__ = [
    "BORTLE_LOWER_EDGES",
    "ZERO_POINT_LUMINANCE",
    "bortle_class",
    "luminance_to_magnitude",
    "magnitude_to_luminance",
]
