"""Kernel bin images: distances averaged per bin (``sub_distances``), time against error.

Knob: ``sub_distances`` of :class:`nightlights.sky.KernelSpec`, the Gauss-Legendre
nodes in ln r whose area-weighted mean (weights r^2) stands for a distance bin (1 = the
geometric bin centre). The pixels next to the source direction always average at least 4
distances (and 8 x 8 directions). Reference: 16 distances per bin. Error: per bin image, the
mean relative error over pixels brighter than 1 % of that image's maximum; reported as the
mean over bins and the worst bin. Grids: 64 bins over 10 m - 100 km and 128 bins over
10 m - 300 km, 32 x 128 images, sources at the observer's altitude and 300 / 500 m above it
(where the source is seen above the horizon and moves across pixels within a bin).

Run: ``python benchmarks/bench_sky_kernel_subdistances.py [--quick] [--out DIR]``
(``--quick``: the two 64-bin grids only).
Writes ``sky_kernel_subdistances.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky import KernelSpec, build_kernel

CASES = (
    ("64 bins 10 m-100 km, h_c = 0", 64, 100_000.0, 0.0),
    ("64 bins 10 m-100 km, h_c = 300 m", 64, 100_000.0, 300.0),
    ("128 bins 10 m-300 km, h_c = 500 m", 128, 300_000.0, 500.0),
)
SUBS = (1, 2, 3, 4)


def images(n_r: int, r_max: float, h_c: float, sub: int) -> tuple[np.ndarray, float]:
    result, seconds = harness.timed(
        lambda: build_kernel(
            KernelSpec(
                r_min=10.0,
                r_max=r_max,
                n_distance=n_r,
                n_elevation=32,
                n_azimuth=128,
                source_altitudes=(h_c,),
                sub_distances=sub,
                n_components=1,
            ),
            progress=False,
        )
    )
    return result.kernel["kernel"].values[0, 0].astype(float), seconds


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="the two 64-bin grids only")
    args = harness.parse_args(parser)
    cases = CASES[:2] if args.quick else CASES
    build_kernel(KernelSpec(n_distance=2, n_elevation=2, n_azimuth=4), progress=False)  # compile
    result: dict = {"reference_sub_distances": 16}
    for label, n_r, r_max, h_c in cases:
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
    result["note"] = "Timings from a shared 2-core machine, noisy. Dotted: worst bin."
    harness.write_results(
        args.out, "sky_kernel_subdistances", result, quick=args.quick, plot=plot, dpi=110
    )


def plot(result: dict):
    plt = harness.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for label in (case[0] for case in CASES if case[0] in result):
        rows = result[label]
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
    ax.set_xlabel("kernel build time (one altitude pair) [s]")
    ax.set_ylabel("relative error vs 16 distances per bin")
    ax.set_title("Kernel bin images: distances per bin (solid mean, dotted worst bin)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
