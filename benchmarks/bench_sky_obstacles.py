"""Obstacles on a test sky: the obstructed emission against the exact truncated shape.

Knob: how obstacles reach the kernel. *Approximation* (what a scene with ``obstacles=`` does,
:mod:`nightlights.sky.obstacles`): the light through the gaps keeps its shape, the light over
the obstacles is carried as Lambertian; the kernel's own shape tables serve it. *Exact*: the
transmitted function I t as a tabulated emission function, a kernel table of its own for each
obstacle class. Case: a 10 km square city of uniform flux (1 lm m-2, Garstang's function
F = G = 0.15) on a 221 km grid of 1 km cells, default turbidity, scene kernels of 16 x 32
pixels and 40 distance bins; the zenith luminance at 0-100 km from the centre, obstacles of
the ``compact_midrise`` defaults (h = 17.5 m, d = 12.7 m) in every lit cell with their own
filling factor f = 0.55 and with f = 1 (full canyons). Each ratio is to its own open sky
(the garstang shapes for the approximation, the tabulated open function for the exact), so
the kernel forms' own differences cancel. Error: approximation ratio / exact ratio - 1.

Run: ``python benchmarks/bench_sky_obstacles.py [--quick] [--out DIR]``
(``--quick``: f = 0.55 at 0, 20 and 100 km).
Writes ``sky_obstacles.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import json
import tempfile

import _harness as harness
import numpy as np
from affine import Affine

from nightlights.emission_functions import EmissionFunction
from nightlights.ground.obstacles import (
    LAND_USE_OBSTACLES,
    ObstacleProperties,
    blocked_intensity,
    escaping_fraction,
)
from nightlights.io import Raster
from nightlights.sky import Observer, Scene, skyglow

CELL = 1000.0  # [m]
N = 221  # cells per side
TAG = "garstang:0.15,0.15"
DISTANCES_KM = (0, 2, 5, 10, 20, 50, 100)
FILLINGS = (0.55, 1.0)


def _raster(flux: np.ndarray, tag: str) -> Raster:
    transform = Affine(
        CELL, 0, 500_000 - (N // 2 + 0.5) * CELL, 0, -CELL, 6_700_000 + (N // 2 + 0.5) * CELL
    )
    return Raster(flux, transform, "EPSG:32635", ("upward",), ("lm m-2",),
                  band_tags=({"emission_function": tag},))  # fmt: skip


def _table(intensity: np.ndarray, angles: np.ndarray) -> str:
    return "tabulated:" + json.dumps({"angles": angles.tolist(), "intensities": intensity.tolist()})


def case(filling: float, distances: tuple[int, ...], cache: str) -> dict:
    base = LAND_USE_OBSTACLES["compact_midrise"]
    props = ObstacleProperties(base.height, base.spacing, filling)
    flux = np.zeros((1, N, N))
    c = N // 2
    flux[0, c - 5 : c + 5, c - 5 : c + 5] = 1.0
    function = EmissionFunction.parse(TAG)
    angles = np.linspace(0.0, 90.0, 361)
    mu = np.cos(np.radians(angles))
    kept = blocked_intensity(mu, function, props.height, props.spacing, props.filling)
    escaping = float(escaping_fraction(function, props.height, props.spacing, props.filling))
    grid = {"n_elevation": 16, "n_azimuth": 32, "n_distance": 40, "cache_dir": cache}
    scenes = {
        "open": Scene(_raster(flux, TAG), **grid),
        "approximation": Scene(_raster(flux, TAG), obstacles=props, **grid),
        "exact_open": Scene(_raster(flux, _table(function.intensity(mu), angles)), **grid),
        "exact": Scene(_raster(flux * escaping, _table(kept, angles)), **grid),
    }
    rows = []
    for km in distances:
        eye = Observer(500_000.0 + km * 1000.0, 6_700_000.0, height=0.0)
        row: dict = {"distance_km": km}
        for name, scene in scenes.items():
            result, seconds = harness.timed(lambda s=scene, e=eye: skyglow(s, e, progress=False))
            row[name] = result.zenith_luminance
            row[f"{name}_seconds"] = seconds
        row["approximation_ratio"] = row["approximation"] / row["open"]
        row["exact_ratio"] = row["exact"] / row["exact_open"]
        row["error"] = row["approximation_ratio"] / row["exact_ratio"] - 1.0
        print(filling, {k: round(v, 4) for k, v in row.items() if "ratio" in k or k == "error"})
        rows.append(row)
    return {"filling": filling, "height_m": props.height, "spacing_m": props.spacing,
            "escaping_fraction": escaping, "rows": rows}  # fmt: skip


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="f = 0.55 at 0, 20 and 100 km")
    args = harness.parse_args(parser)
    fillings = FILLINGS[:1] if args.quick else FILLINGS
    distances = (0, 20, 100) if args.quick else DISTANCES_KM
    with tempfile.TemporaryDirectory() as cache:
        cases = [case(f, distances, cache) for f in fillings]
    table = [
        {"filling": c["filling"], **{k: r[k] for k in ("distance_km", "exact_ratio",
                                                       "approximation_ratio", "error")}}
        for c in cases
        for r in c["rows"]
    ]  # fmt: skip
    result = {
        "cases": cases,
        "table": table,
        "note": "Ratios of the zenith luminance with obstacles to the open sky; the first "
        "skyglow of each scene includes its kernel build. Shared 2-core machine, noisy.",
    }
    harness.write_results(args.out, "sky_obstacles", result, quick=args.quick, plot=plot, dpi=110)


def plot(result: dict):
    plt = harness.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for c in result["cases"]:
        km = [max(r["distance_km"], 0.5) for r in c["rows"]]
        f = c["filling"]
        exact = [r["exact_ratio"] for r in c["rows"]]
        line = ax.semilogx(km, exact, "o-", label=f"exact, f = {f:g}")
        approx = [r["approximation_ratio"] for r in c["rows"]]
        ax.semilogx(km, approx, "s--", color=line[0].get_color(), label=f"approximation, f = {f:g}")
    ax.set_xlabel("distance from the city centre [km] (0 plotted at 0.5)")
    ax.set_ylabel("zenith luminance with obstacles / open [1]")
    ax.set_title("Obstacles (h = 17.5 m, d = 12.7 m) on a 10 km city's sky")
    ax.set_ylim(0, 0.7)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
