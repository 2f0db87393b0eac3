"""Benchmark: r-table interpolation against the exact r of the analytic stand-in table.

Knob: ``interpolation`` of :func:`nightlights.roads.reduced_luminance_coefficient` and
:func:`nightlights.roads.road_luminance`: ``"bilinear"`` in (beta, tan gamma),
``"bilinear_gamma"`` in (beta, gamma) and ``"cubic"`` (bicubic interpolating spline), each on
the CIE table grid (20 beta x 29 tan gamma nodes) of :func:`nightlights.roads.synthetic_rtable`.
That table samples an analytic function, so the function itself is the converged reference:

- error in r: at the (beta, tan gamma) pairs the three installations of :mod:`_roads` use
  (every luminaire towards every point of the standard's luminance field, for every observer),
  weighted by each pair's share of the luminance, I / h^2: the weighted mean of
  |r_interp - r| over the weighted mean of r [%]; and the largest error over a uniform sample
  of the table's whole domain, relative to the largest r [%];
- error in L_av and U_o (lowest over observers) of each installation's standard field against
  the same computation with the exact r. The exact luminance uses ``road_luminance`` with a
  dense table of the analytic function (beta every 0.25 deg, tan gamma every 0.005), whose own
  error in r at the used pairs is recorded (``reference_r_error_percent``; interpolated
  bilinearly);
- time: per 10^6 lookups of r (best of 3) and of the luminance of every installation's field
  (all observers, best of 5).

Run: ``python benchmarks/bench_rtable_interpolation.py [--quick] [--out DIR]`` (``--quick``:
2 x 10^5 lookups). Writes ``rtable_interpolation.json`` and ``.png``.
"""

from __future__ import annotations

from typing import Any

import _harness as harness
import _roads
import numpy as np

from nightlights import roads
from nightlights.roads._geometry import intensities

#: Interpolations compared.
METHODS = ("bilinear", "bilinear_gamma", "cubic")
#: Parameters of the analytic table (synthetic_rtable's defaults) [sr-1], [1].
Q0, FORWARD = 0.07, 1.0
#: Steps of the dense reference table: beta [deg], tan gamma [1].
DENSE_BETA_STEP, DENSE_TAN_STEP = 0.25, 0.005


def exact_r(beta: np.ndarray, tan_gamma: np.ndarray) -> np.ndarray:
    """The analytic r of :func:`nightlights.roads.synthetic_rtable` [10^-4 sr-1]."""
    lobe = 1.0 + FORWARD * tan_gamma * (1.0 + np.cos(np.radians(beta))) / 2.0
    return Q0 * 1e4 * lobe / (1.0 + tan_gamma**2) ** 1.5


def dense_table() -> roads.RTable:
    """The analytic r on a fine grid over the CIE layout's range (0-180 deg, tan gamma 0-12)."""
    beta = np.arange(0.0, 180.0 + DENSE_BETA_STEP / 2, DENSE_BETA_STEP)
    tan_gamma = np.arange(0.0, 12.0 + DENSE_TAN_STEP / 2, DENSE_TAN_STEP)
    bb, tt = np.meshgrid(beta, tan_gamma)
    return roads.RTable(beta, tan_gamma, exact_r(bb, tt), name="dense analytic")


def used_pairs(inst: _roads.Installation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(beta [deg], tan gamma, weight I / h^2 [cd m-2]) of every luminaire-point-observer."""
    field = roads.calculation_field(inst.spacing, _roads.LANE_WIDTH, _roads.LANES)
    flat = roads.field_points(field).reshape(-1, 3)
    candela = intensities(
        flat, inst.lights, inst.rotation, inst.intensity, street_azimuth=inst.street_azimuth
    )
    height = inst.lights[:, None, 2]
    to_light = inst.lights[:, None, :2] - flat[None, :, :2]
    horizontal = np.hypot(to_light[..., 0], to_light[..., 1])
    betas, tans, weights = [], [], []
    for eye in field.observers:
        view = flat[:, :2] - eye[None, :2]
        cos_beta = np.einsum("nmi,mi->nm", to_light, view) / np.maximum(
            horizontal * np.hypot(view[:, 0], view[:, 1])[None, :], 1e-300
        )
        betas.append(np.degrees(np.arccos(np.clip(cos_beta, -1, 1))).ravel())
        tans.append((horizontal / height).ravel())
        weights.append((candela / height**2).ravel())
    beta, tan, weight = (np.concatenate(a) for a in (betas, tans, weights))
    keep = (tan <= 12.0) & (weight > 0)
    return beta[keep], tan[keep], weight[keep]


def field_luminance(inst: _roads.Installation, table: roads.RTable, method: str) -> np.ndarray:
    """Luminance of the standard field for every observer (observers, n_x, n_y)."""
    field = roads.calculation_field(inst.spacing, _roads.LANE_WIDTH, _roads.LANES)
    points = roads.field_points(field)
    return np.stack([_roads.luminance(inst, points, eye, table, method) for eye in field.observers])


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="2 x 10^5 lookups instead of 10^6")
    args = harness.parse_args(parser)
    n_lookups = 200_000 if args.quick else 1_000_000
    table = roads.synthetic_rtable(q0=Q0, forward=FORWARD)
    dense = dense_table()
    insts = _roads.installations()
    pairs = [used_pairs(inst) for inst in insts]
    beta = np.concatenate([p[0] for p in pairs])
    tan = np.concatenate([p[1] for p in pairs])
    weight = np.concatenate([p[2] for p in pairs])
    exact_used = exact_r(beta, tan)
    rng = np.random.default_rng(20261201)
    domain_beta = rng.uniform(0.0, 180.0, n_lookups)
    domain_tan = rng.uniform(0.0, 12.0, n_lookups)
    domain_exact = exact_r(domain_beta, domain_tan)

    def weighted_error(values: np.ndarray) -> float:
        return float(
            100 * np.sum(weight * np.abs(values - exact_used)) / np.sum(weight * exact_used)
        )

    # The dense reference is interpolated bilinearly (a spline through 1.7e6 nodes is needless).
    dense_used = roads.reduced_luminance_coefficient(dense, beta, tan, interpolation="bilinear")
    reference_error = weighted_error(dense_used)
    exact_fields = [field_luminance(inst, dense, "bilinear") for inst in insts]
    exact_metrics = [
        {
            "L_av": float(roads.average_luminance(f).min()),
            "U_o": float(roads.overall_uniformity(f).min()),
        }
        for f in exact_fields
    ]

    rows = []
    for method in METHODS:
        lookup = harness.repeat(
            lambda m=method: roads.reduced_luminance_coefficient(
                table, domain_beta, domain_tan, interpolation=m
            ),
            3,
        )
        domain_error = np.abs(lookup.value - domain_exact)
        used = roads.reduced_luminance_coefficient(table, beta, tan, interpolation=method)
        row: dict[str, Any] = {
            "method": method,
            "seconds_per_1e6_lookups": lookup.best * 1e6 / n_lookups,
            "r_weighted_error_percent": weighted_error(used),
            "r_max_error_percent_of_max": float(100 * domain_error.max() / domain_exact.max()),
            "r_rms_error_percent_of_max": float(
                100 * np.sqrt(np.mean(domain_error**2)) / domain_exact.max()
            ),
            "installations": [],
        }
        for inst, exact in zip(insts, exact_metrics, strict=True):
            timing = harness.repeat(lambda i=inst, m=method: field_luminance(i, table, m), 5)
            average = float(roads.average_luminance(timing.value).min())
            uniformity = float(roads.overall_uniformity(timing.value).min())
            row["installations"].append(
                {
                    "installation": inst.name,
                    "field_seconds": timing.best,
                    "L_av": average,
                    "U_o": uniformity,
                    "L_av error %": 100 * (average / exact["L_av"] - 1),
                    "U_o error %": 100 * (uniformity / exact["U_o"] - 1),
                }
            )
        row["worst_L_av_error_percent"] = max(
            (i["L_av error %"] for i in row["installations"]), key=abs
        )
        row["worst_U_o_error_percent"] = max(
            (i["U_o error %"] for i in row["installations"]), key=abs
        )
        row["field_seconds_total"] = sum(i["field_seconds"] for i in row["installations"])
        rows.append(row)
        print(
            f"{method:15s} {row['seconds_per_1e6_lookups']:.3f} s/1e6, r weighted "
            f"{row['r_weighted_error_percent']:.4f} %, max {row['r_max_error_percent_of_max']:.3f} "
            f"%, L_av {row['worst_L_av_error_percent']:+.4f} %, U_o "
            f"{row['worst_U_o_error_percent']:+.4f} %",
            flush=True,
        )
    result = {
        "table": table.name,
        "grid": f"{table.beta.size} beta x {table.tan_gamma.size} tan gamma (CIE layout)",
        "reference": (
            "the analytic r; for L_av and U_o, road_luminance with a dense table of it "
            f"(beta step {DENSE_BETA_STEP} deg, tan gamma step {DENSE_TAN_STEP})"
        ),
        "reference_r_error_percent": reference_error,
        "used_pairs": int(beta.size),
        "n_lookups": n_lookups,
        "installations": [inst.describe() for inst in insts],
        "exact_metrics": [
            {"installation": inst.name, **m} for inst, m in zip(insts, exact_metrics, strict=True)
        ],
        "note": "wall times on a shared 2-core machine, best of 3 (lookups) or 5 (fields); noisy",
        "rows": rows,
    }
    harness.write_results(
        args.out, "rtable_interpolation", result, quick=args.quick, plot=plot, dpi=110
    )


def plot(result: dict[str, Any]) -> Any:
    """Lookups: time against r error; fields: time against the L_av and U_o errors."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(13, 4.3))
    left, middle, right = figure.subplots(1, 3)
    colours = dict(zip(METHODS, ("tab:blue", "tab:orange", "tab:green"), strict=True))
    markers = ("o", "s", "^")
    for row in result["rows"]:
        colour = colours[row["method"]]
        time = row["seconds_per_1e6_lookups"]
        left.plot(time, row["r_weighted_error_percent"], "o", color=colour, label=row["method"])
        left.plot(time, row["r_max_error_percent_of_max"], "x", color=colour)
        for axis, metric in ((middle, "L_av"), (right, "U_o")):
            for inst, marker in zip(row["installations"], markers, strict=False):
                axis.plot(
                    inst["field_seconds"],
                    max(abs(inst[f"{metric} error %"]), 1e-5),
                    marker,
                    color=colour,
                    label=f"{row['method']}: {inst['installation']}",
                )
    left.set_xlabel("time per 1e6 lookups [s]")
    left.set_ylabel("error in r [%]")
    left.set_yscale("log")
    left.set_title("r: use-weighted mean error (o), largest / max r (x)", fontsize=9)
    left.legend(fontsize=8)
    for axis, metric in ((middle, "L_av"), (right, "U_o")):
        axis.set_xlabel("standard field, all observers [s]")
        axis.set_ylabel(f"|{metric} error| [%]")
        axis.set_yscale("log")
        axis.set_title(f"{metric} against the exact r", fontsize=9)
    right.legend(fontsize=6, ncol=1, loc="best")
    figure.suptitle(f"r-table interpolation on {result['grid']} of {result['table']}", fontsize=10)
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
