"""nightlights: a GIS toolkit for night-time lighting.

Predicts streetlight layouts from street layers, computes the light they put on the
ground and into the sky, and what an observer sees in the night sky.
"""

from importlib.metadata import PackageNotFoundError, version

from nightlights.errors import NightlightsError

try:
    __version__ = version("nightlights")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["NightlightsError", "__version__"]
