"""A project from a VIIRS raster in longitude and latitude: emission viirs, then the sky."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine

from nightlights.project import ProjectError, run

#: Cell size of the test raster [deg] (15 arc seconds, as the VIIRS night-lights products).
STEP = 15 / 3600

PROJECT = """\
[inputs]
viirs = "dnb.tif"

[observers]
crs = "EPSG:4326"
points = {{ harbour = [{lon}, {lat}] }}

[kernel]
r-max = 3000.0
n-distance = 8
n-elevation = 8
n-azimuth = 16
uplight = false

[stages.emission-viirs]
spectrum = "LED_3000K"

[stages.skyglow]
png = false
"""


@pytest.fixture
def viirs_project(tmp_path: Path, kernel_cache: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(kernel_cache))
    with rasterio.open(
        tmp_path / "dnb.tif",
        "w",
        driver="GTiff",
        height=12,
        width=12,
        count=1,
        dtype="float32",
        crs="EPSG:4326",
        transform=Affine(STEP, 0, 24.95, 0, -STEP, 60.18),
    ) as dataset:
        dataset.write(np.full((1, 12, 12), 10.0, np.float32))
    return tmp_path / "project.toml"


def test_viirs_to_skyglow(viirs_project: Path) -> None:
    viirs_project.write_text(PROJECT.format(lon=24.97, lat=60.165))
    result = run(viirs_project, progress=False)
    assert result.ran == ["emission-viirs", "skyglow:harbour"]
    assert (viirs_project.parent / "nightlights-out" / "emission.tif").is_file()
    magnitude, _ = result.zenith["harbour"]
    assert 10.0 < magnitude < 22.0


def test_an_observer_far_from_the_viirs_raster_is_refused(viirs_project: Path) -> None:
    viirs_project.write_text(PROJECT.format(lon=25.2, lat=60.165))
    with pytest.raises(ProjectError, match=r"points\.harbour = \[25\.2, 60\.165\]: lies 1"):
        run(viirs_project, progress=False)
