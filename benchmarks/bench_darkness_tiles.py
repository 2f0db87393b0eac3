"""Benchmark: the tiled darkness map of a country-sized geographic raster: time per tile, peak
memory against :func:`nightlights.sky.tiled.tile_memory`, and tiles per second on a
``dask.distributed`` cluster of one and of two workers.

The scene is synthetic: a geographic raster (EPSG:4326) of 15 arcsec cells from 45 N up, lit
by lognormal clusters (towns: Gaussian discs of 1-5 km whose centre densities are lognormal,
sigma 1.5, plus a sparse lognormal sprinkle), written as a tiled GeoTIFF. The kernel is the
scene kernel at default settings (its range capped at 300 km, ``MAX_KERNEL_RANGE``), built
once into a cache of its own before anything is timed. Every run is a fresh interpreter
(``subprocess``) that reports its peak resident memory (``VmHWM`` of ``/proc/self/status``,
interpreter and libraries included), its wall time, and the estimate the stage checks
(:func:`~nightlights.sky.tiled.tile_memory` at the workers it chose, with the kernel) plus
the interpreter and its modules (:data:`~nightlights.sky.tiled.IMPORTED_MEMORY`), which the
check leaves out. Timings come from a shared 2-core machine and are noisy.

Run: ``python benchmarks/bench_darkness_tiles.py [--quick] [--out DIR]`` (``--quick``: the
1000 x 2000 raster only, no cluster). Writes ``darkness_tiles.json``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _harness as harness

#: One run in a fresh interpreter; prints its figures as JSON.
RUN = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
import numpy as np
import nightlights as nl
from nightlights.sky import tiled

def high_water():
    with open("/proc/self/status") as f:
        fields = dict(line.split(":", 1) for line in f)
    return int(fields["VmHWM"].split()[0]) * 1024

source, out, cache, chunk, scheduler = sys.argv[1:6]
chunk = None if chunk == "default" else int(chunk)
import importlib
stage = importlib.import_module("nightlights.sky.darkness")  # the module, not the function
estimates = []
original = stage.check_memory
def record(estimate, what, **kw):
    # the check leaves the interpreter out; the peak here is the whole process's
    estimates.append(estimate + tiled.IMPORTED_MEMORY)
    return original(estimate, what, **kw)
stage.check_memory = record
cluster = None
if scheduler != "none":
    from distributed import LocalCluster
    cluster = LocalCluster(n_workers=int(scheduler), threads_per_worker=1, processes=True,
                           dashboard_address=None)
    scheduler = cluster.scheduler_address
else:
    scheduler = None
wall = time.perf_counter()
result = nl.darkness(nl.Scene(source, cache_dir=cache), out, chunk_size=chunk,
                     scheduler=scheduler, progress=False)
wall = time.perf_counter() - wall
if cluster is not None:
    cluster.close()
print(json.dumps({"peak_bytes": high_water(), "wall_s": wall, "map_s": result.seconds,
                  "tiles": result.tiles, "estimate_bytes": estimates[-1] if estimates else None}))
"""


def emission_raster(path: Path, rows: int, cols: int, seed: int = 1) -> Path:
    """A geographic raster of 15 arcsec cells from 45 N up, lit by lognormal towns [lm m-2]."""
    import numpy as np
    import rasterio
    from affine import Affine

    rng = np.random.default_rng(seed)
    step = 15 / 3600
    transform = Affine(step, 0, 5.0, 0, -step, 45.0 + rows * step)
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 1,
        "dtype": "float32",
        "crs": "EPSG:4326",
        "transform": transform,
        "tiled": True,
        "blockxsize": 512,
        "blockysize": 512,
        "nodata": np.nan,
    }
    n_towns = max(1, rows * cols // 40_000)
    with rasterio.open(path, "w+", **profile) as dataset:
        for top in range(0, rows, 512):
            height = min(512, rows - top)
            block = (rng.random((height, cols)) < 0.02) * rng.lognormal(-3.0, 1.5, (height, cols))
            dataset.write(block.astype(np.float32)[None], window=((top, top + height), (0, cols)))
        for _ in range(n_towns):
            r, c = int(rng.integers(0, rows)), int(rng.integers(0, cols))
            radius = int(rng.uniform(2, 11))  # cells: 1-5 km
            r0, r1 = max(r - 3 * radius, 0), min(r + 3 * radius + 1, rows)
            c0, c1 = max(c - 3 * radius, 0), min(c + 3 * radius + 1, cols)
            window = ((r0, r1), (c0, c1))
            yy, xx = np.mgrid[r0:r1, c0:c1]
            town = rng.lognormal(0.0, 1.5) * np.exp(-((yy - r) ** 2 + (xx - c) ** 2) / radius**2)
            current = dataset.read(1, window=window)
            dataset.write((current + town).astype(np.float32)[None], window=window)
    return path


def run(source: Path, out: Path, cache: Path, chunk: str = "default", workers: str = "none"):
    command = [sys.executable, "-c", RUN, str(source), str(out), str(cache), chunk, workers]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(command, capture_output=True, text=True, check=False, env=env)
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-3000:])
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    figures["peak_gib"] = figures["peak_bytes"] / 2**30
    if figures["estimate_bytes"]:
        figures["estimate_gib"] = figures["estimate_bytes"] / 2**30
        figures["estimate_over_peak"] = figures["estimate_bytes"] / figures["peak_bytes"]
    figures["s_per_tile"] = figures["map_s"] / max(figures["tiles"], 1)
    figures["tiles_per_s"] = figures["tiles"] / figures["map_s"]
    figures["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return figures


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="the 1000 x 2000 raster only, no cluster")
    args = harness.parse_args(parser)
    sizes = [(1000, 2000)] if args.quick else [(1000, 2000), (2000, 4000), (4000, 8000)]
    rows_out = []
    with tempfile.TemporaryDirectory() as folder:
        work, cache = Path(folder), Path(folder) / "cache"
        for rows, cols in sizes:
            source = emission_raster(work / f"emission_{rows}.tif", rows, cols)
            if not rows_out:  # the scene kernel, into the cache, before anything is timed
                run(source, work / "warm.tif", cache)
            runs = [("default", "none")]
            if (rows, cols) == sizes[-1] and not args.quick:
                runs += [("1024", "none"), ("default", "1"), ("default", "2")]
            for chunk, workers in runs:
                figures = run(source, work / "zenith.tif", cache, chunk, workers)
                figures.update({"shape": [rows, cols], "chunk_size": chunk, "workers": workers})
                print(json.dumps(figures), flush=True)
                rows_out.append(figures)
    harness.write_results(args.out, "darkness_tiles", {"runs": rows_out}, quick=args.quick)


if __name__ == "__main__":
    main()
