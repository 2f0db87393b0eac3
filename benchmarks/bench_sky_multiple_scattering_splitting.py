"""Benchmark: azimuthal splitting in the Monte Carlo, time against error.

Knob: ``split_window`` of :func:`nightlights.sky.montecarlo.monte_carlo_luminance` (0: the
plain ray-integrated next-event estimator; :data:`~nightlights.sky.multiple.SPLIT_WINDOW`:
an event whose circle about the source's vertical passes near a view ray is replaced by the
weighted mean of :data:`~nightlights.sky.multiple.SPLIT_POINTS` rotated copies, the factor
tables' setting). For Garstang's psi^4 lobe at turbidity 2, the shape whose tables the plain
estimator's heavy tail hurt most, the factor f(elevation, azimuth, distance) is measured on the
tables' grid with both estimators at several photon counts, with a seed of its own, and
compared with the shipped table (60,000 photons, split): the median and the worst relative
deviation over the grid up to 150 km, against the wall time of the measurement.

Run: ``python benchmarks/bench_sky_multiple_scattering_splitting.py [--quick] [--out DIR]``
(``--quick``: fewer photons). Writes ``sky_multiple_scattering_splitting.json`` and ``.png``.
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky import multiple
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.kernel import UPLIGHT_EXPONENT

SHAPE = "garstang_lobe"
SEED = 77
PHOTONS = (1_000, 2_000, 4_000, 8_000, 16_000)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="fewer photons")
    args = harness.parse_args(parser)
    atmosphere = Atmosphere(turbidity=2.0)
    reference = multiple.shape_table(atmosphere, SHAPE, UPLIGHT_EXPONENT).factor
    reach = np.asarray(multiple.FACTOR_DISTANCES) <= 150_000.0
    photons = PHOTONS[:2] if args.quick else PHOTONS
    multiple._measure(atmosphere, SHAPE, 50, UPLIGHT_EXPONENT, seed=SEED)  # compile
    rows = []
    for window in (0.0, multiple.SPLIT_WINDOW):
        for n in photons:
            (factor, _), seconds = harness.timed(
                lambda n=n, window=window: multiple._measure(
                    atmosphere, SHAPE, n, UPLIGHT_EXPONENT, seed=SEED, split_window=window
                )
            )
            deviation = np.abs(factor / reference - 1.0)[..., reach]
            rows.append(
                {
                    "estimator": "split" if window else "plain",
                    "split_window": window,
                    "photons": n,
                    "seconds": seconds,
                    "median_deviation": float(np.median(deviation)),
                    "worst_deviation": float(deviation.max()),
                }
            )
            print(rows[-1], flush=True)
    payload = {
        "shape": SHAPE,
        "atmosphere": "turbidity 2",
        "reference": "the shipped table (split estimator, 60,000 photons, other seeds)",
        "split_points": multiple.SPLIT_POINTS,
        "runs": rows,
        "note": "deviation from a table itself measured with splitting: both estimators "
        "converge to the same mean; the plain one's heavy tail shows as the worst deviation",
    }
    harness.write_results(
        args.out, "sky_multiple_scattering_splitting", payload, quick=args.quick, plot=plot
    )


def plot(payload: dict):
    plt = harness.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for estimator, colour in (("plain", "tab:orange"), ("split", "tab:blue")):
        rows = [r for r in payload["runs"] if r["estimator"] == estimator]
        for key, style, label in (
            ("worst_deviation", "o-", "worst to 150 km"),
            ("median_deviation", "s--", "median"),
        ):
            ax.loglog(
                [r["seconds"] for r in rows],
                [r[key] for r in rows],
                style,
                color=colour,
                label=f"{estimator}: {label}",
            )
        for r in rows:
            ax.annotate(f"{r['photons']}", (r["seconds"], r["worst_deviation"]), fontsize=7)
    ax.set_xlabel("measurement time [s] (labels: photons)")
    ax.set_ylabel("relative deviation from the shipped table [1]")
    ax.set_title("psi^4 lobe factor, T = 2: plain vs azimuthal splitting", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
