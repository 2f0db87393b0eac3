"""Polar map resolution: sub-cell supersampling near the observer, time against error.

Knob: ``max_samples`` of :func:`nightlights.sky.polar.polar_map` (the largest number of
sub-points per cell side; cells close to the observer, which span many azimuth bins, are split
into up to max_samples^2 sub-points so that their flux lands in the right azimuths). Scene: a
lit town of 10 m cells (4 x 4 km) with the observer inside it, offset from a cell centre, and a
second town 3 km away. Reference: max_samples = 128. Error: mean relative error of the exact
FFT panorama (no PCA, so only the polar map differs) over pixels brighter than 1 % of the
maximum, and the largest relative error in the 20 deg above the horizon, where the observer's
own neighbourhood dominates. Time: the polar map (best of 3).

Writes benchmarks/results/sky_polar_supersampling.{json,png}.

    python benchmarks/bench_sky_polar_supersampling.py
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from affine import Affine

from nightlights.sky.panorama import kernel_slice, panorama_exact
from nightlights.sky.polar import polar_map
from nightlights.sky.precompute import build_kernel

HERE = Path(__file__).parent
RESULTS = HERE / "results"
CELL = 10.0
SIZE = 800  # 8 km square
TRANSFORM = Affine(CELL, 0, 0, 0, -CELL, SIZE * CELL)
OBSERVER = (4003.0, 3996.5)
SAMPLES = (1, 2, 4, 8, 16, 32, 64)


def scene() -> np.ndarray:
    rng = np.random.default_rng(7)
    emission = np.zeros((1, SIZE, SIZE))
    emission[0, 200:600, 200:600] = rng.uniform(0.0, 1.0, (400, 400)) ** 4  # streets and gaps
    emission[0, 80:120, 680:720] = 2.0  # a second town ~4 km north-east
    return emission


def error(test: np.ndarray, reference: np.ndarray, rows: np.ndarray | slice) -> tuple:
    bright = reference > 0.01 * reference.max()
    rel = np.abs(test - reference) / np.where(bright, reference, 1.0)
    return float(np.mean(rel[bright])), float(np.max(rel[rows][bright[rows]]))


def main() -> None:
    RESULTS.mkdir(exist_ok=True)
    kernel = build_kernel(r_min=5.0, r_max=12_000.0, n_r=64, n_el=32, n_az=256, progress=False)
    tables = kernel_slice(kernel, observer_altitude=1.7)
    emission = scene()
    low_rows = tables.elevation < 20.0

    def panorama(samples: int) -> tuple[np.ndarray, float]:
        best = np.inf
        for _ in range(3):
            start = time.perf_counter()
            polar = polar_map(
                emission,
                TRANSFORM,
                OBSERVER,
                distance_edges=tables.distance_edges,
                n_az=tables.n_az,
                max_samples=samples,
            )
            best = min(best, time.perf_counter() - start)
        return panorama_exact(polar, tables), best

    reference, ref_seconds = panorama(128)
    rows = []
    for samples in SAMPLES:
        pano, seconds = panorama(samples)
        mean, worst_low = error(pano, reference, low_rows)
        rows.append(
            {
                "max_samples": samples,
                "polar_map_seconds": seconds,
                "mean_rel_error": mean,
                "max_rel_error_below_20deg": worst_low,
            }
        )
        print(rows[-1], flush=True)
    result = {
        "benchmark": "sky_polar_supersampling",
        "scene": "4 x 4 km town of 10 m cells around the observer + a town 4 km away",
        "reference": {"max_samples": 128, "polar_map_seconds": ref_seconds},
        "default_max_samples": 16,
        "rows": rows,
        "note": "Timings from a shared 2-core machine, noisy.",
    }
    (RESULTS / "sky_polar_supersampling.json").write_text(json.dumps(result, indent=2))

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    n = [r["max_samples"] for r in rows]
    ax1.loglog(n, [max(r["mean_rel_error"], 1e-12) for r in rows], "o-", label="mean")
    ax1.loglog(
        n, [max(r["max_rel_error_below_20deg"], 1e-12) for r in rows], "s--", label="max, < 20 deg"
    )
    ax1.axvline(16, color="grey", lw=0.8, ls=":")
    ax1.set_xlabel("max sub-points per cell side")
    ax1.set_ylabel("relative error vs 128")
    ax1.legend(fontsize=8)
    ax2.loglog([r["polar_map_seconds"] for r in rows], [r["mean_rel_error"] for r in rows], "o-")
    for r in rows:
        ax2.annotate(str(r["max_samples"]), (r["polar_map_seconds"], r["mean_rel_error"]))
    ax2.set_xlabel("polar map time [s]")
    ax2.set_ylabel("mean relative error")
    fig.suptitle("Polar map: sub-cell supersampling near the observer (observer inside a town)")
    fig.tight_layout()
    fig.savefig(RESULTS / "sky_polar_supersampling.png", dpi=110)


if __name__ == "__main__":
    main()
