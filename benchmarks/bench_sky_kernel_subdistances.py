"""Kernel bin images: distances averaged per bin (``sub_distances``), time against error.

Knob: ``sub_distances`` of :func:`nightlights.sky.precompute.build_kernel`, the Gauss-Legendre
nodes in ln r whose area-weighted mean (weights r^2) stands for a distance bin (1 = the
geometric bin centre). The pixels next to the source direction always average at least 4
distances (and 8 x 8 directions). Reference: 16 distances per bin. Error: per bin image, the
mean relative error over pixels brighter than 1 % of that image's maximum; reported as the
mean over bins and the worst bin. Grids: 64 bins over 10 m - 100 km and 128 bins over
10 m - 300 km, 32 x 128 images, sources at the observer's altitude and 300 / 500 m above it
(where the source is seen above the horizon and moves across pixels within a bin).

Writes benchmarks/results/sky_kernel_subdistances.{json,png}.

    python benchmarks/bench_sky_kernel_subdistances.py
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from nightlights.sky.precompute import build_kernel

HERE = Path(__file__).parent
RESULTS = HERE / "results"
CASES = (
    ("64 bins 10 m-100 km, h_c = 0", 64, 100_000.0, 0.0),
    ("64 bins 10 m-100 km, h_c = 300 m", 64, 100_000.0, 300.0),
    ("128 bins 10 m-300 km, h_c = 500 m", 128, 300_000.0, 500.0),
)
SUBS = (1, 2, 3, 4)


def images(n_r: int, r_max: float, h_c: float, sub: int) -> tuple[np.ndarray, float]:
    start = time.perf_counter()
    ds = build_kernel(
        r_min=10.0,
        r_max=r_max,
        n_r=n_r,
        n_el=32,
        n_az=128,
        source_altitudes=(h_c,),
        sub_distances=sub,
        n_components=1,
        progress=False,
    )
    return ds.kernel.values[0, 0].astype(float), time.perf_counter() - start


def main() -> None:
    RESULTS.mkdir(exist_ok=True)
    build_kernel(n_r=2, n_el=2, n_az=4, progress=False)  # compile
    result: dict = {"benchmark": "sky_kernel_subdistances", "reference_sub_distances": 16}
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for label, n_r, r_max, h_c in CASES:
        reference, _ = images(n_r, r_max, h_c, 16)
        rows = []
        for sub in SUBS:
            test, seconds = images(n_r, r_max, h_c, sub)
            errs = []
            for ref, img in zip(reference, test, strict=True):
                bright = ref > 0.01 * ref.max()
                errs.append(np.mean(np.abs(img[bright] / ref[bright] - 1.0)))
            rows.append(
                {
                    "sub_distances": sub,
                    "seconds": seconds,
                    "mean_rel_error": float(np.mean(errs)),
                    "worst_bin_rel_error": float(np.max(errs)),
                }
            )
            print(label, rows[-1], flush=True)
        result[label] = rows
        line = ax.semilogy(
            [r["seconds"] for r in rows], [r["mean_rel_error"] for r in rows], "o-", label=label
        )
        ax.semilogy(
            [r["seconds"] for r in rows],
            [r["worst_bin_rel_error"] for r in rows],
            "s:",
            color=line[0].get_color(),
        )
        for r in rows:
            ax.annotate(str(r["sub_distances"]), (r["seconds"], r["mean_rel_error"]), fontsize=7)
    result["note"] = "Timings from a shared 2-core machine, noisy. Dotted: worst bin."
    (RESULTS / "sky_kernel_subdistances.json").write_text(json.dumps(result, indent=2))
    ax.set_xlabel("kernel build time (one altitude pair) [s]")
    ax.set_ylabel("relative error vs 16 distances per bin")
    ax.set_title("Kernel bin images: distances per bin (solid mean, dotted worst bin)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / "sky_kernel_subdistances.png", dpi=110)


if __name__ == "__main__":
    main()
