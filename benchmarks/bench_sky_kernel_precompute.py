"""Benchmark: skyglow kernel precomputation time against grid size, and Dobashi's configuration.

Knob: the kernel grid (distance bins x elevation rows x azimuth columns, source and observer
altitudes). Each configuration runs :func:`nightlights.sky.build_kernel` with the
defaults (12 Gauss nodes per panel, 1 distance per bin, 8 x 8 supersampling of the pixels next
to the source, PCA at 0.999999 energy), with the compiled (numba) line-of-sight integrator and,
for the smaller grids, the numpy reference integrator.

Dobashi et al. 2023 (Sec. 5) precompute 256 x 64 panoramas for 128 distances (78.125 m steps to
10 km), 16 source and 16 observer altitudes (62.5 m steps), turbidity 1.3: 4-6 h per turbidity
on a Quadro RTX 6000. This script builds that configuration IN FULL (all 256 altitude pairs,
images + PCA + FFT; measured, not extrapolated) and times writing it to NetCDF separately.
The first bin runs from 1 m (our grid needs edges > 0; Dobashi's first sample is at r = 0).

Run: ``python benchmarks/bench_sky_kernel_precompute.py [--quick] [--out DIR] [--keep-dobashi]``
(``--quick`` skips the Dobashi configuration, which takes ~10 minutes on 2 cores).
Writes ``sky_kernel_precompute.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import _harness as harness
from _dobashi import dobashi_spec

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.store import write_kernel


def timed(spec: KernelSpec, backend: str = "auto") -> tuple[float, object]:
    """Seconds to build the kernel of ``spec``, and the kernel dataset."""
    result, seconds = harness.timed(lambda: build_kernel(spec, backend=backend, progress=False))
    return seconds, result.kernel


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="skip Dobashi's configuration")
    parser.add_argument(
        "--keep-dobashi",
        action="store_true",
        help="skip Dobashi's configuration but keep its last full measurement from the JSON",
    )
    args = harness.parse_args(parser)
    kept = None
    if args.keep_dobashi:
        previous = harness.previous_results("sky_kernel_precompute", args.out)
        kept = None if previous is None else previous.get("dobashi_configuration")
    # compile both numba paths (per-ray and grid) before timing anything
    build_kernel(KernelSpec(n_distance=2, n_elevation=2, n_azimuth=4), progress=False)
    build_kernel(KernelSpec(n_distance=64, n_elevation=2, n_azimuth=16), progress=False)
    grids = [(16, 8, 32), (32, 16, 64), (64, 32, 128), (128, 32, 128), (128, 64, 256)]
    sweep = []
    for n_r, n_el, n_az in grids:
        for backend in ("numba", "numpy"):
            if backend == "numpy" and n_r * n_el * n_az > 64 * 32 * 128:
                continue
            spec = KernelSpec(
                r_min=10.0, r_max=100_000.0, n_distance=n_r, n_elevation=n_el, n_azimuth=n_az
            )
            seconds, ds = timed(spec, backend)
            rays = n_r * n_el * (n_az // 2 + 1)
            sweep.append(
                {
                    "n_r": n_r,
                    "n_el": n_el,
                    "n_az": n_az,
                    "backend": backend,
                    "seconds": seconds,
                    "rays": rays,
                    "us_per_ray": 1e6 * seconds / rays,
                    "components": int(ds.sizes["component"]),  # type: ignore[attr-defined]
                }
            )
            print(sweep[-1], flush=True)
    out: dict = {
        "defaults": {"nodes": 12, "sub_distances": 1, "supersample": 8, "pca_energy": 0.999999},
        "sweep_one_altitude_pair": sweep,
        "flat_terrain_64x32x128_seconds": next(
            s["seconds"]
            for s in sweep
            if (s["n_r"], s["n_el"], s["n_az"], s["backend"]) == (64, 32, 128, "numba")
        ),
        "flat_terrain_target_seconds": 30.0,
    }
    if kept is not None:
        out["dobashi_configuration"] = kept
    elif not args.quick and not args.keep_dobashi:
        spec = dobashi_spec()
        seconds, ds = timed(spec)
        with tempfile.TemporaryDirectory() as tmp:
            path, write_seconds = harness.timed(
                lambda: write_kernel(ds, Path(tmp) / "dobashi.nc")  # type: ignore[arg-type]
            )
            size = path.stat().st_size
        out["dobashi_configuration"] = {
            "grid": "256 az x 64 el, 128 r (78.125 m steps to 10 km), 16 h_c x 16 h_o "
            "(62.5 m steps), turbidity 1.3, defaults",
            "measured_in_full": True,
            "build_seconds": seconds,
            "write_seconds": write_seconds,
            "file_megabytes": size / 1e6,
            "rays": 16 * 16 * 128 * 64 * 129,
            "components": int(ds.sizes["component"]),  # type: ignore[attr-defined]
            "target_seconds": 900.0,
            "paper_seconds": [4 * 3600.0, 6 * 3600.0],
        }
        print(out["dobashi_configuration"], flush=True)
    out["note"] = "Timings from a shared 2-core machine, noisy."
    harness.write_results(
        args.out, "sky_kernel_precompute", out, quick=args.quick, plot=plot, dpi=110
    )


def plot(out: dict):
    plt = harness.pyplot()
    sweep = out["sweep_one_altitude_pair"]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for backend, marker in (("numba", "o-"), ("numpy", "s--")):
        rows = [s for s in sweep if s["backend"] == backend]
        ax.loglog(
            [s["rays"] for s in rows],
            [s["seconds"] for s in rows],
            marker,
            label=f"1 h_c x 1 h_o, {backend}",
        )
    ax.axhline(30.0, color="grey", lw=0.8, ls=":")
    ax.text(sweep[0]["rays"], 33.0, "30 s target (64 x 32 x 128)", fontsize=7)
    if "dobashi_configuration" in out:
        d = out["dobashi_configuration"]
        ax.loglog(
            [d["rays"]],
            [d["build_seconds"]],
            "*",
            ms=12,
            color="C3",
            label=f"Dobashi config, measured: {d['build_seconds'] / 60:.1f} min",
        )
        ax.axhline(900.0, color="C3", lw=0.8, ls=":")
        ax.text(sweep[0]["rays"], 1000.0, "15 min target (Dobashi config)", fontsize=7)
        ax.axhline(4 * 3600.0, color="k", lw=0.8, ls=":")
        ax.text(sweep[0]["rays"], 4 * 3600.0 * 1.1, "paper: 4-6 h on a GPU", fontsize=7)
    ax.set_xlabel("rays traced (pixels over half the azimuths x distances x altitude pairs)")
    ax.set_ylabel("precompute time [s]")
    ax.legend(fontsize=7)
    ax.set_title("Skyglow kernel precomputation (2-core CPU)")
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
