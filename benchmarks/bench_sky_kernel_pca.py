"""Benchmark: PCA bases and distance bins of the skyglow kernel, error against the full kernel.

Knob 1, number of PCA bases: a kernel of 64 distance bins (10 m - 100 km) x 32 x 128 pixels for
source altitudes 0, 250, 500 m and one observer altitude (0 m) is compressed with 1-64 bases
(:func:`nightlights.sky.pca.compress_kernel`); error = mean relative error of the
reconstructed images over pixels brighter than 1 % of each image's maximum (target:
<= 2 % at 64 bases; Dobashi et al. 2023 report < 5 %), also the 99th percentile.

Knob 2, distance bins: for 200 point sources at log-uniform random distances (10 m - 100 km),
the image of the bin that holds the source (16-256 log-spaced bins) against the exact point
image :func:`nightlights.sky.kernel.sky_luminance` at that distance; same error measure. This is
a worst case: flux spread over a bin (the runtime's polar map) averages the bin error down.

Run: ``python benchmarks/bench_sky_kernel_pca.py [--quick] [--out DIR]`` (``--quick``:
16 x 64 pixel images, 60 point sources).
Writes ``sky_kernel_pca.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.kernel import sky_luminance
from nightlights.sky.pca import compress_kernel
from nightlights.sky.spec import panorama_elevations, relative_azimuths


def bright_error(approx: np.ndarray, exact: np.ndarray) -> np.ndarray:
    bright = exact > 0.01 * exact.max(axis=(-2, -1), keepdims=True)
    return (np.abs(approx - exact)[bright]) / exact[bright]


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="smaller kernels")
    args = harness.parse_args(parser)
    n_el, n_az = (16, 64) if args.quick else (32, 128)
    spec = KernelSpec(
        r_min=10.0,
        r_max=100_000.0,
        n_distance=64,
        n_elevation=n_el,
        n_azimuth=n_az,
        source_altitudes=(0.0, 250.0, 500.0),
    )
    ds = build_kernel(spec, progress=False).kernel
    full = ds.kernel.values.astype(float)
    bases = []
    for k in (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64):
        comp, seconds = harness.timed(lambda k=k: compress_kernel(full, n_components=k))
        rec = np.einsum("ocrk,oke...->ocre...", comp.coefficient.values, comp.basis.values)
        err = bright_error(rec, full)
        bases.append(
            {
                "bases": int(comp.sizes["component"]),
                "mean_rel_error": float(err.mean()),
                "p99_rel_error": float(np.percentile(err, 99)),
                "pca_seconds": seconds,
            }
        )
        print(bases[-1])
    default = compress_kernel(full)
    default_components = int(default.sizes["component"])

    rng = np.random.default_rng(0)
    n_src = 60 if args.quick else 200
    r_src = np.exp(rng.uniform(np.log(10.0), np.log(100_000.0), n_src))
    el = panorama_elevations(n_el)[:, None, None]
    az = relative_azimuths(n_az)[None, : n_az // 2 + 1, None]
    exact = np.moveaxis(sky_luminance(el, az, r_src[None, None, :]), -1, 0)
    bins = []
    for n_r in (16, 32, 64, 128, 256):
        kd, seconds = harness.timed(
            lambda n_r=n_r: (
                build_kernel(
                    KernelSpec(
                        r_min=10.0,
                        r_max=100_000.0,
                        n_distance=n_r,
                        n_elevation=n_el,
                        n_azimuth=n_az,
                    ),
                    progress=False,
                ).kernel
            )
        )
        edges = kd.distance_edges.values
        idx = np.clip(np.searchsorted(edges, r_src) - 1, 0, n_r - 1)
        approx = kd.kernel.values[0, 0, idx][..., : n_az // 2 + 1].astype(float)
        err = bright_error(approx, exact)
        bins.append(
            {
                "n_r": n_r,
                "bin_ratio": float(edges[1] / edges[0]),
                "mean_rel_error": float(err.mean()),
                "p99_rel_error": float(np.percentile(err, 99)),
                "build_seconds": seconds,
            }
        )
        print(bins[-1])
    out = {
        "kernel": (
            f"64 r (10 m-100 km) x {n_el} el x {n_az} az, h_c 0/250/500 m, h_o 0 m, turbidity 2"
        ),
        "bases": bases,
        "default_energy_components": default_components,
        "target": "mean relative error <= 2 % at 64 bases over pixels > 1 % of the image maximum",
        "distance_bins": bins,
        "note": "Timings from a shared 2-core machine, noisy.",
    }
    harness.write_results(args.out, "sky_kernel_pca", out, quick=args.quick, plot=plot, dpi=110)


def plot(out: dict):
    plt = harness.pyplot()
    bases, bins = out["bases"], out["distance_bins"]
    default_components = out["default_energy_components"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.semilogy(
        [b["bases"] for b in bases], [b["mean_rel_error"] for b in bases], "o-", label="mean"
    )
    ax1.semilogy(
        [b["bases"] for b in bases], [b["p99_rel_error"] for b in bases], "s--", label="99th pct"
    )
    ax1.axhline(0.02, color="grey", lw=0.8, ls=":")
    ax1.axvline(
        default_components,
        color="C2",
        lw=0.8,
        ls=":",
        label=f"default energy: {default_components}",
    )
    ax1.set_xlabel("PCA bases")
    ax1.set_ylabel("relative error (pixels > 1 % of max)")
    ax1.legend(fontsize=7)
    ax2.loglog([b["n_r"] for b in bins], [b["mean_rel_error"] for b in bins], "o-", label="mean")
    ax2.loglog(
        [b["n_r"] for b in bins], [b["p99_rel_error"] for b in bins], "s--", label="99th pct"
    )
    ax2.set_xticks([b["n_r"] for b in bins], [str(b["n_r"]) for b in bins])
    ax2.minorticks_off()
    ax2.set_xlabel("distance bins (10 m - 100 km, log-spaced)")
    ax2.set_ylabel("point source vs its bin image")
    ax2.legend(fontsize=7)
    fig.suptitle("Skyglow kernel: PCA bases and distance bins")
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
