"""Benchmark: a country end to end, VIIRS mosaic to darkness map, at default settings.

A synthetic national VIIRS annual mosaic (:func:`_mosaic.synthetic_mosaic`: EPSG:4326 at
15 arcsec, 60 degrees of longitude by 35 of latitude, 14,400 x 8,400 = 1.2 x 10^8 cells,
lognormal city radiances in clusters, a coast, a large empty interior) goes through the two
commands a new user runs, with no option but the files::

    nightlights emission viirs mosaic.tif emission.tif
    nightlights darkness emission.tif darkness.tif

each timed in its own process under ``/usr/bin/time -v`` (wall time and peak resident memory,
interpreter included). Targets: both in at most 15 minutes together, each at most 4 GiB.

Then the map is checked where a single projection would be worst: at sites far from the
mosaic's centre (30 degrees of longitude west, in the empty interior lit by villages; the
coast 21 degrees east, among cities; the north-west corner), the map's zenith at the centre of
the cell holding each site (what a map's cell holds) is compared with an independent run on a
crop around that point: the emission within 330 km, resampled (GDAL's area average of the
flux density) onto an azimuthal equidistant grid centred on it, :data:`REFINE` times finer
than the mosaic's metres per cell (on the mosaic's own cell size the resampling alone moved a
dark site's zenith by 10 %; from two to four times finer, by under 2 %), mapped by
:func:`nightlights.darkness` on that projected raster (tiled, which equals the in-memory map
to float rounding), the same scene kernel, read at its centre cell. Target: within 2 %.

Run: ``python benchmarks/bench_country.py [--quick] [--out DIR] [--folder DIR]``
(``--quick``: a 12 x 8 degree mosaic; ``--folder``: keep the files there). Writes
``country.json`` and ``.png``.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np
from _mosaic import synthetic_mosaic

#: Extent of the full run's mosaic [deg] (west, east), (south, north).
LON, LAT = (70.0, 130.0), (18.0, 53.0)
#: Sites checked against a local run: (name, longitude, latitude) [deg].
SITES = (
    ("interior, 30 deg west", 70.5, 40.0),
    ("north-west corner", 71.0, 52.0),
    ("coast, 21 deg east", 120.5, 35.0),
    ("centre", 100.0, 35.5),
)
#: Radius of the crop around a site [m]: the kernel's 300 km and a margin.
CROP_RADIUS = 330_000.0
#: How many times finer than the mosaic the local run's cells are [1].
REFINE = 4
#: The targets: wall time of both commands [s], peak per process [GiB], zenith agreement [1].
TARGET_SECONDS, TARGET_GIB, TARGET_AGREEMENT = 900.0, 4.0, 0.02


def timed_command(arguments: list[str]) -> dict[str, Any]:
    """Run ``nightlights ARGUMENTS`` under ``/usr/bin/time -v``: wall time, peak RSS."""
    command = ["/usr/bin/time", "-v", sys.executable, "-m", "nightlights_cli", *arguments]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(arguments)} failed:\n{done.stderr[-3000:]}")
    peak = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)[1])
    print(" ".join(arguments), f"{wall:.0f} s, {peak / 2**20:.2f} GiB", flush=True)
    return {
        "command": "nightlights " + " ".join(Path(a).name if "/" in a else a for a in arguments),
        "wall_s": wall,
        "peak_gib": peak * 1024 / 2**30,
        "output": done.stdout.strip().splitlines()[-1:] if done.stdout.strip() else [],
    }


def local_zenith(
    emission: Path, lon: float, lat: float, folder: Path, refine: int = REFINE
) -> float:
    """The zenith at (lon, lat) from an in-memory run on an azimuthal equidistant crop."""
    import rasterio
    from affine import Affine
    from rasterio.warp import Resampling, reproject

    import nightlights as nl
    from nightlights.io import Raster

    with rasterio.open(emission) as src:
        band_tags = src.tags(1)  # the emission function the map used (lambertian)
        step_m = abs(src.transform.e) * math.pi / 180 * 6_371_007.2 / refine  # [m]
        half = math.ceil(CROP_RADIUS / step_m)
        size = 2 * half + 1  # the site at the centre of the middle cell
        crs = f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m +no_defs"
        transform = Affine(step_m, 0, -(half + 0.5) * step_m, 0, -step_m, (half + 0.5) * step_m)
        density = np.zeros((size, size))
        reproject(
            rasterio.band(src, 1),
            density,
            dst_transform=transform,
            dst_crs=crs,
            dst_nodata=np.nan,
            resampling=Resampling.average,
        )
    density = np.nan_to_num(density, nan=0.0)
    raster = Raster(density[None], transform, crs, ("upward",), ("lm m-2",), band_tags=(band_tags,))
    result = nl.darkness(nl.Scene(raster), tiled=refine > 1, progress=False)
    return float(result.raster.data[0, half, half])


def cell_centre(raster: Path, lon: float, lat: float) -> tuple[float, float]:
    """The centre of the raster's cell holding (lon, lat) [deg]."""
    import rasterio

    with rasterio.open(raster) as src:
        t = src.transform
    col, row = math.floor((lon - t.c) / t.a), math.floor((lat - t.f) / t.e)
    return t.c + t.a * (col + 0.5), t.f + t.e * (row + 0.5)


def map_zenith(darkness: Path, lon: float, lat: float) -> float:
    import rasterio

    with rasterio.open(darkness) as src:
        return float(next(src.sample([(lon, lat)], indexes=1))[0])


def plot(payload: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.0))
    runs = payload["commands"]
    names = [r["command"].split(" ")[1] for r in runs]
    left.bar(names, [r["wall_s"] / 60 for r in runs], color="tab:blue")
    left.axhline(TARGET_SECONDS / 60, color="k", ls="--", lw=0.8, label="15 min (both)")
    for i, r in enumerate(runs):
        left.annotate(f"{r['peak_gib']:.2f} GiB", (i, r["wall_s"] / 60), ha="center", va="bottom")
    left.set_ylabel("wall time [min] (peak memory above bars)")
    left.set_title(f"{payload['cells'] / 1e6:.0f} M cells at 15 arcsec, default settings")
    left.legend()
    sites = payload["sites"]
    right.bar(
        [s["name"] for s in sites],
        [100 * s["relative_difference"] for s in sites],
        color="tab:green",
    )
    right.axhline(100 * TARGET_AGREEMENT, color="k", ls="--", lw=0.8)
    right.axhline(-100 * TARGET_AGREEMENT, color="k", ls="--", lw=0.8)
    right.set_ylabel("map - local run [% of local]")
    right.set_title("Zenith far from the centre vs a local projection")
    right.tick_params(axis="x", labelrotation=20, labelsize=8)
    fig.tight_layout()
    return fig


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="a 12 x 8 degree mosaic")
    parser.add_argument("--folder", type=Path, default=None, help="keep the files here")
    parser.add_argument(
        "--sites-only",
        action="store_true",
        help="recompute the site checks on the maps kept in --folder; the commands' figures "
        "are the previous run's",
    )
    args = harness.parse_args(parser)
    lon, lat = ((94.0, 106.0), (31.5, 39.5)) if args.quick else (LON, LAT)
    folder = args.folder or Path(tempfile.mkdtemp(prefix="bench_country_"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        mosaic = folder / "mosaic.tif"
        if not mosaic.exists():
            synthetic_mosaic(mosaic, lon=lon, lat=lat)
        emission, darkness = folder / "emission.tif", folder / "darkness.tif"
        previous = harness.previous_results("country", args.out) if args.sites_only else None
        if previous is not None:
            commands = previous["commands"]
        else:
            commands = [
                timed_command(["emission", "viirs", str(mosaic), str(emission), "--overwrite"]),
                timed_command(["darkness", str(emission), str(darkness), "--overwrite"]),
            ]
        import rasterio

        with rasterio.open(emission) as src:
            cells, crs = src.width * src.height, str(src.crs)
        sites = []
        for name, x, y in SITES:
            if not (lon[0] < x < lon[1] and lat[0] < y < lat[1]):
                x, y = (
                    min(max(x, lon[0] + 0.5), lon[1] - 0.5),
                    min(max(y, lat[0] + 0.5), lat[1] - 0.5),
                )
            x, y = cell_centre(emission, x, y)
            mapped = map_zenith(darkness, x, y)
            local = local_zenith(emission, x, y, folder)
            sites.append(
                {
                    "name": name,
                    "lon": x,
                    "lat": y,
                    "map_cd_m2": mapped,
                    "local_cd_m2": local,
                    "relative_difference": (mapped - local) / local if local > 0 else None,
                }
            )
            print(json.dumps(sites[-1]), flush=True)
    finally:
        if args.folder is None:
            shutil.rmtree(folder, ignore_errors=True)
    total = sum(r["wall_s"] for r in commands)
    payload = {
        "lon": list(lon),
        "lat": list(lat),
        "cells": cells,
        "emission_crs": crs,
        "commands": commands,
        "total_wall_s": total,
        "largest_peak_gib": max(r["peak_gib"] for r in commands),
        "sites": sites,
        "targets": {
            "seconds": TARGET_SECONDS,
            "peak_gib": TARGET_GIB,
            "agreement": TARGET_AGREEMENT,
            "met": total <= TARGET_SECONDS
            and all(r["peak_gib"] <= TARGET_GIB for r in commands)
            and all(
                s["relative_difference"] is not None
                and abs(s["relative_difference"]) <= TARGET_AGREEMENT
                for s in sites
            ),
        },
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "commands_date": previous["date"] if previous is not None else None,
    }
    harness.write_results(args.out, "country", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
