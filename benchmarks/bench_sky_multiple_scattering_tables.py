"""Multiple-scattering factor tables: measure the shipped ones, and chart their error and cost.

The kernel's default multiplies single scattering by the Monte Carlo factor
f(elevation, azimuth, distance) of :mod:`nightlights.sky.multiple`. This script

1. measures the factor tables shipped with the package (turbidity 2 and Garstang's K = 1 at
   550 nm; Lambertian, uplight sin^4 and Garstang's psi^4 lobe) with
   :data:`~nightlights.sky.multiple.SHIPPED_PHOTONS` photons each and writes them to
   ``nightlights/sky/data/multiple_scattering.json`` (skipped with ``--no-tables``);
2. checks the default against an independent reference: the all-orders Monte Carlo of
   ``bench_sky_multiple_scattering.py`` (300,000 Lambertian and 150,000 lobe photons, other
   seeds, 15 distances 1-300 km, zenith and 45 deg towards and away from the source): the
   relative error of single x interpolated factor, against single scattering's; and (T = 2)
   the same against the reference's own histories re-estimated with azimuthal splitting
   (``error_table_split``), whose far values have a much lighter tail;
3. charts the error of a table measured at kernel-build time against its photons and cost
   (T = 2, Lambertian), the shipped table as the reference.

The tables are measured with azimuthal splitting (:data:`~nightlights.sky.multiple.SPLIT_WINDOW`;
runs before it are marked ``plain`` in the summary); the reference uses the plain estimator.

Run: ``python benchmarks/bench_sky_multiple_scattering_tables.py [--quick] [--no-tables]
[--add ATMOSPHERE [--fresh]] [--shapes SHAPE ...] [--photons N] [--out DIR]`` (``--quick``:
20,000-photon tables into the results folder only, fewer photon counts in the chart;
``--add``: merge a run of the next seed into that atmosphere's shipped tables, or with
``--fresh`` replace them by it). Writes ``sky_multiple_scattering_tables.json`` and ``.png``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import _harness as harness
import numpy as np

from nightlights.sky import multiple
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere
from nightlights.sky.kernel import UPLIGHT_EXPONENT

PACKAGE_TABLES = (
    Path(__file__).resolve().parents[1]
    / "nightlights"
    / "sky"
    / "data"
    / "multiple_scattering.json"
)
ATMOSPHERES = {"T = 2": Atmosphere(turbidity=2.0), "K = 1": garstang_atmosphere(1.0)}
SHAPES = ("lambertian", "uplight", "garstang_lobe")
CHART_PHOTONS = (1_250, 2_500, 5_000, 10_000, 20_000)


def merge(
    entry: dict[str, Any] | None, factor: np.ndarray, error: np.ndarray, photons: int
) -> tuple:
    """Photon-weighted mean of independent runs (single scattering is exact, so the ratios
    average like the totals) and its standard error."""
    if entry is None:
        return factor, error, photons
    n0 = int(entry["photons"])
    f0 = np.asarray(entry["factor"], dtype=float)
    e0 = np.asarray(entry["standard_error"], dtype=float)
    n = n0 + photons
    return (n0 * f0 + photons * factor) / n, np.hypot(n0 * e0, photons * error) / n, n


def measure_tables(
    photons: int,
    previous: dict[str, Any],
    only: str | None,
    shapes: tuple[str, ...] = SHAPES,
    fresh: bool = False,
) -> tuple[dict[str, Any], list[dict[str, object]]]:
    """Measure every (atmosphere, shape) table, or add a run of another seed to ``only``'s
    (``fresh``: replace ``only``'s tables of ``shapes`` by one new run instead)."""
    tables: dict[str, Any] = dict(previous)
    runs: list[dict[str, object]] = []
    for label, atmosphere in ATMOSPHERES.items():
        if only is not None and label != only:
            continue
        for shape in shapes:
            key = f"{shape}|{UPLIGHT_EXPONENT:g}|{multiple._atmosphere_key(atmosphere)}"
            old = tables.get(key) if only is not None else None
            entry = None if fresh else old
            # a new run takes the seed after the highest of the table's runs (replaced or kept)
            seed = max(int(r["seed"]) for r in old["runs"]) + 1 if old else multiple.SEED
            (factor, error), seconds = harness.timed(
                lambda a=atmosphere, s=shape, seed=seed: multiple._measure(
                    a, s, photons, UPLIGHT_EXPONENT, seed
                )
            )
            combined, combined_error, total = merge(entry, factor, error, photons)
            history = list(entry["runs"]) if entry else []
            history.append(
                {
                    "photons": photons,
                    "seed": seed,
                    "seconds": round(seconds, 1),
                    "split_window": multiple.SPLIT_WINDOW,
                    "split_points": multiple.SPLIT_POINTS,
                }
            )
            tables[key] = {
                "atmosphere": label,
                "emission": shape,
                "photons": total,
                "runs": history,
                "factor": np.round(combined, 6).tolist(),
                "standard_error": np.round(combined_error, 6).tolist(),
            }
            rel = combined_error / combined
            runs.append(
                {
                    "atmosphere": label,
                    "emission": shape,
                    "photons": total,
                    "seconds": round(sum(float(r["seconds"]) for r in history), 1),
                    "median_relative_error": float(np.median(rel)),
                    "max_relative_error_to_150km": float(
                        np.max(rel[..., np.asarray(multiple.FACTOR_DISTANCES) <= 150e3])
                    ),
                }
            )
            print(runs[-1], flush=True)
    return tables, runs


def _shipped_table(
    tables: dict[str, object], label: str, shape: str
) -> multiple.MultipleScatteringTable:
    key = f"{shape}|{UPLIGHT_EXPONENT:g}|{multiple._atmosphere_key(ATMOSPHERES[label])}"
    entry = tables[key]
    assert isinstance(entry, dict)
    raw = np.asarray(entry["factor"], dtype=float)
    err = np.asarray(entry["standard_error"], dtype=float)
    return multiple.MultipleScatteringTable(shape, raw, err, int(entry["photons"]), "shipped")


def garstang_factor(quoted: list[list[float]], distance_km: np.ndarray) -> np.ndarray:
    """Garstang's (1986) double-scattering factor for K = 1 as quoted (1.6, 1.95, 2.5 at 10,
    50, 150 km), linear in ln r between, held outside; one value for every direction."""
    km, factor = np.asarray(quoted, dtype=float).T
    return np.interp(np.log(distance_km), np.log(km), factor)


def against_reference(tables: dict[str, object], split: bool = False) -> list[dict[str, object]]:
    """Three models against the all-orders reference of bench_sky_multiple_scattering.py:
    single scattering, single x Garstang's quoted factor, and the default (single x the
    shipped table; for Garstang's mix, each shape's single scattering times its own table).
    ``split``: against the reference's own photon histories re-estimated with azimuthal
    splitting (its ``split`` entries, where present) instead of its plain estimates."""
    reference = harness.previous_results("sky_multiple_scattering", harness.RESULTS)
    if reference is None:
        return []
    el = np.asarray(reference["ray_elevation_deg"], dtype=float)
    az = np.asarray(reference["ray_azimuth_deg"], dtype=float)
    km = np.asarray(reference["ray_distance_km"], dtype=float)
    quoted = reference["garstang_double_scattering_quoted"]
    rows: list[dict[str, object]] = []
    for label, cases in reference["cases"].items():
        singles = {s: np.asarray(cases[s]["single"], dtype=float) for s in SHAPES if s in cases}
        if split:
            if not all("split" in cases[s] for s in singles):
                continue
            estimates = {s: cases[s]["split"] for s in singles}
        else:
            estimates = {s: cases[s] for s in singles}
        totals = {s: np.asarray(estimates[s]["total"], dtype=float) for s in singles}
        errors = {s: np.asarray(estimates[s]["total_se"], dtype=float) for s in singles}
        defaults = {
            s: singles[s] * _shipped_table(tables, label, s)(el, az, km * 1e3) for s in singles
        }
        mixes = {s: {s: 1.0} for s in singles}
        if "garstang_mix" in cases:
            mixes["garstang_mix"] = {
                k: float(v) for k, v in cases["garstang_mix"]["weights"].items()
            }
        for name, weights in mixes.items():
            single = sum(w * singles[s] for s, w in weights.items())
            total = sum(w * totals[s] for s, w in weights.items())
            se = np.sqrt(sum((w * errors[s]) ** 2 for s, w in weights.items()))
            default = sum(w * defaults[s] for s, w in weights.items())
            garstang = single * garstang_factor(quoted, km)
            for d in np.unique(km):
                sel = km == d
                rows.append(
                    {
                        "atmosphere": label,
                        "emission": name,
                        "distance_km": float(d),
                        "default_error_max": float(np.max(np.abs(default[sel] / total[sel] - 1))),
                        "garstang_factor_error_max": float(
                            np.max(np.abs(garstang[sel] / total[sel] - 1))
                        ),
                        "single_error_max": float(np.max(np.abs(single[sel] / total[sel] - 1))),
                        "reference_relative_se_max": float(np.max(se[sel] / total[sel])),
                    }
                )
    return rows


def photon_chart(tables: dict[str, object], photon_counts: tuple[int, ...]) -> list[dict]:
    """Build-time tables (T = 2, Lambertian) at fewer photons against the shipped one."""
    atmosphere = ATMOSPHERES["T = 2"]
    key = f"lambertian|{UPLIGHT_EXPONENT:g}|{multiple._atmosphere_key(atmosphere)}"
    entry = tables[key]
    assert isinstance(entry, dict)
    ref = np.asarray(entry["factor"], dtype=float)
    near = np.asarray(multiple.FACTOR_DISTANCES) <= 150e3
    rows = []
    for n in photon_counts:
        (raw, _), seconds = harness.timed(  # seeds apart from the shipped runs'
            lambda n=n: multiple._measure(
                atmosphere, "lambertian", n, UPLIGHT_EXPONENT, multiple.SEED + 1000
            )
        )
        rel = np.abs(raw / ref - 1.0)[..., near]
        rows.append(
            {
                "photons": n,
                "seconds": seconds,
                "median_error": float(np.median(rel)),
                "p90_error": float(np.quantile(rel, 0.9)),
            }
        )
        print(rows[-1], flush=True)
    return rows


def plot(result: dict) -> object:
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    rows = result["against_reference"]
    styles = {
        "default_error_max": ("-", "o", "single x table (default)"),
        "garstang_factor_error_max": ("--", "s", "single x Garstang's factor"),
        "single_error_max": (":", "", "single scattering"),
    }
    colours = {"lambertian": "C0", "garstang_lobe": "C1", "garstang_mix": "C2"}
    for ax, label in zip(axes[:2], ("T = 2", "K = 1"), strict=True):
        for emission, colour in colours.items():
            sel = [r for r in rows if r["atmosphere"] == label and r["emission"] == emission]
            if not sel:
                continue
            d = [r["distance_km"] for r in sel]
            for key, (ls, marker, name) in styles.items():
                ax.plot(
                    d,
                    [max(r[key], 1e-4) for r in sel],
                    ls=ls,
                    marker=marker,
                    ms=3,
                    color=colour,
                    label=f"{name}, {emission}",
                )
        ax.axhline(0.10, color="k", lw=0.8, ls="-.")
        ax.set(
            xscale="log",
            yscale="log",
            xlabel="distance [km]",
            ylabel="worst relative error, zenith and 45 deg both ways",
            title=f"{label}: models vs all-orders Monte Carlo",
        )
    axes[0].legend(fontsize=6)
    chart = result["photon_chart"]
    ax = axes[2]
    ax.plot([r["seconds"] for r in chart], [r["median_error"] for r in chart], "o-", label="median")
    ax.plot([r["seconds"] for r in chart], [r["p90_error"] for r in chart], "s--", label="90th pct")
    for r in chart:
        ax.annotate(f"{r['photons']:,}", (r["seconds"], r["median_error"]), fontsize=7)
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="time to measure one table [s] (shared 2 cores)",
        ylabel="relative error vs shipped table, 0.1-150 km",
        title="build-time table: error against cost (T = 2, Lambertian)",
    )
    ax.legend()
    fig.tight_layout()
    return fig


def error_table(rows: list[dict[str, Any]]) -> list[dict[str, object]]:
    """Worst relative error of each model over distance ranges, per atmosphere and emission."""
    ranges = ((1, 10), (15, 50), (70, 150), (200, 300))
    models = (
        ("default_error_max", "single x table (default)"),
        ("garstang_factor_error_max", "single x Garstang's factor"),
        ("single_error_max", "single scattering"),
    )
    out: list[dict[str, object]] = []
    for atmosphere, emission in dict.fromkeys((r["atmosphere"], r["emission"]) for r in rows):
        sel = [r for r in rows if r["atmosphere"] == atmosphere and r["emission"] == emission]
        for key, name in models:
            row: dict[str, object] = {"atmosphere": atmosphere, "emission": emission, "model": name}
            for lo, hi in ranges:
                inside = [r[key] for r in sel if lo <= r["distance_km"] <= hi]
                row[f"{lo}_{hi}_km"] = f"{100 * max(inside):.0f} %"
            out.append(row)
    return out


def summary(tables: dict[str, Any]) -> list[dict[str, object]]:
    """Photons, time and standard errors of every shipped table."""
    near = np.asarray(multiple.FACTOR_DISTANCES) <= 150e3
    rows: list[dict[str, object]] = []
    for entry in tables.values():
        rel = np.asarray(entry["standard_error"]) / np.asarray(entry["factor"])
        split = ["split_window" in r for r in entry["runs"]]
        rows.append(
            {
                "atmosphere": entry["atmosphere"],
                "emission": entry["emission"],
                "photons": entry["photons"],
                "estimator": "split" if all(split) else ("plain" if not any(split) else "mixed"),
                "seconds": round(sum(float(r["seconds"]) for r in entry["runs"]), 1),
                "median_relative_error": float(np.median(rel)),
                "max_relative_error_to_150km": float(np.max(rel[..., near])),
            }
        )
    return rows


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="20,000-photon tables, not shipped")
    parser.add_argument("--no-tables", action="store_true", help="reuse the shipped tables")
    parser.add_argument(
        "--add",
        metavar="ATMOSPHERE",
        choices=list(ATMOSPHERES),
        help="add a run of another seed to this atmosphere's shipped tables",
    )
    parser.add_argument("--photons", type=int, default=multiple.SHIPPED_PHOTONS)
    parser.add_argument(
        "--shapes", nargs="+", choices=SHAPES, default=list(SHAPES), help="shapes to measure"
    )
    parser.add_argument(
        "--fresh", action="store_true", help="with --add: replace the tables instead of merging"
    )
    args = harness.parse_args(parser)
    shipped = json.loads(PACKAGE_TABLES.read_text()) if PACKAGE_TABLES.is_file() else {}
    if args.no_tables:
        tables = shipped
    else:
        photons = 20_000 if args.quick else args.photons
        tables, _ = measure_tables(
            photons, shipped if args.add else {}, args.add, tuple(args.shapes), args.fresh
        )
        if not args.quick:
            PACKAGE_TABLES.parent.mkdir(parents=True, exist_ok=True)
            PACKAGE_TABLES.write_text(json.dumps(tables) + "\n")
            print(f"wrote {PACKAGE_TABLES}", flush=True)
    payload = {
        "grid": {
            "elevation_deg": list(multiple.FACTOR_ELEVATIONS),
            "azimuth_deg": list(multiple.FACTOR_AZIMUTHS),
            "distance_m": list(multiple.FACTOR_DISTANCES),
        },
        "runs": summary(tables),
        "against_reference": against_reference(tables),
    }
    payload["error_table"] = error_table(payload["against_reference"])
    payload["against_split_reference"] = against_reference(tables, split=True)
    payload["error_table_split"] = error_table(payload["against_split_reference"])
    previous = harness.previous_results("sky_multiple_scattering_tables", args.out)
    if args.no_tables and previous is not None:
        payload["photon_chart"] = previous["photon_chart"]
    else:
        counts = CHART_PHOTONS[:3] if args.quick else CHART_PHOTONS
        payload["photon_chart"] = photon_chart(tables, counts)
    harness.write_results(
        args.out, "sky_multiple_scattering_tables", payload, quick=args.quick, plot=plot
    )


if __name__ == "__main__":
    main()
