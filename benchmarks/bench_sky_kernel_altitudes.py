"""Benchmark: kernel precompute time against error when altitude pairs are interpolated.

Lever: ``KernelSpec.altitude_step`` (:func:`nightlights.sky.build.altitude_pairs`). Pairs of
equal height difference h_c - h_o see the same geometry; along each such line every n-th pair
(and the last) is computed and the others are interpolated log-linearly in the observer
altitude. ``altitude_step = 1`` is today's path (every pair computed), the reference of the
same run.

Kernel: Dobashi et al. 2023's altitudes and distances (16 source x 16 observer altitudes in
62.5 m steps, 128 distance bins of 78.125 m to 10 km, the first from 1 m; turbidity 1.3) on
an 8 x 32 panorama (Dobashi's is 64 x 256: 64 times the rays per pair; the interpolation acts
on each pixel alone, and the time per computed pair scales with the rays). ``--quick``:
6 x 6 altitudes, 32 bins.

Measured for each step: the tables' precompute time (:func:`nightlights.sky.build.kernel_tables`:
line-of-sight integration only, single scattering; the PCA is the same for every step) and its
ratio to the reference, the pairs computed, and the error of the tables against the
reference: mean relative error over the pixels brighter than 1 % of their image's maximum over
all images, and the largest such mean of one altitude pair.

Targets (the kernel precompute issue): <= 0.5 % mean relative error against today's build, and
Dobashi's configuration in <= 3 min (today 12.0 min measured in full,
``sky_kernel_precompute.json``): a time ratio of 0.25 or less.

Run: ``python benchmarks/bench_sky_kernel_altitudes.py [--quick] [--out DIR]
[--save-reference FILE.npy]``. Writes ``sky_kernel_altitudes.json`` and ``.png`` (see
``_harness.py`` for where). Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

from pathlib import Path

import _harness as harness
import numpy as np
from _dobashi import bright_relative_errors, dobashi_spec

from nightlights.sky import KernelSpec
from nightlights.sky.build import altitude_pairs, kernel_tables

TARGET_ERROR = 0.005
TARGET_RATIO = 0.25


def spec_for(quick: bool, step: int) -> KernelSpec:
    """Dobashi's altitudes and distances on an 8 x 32 panorama (``quick``: fewer)."""
    n_levels, n_r = (6, 32) if quick else (16, 128)
    return dobashi_spec(n_levels, n_r, 8, 32, altitude_step=step)


def pair_errors(table: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Mean relative error over the bright pixels of all images, and the largest mean of one
    altitude pair."""
    n_o, n_c = reference.shape[:2]
    total, count, worst = 0.0, 0, 0.0
    for o in range(n_o):
        for c in range(n_c):
            rel = bright_relative_errors(table[o, c], reference[o, c])
            total, count = total + float(rel.sum()), count + rel.size
            worst = max(worst, float(rel.mean()) if rel.size else 0.0)
    return total / count, worst


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="6 x 6 altitudes, 32 distance bins")
    parser.add_argument(
        "--save-reference", type=Path, default=None, help="save the reference tables (.npy)"
    )
    args = harness.parse_args(parser)
    kernel_tables(spec_for(True, 1), progress=False)  # compile before timing
    steps = [1, 2, 3, 5] if args.quick else [1, 5, 15]
    rows = []
    reference = None
    for step in steps:
        spec = spec_for(args.quick, step)
        tables, seconds = harness.timed(lambda spec=spec: kernel_tables(spec, progress=False))
        table = tables["lambertian"]
        computed, _ = altitude_pairs(
            np.asarray(spec.observer_altitudes), np.asarray(spec.source_altitudes), step
        )
        if reference is None:
            reference = table
            if args.save_reference is not None:
                np.save(args.save_reference, reference)
        mean_error, worst_pair = pair_errors(table, reference)
        rows.append(
            {
                "altitude_step": step,
                "pairs_computed": int(computed.sum()),
                "pairs": int(computed.size),
                "seconds": seconds,
                "time_ratio": seconds / rows[0]["seconds"] if rows else 1.0,
                "mean_rel_error": mean_error,
                "worst_pair_mean_rel_error": worst_pair,
            }
        )
        print(rows[-1], flush=True)
    spec = spec_for(args.quick, 1)
    out = {
        "kernel": (
            f"{spec.n_azimuth} az x {spec.n_elevation} el, {spec.n_distance} r to "
            f"{spec.r_max:g} m, {len(spec.source_altitudes)} h_c x "
            f"{len(spec.observer_altitudes)} h_o (62.5 m), turbidity 1.3, Lambertian, "
            "single scattering"
        ),
        "steps": rows,
        "targets": {"mean_rel_error": TARGET_ERROR, "time_ratio": TARGET_RATIO},
        "error_measure": "mean |approx - exact| / exact over pixels > 1 % of their image's max",
        "note": "Timings from a shared 2-core machine, noisy; ratios are against altitude_step "
        "1 (today's path) in the same run.",
    }
    harness.write_results(
        args.out, "sky_kernel_altitudes", out, quick=args.quick, plot=plot, dpi=110
    )


def plot(out: dict):
    plt = harness.pyplot()
    rows = out["steps"]
    fig, ax = plt.subplots(figsize=(6.5, 4.4))
    for row in rows[1:]:
        ax.loglog(row["time_ratio"], row["mean_rel_error"], "o", color="C0")
        ax.loglog(row["time_ratio"], row["worst_pair_mean_rel_error"], "^", color="C1")
        ax.annotate(
            f"step {row['altitude_step']}: {row['pairs_computed']}/{row['pairs']} pairs",
            (row["time_ratio"], row["mean_rel_error"]),
            fontsize=7,
            xytext=(4, -10),
            textcoords="offset points",
        )
    ax.plot([], [], "o", color="C0", label="mean over all images")
    ax.plot([], [], "^", color="C1", label="worst altitude pair's mean")
    ax.axhline(out["targets"]["mean_rel_error"], color="grey", ls=":", lw=0.8)
    ax.axvline(out["targets"]["time_ratio"], color="grey", ls=":", lw=0.8)
    ax.set_xlabel(f"precompute time / today's ({rows[0]['seconds']:.0f} s, shared machine)")
    ax.set_ylabel("relative error against today's tables (pixels > 1 % of max)")
    ax.set_title("Altitude pairs interpolated along h_c - h_o", fontsize=9)
    ax.legend(fontsize=7)
    fig.suptitle(out["kernel"], fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
