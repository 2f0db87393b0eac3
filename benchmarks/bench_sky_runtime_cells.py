"""Skyglow runtime against the number of lit cells: PCA+FFT, exact FFT, per-cell baselines.

Targets: >= 1000x speed-up of the PCA+FFT panorama over the naive reference (direct
integration of the kernel for every lit cell, with the compiled integrator; measured at 1-64
cells and at 2,048 cells in full, about 3 minutes) at 2,048 lit cells, and one 256 x 64 panorama in
<= 5 ms at 128 bases after the polar map. Times are medians of repeated calls.

Run: ``python benchmarks/bench_sky_runtime_cells.py [--quick] [--out DIR]`` (``--quick``: up
to 16,384 cells; the naive time at 2,048 cells extrapolated from 1-64 cells).
Writes ``sky_runtime_cells.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import json
from pathlib import Path

import _harness as harness
import numpy as np
from affine import Affine

from nightlights.sky import KernelSpec
from nightlights.sky.panorama import (
    KernelSlice,
    kernel_slice,
    panorama_exact,
    panorama_naive,
    panorama_pca,
)
from nightlights.sky.polar import polar_map
from nightlights.sky.store import get_or_build_kernel

HERE = Path(__file__).parent
CELL = 25.0
SIZE = 2000  # raster of 2000 x 2000 cells of 25 m: 50 km square around the observer
OBSERVER = (SIZE * CELL / 2, SIZE * CELL / 2)
TRANSFORM = Affine(CELL, 0, 0, 0, -CELL, SIZE * CELL)


def median_time(function, repeats: int) -> float:
    """Median wall time of ``repeats`` calls [s]."""
    return harness.repeat(function, repeats).median


def scene(n_cells: int, rng: np.random.Generator) -> np.ndarray:
    """Random lit cells within 24 km of the observer (inside the kernel's 30 km)."""
    emission = np.zeros((1, SIZE, SIZE))
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    r = np.hypot((cols + 0.5) * CELL - OBSERVER[0], (rows + 0.5) * CELL - OBSERVER[1])
    candidates = np.flatnonzero(r.ravel() < 24_000)
    chosen = rng.choice(candidates, size=n_cells, replace=False)
    emission[0].flat[chosen] = rng.uniform(0.1, 10.0, n_cells)
    return emission


def accumulate_images(emission: np.ndarray, tables: KernelSlice) -> np.ndarray:
    """Baseline: add each lit cell's precomputed kernel image, shifted to its azimuth."""
    rows, cols = np.nonzero(emission[0])
    x = (cols + 0.5) * CELL - OBSERVER[0]
    y = OBSERVER[1] - (rows + 0.5) * CELL
    r = np.hypot(x, y)
    d_bin = np.clip(np.searchsorted(tables.distance_edges, r, side="right") - 1, 0, None)
    a_bin = (np.degrees(np.arctan2(x, y)) % 360 * tables.n_az / 360).astype(int)
    flux = emission[0, rows, cols] * CELL * CELL
    image = np.zeros(tables.kernel.shape[2:])
    for i in range(r.size):
        image += flux[i] * np.roll(tables.kernel[0, d_bin[i]], a_bin[i], axis=-1)
    return image


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer cell counts")
    args = harness.parse_args(parser)
    spec = KernelSpec(r_min=10.0, r_max=30_000.0, n_distance=64, n_elevation=64, n_azimuth=256)
    kernel = get_or_build_kernel(spec, cache_dir=HERE / ".cache", progress=False).kernel
    tables = kernel_slice(kernel, observer_altitude=0.0)
    stored = tables.coefficient.shape[-1]
    counts = [1, 8, 64, 512, 2048, 16384] + ([] if args.quick else [131072, 1_000_000])
    rng = np.random.default_rng(0)
    rows = []
    for n in counts:
        emission = scene(n, rng)
        polar = polar_map(
            emission, TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
        )
        row = {
            "lit_cells": n,
            "polar_map_s": median_time(
                lambda e=emission: polar_map(
                    e, TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
                ),
                3,
            ),
            "pca_s": median_time(lambda p=polar: panorama_pca(p, tables), 50),
            "exact_s": median_time(lambda p=polar: panorama_exact(p, tables), 5),
        }
        if n <= 16384:
            row["accumulate_s"] = median_time(lambda e=emission: accumulate_images(e, tables), 1)
        if n <= 64 or (n == 2048 and not args.quick):
            row["naive_s"] = median_time(
                lambda e=emission: panorama_naive(
                    e,
                    TRANSFORM,
                    OBSERVER,
                    elevation=tables.elevation,
                    n_az=tables.n_az,
                    observer_altitude=0.0,
                ),
                1,
            )
        rows.append(row)
        print(row)
    naive_per_cell = np.mean([r["naive_s"] / r["lit_cells"] for r in rows if "naive_s" in r])
    at_2048 = next(r for r in rows if r["lit_cells"] == 2048)
    # measured in full (numba line-of-sight integrator) unless --quick, which extrapolates
    naive_measured = "naive_s" in at_2048
    naive_2048 = at_2048["naive_s"] if naive_measured else naive_per_cell * 2048
    with_polar = at_2048["pca_s"] + at_2048["polar_map_s"]
    # One panorama at 128 bases: the cost depends only on the shapes, so time it with
    # synthetic tables of 128 components (the real kernel stores fewer, see `stored_bases`).
    k = 128
    synthetic = KernelSlice(
        kernel=tables.kernel[:, :, :1],
        coefficient=rng.random((1, tables.coefficient.shape[1], k)),
        basis_fft=rng.random((k, tables.elevation.size, tables.n_az // 2 + 1)) + 0j,
        distance_edges=tables.distance_edges,
        elevation=tables.elevation,
    )
    polar = polar_map(
        scene(2048, rng),
        TRANSFORM,
        OBSERVER,
        distance_edges=tables.distance_edges,
        n_az=tables.n_az,
    )
    pca_128 = median_time(lambda: panorama_pca(polar, synthetic), 200)
    result = {
        "note": "2 shared cores (noisy timings)",
        "panorama": "64 x 256 (elevation x azimuth), 64 distance bins to 30 km",
        "stored_bases": stored,
        "rows": rows,
        "naive_seconds_per_cell": naive_per_cell,
        "naive_2048_seconds": naive_2048,
        "naive_2048_measured": naive_measured,
        "speedup_pca_over_naive_2048": naive_2048 / at_2048["pca_s"],
        "speedup_pca_plus_polar_over_naive_2048": naive_2048 / with_polar,
        "speedup_pca_over_accumulate_2048": at_2048["accumulate_s"] / at_2048["pca_s"],
        "pca_panorama_128_bases_ms": 1000 * pca_128,
        "targets": {"speedup_2048": 1000, "panorama_128_bases_ms": 5},
    }
    harness.write_results(args.out, "sky_runtime_cells", result, quick=args.quick, plot=plot)
    summary = {k: v for k, v in result.items() if k != "rows"}
    print(json.dumps(summary, indent=2))


def plot(result: dict):
    plt = harness.pyplot()
    rows, stored = result["rows"], result["stored_bases"]
    naive_per_cell = result["naive_seconds_per_cell"]
    pca_128 = result["pca_panorama_128_bases_ms"] / 1000
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    n = np.array([r["lit_cells"] for r in rows])
    for key, label in (
        ("polar_map_s", "polar map"),
        ("pca_s", f"PCA+FFT ({stored} bases)"),
        ("exact_s", "exact FFT (no PCA)"),
        ("accumulate_s", "accumulate kernel images per cell"),
    ):
        sel = [r for r in rows if key in r]
        ax.loglog([r["lit_cells"] for r in sel], [r[key] for r in sel], "o-", label=label)
    ax.loglog(n, naive_per_cell * n, "k--", lw=0.8, label="naive, linear in cells")
    ax.loglog(
        [r["lit_cells"] for r in rows if "naive_s" in r],
        [r["naive_s"] for r in rows if "naive_s" in r],
        "ks",
        label="naive, measured",
    )
    ax.axhline(pca_128, color="tab:red", lw=0.8, ls=":", label="PCA panorama, 128 bases")
    ax.set_xlabel("lit cells")
    ax.set_ylabel("time [s]")
    ax.set_title("Skyglow panorama 64 x 256: time against lit cells")
    ax.legend(fontsize=7)
    return fig


if __name__ == "__main__":
    main()
