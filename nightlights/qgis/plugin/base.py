"""The base of the provider's algorithms: parameters to command lines, a run, the results.

Each algorithm turns its parameters into one or more ``nightlights`` command lines
(:meth:`NightlightsAlgorithm.steps`), runs them with :func:`runner.run_command` (progress to
``feedback.setProgress``, messages to the log, cancel honoured) and returns the files the
commands wrote; QGIS loads the layer outputs. Inputs are passed by path: a layer that is not a
file the toolkit reads (a memory layer, a selection, a filtered layer, one layer of a
multi-layer file) is first exported by QGIS to a temporary GeoPackage. Outputs chosen in QGIS
replace an existing file (QGIS has asked).
"""

from __future__ import annotations

import os
import re
from typing import Any

from qgis.core import (
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingUtils,
    QgsProviderRegistry,
)

from .runner import COMMAND_SETTING, CommandCanceled, CommandError, find_command, run_command

#: Vector formats the toolkit reads in place (others are exported to a GeoPackage first).
VECTOR_FORMATS = ["gpkg", "shp", "geojson", "json", "fgb", "pbf", "osm"]


class NightlightsAlgorithm(QgsProcessingAlgorithm):
    """Runs ``nightlights`` command lines; subclasses say which (:meth:`steps`)."""

    #: Algorithm id, title, group and help text (set by each subclass).
    NAME = ""
    TITLE = ""
    GROUP = ""
    HELP = ""
    #: The destination paths of the current run (set by :meth:`output_path`).
    outputs: dict[str, Any]

    def name(self) -> str:
        return self.NAME

    def displayName(self) -> str:
        return self.TITLE

    def group(self) -> str:
        return self.GROUP

    def groupId(self) -> str:
        return self.GROUP.lower().replace(" ", "")

    def shortHelpString(self) -> str:
        return self.HELP

    def createInstance(self) -> NightlightsAlgorithm:
        return type(self)()

    def steps(self, parameters: dict[str, Any], context: Any, feedback: Any) -> list[list[str]]:
        """The command lines to run in order, without the executable."""
        raise NotImplementedError

    def results(self, messages: list[str]) -> dict[str, Any]:
        """The outputs: the destination paths given to the commands (:meth:`output_path`),
        and what subclasses read from the commands' messages."""
        return dict(self.outputs)

    def processAlgorithm(self, parameters: dict[str, Any], context: Any, feedback: Any) -> dict:
        self.outputs = {}
        steps = self.steps(parameters, context, feedback)
        try:
            command = find_command(_command_setting())
        except CommandError as exc:
            raise QgsProcessingException(str(exc)) from exc
        messages: list[str] = []
        for index, arguments in enumerate(steps):
            if feedback.isCanceled():
                break
            line = [*command, *arguments]
            feedback.pushCommandInfo(" ".join(_quoted(part) for part in line))
            words = " ".join(_command_words(arguments))
            title = f"nightlights {words}"
            if len(steps) > 1:
                title += f" ({index + 1} of {len(steps)})"
                feedback.setProgressText(title)

            def remaining(text: str, title: str = title) -> None:
                feedback.setProgressText(f"{title}: about {text} left")

            def progress(fraction: float, index: int = index) -> None:
                feedback.setProgress(100.0 * (index + fraction) / len(steps))

            try:
                result = run_command(
                    line,
                    on_progress=progress,
                    on_message=lambda line: _log(feedback, line),
                    is_canceled=feedback.isCanceled,
                    on_remaining=remaining,
                )
            except (CommandCanceled, CommandError) as exc:
                raise QgsProcessingException(f"{self.TITLE}: {exc}") from exc
            messages.extend(result.messages)
            progress(1.0)
        if feedback.isCanceled():
            raise QgsProcessingException(f"{self.TITLE}: cancelled")
        return self.results(messages)

    # --- parameters to command-line arguments ---------------------------------------------

    def vector_path(
        self, parameters: dict[str, Any], name: str, context: Any, feedback: Any
    ) -> str:
        """The file of a vector input whose layer is the one the toolkit reads by default (the
        file's first; a GeoPackage's ``layer_styles`` table comes after its data)."""
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, name, context, VECTOR_FORMATS, "gpkg", feedback
        )
        if layer and _first_layer(path) != layer:  # another layer of the file: export it
            path = self.parameterAsCompatibleSourceLayerPath(
                parameters, name, context, ["gpkg"], "gpkg", feedback
            )
        return path

    def raster_path(self, parameters: dict[str, Any], name: str, context: Any) -> str | None:
        """The file of a raster input (None for an optional one left empty)."""
        layer = self.parameterAsRasterLayer(parameters, name, context)
        if layer is None:
            return None
        parts = QgsProviderRegistry.instance().decodeUri(layer.providerType(), layer.source())
        path = parts.get("path") or ""
        if layer.providerType() != "gdal" or not os.path.isfile(path):
            raise QgsProcessingException(
                f"{layer.name()}: not a raster file ({layer.source()}); save it as a GeoTIFF first"
            )
        return str(path)

    def output_path(
        self, parameters: dict[str, Any], name: str, context: Any, *, layer: bool = True
    ) -> str:
        """The path of a destination parameter (a layer, or a file with ``layer=False``),
        recorded as that output's result (QGIS names a temporary output anew at each call)."""
        if layer:
            path = self.parameterAsOutputLayer(parameters, name, context)
        else:
            path = self.parameterAsFileOutput(parameters, name, context)
        self.outputs[name] = path or None
        return str(path or "")

    def temporary_path(self, name: str) -> str:
        """A new path in QGIS's temporary folder (a folder of its own per call)."""
        return str(QgsProcessingUtils.generateTempFilename(name))


def _first_layer(path: str) -> str | None:
    """The name of the first layer of a vector file (read with QGIS's own GDAL)."""
    from osgeo import ogr

    source = ogr.Open(path)
    if source is None or source.GetLayerCount() == 0:
        return None
    return str(source.GetLayer(0).GetName())


def _command_words(arguments: list[str]) -> list[str]:
    """The (sub)command names that start a command line, e.g. ``streets sample``."""
    words = []
    for argument in arguments:
        if not re.fullmatch(r"[a-z][a-z-]*", argument):
            break
        words.append(argument)
    return words


def _log(feedback: Any, line: str) -> None:
    """A line of the command in QGIS's log: its warnings (``WARNING ...``) as warnings."""
    if line.startswith("WARNING "):
        feedback.pushWarning(line)
    else:
        feedback.pushInfo(line)


def _command_setting() -> str | None:
    """The provider's setting naming the ``nightlights`` command (empty when unset)."""
    try:
        from processing.core.ProcessingConfig import ProcessingConfig
    except ImportError:  # the Processing plugin is not loaded: no settings
        return None
    value = ProcessingConfig.getSetting(COMMAND_SETTING)
    return str(value) if value else None


def _quoted(part: str) -> str:
    return f'"{part}"' if (" " in part or not part) else part
