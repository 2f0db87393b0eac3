"""Clouds: the analytic model's two knobs, time against error.

The bounce grid's cells per base height (:func:`nightlights.sky.clouds.cloud_profiles`) and the
Gauss-Legendre nodes per panel of the line-of-sight integrals
(:func:`nightlights.sky.clouds.cloud_luminance`), against a converged reference (32 cells per
height, 64 nodes). Rays: elevations 90, 45 and 20 deg, towards and away from a point source at
0.5-30 km, relative azimuths 0 and 180 deg; a 1 km deck of optical depth 15 over a flat Earth,
turbidity 2, Lambertian emission. Error: the largest relative error over the rays; time: one
profile and the table of all rays (best of three).

Run: ``python benchmarks/bench_sky_clouds_knobs.py [--quick] [--out DIR]``
(``--quick``: fewer settings).
Writes ``sky_clouds_knobs.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

from typing import Any

import _harness as harness
import numpy as np

from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer, cloud_luminance, cloud_profiles

CELLS = (2, 4, 8, 16)
NODES = (4, 8, 16, 32)
REFERENCE = (32, 64)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer settings")
    args = harness.parse_args(parser)
    atmosphere = Atmosphere(flat_earth=True)
    deck = CloudLayer(1000.0, optical_depth=15.0)
    el, az, r = np.meshgrid(
        [90.0, 45.0, 20.0], [0.0, 180.0], [500.0, 2e3, 5e3, 10e3, 30e3], indexing="ij"
    )

    def table(cells: int, nodes: int) -> np.ndarray:
        profiles = cloud_profiles(deck, atmosphere, cells_per_height=cells)
        return np.asarray(
            cloud_luminance(el, az, r, deck, atmosphere, profiles=profiles, nodes=nodes)
        )

    reference = table(*REFERENCE)
    cells = CELLS[1:3] if args.quick else CELLS
    nodes = NODES[1:3] if args.quick else NODES
    rows = []
    for c in cells:
        for n in nodes:
            timing = harness.repeat(lambda c=c, n=n: table(c, n), repeats=3)
            error = float(np.max(np.abs(timing.value / reference - 1.0)))
            rows.append({"cells_per_height": c, "nodes": n, "seconds": timing.best, "error": error})
            print(f"cells {c:3d} nodes {n:3d}: {timing.best:.3f} s, error {error:.2e}", flush=True)
    result = {"reference": {"cells_per_height": REFERENCE[0], "nodes": REFERENCE[1]}, "rows": rows}
    harness.write_results(args.out, "sky_clouds_knobs", result, quick=args.quick, plot=plot)


def plot(result: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for c in sorted({r["cells_per_height"] for r in result["rows"]}):
        rows = [r for r in result["rows"] if r["cells_per_height"] == c]
        ax.plot(
            [r["seconds"] for r in rows],
            [max(r["error"], 1e-12) for r in rows],
            "o-",
            label=f"{c} cells per base height",
        )
        for r in rows:
            ax.annotate(str(r["nodes"]), (r["seconds"], max(r["error"], 1e-12)), fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time for the profile and 30 rays [s]")
    ax.set_ylabel("largest relative error")
    ax.set_title("cloudy-sky model: grid cells and Gauss nodes (labels)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
