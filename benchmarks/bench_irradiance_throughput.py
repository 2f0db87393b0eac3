"""Benchmark: irradiance throughput and scaling with lights, resolution and threads.

Target: 100,000 luminaires at 1 m over 10 x 10 km in <= 5 min on this 2-core
machine. That is a density of 1,000 luminaires per km2. The script measures, on scenes of
the same density built from the bundled luminaire database (all five systems, random
headings, tilts 0/5/10 deg, default region of influence ``floor:0.01`` lx):

* scaling with the number of lights: squares of 0.25-4 km2 (250-4,000 lights) at 1 m;
* scaling with resolution: a 1 km2 square at 0.5, 1, 2, 4 m;
* threads: the 4 km2 square at 1 m (4 tiles) with 1 and 2 local Dask threads;
* the COG write time per pixel (``nightlights.io.write_cog``).

Light-pixel evaluations per second ("pairs/s") is the throughput figure. The target's time
is *extrapolated* from the largest measured scene (pairs and write time scale linearly with
area at fixed density), labelled as such in the JSON and the chart. ``--full`` also runs the
full 10 x 10 km target once through the stage (about 5 min and 1 GB of memory).

Run: ``python benchmarks/bench_irradiance_throughput.py [--quick] [--out DIR] [--full]``
(``--quick``: scenes up to 1 km2, resolutions 1-4 m, a 1 km COG for the write time).
Writes ``irradiance_throughput.json`` and ``.png`` (see ``_harness.py`` for where); without
``--full`` the last measured full target is kept from the previous results.
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import _harness as harness
import geopandas as gpd
import numpy as np

from ies.library import load_library
from nightlights.ground import (
    InfluenceThreshold,
    compute_irradiance,
    grid_from_bounds,
    irradiance,
    resolve_luminaires,
    sensor_factors,
)
from nightlights.io import RasterBand, write_cog

DENSITY = 1000.0  # luminaires per km2 (100,000 over 10 x 10 km)
TARGET_SIDE = 10_000.0  # [m]
TARGET_LIMIT_S = 300.0


def scene_frame(side: float, seed: int = 0) -> gpd.GeoDataFrame:
    """Light layer of the bundled systems scattered over a square of ``side`` metres."""
    database = load_library()
    rng = np.random.default_rng(seed)
    n = round(DENSITY * (side / 1000) ** 2)
    names = np.array(sorted(database.systems))
    return gpd.GeoDataFrame(
        {
            "light_id": np.arange(n),
            "system_id": rng.choice(names, n),
            "heading": rng.uniform(0, 360, n),
            "tilt": rng.choice([0.0, 5.0, 10.0], n),
        },
        geometry=gpd.points_from_xy(rng.uniform(0, side, n), rng.uniform(0, side, n)),
        crs="EPSG:32633",
    )


def measure(side: float, resolution: float, threads: int | None) -> dict:
    """Time one scene: luminaire setup, radii and tiles (no file output)."""
    database = load_library()
    with harness.Stopwatch() as setup_watch:
        luminaires = resolve_luminaires(scene_frame(side), database)
        radius = luminaires.radius(InfluenceThreshold())
        weights = sensor_factors(luminaires.spectra, ["photopic"])[luminaires.table_index]
    setup = setup_watch.seconds
    grid = grid_from_bounds((0, 0, side, side), resolution)
    result, elapsed = harness.timed(
        lambda: compute_irradiance(
            grid, luminaires, weights, radius, num_workers=threads, progress=False
        )
    )
    return {
        "side_m": side,
        "lights": len(luminaires),
        "resolution_m": resolution,
        "threads": threads or 2,
        "pixels": grid.rows * grid.cols,
        "pairs": result.n_pairs,
        "setup_s": setup,
        "compute_s": elapsed,
        "pairs_per_s": result.n_pairs / elapsed,
    }


def write_time(side: float) -> float:
    """Seconds to write a 1 m float32 COG of a ``side``-metre square."""
    pixels = int(side)
    data = np.random.default_rng(0).gamma(0.5, 2.0, (pixels, pixels)).astype(np.float32)
    grid = grid_from_bounds((0, 0, side, side), 1.0)
    with tempfile.TemporaryDirectory() as folder:
        _, seconds = harness.timed(
            lambda: write_cog(
                Path(folder) / "w.tif",
                [RasterBand(data, "photopic", "lx")],
                transform=grid.transform,
                crs="EPSG:32633",
            )
        )
        return seconds


def full_target() -> dict:
    """Run the whole 10 x 10 km target through the stage (writes a temporary COG)."""
    with tempfile.TemporaryDirectory() as folder:
        lights = Path(folder) / "lights.gpkg"
        scene_frame(TARGET_SIDE).to_file(lights, driver="GPKG")
        result, elapsed = harness.timed(
            lambda: irradiance(
                lights,
                Path(folder) / "e.tif",
                resolution=1.0,
                bounds=(0, 0, TARGET_SIDE, TARGET_SIDE),
                progress=False,
            )
        )
    return {
        "lights": result.n_lights,
        "pairs": result.n_pairs,
        "total_s": elapsed,
        "measured": True,
    }


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="smaller scenes")
    parser.add_argument("--full", action="store_true", help="also run the full target")
    args = harness.parse_args(parser)
    sides = (500.0, 1000.0) if args.quick else (500.0, 1000.0, 1500.0, 2000.0)
    resolutions = (1.0, 2.0, 4.0) if args.quick else (0.5, 1.0, 2.0, 4.0)
    by_lights = [measure(side, 1.0, None) for side in sides]
    by_resolution = [measure(1000.0, res, None) for res in resolutions]
    # 2 km at 1 m = 4 tiles of 1024 px, so that two threads have work to share.
    by_threads = [measure(2000.0, 1.0, threads) for threads in (1, 2)]
    for row in (*by_lights, *by_resolution, *by_threads):
        print(json.dumps(row))
    largest = by_lights[-1]
    write_side = 2000.0 if not args.quick else 1000.0
    write_s = write_time(write_side)
    scale = (TARGET_SIDE / largest["side_m"]) ** 2
    extrapolated = {
        "measured": False,
        "method": f"largest measured scene ({largest['side_m']:g} m square, "
        f"{largest['lights']} lights) x {scale:g} (area ratio at equal density); write "
        f"time from a {write_side:g} m COG x {(TARGET_SIDE / write_side) ** 2:g}",
        "lights": int(DENSITY * (TARGET_SIDE / 1000) ** 2),
        "pairs": largest["pairs"] * scale,
        "setup_s": largest["setup_s"] * scale,
        "compute_s": largest["compute_s"] * scale,
        "write_s": write_s * (TARGET_SIDE / write_side) ** 2,
    }
    extrapolated["total_s"] = (
        extrapolated["setup_s"] + extrapolated["compute_s"] + extrapolated["write_s"]
    )
    payload = {
        "target": {
            "lights": 100_000,
            "side_m": TARGET_SIDE,
            "resolution_m": 1.0,
            "limit_s": TARGET_LIMIT_S,
        },
        "threshold": "floor:0.01 (default)",
        "note": "timings from a shared 2-core machine, noisy",
        "by_lights": by_lights,
        "by_resolution": by_resolution,
        "by_threads": by_threads,
        "extrapolated_target": extrapolated,
    }
    previous = harness.previous_results("irradiance_throughput", args.out)
    if args.full:
        payload["full_target"] = full_target()
        payload["full_target"]["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
        print(json.dumps(payload["full_target"]))
    elif previous is not None and "full_target" in previous:
        # Keep the last full run (a real measurement, dated) when only the sweep is rerun.
        payload["full_target"] = previous["full_target"]
    print(json.dumps(extrapolated))
    harness.write_results(
        args.out, "irradiance_throughput", payload, quick=args.quick, plot=plot, dpi=120
    )


def plot(payload: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    rows = payload["by_lights"]
    axes[0].plot(
        [r["lights"] for r in rows],
        [r["compute_s"] for r in rows],
        "o-",
        label="measured (1 m, 2 threads)",
    )
    target = payload["extrapolated_target"]
    axes[0].plot(
        [target["lights"]],
        [target["compute_s"]],
        "r*",
        ms=12,
        label=f"target, extrapolated: {target['total_s']:.0f} s incl. write",
    )
    if "full_target" in payload:
        full = payload["full_target"]
        axes[0].plot(
            [full["lights"]],
            [full["total_s"]],
            "kD",
            label=f"target, measured: {full['total_s']:.0f} s",
        )
    axes[0].axhline(payload["target"]["limit_s"], color="grey", ls="--", label="5 min")
    axes[0].set_xscale("log")
    axes[0].set_yscale("log")
    axes[0].set_xlabel("luminaires (1,000 per km2)")
    axes[0].set_ylabel("compute time [s]")
    axes[0].set_title("scaling with lights")
    rows = payload["by_resolution"]
    axes[1].plot([r["resolution_m"] for r in rows], [r["compute_s"] for r in rows], "o-")
    for r in rows:
        axes[1].annotate(
            f"{r['pairs_per_s'] / 1e6:.1f} M pairs/s",
            (r["resolution_m"], r["compute_s"]),
            fontsize=7,
            xytext=(3, 3),
            textcoords="offset points",
        )
    axes[1].set_xscale("log", base=2)
    axes[1].set_yscale("log")
    axes[1].set_xlabel("pixel size [m]")
    axes[1].set_ylabel("compute time [s]")
    axes[1].set_title("scaling with resolution (1 km2, 1,000 lights)")
    rows = payload["by_threads"]
    axes[2].bar([str(r["threads"]) for r in rows], [r["pairs_per_s"] / 1e6 for r in rows])
    axes[2].set_xlabel("local Dask threads")
    axes[2].set_ylabel("light-pixel evaluations [M s-1]")
    axes[2].set_title("throughput (4 km2, 4,000 lights, 1 m)")
    for axis in axes[:2]:
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Irradiance throughput, numpy kernel, shared 2-core machine (noisy)", fontsize=10)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
