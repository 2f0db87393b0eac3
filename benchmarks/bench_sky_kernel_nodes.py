"""Benchmark: Gauss nodes per panel against the error of the kernel's bin images.

``bench_sky_kernel_quadrature.py`` measures single rays; what a kernel stores are bin images
(one ray per pixel centre at the bin's geometric centre, the pixels next to the source averaged
over 8 x 8 directions and 4 distances), and what the kernel benchmarks measure is the mean
relative error over the pixels brighter than 1 % of their image's maximum. This script
integrates altitude pairs at a range of node counts (``pair_images`` of the default build,
single scattering: the multiple-scattering factor multiplies every node count alike) and
compares their images with those at 32 nodes per panel (converged: 12 nodes are within
0.02 % of it), for two kernels:

* ``dobashi``: Dobashi's configuration in full (64 x 256 panorama, 128 distances of 78.125 m
  to 10 km, turbidity 1.3), at 4 of the 60 altitude pairs its default build integrates
  (h_o, h_c) = (0, 0), (0, 937.5), (937.5, 0), (0, 500) m;
* ``range``: a scene-sized kernel to the largest range, 128 distances log-spaced from 10 m to
  300 km on a 32 x 128 panorama, turbidity 2, (h_o, h_c) = (0, 0), (0, 500), (500, 0) m.

Per node count: wall time per altitude pair (best of 3 runs of all pairs, 2 threads; the
machine is shared), mean bright-pixel error over the pairs, the worst pair's mean, and the 99th
percentile and maximum of the bright pixels' errors.

Run: ``python benchmarks/bench_sky_kernel_nodes.py [--quick] [--out DIR]`` (``--quick``: a
quarter of the distances and half the panorama). Writes ``sky_kernel_nodes.json`` and ``.png``.
"""

from __future__ import annotations

import time
from typing import Any

import _harness as harness
import numpy as np
from _dobashi import bright_relative_errors, dobashi_spec

NAME = "sky_kernel_nodes"
NODES = (4, 5, 6, 7, 8, 10, 12)
REFERENCE_NODES = 32
#: Timed runs per node count (the best is kept: the machine is shared) [1].
REPEATS = 3


def kernels(quick: bool) -> dict[str, tuple[Any, list[tuple[int, int]]]]:
    """The two kernels' specifications and the (observer, source) level pairs integrated."""
    from nightlights.sky import KernelSpec

    shrink = 2 if quick else 1
    n_r = 32 if quick else 128
    dobashi = dobashi_spec(16, n_r, 64 // shrink, 256 // shrink, exact=False)
    scene = KernelSpec(
        r_min=10.0,
        r_max=300_000.0,
        n_distance=n_r,
        n_elevation=32 // shrink,
        n_azimuth=128 // shrink,
        source_altitudes=(0.0, 500.0),
        observer_altitudes=(0.0, 500.0),
    )
    return {
        "dobashi": (dobashi, [(0, 0), (0, 15), (15, 0), (0, 8)]),
        "range": (scene, [(0, 0), (0, 1), (1, 0)]),
    }


def measure(spec: Any, pairs: list[tuple[int, int]]) -> dict[str, Any]:
    from nightlights.sky.build import pair_images

    reference = [pair_images(spec, o, c, "lambertian", nodes=REFERENCE_NODES) for o, c in pairs]
    rows = []
    for nodes in NODES:
        errors, means, seconds = [], [], []
        for _ in range(REPEATS):
            start = time.perf_counter()
            images = [pair_images(spec, o, c, "lambertian", nodes=nodes) for o, c in pairs]
            seconds.append(time.perf_counter() - start)
        for image, exact in zip(images, reference, strict=True):
            rel = bright_relative_errors(image, exact)
            errors.append(rel)
            means.append(float(rel.mean()))
        every = np.concatenate(errors)
        rows.append(
            {
                "nodes": nodes,
                "seconds_per_pair": min(seconds) / len(pairs),
                "mean_rel_error": float(every.mean()),
                "worst_pair_mean_rel_error": max(means),
                "p99_rel_error": float(np.percentile(every, 99)),
                "max_rel_error": float(every.max()),
            }
        )
        print(rows[-1], flush=True)
    return {"pairs": [list(p) for p in pairs], "rows": rows}


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="smaller grids")
    args = harness.parse_args(parser)
    from nightlights.sky.build import pair_images

    warm, _ = kernels(True)["range"]
    pair_images(warm, 0, 0, "lambertian", nodes=4)  # compile
    out: dict[str, Any] = {"reference_nodes": REFERENCE_NODES}
    for label, (spec, pairs) in kernels(args.quick).items():
        out[label] = measure(spec, pairs) | {
            "grid": [spec.n_distance, spec.n_elevation, spec.n_azimuth],
            "r_max": spec.r_max,
            "turbidity": spec.atmosphere.turbidity,
        }
    out["note"] = (
        "Bin images of single scattering (pair_images of the default build) against 32 nodes "
        "per panel; error over the pixels brighter than 1 % of their image's maximum. Wall "
        "time per pair, best of 3 runs, 2 threads, on a shared 2-core machine."
    )
    harness.write_results(args.out, NAME, out, quick=args.quick, plot=plot)


def plot(out: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for label, colour in (("dobashi", "C0"), ("range", "C1")):
        rows = out[label]["rows"]
        n = [r["nodes"] for r in rows]
        for key, style in (
            ("mean_rel_error", "o-"),
            ("p99_rel_error", "s--"),
            ("max_rel_error", ":"),
        ):
            ax1.semilogy(
                n,
                [max(r[key], 1e-12) for r in rows],
                style,
                color=colour,
                label=f"{label}: {key.split('_')[0]}",
            )
        ax2.loglog(
            [r["seconds_per_pair"] for r in rows],
            [max(r["mean_rel_error"], 1e-12) for r in rows],
            "o-",
            color=colour,
            label=f"{label}: mean error",
        )
        for r in rows:
            ax2.annotate(str(r["nodes"]), (r["seconds_per_pair"], r["mean_rel_error"]), fontsize=7)
    for ax in (ax1, ax2):
        ax.axhline(0.005, color="grey", ls="--", lw=0.8)
        ax.legend(fontsize=7)
    ax1.set_xlabel("Gauss nodes per panel")
    ax1.set_ylabel(f"bright-pixel relative error vs {out['reference_nodes']} nodes")
    ax2.set_xlabel("time per altitude pair (best of 3) [s]")
    ax2.set_ylabel("mean bright-pixel relative error")
    fig.suptitle("Skyglow kernel: bin images against Gauss nodes per panel")
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
