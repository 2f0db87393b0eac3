"""Benchmark: auditing a city's street lighting (``nl.audit``): time against size, and the reach.

- **Size**: a synthetic grid city of square blocks 100 m on a side, every street line cut into
  one segment per block, with the street mix of a real town (every fifth line an arterial of
  4 lanes with poles on both sides, class M3; every other line a collector, M4; the rest local
  streets, P3), lights placed by ``streets place`` at the layer's spacing. The audit of 10^3,
  3 x 10^3 and 10^4 segments is timed end to end (reading nothing, writing the styled
  GeoPackage), and split into building the model (layout and influence matrices) and rating.
  Target: 10^4 segments in under 60 s on this machine.
- **Reach** (:data:`nightlights.roads._influence.ILLUMINANCE_REACH_HEIGHTS`): the horizontal
  distance, in mounting heights, within which a luminaire counts at a road point for
  horizontal illuminance (luminance stops at 12, where the r-tables end). Each setting's
  figures on a 420-segment district against a reach of 48 heights for both: the worst
  relative error of any figure a segment's class sets, and the time of model and rating.

Run: ``python benchmarks/bench_road_audit.py [--quick] [--out DIR]`` (``--quick``: 10^3
segments at most). Writes ``road_audit.json`` and ``.png``.
"""

from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import _harness as harness
import geopandas as gpd
import numpy as np
from shapely import LineString

#: Block side [m].
BLOCK = 100.0
#: City sizes swept: street lines per direction (segments = 2 n (n - 1)).
SIZES = (23, 39, 71)
#: Reach settings swept [mounting heights], and the reference.
REACHES = (5.0, 8.0, 12.0, 16.0, 24.0, 32.0)
REFERENCE_REACH = 48.0
#: Street lines per direction of the reach district.
REACH_CITY = 15

_KINDS = {
    # street_class: (width, lanes, arrangement, spacing, height, system, class)
    "arterial": (14.0, 4, "opposite", 40.0, 10.0, "road_led_large", "M3"),
    "collector": (8.0, 2, "single_sided", 32.0, 8.0, "street_led_medium", "M4"),
    "local": (6.0, 2, "single_sided", 28.0, 6.0, "street_led_small", "P3"),
}


def grid_city(n: int) -> gpd.GeoDataFrame:
    """Streets of an n x n line grid, one segment per block side."""
    rows: list[dict[str, Any]] = []
    geometry = []
    for direction in (0, 1):
        for line in range(n):
            kind = "arterial" if line % 5 == 0 else "collector" if line % 2 else "local"
            width, lanes, arrangement, spacing, height, system, _ = _KINDS[kind]
            for block in range(n - 1):
                a, b = block * BLOCK, (block + 1) * BLOCK
                c = line * BLOCK
                points = [(a, c), (b, c)] if direction == 0 else [(c, a), (c, b)]
                geometry.append(LineString(points))
                rows.append(
                    {
                        "source_id": f"{direction}-{line}-{block}",
                        "street_class": kind,
                        "width": width,
                        "lanes": lanes,
                        "lit": True,
                        "arrangement": arrangement,
                        "spacing": spacing,
                        "mounting_height": height,
                        "system_id": system,
                        "lighting_class": _KINDS[kind][6],
                    }
                )
    return gpd.GeoDataFrame(rows, geometry=geometry, crs="EPSG:3067")


def _lights(streets: gpd.GeoDataFrame) -> gpd.GeoDataFrame:
    from nightlights.streets import place

    return place(streets, seed=1, along_jitter=0.0, across_jitter=0.0).lights


def size_sweep(sizes: tuple[int, ...], folder: Path) -> list[dict[str, Any]]:
    from nightlights import roads

    rows = []
    for n in sizes:
        streets = grid_city(n)
        lights = _lights(streets)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            start = time.perf_counter()
            model = roads.road_model(lights, streets)
            built = time.perf_counter() - start
            start = time.perf_counter()
            rating = model.rate()
            rated = time.perf_counter() - start
            start = time.perf_counter()
            result = roads.audit(lights, streets, folder / f"audit_{n}.gpkg")
            total = time.perf_counter() - start
        row = {
            "segments": len(streets),
            "lights": len(lights),
            "sections": model.fields.n_sections,
            "luminance_samples": int(model.influence.luminance.shape[0]),
            "matrix_entries": int(
                model.influence.luminance.nnz
                + model.influence.illuminance.nnz
                + model.influence.strips.nnz
                + model.influence.veiling.nnz
            ),
            "model_seconds": built,
            "rate_seconds": rated,
            "audit_seconds": total,
            "share_compliant": result.summary.share,
            "passed": int((rating["passed"] == True).sum()),  # noqa: E712
        }
        rows.append(row)
        print(
            f"{row['segments']:6d} segments, {row['lights']:6d} lights: model "
            f"{built:.1f} s, rate {rated:.2f} s, audit {total:.1f} s",
            flush=True,
        )
    return rows


def reach_sweep() -> dict[str, Any]:
    from nightlights import roads
    from nightlights.roads import _influence
    from nightlights.roads._rating import FIGURES

    default = _influence.ILLUMINANCE_REACH_HEIGHTS
    streets = grid_city(REACH_CITY)
    lights = _lights(streets)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reference = roads.road_model(lights, streets, reach_heights=REFERENCE_REACH).rate()
        rows = []
        for reach in REACHES:
            start = time.perf_counter()
            _influence.ILLUMINANCE_REACH_HEIGHTS = reach
            rating = roads.road_model(lights, streets).rate()
            seconds = time.perf_counter() - start
            errors = {}
            for name in FIGURES:
                ref = reference[name].to_numpy(float)
                got = rating[name].to_numpy(float)
                rated = np.isfinite(reference[f"{name}_required"].to_numpy(float))
                ok = rated & np.isfinite(ref) & np.isfinite(got) & (ref != 0)
                errors[name] = (
                    float(np.max(np.abs(got[ok] / ref[ok] - 1))) * 100 if ok.any() else 0.0
                )
            worst = max(errors, key=lambda k: errors[k])
            flips = int(np.sum(rating["passed"].to_numpy() != reference["passed"].to_numpy()))
            rows.append(
                {
                    "reach_heights": reach,
                    "seconds": seconds,
                    "worst_error_percent": errors[worst],
                    "worst_figure": worst,
                    "errors_percent": errors,
                    "verdicts_changed": flips,
                }
            )
            print(f"reach {reach:4.0f} h: {seconds:.2f} s, worst {errors[worst]:.3f} % ({worst})")
    _influence.ILLUMINANCE_REACH_HEIGHTS = default
    return {"segments": len(streets), "lights": len(lights), "rows": rows}


def plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    sizes = document["sizes"]
    segments = [r["segments"] for r in sizes]
    left.plot(segments, [r["audit_seconds"] for r in sizes], "o-", label="audit (GeoPackage)")
    left.plot(segments, [r["model_seconds"] for r in sizes], "s--", label="model (matrices)")
    left.plot(segments, [r["rate_seconds"] for r in sizes], "^:", label="rating")
    left.axhline(60.0, color="grey", lw=0.8)
    left.text(segments[0], 62.0, "target 60 s", fontsize=8, color="grey")
    left.set_xscale("log")
    left.set_yscale("log")
    left.set_xlabel("segments")
    left.set_ylabel("time [s]")
    left.set_title("audit of a grid city")
    left.legend(fontsize=8)
    reach = document["reach"]["rows"]
    right.plot(
        [r["seconds"] for r in reach], [max(r["worst_error_percent"], 1e-4) for r in reach], "o-"
    )
    for r in reach:
        right.annotate(
            f"{r['reach_heights']:.0f} h",
            (r["seconds"], max(r["worst_error_percent"], 1e-4)),
            fontsize=8,
            xytext=(4, 4),
            textcoords="offset points",
        )
    default = [r for r in reach if r["reach_heights"] == document["default_reach"]]
    if default:
        right.plot(default[0]["seconds"], max(default[0]["worst_error_percent"], 1e-4), "r*", ms=14)
    right.set_yscale("log")
    right.set_xlabel("model + rating time [s]")
    right.set_ylabel("worst figure error [%]")
    right.set_title(f"illuminance reach, {document['reach']['segments']} segments (star: default)")
    figure.tight_layout()
    return figure


def main() -> None:
    from nightlights.roads._influence import ILLUMINANCE_REACH_HEIGHTS

    parser = harness.argument_parser(__doc__, quick="10^3 segments at most")
    args = harness.parse_args(parser)
    sizes = SIZES[:1] if args.quick else SIZES
    with tempfile.TemporaryDirectory() as folder:
        size_rows = size_sweep(sizes, Path(folder))
    reach = reach_sweep()
    payload = {
        "reference": f"figures at a reach of {REFERENCE_REACH:.0f} mounting heights",
        "default_reach": ILLUMINANCE_REACH_HEIGHTS,
        "target": "10^4 segments in under 60 s",
        "sizes": size_rows,
        "reach": reach,
    }
    harness.write_results(args.out, "road_audit", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
