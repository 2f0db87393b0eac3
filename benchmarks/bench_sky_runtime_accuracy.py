"""Skyglow runtime accuracy against converged references, with the time each setting costs.

Knobs: PCA bases used (reference: the exact FFT panorama), distance bins n_r and azimuth
resolution n_az (reference: the naive panorama, direct integration per lit cell). Error is the
mean relative error over pixels brighter than 1 % of the maximum (the target's measure).

Run: ``python benchmarks/bench_sky_runtime_accuracy.py [--quick] [--out DIR]`` (``--quick``:
distance bins 12-48, azimuth bins 32 and 64).
Writes ``sky_runtime_accuracy.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import json

import _harness as harness
import numpy as np
from affine import Affine

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.panorama import kernel_slice, panorama_exact, panorama_naive, panorama_pca
from nightlights.sky.polar import polar_map

CELL = 200.0
SIZE = 100  # 20 km square
OBSERVER = (SIZE * CELL / 2 + 30.0, SIZE * CELL / 2 - 70.0)
TRANSFORM = Affine(CELL, 0, 0, 0, -CELL, SIZE * CELL)
N_EL = 16


def error(test: np.ndarray, reference: np.ndarray) -> float:
    bright = reference > 0.01 * reference.max()
    return float(np.mean(np.abs(test[bright] - reference[bright]) / reference[bright]))


def scene() -> np.ndarray:
    rng = np.random.default_rng(3)
    emission = np.zeros((1, SIZE, SIZE))
    emission[0, 45:52, 58:66] = 1.0  # a town 2 km east
    cells = rng.choice(SIZE * SIZE, 24, replace=False)
    emission[0].flat[cells] = rng.uniform(0.2, 2.0, 24)  # scattered villages
    return emission


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer distance and azimuth bins")
    args = harness.parse_args(parser)
    emission = scene()
    result: dict = {
        "measure": "mean relative error, pixels > 1 % of max",
        "series": {},
    }
    # (a) PCA bases, with a kernel over three source altitudes (more structure to compress).
    kernel, build_s = harness.timed(
        lambda: (
            build_kernel(
                KernelSpec(
                    r_min=10,
                    r_max=15_000,
                    n_distance=48,
                    n_elevation=N_EL,
                    n_azimuth=128,
                    source_altitudes=(0, 250, 500),
                    n_components=64,
                ),
                progress=False,
            ).kernel
        )
    )
    tables = kernel_slice(kernel, observer_altitude=0.0, source_altitude=250.0)
    polar = polar_map(
        emission, TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    exact = panorama_exact(polar, tables)
    bases = []
    for k in (1, 2, 4, 8, 16, 32, 64):
        if k > tables.coefficient.shape[-1]:
            break
        pano, seconds = harness.timed(lambda k=k: panorama_pca(polar, tables, components=k))
        bases.append({"knob": k, "error": error(pano, exact), "seconds": seconds})
    result["series"]["pca_bases"] = bases
    # (b) distance bins and (c) azimuth resolution against the naive reference.
    naive_cache: dict[int, np.ndarray] = {}

    def naive(n_az: int) -> np.ndarray:
        if n_az not in naive_cache:
            naive_cache[n_az] = panorama_naive(
                emission,
                TRANSFORM,
                OBSERVER,
                elevation=90 - (np.arange(N_EL) + 0.5) * 90 / N_EL,
                n_az=n_az,
                observer_altitude=0.0,
            )
        return naive_cache[n_az]

    distance_series = []
    for n_r in (12, 24, 48) if args.quick else (12, 24, 48, 96):
        k, build = harness.timed(
            lambda n_r=n_r: (
                build_kernel(
                    KernelSpec(
                        r_min=10, r_max=15_000, n_distance=n_r, n_elevation=N_EL, n_azimuth=64
                    ),
                    progress=False,
                ).kernel
            )
        )
        t = kernel_slice(k, observer_altitude=0.0)
        p = polar_map(emission, TRANSFORM, OBSERVER, distance_edges=t.distance_edges, n_az=64)
        pano, seconds = harness.timed(lambda p=p, t=t: panorama_exact(p, t))
        distance_series.append(
            {
                "knob": n_r,
                "error": error(pano, naive(64)),
                "seconds": seconds,
                "build_seconds": build,
            }
        )
    result["series"]["distance_bins"] = distance_series
    azimuth_series = []
    for n_az in (32, 64) if args.quick else (32, 64, 128):
        k, build = harness.timed(
            lambda n_az=n_az: (
                build_kernel(
                    KernelSpec(
                        r_min=10, r_max=15_000, n_distance=48, n_elevation=N_EL, n_azimuth=n_az
                    ),
                    progress=False,
                ).kernel
            )
        )
        t = kernel_slice(k, observer_altitude=0.0)
        p = polar_map(emission, TRANSFORM, OBSERVER, distance_edges=t.distance_edges, n_az=n_az)
        pano, seconds = harness.timed(lambda p=p, t=t: panorama_exact(p, t))
        azimuth_series.append(
            {
                "knob": n_az,
                "error": error(pano, naive(n_az)),
                "seconds": seconds,
                "build_seconds": build,
            }
        )
    result["series"]["azimuth_bins"] = azimuth_series
    result["pca_kernel_build_seconds"] = build_s
    harness.write_results(
        args.out, "sky_runtime_accuracy", result, quick=args.quick, plot=plot, dpi=110
    )
    print(json.dumps(result, indent=1))


def plot(result: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), layout="constrained")
    for ax, (name, series) in zip(axes, result["series"].items(), strict=True):
        ax.loglog([s["knob"] for s in series], [max(s["error"], 1e-8) for s in series], "o-")
        for s in series:
            ax.annotate(
                f"{1000 * s['seconds']:.2f} ms", (s["knob"], max(s["error"], 1e-8)), fontsize=7
            )
        ax.set_xlabel(name.replace("_", " "))
        ax.set_ylabel("mean relative error")
        ax.axhline(0.02, color="tab:red", lw=0.8, ls=":")
    axes[0].set_title("PCA bases vs exact FFT")
    axes[1].set_title("distance bins vs naive")
    axes[2].set_title("azimuth bins vs naive")
    return fig


if __name__ == "__main__":
    main()
