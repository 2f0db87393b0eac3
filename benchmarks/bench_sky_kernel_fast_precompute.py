"""Benchmark: Dobashi's kernel configuration in full with the precompute levers, against today's.

Dobashi et al. 2023 (Sec. 5): 256 x 64 panoramas, 128 distances (78.125 m steps to 10 km),
16 source and 16 observer altitudes (62.5 m steps), turbidity 1.3. Today's build of it took
12.0 min on this machine (``sky_kernel_precompute.json``, every pair at 12 Gauss nodes per
panel). The levers, each charted on its own elsewhere:

* ``altitude_step``: along each line of equal height difference only every n-th altitude pair
  is integrated and the others are interpolated log-linearly in the observer altitude
  (``bench_sky_kernel_altitudes.py``; step 15 leaves 60 of the 256 pairs, the fewest this
  scheme allows on 16 levels);
* ``nodes``: Gauss-Legendre nodes per panel of the line-of-sight integral
  (``bench_sky_kernel_quadrature.py``).

For each lever setting this script builds the whole configuration with
:func:`nightlights.sky.build_kernel` (tables, the multiple-scattering factor, PCA; timed end to
end, nothing extrapolated), then measures its error against today's build on a sample of
altitude pairs: the exact single-scattering images of today's path (12 nodes, every pair
integrated) against what the levers give for the same pairs (computed at their node count, or
interpolated from the computed pairs around them), as the mean relative error over the pixels
brighter than 1 % of their image's maximum (the PCA and the multiple-scattering factor are
the same in both builds and are left out of the comparison). The sample holds every
interpolated pair's neighbours along one line of each kind.

Targets (the kernel precompute issue): Dobashi's configuration in <= 3 min on this machine
with <= 0.5 % mean relative error against today's build.

Run: ``NIGHTLIGHTS_MAX_MEMORY=20G python benchmarks/bench_sky_kernel_fast_precompute.py
[--quick] [--out DIR]`` (``--quick``: a 16 x 64 panorama, 32 distances and 6 x 6 altitudes).
The full configuration's build is estimated at 17.6 GiB, above the default limit of half the
machine's memory, hence the raised limit. Writes
``sky_kernel_fast_precompute.json`` and ``.png``. Timings come from a shared 2-core machine
and are noisy.
"""

from __future__ import annotations

import os

import _harness as harness
import numpy as np
from _dobashi import bright_relative_errors, dobashi_spec

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.build import altitude_pairs, pair_images

TARGET_SECONDS = 180.0
TARGET_ERROR = 0.005
TODAY_SECONDS = 722.1  # sky_kernel_precompute.json, dobashi_configuration.build_seconds
#: (altitude_step, nodes) settings; (1, 12) is today's path.
SETTINGS = ((15, 8), (15, 6))
#: Altitude pairs compared with today's path: (observer level, source level).
SAMPLE_PAIRS = 8


def spec_for(quick: bool, step: int, nodes: int) -> KernelSpec:
    """Dobashi's configuration (``quick``: a 16 x 64 panorama, 32 distances, 6 x 6 altitudes)."""
    grid = (6, 32, 16, 64) if quick else (16, 128, 64, 256)
    return dobashi_spec(*grid, altitude_step=step, nodes=nodes)


def images(spec: KernelSpec, o: int, c: int, nodes: int) -> np.ndarray:
    """Single-scattering Lambertian images of one altitude pair, shape (n_r, n_el, n_az)."""
    return pair_images(spec, o, c, "lambertian", nodes=nodes)


def lever_error(spec: KernelSpec, pairs: list[tuple[int, int]]) -> dict:
    """Error of the levers' images against today's on ``pairs`` (see the module notes)."""
    computed, interpolated = altitude_pairs(
        spec.observer_altitudes, spec.source_altitudes, spec.altitude_step
    )
    how = {(p.observer, p.source): p for p in interpolated}
    cache: dict[tuple[int, int], np.ndarray] = {}

    def fast(o: int, c: int) -> np.ndarray:
        if (o, c) not in cache:
            cache[(o, c)] = images(spec, o, c, spec.nodes)
        return cache[(o, c)]

    rows = []
    for o, c in pairs:
        exact = images(spec, o, c, 12)
        if computed[o, c]:
            approx = fast(o, c)
        else:
            pair = how[(o, c)]
            lower, upper, w = fast(*pair.lower), fast(*pair.upper), pair.weight
            approx = (1 - w) * lower + w * upper
            positive = (lower > 0) & (upper > 0)
            approx[positive] = np.exp(
                (1 - w) * np.log(lower[positive]) + w * np.log(upper[positive])
            )
        rows.append(
            {
                "observer_level": o,
                "source_level": c,
                "computed": bool(computed[o, c]),
                "mean_rel_error": float(np.mean(bright_relative_errors(approx, exact))),
            }
        )
    interpolated_share = 1.0 - computed.mean()
    by_kind = {
        kind: float(np.mean([r["mean_rel_error"] for r in rows if r["computed"] is kind]))
        for kind in (True, False)
        if any(r["computed"] is kind for r in rows)
    }
    # the kernel's mean: computed and interpolated pairs in their shares of all pairs
    estimate = (1 - interpolated_share) * by_kind.get(True, 0.0) + interpolated_share * by_kind.get(
        False, 0.0
    )
    return {
        "pairs": rows,
        "pairs_computed": int(computed.sum()),
        "pairs_total": int(computed.size),
        "computed_pairs_error": by_kind.get(True),
        "interpolated_pairs_error": by_kind.get(False),
        "mean_rel_error": estimate,
        "worst_pair_mean_rel_error": max(r["mean_rel_error"] for r in rows),
    }


def sample_pairs(spec: KernelSpec) -> list[tuple[int, int]]:
    """Altitude pairs spread over the kernel: half interpolated, half computed."""
    computed, _ = altitude_pairs(spec.observer_altitudes, spec.source_altitudes, 15)
    rng = np.random.default_rng(7)
    inside = [tuple(p) for p in np.argwhere(~computed)]
    outside = [tuple(p) for p in np.argwhere(computed)]
    half = SAMPLE_PAIRS // 2
    chosen = [inside[i] for i in rng.choice(len(inside), min(half, len(inside)), replace=False)]
    chosen += [outside[i] for i in rng.choice(len(outside), half, replace=False)]
    return [(int(o), int(c)) for o, c in chosen]


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="a small grid")
    args = harness.parse_args(parser)
    # compile the numba paths before timing anything
    build_kernel(KernelSpec(n_distance=2, n_elevation=2, n_azimuth=4), progress=False)
    rows = []
    for step, nodes in SETTINGS:
        spec = spec_for(args.quick, step, nodes)
        result, seconds = harness.timed(lambda spec=spec: build_kernel(spec, progress=False))
        ds = result.kernel
        row = {
            "altitude_step": step,
            "nodes": nodes,
            "build_seconds": seconds,
            "time_ratio": seconds / TODAY_SECONDS,
            "components": int(ds.sizes["component"]),
            "threads": os.cpu_count(),
        }
        del result, ds
        row |= lever_error(spec, sample_pairs(spec))
        rows.append(row)
        print(
            f"step {step} nodes {nodes}: {seconds:.0f} s, "
            f"error {row['mean_rel_error']:.2e} "
            f"(worst pair {row['worst_pair_mean_rel_error']:.2e})",
            flush=True,
        )
    payload = {
        "kernel": "256 az x 64 el, 128 r (78.125 m steps to 10 km), 16 h_c x 16 h_o (62.5 m), "
        "turbidity 1.3, Lambertian and uplight, multiple scattering by the Monte Carlo factor"
        if not args.quick
        else "quick: 64 az x 16 el, 32 r, 6 x 6 altitudes",
        "today_seconds": TODAY_SECONDS,
        "targets": {"seconds": TARGET_SECONDS, "mean_rel_error": TARGET_ERROR},
        "error_measure": "mean |approx - exact| / exact over pixels > 1 % of their image's max, "
        "single-scattering Lambertian images of sampled altitude pairs against 12 nodes with "
        "every pair integrated; the kernel's mean weights computed and interpolated pairs by "
        "their shares",
        "settings": rows,
        "note": "Timings from a shared 2-core machine, noisy; build_seconds is the whole "
        "build_kernel call (tables, multiple-scattering factor, PCA).",
    }
    harness.write_results(
        args.out, "sky_kernel_fast_precompute", payload, quick=args.quick, plot=plot
    )


def plot(payload: dict):
    plt = harness.pyplot()
    rows = payload["settings"]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(
        [payload["today_seconds"] / 60],
        [1e-7],
        "ks",
        label="today (every pair, 12 nodes): the reference, error 0 drawn at 1e-7",
    )
    for row in rows:
        ax.plot(
            row["build_seconds"] / 60,
            max(row["mean_rel_error"], 1e-7),
            "o",
            label=f"altitude step {row['altitude_step']}, {row['nodes']} nodes",
        )
    ax.axvline(payload["targets"]["seconds"] / 60, color="grey", ls="--", lw=0.8)
    ax.axhline(payload["targets"]["mean_rel_error"], color="grey", ls=":", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("build time, whole kernel [min]")
    ax.set_ylabel("mean relative error against today's build [1]")
    ax.set_title("Dobashi's configuration: precompute levers (targets dashed)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
