"""Benchmark: the two knobs of the tiled darkness map of a geographic raster, time against error.

- ``NEAR_CELLS`` (:mod:`nightlights.sky._tile_run`): the radius, in north-south cells, of the
  near field summed on the geographic grid itself (0: everything through the tiles' local
  grids). Each setting maps a synthetic 12 x 8 degree mosaic at 15 arcsec
  (:func:`_mosaic.synthetic_mosaic`, through ``nightlights emission viirs``) and its zenith
  at sites (cell centres; two of them dark, a few cells from villages) is compared with the
  converged reference of ``bench_country.py``: a run on a crop around each site in its own
  azimuthal equidistant projection, four times finer than the mosaic.
- ``LATTICE_SPAN`` (:mod:`nightlights.sky._tiles`): the side of the lattice whose corners are
  projected exactly, the sub-points' positions interpolated between. For one default tile at
  60 N and its 300 km halo: the time of the deposit and the largest position error of
  200,000 random sub-points against PROJ; the exact path (every sub-point projected,
  ``deposit_exact``) is the reference row.

Run: ``python benchmarks/bench_darkness_near_field.py [--quick] [--out DIR]`` (``--quick``:
two sites, a twice finer reference, three radii). Writes ``darkness_near_field.json`` and
``.png``.
"""

from __future__ import annotations

import importlib
import math
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np
from _mosaic import synthetic_mosaic
from bench_country import cell_centre, local_zenith, map_zenith

#: The mosaic [deg] (west, east), (south, north).
LON, LAT = (94.0, 106.0), (31.5, 39.5)
#: Sites (longitude, latitude) [deg]: two dark ones near villages, two in towns.
SITES = ((94.5, 32.0), (97.3, 34.2), (100.0, 35.5), (102.1, 37.7))
#: Near-field radii swept [north-south cells] (0: none).
RADII = (0, 2, 4, 8, 16)
#: Lattice spans swept [m].
SPANS = (1000.0, 3000.0, 7000.0, 20000.0, 60000.0)


def near_field_sweep(folder: Path, radii: tuple[int, ...], sites: Any, refine: int) -> list:
    """Time and site errors of the map at each near-field radius."""
    import nightlights as nl
    from nightlights.sky import _tile_run

    emission = folder / "emission.tif"
    points = [cell_centre(emission, x, y) for x, y in sites]
    reference = [local_zenith(emission, x, y, folder, refine) for x, y in points]
    rows = []
    for radius in radii:
        _tile_run.NEAR_CELLS = radius if radius > 0 else 1e-9
        out = folder / f"darkness_{radius}.tif"
        start = time.perf_counter()
        nl.darkness(nl.Scene(str(emission)), output=str(out), progress=False)
        seconds = time.perf_counter() - start
        pairs = zip(points, reference, strict=True)
        errors = [map_zenith(out, x, y) / r - 1 for (x, y), r in pairs]
        rows.append(
            {
                "near_cells": radius,
                "seconds": seconds,
                "max_abs_error": max(abs(e) for e in errors),
                "site_errors": errors,
            }
        )
        print(rows[-1], flush=True)
    _tile_run.NEAR_CELLS = 8
    return rows


def lattice_sweep(spans: tuple[float, ...]) -> list:
    """Deposit time and position error of one default tile at 60 N for each lattice span."""
    from affine import Affine
    from scipy.ndimage import map_coordinates

    tiles = importlib.import_module("nightlights.sky._tiles")
    step = 15 / 3600
    transform = Affine(step, 0, 20.0, 0, -step, 64.3)
    cell = tiles.AUTHALIC_RADIUS * math.radians(step)
    rng = np.random.default_rng(3)
    shape = (3400, 3400)
    data = rng.lognormal(0.0, 1.5, (1, *shape)) * (rng.random((1, *shape)) < 0.05)
    emission = tiles.Emission(None, data, transform, "EPSG:4326", shape, 1, "bench")
    grid = tiles.local_grid("EPSG:4326", transform, (650, 2698, 650, 2698), cell, (650, 650))
    window = tiles.source_window(emission, grid)
    r0, r1, c0, c1 = window
    to_local = tiles._transformer("EPSG:4326", grid.crs)
    fr, fc = rng.uniform(0, r1 - r0, 200_000), rng.uniform(0, c1 - c0, 200_000)
    ex, ey = to_local.transform(*tiles._apply(transform, c0 + fc, r0 + fr))
    rows = []
    original = tiles.LATTICE_SPAN
    start = time.perf_counter()
    tiles.deposit_exact(emission, window, grid)
    rows.append({"span_m": None, "seconds": time.perf_counter() - start, "max_error_m": 0.0})
    tiles.deposit(emission, window, grid)  # compile
    for span in spans:
        tiles.LATTICE_SPAN = span
        start = time.perf_counter()
        tiles.deposit(emission, window, grid)
        seconds = time.perf_counter() - start
        lattice = tiles.lattice_step(cell)
        nr = tiles._lattice_nodes(r1 - r0, lattice)
        nc = tiles._lattice_nodes(c1 - c0, lattice)
        cc, rr = np.meshgrid(c0 + nc, r0 + nr)
        px, py = (np.asarray(v) for v in to_local.transform(*tiles._apply(transform, cc, rr)))
        ir = np.interp(fr, nr, np.arange(nr.size))
        ic = np.interp(fc, nc, np.arange(nc.size))
        qx = map_coordinates(px, [ir, ic], order=1)
        qy = map_coordinates(py, [ir, ic], order=1)
        error = float(np.max(np.hypot(qx - np.asarray(ex), qy - np.asarray(ey))))
        rows.append({"span_m": span, "seconds": seconds, "max_error_m": error})
        print(rows[-1], flush=True)
    tiles.LATTICE_SPAN = original
    return rows


def plot(payload: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.0))
    near = payload["near_field"]
    left.plot([r["seconds"] for r in near], [100 * r["max_abs_error"] for r in near], "o-")
    for r in near:
        left.annotate(f"{r['near_cells']}", (r["seconds"], 100 * r["max_abs_error"]))
    left.axhline(2.0, ls=":", c="grey")
    left.set_yscale("log")
    left.set_xlabel("darkness map [s]")
    left.set_ylabel("worst site vs 4x finer local run [%]")
    left.set_title("near-field radius (north-south cells)")
    lattice = [r for r in payload["lattice"] if r["span_m"] is not None]
    exact = next(r for r in payload["lattice"] if r["span_m"] is None)
    right.plot([r["seconds"] for r in lattice], [r["max_error_m"] for r in lattice], "o-")
    for r in lattice:
        right.annotate(f"{r['span_m'] / 1000:g} km", (r["seconds"], r["max_error_m"]))
    right.axvline(exact["seconds"], ls=":", c="grey", label="every sub-point projected")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlabel("deposit of one tile [s]")
    right.set_ylabel("largest position error [m]")
    right.set_title("lattice span (one tile at 60 N, 300 km halo)")
    right.legend()
    fig.tight_layout()
    return fig


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="two sites, a 2x finer reference, 3 radii")
    args = harness.parse_args(parser)
    warnings.simplefilter("ignore")
    folder = Path(tempfile.mkdtemp(prefix="bench_near_"))
    mosaic = folder / "mosaic.tif"
    synthetic_mosaic(mosaic, lon=LON, lat=LAT)
    subprocess.run(
        [sys.executable, "-m", "nightlights_cli", "emission", "viirs", str(mosaic),
         str(folder / "emission.tif")],
        check=True,
        capture_output=True,
    )  # fmt: skip
    sites = SITES[:2] if args.quick else SITES
    radii = (0, 4, 8) if args.quick else RADII
    payload = {
        "mosaic": {"lon": list(LON), "lat": list(LAT), "arcsec": 15},
        "sites": [list(s) for s in sites],
        "reference_refine": 2 if args.quick else 4,
        "near_field": near_field_sweep(folder, radii, sites, 2 if args.quick else 4),
        "lattice": lattice_sweep(SPANS[1:4] if args.quick else SPANS),
    }
    harness.write_results(args.out, "darkness_near_field", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
