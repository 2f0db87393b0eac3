"""Benchmark: region-of-influence threshold of the irradiance stage, time against error.

Knob: the threshold that sets each luminaire's region of influence
(``nightlights.ground.InfluenceThreshold``): the truncated-energy fraction (``energy``)
or the illuminance floor (``floor``). The scene is a 600 x 600 m square with 360 lights
(1,000 per km2, the density of the 100,000-luminaire target) drawn from the bundled
luminaire database (all five systems, random headings, tilts 0-10 deg), on a 1 m grid.
The reference is the all-pixels sum (``threshold none``) on the same grid. For each
threshold the script measures the wall time (best of 2) and the errors against the
reference: lost ground flux (fraction), mean and maximum absolute pixel error [lx], and the
99th percentile of the relative error over pixels lit above 0.5 lx.

Run: ``python benchmarks/bench_irradiance_roi.py [--quick] [--out DIR]`` (``--quick``: a
300 m square, every other threshold, one timing run).
Writes ``irradiance_roi.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import json

import _harness as harness
import geopandas as gpd
import numpy as np

from ies.library import load_library
from nightlights.ground import (
    InfluenceThreshold,
    compute_irradiance,
    grid_from_bounds,
    resolve_luminaires,
    sensor_factors,
)

ENERGY = (0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001)
FLOOR = (3.0, 1.0, 0.3, 0.1, 0.03, 0.01, 0.003)
DEFAULT = InfluenceThreshold()


def scene(side: float, density: float, seed: int = 0):
    """Luminaires of the bundled systems scattered over a square [m]."""
    database = load_library()
    rng = np.random.default_rng(seed)
    n = int(density * (side / 1000) ** 2)
    names = np.array(sorted(database.systems))
    frame = gpd.GeoDataFrame(
        {
            "light_id": np.arange(n),
            "system_id": rng.choice(names, n),
            "heading": rng.uniform(0, 360, n),
            "tilt": rng.choice([0.0, 5.0, 10.0], n),
        },
        geometry=gpd.points_from_xy(rng.uniform(0, side, n), rng.uniform(0, side, n)),
        crs="EPSG:32633",
    )
    return resolve_luminaires(frame, database)


def run(luminaires, grid, threshold: InfluenceThreshold, repeats: int):
    weights = sensor_factors(luminaires.spectra, ["photopic"])[luminaires.table_index]
    timing = harness.repeat(
        lambda: compute_irradiance(
            grid, luminaires, weights, luminaires.radius(threshold), progress=False
        ),
        repeats,
    )
    return timing.best, timing.value


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="smaller scene, fewer thresholds")
    args = harness.parse_args(parser)
    side = 300.0 if args.quick else 600.0
    repeats = 1 if args.quick else 2
    luminaires = scene(side, 1000.0)
    grid = grid_from_bounds((0, 0, side, side), 1.0)
    ref_time, ref = run(luminaires, grid, InfluenceThreshold("none"), repeats)
    reference = ref.bands[0].astype(float)
    lit = reference > 0.5
    rows = []
    sweeps = [("energy", ENERGY), ("floor", FLOOR)]
    if args.quick:
        sweeps = [("energy", ENERGY[::2]), ("floor", FLOOR[::2])]
    for kind, values in sweeps:
        for value in values:
            threshold = InfluenceThreshold(kind, value)  # type: ignore[arg-type]
            elapsed, result = run(luminaires, grid, threshold, repeats)
            band = result.bands[0].astype(float)
            error = reference - band
            rows.append(
                {
                    "kind": kind,
                    "value": value,
                    "time_s": elapsed,
                    "pairs": result.n_pairs,
                    "lost_flux_fraction": float(error.sum() / reference.sum()),
                    "mean_abs_error_lx": float(np.abs(error).mean()),
                    "max_abs_error_lx": float(np.abs(error).max()),
                    "p99_relative_error_lit": float(
                        np.percentile(np.abs(error[lit]) / reference[lit], 99)
                    ),
                    "mean_radius_m": float(luminaires.radius(threshold).mean()),
                }
            )
            print(json.dumps(rows[-1]))
    payload = {
        "scene": {
            "side_m": side,
            "lights": len(luminaires),
            "resolution_m": 1.0,
            "systems": list(luminaires.names),
        },
        "reference": {"time_s": ref_time, "pairs": ref.n_pairs, "mean_lx": float(reference.mean())},
        "default": {"kind": DEFAULT.kind, "value": DEFAULT.value},
        "note": "timings from a shared 2-core machine, noisy",
        "rows": rows,
    }
    harness.write_results(args.out, "irradiance_roi", payload, quick=args.quick, plot=plot, dpi=120)


def plot(payload: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    markers = {"energy": "o-", "floor": "s-"}
    for kind in ("energy", "floor"):
        rows = [r for r in payload["rows"] if r["kind"] == kind]
        times = [r["time_s"] for r in rows]
        for axis, key in zip(axes, ("lost_flux_fraction", "mean_abs_error_lx"), strict=True):
            axis.plot(times, [max(r[key], 1e-9) for r in rows], markers[kind], label=kind)
            offset = (4, 4) if kind == "energy" else (4, -11)
            for r in rows:
                value = max(r[key], 1e-9)
                axis.annotate(
                    f"{r['value']:g}",
                    (r["time_s"], value),
                    fontsize=7,
                    xytext=offset,
                    textcoords="offset points",
                )
                if kind == payload["default"]["kind"] and r["value"] == payload["default"]["value"]:
                    axis.plot(
                        [r["time_s"]],
                        [value],
                        "r*",
                        ms=13,
                        zorder=3,
                        label=f"default {kind}:{r['value']:g}",
                    )
    for axis, title in zip(
        axes, ("lost ground flux [fraction]", "mean absolute pixel error [lx]"), strict=True
    ):
        axis.axvline(
            payload["reference"]["time_s"], color="grey", ls="--", label="all pixels (reference)"
        )
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("wall time [s]")
        axis.set_title(title)
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    scene = payload["scene"]
    fig.suptitle(
        f"Region of influence: {scene['lights']} lights, {scene['side_m']:g} m square, 1 m "
        "pixels (threshold values annotated)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
