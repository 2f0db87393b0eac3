"""Benchmark: time and marginal error of likelihood weighting against ``--candidates``.

For evidence patterns typical of street layers in which the evidence has unobserved
ancestors (so the weights matter), sample ``--records`` segments per pattern for each
candidate count N and compare the sampled marginals of every unobserved field with exact
inference (pgmpy variable elimination). Error: total-variation distance
0.5 * sum |p_sampled - p_exact| averaged over the unobserved fields and patterns. The
*noise floor* is the same error for an exact sampler with the same number of records
(multinomial draws from the exact marginals): below it more candidates cannot help.
Time: sampling all patterns, and a realistic 1e5-segment layer (see
``bench_bn_throughput.py``), at each N.

Run: ``python benchmarks/bench_bn_candidates.py [--quick] [--out DIR] [--network NAME]
[--records N]`` (``--quick``: 10,000 records per pattern, N = 1, 4, 16, 64, 200).
Writes ``bn_candidates.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np
from bench_bn_throughput import realistic_frame

from bayesnets import (
    exact_marginals,
    likelihood_weighted_sample,
    load_network,
    sample_frame,
)

CANDIDATES = [1, 2, 4, 8, 16, 32, 64, 128, 200]

#: Evidence patterns (field values) whose unobserved ancestors carry the weight.
PATTERNS = {
    "local street, 10 m wide": {"STREET_CLASS": "local", "WIDTH": "10"},
    "21 m wide, class unknown": {"WIDTH": "21"},
    "arterial, lit, 14 m wide": {"STREET_CLASS": "arterial", "LIT": "T", "WIDTH": "14"},
    "mapped opposite poles": {"ARRANGEMENT": "opposite"},
    "mapped road_hps luminaire, 7.5 m": {"SYSTEM": "road_hps", "WIDTH": "7.5"},
}


def total_variation(p: np.ndarray, q: np.ndarray) -> float:
    return 0.5 * float(np.abs(p - q).sum())


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer records and N values")
    parser.add_argument("--network", default="europe")
    parser.add_argument(
        "--records",
        type=int,
        default=None,
        help="records per pattern (default 40000; 10000 with --quick)",
    )
    args = harness.parse_args(parser)
    records = args.records or (10_000 if args.quick else 40_000)
    candidates = [1, 4, 16, 64, 200] if args.quick else CANDIDATES
    network = load_network(args.network)
    fields = [v for v in network.variables if network.field_of(v)]
    exact = {}
    for name, pattern in PATTERNS.items():
        codes = {v: network.states[v].index(s) for v, s in pattern.items()}
        exact[name] = (
            codes,
            exact_marginals(network, codes, [v for v in fields if v not in codes]),
        )
    rng = np.random.default_rng(0)
    floor_errors = []
    for _codes, marginals in exact.values():
        for p in marginals.values():
            draws = rng.multinomial(records, p, size=20) / records
            floor_errors.append(np.mean([total_variation(d, p) for d in draws]))
    noise_floor = float(np.mean(floor_errors))
    layer = realistic_frame(network, 100_000, np.random.default_rng(1))
    rows = []
    for n_candidates in candidates:
        per_pattern = {}
        with harness.Stopwatch() as patterns_watch:
            for index, (name, (codes, marginals)) in enumerate(exact.items()):
                evidence = {v: np.full(records, c) for v, c in codes.items()}
                samples = likelihood_weighted_sample(
                    network,
                    evidence,
                    candidates=n_candidates,
                    rng=np.random.default_rng(100 + index),
                )
                errors = {
                    v: total_variation(np.bincount(samples[v], minlength=len(p)) / records, p)
                    for v, p in marginals.items()
                }
                per_pattern[name] = {
                    "mean_tv": float(np.mean(list(errors.values()))),
                    "max_tv": float(max(errors.values())),
                    "worst_field": network.field_of(max(errors, key=errors.get)),
                }
        pattern_seconds = patterns_watch.seconds
        _, layer_seconds = harness.timed(
            lambda n=n_candidates: sample_frame(
                network, layer, candidates=n, rng=np.random.default_rng(2)
            )
        )
        error = float(np.mean([r["mean_tv"] for r in per_pattern.values()]))
        rows.append(
            {
                "candidates": n_candidates,
                "mean_tv": error,
                "max_tv": float(max(r["max_tv"] for r in per_pattern.values())),
                "pattern_seconds": pattern_seconds,
                "realistic_1e5_seconds": layer_seconds,
                "patterns": per_pattern,
            }
        )
        print(
            f"N={n_candidates:>4d}: mean TV {error:.4f} (floor {noise_floor:.4f}), "
            f"{pattern_seconds:.2f} s for {len(PATTERNS)} x {records} weighted records, "
            f"{layer_seconds:.2f} s for 1e5 realistic segments"
        )
    result = {
        "network": network.name,
        "records_per_pattern": records,
        "patterns": PATTERNS,
        "error": "total-variation distance of sampled vs exact (pgmpy VariableElimination) "
        "marginals, mean over unobserved fields and patterns",
        "noise_floor_mean_tv": noise_floor,
        "note": "timings on a shared 2-core machine are noisy",
        "rows": rows,
    }
    harness.write_results(args.out, "bn_candidates", result, quick=args.quick, plot=plot, dpi=120)


def plot(result: dict):
    plt = harness.pyplot()
    rows = result["rows"]
    records = result["records_per_pattern"]
    noise_floor = result["noise_floor_mean_tv"]
    n_patterns = len(result["patterns"])
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    n = [r["candidates"] for r in rows]
    left.loglog(n, [r["mean_tv"] for r in rows], "o-", label="mean over fields and patterns")
    left.loglog(n, [r["max_tv"] for r in rows], "s--", alpha=0.6, label="worst field")
    left.axhline(noise_floor, color="grey", ls=":", label=f"noise floor ({records} records)")
    left.set_xlabel("candidates per segment N")
    left.set_ylabel("marginal error (total variation)")
    left.set_title("Error vs candidates")
    left.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=8)
    right.semilogy(
        [r["pattern_seconds"] for r in rows],
        [r["mean_tv"] for r in rows],
        "o-",
        label=f"{n_patterns} x {records} weighted segments",
    )
    right.semilogy(
        [r["realistic_1e5_seconds"] for r in rows],
        [r["mean_tv"] for r in rows],
        "s-",
        label="1e5 realistic segments (same error axis)",
    )
    for row in rows:
        right.annotate(
            str(row["candidates"]),
            (row["pattern_seconds"], row["mean_tv"]),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=8,
        )
    right.axhline(noise_floor, color="grey", ls=":")
    right.set_xlabel("sampling time [s]")
    right.set_ylabel("marginal error (total variation)")
    right.set_title("Time vs error (labels: N)")
    right.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=8)
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
