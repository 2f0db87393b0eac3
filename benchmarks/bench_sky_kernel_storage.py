"""Benchmark: the skyglow kernel's file size, accuracy and load time against the storage levers.

Kernel: Dobashi et al. 2023's altitudes (16 source x 16 observer altitudes in 62.5 m steps;
turbidity 1.3), distances to 10 km (the first bin from 1 m), Lambertian emission, single
scattering (the tables of :func:`nightlights.sky.build.kernel_tables`, computed once;
``--tables-cache`` keeps them in a ``.npy`` file between runs). By default a reduced
configuration: 32 distance bins and a 16 x 64 panorama, 8,192 images of 1,024 pixels.
``--full``: Dobashi's configuration, 128 bins (78.125 m) and a 64 x 256 panorama, 32,768
images of 16,384 pixels (its tables take about 12 min of both cores; with
``--altitude-step 15`` a quarter of that, within 0.1 % of them:
``bench_sky_kernel_altitudes.py``), written to ``sky_kernel_storage_dobashi.json``;
``--quick``: 4 x 4 altitudes.

Levers, each added to the previous one (``today`` is the original path: PCA per observer
altitude at 0.999999 explained energy, float64, raw tables stored, every variable written as
it is in memory):

1. no raw tables (``--no-tables``);
2. the compact layout (:mod:`nightlights.sky.store`: the bases' spectra derived on reading,
   deflate-compressed chunks);
3. float32 bases and coefficients;
4. the number of bases chosen by an error target (1 %) instead of the energy;
5. one basis shared by every observer altitude, at error targets 2, 1 and 0.5 %.

Measured for each: bases, mean relative error of the reconstructed images against the full
tables over the pixels brighter than 1 % of their image's maximum
(:func:`nightlights.sky.pca.bright_relative_error`), its 99th percentile, the compression time,
the file size, the write time, and the load time: :func:`~nightlights.sky.store.read_kernel`
plus :func:`~nightlights.sky.panorama.kernel_slice` at an observer and a source altitude
between levels (what the first panorama needs), best of 3 with the file in the page cache.
Also error against the number of bases for per-level and shared bases, float64 and float32,
on every 4th image (Dobashi's configuration: every 8th).

Targets (the kernel storage issue): <= 50 MB, <= 1 % mean relative error, loaded in <= 1 s.

Run: ``python benchmarks/bench_sky_kernel_storage.py [--quick] [--out DIR]
[--tables-cache FILE.npy]``. Writes ``sky_kernel_storage.json`` and ``.png`` (see
``_harness.py`` for where). Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import gc
import tempfile
import time
from pathlib import Path

import _harness as harness
import numpy as np
from _dobashi import dobashi_spec

from nightlights.sky import KernelSpec
from nightlights.sky.build import kernel_dataset, kernel_tables
from nightlights.sky.panorama import kernel_slice
from nightlights.sky.pca import (
    BRIGHT_FRACTION,
    bright_relative_error,
    decompose_levels,
    shared_basis,
)
from nightlights.sky.store import read_kernel, write_kernel

TARGET_MEGABYTES = 50.0
TARGET_ERROR = 0.01
TARGET_LOAD_SECONDS = 1.0


def spec_for(quick: bool, full: bool) -> KernelSpec:
    """The reduced configuration (``quick``: fewer altitudes; ``full``: Dobashi's), with the
    original storage options."""
    n_el, n_az = (64, 256) if full else (16, 64)
    return dobashi_spec(4 if quick else 16, 128 if full else 32, n_el, n_az)


def images_error(ds, table: np.ndarray) -> tuple[float, float]:
    """Mean and 99th percentile of the relative error of the reconstructed images over the
    bright pixels (one observer level at a time)."""
    n_o, n_c, n_r = table.shape[:3]
    total, count, p99 = 0.0, 0, []
    for o in range(n_o):
        basis = ds["basis"].values[o].reshape(ds.sizes["component"], -1)
        coefficient = ds["coefficient"].values[o].reshape(n_c * n_r, -1)
        exact = table[o].reshape(n_c * n_r, -1).astype(float)
        approx = coefficient @ basis
        peak = exact.max(axis=1, keepdims=True)
        bright = exact > BRIGHT_FRACTION * peak
        rel = np.abs(approx[bright] - exact[bright]) / exact[bright]
        total, count = total + float(rel.sum()), count + rel.size
        p99.append(np.percentile(rel, 99))
    return total / count, float(np.max(p99))


def load_seconds(path: Path, spec: KernelSpec) -> tuple[float, float]:
    """Best of 3 wall and CPU times [s]: read the file and slice it for a first panorama
    (observer and source between levels). On the shared machine the wall time waits for the
    other jobs; the CPU time is this process's own work."""
    h_o = float(np.mean(spec.observer_altitudes[:2]))
    h_c = float(np.mean(spec.source_altitudes[-2:]))
    walls, cpus = [], []
    for _ in range(3):
        wall, cpu = time.perf_counter(), time.process_time()
        kernel_slice(read_kernel(path), observer_altitude=h_o, source_altitude=h_c)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="a reduced kernel (4 x 4 altitudes)")
    parser.add_argument("--tables-cache", type=Path, default=None, help="tables .npy to reuse")
    parser.add_argument("--full", action="store_true", help="Dobashi's 64 x 256 panorama")
    parser.add_argument(
        "--altitude-step", type=int, default=1, help="build the tables with this altitude_step"
    )
    args = harness.parse_args(parser)
    spec = spec_for(args.quick, args.full)
    cache = args.tables_cache
    if cache is not None and cache.is_file():
        table = np.load(cache, mmap_mode="r")
        table = np.ascontiguousarray(table)
        tables_seconds = tables_cpu_seconds = None
    else:
        stepped = KernelSpec(**_spec_arguments(spec), altitude_step=args.altitude_step)
        wall, cpu = time.perf_counter(), time.process_time()
        table = kernel_tables(stepped, progress=False)["lambertian"]
        tables_seconds = time.perf_counter() - wall
        tables_cpu_seconds = time.process_time() - cpu
        if cache is not None:
            np.save(cache, table)
    assert table.shape == (
        len(spec.observer_altitudes),
        len(spec.source_altitudes),
        spec.n_distance,
        spec.n_elevation,
        spec.n_azimuth,
    ), table.shape
    levers = [
        ("today (energy, per level, float64, raw tables)", {}, False),
        ("1. no raw tables", {"store_tables": False}, False),
        ("2. + compact layout", {"store_tables": False}, True),
        ("3. + float32", {"store_tables": False, "precision": "float32"}, True),
        (
            "4. + error target 1 %",
            {"store_tables": False, "precision": "float32", "pca_error": 0.01},
            True,
        ),
    ]
    for error in (0.02, 0.01, 0.005):
        levers.append(
            (
                f"5. + shared bases, error target {100 * error:g} %",
                {
                    "store_tables": False,
                    "precision": "float32",
                    "pca_error": error,
                    "shared_bases": True,
                },
                True,
            )
        )
    levels, decompose_seconds = harness.timed(lambda: decompose_levels(table))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, options, compact in levers:
            variant = KernelSpec(**{**_spec_arguments(spec), **options})
            ds, compress_seconds = harness.timed(
                lambda variant=variant: kernel_dataset(
                    {"lambertian": table}, variant, decompositions=levels
                )
            )
            mean_error, p99_error = images_error(ds, table)
            path = Path(tmp) / "kernel.nc"
            _, write_seconds = harness.timed(
                lambda ds=ds, path=path, compact=compact: write_kernel(ds, path, compact=compact)
            )
            row = {
                "lever": name,
                "options": options,
                "compact_layout": compact,
                "bases": int(ds.sizes["component"]),
                "mean_rel_error": mean_error,
                "p99_rel_error": p99_error,
                "compress_seconds": compress_seconds,
                "file_megabytes": path.stat().st_size / 1e6,
                "write_seconds": write_seconds,
            }
            row["load_seconds"], row["load_cpu_seconds"] = load_seconds(path, variant)
            rows.append(row)
            print(row, flush=True)
            del ds
            path.unlink()
            gc.collect()
    curves = error_curves(table, levels)
    out = {
        "kernel": (
            f"{spec.n_azimuth} az x {spec.n_elevation} el, {spec.n_distance} r to "
            f"{spec.r_max:g} m, {len(spec.source_altitudes)} h_c x "
            f"{len(spec.observer_altitudes)} h_o, turbidity 1.3, Lambertian, single scattering"
        ),
        "tables_altitude_step": args.altitude_step,
        "tables_seconds": tables_seconds,
        "tables_cpu_seconds": tables_cpu_seconds,
        "decompose_seconds": decompose_seconds,
        "levers": rows,
        "error_against_bases": curves,
        "targets": {
            "file_megabytes": TARGET_MEGABYTES,
            "mean_rel_error": TARGET_ERROR,
            "load_seconds": TARGET_LOAD_SECONDS,
        },
        "error_measure": "mean |approx - exact| / exact over pixels > 1 % of their image's max",
        "load_measure": "read_kernel + kernel_slice (observer and source between levels), "
        "best of 3 wall and CPU times, file in the page cache",
        "note": "Timings from a shared 2-core machine, noisy.",
    }
    name = "sky_kernel_storage_dobashi" if args.full else "sky_kernel_storage"
    harness.write_results(args.out, name, out, quick=args.quick, plot=plot, dpi=110)


def _spec_arguments(spec: KernelSpec) -> dict:
    return {
        "distance_edges": spec.distance_edges,
        "source_altitudes": spec.source_altitudes,
        "observer_altitudes": spec.observer_altitudes,
        "n_elevation": spec.n_elevation,
        "n_azimuth": spec.n_azimuth,
        "atmosphere": spec.atmosphere,
    }


def error_curves(table: np.ndarray, levels: list) -> dict[str, list[dict]]:
    """Mean relative error against the number of bases: per level and shared, float64 and
    float32 (every n-th image of each level: 4th, or fewer for at most 4096 images)."""
    n_o, n_c, n_r, n_el, n_az = table.shape
    stride = max(4, n_o * n_c * n_r // 4096)
    sample = [level.images[::stride].astype(float) for level in levels]
    counts = [4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256]
    counts = [k for k in counts if k <= min(n_c * n_r, n_el * n_az)]
    # each level contributes the components of 1 - 1e-6 of its energy to the merge
    shared, _, _ = shared_basis(levels, n_components=max(counts), energy=1.0 - 1e-4)
    per_level = [level.basis(max(counts)) for level in levels]
    curves: dict[str, list[dict]] = {}
    for precision in ("float64", "float32"):
        dtype = np.float32 if precision == "float32" else np.float64
        for kind, bases in (("shared", [shared] * n_o), ("per_level", per_level)):
            points = []
            for k in counts:
                approx, exact = [], []
                for o in range(n_o):
                    b = bases[o][:k].astype(dtype).astype(float)
                    coefficient = (sample[o] @ b.T).astype(dtype).astype(float)
                    approx.append(coefficient @ b)
                    exact.append(sample[o])
                error = bright_relative_error(np.concatenate(approx), np.concatenate(exact))
                stored = (1 if kind == "shared" else n_o) * k * n_el * n_az + n_o * n_c * n_r * k
                points.append(
                    {
                        "bases": k,
                        "mean_rel_error": error,
                        "pca_megabytes": stored * (4 if precision == "float32" else 8) / 1e6,
                    }
                )
            curves[f"{kind}_{precision}"] = points
            print(kind, precision, [(p["bases"], round(p["mean_rel_error"], 5)) for p in points])
    return curves


def plot(out: dict):
    plt = harness.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 6.0))
    rows = out["levers"]
    for index, row in enumerate(rows):
        ax1.loglog(
            row["file_megabytes"],
            max(row["mean_rel_error"], 1e-6),
            "o",
            color=f"C{index}",
            label=f"{row['lever']}: {row['bases']} bases, {row['file_megabytes']:.3g} MB, "
            f"load {row['load_seconds']:.2f} s ({row['load_cpu_seconds']:.2f} s CPU)",
        )
    ax1.axhline(out["targets"]["mean_rel_error"], color="grey", ls=":", lw=0.8)
    ax1.set_xlabel("file size [MB]")
    ax1.set_ylabel("mean relative error (pixels > 1 % of max)")
    ax1.set_title("Storage levers, each added to the previous")
    ax1.legend(fontsize=6, loc="upper left", bbox_to_anchor=(0.0, -0.14))
    for name, points in out["error_against_bases"].items():
        style = "-" if name.startswith("shared") else "--"
        marker = "o" if name.endswith("float64") else "x"
        ax2.loglog(
            [p["bases"] for p in points],
            [max(p["mean_rel_error"], 1e-6) for p in points],
            style + marker,
            label=name.replace("_", " "),
        )
    ax2.axhline(out["targets"]["mean_rel_error"], color="grey", ls=":", lw=0.8)
    ax2.set_xlabel("PCA bases")
    ax2.set_ylabel("mean relative error (pixels > 1 % of max)")
    ax2.set_title("Error against bases and precision (a sample of the images)")
    ax2.legend(fontsize=7)
    fig.suptitle(out["kernel"], fontsize=8)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
