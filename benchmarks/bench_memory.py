"""Benchmark: peak memory, wall and CPU time of every stage, on the demo and on 100,000 lights.

Each stage runs in a fresh interpreter (``subprocess``) on inputs prepared beforehand, and
reports its peak resident memory (``VmHWM`` of ``/proc/self/status``: the high-water mark
of the whole process, interpreter and libraries included), its wall time and its CPU time
(all threads). Scenes:

* ``demo``: the bundled Helsinki example as its project file runs it (streets normalize,
  sample and place with the project's seed, then irradiance at 1 m with the photopic and
  scotopic bands, emission at 50 m with albedo 0.15);
* ``city_100k`` (``--full``): 100,000 luminaires over 10 x 10 km at 1 m (the irradiance
  throughput benchmark's scene, 1,000 luminaires per km2), irradiance then emission at
  50 m.

Both irradiance kernels (``numba``, ``numpy``) run on the demo; the 100,000-luminaire scene
runs the default (``numba``) only (the numpy kernel's run is the throughput benchmark's
dated figure).

Every other stage runs as a project run does it (:func:`nightlights.run`):
the project's tables grow by one stage at a time and each run, in a fresh interpreter, finds
the stages before it up to date, so it runs only the new one (the figures include checking
the upstream outputs' hashes). The project's kernel is built first in a process of its own
(into an empty cache). The demo is ``helsinki.toml`` plus a darkness map; the
100,000-luminaire scene (``--full``) is its emission raster with two observers, one in the
city's centre and one 2 km outside its edge, and the same sky stages and kernel as the demo.
Last, the night sky (stars, Moon and skyglow; :func:`nightlights.sky_render`) is rendered
from the first observer's panorama.

The limit the stages are held to is 4 GiB. Timings come from a shared 2-core machine and are
noisy (wall times more than CPU times).

Run: ``python benchmarks/bench_memory.py [--quick] [--full] [--out DIR]`` (``--quick``: the
demo with the compiled kernel only, no sky stages). Writes ``memory.json`` and ``.png``.
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _harness as harness

LIMIT_GIB = 4.0

#: Runs one stage in a fresh interpreter and prints its figures as JSON.
STAGE = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
import nightlights as nl

def high_water():
    with open("/proc/self/status") as f:
        fields = dict(line.split(":", 1) for line in f)
    return int(fields["VmHWM"].split()[0]) * 1024

kind, source, out, backend = sys.argv[1:5]
wall, cpu = time.perf_counter(), time.process_time()
if kind == "project":
    with open(source) as f:
        result = nl.run(json.load(f), out, progress=False)
    extra = {"ran": result.ran}
elif kind == "kernel":
    from nightlights.project._tasks import kernel_spec
    from nightlights.sky.store import get_or_build_kernel
    with open(source) as f:
        spec = kernel_spec(nl.load_project(json.load(f)))
    get_or_build_kernel(spec, progress=False)
    extra = {"ran": ["kernel"]}
elif kind == "render":
    result = nl.sky_render(None, out, time="2026-01-25T20:00:00Z", panorama=source)
    extra = {"lonlat": list(result.lonlat)}
elif kind == "irradiance":
    result = nl.irradiance(
        source, out, resolution=1.0, sensors=tuple(sys.argv[5].split(",")), backend=backend,
        progress=False,
    )
    grid = result.grid  # not result.raster, which would read the streamed file back
    extra = {"pairs": result.n_pairs, "lights": result.n_lights, "shape": [grid.rows, grid.cols]}
else:
    result = nl.emission(source, out, resolution=50.0, albedo=0.15)
    extra = {"shape": result.raster.shape}
print(json.dumps({
    "peak_bytes": high_water(),
    "wall_s": time.perf_counter() - wall,
    "cpu_s": time.process_time() - cpu,
    **extra,
}))
"""


def demo_lights(folder: Path) -> Path:
    """The demo's light layer (streets normalize, sample, place with the project's seed)."""
    import tomllib

    import nightlights as nl
    from nightlights.demo import example_path

    seed = tomllib.loads(example_path("helsinki.toml").read_text())["project"]["seed"]
    normalized = nl.normalize(example_path(), folder / "streets_norm.gpkg", mapping="osm")
    sampled = nl.sample(normalized.streets, folder / "streets_lit.gpkg", seed=seed)
    lights = folder / "lights.gpkg"
    nl.place(sampled.streets, lights, seed=seed)
    return lights


def city_lights(folder: Path) -> Path:
    """The throughput benchmark's 100,000 luminaires over 10 x 10 km."""
    from bench_irradiance_throughput import scene_frame

    lights = folder / "city_lights.gpkg"
    scene_frame(10_000.0).to_file(lights, driver="GPKG")
    return lights


def run_stage(
    kind: str, source: Path, out: Path, backend: str, sensors: str, env: dict | None = None
) -> dict:
    """One stage in a fresh interpreter; its figures."""
    command = [sys.executable, "-c", STAGE, kind, str(source), str(out), backend, sensors]
    done = subprocess.run(command, capture_output=True, text=True, check=False, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{kind} failed:\n{done.stderr[-3000:]}")
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    figures["peak_gib"] = figures["peak_bytes"] / 2**30
    figures["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    print(kind, backend, json.dumps(figures), flush=True)
    return figures


def scene_runs(name: str, lights: Path, folder: Path, backends: tuple[str, ...], sensors: str):
    rows = []
    for backend in backends:
        ground = folder / f"{name}_{backend}_irradiance.tif"
        rows.append(
            {
                "scene": name,
                "stage": "irradiance",
                "backend": backend,
                **run_stage("irradiance", lights, ground, backend, sensors),
            }
        )
    emission = run_stage("emission", ground, folder / f"{name}_emission.tif", "-", "-")
    rows.append({"scene": name, "stage": "emission", "backend": "-", **emission})
    return rows


#: The sky stages of the demo project, in the order they run, and the darkness map.
SKY_STAGES = ("skyglow", "observers", "inverse-q", "inverse-s", "inverse-reduce", "darkness")


def demo_project() -> dict:
    """``helsinki.toml`` as a mapping with absolute paths, plus a darkness map."""
    import tomllib

    from nightlights.demo import example_path

    path = example_path("helsinki.toml")
    tables = tomllib.loads(path.read_text())
    tables["inputs"]["streets"] = str(path.parent / tables["inputs"]["streets"])
    tables["stages"]["darkness"] = {}
    return tables


def city_project(emission: Path, demo: dict) -> dict:
    """The 100,000-luminaire scene's emission with the demo's kernel and sky stages."""
    from bench_irradiance_throughput import scene_frame

    crs = scene_frame(1_000.0).crs.to_string()
    tables = {key: copy.deepcopy(demo[key]) for key in ("project", "atmosphere", "kernel")}
    tables["project"]["name"] = "city_100k"
    tables["inputs"] = {"emission": str(emission)}
    # the scene spans 0-10 km in its CRS: one observer in the centre, one 2 km outside
    tables["observers"] = {
        "crs": crs,
        "height": demo["observers"]["height"],
        "points": {"centre": [5_000.0, 5_000.0], "outside": [12_000.0, 5_000.0]},
    }
    tables["stages"] = {
        "skyglow": {},
        "observers": {},
        "inverse-q": {"observer": "centre", "metric": "zenith"},
        "inverse-s": {"observer": "outside", "region": "horizon:240,300,20"},
        "inverse-reduce": {"by": "inverse-s", "qa": "50%", "qb": "90%"},
        "darkness": {},
    }
    return tables


def project_runs(name: str, tables: dict, folder: Path) -> list:
    """The project's kernel, then one run per stage added (each in a fresh interpreter)."""
    from nightlights.project import STAGES

    env = {**os.environ, "NIGHTLIGHTS_CACHE": str(folder / f"{name}_cache")}
    out = folder / f"{name}_project"
    chosen = tables["stages"]
    order = [stage for stage in STAGES if stage in chosen]
    spec_file = folder / f"{name}_kernel.json"
    spec_file.write_text(json.dumps(tables))
    rows = [
        {"scene": name, "stage": "kernel build", "backend": "-"}
        | run_stage("kernel", spec_file, out, "-", "-", env)
    ]
    for count, stage in enumerate(order, start=1):
        step = {**tables, "stages": {s: chosen[s] for s in order[:count]}}
        path = folder / f"{name}_{count}.json"
        path.write_text(json.dumps(step))
        figures = run_stage("project", path, out, "-", "-", env)
        rows.append({"scene": name, "stage": stage, "backend": "-", **figures})
    # the night sky (stars, Moon, skyglow) rendered from the first observer's panorama
    panorama = sorted(out.glob("skyglow_*.nc"))[0]
    figures = run_stage("render", panorama, folder / f"{name}_sky.png", "-", "-", env)
    rows.append({"scene": name, "stage": "sky render", "backend": "-", **figures})
    return rows


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="the demo with the compiled kernel only")
    parser.add_argument("--full", action="store_true", help="also the 100,000-luminaire scene")
    args = harness.parse_args(parser)
    rows = []
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        backends = ("numba",) if args.quick else ("numba", "numpy")
        rows += scene_runs("demo", demo_lights(folder), folder, backends, "photopic,scotopic")
        demo = demo_project()
        if not args.quick:
            rows += project_runs("demo project", demo, folder)
        if args.full:
            rows += scene_runs("city_100k", city_lights(folder), folder, ("numba",), "photopic")
            emission = folder / "city_100k_emission.tif"
            rows += project_runs("city_100k", city_project(emission, demo), folder)
    previous = harness.previous_results("memory", args.out)
    if not args.full and previous is not None:
        # keep the last run of the large scene (dated in its rows) when only the demo reruns
        rows += [row for row in previous.get("runs", []) if row["scene"] == "city_100k"]
    payload = {
        "limit_gib": LIMIT_GIB,
        "note": "peak = VmHWM of a fresh interpreter running one stage (imports included); "
        "'demo project' and the city's sky stages run as project runs that add one stage at a "
        "time (the stages before are up to date and skipped); timings from a shared 2-core "
        "machine, noisy",
        "largest_peak_gib": round(max(row["peak_gib"] for row in rows), 3),
        "runs": rows,
    }
    harness.write_results(args.out, "memory", payload, quick=args.quick, plot=plot)


def plot(payload: dict):
    plt = harness.pyplot()
    rows = payload["runs"]
    fig, axis = plt.subplots(figsize=(8, 0.32 * len(rows) + 1.2))
    labels = [
        f"{r['scene']}: {r['stage']}" + (f" ({r['backend']})" if r["backend"] != "-" else "")
        for r in rows
    ]
    colours = {"demo": "tab:blue", "demo project": "tab:cyan", "city_100k": "tab:orange"}
    positions = range(len(rows))[::-1]
    bars = axis.barh(
        list(positions),
        [r["peak_gib"] for r in rows],
        color=[colours.get(r["scene"], "tab:grey") for r in rows],
    )
    for bar, row in zip(bars, rows, strict=True):
        axis.annotate(
            f" {row['peak_gib']:.2f} GiB, {row['wall_s']:.0f} s wall, {row['cpu_s']:.0f} s CPU",
            (bar.get_width(), bar.get_y() + bar.get_height() / 2),
            va="center",
            fontsize=7,
        )
    axis.set_yticks(list(positions), labels, fontsize=8)
    axis.axvline(payload["limit_gib"], color="grey", ls="--", label="4 GiB limit")
    axis.set_xlabel("peak resident memory [GiB]")
    axis.set_xlim(0, payload["limit_gib"] * 1.45)
    axis.legend(fontsize=8, loc="lower right")
    axis.set_title("Peak memory per stage (fresh process each), shared 2-core machine", fontsize=9)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
