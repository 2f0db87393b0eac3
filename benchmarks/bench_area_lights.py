"""Benchmark: area sources as Voronoi pseudo-lights, accuracy against their number.

Knob: the pseudo-light spacing (``AreaLightOptions.spacing``), hence the number of
pseudo-lights per area source (Chuang 2011, Sec. 5.2). Two sources, each a horizontal
Lambertian panel with uniform luminous exitance: a 40 x 20 m parking lot at 8 m and a
105 x 68 m sports field at 15 m. The reference is exact: the illuminance under a uniform
Lambertian rectangle from the view factor of a differential element to a parallel rectangle
(Howell's catalogue, factor B-3; ``nightlights.ground.rectangle_illuminance``),
evaluated at the pixel centres of a 1 m grid that extends 3 heights beyond the panel. For
each spacing (as a fraction of the height) the script measures the time of the irradiance
kernel, the largest and the mean absolute error relative to the peak illuminance, and the
ground flux on the grid against the exact one.

Run: ``python benchmarks/bench_area_lights.py [--quick] [--out DIR]`` (``--quick``: every
other spacing). Writes ``area_lights.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import json

import _harness as harness
import numpy as np
import shapely

from nightlights.ground import (
    area_luminaires,
    compute_irradiance,
    grid_from_bounds,
    pseudo_lights,
    rectangle_illuminance,
)

SOURCES = {
    "parking lot 40 x 20 m at 8 m": ((0.0, 0.0, 40.0, 20.0), 8.0, 20.0),
    "sports field 105 x 68 m at 15 m": ((0.0, 0.0, 105.0, 68.0), 15.0, 300.0),
}
SPACING_FRACTIONS = (4.0, 2.0, 1.0, 0.5, 0.25, 0.125)
DEFAULT_FRACTION = 0.5


def run(bounds, height: float, exitance: float, fraction: float) -> dict:
    margin = 3 * height
    grid = grid_from_bounds(
        (bounds[0] - margin, bounds[1] - margin, bounds[2] + margin, bounds[3] + margin), 1.0
    )
    x = grid.x_min + np.arange(grid.cols) + 0.5
    y = grid.y_max - np.arange(grid.rows) - 0.5
    exact = rectangle_illuminance(x[None, :], y[:, None], bounds, exitance=exitance, height=height)
    with harness.Stopwatch() as watch:
        lights = pseudo_lights([shapely.box(*bounds)], [exitance], spacing=fraction * height)
        luminaires = area_luminaires(lights, height=height)
        result = compute_irradiance(
            grid,
            luminaires,
            luminaires.intensity_scale[:, None],
            np.full(len(lights.x), np.inf),
            progress=False,
        )
    error = result.bands[0].astype(float) - exact
    return {
        "spacing_over_height": fraction,
        "pseudo_lights": len(lights.x),
        "time_s": watch.seconds,
        "max_error_over_peak": float(np.abs(error).max() / exact.max()),
        "mean_abs_error_over_peak": float(np.abs(error).mean() / exact.max()),
        "flux_error": float(result.bands[0].astype(float).sum() / exact.sum() - 1),
    }


def main() -> None:
    args = harness.parse_args(harness.argument_parser(__doc__, quick="every other spacing"))
    fractions = SPACING_FRACTIONS[::2] if args.quick else SPACING_FRACTIONS
    results = {}
    run(*SOURCES[next(iter(SOURCES))], 1.0)  # warm-up: first calls pay for imports and caches
    for name, (bounds, height, exitance) in SOURCES.items():
        results[name] = [run(bounds, height, exitance, fraction) for fraction in fractions]
        for row in results[name]:
            print(name, json.dumps(row))
    payload = {
        "reference": "exact view factor of a parallel rectangle (Howell B-3)",
        "default_spacing_over_height": DEFAULT_FRACTION,
        "note": "timings from a shared 2-core machine, noisy",
        "sources": results,
    }
    harness.write_results(args.out, "area_lights", payload, quick=args.quick, plot=plot, dpi=120)


def plot(payload: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, rows in payload["sources"].items():
        n = [r["pseudo_lights"] for r in rows]
        line = axes[0].plot(n, [r["max_error_over_peak"] for r in rows], "o-", label=f"{name}, max")
        axes[0].plot(
            n,
            [r["mean_abs_error_over_peak"] for r in rows],
            "s--",
            color=line[0].get_color(),
            label=f"{name}, mean",
        )
        for r in rows:
            label = f"s={r['spacing_over_height']:g}h"
            if r["spacing_over_height"] == payload["default_spacing_over_height"]:
                label += " (default)"
            axes[0].annotate(
                label,
                (r["pseudo_lights"], r["max_error_over_peak"]),
                fontsize=7,
                xytext=(3, 3),
                textcoords="offset points",
            )
        axes[1].plot(
            [r["time_s"] for r in rows], [r["max_error_over_peak"] for r in rows], "o-", label=name
        )
    axes[0].set_xlabel("pseudo-lights per source")
    axes[0].set_ylabel("pixel error / peak illuminance")
    axes[0].set_title("accuracy against the exact Lambertian panel")
    axes[1].set_xlabel("kernel time [s]")
    axes[1].set_ylabel("max pixel error / peak")
    axes[1].set_title("time against error")
    for axis in axes:
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    fig.suptitle("Area sources as Voronoi pseudo-lights (Chuang 2011, Sec. 5.2)", fontsize=10)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
