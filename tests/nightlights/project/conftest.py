"""Fixtures of the project tests: a small emission raster and a project file that runs in
seconds (a tiny kernel, cached once per session)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

#: A small project on the raster below: two observers, sky stages only, a tiny kernel.
SMALL_PROJECT = """\
[project]
output = "out"

[inputs]
emission = "emission.tif"

[observers]
points = { a = [385500.0, 6671500.0], b = [385200.0, 6671200.0] }

[kernel]
r-min = 10.0
r-max = 3000.0
n-distance = 8
n-elevation = 8
n-azimuth = 16
uplight = false

[stages.skyglow]
png = false

[stages.inverse-q]
metric = "zenith"
map = false
"""


def write_emission(path: Path) -> Path:
    """A 20 x 20 raster of 50 m cells (EPSG:3067) with a lit 4 x 4 block [lm m-2]."""
    data = np.zeros((20, 20), dtype="float32")
    data[8:12, 8:12] = 5.0
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=20,
        height=20,
        count=1,
        dtype="float32",
        crs="EPSG:3067",
        transform=from_origin(385000.0, 6672000.0, 50.0, 50.0),
    ) as dst:
        dst.write(data, 1)
    return path


@pytest.fixture(scope="session")
def kernel_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A kernel cache shared by the session's project tests."""
    return tmp_path_factory.mktemp("kernel-cache")


@pytest.fixture
def small_project(tmp_path: Path, kernel_cache: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The small project file, its raster beside it; the kernel cache set for the session."""
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(kernel_cache))
    write_emission(tmp_path / "emission.tif")
    path = tmp_path / "project.toml"
    path.write_text(SMALL_PROJECT, encoding="utf-8")
    return path
