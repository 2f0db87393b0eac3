"""Run the plugin's algorithms in QGIS and report what came out: run by the system Python that
has PyQGIS, never by the toolkit's.

Usage: ``QT_QPA_PLATFORM=offscreen /usr/bin/python3 qgis_processing_run.py MODE PLUGINS
INPUT WORK``: PLUGINS is a QGIS plugin folder holding the unzipped plugin, WORK a folder for
the outputs. It loads the plugin as QGIS does (metadata, ``classFactory``,
``initProcessing``), then with ``processing.run``, for MODE ``light`` (INPUT: a street line
layer, ``FILE|layername=NAME``):

1. ``nightlights:streetstolights`` on INPUT;
2. ``nightlights:irradiance`` on the lights of 1, two sensors at 5 m;
3. ``nightlights:irradiance`` again, as the Processing dialog runs it (a task on a worker
   thread), cancelled as soon as its command starts;

for MODE ``sky`` (INPUT: a folder with the ``lights.gpkg`` and ``irradiance.tif`` of ``light``):

1. ``nightlights:emission`` of those at 50 m;
2. ``nightlights:skyglow`` over it for an observer given in longitude and latitude;
3. ``nightlights:inverseq`` for that observer: each cell's part of the zenith luminance;
4. ``nightlights:darkness`` over it.

Prints one JSON object: for each run its outputs as QGIS opens them (validity, CRS, extent,
features or bands and statistics), the progress values reported and the log, or the error.
"""

from __future__ import annotations

import json
import sys
from typing import Any

PLUGIN = "nightlights_processing"
#: Processing's own Python plugin on Debian/Ubuntu.
PROCESSING_PLUGINS = "/usr/share/qgis/python/plugins"
#: The sky run's observer: Esplanadi park in central Helsinki (longitude, latitude) [deg].
OBSERVER = (24.9480, 60.1675)


def _feedback(cancel_on_start: bool = False) -> Any:
    from qgis.core import QgsProcessingFeedback

    class Recorder(QgsProcessingFeedback):
        """Keeps the progress values and messages; optionally cancels when a command starts."""

        def __init__(self) -> None:
            super().__init__()
            self.progress: list[float] = []
            self.log: list[str] = []
            self.progressChanged.connect(self.progress.append)

        def pushInfo(self, info: str) -> None:
            self.log.append(info)

        def reportError(self, error: str, fatalError: bool = False) -> None:
            self.log.append(error)

        def pushCommandInfo(self, info: str) -> None:
            self.log.append(info)
            if cancel_on_start:
                self.cancel()

    return Recorder()


def _vector(path: str) -> dict[str, Any]:
    from qgis.core import QgsVectorLayer, QgsWkbTypes

    layer = QgsVectorLayer(path, "lights", "ogr")
    if not layer.isValid():
        return {"valid": False}
    extent = layer.extent()
    return {
        "valid": True,
        "crs": layer.crs().authid(),
        "features": layer.featureCount(),
        "geometry": QgsWkbTypes.geometryDisplayString(layer.geometryType()),
        "fields": layer.fields().names(),
        "extent": [extent.xMinimum(), extent.yMinimum(), extent.xMaximum(), extent.yMaximum()],
    }


def _raster(path: str, sample: tuple[float, float] | None = None) -> dict[str, Any]:
    """A raster as QGIS opens it; ``sample``: a longitude and latitude [deg] to read."""
    from qgis.core import (
        QgsCoordinateReferenceSystem,
        QgsCoordinateTransform,
        QgsPointXY,
        QgsProject,
        QgsRasterBandStats,
        QgsRasterLayer,
    )

    layer = QgsRasterLayer(path, "raster", "gdal")
    if not layer.isValid():
        return {"valid": False, "error": layer.error().summary()}
    extent = layer.extent()
    provider = layer.dataProvider()
    bands = []
    for band in range(1, layer.bandCount() + 1):
        stats = provider.bandStatistics(band, QgsRasterBandStats.All)
        bands.append(
            {
                "description": provider.generateBandName(band),
                "min": stats.minimumValue,
                "max": stats.maximumValue,
                "mean": stats.mean,
                "sum": stats.sum,
            }
        )
    values = []
    if sample is not None:
        transform = QgsCoordinateTransform(
            QgsCoordinateReferenceSystem("EPSG:4326"), layer.crs(), QgsProject.instance()
        )
        point = transform.transform(QgsPointXY(*sample))
        values = [provider.sample(point, band)[0] for band in range(1, layer.bandCount() + 1)]
    return {
        "valid": True,
        "crs": layer.crs().authid(),
        "extent": [extent.xMinimum(), extent.yMinimum(), extent.xMaximum(), extent.yMaximum()],
        "pixel": [layer.rasterUnitsPerPixelX(), layer.rasterUnitsPerPixelY()],
        "bands": bands,
        "sample": values,
    }


def _run(algorithm: str, parameters: dict[str, Any], feedback: Any) -> dict[str, Any]:
    import time

    import processing
    from qgis.core import QgsProcessingException

    start = time.monotonic()
    try:
        result = {"outputs": processing.run(algorithm, parameters, feedback=feedback)}
    except QgsProcessingException as exc:
        result = {"error": str(exc)}
    seconds = time.monotonic() - start
    return {**result, "progress": feedback.progress, "log": feedback.log, "seconds": seconds}


def _run_task(algorithm: str, parameters: dict[str, Any], feedback: Any) -> dict[str, Any]:
    """Run ``algorithm`` as the Processing dialog does: a task on a worker thread."""
    import time

    from qgis.core import QgsApplication, QgsProcessingAlgRunnerTask, QgsProcessingContext
    from qgis.PyQt.QtCore import QEventLoop

    instance = QgsApplication.processingRegistry().createAlgorithmById(algorithm)
    context = QgsProcessingContext()
    task = QgsProcessingAlgRunnerTask(instance, parameters, context, feedback)
    loop = QEventLoop()
    result: dict[str, Any] = {}

    def executed(ok: bool, outputs: dict[str, Any]) -> None:
        result.update({"outputs": outputs} if ok else {"error": " ".join(feedback.log[-1:])})
        loop.quit()

    task.executed.connect(executed)
    start = time.monotonic()
    QgsApplication.taskManager().addTask(task)
    loop.exec_()
    seconds = time.monotonic() - start
    return {**result, "progress": feedback.progress, "log": feedback.log, "seconds": seconds}


def main(mode: str, plugins: str, source: str, work: str) -> dict[str, Any]:
    sys.path[:0] = [plugins, PROCESSING_PLUGINS]
    from qgis.core import QgsApplication

    application = QgsApplication([], False)
    application.initQgis()
    from processing.core.Processing import Processing

    Processing.initialize()
    import qgis.utils

    qgis.utils.plugin_paths = [plugins]
    qgis.utils.updateAvailablePlugins()
    report: dict[str, Any] = {
        "available": PLUGIN in qgis.utils.available_plugins,
        "metadata": {
            key: qgis.utils.pluginMetadata(PLUGIN, key)
            for key in ("name", "version", "qgisMinimumVersion", "hasProcessingProvider")
        },
        # as QGIS does at start-up: import the package, then classFactory and initProcessing
        "started": bool(qgis.utils.loadPlugin(PLUGIN) and qgis.utils.startProcessingPlugin(PLUGIN)),
    }
    registry = QgsApplication.processingRegistry()
    provider = registry.providerById("nightlights")
    report["algorithms"] = sorted(a.id() for a in provider.algorithms()) if provider else []
    report.update(light(source, work) if mode == "light" else sky(source, work))
    return report


def light(streets: str, work: str) -> dict[str, Any]:
    """Streets to lights, their irradiance, and a cancelled irradiance task."""
    report: dict[str, Any] = {}
    lights = f"{work}/lights.gpkg"
    run = _run(
        "nightlights:streetstolights",
        {"INPUT": streets, "MAPPING": 1, "NETWORK": 0, "SEED": 2011, "OUTPUT": lights},
        _feedback(),
    )
    report["streetstolights"] = {**run, "layer": _vector(lights) if "error" not in run else None}
    irradiance = f"{work}/irradiance.tif"
    run = _run(
        "nightlights:irradiance",
        {"LIGHTS": lights, "RESOLUTION": 5.0, "SENSORS": [0, 1], "OUTPUT": irradiance},
        _feedback(),
    )
    report["irradiance"] = {**run, "layer": _raster(irradiance) if "error" not in run else None}
    cancelled = f"{work}/cancelled.tif"
    report["cancelled"] = _run_task(
        "nightlights:irradiance",
        {"LIGHTS": lights, "RESOLUTION": 5.0, "OUTPUT": cancelled},
        _feedback(cancel_on_start=True),
    )
    return report


def sky(folder: str, work: str) -> dict[str, Any]:
    """Emission of the light run's outputs, then skyglow and inverse q at :data:`OBSERVER`, and
    darkness."""
    report: dict[str, Any] = {}
    emission = f"{work}/emission.tif"
    run = _run(
        "nightlights:emission",
        {
            "IRRADIANCE": f"{folder}/irradiance.tif",
            "LIGHTS": f"{folder}/lights.gpkg",
            "RESOLUTION": 50.0,
            "ALBEDO": 0.15,
            "OUTPUT": emission,
        },
        _feedback(),
    )
    report["emission"] = {**run, "layer": _raster(emission) if "error" not in run else None}
    longitude, latitude = OBSERVER
    run = _run(
        "nightlights:skyglow",
        {
            "EMISSION": emission,
            "OBSERVER": f"{longitude},{latitude} [EPSG:4326]",
            "OUTPUT": f"{work}/skyglow.nc",
            "PNG": f"{work}/skyglow.png",
        },
        _feedback(),
    )
    report["skyglow"] = run
    q = f"{work}/q_zenith.tif"
    run = _run(
        "nightlights:inverseq",
        {
            "EMISSION": emission,
            "OBSERVER": f"{longitude},{latitude} [EPSG:4326]",
            "METRIC": 1,
            "OUTPUT": q,
        },
        _feedback(),
    )
    report["inverseq"] = {**run, "layer": _raster(q) if "error" not in run else None}
    darkness = f"{work}/darkness.tif"
    run = _run("nightlights:darkness", {"EMISSION": emission, "OUTPUT": darkness}, _feedback())
    report["darkness"] = {
        **run,
        "layer": _raster(darkness, sample=OBSERVER) if "error" not in run else None,
    }
    return report


if __name__ == "__main__":
    import os

    print(json.dumps(main(*sys.argv[1:5])), flush=True)
    os._exit(0)  # skip QGIS's teardown, which can crash a headless application at exit
