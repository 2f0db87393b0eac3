"""Benchmark: peak memory, wall and CPU time of the irradiance and emission stages.

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
dated figure). The limit the stages are held to is 4 GiB. Timings come from a shared 2-core
machine and are noisy (wall times more than CPU times).

Run: ``python benchmarks/bench_memory.py [--quick] [--full] [--out DIR]`` (``--quick``: the
demo with the compiled kernel only). Writes ``memory.json`` and ``.png``.
"""

from __future__ import annotations

import json
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
if kind == "irradiance":
    result = nl.irradiance(
        source, out, resolution=1.0, sensors=tuple(sys.argv[5].split(",")), backend=backend,
        progress=False,
    )
    extra = {"pairs": result.n_pairs, "lights": result.n_lights, "shape": result.raster.shape}
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


def run_stage(kind: str, source: Path, out: Path, backend: str, sensors: str) -> dict:
    """One stage in a fresh interpreter; its figures."""
    command = [sys.executable, "-c", STAGE, kind, str(source), str(out), backend, sensors]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
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


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="the demo with the compiled kernel only")
    parser.add_argument("--full", action="store_true", help="also the 100,000-luminaire scene")
    args = harness.parse_args(parser)
    rows = []
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        backends = ("numba",) if args.quick else ("numba", "numpy")
        rows += scene_runs("demo", demo_lights(folder), folder, backends, "photopic,scotopic")
        if args.full:
            rows += scene_runs("city_100k", city_lights(folder), folder, ("numba",), "photopic")
    previous = harness.previous_results("memory", args.out)
    if not args.full and previous is not None:
        # keep the last run of the large scene (dated in its rows) when only the demo reruns
        rows += [row for row in previous.get("runs", []) if row["scene"] == "city_100k"]
    payload = {
        "limit_gib": LIMIT_GIB,
        "note": "peak = VmHWM of a fresh interpreter running one stage (imports included); "
        "timings from a shared 2-core machine, noisy",
        "runs": rows,
    }
    harness.write_results(args.out, "memory", payload, quick=args.quick, plot=plot)


def plot(payload: dict):
    plt = harness.pyplot()
    rows = payload["runs"]
    fig, axis = plt.subplots(figsize=(8, 4))
    labels = [
        f"{r['scene']}\n{r['stage']}" + (f"\n({r['backend']})" if r["backend"] != "-" else "")
        for r in rows
    ]
    bars = axis.bar(labels, [r["peak_gib"] for r in rows], color="tab:blue")
    for bar, row in zip(bars, rows, strict=True):
        axis.annotate(
            f"{row['peak_gib']:.2f} GiB\n{row['wall_s']:.0f} s wall\n{row['cpu_s']:.0f} s CPU",
            (bar.get_x() + bar.get_width() / 2, bar.get_height()),
            ha="center",
            va="bottom",
            fontsize=7,
        )
    axis.axhline(payload["limit_gib"], color="grey", ls="--", label="4 GiB limit")
    axis.set_ylabel("peak resident memory [GiB]")
    axis.set_ylim(0, payload["limit_gib"] * 1.15)
    axis.legend(fontsize=8)
    axis.set_title("Peak memory per stage (fresh process each), shared 2-core machine", fontsize=9)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
