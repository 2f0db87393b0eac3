"""Vector layers: read anything GDAL reads, write GeoPackage with explicit field types.

GeoPackages are written as version 1.2 (:data:`GPKG_VERSION`) so that GDAL 3.6 and the QGIS
built on it (Debian 12) open them without a version warning, with the layer's QGIS style, when
given one, in the ``layer_styles`` table (:mod:`nightlights.io.styles`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import geopandas as gpd
import numpy as np
import pandas as pd
import pyogrio

from nightlights._resources import check_memory
from nightlights.errors import InputError, OutputError
from nightlights.io.atomic import atomic_output
from nightlights.io.styles import STYLES_TABLE, LayerStyle, add_layer_style

FieldType = Literal["int", "float", "bool", "str"]

_OSM_SUFFIXES = (".pbf", ".osm", ".osm.gz", ".osm.bz2")

#: Bytes per feature of a layer read and normalised besides its fields: the geometry, the
#: index, the copies a stage makes; with :data:`BYTES_PER_FIELD` 2.7 KB measured per feature of
#: 11 fields (peak resident memory of ``streets normalize``, 136 800 OpenStreetMap lines) [B].
BYTES_PER_FEATURE = 2048.0
#: Bytes per field and feature (an object or float column and its copies) [B].
BYTES_PER_FIELD = 128.0
#: Bytes per byte of a file whose features GDAL cannot count without reading it all (an
#: OpenStreetMap extract: compressed nodes and ways) [1].
BYTES_PER_FILE_BYTE = 64.0
#: GeoPackage version written (OGC 12-128r15, GeoPackage 1.2.1): GDAL 3.7 and later default
#: to 1.4, which GDAL 3.6 (Debian 12's, under its QGIS 3.22) opens with a warning.
GPKG_VERSION = "1.2"


def read_vector(
    path: str | os.PathLike[str], *, layer: str | int | None = None
) -> gpd.GeoDataFrame:
    """Read a vector layer from any format pyogrio/GDAL reads.

    GeoPackage, Shapefile, GeoJSON, FlatGeobuf and OpenStreetMap (.pbf, .osm, .osm.gz) are
    all read the same way. For OSM files the default layer is ``lines`` (GDAL's OSM driver
    puts highway ways there, with unlisted tags packed in ``other_tags``); for a GeoPackage
    it is the first layer other than the ``layer_styles`` table of its QGIS styles.

    Parameters
    ----------
    path
        File to read.
    layer
        Layer name or index. Default: the first layer (``lines`` for OSM files).

    Raises
    ------
    InputError
        The file does not exist or GDAL cannot read it.
    ResourceError
        The layer's memory estimate (:func:`vector_memory`) is over the limit; checked before
        it is read.
    """
    source = Path(path)
    if not source.exists():
        raise InputError(f"{source}: no such file")
    name = source.name.lower()
    if str(source).endswith(".gz") and name.endswith(".osm.gz"):
        read_path: str = f"/vsigzip/{source}"
    else:
        read_path = str(source)
    if layer is None and name.endswith(_OSM_SUFFIXES):
        layer = "lines"
    elif layer is None and name.endswith(".gpkg"):
        layer = _first_data_layer(source)
    check_memory(
        vector_memory(read_path, layer=layer, file_bytes=source.stat().st_size),
        f"reading {source}",
        option="read a smaller extract of it",
    )
    try:
        frame = pyogrio.read_dataframe(read_path, layer=layer)
    except (pyogrio.errors.DataSourceError, pyogrio.errors.DataLayerError) as exc:
        raise InputError(f"{source}: cannot read vector layer {layer!r}: {exc}") from exc
    if "geometry" not in frame or not isinstance(frame, gpd.GeoDataFrame):
        raise InputError(f"{source}: layer {layer!r} has no geometry column")
    return frame


def vector_memory(
    path: str | os.PathLike[str], *, layer: str | int | None = None, file_bytes: int = 0
) -> float:
    """Estimated memory of a vector layer read into a GeoDataFrame and handled by a street
    stage [B].

    From the layer's header when GDAL counts its features without reading them:
    :data:`BYTES_PER_FEATURE` plus :data:`BYTES_PER_FIELD` per field and feature; else (an
    OpenStreetMap file) :data:`BYTES_PER_FILE_BYTE` per byte of the file.

    Parameters
    ----------
    path
        The file (as GDAL opens it: ``/vsigzip/...`` for a compressed OSM file).
    layer
        The layer (default: GDAL's first).
    file_bytes
        Size of the file [B].

    Returns
    -------
    float
        Bytes (0 when the header cannot be read: the reader reports that).
    """
    try:
        info = pyogrio.read_info(path, layer=layer)
    except (pyogrio.errors.DataSourceError, pyogrio.errors.DataLayerError, ValueError):
        return 0.0
    features = int(info.get("features", -1))
    fields = len(info.get("fields", ()))
    if features < 0:
        return BYTES_PER_FILE_BYTE * float(file_bytes)
    return float(features) * (BYTES_PER_FEATURE + BYTES_PER_FIELD * fields)


def _first_data_layer(source: Path) -> str | None:
    """The first layer of a GeoPackage that is not its ``layer_styles`` table (None: let GDAL
    choose, as for a file with one layer or one that GDAL cannot list)."""
    try:
        names = [str(row[0]) for row in pyogrio.list_layers(source)]
    except pyogrio.errors.DataSourceError:
        return None
    data = [layer for layer in names if layer != STYLES_TABLE]
    return data[0] if data and len(names) > 1 else None


def as_vector(
    source: gpd.GeoDataFrame | str | os.PathLike[str],
    *,
    layer: str | None = None,
    name: str = "layer",
) -> tuple[gpd.GeoDataFrame, str]:
    """A vector input of a stage, in memory or read from a file, and how messages name it.

    Parameters
    ----------
    source
        A GeoDataFrame (used as it is, not copied) or a path to any vector file GDAL reads.
    layer
        Layer inside the file (default: the first; ``lines`` for OSM files). Only for paths.
    name
        What the input is (``streets``, ``lights``), for messages about an in-memory layer.

    Returns
    -------
    frame : geopandas.GeoDataFrame
        The layer.
    label : str
        The path, or ``in-memory <name>``.

    Raises
    ------
    InputError
        ``source`` is neither a GeoDataFrame nor a path, a layer name was given with a
        GeoDataFrame, or the file cannot be read.
    """
    if isinstance(source, gpd.GeoDataFrame):
        if layer is not None:
            raise InputError(
                f"layer={layer!r} names a layer inside a file, but the {name} are a GeoDataFrame"
            )
        return source, f"in-memory {name}"
    if not isinstance(source, str | os.PathLike):
        raise InputError(
            f"{name}: got {type(source).__name__}; expected a GeoDataFrame or a vector file path"
        )
    return read_vector(source, layer=layer), str(source)


def write_gpkg(
    frame: gpd.GeoDataFrame,
    path: str | os.PathLike[str],
    *,
    layer: str,
    schema: Mapping[str, FieldType] | None = None,
    style: LayerStyle | None = None,
) -> Path:
    """Write ``frame`` to a GeoPackage (version 1.2) atomically, with explicit field types.

    Parameters
    ----------
    frame
        Layer to write; must have a CRS.
    path
        Output ``.gpkg`` path; replaced atomically if it exists.
    layer
        Layer name inside the GeoPackage.
    schema
        Field name to type (``int``, ``float``, ``bool``, ``str``). Listed fields are cast,
        with missing values kept as nulls; unlisted fields keep their dtype.
    style
        QGIS style stored as the layer's default in the ``layer_styles`` table
        (:func:`~nightlights.io.styles.add_layer_style`); None stores none.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    if frame.crs is None:
        raise OutputError(f"{path}: refusing to write a layer without a CRS")
    out = frame.copy()
    for column, kind in (schema or {}).items():
        if column not in out:
            raise OutputError(f"{path}: schema names field {column!r} that the layer lacks")
        out[column] = _cast(out[column], kind)
    with atomic_output(path) as tmp:
        pyogrio.write_dataframe(
            out, tmp, layer=layer, driver="GPKG", dataset_options={"VERSION": GPKG_VERSION}
        )
        if style is not None:
            geometry_column = pyogrio.read_info(tmp, layer=layer)["geometry_name"] or "geom"
            add_layer_style(tmp, layer, style, geometry_column=geometry_column)
    return Path(path)


def _cast(values: pd.Series, kind: FieldType) -> pd.Series:
    if kind == "float":
        return pd.to_numeric(values, errors="raise").astype("float64")
    if kind == "int":
        numeric = pd.to_numeric(values, errors="raise")
        return numeric.astype("Int64") if numeric.isna().any() else numeric.astype("int64")
    if kind == "bool":
        if values.isna().any():
            return values.astype("boolean")
        return values.astype(bool)
    if kind == "str":
        return values.where(values.isna(), values.astype(str)).astype(object)
    raise OutputError(f"unknown field type {kind!r}; expected int, float, bool or str")


def empty_like(frame: gpd.GeoDataFrame) -> gpd.GeoDataFrame:
    """An empty layer with the columns and CRS of ``frame``."""
    return frame.iloc[np.zeros(0, dtype=int)].copy()
