"""Benchmark: skyglow kernel precomputation time against grid size.

Knob: the kernel grid (distance bins x elevation rows x azimuth columns, source and observer
altitudes). Each configuration runs :func:`nightlights.sky.precompute.build_kernel` with the
defaults (24 Gauss nodes per panel, 2 sub-distances per bin, PCA at 0.999999 energy).

Dobashi et al. 2023 (Sec. 5) precompute 256 x 64 panoramas for 128 distances, 16 source and
16 observer altitudes (4-6 h per turbidity on a Quadro RTX 6000). Building that here in full
would take hours, so the script times a fraction (one source and one observer altitude, all
128 distances, the full 64 x 256 panorama) and EXTRAPOLATES linearly to the 256 altitude pairs
(the images of each pair cost the same; the PCA is timed separately on the fraction and scaled
by the 16 observer altitudes). The extrapolation is labelled as such in the JSON and chart.
Also reported: the same fraction with 12 nodes and 1 sub-distance (cheaper, ~2e-3 max error).

Run: ``.venv/bin/python benchmarks/bench_sky_kernel_precompute.py [--quick]``.
Writes ``benchmarks/results/sky_kernel_precompute.json`` and ``.png``.
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from nightlights.sky.precompute import build_kernel, compress_kernel

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def timed(**kwargs: object) -> tuple[float, object]:
    start = time.perf_counter()
    ds = build_kernel(progress=False, **kwargs)  # type: ignore[arg-type]
    return time.perf_counter() - start, ds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the Dobashi-size fraction")
    args = parser.parse_args()
    grids = [(16, 8, 32), (32, 16, 64), (64, 32, 128)]
    if not args.quick:
        grids.append((128, 32, 128))
    sweep = []
    for n_r, n_el, n_az in grids:
        seconds, ds = timed(r_min=10.0, r_max=100_000.0, n_r=n_r, n_el=n_el, n_az=n_az)
        rays = n_r * n_el * (n_az // 2 + 1) * 2
        sweep.append(
            {
                "n_r": n_r,
                "n_el": n_el,
                "n_az": n_az,
                "seconds": seconds,
                "rays": rays,
                "us_per_ray": 1e6 * seconds / rays,
                "components": int(ds.sizes["component"]),  # type: ignore[attr-defined]
            }
        )
        print(sweep[-1])
    out: dict = {
        "machine": platform.processor() or platform.machine(),
        "sweep_one_altitude_pair": sweep,
        "flat_terrain_64x32x128_seconds": next(
            s["seconds"] for s in sweep if (s["n_r"], s["n_el"], s["n_az"]) == (64, 32, 128)
        ),
        "flat_terrain_target_seconds": 30.0,
    }
    if not args.quick:
        dobashi = {}
        for label, kwargs in (
            ("default_24_nodes_2_sub", {}),
            ("fast_12_nodes_1_sub", {"nodes": 12, "sub_distances": 1}),
        ):
            seconds, ds = timed(r_min=10.0, r_max=300_000.0, n_r=128, n_el=64, n_az=256, **kwargs)
            kernel = np.repeat(ds.kernel.values, 16, axis=1)  # type: ignore[attr-defined]
            start = time.perf_counter()
            compress_kernel(kernel.astype(float))
            pca = time.perf_counter() - start
            total = 256 * seconds + 16 * pca
            dobashi[label] = {
                "fraction": "1 of 256 (h_c, h_o) pairs, 128 r x 64 el x 256 az",
                "fraction_seconds": seconds,
                "pca_seconds_per_observer_altitude_(16_h_c)": pca,
                "extrapolated_total_seconds": total,
                "extrapolated": True,
            }
            print(label, dobashi[label])
        out["dobashi_configuration_extrapolated"] = dobashi
        out["dobashi_target_seconds"] = 900.0
    out["note"] = (
        "Timings from a shared 2-core machine, noisy. Dobashi-size totals are extrapolations."
    )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "sky_kernel_precompute.json").write_text(json.dumps(out, indent=2))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.loglog(
        [s["rays"] for s in sweep],
        [s["seconds"] for s in sweep],
        "o-",
        label="measured (1 h_c, 1 h_o)",
    )
    ax.axhline(30.0, color="grey", lw=0.8, ls=":")
    ax.text(sweep[0]["rays"], 33.0, "30 s target (64 x 32 x 128)", fontsize=7)
    if "dobashi_configuration_extrapolated" in out:
        for label, marker, n_sub in (
            ("default_24_nodes_2_sub", "s", 2),
            ("fast_12_nodes_1_sub", "^", 1),
        ):
            rays = 16 * 16 * 128 * 64 * 129 * n_sub
            total = out["dobashi_configuration_extrapolated"][label]["extrapolated_total_seconds"]
            ax.loglog([rays], [total], marker, label=f"Dobashi config, EXTRAPOLATED ({label})")
        ax.axhline(900.0, color="C3", lw=0.8, ls=":")
        ax.text(sweep[0]["rays"], 1000.0, "15 min target (Dobashi config)", fontsize=7)
    ax.set_xlabel("rays traced (pixels x distances x sub-distances, half azimuth range)")
    ax.set_ylabel("precompute time [s]")
    ax.legend(fontsize=7)
    ax.set_title("Skyglow kernel precomputation")
    fig.tight_layout()
    fig.savefig(RESULTS / "sky_kernel_precompute.png", dpi=110)


if __name__ == "__main__":
    main()
