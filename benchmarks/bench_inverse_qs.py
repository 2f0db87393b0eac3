"""Inverse maps Q_i and S_i: raster time against raster size, S error against PCA bases.

Scene: square rasters of 10 m cells (500-4000 per side) with the observer (1.7 m) at the
centre and two emission bands (Lambertian + 10 % direct uplight [lm m-2]); lit cells are
clustered like a city (a city east-north-east of the observer, three towns and a scattered
rural tenth) and their number grows with the area: 1e5 lit cells at 4000 x 4000. Kernel:
Dobashi's panorama grid (64 elevations x 256 azimuths), 128 distance bins from 10 m to the
raster's half diagonal, one observer and one source level, with the uplight table; its PCA keeps
every basis up to the numerical rank of the images (``n_components`` = number of images), so
"all" bases is the exact kernel to float precision. The kernel is cached in the default kernel
cache (``$NIGHTLIGHTS_CACHE``).

1. Time of :func:`nightlights.inverse.inverse_q` (``pca-norm``, ``zenith``) and
   :func:`nightlights.inverse.inverse_s` (``pca``, all bases; ``brute``: each cell's kernel
   image summed over the region) for a horizon band toward the city, from an in-memory Raster
   with the kernel loaded: end to end (best of repeated calls) and the result's ``seconds``
   (the per-cell computation after the scene and kernel are ready). Target: S of 4000 x 4000
   with 1e5 lit cells in <= 5 s on the 2-core development machine, >= 100x the brute force.
2. Error of S by PCA (4-128 bases and all) against the brute force for four regions (a zenith
   cap, a horizon band toward the city, a small polygon toward a town, the whole sky) on the
   largest raster: mean and max relative error over the cells with S above 1 % of the largest
   S. Target: mean <= 2 % at 64 bases. Bases beyond what the kernel stores are not measured
   (more bases than its rank add nothing). Also the speed-up over the brute force per region:
   the brute force costs in proportion to the panorama rows the region touches, the PCA does
   not.

Run: ``python benchmarks/bench_inverse_qs.py [--quick] [--out DIR]`` (``--quick``: 250-1000
cells per side, a 32 x 128 kernel of 64 distance bins, bases 4, 16 and all).
Writes ``inverse_qs.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from functools import partial
from typing import Any

import _harness as harness
import numpy as np
import xarray as xr
from affine import Affine
from pyproj import CRS

from nightlights.inverse import InfluenceResult, SkyRegion, inverse_q, inverse_s
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene
from nightlights.sky.influence import (
    cell_values,
    cell_values_brute,
    region_table,
    region_weights,
)
from nightlights.sky.polar import polar_cells
from nightlights.sky.setup import prepare_scene
from nightlights.sky.store import get_or_build_kernel

CELL = 10.0  # [m]
UTM = CRS.from_epsg(32635)
OBSERVER_HEIGHT = 1.7  # [m]
#: Lit cells of the largest raster (4000 x 4000); smaller rasters keep the same density.
LIT_AT_4000 = 100_000
#: Clusters: (east, north) offset of the centre from the observer and standard deviation, as
#: fractions of the raster side, and the share of the lit cells; the rest is scattered.
CLUSTERS = (
    (0.20, 0.08, 0.05, 0.60),  # the city, azimuth 68 deg
    (-0.25, -0.20, 0.025, 0.15),  # town, azimuth 231 deg
    (0.15, -0.30, 0.02, 0.08),  # town, azimuth 153 deg
    (-0.20, 0.30, 0.02, 0.07),  # town, azimuth 326 deg
)
RURAL = 0.10
CITY_AZIMUTH = math.degrees(math.atan2(CLUSTERS[0][0], CLUSTERS[0][1]))  # [deg]
#: The regions of the error sweep; the horizon band is also the region of the timings.
REGIONS = {
    "zenith cap": "zenith:20",
    "horizon band toward the city": (f"horizon:{CITY_AZIMUTH - 30:.0f},{CITY_AZIMUTH + 30:.0f},15"),
    "small polygon toward a town": "222,4 240,6 237,20 220,16 222,4",
    "whole sky": "zenith:90",
}
TIMING_REGION = "horizon band toward the city"
BRUTE_LIMIT_S = 120.0  # skip the brute force where it would take longer [s]
TARGET_S = 5.0  # [s]
TARGET_SPEEDUP = 100.0
TARGET_ERROR = 0.02


def city(side: int, seed: int = 0, n_lit: int | None = None) -> Raster:
    """Clustered lit cells on a ``side`` x ``side`` raster of 10 m cells, two bands [lm m-2].

    The lit cells are drawn without replacement with probability proportional to a mixture of
    Gaussians (:data:`CLUSTERS`) and a uniform part (Gumbel top-k), so their number is exact
    (``n_lit``, default 1e5 over 4000 x 4000 cells, the same density on any side).
    """
    rng = np.random.default_rng(seed)
    if n_lit is None:
        n_lit = round(LIT_AT_4000 * (side / 4000) ** 2)
    centre = np.arange(side) + 0.5 - side / 2  # cell centre from the observer [cells]
    x, y = centre[None, :], -centre[:, None]  # east, north
    density = np.full((side, side), RURAL / side**2)
    for east, north, sigma, share in CLUSTERS:
        s = sigma * side
        blob = np.exp(-((x - east * side) ** 2 + (y - north * side) ** 2) / (2 * s * s))
        density += share * blob / (2 * np.pi * s * s)
    keys = np.log(density.ravel()) + rng.gumbel(size=density.size)
    lit = np.argpartition(keys, -n_lit)[-n_lit:]
    lambertian = rng.lognormal(np.log(3.0), 0.8, n_lit)  # [lm m-2]
    data = np.zeros((2, side, side))
    data[0].flat[lit] = lambertian
    data[1].flat[lit] = 0.1 * lambertian
    transform = Affine(CELL, 0, 0, 0, -CELL, side * CELL)
    return Raster(data, transform, UTM, ("lambertian", "uplight"), ("lm m-2", "lm m-2"))


def observer(side: int) -> tuple[float, float]:
    """The raster centre [m]."""
    return (side * CELL / 2, side * CELL / 2)


def kernel_spec(largest: int, quick: bool) -> KernelSpec:
    """Dobashi's grid (a smaller one with ``quick``) out to the largest raster's corners."""
    n_el, n_az, n_r = (32, 128, 64) if quick else (64, 256, 128)
    return KernelSpec(
        r_min=10.0,
        r_max=1.01 * largest * CELL / math.sqrt(2),
        n_distance=n_r,
        n_elevation=n_el,
        n_azimuth=n_az,
        observer_altitudes=(OBSERVER_HEIGHT,),
        source_altitudes=(0.0,),
        uplight=True,
        n_components=2 * n_r,  # every image: the PCA stops at the numerical rank
    )


def timed_calls(
    call: Callable[[], InfluenceResult], repeats: int
) -> tuple[InfluenceResult, float, float]:
    """Call ``repeats`` times: the last result, shortest end-to-end and ``seconds`` [s]."""
    results = [harness.timed(call) for _ in range(repeats)]
    return (
        results[-1][0],
        min(total for _, total in results),
        min(result.seconds for result, _ in results),
    )


def sub_points(raster: Raster, table: xr.Dataset, side: int) -> int:
    """Polar sub-points of the lit cells (what the per-cell lookups and the brute force walk)."""
    cells = polar_cells(
        raster.data,
        raster.transform,
        observer(side),
        distance_edges=table["distance_edges"].values,
        n_az=table.sizes["azimuth"],
    )
    return int(cells.cell.size)


def stage(
    name: str, raster: Raster, where: tuple[float, float], region: str, table: xr.Dataset
) -> InfluenceResult:
    """One timed call: ``q_pca_norm``, ``q_zenith``, ``s_pca`` or ``s_brute``."""
    if name.startswith("q_"):
        metric = "pca-norm" if name == "q_pca_norm" else "zenith"
        return inverse_q(
            Scene(raster, kernel=table), Observer(*where), metric=metric, progress=False
        )
    method = name.removeprefix("s_")
    return inverse_s(
        Scene(raster, kernel=table), Observer(*where), region=region, method=method, progress=False
    )


def core_times(
    raster: Raster, where: tuple[float, float], region: str, table: xr.Dataset, *, brute: bool
) -> tuple[float, float | None]:
    """S from the lit cells' polar sub-points, without what both methods share (reading the
    raster, finding the lit cells, splitting them into sub-points): PCA (the weights
    cross-correlated with the bases, then one lookup per sub-point) and, when asked, the brute
    force (each sub-point's kernel image summed over the region) [s]."""
    setup = prepare_scene(
        Scene(raster, kernel=table), Observer(*where, height=OBSERVER_HEIGHT), progress=False
    )
    cells = setup.polar_cells()
    levels = setup.level_weights(cells)
    first = setup.slices[0]
    mask = SkyRegion.parse(region).mask(
        first.elevation, (np.arange(first.n_az) + 0.5) * 360.0 / first.n_az
    )
    weights = region_weights(mask & ~setup.below_terrain(), first.elevation)

    def pca() -> np.ndarray:
        return cell_values(cells, levels, [region_table(t, weights) for t in setup.slices])

    pca_s = harness.repeat(pca, 3).best
    if not brute:
        return pca_s, None
    _, brute_s = harness.timed(lambda: cell_values_brute(cells, levels, setup.slices, weights))
    return pca_s, brute_s


def timing_rows(
    sides: list[int], table: xr.Dataset, repeats: int
) -> tuple[list[dict[str, Any]], dict[int, Raster]]:
    """Q and S time against raster size (section 1)."""
    region = REGIONS[TIMING_REGION]
    rows, rasters = [], {}
    brute_rate: float | None = None  # sub-points per second of the last brute-force run
    for side in sides:
        raster = rasters[side] = city(side)
        where = observer(side)
        lit = int(np.count_nonzero(raster.data[0]))
        subs = sub_points(raster, table, side)
        row: dict[str, Any] = {"side": side, "lit_cells": lit, "sub_points": subs}
        for name in ("q_pca_norm", "q_zenith", "s_pca"):
            _, total, compute = timed_calls(
                partial(stage, name, raster, where, region, table), repeats
            )
            row[f"{name}_s"], row[f"{name}_compute_s"] = total, compute
        estimate = None if brute_rate is None else subs / brute_rate
        if estimate is None or estimate < BRUTE_LIMIT_S:
            _, total, compute = timed_calls(
                partial(stage, "s_brute", raster, where, region, table), 1
            )
            brute_rate = subs / compute
            row["s_brute_s"], row["s_brute_compute_s"] = total, compute
            row["brute_cells_per_s"] = lit / compute
            row["speedup_compute"] = compute / row["s_pca_compute_s"]
            row["speedup_end_to_end"] = total / row["s_pca_s"]
            row["s_pca_core_s"], row["s_brute_core_s"] = core_times(
                raster, where, region, table, brute=True
            )
            row["speedup_core"] = row["s_brute_core_s"] / row["s_pca_core_s"]
        else:
            row["s_brute_estimate_s"] = estimate
        row["pca_cells_per_s"] = lit / row["s_pca_compute_s"]
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows, rasters


def relative_errors(approx: InfluenceResult, exact: InfluenceResult) -> tuple[float, float, int]:
    """Mean and max relative error over the cells whose exact S exceeds 1 % of its maximum."""
    a, e = approx.raster.data[0], exact.raster.data[0]
    lit = np.isfinite(e)
    bright = lit & (np.where(lit, e, 0.0) > 0.01 * np.nanmax(e))
    error = np.abs(a[bright] - e[bright]) / e[bright]
    return float(error.mean()), float(error.max()), int(bright.sum())


def error_rows(
    raster: Raster, side: int, table: xr.Dataset, bases: list[int], repeats: int
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """S error against the brute force by PCA bases, and the speed-up, per region (section 2)."""
    stored = table.sizes["component"]
    where = observer(side)
    lit = int(np.count_nonzero(raster.data[0]))
    regions, rows = [], []
    for label, text in REGIONS.items():

        def call(k: int | None = None, method: str = "pca", text: str = text) -> InfluenceResult:
            return inverse_s(
                Scene(raster, kernel=table),
                Observer(*where),
                region=text,
                method=method,
                components=k,
                progress=False,
            )

        exact, brute_total, brute_compute = timed_calls(lambda: call(method="brute"), 1)
        _, pca_total, pca_compute = timed_calls(call, repeats)
        regions.append(
            {
                "region": label,
                "text": text,
                "bright_cells": relative_errors(exact, exact)[2],
                "brute_s": brute_total,
                "brute_compute_s": brute_compute,
                "brute_cells_per_s": lit / brute_compute,
                "pca_s": pca_total,
                "pca_compute_s": pca_compute,
                "speedup_compute": brute_compute / pca_compute,
                "speedup_end_to_end": brute_total / pca_total,
            }
        )
        print(json.dumps(regions[-1]), flush=True)
        for k in [b for b in bases if b < stored] + [stored]:
            approx, _, compute = timed_calls(partial(call, k), 1)
            mean, worst, _ = relative_errors(approx, exact)
            row = {
                "region": label,
                "bases": k,
                "all": k == stored,
                "mean_rel_error": mean,
                "max_rel_error": worst,
                "total_rel_error": abs(approx.total - exact.total) / exact.total,
                "compute_s": compute,
            }
            rows.append(row)
            print(json.dumps(row), flush=True)
    return regions, rows


def main() -> None:
    parser = harness.argument_parser(
        __doc__, quick="250-1000 cells per side, a 32 x 128 kernel of 64 bins, 3 basis counts"
    )
    args = harness.parse_args(parser)
    sides = [250, 500, 1000] if args.quick else [500, 1000, 2000, 4000]
    bases = [4, 16] if args.quick else [4, 8, 16, 32, 64, 128]
    spec = kernel_spec(max(sides), args.quick)
    kernel, build_s = harness.timed(lambda: get_or_build_kernel(spec, progress=False))
    table = kernel.kernel.load()
    stored = int(table.sizes["component"])
    print(f"kernel {kernel.path} ({build_s:.1f} s, {stored} bases)", flush=True)
    repeats = 2 if args.quick else 3
    rows, rasters = timing_rows(sides, table, repeats)
    largest = max(sides)
    regions, errors = error_rows(rasters[largest], largest, table, bases, repeats)

    at_largest = rows[-1]
    reference = [r for r in errors if r["all"] or r["bases"] == 64]
    at_64 = [r for r in reference if r["bases"] == 64] or [r for r in reference if r["all"]]
    speedup = at_largest.get("speedup_compute")
    worst_mean = max(r["mean_rel_error"] for r in at_64)
    summary: dict[str, Any] = {
        "side": largest,
        "lit_cells": at_largest["lit_cells"],
        "s_pca_s": at_largest["s_pca_s"],
        "s_pca_compute_s": at_largest["s_pca_compute_s"],
        "s_brute_compute_s": at_largest.get("s_brute_compute_s"),
        "speedup_compute": speedup,
        "speedup_end_to_end": at_largest.get("speedup_end_to_end"),
        "s_pca_core_s": at_largest.get("s_pca_core_s"),
        "s_brute_core_s": at_largest.get("s_brute_core_s"),
        "speedup_core": at_largest.get("speedup_core"),
        "speedup_compute_by_region": {r["region"]: r["speedup_compute"] for r in regions},
        "bases_for_error_target": at_64[0]["bases"],
        "worst_mean_rel_error_at_target_bases": worst_mean,
        "worst_max_rel_error_at_target_bases": max(r["max_rel_error"] for r in at_64),
        "s_time_target_met": bool(at_largest["s_pca_s"] <= TARGET_S),
        "speedup_target_met": None if speedup is None else bool(speedup >= TARGET_SPEEDUP),
        "speedup_core_target_met": (
            None
            if at_largest.get("speedup_core") is None
            else bool(at_largest["speedup_core"] >= TARGET_SPEEDUP)
        ),
        "error_target_met": bool(worst_mean <= TARGET_ERROR),
    }
    result: dict[str, Any] = {
        "kernel": (
            f"{spec.n_elevation} el x {spec.n_azimuth} az, {spec.n_distance} distance bins "
            f"10 m-{spec.r_max / 1000:.1f} km, h_o {OBSERVER_HEIGHT} m, h_c 0 m, uplight, "
            "turbidity 2"
        ),
        "stored_bases": stored,
        "kernel_seconds": build_s,
        "kernel_note": "time to build the kernel, or to open it when it was cached",
        "scene": (
            f"{CELL:g} m cells, observer at the centre ({OBSERVER_HEIGHT} m), two bands "
            "(Lambertian + 10 % uplight), lit cells clustered: a city at azimuth "
            f"{CITY_AZIMUTH:.0f} deg, three towns, {RURAL:.0%} scattered; "
            f"{LIT_AT_4000:,} lit at 4000 x 4000, same density elsewhere"
        ),
        "timing_region": f"{TIMING_REGION} ({REGIONS[TIMING_REGION]})",
        "rows": rows,
        "error_side": largest,
        "regions": regions,
        "errors": errors,
        "unavailable_bases": [b for b in bases if b >= stored],
        "summary": summary,
        "targets": {
            "s_4000_seconds": TARGET_S,
            "speedup_over_brute": TARGET_SPEEDUP,
            "mean_rel_error_at_64_bases": TARGET_ERROR,
        },
        "note": (
            "2 shared cores (noisy timings); end-to-end = the whole call from an in-memory "
            "Raster with the kernel loaded, best of repeats; compute = the result's seconds"
        ),
    }
    harness.write_results(args.out, "inverse_qs", result, quick=args.quick, plot=plot)
    print(json.dumps(summary, indent=2))


def plot(result: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    rows, errors = result["rows"], result["errors"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
    lit = np.array([r["lit_cells"] for r in rows])
    for index, (key, label) in enumerate(
        (
            ("q_pca_norm", "Q pca-norm"),
            ("q_zenith", "Q zenith"),
            ("s_pca", "S pca (all bases)"),
            ("s_brute", "S brute force"),
        )
    ):
        sel = [r for r in rows if f"{key}_s" in r]
        n = [r["lit_cells"] for r in sel]
        color = f"C{index}"
        ax1.loglog(n, [r[f"{key}_s"] for r in sel], "o-", color=color, label=f"{label}, call")
        ax1.loglog(n, [r[f"{key}_compute_s"] for r in sel], "s--", color=color, mfc="none")
    target = result["targets"]["s_4000_seconds"]
    ax1.axhline(target, color="grey", lw=0.8, ls=":", label=f"target for S: {target:g} s")
    ax1.plot([], [], "ks--", mfc="none", label="dashed: per-cell part (seconds)")
    ax1.set_xticks(lit, [f"{r['lit_cells']:,}\n{r['side']}²" for r in rows])
    ax1.minorticks_off()
    ax1.set_xlabel("lit cells / raster cells (10 m)")
    ax1.set_ylabel("time [s]")
    ax1.set_title("Q and S rasters: time")
    ax1.legend(fontsize=7)
    for index, region in enumerate(dict.fromkeys(r["region"] for r in errors)):
        sel = [r for r in errors if r["region"] == region]
        k = [r["bases"] for r in sel]
        color = f"C{index}"
        ax2.semilogy(k, [r["mean_rel_error"] for r in sel], "o-", color=color, label=region)
        ax2.semilogy(k, [r["max_rel_error"] for r in sel], "s--", color=color, mfc="none")
    target = result["targets"]["mean_rel_error_at_64_bases"]
    ax2.axhline(target, color="grey", lw=0.8, ls=":", label=f"target: {target:.0%} mean")
    ax2.plot([], [], "ks--", mfc="none", label="dashed: max over cells")
    ax2.set_xscale("log", base=2)
    ticks = sorted({r["bases"] for r in errors})
    stored = result["stored_bases"]  # "all", on a second line: it may sit next to 32
    ax2.set_xticks(ticks, [f"\nall = {k}" if k == stored else str(k) for k in ticks])
    ax2.minorticks_off()
    ax2.set_xlabel(f"PCA bases (the kernel stores {result['stored_bases']})")
    ax2.set_ylabel("relative error of S (cells > 1 % of max)")
    ax2.set_title(f"S by PCA against brute force, {result['error_side']}² raster")
    ax2.legend(fontsize=7)
    return fig


if __name__ == "__main__":
    main()
