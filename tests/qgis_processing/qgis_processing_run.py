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
4. ``nightlights:darkness`` over it;
5. ``nightlights:skyrender``: the night sky with the panorama of 2, at a point given in UTM
   that the algorithm hands on in longitude and latitude;

for MODE ``stages`` (INPUT: a folder with a small ``emission.tif`` and ``observers.gpkg`` in
UTM 35N, :data:`SMALL_OBSERVER` among the lit cells):

1. ``nightlights:kernelbuild``: a tiny kernel (3 km, 8 distances, 8 x 16 directions, uplight);
2. ``nightlights:inverses`` with it: each cell's part of the glow within 30 deg of the zenith;
3. ``nightlights:inversedim`` by that raster (no dimming below 0, all above half its maximum),
   with the dimming raster and the summary;
4. ``nightlights:inverseplan``: the least dimming that brings every point of the observers'
   layer to a zenith of :data:`TARGET_ZENITH`;
5. ``nightlights:skyobservers``: the skies of the observers' layer.

Prints one JSON object: the provider's algorithms with their parameters and outputs, and for
each run its outputs as QGIS opens them (validity, CRS, extent, features or bands and
statistics), the progress values reported and the log, or the error.
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
#: The stages run's observer, in UTM 35N [m], and its target zenith [mag arcsec-2].
SMALL_OBSERVER = "501000,6699000 [EPSG:32635]"
TARGET_ZENITH = 23.0
#: The tiny kernel of the stages run (covers the 2 km square of its emission).
TINY_KERNEL = {"R_MAX": 3000.0, "N_DISTANCE": 8, "N_ELEVATION": 8, "N_AZIMUTH": 16, "UPLIGHT": True}


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
    report["algorithms"] = {
        algorithm.id(): {
            "parameters": [p.name() for p in algorithm.parameterDefinitions()],
            "types": [p.type() for p in algorithm.parameterDefinitions()],
            "outputs": [o.name() for o in algorithm.outputDefinitions()],
            "group": algorithm.group(),
        }
        for algorithm in (provider.algorithms() if provider else [])
    }
    report.update({"light": light, "sky": sky, "stages": stages}[mode](source, work))
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
    report["skyrender"] = _run(
        "nightlights:skyrender",
        {
            "OUTPUT": f"{work}/sky.png",
            "TIME": "2024-01-15T22:00:00",
            "LONLAT": f"{_utm(*OBSERVER)} [EPSG:32635]",
            "PANORAMA": f"{work}/skyglow.nc",
            "WIDTH": 240,
            "HEIGHT": 120,
        },
        _feedback(),
    )
    return report


def _utm(longitude: float, latitude: float) -> str:
    """A longitude and latitude [deg] as x,y in UTM 35N [m], transformed by QGIS."""
    from qgis.core import (
        QgsCoordinateReferenceSystem,
        QgsCoordinateTransform,
        QgsPointXY,
        QgsProject,
    )

    transform = QgsCoordinateTransform(
        QgsCoordinateReferenceSystem("EPSG:4326"),
        QgsCoordinateReferenceSystem("EPSG:32635"),
        QgsProject.instance(),
    )
    point = transform.transform(QgsPointXY(longitude, latitude))
    return f"{point.x()!r},{point.y()!r}"


def stages(folder: str, work: str) -> dict[str, Any]:
    """A tiny kernel, then inverse s, the dimming rule, the least dimming and the skies of many
    observers with it, on the small scene in ``folder``."""
    report: dict[str, Any] = {}
    emission, observers, kernel = (
        f"{folder}/emission.tif",
        f"{folder}/observers.gpkg",
        f"{work}/kernel.nc",
    )
    report["kernelbuild"] = _run(
        "nightlights:kernelbuild", {**TINY_KERNEL, "OUTPUT": kernel}, _feedback()
    )
    s = f"{work}/s.tif"
    run = _run(
        "nightlights:inverses",
        {
            "EMISSION": emission,
            "OBSERVER": SMALL_OBSERVER,
            "KERNEL": kernel,
            "REGION": "zenith:30",
            "OUTPUT": s,
        },
        _feedback(),
    )
    report["inverses"] = {**run, "layer": _raster(s) if "error" not in run else None}
    if "error" in run:
        return report
    (band,) = report["inverses"]["layer"]["bands"]
    report["qb"] = band["max"] / 2
    dimmed = f"{work}/dimmed.tif"
    run = _run(
        "nightlights:inversedim",
        {
            "EMISSION": emission,
            "BY": s,
            "QA": 0.0,
            "QB": report["qb"],
            "KERNEL": kernel,
            "OUTPUT": dimmed,
            "DIMMING_OUTPUT": f"{work}/dimming.tif",
            "SUMMARY_OUTPUT": f"{work}/dim_summary.json",
        },
        _feedback(),
    )
    report["inversedim"] = {**run, "layer": _raster(dimmed) if "error" not in run else None}
    planned = f"{work}/planned.tif"
    run = _run(
        "nightlights:inverseplan",
        {
            "EMISSION": emission,
            "OBSERVERS": observers,
            "TARGET_ZENITH": TARGET_ZENITH,
            "KERNEL": kernel,
            "OUTPUT": planned,
            "SUMMARY_OUTPUT": f"{work}/plan_summary.json",
        },
        _feedback(),
    )
    report["inverseplan"] = {**run, "layer": _raster(planned) if "error" not in run else None}
    summary = f"{work}/observers_summary.gpkg"
    run = _run(
        "nightlights:skyobservers",
        {"EMISSION": emission, "OBSERVERS": observers, "KERNEL": kernel, "SUMMARY": summary},
        _feedback(),
    )
    report["skyobservers"] = {**run, "layer": _vector(summary) if "error" not in run else None}
    return report


if __name__ == "__main__":
    import os

    print(json.dumps(main(*sys.argv[1:5])), flush=True)
    os._exit(0)  # skip QGIS's teardown, which can crash a headless application at exit
