"""File input and output: the only place the toolkit touches files.

Vector layers are read with pyogrio (any format GDAL reads) and written as GeoPackage with
explicit field types; rasters are written as float32 Cloud-Optimised GeoTIFFs, whole
(:func:`write_cog`) or window by window when they are too large to hold (:class:`CogWriter`).
Every write is atomic: the output appears complete or not at all, and a stage's several outputs
(:class:`OutputSet`) appear all together or not at all.
"""

from nightlights.io.atomic import atomic_output
from nightlights.io.crs import ensure_projected
from nightlights.io.outputs import OutputSet, Terminated
from nightlights.io.raster import Raster, RasterBand, as_raster, source_label, write_cog
from nightlights.io.streamed import CogWriter
from nightlights.io.terrain import raster_on_grid, sample_raster
from nightlights.io.vector import as_vector, read_vector, write_gpkg

__all__ = [
    "CogWriter",
    "OutputSet",
    "Raster",
    "RasterBand",
    "Terminated",
    "as_raster",
    "as_vector",
    "atomic_output",
    "ensure_projected",
    "raster_on_grid",
    "read_vector",
    "sample_raster",
    "source_label",
    "write_cog",
    "write_gpkg",
]
