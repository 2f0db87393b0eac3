"""The commented project template that ``nightlights init`` writes."""

from __future__ import annotations

import os
from pathlib import Path

from nightlights.io.atomic import atomic_output

#: The template: every table and key, the common ones set, the others commented out.
TEMPLATE = """\
# nightlights project: run it with `nightlights run THIS_FILE.toml`.
# Paths are relative to this file. Stage options carry the command line's names
# (`along-jitter` is `--along-jitter`); a stage runs when its [stages.NAME] table is present.
# The whole file is checked before any stage runs; a stage whose inputs and options have not
# changed since its last run is skipped (`--force STAGE` reruns it and what follows).

[project]
name = "my city"
output = "nightlights-out"        # output folder
seed = 1                          # random seed of sample and place (same seed, same output)
# credit = "(c) OpenStreetMap contributors, ODbL"   # printed on the maps

[inputs]
# Exactly one of streets, emission, viirs:
streets = "streets.gpkg"          # any street layer GDAL reads (GeoPackage, Shapefile, .osm.pbf)
# emission = "emission.tif"       # an upward flux density raster [lm m-2] (skips the streets)
# viirs = "viirs.tif"             # a VIIRS day/night band raster [nW cm-2 sr-1]
# dem = "dem.tif"                 # terrain heights above sea level [m]
mapping = "osm"                   # field mapping: osm, municipal or a mapping TOML file
# network = "europe"              # Bayesian network: east_asia, europe, generic, helsinki,
                                  # north_america or a network folder (default: from where
                                  # the streets lie)
# catalog = "luminaires/"         # luminaire database folder (default: the bundled one)

[observers]
crs = "EPSG:4326"                 # CRS of the points (default: the data's)
height = 1.7                      # eye height above the ground [m]
points = { site = [24.9480, 60.1675] }   # name = [x, y]; names become parts of file names
# file = "observers.gpkg"         # or a point layer (instead of points) ...
# layer = "observers"
# name-field = "name"             # ... with the observers' names in this field

[atmosphere]
turbidity = 2.0                   # aerosol turbidity T (>= 1)

# One kernel for every sky stage (built once, then cached). Without this table each sky stage
# builds a scene kernel sized to its observer (stages take n-azimuth, n-elevation, n-distance).
[kernel]
r-min = 10.0                      # inner distance [m]
r-max = 20000.0                   # outer distance [m]: observers farther from the data are refused
n-distance = 48
n-elevation = 32
n-azimuth = 128
uplight = true                    # tables for the luminaires' direct uplight (stages.emission)

[stages.normalize]
# layer = "lines"                 # input layer (default: the first; lines for OSM)
# crs = "EPSG:3067"               # CRS of an input that has none
# target-crs = "EPSG:3067"        # projected output CRS (default: the input's or local UTM)

[stages.sample]
candidates = 128                  # likelihood-weighting candidates per segment
on-conflict = "error"             # impossible evidence: error or relax

[stages.place]
# along-jitter = 0.05             # fraction of the spacing [1]
# across-jitter = 0.2             # [m]
# merge-fraction = 0.5            # [1]

[stages.irradiance]
resolution = 1.0                  # pixel size [m]
sensor = ["photopic"]             # photopic, scotopic, cie_x, cie_y, cie_z, melanopic, ...
threshold = "floor:0.01"          # region of influence: energy:FRACTION, floor:LUX or none
max-radius = 1000.0               # [m]
map = true                        # also irradiance.png
# bounds = [xmin, ymin, xmax, ymax]   # output extent in the lights' CRS [m]
# map-window = [xmin, ymin, xmax, ymax]  # an enlarged window in the map [m]

[stages.emission]
resolution = 50.0                 # cell size [m]
albedo = 0.15                     # ground albedo [1], or an albedo raster

# [stages.emission-viirs]         # with inputs.viirs instead of the three street stages
# spectrum = "LED_4000K"
# emission-function = "lambertian"

[stages.skyglow]                  # a panorama per observer
png = true
projection = "fisheye"            # equirectangular or fisheye, or per observer:
                                  # { site = "fisheye" } (others equirectangular)
# observer = ["site"]             # only these observers (default: all)
# mode = "pca"                    # pca, exact or naive
# bands = "V"                     # V or RGB

# [stages.observers]              # one summary point layer for all observers
# panoramas = false
# top-cells = 5
# scheduler = "threads"           # threads, processes or synchronous

# [stages.inverse-q]              # each lit cell's part of an observer's sky
# metric = "zenith"               # pca-norm, zenith or hemisphere

# [stages.inverse-s]              # each lit cell's part of a region of the sky
# region = "zenith:30"            # zenith:R, horizon:AZ1,AZ2,EL, 'az,el az,el ...'

# [stages.inverse-reduce]         # dim the emission by an inverse map
# by = "inverse-s"                # inverse-q or inverse-s
# observer = "site"               # whose map (when that stage runs for several)
# qa = "50%"                      # no dimming below (a value, or a percentile of the lit cells)
# qb = "90%"                      # full dimming above
# gamma = 1.0                     # fraction of flux removed above qb

# [stages.darkness]               # zenith brightness with the observer at every cell
"""


def write_template(path: str | os.PathLike[str]) -> Path:
    """Write :data:`TEMPLATE` to ``path`` (atomically, replacing a file there).

    Parameters
    ----------
    path
        The project file to write.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    target = Path(path)
    with atomic_output(target) as temporary:
        temporary.write_text(TEMPLATE, encoding="utf-8")
    return target
