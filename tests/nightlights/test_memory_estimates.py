"""The sky stages' memory estimates against their measured peaks: darkness, sky render, the
explore session and many observers.

As ``tests/nightlights/ground/test_memory.py``: each stage runs in a fresh interpreter after a
small warm-up run (imports, compiled kernels); its peak resident memory over the baseline
(``VmHWM`` of ``/proc/self/status``, less file-backed pages read back) must stay within twice
the estimate it gave :func:`~nightlights._resources.check_memory`, and the estimate must not
exceed four times the peak.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine

SCRIPT = """
import json, sys, warnings
warnings.simplefilter("ignore")
import numpy as np
import geopandas as gpd
import importlib
import nightlights._resources as resources
# the modules (a package may hand on a function of the same name)
session_module = importlib.import_module("nightlights.explore._session")
render_module = importlib.import_module("nightlights.nightsky.stage")
darkness_module = importlib.import_module("nightlights.sky.darkness")
observers_module = importlib.import_module("nightlights.sky.observers")
from nightlights.explore import ExploreSession
from nightlights.nightsky import sky_render
from nightlights.sky import Observer, Scene

estimates = []
def spy(estimate, what, *, option=None):
    estimates.append(estimate)
    resources.check_memory(estimate, what, option=option)
for module in (session_module, render_module, darkness_module, observers_module):
    module.check_memory = spy

def status():
    with open("/proc/self/status") as f:
        fields = dict(line.split(":", 1) for line in f)
    return {key: int(fields[key].split()[0]) * 1024 for key in ("VmRSS", "VmHWM", "RssFile")}

kind, small, large, kernel, points, out = sys.argv[1:7]

def run(emission, size):
    if kind == "darkness":
        darkness_module.darkness(Scene(emission, kernel=kernel), out, height=0.0, progress=False)
    elif kind == "render":
        sky_render(Observer.from_lonlat(24.95, 60.17), out, time="2026-01-25T20:00:00Z",
                   width=size, height=512)
    elif kind == "explore":
        session = ExploreSession(Scene(emission, kernel=kernel), height=0.0, progress=False)
        x0, _, _, y1 = session.bounds
        x, y = x0 + 1550.0, y1 - 1550.0
        session.panorama(x, y)
        session.emission("current")
        for metric in ("zenith", "hemisphere", "pca-norm"):
            session.influence(x, y, kind="q", metric=metric)
        session.dim(x, y, by="q", qa=0.0, qb=1e-9, gamma=0.5)
        session.edit("paint", [[x, y], [x + 2000, y - 2000]], radius=300.0, value=2.0)
        session.influence(x, y, kind="q", metric="zenith")
    else:
        sites = Observer.from_layer(points)
        observers_module.observers(Scene(emission, kernel=kernel), sites, out, top_cells=600,
                                   num_workers=2, overwrite=True, progress=False)

run(small, 64)  # imports, compiled kernels, GDAL and PROJ set up once per process
estimates.clear()
base = status()
run(large, 8000)
after = status()
peak = after["VmHWM"] - base["VmRSS"] - max(0, after["RssFile"] - base["RssFile"])
print(json.dumps({"peak": peak, "estimate": max(estimates)}))
"""


def _emission(path: Path, size: int) -> Path:
    """A ``size`` x ``size`` emission raster at 100 m, every 35th cell lit."""
    values = np.zeros((size, size), np.float32)
    values[::7, ::5] = np.random.default_rng(0).random(values[::7, ::5].shape)
    with rasterio.open(
        path, "w", driver="GTiff", width=size, height=size, count=1, dtype="float32",
        crs="EPSG:32635", transform=Affine(100, 0, 500_000, 0, -100, 6_700_000), tiled=True,
    ) as dataset:  # fmt: skip
        dataset.write(values, 1)
        dataset.set_band_description(1, "reflected")
    return path


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc/self/status")
def test_sky_stages_stay_within_twice_their_estimate(tmp_path: Path) -> None:
    import geopandas as gpd

    from nightlights.sky import KernelSpec, build_kernel

    small = _emission(tmp_path / "small.tif", 40)
    large = _emission(tmp_path / "large.tif", 1500)
    kernel = tmp_path / "kernel.nc"
    build_kernel(
        KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), kernel, progress=False
    )
    rng = np.random.default_rng(1)
    xy = np.column_stack([500_000 + rng.random(200) * 3900, 6_700_000 - rng.random(200) * 3900])
    points = tmp_path / "observers.gpkg"
    gpd.GeoDataFrame(geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs="EPSG:32635").to_file(
        points
    )
    outputs = {"darkness": "z.tif", "render": "sky.png", "explore": "", "observers": "o.gpkg"}
    for kind, name in outputs.items():  # one at a time: the peaks are of one process each
        out = str(tmp_path / name) if name else ""
        args = [kind, str(small), str(large), str(kernel), str(points), out]
        done = subprocess.run(
            [sys.executable, "-c", SCRIPT, *args], capture_output=True, text=True, timeout=600
        )
        assert done.returncode == 0, done.stderr[-3000:]
        measured = json.loads(done.stdout.strip().splitlines()[-1])
        peak, estimate = measured["peak"], measured["estimate"]
        assert estimate > 30 * 2**20, (kind, measured)  # large enough to measure
        assert peak <= 2 * estimate, (kind, measured)
        assert estimate <= 4 * peak, (kind, measured)
