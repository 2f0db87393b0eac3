"""QGIS plugin: the nightlights toolkit's stages as Processing algorithms.

The algorithms run the installed ``nightlights`` command in a subprocess (``runner``), so
QGIS's Python never imports the toolkit. Nothing here imports QGIS until QGIS calls
:func:`classFactory`.
"""

from __future__ import annotations

from typing import Any


def classFactory(iface: Any) -> Any:
    """The plugin object QGIS loads (QGIS's plugin entry point)."""
    from .plugin import NightlightsPlugin

    return NightlightsPlugin(iface)
