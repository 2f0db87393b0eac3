"""Benchmark: the two knobs of the road influence matrices, glare reach and r-table resampling.

Both are module constants of :mod:`nightlights.roads._influence`, swept on the 420-segment
district of ``bench_road_audit.py`` (a grid city of 100 m blocks with the street mix of a real
town, lights placed by ``streets place``):

- **Glare reach** (:data:`~nightlights.roads._influence.GLARE_REACH`): the distance from the
  eye within which a luminaire counts in the veiling luminance of EN 13201-3 Eq. (15). The
  threshold increment f_TI of every rated M-class segment is compared with a reach of
  2,000 m: the worst difference in percentage points of f_TI (the requirement is a maximum
  of 10-20 %), and model + rating time.
- **r-table resampling** (:data:`~nightlights.roads._influence.R_BETA_STEP`,
  :data:`~nightlights.roads._influence.R_TAN_STEP`): the compiled kernel reads r bilinearly
  off the r-table resampled on a regular grid by the table's own (default bicubic)
  interpolation. Every luminance figure of every rated segment (L_av, U_o, U_l, R_EI does
  not use r) is compared with a grid 4 times finer than the finest setting; the worst
  relative error [%] against model + rating time.

Run: ``python benchmarks/bench_road_influence.py [--quick] [--out DIR]`` (``--quick``: a
smaller district). Writes ``road_influence.json`` and ``.png``.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import _harness as harness
import numpy as np
from bench_road_audit import REACH_CITY, _lights, grid_city

#: Glare reaches swept [m], and the reference.
GLARE_REACHES = (100.0, 200.0, 300.0, 500.0, 1000.0)
REFERENCE_GLARE_REACH = 2000.0
#: r-table resampling steps swept: (beta [deg], tan gamma [1]), and the reference.
R_STEPS = ((2.0, 0.08), (1.0, 0.04), (0.5, 0.02), (0.25, 0.01), (0.125, 0.005))
REFERENCE_R_STEP = (0.03125, 0.00125)
#: Luminance figures compared for the r-table grid.
LUMINANCE_FIGURES = ("average_luminance", "overall_uniformity", "longitudinal_uniformity")


def _rated(reference: Any, rating: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    ref = reference[name].to_numpy(float)
    got = rating[name].to_numpy(float)
    rated = np.isfinite(reference[f"{name}_required"].to_numpy(float))
    ok = rated & np.isfinite(ref) & np.isfinite(got)
    return ref[ok], got[ok]


def _model(lights: Any, streets: Any, **constants: Any) -> tuple[Any, float]:
    """Rating with the influence module's constants set as given; (rating, seconds)."""
    from nightlights import roads
    from nightlights.roads import _influence

    saved = {name: getattr(_influence, name) for name in constants}
    try:
        for name, value in constants.items():
            setattr(_influence, name, value)
        start = time.perf_counter()
        rating = roads.road_model(lights, streets).rate()
        return rating, time.perf_counter() - start
    finally:
        for name, value in saved.items():
            setattr(_influence, name, value)


def glare_sweep(lights: Any, streets: Any) -> list[dict[str, Any]]:
    reference, _ = _model(lights, streets, GLARE_REACH=REFERENCE_GLARE_REACH)
    rows = []
    for reach in GLARE_REACHES:
        rating, seconds = _model(lights, streets, GLARE_REACH=reach)
        ref, got = _rated(reference, rating, "threshold_increment")
        error = float(np.max(np.abs(got - ref))) if ref.size else 0.0
        flips = int(np.sum(rating["passed"].to_numpy() != reference["passed"].to_numpy()))
        rows.append(
            {
                "glare_reach_m": reach,
                "seconds": seconds,
                "worst_fti_points": error,
                "segments_rated": int(ref.size),
                "verdicts_changed": flips,
            }
        )
        print(f"glare reach {reach:6.0f} m: {seconds:.2f} s, worst f_TI {error:.4f} points")
    return rows


def rtable_sweep(lights: Any, streets: Any) -> list[dict[str, Any]]:
    beta, tan = REFERENCE_R_STEP
    reference, _ = _model(lights, streets, R_BETA_STEP=beta, R_TAN_STEP=tan)
    rows = []
    for beta, tan in R_STEPS:
        rating, seconds = _model(lights, streets, R_BETA_STEP=beta, R_TAN_STEP=tan)
        errors = {}
        for name in LUMINANCE_FIGURES:
            ref, got = _rated(reference, rating, name)
            ok = ref != 0
            errors[name] = float(np.max(np.abs(got[ok] / ref[ok] - 1))) * 100 if ok.any() else 0.0
        worst = max(errors, key=lambda k: errors[k])
        rows.append(
            {
                "beta_step_deg": beta,
                "tan_step": tan,
                "seconds": seconds,
                "worst_error_percent": errors[worst],
                "worst_figure": worst,
                "errors_percent": errors,
            }
        )
        print(f"r grid {beta:6.3f} deg x {tan:.4f}: {seconds:.2f} s, worst {errors[worst]:.4f} %")
    return rows


def _panel(axis: Any, rows: list[dict[str, Any]], x: str, y: str, label: Any, default: Any) -> None:
    xs = [r[x] for r in rows]
    ys = [max(r[y], 1e-6) for r in rows]
    axis.plot(xs, ys, "o-")
    for r, xv, yv in zip(rows, xs, ys, strict=True):
        axis.annotate(label(r), (xv, yv), fontsize=8, xytext=(4, 4), textcoords="offset points")
        if default(r):
            axis.plot(xv, yv, "r*", ms=14)
    axis.set_yscale("log")


def plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    _panel(
        left,
        document["glare"],
        "seconds",
        "worst_fti_points",
        lambda r: f"{r['glare_reach_m']:.0f} m",
        lambda r: r["glare_reach_m"] == document["default_glare_reach_m"],
    )
    left.set_xlabel("model + rating time [s]")
    left.set_ylabel("worst f_TI difference [percentage points]")
    left.set_title(f"glare reach vs {REFERENCE_GLARE_REACH:.0f} m (star: default)")
    step = tuple(document["default_r_step"])
    _panel(
        right,
        document["rtable"],
        "seconds",
        "worst_error_percent",
        lambda r: f"{r['beta_step_deg']:g} deg x {r['tan_step']:g}",
        lambda r: (r["beta_step_deg"], r["tan_step"]) == step,
    )
    right.set_xlabel("model + rating time [s]")
    right.set_ylabel("worst luminance figure error [%]")
    right.set_title("r-table resampling grid (star: default)")
    figure.suptitle(f"{document['segments']} segments, {document['lights']} lights", fontsize=9)
    figure.tight_layout()
    return figure


def main() -> None:
    from nightlights.roads import _influence

    parser = harness.argument_parser(__doc__, quick="a 7 x 7 line district")
    args = harness.parse_args(parser)
    streets = grid_city(7 if args.quick else REACH_CITY)
    lights = _lights(streets)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        glare = glare_sweep(lights, streets)
        rtable = rtable_sweep(lights, streets)
    payload = {
        "segments": len(streets),
        "lights": len(lights),
        "reference_glare_reach_m": REFERENCE_GLARE_REACH,
        "reference_r_step": list(REFERENCE_R_STEP),
        "default_glare_reach_m": _influence.GLARE_REACH,
        "default_r_step": [_influence.R_BETA_STEP, _influence.R_TAN_STEP],
        "glare": glare,
        "rtable": rtable,
    }
    harness.write_results(args.out, "road_influence", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
