"""Least-flux dimming: linear program and greedy time against lit cells and targets.

``nightlights.inverse.least_flux_dimming`` on contribution matrices of a realistic structure:
lit cells drawn at random on a 40 km square raster of 100 m cells, log-normal flux per cell
(median 2,000 lm, sigma 1.2), observers at random positions whose zenith luminance per cell
falls as F_i r^-alpha with alpha drawn in [2, 2.5] per observer (r clipped at half a cell), an
artificial zenith luminance per observer drawn log-uniformly in [3e-4, 3e-3] cd m-2 on top of a
natural 1.7e-4 cd m-2 (22 mag arcsec-2) that cannot be dimmed, every cell dimmable by at most
90 % except 10 % protected ones (max 0), and each target asking to remove 30-70 % of what
dimming can remove (so every instance is feasible). Each plan is checked: within bounds, every
target met (largest violation relative to the required reduction), at most one part-dimmed
cell per target (a basic solution of the LP), and the greedy plan's flux equal to the LP's for
one target. Also measured: a dense against a sparse constraint matrix, and HiGHS presolve on
(the default of ``linprog``) against off (what ``least_flux_dimming`` uses), one call each, at
one target and the most targets (about 2 minutes of the full run: presolve is slow on one
constraint with many columns).

Run: ``python benchmarks/bench_inverse_lp.py [--quick] [--out DIR]`` (``--quick``: up to 1e4
cells, targets 1, 2, 5, 10, no presolve comparison). Writes ``inverse_lp.json`` and ``.png``
(see ``_harness.py`` for where).
"""

from __future__ import annotations

from typing import Any

import _harness as harness
import numpy as np

from nightlights.inverse import _dimming
from nightlights.inverse._dimming import least_flux_dimming

CELL = 100.0  # [m]
SIDE = 400  # cells: a 40 km square, room for 1e5 distinct lit cells
NATURAL = 1.7e-4  # natural zenith luminance [cd m-2], 22 mag arcsec-2
MAX_DIMMING = 0.9  # [1]
PROTECTED = 0.1  # share of cells that may not be dimmed [1]


def instance(n_cells: int, n_targets: int, rng: np.random.Generator) -> dict[str, Any]:
    """A random feasible least-flux dimming problem (see the module docstring)."""
    index = rng.choice(SIDE * SIDE, size=n_cells, replace=False)
    cells = np.column_stack([(index % SIDE + 0.5) * CELL, (index // SIDE + 0.5) * CELL])
    observers = rng.uniform(0, SIDE * CELL, (n_targets, 2))
    r = np.maximum(
        np.hypot(
            cells[None, :, 0] - observers[:, None, 0], cells[None, :, 1] - observers[:, None, 1]
        ),
        CELL / 2,
    )
    flux = rng.lognormal(np.log(2000.0), 1.2, n_cells)
    alpha = rng.uniform(2.0, 2.5, (n_targets, 1))
    shape = flux * r**-alpha
    artificial = 10 ** rng.uniform(np.log10(3e-4), np.log10(3e-3), n_targets)
    contribution = shape * (artificial / shape.sum(axis=1))[:, None]
    max_dimming = np.where(rng.random(n_cells) < PROTECTED, 0.0, MAX_DIMMING)
    before = contribution.sum(axis=1) + NATURAL
    target = before - rng.uniform(0.3, 0.7, n_targets) * (contribution @ max_dimming)
    return {
        "contribution": contribution,
        "flux": flux,
        "before": before,
        "target": target,
        "max_dimming": max_dimming,
    }


def check(plan: _dimming.DimmingPlan, problem: dict[str, Any]) -> dict[str, Any]:
    """Independent check of a plan: bounds, targets, part-dimmed cells, flux removed."""
    x, m = plan.fraction, problem["max_dimming"]
    before, target = problem["before"], problem["target"]
    after = before - problem["contribution"] @ x
    violation = float(np.max((after - target) / (before - target)))
    assert np.all(x >= 0) and np.all(x <= m), "a fraction outside its bounds"
    assert violation <= 1e-9, f"a target missed by {violation:.3g} of its reduction"
    partial = int(np.sum((x > 1e-12) & (x < m - 1e-12)))
    return {
        "max_violation": violation,
        "part_dimmed_cells": partial,
        "dimmed_cells": int(np.sum(x > 1e-12)),
        "removed_flux_percent": 100 * plan.removed_flux / plan.total_flux,
    }


def timing(function, n_cells: int) -> float:
    """Median wall time [s]: 5 calls up to 1e4 cells, 3 above."""
    return harness.repeat(function, 5 if n_cells <= 10_000 else 3).median


def with_options(name: str, value: Any, function):
    """Call ``function`` with ``_dimming.<name>`` set to ``value`` for the call."""
    saved = getattr(_dimming, name)
    setattr(_dimming, name, value)
    try:
        return function()
    finally:
        setattr(_dimming, name, saved)


def main() -> None:
    parser = harness.argument_parser(
        __doc__, quick="up to 1e4 cells, targets 1, 2, 5, 10, no presolve comparison"
    )
    args = harness.parse_args(parser)
    cells = [100, 1000, 10_000] if args.quick else [100, 300, 1000, 3000, 10_000, 30_000, 100_000]
    targets = [1, 2, 5, 10] if args.quick else [1, 2, 3, 5, 10]
    rng = np.random.default_rng(0)
    rows = []
    for n_cells in cells:
        for n_targets in targets:
            problem = instance(n_cells, n_targets, rng)
            lp = least_flux_dimming(**problem, method="lp")
            row = {
                "lit_cells": n_cells,
                "targets": n_targets,
                "lp_s": timing(lambda p=problem: least_flux_dimming(**p, method="lp"), n_cells),
                **check(lp, problem),
            }
            if n_targets == 1:
                greedy = least_flux_dimming(**problem, method="greedy")
                check(greedy, problem)
                row["greedy_s"] = timing(
                    lambda p=problem: least_flux_dimming(**p, method="greedy"), n_cells
                )
                row["greedy_lp_flux_gap"] = abs(greedy.removed_flux / lp.removed_flux - 1)
            if n_targets == targets[-1]:
                force_dense = 10**12 if n_cells >= _dimming.SPARSE_FROM_CELLS else 0
                key = "dense_lp_s" if force_dense else "sparse_lp_s"
                row[key] = with_options(
                    "SPARSE_FROM_CELLS",
                    force_dense,
                    lambda p=problem, n=n_cells: timing(
                        lambda: least_flux_dimming(**p, method="lp"), n
                    ),
                )
            if not args.quick and n_targets in (1, targets[-1]):
                options = {**_dimming.HIGHS_OPTIONS, "presolve": True}
                plan, seconds = with_options(
                    "HIGHS_OPTIONS",
                    options,
                    lambda p=problem: harness.timed(lambda: least_flux_dimming(**p, method="lp")),
                )
                check(plan, problem)
                row["presolve_lp_s"] = seconds
            rows.append(row)
            print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    largest = [r for r in rows if r["lit_cells"] == cells[-1]]
    result = {
        "scene": f"{SIDE} x {SIDE} cells of {CELL:g} m, lit cells at random; contributions "
        "F_i r^-alpha, alpha in [2, 2.5]; flux log-normal (median 2000 lm, sigma 1.2)",
        "max_dimming": MAX_DIMMING,
        "protected_share": PROTECTED,
        "sparse_from_cells": _dimming.SPARSE_FROM_CELLS,
        "highs_options": _dimming.HIGHS_OPTIONS,
        "note": "median wall time of least_flux_dimming (validation included); 2 shared cores",
        "rows": rows,
        "largest": {
            "lit_cells": cells[-1],
            "lp_s_at_most_targets": largest[-1]["lp_s"],
            "greedy_s": largest[0]["greedy_s"],
            "max_violation": max(r["max_violation"] for r in rows),
            "max_greedy_lp_flux_gap": max(r.get("greedy_lp_flux_gap", 0.0) for r in rows),
        },
    }
    harness.write_results(args.out, "inverse_lp", result, quick=args.quick, plot=plot)


def plot(result: dict):
    plt = harness.pyplot()
    rows = result["rows"]
    targets = sorted({r["targets"] for r in rows})
    cells = sorted({r["lit_cells"] for r in rows})
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.3), layout="constrained")
    colour = {}
    for n_targets in targets:
        sel = [r for r in rows if r["targets"] == n_targets]
        (line,) = left.loglog(
            [r["lit_cells"] for r in sel], [r["lp_s"] for r in sel], "o-", label=f"LP, {n_targets}"
        )
        colour[n_targets] = line.get_color()
    greedy = [r for r in rows if "greedy_s" in r]
    left.loglog(
        [r["lit_cells"] for r in greedy],
        [r["greedy_s"] for r in greedy],
        "k^--",
        label="greedy, 1 target",
    )
    for n_targets in targets:
        sel = [r for r in rows if r["targets"] == n_targets and "presolve_lp_s" in r]
        if sel:
            left.loglog(
                [r["lit_cells"] for r in sel],
                [r["presolve_lp_s"] for r in sel],
                "x:",
                color=colour[n_targets],
                label=f"LP with presolve, {n_targets}",
            )
    left.set_xlabel("lit cells")
    left.set_ylabel("time [s]")
    left.set_title("Least-flux dimming: time against lit cells (legend: targets)")
    left.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=7)
    for n_cells in cells:
        sel = [r for r in rows if r["lit_cells"] == n_cells]
        right.semilogy(
            [r["targets"] for r in sel], [r["lp_s"] for r in sel], "o-", label=f"{n_cells:,} cells"
        )
    right.set_xlabel("targets (observers)")
    right.set_ylabel("LP time [s]")
    right.set_title("LP time against targets")
    right.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=7)
    return figure


if __name__ == "__main__":
    main()
