"""Benchmark: irradiance throughput of the compiled and numpy kernels against lights and pixels.

Target: >= 150 M light-pixel evaluations per second on this 2-core machine with the compiled
(numba) kernel, so that 100,000 luminaires at 1 m over 10 x 10 km (1,000 luminaires per
km2) take <= 30 s end to end. The script measures, on scenes of that density built from the
bundled luminaire database (all five systems, random headings, tilts 0/5/10 deg, default
region of influence ``floor:0.01`` lx), both kernels in the same run:

* scaling with the number of lights: squares of 0.25-4 km2 (250-4,000 lights) at 1 m;
* scaling with pixels: a 1 km2 square at 0.5, 1, 2, 4 m;
* threads: the 4 km2 square at 1 m (4 tiles) with 1 and 2 local Dask threads;
* agreement: the largest relative difference of the two kernels' float32 rasters over the
  lit pixels of each scene;
* the COG write of a lit 2 km square at 1 m (``nightlights.io.write_cog``), with the writer's
  defaults and with the irradiance stage's options (ZSTD level 1, all cores, averaged
  overviews);
* end to end, measured (the fastest of three runs): ``nightlights.ground.irradiance`` on the
  target scene, 100,000 luminaires over 10 x 10 km at 1 m, from the light layer to the
  written COG, split into the kernel (``compute_irradiance``, which streams each tile into
  the writer's scratch GeoTIFF as it is done), the COG made from that file when the writer
  closes ("write") and the rest ("setup": luminaire placement and photometry, regions of
  influence, grid, opening the writer).

Light-pixel evaluations per second ("pairs/s") is the throughput figure, from wall time
(2 local threads unless stated; the fastest of five runs of the compiled kernel and of two of
the numpy kernel) and from CPU time (all threads, of that run): on a shared machine the
CPU figure per thread is the steadier one, and the ratio of the two kernels in the same run
is the speed-up. The numpy kernel's time on the target scene is *extrapolated* from the
largest measured scene (pairs and write time scale linearly with area at fixed density),
labelled as such, and so is the compiled kernel's for comparison with its measured run.

Run: ``python benchmarks/bench_irradiance_throughput.py [--quick] [--out DIR]``
(``--quick``: scenes up to 1 km2, resolutions 1-4 m, a 1 km COG for the write time, the end
to end run on a 2 km square).
Writes ``irradiance_throughput.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import datetime
import json
import os
import resource
import tempfile
import time
from contextlib import contextmanager
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
from nightlights.ground import stage as irradiance_stage
from nightlights.io import CogWriter, RasterBand, write_cog

DENSITY = 1000.0  # luminaires per km2 (100,000 over 10 x 10 km)
TARGET_SIDE = 10_000.0  # [m]
TARGET_LIMIT_S = 30.0
TARGET_PAIRS_PER_S = 150e6
BACKENDS = ("numba", "numpy")
#: Runs per scene and kernel; the fastest counts (the machine is shared: runs of the same
#: scene a minute apart differ by up to a fifth).
REPEATS = {"numba": 5, "numpy": 2}
#: Runs of the end-to-end stage on the target scene; the fastest counts.
END_TO_END_RUNS = 3


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


def measure(side: float, resolution: float, threads: int | None) -> list[dict]:
    """Time one scene with both kernels: luminaire setup, radii and tiles (no file output)."""
    database = load_library()
    with harness.Stopwatch() as setup_watch:
        luminaires = resolve_luminaires(scene_frame(side), database)
        radius = luminaires.radius(InfluenceThreshold())
        weights = sensor_factors(luminaires.spectra, ["photopic"])[luminaires.table_index]
    setup = setup_watch.seconds
    grid = grid_from_bounds((0, 0, side, side), resolution)
    rows, bands = [], {}
    for backend in BACKENDS:
        # the fastest of REPEATS[backend] runs (wall time) and that run's CPU time
        elapsed = cpu = float("inf")
        for _ in range(REPEATS[backend]):
            start = time.process_time()
            result, wall = harness.timed(
                lambda backend=backend: compute_irradiance(
                    grid,
                    luminaires,
                    weights,
                    radius,
                    num_workers=threads,
                    progress=False,
                    backend=backend,
                )
            )
            if wall < elapsed:
                elapsed, cpu = wall, time.process_time() - start
        bands[backend] = result.bands[0].astype(float)
        rows.append(
            {
                "backend": backend,
                "side_m": side,
                "lights": len(luminaires),
                "resolution_m": resolution,
                "threads": threads or 2,
                "pixels": grid.rows * grid.cols,
                "pairs": result.n_pairs,
                "setup_s": setup,
                "compute_s": elapsed,
                "cpu_s": cpu,
                "pairs_per_s": result.n_pairs / elapsed,
                "pairs_per_cpu_s": result.n_pairs / cpu,
            }
        )
    lit = bands["numpy"] > 0
    difference = np.abs(bands["numba"][lit] - bands["numpy"][lit]) / bands["numpy"][lit]
    for row in rows:
        row["max_relative_difference"] = float(difference.max())
        row["same_lit_pixels"] = bool(np.array_equal(bands["numba"] > 0, lit))
    return rows


def write_time(side: float) -> dict:
    """Seconds to write a 1 m float32 COG of a ``side``-metre square of a lit scene.

    The raster is the numba kernel's on a scene of the benchmark's density (every pixel lit,
    as in the target), written with the writer's defaults (DEFLATE) and with the options the
    irradiance stage uses (``nightlights.ground.stage.COG_OPTIONS``).
    """
    luminaires = resolve_luminaires(scene_frame(side, seed=1), load_library())
    grid = grid_from_bounds((0, 0, side, side), 1.0)
    data = compute_irradiance(
        grid,
        luminaires,
        np.ones((len(luminaires), 1)),
        luminaires.radius(InfluenceThreshold()),
        progress=False,
    ).bands[0]
    times = {}
    with tempfile.TemporaryDirectory() as folder:
        for label, options in (("default", {}), ("stage", irradiance_stage.COG_OPTIONS)):
            _, seconds = harness.timed(
                lambda options=options: write_cog(
                    Path(folder) / "w.tif",
                    [RasterBand(data, "photopic", "lx")],
                    transform=grid.transform,
                    crs="EPSG:32633",
                    **options,
                )
            )
            times[label] = seconds
    return {"side_m": side, "pixels": data.size, "write_s": times}


@contextmanager
def stage_clock(clock: dict):
    """Time the irradiance stage's kernel (``compute_irradiance``, which also streams the tiles
    into the writer's scratch file) and the COG made from that file when the writer closes."""
    compute, finish = irradiance_stage.compute_irradiance, CogWriter._finish

    def timed_compute(*args, **kwargs):
        result, clock["compute_s"] = harness.timed(lambda: compute(*args, **kwargs))
        return result

    def timed_finish(self, *args, **kwargs):
        result, clock["write_s"] = harness.timed(lambda: finish(self, *args, **kwargs))
        return result

    irradiance_stage.compute_irradiance, CogWriter._finish = timed_compute, timed_finish
    try:
        yield clock
    finally:
        irradiance_stage.compute_irradiance, CogWriter._finish = compute, finish


def end_to_end(side: float) -> dict:
    """The irradiance stage on a ``side``-metre square at the target density, to a COG: the
    fastest of :data:`END_TO_END_RUNS` runs (every run's total in ``totals_s``).

    One call of ``nightlights.ground.irradiance`` (the compiled kernel, local threads) from
    the light layer to the written file; the kernel (with the tiles streamed into the
    scratch file) and the COG made from it are timed inside it, the rest (luminaire placement
    and photometry, regions of influence, grid, opening the writer) is ``setup_s``.
    """
    runs = [end_to_end_once(side) for _ in range(END_TO_END_RUNS)]
    best = min(runs, key=lambda run: run["total_s"])
    return best | {"totals_s": [round(run["total_s"], 2) for run in runs]}


def end_to_end_once(side: float) -> dict:
    """One run of :func:`end_to_end`."""
    frame = scene_frame(side)
    clock: dict = {}
    with tempfile.TemporaryDirectory() as folder, stage_clock(clock):
        cpu = time.process_time()
        result, total = harness.timed(
            lambda: irradiance(
                frame,
                Path(folder) / "irradiance.tif",
                resolution=1.0,
                bounds=(0, 0, side, side),
                progress=False,
            )
        )
        cpu = time.process_time() - cpu
        size = (Path(folder) / "irradiance.tif").stat().st_size
    return {
        "measured": True,
        "side_m": side,
        "lights": len(frame),
        "resolution_m": 1.0,
        "pixels": int(result.grid.rows * result.grid.cols),
        "pairs": result.n_pairs,
        "setup_s": total - clock["compute_s"] - clock["write_s"],
        "compute_s": clock["compute_s"],
        "write_s": clock["write_s"],
        "total_s": total,
        "cpu_s": cpu,
        "pairs_per_s": result.n_pairs / clock["compute_s"],
        "file_mb": size / 1e6,
        "cog_options": {k: str(v) for k, v in irradiance_stage.COG_OPTIONS.items()},
        # the benchmark process's high-water mark after the run (its largest scene)
        "peak_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "date": datetime.date.today().isoformat(),
    }


def warm_up() -> None:
    """Load (or compile) the compiled kernel once, outside the timings."""
    luminaires = resolve_luminaires(scene_frame(100.0), load_library())
    grid = grid_from_bounds((0, 0, 100, 100), 1.0)
    weights = np.ones((len(luminaires), 1))
    compute_irradiance(grid, luminaires, weights, np.full(len(luminaires), 20.0), progress=False)


def speedups(rows: list[dict]) -> list[dict]:
    """numba / numpy ratios of wall and CPU throughput per scene of ``rows``."""
    numba = [r for r in rows if r["backend"] == "numba"]
    numpy_rows = [r for r in rows if r["backend"] == "numpy"]
    return [
        {
            "side_m": a["side_m"],
            "resolution_m": a["resolution_m"],
            "threads": a["threads"],
            "wall": a["pairs_per_s"] / b["pairs_per_s"],
            "cpu": a["pairs_per_cpu_s"] / b["pairs_per_cpu_s"],
        }
        for a, b in zip(numba, numpy_rows, strict=True)
    ]


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="smaller scenes")
    args = harness.parse_args(parser)
    warm_up()
    load = {"before": os.getloadavg()}
    sides = (500.0, 1000.0) if args.quick else (500.0, 1000.0, 1500.0, 2000.0)
    resolutions = (1.0, 2.0, 4.0) if args.quick else (0.5, 1.0, 2.0, 4.0)
    by_lights = [row for side in sides for row in measure(side, 1.0, None)]
    by_resolution = [row for res in resolutions for row in measure(1000.0, res, None)]
    # 2 km at 1 m = 4 tiles of 1024 px, so that two threads have work to share.
    by_threads = [row for threads in (1, 2) for row in measure(2000.0, 1.0, threads)]
    for row in (*by_lights, *by_resolution, *by_threads):
        print(json.dumps(row), flush=True)
    write_side = 2000.0 if not args.quick else 1000.0
    write = write_time(write_side)
    print(json.dumps(write), flush=True)
    # the target scene end to end, measured (a 2 km square with --quick)
    full = end_to_end(2000.0 if args.quick else TARGET_SIDE)
    print(json.dumps(full), flush=True)
    load["after"] = os.getloadavg()
    extrapolated = {}
    for backend in BACKENDS:
        largest = [r for r in by_lights if r["backend"] == backend][-1]
        scale = (TARGET_SIDE / largest["side_m"]) ** 2
        target = {
            "measured": False,
            "method": f"largest measured scene ({largest['side_m']:g} m square, "
            f"{largest['lights']} lights) x {scale:g} (area ratio at equal density); write "
            f"time (the stage's options) from a {write_side:g} m COG x "
            f"{(TARGET_SIDE / write_side) ** 2:g}; setup from the end-to-end run",
            "lights": int(DENSITY * (TARGET_SIDE / 1000) ** 2),
            "pairs": largest["pairs"] * scale,
            # the measured end-to-end run's setup (at the target's area)
            "setup_s": full["setup_s"] * (TARGET_SIDE / full["side_m"]) ** 2,
            "compute_s": largest["compute_s"] * scale,
            "write_s": write["write_s"]["stage"] * (TARGET_SIDE / write_side) ** 2,
        }
        target["total_s"] = target["setup_s"] + target["compute_s"] + target["write_s"]
        extrapolated[backend] = target
        print(backend, json.dumps(target))
    payload = {
        "target": {
            "lights": 100_000,
            "side_m": TARGET_SIDE,
            "resolution_m": 1.0,
            "limit_s": TARGET_LIMIT_S,
            "pairs_per_s": TARGET_PAIRS_PER_S,
        },
        "threshold": "floor:0.01 (default)",
        "note": "timings from a shared 2-core machine (other jobs running), noisy; the "
        "numba/numpy ratios are measured in the same run; per scene and kernel the fastest "
        "of the runs in 'repeats'",
        "repeats": REPEATS,
        "load_average_1_5_15_min": load,
        "by_lights": by_lights,
        "by_resolution": by_resolution,
        "by_threads": by_threads,
        "speedup": {
            "by_lights": speedups(by_lights),
            "by_resolution": speedups(by_resolution),
            "by_threads": speedups(by_threads),
        },
        "write": write,
        "end_to_end": full,
        # the same run under the key the benchmarks page reads
        "full_target": full,
        "extrapolated_target": extrapolated,
    }
    harness.write_results(
        args.out, "irradiance_throughput", payload, quick=args.quick, plot=plot, dpi=120
    )


def plot(payload: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    styles = {"numba": ("tab:blue", "o-"), "numpy": ("tab:orange", "s--")}
    for backend, (colour, style) in styles.items():
        rows = [r for r in payload["by_lights"] if r["backend"] == backend]
        axes[0].plot(
            [r["lights"] for r in rows],
            [r["pairs_per_s"] / 1e6 for r in rows],
            style,
            color=colour,
            label=f"{backend}, wall (2 threads)",
        )
        axes[0].plot(
            [r["lights"] for r in rows],
            [r["pairs_per_cpu_s"] / 1e6 for r in rows],
            style,
            color=colour,
            alpha=0.4,
            label=f"{backend}, per CPU second",
        )
        rows = [r for r in payload["by_resolution"] if r["backend"] == backend]
        axes[1].plot(
            [r["pixels"] for r in rows],
            [r["pairs_per_s"] / 1e6 for r in rows],
            style,
            color=colour,
            label=f"{backend}, wall (2 threads)",
        )
        axes[1].plot(
            [r["pixels"] for r in rows],
            [r["pairs_per_cpu_s"] / 1e6 for r in rows],
            style,
            color=colour,
            alpha=0.4,
            label=f"{backend}, per CPU second",
        )
    for axis, key in ((axes[0], "by_lights"), (axes[1], "by_resolution")):
        axis.axhline(
            payload["target"]["pairs_per_s"] / 1e6, color="grey", ls=":", label="target 150 M/s"
        )
        for ratio, row in zip(
            payload["speedup"][key],
            [r for r in payload[key] if r["backend"] == "numba"],
            strict=True,
        ):
            axis.annotate(
                f"x{ratio['wall']:.1f}",
                (row["lights"] if key == "by_lights" else row["pixels"], row["pairs_per_s"] / 1e6),
                fontsize=7,
                xytext=(3, 4),
                textcoords="offset points",
            )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.xaxis.set_minor_formatter(plt.NullFormatter())
        axis.set_ylabel("light-pixel evaluations [M s-1]")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    axes[0].set_xlabel("luminaires (1,000 per km2, 1 m pixels)")
    axes[0].set_title("against lights (x: numba / numpy, wall)", fontsize=9)
    axes[1].set_xlabel("pixels (1 km2, 0.5-4 m)")
    axes[1].set_title("against pixels (1,000 lights)", fontsize=9)
    targets = payload["extrapolated_target"]
    full = payload["end_to_end"]
    bars = [
        (f"numba\nmeasured\n({full['side_m'] / 1000:g} km)", full, "tab:blue"),
        ("numba\nextrapolated", targets["numba"], "tab:blue"),
        ("numpy\nextrapolated", targets["numpy"], "tab:orange"),
    ]
    parts = (
        ("setup_s", "setup", 1.0),
        ("compute_s", "kernel", 0.75),
        ("write_s", "COG write", 0.4),
    )
    for index, (_, run, colour) in enumerate(bars):
        bottom = 0.0
        for key, name, alpha in parts:
            axes[2].bar(
                index,
                run[key],
                bottom=bottom,
                color=colour,
                alpha=alpha,
                edgecolor="k",
                linewidth=0.4,
                label=name if index == 0 else None,
            )
            bottom += run[key]
    top = 1.6 * max(full["total_s"], targets["numba"]["total_s"], payload["target"]["limit_s"])
    for index, (_, run, _) in enumerate(bars):
        axes[2].annotate(
            f"{run['total_s']:.0f} s",
            (index, min(run["total_s"], 0.93 * top)),
            ha="center",
            va="bottom",
            fontsize=8,
        )
    axes[2].set_ylim(0, top)
    axes[2].set_xticks(range(len(bars)), [label for label, _, _ in bars], fontsize=8)
    axes[2].axhline(payload["target"]["limit_s"], color="grey", ls="--", label="30 s target")
    axes[2].set_ylabel("end to end [s] (setup + kernel + COG write)")
    axes[2].set_title("100,000 luminaires, 10 x 10 km at 1 m", fontsize=9)
    axes[2].legend(fontsize=7)
    load = payload.get("load_average_1_5_15_min", {}).get("before", [float("nan")])[0]
    fig.suptitle(
        "Irradiance throughput, compiled (numba) and numpy kernels, shared 2-core machine "
        f"(load average {load:.1f} at the start; noisy)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
