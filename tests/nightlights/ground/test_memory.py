"""The ground stages' memory estimates against their measured peaks.

Each stage runs in a fresh interpreter; its peak resident memory over the baseline before the
call (``VmHWM`` of ``/proc/self/status``, less file-backed pages read back) must stay within
twice the estimate the stage gave :func:`~nightlights._resources.check_memory`, and the
estimate must not exceed four times the peak (an estimate that refuses work the machine could
do is not honest either).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from nightlights.ground.checks import IRRADIANCE_FIXED_BYTES, LOCAL_TILES_FIXED_BYTES

SCRIPT = """
import json, sys, warnings
warnings.simplefilter("ignore")
import geopandas as gpd
from shapely.geometry import Point
import nightlights as nl
import nightlights._resources as resources
import nightlights.ground.stage as stage
import nightlights.ground._viirs_run as viirs_run
import nightlights.ground._emission_run as emission_run

estimates = []
def spy(estimate, what, *, option=None):
    estimates.append(estimate)
    resources.check_memory(estimate, what, option=option)
stage.check_memory = emission_run.check_memory = viirs_run.check_memory = spy

def status():
    with open("/proc/self/status") as f:
        fields = dict(line.split(":", 1) for line in f)
    return {key: int(fields[key].split()[0]) * 1024 for key in ("VmRSS", "VmHWM", "RssFile")}

kind, source, out = sys.argv[1:4]
lights = gpd.GeoDataFrame(
    {"system_id": ["street_led_medium", "road_hps"], "heading": [0.0, 180.0]},
    geometry=[Point(385_000, 6_672_000), Point(385_030, 6_672_010)], crs="EPSG:3067")
# A small run first: imports, the luminaire database, GDAL and PROJ set up once per process.
if kind == "irradiance":
    nl.irradiance(lights, resolution=10.0, progress=False)
else:
    import numpy as np
    from affine import Affine
    small = nl.io.Raster(np.ones((1, 4, 4)), Affine(0.01, 0, 24, 0, -0.01, 61), "EPSG:4326",
                         ("photopic",))
    nl.emission_from_viirs(small, resolution=500.0)
    nl.emission(nl.io.Raster(np.ones((1, 4, 4)), Affine(1, 0, 0, 0, -1, 0), "EPSG:3067",
                             ("photopic",)), resolution=2.0, albedo=0.1)
estimates.clear()
base = status()
if kind == "irradiance":
    nl.irradiance(lights, out, resolution=0.25, sensors=("photopic", "scotopic"), progress=False)
elif kind == "emission":
    nl.emission(source, out, resolution=10.0, albedo=0.15)
else:
    nl.emission_from_viirs(source, out, resolution=250.0)
after = status()
# Library pages evicted by other processes before the call and read back during it are not
# the stage's memory: take the growth of file-backed pages off the peak.
peak = after["VmHWM"] - base["VmRSS"] - max(0, after["RssFile"] - base["RssFile"])
print(json.dumps({"peak": peak, "estimate": estimates[-1]}))
"""


def _write(path: Path, values: np.ndarray, crs: str, transform: object, name: str) -> Path:
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=values.shape[0],
        width=values.shape[1],
        count=1,
        dtype="float32",
        crs=crs,
        transform=transform,
    ) as dataset:
        dataset.write(values.astype(np.float32), 1)
        dataset.set_band_description(1, name)
    return path


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc/self/status")
def test_stages_stay_within_twice_their_estimate(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    ground = _write(
        tmp_path / "ground.tif",
        rng.gamma(2.0, 5.0, (2000, 2000)),
        "EPSG:3067",
        from_origin(385_000, 6_672_000, 0.5, 0.5),
        "photopic",
    )
    viirs = _write(
        tmp_path / "viirs.tif",
        rng.gamma(1.0, 10.0, (1400, 1400)),
        "EPSG:4326",
        from_origin(24.0, 61.0, 0.004, 0.002),
        "radiance",
    )
    runs = {
        kind: subprocess.Popen(
            [sys.executable, "-c", SCRIPT, kind, str(source), str(tmp_path / f"{kind}_out.tif")],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for kind, source in (("irradiance", ""), ("emission", ground), ("viirs", viirs))
    }
    # the small run first paid the first calls' memory, which the irradiance estimate counts
    # (a fresh process's cost: bench_memory_estimates.py); the peak here is over it
    paid = {"irradiance": IRRADIANCE_FIXED_BYTES + LOCAL_TILES_FIXED_BYTES}
    for kind, run in runs.items():
        stdout, stderr = run.communicate(timeout=120)
        assert run.returncode == 0, stderr
        measured = json.loads(stdout.strip().splitlines()[-1])
        peak, estimate = measured["peak"], measured["estimate"] - paid.get(kind, 0)
        assert estimate > 30 * 2**20, (kind, measured)  # large enough to measure
        assert peak <= 2 * estimate, (kind, measured)
        assert estimate <= 4 * peak, (kind, measured)
        assert (tmp_path / f"{kind}_out.tif").exists()
