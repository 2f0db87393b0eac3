"""Choices of the algorithms' parameters, mirrored from the toolkit.

QGIS's Python does not import the toolkit (see ``runner``), so the lists the commands accept are
copied here; the toolkit's tests check that each equals the library's.
"""

from __future__ import annotations

#: ``nightlights.streets.builtin_mappings()``: field mappings of ``streets normalize``.
MAPPINGS = ("municipal", "osm")
#: ``bayesnets.catalog_names()``: the networks of ``streets sample``.
NETWORKS = ("east_asia", "europe", "generic", "helsinki", "north_america")
#: ``ies.spectra.SENSORS``: the bands of ``irradiance`` (photopic gives lx, the others W m-2).
SENSORS = (
    "photopic",
    "scotopic",
    "cie_x",
    "cie_y",
    "cie_z",
    "melanopic",
    "nvis_class_a",
    "nvis_class_b",
)
#: ``nightlights.sky.render.PROJECTIONS``: pictures of ``skyglow --png``.
PROJECTIONS = ("equirectangular", "fisheye")
#: ``nightlights.sky.influence.METRICS``: what ``inverse q`` maps per lit cell.
Q_METRICS = ("pca-norm", "zenith", "hemisphere")
#: ``nightlights.ground.upward.DEFAULT_VIIRS_SPECTRUM``: spectrum of ``emission viirs``.
DEFAULT_VIIRS_SPECTRUM = "LED_4000K"
