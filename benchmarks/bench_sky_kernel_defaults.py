"""Benchmark: the kernel build's defaults against the exact path (time, file, error, memory).

The defaults of :class:`nightlights.sky.KernelSpec` (and so of ``nightlights kernel build``)
are the settings the lever benchmarks chose: 6 Gauss nodes per panel
(``bench_sky_kernel_nodes.py``), every 15th altitude pair integrated along each line of
equal h_c - h_o with the interpolated span capped at 937.5 m (``bench_sky_kernel_altitudes.py``,
``bench_sky_kernel_fast_precompute.py``), and one float32 PCA basis shared by the observer
altitudes at a 0.3 % error target (``bench_sky_kernel_storage.py``), found by a randomized
range finder (``nightlights.sky.pca.sketched_basis``); such a kernel without raw tables is
built through a temporary folder (the integrated pairs, then one observer level at a time).
The exact path (``KernelSpec.exact()``, ``kernel build --exact``) integrates every pair at 12
nodes and compresses each observer level by explained energy in float64, in memory.

Each build runs in a child process (``build_kernel`` to a file, as ``kernel build`` does,
raw tables not stored): wall time, file size, peak resident memory over the child's baseline
after a warm-up build (imports, compiled integrators, the multiple-scattering tables of the
atmosphere), and :func:`nightlights.sky.build.kernel_memory`, the estimate the memory check
reads. Error: mean relative error over the pixels brighter than 1 % of their image's maximum
of the default kernel's images (coefficients x bases) against the exact path's, over every
altitude pair, distance and emission.

Cases:

* ``reduced``: Dobashi's altitudes and distances (16 x 16 levels, 62.5 m apart; 32 bins of
  312.5 m to 10 km; turbidity 1.3) on a 16 x 64 panorama, defaults and exact;
* ``levels``: peak memory against the number of observer levels (1 and 16; 8 source levels,
  64 bins, 32 x 128 panorama), the streamed defaults and the same settings in memory
  (``store_tables=True``: the raw tables are output, so they are held);
* ``dobashi``: Dobashi's configuration in full (64 x 256 panorama, 128 distances of 78.125 m,
  16 x 16 levels, turbidity 1.3), defaults; ``dobashi-exact``: the exact path in full (the
  error over every image needs both files in ``--keep``); the defaults' error is also
  measured on a sample of altitude pairs against the exact path's images integrated directly
  (12 nodes, multiple-scattering factor applied), which needs no exact build.

Measured (this 2-core machine, shared with other jobs): Dobashi's configuration at the
defaults in 90 s wall, 134 s of CPU (load average 1.9-2.7; target 4 min: met), 16.0 MB
(target 50 MB), 103 bases, 0.29 % mean error against the exact path's images of 8 sampled
pairs (target 0.5 %; worst pair 0.95 %), peak 0.78 GiB against the 1.53 GiB estimate (x1.97:
the estimate predates the sketched basis, which holds less than the per-level decompositions
did). Before (the per-level decompositions merged into the shared basis, 8 nodes; the same
``build_kernel`` call timed outside this script at load 4): 360 s wall, 287 s of CPU, of
which 203 s integrating the 60 pairs and 128 s the PCA; the first build at these defaults
took 31.3 min (17.0 min of CPU). Reduced grid: defaults 3.7 s (42.6 s before), 1.1 MB, 33
bases, 0.30 % from exact over every image; exact 17.5 s (134.5 s before, at a higher load),
7.8 MB. The ``levels`` rows (peak memory against observer levels) predate the sketched
basis.

Run: ``python benchmarks/bench_sky_kernel_defaults.py [--quick]
[--cases reduced,levels,dobashi,dobashi-exact] [--keep DIR] [--out DIR]``; cases not run keep
their rows from the previous results.
Writes ``sky_kernel_defaults.json`` and ``.png``.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np
from _dobashi import BRIGHT_FRACTION, LEVEL_STEP, RANGE, TURBIDITY, dobashi_spec

NAME = "sky_kernel_defaults"
#: Targets: Dobashi's configuration at the defaults [s], [MB], mean relative error [1], and
#: the estimate within this factor of the measured peak [1].
TARGETS = {"seconds": 240.0, "file_megabytes": 50.0, "mean_rel_error": 0.005, "estimate": 1.5}
#: Altitude pairs of Dobashi's configuration compared with directly integrated exact images.
SAMPLE_PAIRS = ((0, 3), (14, 1), (9, 10), (13, 8), (10, 8), (7, 7), (1, 15), (15, 15))


def case_spec(case: dict[str, Any]) -> Any:
    """The specification of a case: Dobashi's altitudes and range on a grid, default or exact
    settings; ``n_observer`` observer levels (default as many as source levels)."""
    from nightlights.sky import KernelSpec

    n_levels, n_r, n_el, n_az = case["grid"]
    spec = dobashi_spec(n_levels, n_r, n_el, n_az, exact=case["exact"], store_tables=False)
    fields: dict[str, Any] = {}
    if case.get("n_observer"):
        fields["observer_altitudes"] = np.arange(case["n_observer"]) * LEVEL_STEP
    if case.get("store_tables"):
        fields["store_tables"] = True
    if not fields:
        return spec
    import dataclasses

    base = {f.name: getattr(spec, f.name) for f in dataclasses.fields(KernelSpec)}
    base.pop("r_min"), base.pop("r_max"), base.pop("n_distance")
    return KernelSpec(**(base | fields))


def _rss_bytes() -> int:
    """Resident memory of this process now [B]."""
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def child(case: dict[str, Any]) -> None:
    """Build one case to ``case["path"]`` and print its figures as one JSON line."""
    from nightlights.sky import KernelSpec, build_kernel
    from nightlights.sky.atmosphere import Atmosphere
    from nightlights.sky.build import kernel_memory, streams

    warm = KernelSpec(r_max=RANGE, n_distance=2, n_elevation=2, n_azimuth=4)
    build_kernel(warm, progress=False)  # imports and compiled integrators
    build_kernel(  # the multiple-scattering tables of the atmosphere (cached)
        KernelSpec(
            r_max=RANGE,
            n_distance=2,
            n_elevation=2,
            n_azimuth=4,
            atmosphere=Atmosphere(turbidity=TURBIDITY),
        ),
        progress=False,
    )
    spec = case_spec(case)
    baseline = _rss_bytes()
    cpu = time.process_time()
    start = time.perf_counter()
    result = build_kernel(spec, case["path"], progress=False)
    seconds = time.perf_counter() - start
    cpu = time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    ds = result.kernel
    print(
        json.dumps(
            {
                "seconds": seconds,
                "cpu_seconds": cpu,
                "peak_gib": (peak - baseline) / 2**30,
                "estimate_gib": kernel_memory(spec) / 2**30,
                "streamed": streams(spec),
                "file_megabytes": os.path.getsize(case["path"]) / 1e6,
                "components": int(ds.sizes["component"]),
                "pca_mean_error": float(ds.attrs.get("pca_mean_error", float("nan"))),
                "pairs_computed": _pairs_computed(spec),
            }
        ),
        flush=True,
    )


def _pairs_computed(spec: Any) -> int:
    from nightlights.sky.build import altitude_pairs

    computed, _ = altitude_pairs(
        np.asarray(spec.observer_altitudes), np.asarray(spec.source_altitudes), spec.altitude_step
    )
    return int(computed.sum())


def run_case(case: dict[str, Any], folder: Path) -> dict[str, Any]:
    """Run one case in a child process; its figures with the case's description."""
    path = folder / f"{case['label']}.nc"
    load = os.getloadavg()[0]
    text = json.dumps(case | {"path": str(path)})
    done = subprocess.run(
        [sys.executable, __file__, "--child", text], capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        raise RuntimeError(f"{case['label']}: {done.stderr[-2000:]}")
    row = json.loads(done.stdout.strip().splitlines()[-1])
    row |= {
        "case": case["label"],
        "settings": "exact" if case["exact"] else "defaults",
        "grid": case["grid"],
        "n_observer": case.get("n_observer") or case["grid"][0],
        "store_tables": bool(case.get("store_tables")),
        "load_before": load,
        "load_after": os.getloadavg()[0],
        "path": str(path),
    }
    print(
        f"{case['label']}: {row['seconds']:.1f} s, peak {row['peak_gib']:.3f} GiB "
        f"(estimate {row['estimate_gib']:.3f}), {row['file_megabytes']:.1f} MB, "
        f"{row['components']} bases",
        flush=True,
    )
    return row


def kernel_images(path: str, observer: int) -> np.ndarray:
    """One observer level's images of every emission (coefficients x bases), shape
    ``(rows, el, az)``."""
    from nightlights.sky.store import read_kernel

    ds = read_kernel(path)
    basis = np.asarray(ds["basis"].isel(observer_altitude=observer).values, dtype=float)
    names = [v for v in ds.data_vars if str(v).startswith("coefficient")]
    coefficients = [
        np.asarray(ds[v].isel(observer_altitude=observer).values, dtype=float) for v in names
    ]
    coefficient = np.concatenate([c.reshape(-1, c.shape[-1]) for c in coefficients])
    return np.einsum("nk,kea->nea", coefficient, basis)


def error_sums(approx: np.ndarray, exact: np.ndarray) -> tuple[float, int]:
    """Sum and count of the relative errors over the bright pixels of each image."""
    bright = exact > BRIGHT_FRACTION * exact.max(axis=(-2, -1), keepdims=True)
    rel = np.abs(approx[bright] - exact[bright]) / exact[bright]
    return float(rel.sum()), int(rel.size)


def file_error(default_path: str, exact_path: str, n_observer: int) -> dict[str, float]:
    """Error of the default kernel against the exact one over every image."""
    total, count, worst = 0.0, 0, 0.0
    for o in range(n_observer):
        t, n = error_sums(kernel_images(default_path, o), kernel_images(exact_path, o))
        total, count, worst = total + t, count + n, max(worst, t / max(n, 1))
    return {"mean_rel_error": total / max(count, 1), "worst_level_mean_rel_error": worst}


def sample_error(default_path: str, grid: tuple[int, ...]) -> dict[str, Any]:
    """Error of the default kernel against the exact path's images of sampled altitude
    pairs, integrated directly (12 nodes) with the multiple-scattering factor."""
    from nightlights.sky.build import pair_images
    from nightlights.sky.multiple import apply_multiple_scattering

    exact = dobashi_spec(*grid, exact=True, store_tables=False)
    from nightlights.sky.store import read_kernel

    ds = read_kernel(default_path)
    basis = np.asarray(ds["basis"].isel(observer_altitude=0).values, dtype=float)
    rows, total, count = [], 0.0, 0
    start = time.perf_counter()
    for o, c in SAMPLE_PAIRS:
        if o >= grid[0] or c >= grid[0]:
            continue
        reference = pair_images(exact, o, c, "lambertian")[None, None].astype(np.float32)
        apply_multiple_scattering({"lambertian": reference}, exact)
        coefficient = np.asarray(ds["coefficient"].values[o, c], dtype=float)
        approx = np.einsum("rk,kea->rea", coefficient, basis)
        t, n = error_sums(approx, reference[0, 0].astype(float))
        rows.append({"observer_level": o, "source_level": c, "mean_rel_error": t / n})
        total, count = total + t, count + n
    return {
        "sample_mean_rel_error": total / max(count, 1),
        "sample_pairs": rows,
        "sample_seconds": time.perf_counter() - start,
    }


def cases(quick: bool, parts: set[str]) -> list[dict[str, Any]]:
    """The builds to run."""
    out: list[dict[str, Any]] = []
    reduced = (6, 16, 8, 32) if quick else (16, 32, 16, 64)
    if "reduced" in parts:
        out += [
            {"label": "reduced-defaults", "grid": reduced, "exact": False, "part": "reduced"},
            {"label": "reduced-exact", "grid": reduced, "exact": True, "part": "reduced"},
        ]
    if "levels" in parts:
        grid = (4, 16, 8, 32) if quick else (8, 64, 32, 128)
        for n in (1, 2, 4) if quick else (1, 16):
            for store in (False, True):
                out.append(
                    {
                        "label": f"levels-{n}-{'in-memory' if store else 'streamed'}",
                        "grid": grid,
                        "n_observer": n,
                        "exact": False,
                        "store_tables": store,
                        "part": "levels",
                    }
                )
    if "dobashi" in parts:
        grid = (6, 32, 16, 64) if quick else (16, 128, 64, 256)
        out.append({"label": "dobashi-defaults", "grid": grid, "exact": False, "part": "dobashi"})
    if "dobashi-exact" in parts:
        grid = (6, 32, 16, 64) if quick else (16, 128, 64, 256)
        label = "dobashi-exact"
        out.append({"label": label, "grid": grid, "exact": True, "part": "dobashi-exact"})
    return out


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="small grids")
    parser.add_argument(
        "--cases",
        default="reduced,levels,dobashi",
        help="of reduced, levels, dobashi, dobashi-exact",
    )
    parser.add_argument("--keep", type=Path, default=None, help="folder for the kernel files")
    parser.add_argument(
        "--estimates",
        action="store_true",
        help="recompute every row's estimate with the current kernel_memory",
    )
    args = harness.parse_args(parser)
    parts = set(args.cases.split(","))
    folder = args.keep or Path(tempfile.mkdtemp(prefix="kernel-defaults-"))
    folder.mkdir(parents=True, exist_ok=True)
    new = [run_case(case, folder) | {"part": case["part"]} for case in cases(args.quick, parts)]
    # other runs may have written meanwhile: merge with the results as they are now
    previous = harness.previous_results(NAME, args.out) or {}
    rows = [r for r in previous.get("runs", []) if r.get("part") not in parts] + new
    by_label = {row["case"]: row for row in rows}
    for part in ("reduced", "dobashi"):
        default, exact = by_label.get(f"{part}-defaults"), by_label.get(f"{part}-exact")
        paths = [folder / f"{part}-{kind}.nc" for kind in ("defaults", "exact")]
        if default is not None and exact is not None and all(p.is_file() for p in paths):
            default |= file_error(str(paths[0]), str(paths[1]), default["n_observer"])
        if part == "dobashi" and default is not None and "dobashi" in parts:
            default |= sample_error(str(paths[0]), tuple(default["grid"]))
    for row in rows:
        row.pop("path", None)
        if args.estimates:  # the estimate is a function of the specification alone
            from nightlights.sky.build import kernel_memory

            case = {"grid": row["grid"], "exact": row["settings"] == "exact"}
            case |= {"n_observer": row["n_observer"], "store_tables": row["store_tables"]}
            row["estimate_gib"] = kernel_memory(case_spec(case)) / 2**30
    dobashi = by_label.get("dobashi-defaults")
    payload = {
        "kernel": "Dobashi et al. 2023's altitudes and range (16 x 16 levels 62.5 m apart, "
        "distances to 10 km, turbidity 1.3, Lambertian, multiple-scattering factor); grids "
        "(levels, distances, elevations, azimuths) per run",
        "targets": TARGETS,
        "error_measure": "mean |default - exact| / exact over pixels > 1 % of their image's "
        "max, every image of the two kernels (coefficients x bases); sample: Dobashi's "
        "configuration at sampled pairs against images integrated at 12 nodes",
        "memory_measure": "peak resident memory of the child process over its resident memory "
        "after warm-up builds, against kernel_memory(spec)",
        "dobashi_defaults": dobashi,
        "runs": rows,
        "note": "Timings from a shared 2-core machine; load averages (1 min) before and after "
        "each run are recorded, and the CPU time of the build.",
    }
    harness.write_results(args.out, NAME, payload, quick=args.quick, plot=plot)


def plot(payload: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    rows = payload["runs"]
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(14, 4.2))
    compared = [r for r in rows if r["part"] in ("reduced", "dobashi", "dobashi-exact")]
    labels = [r["case"] for r in compared]
    x = np.arange(len(compared))
    ax1.bar(x, [r["seconds"] / 60 for r in compared], color="C0")
    for i, r in enumerate(compared):
        text = f"{r['file_megabytes']:.1f} MB"
        if "mean_rel_error" in r:
            text += f"\n{100 * r['mean_rel_error']:.2f} %"
        if "sample_mean_rel_error" in r:
            text += f"\nsample {100 * r['sample_mean_rel_error']:.2f} %"
        ax1.annotate(text, (i, r["seconds"] / 60), ha="center", va="bottom", fontsize=7)
    ax1.axhline(payload["targets"]["seconds"] / 60, color="grey", ls="--", lw=0.8)
    ax1.set_xticks(x, labels, rotation=20, fontsize=7)
    ax1.set_ylabel("build time [min]")
    ax1.set_title("time; file size and mean error against exact", fontsize=9)
    levels = [r for r in rows if r["part"] == "levels"]
    for store, style in ((False, "o-"), (True, "s--")):
        part = sorted(
            (r for r in levels if r["store_tables"] == store), key=lambda r: r["n_observer"]
        )
        if not part:
            continue
        name = "in memory (raw tables output)" if store else "streamed (default)"
        n = [r["n_observer"] for r in part]
        line = ax2.plot(n, [r["peak_gib"] * 1024 for r in part], style, label=f"{name}: measured")
        ax2.plot(
            n,
            [r["estimate_gib"] * 1024 for r in part],
            ":",
            color=line[0].get_color(),
            label=f"{name}: estimate",
        )
    ax2.set_xscale("log", base=2)
    ax2.set_xlabel("observer levels")
    ax2.set_ylabel("peak over baseline [MiB]")
    ax2.set_title("peak memory against observer levels", fontsize=9)
    ax2.legend(fontsize=7)
    for r in rows:
        marker = "o" if r["settings"] == "defaults" else "s"
        ax3.plot(r["peak_gib"], r["estimate_gib"], marker, color="C0" if r["streamed"] else "C1")
    top = max(max(r["peak_gib"], r["estimate_gib"]) for r in rows) * 1.3
    low = min(min(r["peak_gib"], r["estimate_gib"]) for r in rows) / 1.3
    grid = np.geomspace(low, top, 10)
    ax3.plot(grid, grid, "k-", lw=0.8, label="estimate = peak")
    ax3.plot(grid, 1.5 * grid, "k:", lw=0.8, label="x 1.5, / 1.5")
    ax3.plot(grid, grid / 1.5, "k:", lw=0.8)
    ax3.plot([], [], "o", color="C0", label="streamed")
    ax3.plot([], [], "o", color="C1", label="in memory (o defaults, s exact)")
    ax3.set_xscale("log")
    ax3.set_yscale("log")
    ax3.set_xlabel("measured peak [GiB]")
    ax3.set_ylabel("kernel_memory estimate [GiB]")
    ax3.set_title("memory estimate against measured", fontsize=9)
    ax3.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        child(json.loads(sys.argv[2]))
    else:
        main()
