"""Many observers on the demo scene: time against the number of observers and the scheduler.

Scene: the bundled Helsinki demo's emission raster (streets normalised, sampled and placed,
irradiance at 1 m, emission at 50 m with albedo 0.15, as ``nightlights demo`` makes it: 38 x 25
cells, 772 lit, two bands) and the demo's kernel (48 distance bins to 10 km, 32 x 128
panorama, Lambertian and uplight tables, eye at 1.7 m). Observers: 10, 100 and 1000 points
drawn uniformly over the raster's extent (seed 0).

1. :func:`nightlights.sky.observers.observers` for each count with the ``synchronous``,
   ``threads`` and ``processes`` Dask schedulers (default workers: one per core), top 5 cells
   per observer, writing the summary GeoPackage: the wall time of the whole call (scene
   checks, kernel read, skies, GeoPackage) and the time of the skies alone
   (``ObserversResult.seconds``), best of 2 calls (one call with ``processes``: its workers
   start, and import the toolkit, on every call). With ``threads`` also without the top
   cells (``top_cells=0``: the compiled polar scatter instead of the numpy sub-points).
2. The reference path: :func:`nightlights.sky.skyglow` called once per observer (in memory, no
   file), on the first 10 observers, timed per observer; the ratio of that to the per-observer
   time of (1) is the speed-up of the many-observers stage. Both compute the same zenith
   luminance (checked here to 1e-9 relative).
3. The top-cell search: how many lit cells per observer the bounds leave to be split into
   sub-points and summed exactly (5 top cells; mean and most over the largest set of
   observers).

Run: ``python benchmarks/bench_sky_observers.py [--quick] [--out DIR] [--emission TIF]``
(``--quick``: 10 and 100 observers; ``--emission``: an existing demo emission raster instead
of making one, which takes a minute or two). Writes ``sky_observers.json`` and ``.png`` (see
``_harness.py`` for where). Timings come from a shared 2-core machine and are noisy; the load
average is recorded beside them.
"""

from __future__ import annotations

import os
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np

import nightlights as nl
from nightlights.demo import DEMO_PROJECT, example_path
from nightlights.io import as_raster
from nightlights.sky import KernelSpec, Observer, Scene, skyglow
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.observers import SCHEDULERS, _engine, _Levels, observers
from nightlights.sky.store import get_or_build_kernel

COUNTS = (10, 100, 1000)
QUICK_COUNTS = (10, 100)
#: Observers the reference path (one skyglow call each) is timed on [1].
REFERENCE_OBSERVERS = 10
#: Calls per configuration, the best kept (the machine is shared) [1].
REPEATS = 2


def demo() -> dict[str, Any]:
    """The demo's project file (seed, kernel, observer height, irradiance and emission)."""
    return tomllib.loads(example_path(DEMO_PROJECT).read_text())


def demo_kernel(project: dict[str, Any]) -> KernelSpec:
    """The demo project's kernel."""
    kernel = project["kernel"]
    return KernelSpec(
        r_min=kernel["r-min"],
        r_max=kernel["r-max"],
        n_distance=kernel["n-distance"],
        n_elevation=kernel["n-elevation"],
        n_azimuth=kernel["n-azimuth"],
        uplight=kernel["uplight"],
        observer_altitudes=(project["observers"]["height"],),
        atmosphere=Atmosphere(turbidity=project["atmosphere"]["turbidity"]),
    )


def demo_emission(project: dict[str, Any], folder: Path) -> Path:
    """The demo's emission raster, made with the demo project's stage options."""
    seed = project["project"]["seed"]
    stages = project["stages"]
    streets = nl.normalize(example_path(), folder / "streets_norm.gpkg", mapping="osm").streets
    streets = nl.sample(streets, folder / "streets_lit.gpkg", seed=seed).streets
    lights = nl.place(streets, folder / "lights.gpkg", seed=seed).lights
    ground = nl.irradiance(
        lights,
        folder / "irradiance.tif",
        resolution=stages["irradiance"]["resolution"],
        sensors=("photopic",),
        progress=False,
    ).raster
    path = folder / "emission.tif"
    options = stages["emission"]
    nl.emission(
        ground, path, lights=lights, resolution=options["resolution"], albedo=options["albedo"]
    )
    return path


def points(emission: Path, count: int) -> np.ndarray:
    left, bottom, right, top = as_raster(emission).bounds
    rng = np.random.default_rng(0)
    return np.column_stack([rng.uniform(left, right, count), rng.uniform(bottom, top, count)])


def run(emission: Path, kernel: Any, xy: np.ndarray, folder: Path, **options: Any) -> dict:
    """The best of :data:`REPEATS` calls (one with worker processes, which start each call)."""
    out = folder / "summary.gpkg"
    best = None
    for _ in range(1 if options.get("scheduler") == "processes" else REPEATS):
        start = time.perf_counter()
        sites = [Observer(x, y) for x, y in xy]
        result = observers(Scene(emission, kernel=kernel), sites, out, overwrite=True,
                           progress=False, **options)  # fmt: skip
        wall = time.perf_counter() - start
        if best is None or wall < best[0]:
            best = (wall, result)
    assert best is not None
    wall, result = best
    row = {
        "observers": len(xy),
        **{k: v for k, v in options.items() if k != "top_cells"},
        "top_cells": options.get("top_cells", 5),
        "wall_s": wall,
        "skies_s": result.seconds,
        "per_observer_ms": 1000 * result.seconds / len(xy),
        "load_average": os.getloadavg()[0],
    }
    print(row, flush=True)
    return {"row": row, "summary": result.summary}


def reference(emission: Path, kernel: Any, xy: np.ndarray, summary: Any) -> dict[str, Any]:
    """One skyglow call per observer: time per observer and the largest zenith difference."""
    times, worst = [], 0.0
    for (x, y), expected in zip(xy, summary["zenith_artificial"], strict=False):
        start = time.perf_counter()
        alone = skyglow(Scene(emission, kernel=kernel), Observer(x, y), progress=False)
        times.append(time.perf_counter() - start)
        worst = max(worst, abs(alone.zenith_luminance - expected) / alone.zenith_luminance)
    row = {
        "observers": len(times),
        "per_observer_ms": 1000 * float(np.median(times)),
        "max_zenith_relative_difference": worst,
    }
    print("reference", row, flush=True)
    return row


def candidates(emission: Path, kernel: Any, xy: np.ndarray, top_cells: int) -> dict[str, Any]:
    """How many lit cells the bounds of the top-cell search leave to be summed exactly."""
    from nightlights.sky.setup import prepare_scene

    setup = prepare_scene(Scene(emission, kernel=kernel), Observer(*xy[0]), progress=False)
    engine = _engine(setup, False, top_cells, False)
    zenith = _Levels(engine).zenith(list(engine.slices))
    counts = []
    for x, y in xy:
        lower, upper = zenith.bounds(engine, (float(x), float(y)))
        threshold = np.sort(lower)[-min(top_cells, lower.size)]
        counts.append(int(np.count_nonzero(upper >= threshold)))
    row = {"observers": len(xy), "top_cells": top_cells, "lit_cells": int(lower.size),
           "mean": float(np.mean(counts)), "max": int(np.max(counts))}  # fmt: skip
    print("candidates", row, flush=True)
    return row


def plot(result: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    rows = [r for r in result["runs"] if r["top_cells"] == 5]
    for scheduler in SCHEDULERS:
        mine = [r for r in rows if r["scheduler"] == scheduler]
        ax.loglog([r["observers"] for r in mine], [r["wall_s"] for r in mine], "o-",
                  label=f"observers, {scheduler}")  # fmt: skip
    no_cells = [r for r in result["runs"] if r["top_cells"] == 0]
    ax.loglog([r["observers"] for r in no_cells], [r["wall_s"] for r in no_cells], "s--",
              label="observers, threads, no top cells")  # fmt: skip
    per = result["reference"]["per_observer_ms"] / 1000
    counts = np.array(sorted({r["observers"] for r in rows}))
    ax.loglog(counts, per * counts, "k:", label="skyglow per observer (reference)")
    ax.set_xlabel("observers")
    ax.set_ylabel("wall time [s]")
    ax.set_title("Many observers on the demo scene (shared 2-core machine)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="10 and 100 observers")
    parser.add_argument("--emission", type=Path, default=None, help="demo emission raster")
    args = harness.parse_args(parser)
    counts = QUICK_COUNTS if args.quick else COUNTS
    project = demo()
    kernel = get_or_build_kernel(demo_kernel(project), progress=False).kernel
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        emission = args.emission or demo_emission(project, folder)
        prepare = time.perf_counter() - start
        lit = int(np.count_nonzero(np.nansum(as_raster(emission).data, axis=0) > 0))
        for top_cells in (5, 0):  # compile and warm both paths
            run(emission, kernel, points(emission, 4), folder, top_cells=top_cells)
        runs, summaries = [], {}
        for count in counts:
            xy = points(emission, count)
            for scheduler in SCHEDULERS:
                done = run(emission, kernel, xy, folder, scheduler=scheduler)
                runs.append(done["row"])
                summaries[count] = done["summary"]
            runs.append(run(emission, kernel, xy, folder, scheduler="threads", top_cells=0)["row"])
        xy = points(emission, REFERENCE_OBSERVERS)
        ref = reference(emission, kernel, xy, summaries[counts[0]])
        searched = candidates(emission, kernel, points(emission, counts[-1]), 5)
    for row in runs:
        row["speedup_vs_reference"] = ref["per_observer_ms"] / row["per_observer_ms"]
    result = {
        "scene": {
            "lit_cells": lit,
            "emission_seconds": prepare,
            "kernel": "the demo project's [kernel]",
        },
        "runs": runs,
        "reference": ref,
        "top_cell_candidates": searched,
        "cores": os.cpu_count(),
    }
    harness.write_results(args.out, "sky_observers", result, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
