"""Zenith darkness map: time against region size (one FFT and Dask chunks), error against
full skyglow panoramas at sampled cells (flat terrain and over terrain).

Knobs: the region size (up to 40 M cells of 500 m, a 3,160 km square, with the 300 km kernel
range limit) and the chunk edge (one FFT in memory, or 2,048-cell Dask chunks on the local
threads). Time: :attr:`DarknessResult.seconds` (stencils and convolutions, kernel cached),
with the peak of numpy memory traced during the call.

Error: the map's zenith luminance at sampled cells against a full
:func:`~nightlights.sky.forward.skyglow_panorama` there (its zenith: the mean of the top row),
the way a user would compute it: the observer at the cell centre, its own scene kernel (range
to the farthest corner from that cell, exact eye altitude, default PCA mode). Flat terrain:
400 x 400 cells of 500 m with 40 towns, default kernels (64 x 256, 64 distance bins); also
against the same kernel's exact panorama (float rounding only) to separate the causes. Terrain:
160 x 160 cells of 250 m over hills of 300 m, kernels of 32 x 128 with 48 bins (the darkness
kernel then spans 7 x 7 source and observer levels). Target: <= 2 %.

Run: ``python benchmarks/bench_inverse_darkness.py [--quick] [--out DIR]`` (``--quick``:
regions up to 2,048 x 2,048 cells with 1,200-cell chunks, small kernels, fewer cells sampled).
Writes ``inverse_darkness.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import json
import tracemalloc
import warnings
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np
from affine import Affine

from nightlights.errors import DataQualityWarning
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene
from nightlights.sky.darkness import darkness
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.spec import MAX_KERNEL_RANGE
from nightlights.sky.store import get_or_build_kernel, kernel_cache_path, read_kernel

HERE = Path(__file__).parent
CACHE = HERE / ".cache"
CRS = "EPSG:32635"
CELL = 500.0  # [m], about a VIIRS DNB pixel
OBSERVER_HEIGHT = 1.7  # [m]
TARGET = 0.02


def grid(n: int, cell: float) -> Affine:
    return Affine(cell, 0, 0, 0, -cell, n * cell)


def sparse_scene(n: int, rng: np.random.Generator) -> Raster:
    """Timing scene: 5 % of the cells lit at random (an FFT's time does not depend on it)."""
    flux = np.zeros((1, n, n))
    lit = rng.random((n, n)) < 0.05
    flux[0][lit] = rng.lognormal(-2.0, 1.0, int(lit.sum()))
    return Raster(flux, grid(n, CELL), CRS)


def towns(n: int, cell: float, count: int, rng: np.random.Generator) -> Raster:
    """Accuracy scene: towns as Gaussian discs of flux density (radius 0.5-4 km, peak
    0.05-2 lm m-2), a dim scatter of villages, dark land between."""
    rows, cols = np.mgrid[0:n, 0:n]
    flux = np.zeros((n, n))
    for _ in range(count):
        r0, c0 = rng.uniform(0, n, 2)
        sigma = rng.uniform(500.0, 4000.0) / cell
        near = (np.abs(rows - r0) < 4 * sigma) & (np.abs(cols - c0) < 4 * sigma)
        flux[near] += rng.lognormal(-1.5, 1.0) * np.exp(
            -((rows[near] - r0) ** 2 + (cols[near] - c0) ** 2) / (2 * sigma**2)
        )
    villages = rng.random((n, n)) < 0.01
    flux[villages] += rng.uniform(0.001, 0.05, int(villages.sum()))
    flux[flux < 1e-4] = 0.0
    return Raster(flux[None], grid(n, cell), CRS)


def hills(n: int, cell: float, relief: float) -> Raster:
    """Terrain from 0 to ``relief`` m: ridges and a valley [m]."""
    y, x = np.mgrid[0:n, 0:n] * cell / 10_000.0
    z = np.sin(1.3 * x + 0.4) * np.cos(0.9 * y) + 0.5 * np.sin(2.7 * y - x) + 0.3 * x
    z = (z - z.min()) / (z.max() - z.min())
    return Raster(relief * z[None], grid(n, cell), CRS)


def sample_cells(zenith: np.ndarray, count: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    """The brightest, median and darkest cells, a corner, an edge cell and random ones."""
    n = zenith.shape[0]
    order = np.argsort(zenith, axis=None)
    picks = [order[-1], order[order.size // 2], order[0]]
    cells = [tuple(int(v) for v in np.unravel_index(p, zenith.shape)) for p in picks]
    cells += [(0, 0), (n // 2, 0)]
    while len(set(cells)) < count:
        cells.append(tuple(int(v) for v in rng.integers(0, n, 2)))
    return list(dict.fromkeys(cells))[:count]


def reference_zenith(
    raster: Raster, cell: tuple[int, int], *, mode: str = "pca", **scene: Any
) -> float:
    """The panorama's zenith with the observer at ``cell``; ``scene``: the Scene's fields
    beside the emission (kernel, dem, grid)."""
    t = raster.transform
    xy = (t.c + t.a * (cell[1] + 0.5), t.f + t.e * (cell[0] + 0.5))
    sky = skyglow_panorama(
        Scene(raster, cache_dir=CACHE, **scene),
        Observer(*xy, height=OBSERVER_HEIGHT),
        mode=mode,
        progress=False,
    )
    return float(sky.panorama.attrs["zenith_luminance_cd_m2"])


def timing(quick: bool, sizes: dict[str, Any]) -> list[dict[str, Any]]:
    spec = KernelSpec(
        r_min=10.0,
        r_max=MAX_KERNEL_RANGE,
        observer_altitudes=(OBSERVER_HEIGHT,),
        **sizes,
    )
    kernel = get_or_build_kernel(spec, cache_dir=CACHE, progress=False).kernel
    chunk = 1200 if quick else 2048
    rows = []
    rng = np.random.default_rng(0)
    for n in (512, 1024, 2048) if quick else (512, 1024, 2048, 4096, 6325):
        raster = sparse_scene(n, rng)
        row: dict[str, Any] = {"cells": n * n, "edge_cells": n, "region_km": n * CELL / 1000}
        runs = [("one_fft", n)] + ([("chunked", chunk)] if n > chunk else [])
        for label, size in runs:
            tracemalloc.start()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DataQualityWarning)  # regions beyond 300 km
                result = darkness(Scene(raster, kernel=kernel), chunk_size=size, progress=False)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            row[f"{label}_s"] = result.seconds
            row[f"{label}_peak_gib"] = peak / 2**30
            row[f"{label}_method"] = result.raster.tags["method"].rsplit("; ", 1)[-1]
        rows.append(row)
        print(row, flush=True)
        del raster, result
    return rows


def flat_accuracy(quick: bool, sizes: dict[str, Any]) -> dict[str, Any]:
    rng = np.random.default_rng(1)
    n = 200 if quick else 400
    raster = towns(n, CELL, 20 if quick else 40, rng)
    options = {"n_distance": sizes["n_distance"], "n_elevation": sizes["n_elevation"]}
    options["n_azimuth"] = sizes["n_azimuth"]
    result = darkness(
        Scene(raster, cache_dir=CACHE, **options), height=OBSERVER_HEIGHT, progress=False
    )
    zenith = result.raster.data[0]
    same = read_kernel(kernel_cache_path(result.raster.tags["kernel_hash"], CACHE))
    cells = []
    for cell in sample_cells(zenith, 4 if quick else 8, rng):
        own = reference_zenith(raster, cell, **options)
        own_exact = reference_zenith(raster, cell, mode="exact", **options)
        same_exact = reference_zenith(raster, cell, kernel=same, mode="exact")
        cells.append(
            {
                "cell": cell,
                "zenith_cd_m2": float(zenith[cell]),
                "zenith_mag": float(result.raster.data[1][cell]),
                "error_vs_own_kernel_pca": float(zenith[cell] / own - 1),
                "error_vs_own_kernel_exact": float(zenith[cell] / own_exact - 1),
                "error_vs_same_kernel_exact": float(zenith[cell] / same_exact - 1),
            }
        )
        print(cells[-1], flush=True)
    return {
        "region": f"{n} x {n} cells of {CELL:g} m",
        "map_seconds": result.seconds,
        "cells": cells,
        "max_abs_error_vs_own_kernel_pca": max(abs(c["error_vs_own_kernel_pca"]) for c in cells),
    }


def terrain_accuracy(quick: bool) -> dict[str, Any]:
    rng = np.random.default_rng(2)
    cell, relief = 250.0, (100.0 if quick else 300.0)
    n = 80 if quick else 160
    raster, dem = towns(n, cell, 8 if quick else 15, rng), hills(n, cell, relief)
    options = {"n_distance": 48, "n_elevation": 32, "n_azimuth": 128}
    (result, seconds) = harness.timed(
        lambda: darkness(
            Scene(raster, dem=dem, cache_dir=CACHE, **options),
            height=OBSERVER_HEIGHT,
            progress=False,
        )
    )
    zenith = result.raster.data[0]
    cells = []
    for cell_index in sample_cells(zenith, 3 if quick else 5, rng):
        own = reference_zenith(raster, cell_index, dem=dem, **options)
        cells.append(
            {
                "cell": cell_index,
                "ground_m": float(dem.data[0][cell_index]),
                "zenith_cd_m2": float(zenith[cell_index]),
                "error_vs_own_kernel_pca": float(zenith[cell_index] / own - 1),
            }
        )
        print(cells[-1], flush=True)
    tags = result.raster.tags
    return {
        "region": f"{n} x {n} cells of {cell:g} m, hills of {relief:g} m",
        "source_levels": len(json.loads(tags["source_altitude_levels_m"])),
        "observer_levels": len(json.loads(tags["observer_altitude_levels_m"])),
        "kernel_build_and_map_seconds": seconds,
        "map_seconds": result.seconds,
        "cells": cells,
        "max_abs_error_vs_own_kernel_pca": max(abs(c["error_vs_own_kernel_pca"]) for c in cells),
    }


def main() -> None:
    parser = harness.argument_parser(
        __doc__, quick="regions to 2,048^2 cells, small kernels, fewer sampled cells"
    )
    args = harness.parse_args(parser)
    sizes = (
        {"n_distance": 32, "n_elevation": 16, "n_azimuth": 64}
        if args.quick
        else {"n_distance": 64, "n_elevation": 64, "n_azimuth": 256}
    )
    result = {
        "note": "2 shared cores (noisy timings); kernels cached before timing",
        "cell_m": CELL,
        "kernel": f"{sizes['n_elevation']} x {sizes['n_azimuth']}, {sizes['n_distance']} "
        f"distance bins to {MAX_KERNEL_RANGE / 1000:g} km",
        "timing": timing(args.quick, sizes),
        "flat": flat_accuracy(args.quick, sizes),
        "terrain": terrain_accuracy(args.quick),
        "target_error": TARGET,
    }
    harness.write_results(args.out, "inverse_darkness", result, quick=args.quick, plot=plot)
    summary = {key: value for key, value in result.items() if key != "timing"}
    print(json.dumps(summary, indent=2, default=str))


def plot(result: dict[str, Any]):
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
    rows = result["timing"]
    cells = np.array([r["cells"] for r in rows])
    left.loglog(cells, [r["one_fft_s"] for r in rows], "o-", label="one FFT")
    chunked = [r for r in rows if "chunked_s" in r]
    if chunked:
        left.loglog(
            [r["cells"] for r in chunked],
            [r["chunked_s"] for r in chunked],
            "s-",
            label="Dask chunks (local threads)",
        )
    left.set_xlabel("region [cells of 500 m]")
    left.set_ylabel("time [s]")
    left.set_title(f"darkness map: time ({result['kernel']})", fontsize=9)
    left.legend(fontsize=8)
    series = [
        ("flat", "error_vs_own_kernel_pca", "flat, own scene kernel (PCA)"),
        ("flat", "error_vs_own_kernel_exact", "flat, own scene kernel (exact)"),
        ("flat", "error_vs_same_kernel_exact", "flat, same kernel (exact)"),
        ("terrain", "error_vs_own_kernel_pca", "terrain, own scene kernel (PCA)"),
    ]
    for offset, (part, key, label) in enumerate(series):
        values = [abs(c[key]) for c in result[part]["cells"]]
        right.semilogy(
            np.arange(len(values)) + 0.15 * offset, np.maximum(values, 1e-17), "o", label=label
        )
    right.axhline(result["target_error"], color="k", ls="--", lw=0.8, label="target 2 %")
    right.set_xlabel("sampled cell (brightest, median, darkest, corner, edge, random)")
    right.set_ylabel("|map / panorama zenith - 1|")
    right.set_title("error against full panoramas at the cell", fontsize=9)
    right.legend(fontsize=7)
    return fig


if __name__ == "__main__":
    main()
