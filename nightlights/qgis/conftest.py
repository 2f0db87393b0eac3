"""pytest: the plugin's modules that import QGIS run in QGIS's Python only.

The toolkit's interpreter has no ``qgis`` module (and must not load QGIS's GDAL beside its
own), so its doctest collection skips them; ``tests/qgis_processing`` runs them in QGIS.
"""

collect_ignore = [
    "plugin/algorithms.py",
    "plugin/base.py",
    "plugin/plugin.py",
    "plugin/provider.py",
]
