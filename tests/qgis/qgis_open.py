"""Open files in QGIS and report what QGIS sees: run by the system Python that has PyQGIS.

Usage: ``QT_QPA_PLATFORM=offscreen /usr/bin/python3 qgis_open.py FILE...`` (a GeoPackage as
``FILE.gpkg|layername=NAME``). Prints one JSON object: for each file its validity, CRS (WKT),
extent, renderer type, the style it loaded by default (the ``.qml`` beside a raster or the
``layer_styles`` row of a GeoPackage layer), and, rendered alone onto a 256 x 256 image, the
number of distinct colours and of painted pixels. It imports nothing from the toolkit: QGIS's
Python must not load the toolkit's wheels (they bundle another GDAL). With the environment
variable ``QGIS_OPEN_PNG_DIR`` set, each rendered image is saved there as a PNG.
"""

from __future__ import annotations

import json
import os
import sys


def _render(layer, size=256, save=None):  # type: ignore[no-untyped-def]
    from qgis.core import QgsMapRendererSequentialJob, QgsMapSettings
    from qgis.PyQt.QtCore import QSize
    from qgis.PyQt.QtGui import QColor

    settings = QgsMapSettings()
    settings.setLayers([layer])
    settings.setDestinationCrs(layer.crs())
    settings.setExtent(layer.extent())
    settings.setOutputSize(QSize(size, size))
    settings.setBackgroundColor(QColor(0, 0, 0, 0))
    job = QgsMapRendererSequentialJob(settings)
    job.start()
    job.waitForFinished()
    image = job.renderedImage()
    if save:
        image.save(save)
    colours = set()
    painted = 0
    for y in range(0, image.height(), 2):
        for x in range(0, image.width(), 2):
            pixel = image.pixel(x, y)
            if (pixel >> 24) & 0xFF:
                painted += 1
                colours.add(pixel)
    return len(colours), painted


def _open(source: str) -> dict[str, object]:
    from qgis.core import QgsRasterLayer, QgsVectorLayer

    path = source.split("|")[0]
    if path.endswith((".tif", ".tiff")):
        layer = QgsRasterLayer(source, "raster")
        kind = "raster"
    else:
        layer = QgsVectorLayer(source, "vector", "ogr")
        kind = "vector"
    report: dict[str, object] = {"source": source, "kind": kind, "valid": layer.isValid()}
    if not layer.isValid():
        report["error"] = layer.error().summary()
        return report
    extent = layer.extent()
    report.update(
        crs_wkt=layer.crs().toWkt(),
        crs_valid=layer.crs().isValid(),
        crs_authid=layer.crs().authid(),
        extent=[extent.xMinimum(), extent.yMinimum(), extent.xMaximum(), extent.yMaximum()],
    )
    if kind == "raster":
        renderer = layer.renderer()
        report["renderer"] = renderer.type()
        report["band"] = renderer.usesBands()
        shader = getattr(renderer, "shader", lambda: None)()
        function = shader.rasterShaderFunction() if shader is not None else None
        if function is not None:
            items = function.colorRampItemList()
            report["ramp"] = [[item.value, item.color.name(), item.label] for item in items]
            report["ramp_type"] = int(function.colorRampType())
        report["bands"] = [layer.bandName(i) for i in range(1, layer.bandCount() + 1)]
        transparency = renderer.rasterTransparency()
        report["transparent_values"] = (
            [
                [p.min, p.max, p.percentTransparent]
                for p in transparency.transparentSingleValuePixelList()
            ]
            if transparency is not None
            else []
        )
    else:
        renderer = layer.renderer()
        report["renderer"] = renderer.type()
        report["features"] = layer.featureCount()
        report["geometry_type"] = int(layer.geometryType())
        attribute = getattr(renderer, "classAttribute", lambda: None)()
        report["attribute"] = attribute
        if renderer.type() == "categorizedSymbol":
            report["classes"] = [c.value() for c in renderer.categories()]
        elif renderer.type() == "graduatedSymbol":
            report["classes"] = [[r.lowerValue(), r.upperValue()] for r in renderer.ranges()]
        symbol = renderer.symbols(_context())[0] if renderer.symbols(_context()) else None
        if symbol is not None:
            properties = symbol.symbolLayer(0).dataDefinedProperties()
            angle = (
                properties.property(properties.propertyKeys()[0])
                if properties.propertyKeys()
                else None
            )
            report["data_defined"] = angle.field() if angle is not None else None
        report["labels"] = layer.labelsEnabled()
    folder = os.environ.get("QGIS_OPEN_PNG_DIR")
    save = (
        os.path.join(folder, os.path.basename(path) + f".{len(os.listdir(folder))}.png")
        if folder
        else None
    )
    report["colours"], report["painted"] = _render(layer, save=save)
    return report


def _context():  # type: ignore[no-untyped-def]
    from qgis.core import QgsRenderContext

    return QgsRenderContext()


def main(sources: list[str]) -> int:
    from qgis.core import Qgis, QgsApplication

    app = QgsApplication([], False)
    app.initQgis()
    try:
        reports = [_open(source) for source in sources]
    finally:
        app.exitQgis()
    json.dump({"qgis": Qgis.QGIS_VERSION, "layers": reports}, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
