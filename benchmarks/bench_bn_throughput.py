"""Benchmark: likelihood-weighted sampling time against the number of street segments.

Records are drawn from the network itself and then masked with the observation rates of
the bundled Helsinki OSM extract after ``streets normalize`` (street class always, lanes
34 %, oneway 28 %, lit 65 %, width 3 %), so the evidence is realistic and consistent.

Run: ``python benchmarks/bench_bn_throughput.py [--quick] [--out DIR] [--network NAME]
[--candidates N]`` (``--quick``: stop at 1e5 segments).
Writes ``bn_throughput.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np
import pandas as pd

from bayesnets import (
    DEFAULT_CANDIDATES,
    decode_samples,
    encode_frame,
    likelihood_weighted_sample,
    load_network,
    sample_frame,
)

#: Share of segments with each field observed (Helsinki extract, ``streets normalize``:
#: 1637 segments; street_class 1637, lanes 552, width 43, oneway 457, lit 1062 observed).
OBSERVED_RATE = {
    "street_class": 1.0,
    "lanes": 552 / 1637,
    "width": 43 / 1637,
    "oneway": 457 / 1637,
    "lit": 1062 / 1637,
    "has_median": 0.0,
}
TARGET_SECONDS = 30.0  # target: 1e6 segments in <= 30 s on the 2-core machine


def realistic_frame(network, n: int, rng: np.random.Generator) -> pd.DataFrame:
    """``n`` street records from ``network`` with fields masked at the observed rates."""
    full = decode_samples(network, likelihood_weighted_sample(network, {}, size=n, rng=rng))
    frame = pd.DataFrame(index=full.index)
    for field, rate in OBSERVED_RATE.items():
        keep = rng.random(n) < rate
        values = full[field].astype(object)
        if field == "width":  # observed widths are continuous, not the bin values
            values = pd.Series(np.round(full[field] * rng.uniform(0.8, 1.2, n), 1))
        frame[field] = values.where(keep, None)
    return frame


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="stop at 1e5 segments")
    parser.add_argument("--network", default="europe")
    parser.add_argument("--candidates", type=int, default=DEFAULT_CANDIDATES)
    args = harness.parse_args(parser)
    network = load_network(args.network)
    sizes = [100, 1_000, 10_000, 100_000] + ([] if args.quick else [1_000_000])
    rows = []
    for n in sizes:
        frame = realistic_frame(network, n, np.random.default_rng(n))
        codes = encode_frame(network, frame)
        patterns = len(np.unique(np.stack(list(codes.values()), axis=1), axis=0))
        repeats = 3 if n <= 100_000 else 1
        times = [
            harness.timed(
                lambda frame=frame, seed=seed: sample_frame(
                    network, frame, candidates=args.candidates, rng=np.random.default_rng(seed)
                )
            )[1]
            for seed in range(repeats)
        ]
        best = min(times)
        # Worst case: width observed on every segment and nothing else, so the hidden
        # street class and lane count are drawn N times per segment and weighted.
        widths = pd.DataFrame({"width": np.round(np.random.default_rng(n).uniform(3, 25, n), 1)})
        _, weighted = harness.timed(
            lambda widths=widths: sample_frame(
                network, widths, candidates=args.candidates, rng=np.random.default_rng(9)
            )
        )
        rows.append(
            {
                "segments": n,
                "seconds": best,
                "all_seconds": times,
                "evidence_patterns": patterns,
                "segments_per_second": n / best,
                "all_weighted_seconds": weighted,
            }
        )
        print(
            f"{n:>9d} segments: {best:8.3f} s ({patterns} evidence patterns); "
            f"all weighted {weighted:8.3f} s"
        )
    result = {
        "network": network.name,
        "candidates": args.candidates,
        "observed_rate": OBSERVED_RATE,
        "target_seconds_1e6": TARGET_SECONDS,
        "note": "shared 2 cores (timings are noisy: other jobs share the machine)",
        "rows": rows,
    }
    harness.write_results(args.out, "bn_throughput", result, quick=args.quick, plot=plot, dpi=120)


def plot(result: dict):
    plt = harness.pyplot()
    rows = result["rows"]
    figure, axis = plt.subplots(figsize=(6, 4))
    x = [r["segments"] for r in rows]
    axis.loglog(
        x,
        [r["seconds"] for r in rows],
        "o-",
        label=f"realistic evidence mix ({result['network']}, N={result['candidates']})",
    )
    axis.loglog(
        x,
        [r["all_weighted_seconds"] for r in rows],
        "s-",
        label="worst case: every segment weighted",
    )
    axis.loglog(
        x, [r["segments"] / 1e6 * 1.0 for r in rows], ":", color="grey", label="1 µs per segment"
    )
    axis.axhline(
        result["target_seconds_1e6"], color="tab:red", ls="--", label="target: 1e6 in 30 s"
    )
    axis.set_xlabel("street segments")
    axis.set_ylabel("sampling time [s] (best of 3; 1 run at 1e6)")
    axis.set_title("Likelihood-weighted sampling throughput")
    axis.grid(True, which="both", alpha=0.3)
    axis.legend()
    figure.tight_layout()
    return figure


if __name__ == "__main__":
    main()
