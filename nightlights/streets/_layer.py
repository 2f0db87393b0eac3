"""The input of a street stage: a layer in memory or a file to read."""

from __future__ import annotations

import os

import geopandas as gpd

from nightlights._typing import PathLike
from nightlights.errors import InputError
from nightlights.io import read_vector

#: How messages name a layer that was passed in memory rather than read from a file.
IN_MEMORY = "in-memory layer"


def read_layer(
    layer: gpd.GeoDataFrame | PathLike, *, name: str | None = None
) -> tuple[gpd.GeoDataFrame, str]:
    """The layer itself and the name messages give it.

    Parameters
    ----------
    layer
        A GeoDataFrame (used as it is, not copied) or a path to any vector file GDAL reads.
    name
        Layer inside the file (default: the first; ``lines`` for OSM files). Only for paths.

    Returns
    -------
    frame : geopandas.GeoDataFrame
        The layer.
    source : str
        The path, or :data:`IN_MEMORY`.

    Raises
    ------
    InputError
        ``layer`` is neither a GeoDataFrame nor a path, a layer name was given with a
        GeoDataFrame, or the file cannot be read.
    """
    if isinstance(layer, gpd.GeoDataFrame):
        if name is not None:
            raise InputError(
                f"layer={name!r} names a layer inside a file, but the streets are a GeoDataFrame"
            )
        return layer, IN_MEMORY
    if not isinstance(layer, str | os.PathLike):
        raise InputError(
            f"streets: got {type(layer).__name__}; expected a GeoDataFrame or a vector file path"
        )
    return read_vector(layer, layer=name), str(layer)
