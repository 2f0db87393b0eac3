"""The natural sky through an instrument: time against error for the sky grid and the shared
skies of many readings.

Knobs of :mod:`nightlights.meter.natural`: ``SKY_GRID_STEP`` (the grid of directions the
natural sky is read on: 1, 2, 4 deg) and ``SIDEREAL_STEP`` (readings share one sky per step of
local sidereal time, with ``LATITUDE_STEP`` = step / 2 of latitude: 0.5 to 8 deg; 0: every
reading its own). Error: the largest difference [mag arcsec-2] of 200 SQM-L and 200 SQM
readings (one March night over 20-28 E, 58-64 N) from the reference, each reading's own sky on
a 0.5 deg grid. Time: the readings' natural skies, per reading.

Run: ``python benchmarks/bench_meter_natural.py [--quick] [--out DIR]`` (``--quick``: 50
readings). Writes ``meter_natural.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import time
from typing import Any

import _harness as harness
import numpy as np
import pandas as pd

import nightlights.meter.natural as natural
from nightlights.brightness import luminance_to_magnitude


def readings(count: int) -> tuple[pd.DatetimeIndex, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    times = pd.Timestamp("2026-03-20T19:00Z") + pd.to_timedelta(rng.uniform(0, 8, count), "h")
    return times, rng.uniform(20.0, 28.0, count), rng.uniform(58.0, 64.0, count)


def skies(instrument: str, grid: float, sidereal: float, data: Any) -> tuple[np.ndarray, float]:
    """The readings' natural skies with these knobs, and the time per reading [s]."""
    times, lon, lat = data
    natural.SKY_GRID_STEP = grid
    natural._grid.cache_clear()
    start = time.perf_counter()
    if sidereal == 0:
        values = np.array(
            [
                natural.natural_reading(instrument, t, x, y)
                for t, x, y in zip(times, lon, lat, strict=True)
            ]
        )
    else:
        natural.SIDEREAL_STEP, natural.LATITUDE_STEP = sidereal, sidereal / 2
        values = natural.natural_readings(instrument, times, lon, lat)
    return values, (time.perf_counter() - start) / len(times)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="50 readings")
    args = harness.parse_args(parser)
    data = readings(50 if args.quick else 200)
    defaults = (natural.SKY_GRID_STEP, natural.SIDEREAL_STEP, natural.LATITUDE_STEP)
    rows = []
    for instrument in ("sqm-l", "sqm"):
        reference, _ = skies(instrument, 0.5, 0, data)
        for grid in (1.0, 2.0, 4.0):
            for sidereal in (0, 0.5, 2.0, 8.0):
                values, seconds = skies(instrument, grid, sidereal, data)
                error = luminance_to_magnitude(values) - luminance_to_magnitude(reference)
                rows.append(
                    {
                        "instrument": instrument,
                        "grid_step_deg": grid,
                        "sidereal_step_deg": sidereal,
                        "seconds_per_reading": seconds,
                        "max_abs_error_mag": float(np.max(np.abs(error))),
                    }
                )
    natural.SKY_GRID_STEP, natural.SIDEREAL_STEP, natural.LATITUDE_STEP = defaults
    payload = {
        "readings": len(data[0]),
        "defaults": {"grid_step_deg": defaults[0], "sidereal_step_deg": defaults[1]},
        "rows": rows,
    }
    harness.write_results(args.out, "meter_natural", payload, quick=args.quick, plot=plot)


def plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained", sharey=True)
    for ax, instrument in zip(axes, ("sqm-l", "sqm"), strict=True):
        for grid, marker in ((1.0, "o"), (2.0, "s"), (4.0, "^")):
            points = [
                r
                for r in document["rows"]
                if r["instrument"] == instrument and r["grid_step_deg"] == grid
            ]
            ax.plot(
                [r["seconds_per_reading"] for r in points],
                [max(r["max_abs_error_mag"], 1e-5) for r in points],
                marker=marker,
                label=f"grid {grid:g} deg (sidereal step 0, 0.5, 2, 8 deg)",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"{instrument}: default grid 2 deg, sidereal step 2 deg", fontsize=10)
        ax.set_xlabel("time per reading [s]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("max |error| vs 0.5 deg grid, own skies [mag arcsec$^{-2}$]")
    return fig


if __name__ == "__main__":
    main()
