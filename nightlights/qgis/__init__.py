"""The QGIS Processing provider, packaged as a QGIS plugin.

The plugin's sources live in :mod:`nightlights.qgis.plugin` (package data: QGIS's Python
imports them, the toolkit does not). Each algorithm runs the installed ``nightlights``
command in a subprocess, reports its progress bars to QGIS's feedback and stops it on cancel,
the way QGIS's GRASS and SAGA providers run their tools, so that QGIS's Python never loads the
toolkit's libraries (whose wheels bundle a GDAL of their own).

:func:`build_plugin` writes the zip QGIS installs (``nightlights qgis-plugin build``), with the
description of the stage commands that the plugin makes one algorithm of each.
"""

from nightlights.qgis._build import (
    PLUGIN_FILES,
    PLUGIN_FOLDER,
    build_plugin,
    plugin_command,
    toolkit_command,
)

__all__ = ["PLUGIN_FILES", "PLUGIN_FOLDER", "build_plugin", "plugin_command", "toolkit_command"]
