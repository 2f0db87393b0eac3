"""Source-level spacing of scene kernels over terrain: build time against interpolation error.

Knob: the spacing of the source-altitude levels (:data:`nightlights.sky.spec.SOURCE_LEVEL_SPACING`,
default 50 m) at which a scene kernel is tabulated; each lit cell's image is the linear blend
of the two levels around its altitude. Worst case: a source halfway between two levels. For
spacings of 200-12.5 m the image interpolated between levels 0 and `spacing` is compared with
the image computed at `spacing / 2` directly (observer at 100 m above sea level, 32 x 128
images, sources 200 m - 10 km away). Error: mean relative error over pixels brighter than 1 %
of the image's maximum, per distance. Time: building a kernel whose levels span a 250 m terrain
range at that spacing (64 log bins 10 m - 20 km, 32 x 128).

Run: ``python benchmarks/bench_sky_source_levels.py [--quick] [--out DIR]`` (``--quick``:
spacings 200, 100 and 50 m).
Writes ``sky_source_levels.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.spec import SOURCE_LEVEL_SPACING, source_levels

SPACINGS = (200.0, 100.0, 50.0, 25.0, 12.5)
DISTANCES = (200.0, 500.0, 2000.0, 10_000.0)
OBSERVER = 100.0


def images(levels: tuple[float, ...]) -> np.ndarray:
    edges = np.sort(np.concatenate([[d * 0.98, d * 1.02] for d in DISTANCES]))
    spec = KernelSpec(
        distance_edges=edges,
        n_elevation=32,
        n_azimuth=128,
        source_altitudes=levels,
        observer_altitudes=(OBSERVER,),
        n_components=1,
    )
    ds = build_kernel(spec, progress=False).kernel
    return ds.kernel.values[0][:, ::2].astype(float)  # (levels, distances, el, az)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="the three widest spacings")
    args = harness.parse_args(parser)
    spacings = SPACINGS[:3] if args.quick else SPACINGS
    build_kernel(KernelSpec(n_distance=64, n_elevation=2, n_azimuth=16), progress=False)  # compile
    rows = []
    for spacing in spacings:
        pair = images((0.0, spacing))
        middle = images((spacing / 2.0,))[0]
        blended = 0.5 * (pair[0] + pair[1])
        errors = {}
        for i, d in enumerate(DISTANCES):
            bright = middle[i] > 0.01 * middle[i].max()
            errors[str(int(d))] = float(np.mean(np.abs(blended[i][bright] / middle[i][bright] - 1)))
        levels = source_levels([0.0, 250.0], spacing=spacing, max_levels=64)
        _, build_seconds = harness.timed(
            lambda levels=levels: build_kernel(
                KernelSpec(
                    r_min=10.0,
                    r_max=20_000.0,
                    n_distance=64,
                    n_elevation=32,
                    n_azimuth=128,
                    source_altitudes=tuple(levels),
                    observer_altitudes=(OBSERVER,),
                ),
                progress=False,
            )
        )
        rows.append(
            {
                "spacing_m": spacing,
                "levels_over_250_m": int(levels.size),
                "build_seconds": build_seconds,
                "mean_rel_error_by_distance_m": errors,
            }
        )
        print(rows[-1], flush=True)
    result = {
        "default_spacing_m": SOURCE_LEVEL_SPACING,
        "case": "source halfway between two levels, observer at 100 m",
        "rows": rows,
        "note": "Timings from a shared 2-core machine, noisy.",
    }
    harness.write_results(args.out, "sky_source_levels", result, quick=args.quick, plot=plot)


def plot(result: dict):
    plt = harness.pyplot()
    rows = result["rows"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    for d in DISTANCES:
        ax1.loglog(
            [r["spacing_m"] for r in rows],
            [r["mean_rel_error_by_distance_m"][str(int(d))] for r in rows],
            "o-",
            label=f"source {d / 1000:g} km away",
        )
    ax1.axvline(SOURCE_LEVEL_SPACING, color="grey", lw=0.8, ls=":")
    ax1.set_xticks(SPACINGS, [f"{x:g}" for x in SPACINGS])
    ax1.minorticks_off()
    ax1.set_xlabel("source-level spacing [m]")
    ax1.set_ylabel("mean relative error (halfway source)")
    ax1.legend(fontsize=7)
    ax2.semilogy(
        [r["build_seconds"] for r in rows],
        [r["mean_rel_error_by_distance_m"]["500"] for r in rows],
        "o-",
    )
    for r in rows:
        ax2.annotate(
            f"{r['spacing_m']:g} m", (r["build_seconds"], r["mean_rel_error_by_distance_m"]["500"])
        )
    ax2.set_xlabel("kernel build time, levels over a 250 m range [s]")
    ax2.set_ylabel("mean relative error, source 500 m away")
    fig.suptitle("Scene kernels over terrain: source-level spacing")
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
