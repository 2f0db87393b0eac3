"""Emission angular distributions of a ground source and their registry, as the sky package has
named them.

The shapes and their registry are a leaf of the whole package now
(:mod:`nightlights.emission_functions`, with the band tag that names a band's mix of them),
importable from any layer; this module hands the same objects on under their earlier path, so a
shape registered through either path is one registration.
"""

from __future__ import annotations

from nightlights.emission_functions import *  # noqa: F403 (the same objects, every public name)
from nightlights.emission_functions import __all__ as __all__
