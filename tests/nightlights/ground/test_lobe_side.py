"""The bundled light systems throw their light towards the street (their heading)."""

from __future__ import annotations

import geopandas as gpd
import numpy as np
import pytest
import rasterio
import shapely

from ies.library import load_library
from nightlights.ground import irradiance

ASYMMETRIC = ["street_led_small", "street_led_medium", "road_led_large", "road_hps"]


@pytest.mark.parametrize("system_id", ASYMMETRIC)
@pytest.mark.parametrize("heading", [0.0, 90.0, 225.0])
def test_illuminance_centroid_lies_on_the_heading_side(tmp_path, system_id, heading) -> None:
    """A placed pole faces the carriageway (heading); the system's street_azimuth C-plane
    must turn the photometric lobe that way, so the light lands on the street side."""
    assert system_id in load_library().systems
    lights = gpd.GeoDataFrame(
        {
            "light_id": [0],
            "system_id": [system_id],
            "heading": [heading],
            "mounting_height": [10.0],
            "arm_length": [0.0],
            "tilt": [0.0],
        },
        geometry=[shapely.Point(0, 0)],
        crs="EPSG:3067",
    )
    src, out = tmp_path / "one.gpkg", tmp_path / "one.tif"
    lights.to_file(src)
    irradiance(src, out, resolution=1.0, bounds=(-60, -60, 60, 60), progress=False)
    with rasterio.open(out) as dataset:
        lux = np.nan_to_num(dataset.read(1))
        transform = dataset.transform
    rows, cols = np.indices(lux.shape)
    x = transform.c + (cols + 0.5) * transform.a
    y = transform.f + (rows + 0.5) * transform.e
    cx, cy = (lux * x).sum() / lux.sum(), (lux * y).sum() / lux.sum()
    toward = np.array([np.sin(np.radians(heading)), np.cos(np.radians(heading))])
    along = cx * toward[0] + cy * toward[1]
    across = abs(-cx * toward[1] + cy * toward[0])
    assert along > 1.0  # metres towards the street
    assert across < 0.2 * along + 0.2  # and not sideways
