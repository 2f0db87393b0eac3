"""Benchmark: a plan for the world, from the measured cost of one tile of the darkness map.

The darkness map of a geographic emission raster is computed tile by tile
(:mod:`nightlights.sky.tiled`): every tile is the same work (read its window and a halo of
the kernel's range, deposit the flux on a local grid, one FFT per stencil, sample back,
write), so the world's cost is the number of tiles times the cost of one. This script takes

* **the cost of a tile** at 15 arcsec with the scene kernel of the largest range (300 km,
  :data:`~nightlights.sky.spec.MAX_KERNEL_RANGE`) at default settings: the darkness command of
  ``bench_country.py`` on its 1.2 x 10^8-cell mosaic (wall time over its tiles, the kernel
  build and the COG included), and the scaling from one to two ``dask.distributed`` workers
  from ``bench_darkness_tiles.py`` (run both first; this script measures nothing twice);
* **the world at 15 arcsec**: 86,400 x 43,200 = 3.7 x 10^9 cells in tiles of the default
  edge. Tiles with no light within the kernel's reach convolve nothing; the plan counts the
  tiles with land within 300 km (GLOBE's 30 arcsec land mask, from the ``global-land-mask``
  package, which this script installs with pip when it is missing) as a lower bound of the
  work (deserts, ice caps and taiga hold no light either) and every tile as the upper bound.
  The hours for N workers divide one worker's time by N: the tiles are independent, and the
  measured step from one to two workers is reported beside it;
* **where the 300 km range stops mattering**: the zenith luminance per lumen of the 300 km
  scene kernel at 10-295 km, and the upward flux a city must send up to add 1 % of the
  natural zenith (22.0 mag arcsec-2) at each distance.

Run: ``python benchmarks/bench_world_plan.py [--out DIR]``. Writes ``world_plan.json`` and
``.png``.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np

#: Cells of the world at 15 arcsec: 360 x 240 by 180 x 240 [1].
WORLD_SHAPE = (43_200, 86_400)
#: Natural zenith sky brightness the flux threshold is set against [mag arcsec-2] (V).
NATURAL_SKY = 22.0
#: The added zenith luminance that counts, as a share of the natural sky's [1].
MATTERS = 0.01
#: Distances of the range chart [m].
DISTANCES = (10e3, 25e3, 50e3, 100e3, 150e3, 200e3, 250e3, 295e3)


def range_analysis() -> dict[str, Any]:
    """The zenith per lumen of the 300 km scene kernel at :data:`DISTANCES` and the flux that
    adds :data:`MATTERS` of the natural zenith at each."""
    import nightlights as nl
    from nightlights.brightness import magnitude_to_luminance
    from nightlights.sky.darkness import zenith_per_lumen
    from nightlights.sky.panorama import kernel_slice
    from nightlights.sky.spec import MAX_KERNEL_RANGE

    spec = nl.KernelSpec(r_min=10.0, r_max=MAX_KERNEL_RANGE)
    kernel = nl.build_kernel(spec, progress=False).kernel
    tables = kernel_slice(kernel, observer_altitude=0.0)
    z = zenith_per_lumen(tables)[0]
    edges = tables.distance_edges
    centres = np.sqrt(edges[1:] * edges[:-1])
    natural = float(magnitude_to_luminance(NATURAL_SKY))
    per_lumen = np.exp(np.interp(np.log(DISTANCES), np.log(centres), np.log(z)))
    return {
        "kernel_range_m": float(edges[-1]),
        "natural_luminance_cd_m2": natural,
        "rows": [
            {
                "distance_km": d / 1000,
                "zenith_per_lumen_cd_m2_lm": float(z_d),
                "flux_for_one_percent_lm": float(MATTERS * natural / z_d),
            }
            for d, z_d in zip(DISTANCES, per_lumen, strict=True)
        ],
    }


def lit_tile_share(tile_edge: int, reach: float) -> dict[str, Any]:
    """Share of the world's tiles of ``tile_edge`` cells of 15 arcsec that hold land within
    ``reach`` [m] (GLOBE's 30 arcsec land mask, the ``global-land-mask`` package, installed
    here with pip when missing): an upper bound on the tiles that need an FFT."""
    import importlib
    import subprocess
    import sys

    try:
        globe = importlib.import_module("global_land_mask.globe")
    except ImportError:
        subprocess.run(
            [sys.executable, "-m", "pip", "install", "-q", "global-land-mask"], check=True
        )
        globe = importlib.import_module("global_land_mask.globe")
    land = ~np.asarray(globe._mask, dtype=bool)  # the mask is the ocean; 21600 x 43200, 30"
    if globe._lat[0] < globe._lat[-1]:
        land = land[::-1]  # north first
    # any land per block of 0.25 deg (30 x 30 cells of 30 arcsec)
    block = 30
    coarse = land.reshape(land.shape[0] // block, block, -1, block).any(axis=(1, 3))
    rows, cols = coarse.shape  # 720 x 1440
    step = 0.25
    lat = 90 - (np.arange(rows) + 0.5) * step
    radius = 6_371_000.0
    reach_deg = math.degrees(reach / radius)
    near = np.zeros_like(coarse)
    dy = math.ceil(reach_deg / step)
    for i in range(rows):
        band = coarse[max(0, i - dy) : i + dy + 1].any(axis=0)
        dx = math.ceil(reach_deg / max(math.cos(math.radians(lat[i])), 1e-3) / step)
        dx = min(dx, cols // 2)
        shifted = np.zeros(cols, dtype=bool)
        for offset in range(-dx, dx + 1):
            shifted |= np.roll(band, offset)
        near[i] = shifted
    # tiles of tile_edge cells of 15 arcsec = tile_edge / 240 deg
    per_tile = tile_edge / 240 / step
    tile_rows = math.ceil(rows / per_tile)
    tile_cols = math.ceil(cols / per_tile)
    lit = 0
    for ti in range(tile_rows):
        r0, r1 = int(ti * per_tile), min(rows, int((ti + 1) * per_tile))
        for tj in range(tile_cols):
            c0, c1 = int(tj * per_tile), min(cols, int((tj + 1) * per_tile))
            lit += bool(near[r0:r1, c0:c1].any())
    return {
        "land_share_of_blocks": float(coarse.mean()),
        "tiles": tile_rows * tile_cols,
        "lit_tiles": lit,
        "lit_share": lit / (tile_rows * tile_cols),
        "mask": "GLOBE 30 arcsec land mask (global-land-mask 1.0.0, NOAA NGDC GLOBE)",
    }


def world_plan(seconds_per_tile: float, tile_edge: int, rates: dict[int, float]) -> dict[str, Any]:
    """Tiles of the world and the hours for N workers, from the measured time per tile."""
    from nightlights.sky.spec import MAX_KERNEL_RANGE

    share = lit_tile_share(tile_edge, MAX_KERNEL_RANGE)
    tiles, lit = share["tiles"], share["lit_tiles"]
    # an unlit tile (no land within the kernel's reach) convolves nothing: its cost is its
    # read, deposit and write, counted here as a lit tile's (an upper bound) and not at all
    # (a lower bound)
    upper, lower = tiles * seconds_per_tile, lit * seconds_per_tile
    speedup = rates[2] / rates[1] if 1 in rates and 2 in rates else None
    workers = [1, 2, 8, 32, 128, 512, 1024]
    return {
        **share,
        "seconds_per_tile": seconds_per_tile,
        "seconds_one_worker": [lower, upper],
        "measured_speedup_1_to_2": speedup,
        "workers": workers,
        # ideal scaling beyond what was measured: the tiles are independent and a tile's
        # read and write are a small share of its time; a worker here is a 2-core machine
        "hours_lit_only": [lower / n / 3600 for n in workers],
        "hours_all_tiles": [upper / n / 3600 for n in workers],
    }


def plot(payload: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    plan = payload["world"]
    left.loglog(plan["workers"], plan["hours_all_tiles"], "o-", label="every tile")
    left.loglog(plan["workers"], plan["hours_lit_only"], "s--", label="tiles with land in reach")
    left.legend()
    left.set_xlabel("workers")
    left.set_ylabel("hours for the world at 15 arcsec")
    left.set_title(
        f"{plan['tiles']} tiles, {plan['lit_tiles']} lit; {plan['seconds_per_tile']:.1f} s per tile"
    )
    left.grid(True, which="both", alpha=0.3)
    reach = payload["range"]
    km = [row["distance_km"] for row in reach["rows"]]
    right.loglog(km, [row["flux_for_one_percent_lm"] for row in reach["rows"]], "o-")
    right.set_xlabel("distance of the city [km]")
    right.set_ylabel("upward flux adding 1 % of the natural zenith [lm]")
    right.set_title("Where the 300 km range stops mattering")
    right.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def measured_tiles(out: Path) -> dict[str, Any]:
    """The cost of a tile: the darkness command of ``bench_country.py`` (a 1.2 x 10^8-cell
    geographic mosaic at 15 arcsec, default settings: its wall time, kernel build and COG
    included, over its tiles), and the scaling from one to two ``dask.distributed`` workers
    measured by ``bench_darkness_tiles.py`` (their last results in ``out``, else the
    checked-in full runs')."""
    import math as m

    from nightlights.sky.tiled import DEFAULT_TILE_SIZE

    country = harness.previous_results("country", out)
    tiles_bench = harness.previous_results("darkness_tiles", out)
    if country is None or tiles_bench is None:
        raise SystemExit("run bench_country.py and bench_darkness_tiles.py first")
    rows = round((country["lat"][1] - country["lat"][0]) * 240)
    cols = round((country["lon"][1] - country["lon"][0]) * 240)
    tiles = m.ceil(rows / DEFAULT_TILE_SIZE) * m.ceil(cols / DEFAULT_TILE_SIZE)
    darkness = next(r for r in country["commands"] if " darkness " in f" {r['command']} ")
    runs = tiles_bench["runs"]
    shapes = [r["shape"] for r in runs if r["workers"] != "none"]
    cluster = {
        int(r["workers"]): r["tiles_per_s"]
        for r in runs
        if r["workers"] != "none" and r["shape"] == shapes[-1]
    }
    return {
        "source": "benchmarks/results/country.json (darkness command)",
        "measured": country.get("date"),
        "shape": [rows, cols],
        "tiles": tiles,
        "seconds_per_tile_process": darkness["wall_s"] / tiles,
        "edge": DEFAULT_TILE_SIZE,
        "cluster_tiles_per_s": cluster,
        "cluster_source": "benchmarks/results/darkness_tiles.json",
    }


def main() -> None:
    args = harness.parse_args(harness.argument_parser(__doc__, quick="the same (it is cheap)"))
    tile = measured_tiles(args.out)
    rates = tile["cluster_tiles_per_s"]
    # a process's throughput: its tiles in flight share the machine's cores, so the seconds per
    # tile of the whole process is the cost that N such processes (or workers) divide
    payload = {
        "tile": tile,
        "world": world_plan(tile["seconds_per_tile_process"], tile["edge"], rates),
        "range": range_analysis(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    harness.write_results(args.out, "world_plan", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
