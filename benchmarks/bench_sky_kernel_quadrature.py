"""Benchmark: Gauss-Legendre nodes of the skyglow line-of-sight integral, time against error.

Knob: ``nodes`` of :func:`nightlights.sky.kernel.sky_luminance` (nodes per panel; three panels
per ray: before the closest approach, after it, past one density scale length). Rays: 16
elevations (panorama rows) x 9 relative azimuths (0-180 deg) x 12 source distances (100 m -
300 km, log-spaced) for three altitude pairs (h_c, h_o) = (0, 0), (500, 0), (0, 500) m, default
atmosphere (turbidity 2, spherical Earth). Reference: 256 nodes. Error: relative error over lit
rays (max, 99th percentile, median). Also, separately, sources 10-100 m away (observer next to
a lit cell), where convergence is slower. Time: wall time per ray (best of 2), for the
compiled (numba, default) and the numpy backend.
Baseline (Dobashi et al. 2023, Sec. 3.2): uniform steps along the ray (midpoint rule, 3 m -
1 km steps, as far as the top of the model atmosphere) on a subset of 4 x 3 x 4 rays, same
integrand (:func:`nightlights.sky.kernel.line_of_sight_integrand`).

Run: ``python benchmarks/bench_sky_kernel_quadrature.py [--quick] [--out DIR]`` (``--quick``:
8 x 5 x 6 rays, every fourth uniform-step ray).
Writes ``sky_kernel_quadrature.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.geometry import ray_exit_distance
from nightlights.sky.kernel import line_of_sight_integrand, sky_luminance
from nightlights.sky.spec import panorama_elevations

NODES = (4, 6, 8, 12, 16, 24, 32, 48, 64)
PAIRS = ((0.0, 0.0), (500.0, 0.0), (0.0, 500.0))


def rays(near: bool, n_el: int, n_az: int, n_r: int) -> tuple[np.ndarray, ...]:
    el = panorama_elevations(n_el)[:, None, None]
    az = np.linspace(0.0, 180.0, n_az)[None, :, None]
    r = np.geomspace(10.0, 100.0, n_r) if near else np.geomspace(100.0, 3e5, n_r)
    return el, az, r[None, None, :]


def timed(nodes: int, grid: tuple[np.ndarray, ...], backend: str) -> tuple[float, dict]:
    """Best of 2 wall times of all altitude pairs [s], and their luminances."""
    timing = harness.repeat(
        lambda: {
            p: sky_luminance(
                *grid, source_altitude=p[0], observer_altitude=p[1], nodes=nodes, backend=backend
            )
            for p in PAIRS
        },
        2,
    )
    return timing.best, timing.value


def measure(nodes: int, ref: dict, grid: tuple[np.ndarray, ...]) -> dict:
    errs = []
    best, values = timed(nodes, grid, "numba")
    best_numpy, _ = timed(nodes, grid, "numpy")
    for p in PAIRS:
        lit = ref[p] > 0
        errs.append(np.abs(values[p][lit] / ref[p][lit] - 1.0))
    err = np.concatenate(errs)
    n_rays = sum(int(np.size(ref[p])) for p in PAIRS)
    return {
        "nodes": nodes,
        "points_per_ray": 3 * nodes,
        "time_per_ray_us": 1e6 * best / n_rays,
        "time_per_ray_us_numpy": 1e6 * best_numpy / n_rays,
        "max_rel_error": float(err.max()),
        "p99_rel_error": float(np.percentile(err, 99)),
        "median_rel_error": float(np.median(err)),
    }


def uniform_steps(quick: bool) -> list[dict]:
    """Midpoint rule with uniform steps against the 256-node reference (h_c = h_o = 0)."""
    atm = Atmosphere()
    rays = [
        (el, az, r)
        for el in (5.0, 20.0, 45.0, 85.0)
        for az in (0.0, 90.0, 180.0)
        for r in (100.0, 1000.0, 10_000.0, 100_000.0)
    ]
    if quick:
        rays = rays[::4]
    rows = []
    for step in (1000.0, 300.0, 100.0, 30.0, 10.0, 3.0):
        errs, seconds = [], 0.0
        for el, az, r in rays:
            ref = float(sky_luminance(el, az, r, nodes=256))
            with harness.Stopwatch() as watch:
                top = float(
                    ray_exit_distance(
                        el, 0.0, atm.top_altitude, earth_radius=atm.earth_radius, flat_earth=False
                    )
                )
                u_all = np.arange(0.5 * step, top, step)
                total = 0.0
                for lo in range(0, u_all.size, 1_000_000):
                    u = u_all[lo : lo + 1_000_000]
                    integrand = line_of_sight_integrand(u, el, az, r, atmosphere=atm)
                    total += float(integrand.sum()) * step
            seconds += watch.seconds
            if ref > 0:
                errs.append(abs(total / ref - 1.0))
        err = np.array(errs)
        rows.append(
            {
                "step_m": step,
                "time_per_ray_us": 1e6 * seconds / len(rays),
                "max_rel_error": float(err.max()),
                "median_rel_error": float(np.median(err)),
            }
        )
        print("uniform", rows[-1])
    return rows


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer rays")
    args = harness.parse_args(parser)
    shape = (8, 5, 6) if args.quick else (16, 9, 12)
    out: dict = {"reference_nodes": 256}
    for label, near in (("far", False), ("near", True)):
        grid = rays(near, *shape)
        ref = {
            p: sky_luminance(*grid, source_altitude=p[0], observer_altitude=p[1], nodes=256)
            for p in PAIRS
        }
        out[label] = [measure(n, ref, grid) for n in NODES]
    out["uniform_steps"] = uniform_steps(args.quick)
    out["note"] = (
        "far: sources 100 m - 300 km; near: sources 10-100 m (observer next to a lit cell). "
        "Timings from a shared 2-core machine, noisy."
    )
    harness.write_results(
        args.out, "sky_kernel_quadrature", out, quick=args.quick, plot=plot, dpi=110
    )
    for label in ("far", "near"):
        for r in out[label]:
            print(label, r)


def plot(out: dict):
    plt = harness.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    for label, style in (("far", "-"), ("near", "--")):
        rows = out[label]
        n = [r["nodes"] for r in rows]
        for key, colour in (
            ("max_rel_error", "C3"),
            ("p99_rel_error", "C1"),
            ("median_rel_error", "C0"),
        ):
            ax1.loglog(
                n,
                [max(r[key], 1e-16) for r in rows],
                style,
                color=colour,
                marker="o",
                label=f"{key.split('_')[0]} ({label})",
            )
        for key, backend, colour in (
            ("time_per_ray_us", "numba", "C2"),
            ("time_per_ray_us_numpy", "numpy", "C4"),
        ):
            ax2.semilogy(
                [r[key] for r in rows],
                [max(r["max_rel_error"], 1e-16) for r in rows],
                style,
                marker="o",
                color=colour,
                label=f"max error ({label}, {backend})",
            )
    uni = out["uniform_steps"]
    ax2.semilogy(
        [r["time_per_ray_us"] for r in uni],
        [r["max_rel_error"] for r in uni],
        ":",
        marker="x",
        color="k",
        label="uniform steps 1 km-3 m (max error)",
    )
    ax2.set_xscale("log")
    ax1.axhline(1e-5, color="grey", lw=0.8)
    ax1.set_xticks(NODES, [str(n) for n in NODES])
    ax1.minorticks_off()
    ax1.set_xlabel("Gauss nodes per panel")
    ax1.set_ylabel("relative error vs 256 nodes")
    ax1.legend(fontsize=7)
    ax2.axhline(1e-5, color="grey", lw=0.8)
    ax2.set_xlabel("time per ray [us]")
    ax2.set_ylabel("max relative error")
    ax2.legend(fontsize=7)
    fig.suptitle("Skyglow kernel: line-of-sight quadrature (tan substitution, 3 panels)")
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
