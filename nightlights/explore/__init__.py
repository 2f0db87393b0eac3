"""Interactive forward and inverse investigation in the browser (``nightlights explore``).

Dobashi et al. (2023, Secs. 4-5) built an interactive system: move the observer and see the
sky at once, draw a region on the sky and see the lights that cause it, dim them and edit
them. :class:`ExploreSession` is that engine over the toolkit's stages, in memory;
:func:`create_app` serves it as a local web application (an HTTP API and one page) and
:func:`serve` runs it.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Secs. 4-5.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY: dict[str, str] = {
    "ExploreSession": "nightlights.explore._session",
    "PanoramaView": "nightlights.explore._session",
    "InfluenceView": "nightlights.explore._session",
    "DimmingView": "nightlights.explore._session",
    "EditView": "nightlights.explore._session",
    "RoadOptions": "nightlights.explore._roads",
    "RoadPlanView": "nightlights.explore._roads",
    "RoadView": "nightlights.explore._roads",
    "create_app": "nightlights.explore._app",
    "serve": "nightlights.explore._app",
}

if TYPE_CHECKING:
    from nightlights.explore._app import create_app, serve
    from nightlights.explore._roads import RoadOptions, RoadPlanView, RoadView
    from nightlights.explore._session import (
        DimmingView,
        EditView,
        ExploreSession,
        InfluenceView,
        PanoramaView,
    )

__all__ = [
    "DimmingView",
    "EditView",
    "ExploreSession",
    "InfluenceView",
    "PanoramaView",
    "RoadOptions",
    "RoadPlanView",
    "RoadView",
    "create_app",
    "serve",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights.explore' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
