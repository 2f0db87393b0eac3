"""The QGIS plugin: adds the ``nightlights`` Processing provider when QGIS starts."""

from __future__ import annotations

from typing import Any

from qgis.core import QgsApplication

from .provider import NightlightsProvider


class NightlightsPlugin:
    """Registers :class:`NightlightsProvider` (Processing only: no menus or toolbars)."""

    def __init__(self, iface: Any) -> None:
        self.iface = iface
        self.provider: NightlightsProvider | None = None

    def initProcessing(self) -> None:
        """Add the provider (QGIS calls this for plugins with ``hasProcessingProvider=yes``)."""
        if self.provider is None:
            self.provider = NightlightsProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self) -> None:
        self.initProcessing()

    def unload(self) -> None:
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
