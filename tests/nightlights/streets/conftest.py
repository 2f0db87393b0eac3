"""Hand-made street layers shared by the street stage tests."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import shapely

from nightlights.io import write_gpkg
from nightlights.streets.schema import STREET_FIELDS, observed_field


def write_normalized(layer: gpd.GeoDataFrame, path: Path) -> Path:
    """Write like ``streets normalize`` does: explicit (nullable) field types."""
    schema = {"source_id": "str", **STREET_FIELDS}
    schema |= {observed_field(name): "bool" for name in STREET_FIELDS}
    return write_gpkg(layer, path, layer="streets", schema=schema)


def normalized_layer(rows: list[dict]) -> gpd.GeoDataFrame:
    """Normalised streets in EPSG:3067; a field is observed where it is given."""
    n = len(rows)
    data: dict[str, list] = {"source_id": [f"way/{i}" for i in range(n)]}
    for name in STREET_FIELDS:
        data[name] = [row.get(name) for row in rows]
        data[observed_field(name)] = [name in row for row in rows]
    lines = [
        shapely.LineString([(385000 + 50 * i, 6672000), (385000 + 50 * i, 6672120)])
        for i in range(n)
    ]
    return gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067")
