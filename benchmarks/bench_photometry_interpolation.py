"""Benchmark: candela interpolation, speed against accuracy.

Knobs: interpolation method (bilinear, Chuang 2011 Eq. 4; bicubic spline) and grid
resolution. The fine file is the Hella LED street luminaire measured on a 1 x 1 deg grid
(V 0-130, H 0-359); coarser grids are made by keeping every k-th angle (k = 1, 2, 5, 10 deg).
The reference is the full-resolution measurement itself: every measured (V, H) node of the
1-deg file, including the ones a coarse grid drops. For each (method, step) the script
measures the time per 1e6 random lookups (best of 3), the error at the measured nodes (RMS
and maximum, relative to the peak intensity) and the error of the integrated flux. At step 1
both methods reproduce the nodes exactly (error 0; not drawn on the log axes).

Run: ``python benchmarks/bench_photometry_interpolation.py [--quick] [--out DIR]``
(``--quick``: 2e5 lookups instead of 1e6).
Writes ``photometry_interpolation.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import _harness as harness
import numpy as np

import ies
from ies.errors import PhotometryWarning

ROOT = Path(__file__).resolve().parents[1]
FINE_FILE = (
    ROOT
    / "tests"
    / "data"
    / "ies"
    / "fglichttechnik__Radiance-RoadLighting-Simulation-Framework"
    / "HellaEcoLight_2070lm_LDT.ies"
)
STEPS = (1, 2, 5, 10)  # grid step [deg] (every k-th angle of the 1-deg file)
METHODS = ("bilinear", "cubic")


def subsample(photometry: ies.Photometry, step: int) -> ies.Photometry:
    """Keep every ``step``-th vertical and horizontal angle of a 1-deg grid."""
    return ies.Photometry(
        "C",
        photometry.vertical_angles[::step],
        photometry.horizontal_angles[::step],
        photometry.candela[::step, ::step],
        source=f"{photometry.source} every {step} deg",
    )


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="2e5 lookups instead of 1e6")
    args = harness.parse_args(parser)
    n_lookups = 200_000 if args.quick else 1_000_000

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhotometryWarning)  # the file's declared lumens are off
        fine = ies.read_ies(FINE_FILE)
    rng = np.random.default_rng(20261122)
    # directions uniform on the measured part of the sphere (V 0-130 deg)
    cos_v = rng.uniform(np.cos(np.radians(130.0)), 1.0, n_lookups)
    vertical = np.degrees(np.arccos(cos_v))
    horizontal = rng.uniform(0.0, 360.0, n_lookups)
    node_v, node_h = np.meshgrid(fine.vertical_angles, fine.horizontal_angles[:-1])
    reference = fine.candela[:-1]  # measured values at every node (H = 360 repeats H = 0)
    peak = float(fine.candela.max())
    reference_flux = fine.luminous_flux()

    rows = []
    for step in STEPS:
        coarse = subsample(fine, step)
        for method in METHODS:
            coarse.intensity(vertical[:10], horizontal[:10], method=method)  # build spline
            seconds = harness.repeat(
                lambda c=coarse, m=method: c.intensity(vertical, horizontal, method=m), 3
            ).best
            values = coarse.intensity(node_v, node_h, method=method)
            error = values - reference
            rows.append(
                {
                    "method": method,
                    "grid_step_deg": step,
                    "grid_shape": list(coarse.candela.shape),
                    "seconds_per_1e6_lookups": seconds * 1e6 / n_lookups,
                    "rms_error_percent_of_peak": float(100 * np.sqrt(np.mean(error**2)) / peak),
                    "max_error_percent_of_peak": float(100 * np.max(np.abs(error)) / peak),
                    "flux_error_percent": float(100 * (coarse.luminous_flux() / reference_flux - 1))
                    if method == "bilinear"
                    else None,
                }
            )
            print(
                f"{method:8s} step {step:2d} deg: {rows[-1]['seconds_per_1e6_lookups']:.3f} "
                f"s/1e6, RMS {rows[-1]['rms_error_percent_of_peak']:.3f} % of peak"
            )

    result = {
        "file": FINE_FILE.name,
        "reference": "measured candela at every node of the 1-deg file",
        "n_lookups": n_lookups,
        "peak_candela": peak,
        "reference_flux_lm": reference_flux,
        "note": (
            "wall times on a shared 2-core machine, best of 3; noisy. Errors are at the "
            "measured nodes of the 1-deg file; at step 1 both interpolants reproduce them."
        ),
        "rows": rows,
    }
    harness.write_results(
        args.out, "photometry_interpolation", result, quick=args.quick, plot=plot, dpi=110
    )


def plot(result: dict):
    """Time per 1e6 lookups against RMS error, one line per method, labelled by step."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(10, 4.2))
    left, right = figure.subplots(1, 2)
    for method, marker, colour in zip(METHODS, ("o", "s"), ("tab:blue", "tab:orange"), strict=True):
        all_rows = [r for r in result["rows"] if r["method"] == method]
        rows = [r for r in all_rows if r["grid_step_deg"] > 1]
        steps = [r["grid_step_deg"] for r in rows]
        rms = [r["rms_error_percent_of_peak"] for r in rows]
        seconds = [r["seconds_per_1e6_lookups"] for r in rows]
        left.plot(seconds, rms, marker=marker, color=colour, label=method)
        for s, t, e in zip(steps, seconds, rms, strict=True):
            left.annotate(f"{s} deg", (t, e), textcoords="offset points", xytext=(4, 4), fontsize=8)
        right.plot(steps, rms, marker=marker, color=colour, label=f"{method}: RMS")
        right.plot(
            steps,
            [r["max_error_percent_of_peak"] for r in rows],
            marker=marker,
            linestyle="--",
            color=colour,
            label=f"{method}: max",
        )
        full = next(r for r in all_rows if r["grid_step_deg"] == 1)
        left.axvline(
            full["seconds_per_1e6_lookups"],
            color=left.lines[-1].get_color(),
            linestyle=":",
            linewidth=1,
        )
    left.set_xlabel("time per 1e6 lookups [s] (dotted: 1-deg grid, exact at nodes)")
    left.set_ylabel("RMS error [% of peak cd]")
    left.set_yscale("log")
    left.set_title("speed vs accuracy (2-core machine, noisy)")
    left.legend()
    right.set_xlabel("grid step [deg]")
    right.set_ylabel("error [% of peak cd]")
    right.set_yscale("log")
    right.set_title(f"error at the measured 1-deg nodes: {result['file']}", fontsize=9)
    right.legend(fontsize=8)
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
