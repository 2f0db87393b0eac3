"""Polar map resolution: sub-cell supersampling near the observer, time against error.

Knob: ``max_samples`` of :func:`nightlights.sky.polar.polar_map` (the largest number of
sub-points per cell side; cells close to the observer, which span many azimuth bins, are split
into up to max_samples^2 sub-points so that their flux lands in the right azimuths). Scene: a
lit town of 10 m cells (4 x 4 km) with the observer inside it, offset from a cell centre, and a
second town 3 km away. Reference: max_samples = 128. Error: mean relative error of the exact
FFT panorama (no PCA, so only the polar map differs) over pixels brighter than 1 % of the
maximum, and the largest relative error in the 20 deg above the horizon, where the observer's
own neighbourhood dominates. Time: the polar map (best of 3).

Run: ``python benchmarks/bench_sky_polar_supersampling.py [--quick] [--out DIR]``
(``--quick``: max_samples 1, 4, 16, 64).
Writes ``sky_polar_supersampling.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np
from affine import Affine

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.panorama import kernel_slice, panorama_exact
from nightlights.sky.polar import polar_map

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
    parser = harness.argument_parser(__doc__, quick="every other max_samples")
    args = harness.parse_args(parser)
    samples_sweep = SAMPLES[::2] if args.quick else SAMPLES
    spec = KernelSpec(r_min=5.0, r_max=12_000.0, n_distance=64, n_elevation=32, n_azimuth=256)
    kernel = build_kernel(spec, progress=False).kernel
    tables = kernel_slice(kernel, observer_altitude=1.7)
    emission = scene()
    low_rows = tables.elevation < 20.0

    def panorama(samples: int) -> tuple[np.ndarray, float]:
        timing = harness.repeat(
            lambda: polar_map(
                emission,
                TRANSFORM,
                OBSERVER,
                distance_edges=tables.distance_edges,
                n_az=tables.n_az,
                max_samples=samples,
            ),
            3,
        )
        return panorama_exact(timing.value, tables), timing.best

    reference, ref_seconds = panorama(128)
    rows = []
    for samples in samples_sweep:
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
        "scene": "4 x 4 km town of 10 m cells around the observer + a town 4 km away",
        "reference": {"max_samples": 128, "polar_map_seconds": ref_seconds},
        "default_max_samples": 16,
        "rows": rows,
        "note": "Timings from a shared 2-core machine, noisy.",
    }
    harness.write_results(
        args.out, "sky_polar_supersampling", result, quick=args.quick, plot=plot, dpi=110
    )


def plot(result: dict):
    plt = harness.pyplot()
    rows = result["rows"]
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
    return fig


if __name__ == "__main__":
    main()
