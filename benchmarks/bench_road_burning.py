"""Benchmark: the sampling step of the photocell's burning hours (``step_minutes``).

:func:`nightlights.roads.burning_intervals` samples the Sun's elevation every ``step_minutes``
over a year, bisects every sample interval that straddles the switch elevation and refines
every sampled extremum that stays on one side (a graze shorter than a step). The step should
set only the speed; this benchmark checks that it does, at latitudes from the equator to the
edge of the polar day and night (0, 35 S and 67 S, 40, 60, seven latitudes from 65.5 to 70,
and 78 N, longitude 25 E, 2025; around the polar circle a graze of the switch elevation lasts
less than a step):

- error: the largest difference of the annual burning hours, and of the number of switching
  intervals, against a step of :data:`REFERENCE_STEP` minutes [s];
- time: one year at each latitude (best of 3) [s].

Run: ``python benchmarks/bench_road_burning.py [--quick] [--out DIR]`` (``--quick``: three
latitudes). Writes ``road_burning.json`` and ``.png``.
"""

from __future__ import annotations

from typing import Any

import _harness as harness

#: Steps swept [min] and the reference.
STEPS = (60.0, 30.0, 10.0, 5.0, 2.0, 1.0)
REFERENCE_STEP = 0.25
#: Latitudes [deg] (negative south), at one longitude [deg] and year.
LATITUDES = (0.0, -35.0, 40.0, 60.0, 65.5, 66.0, 66.5, 67.0, 67.5, 68.5, 70.0, 78.0, -67.0)
LONGITUDE, YEAR = 25.0, 2025


def sweep(latitudes: tuple[float, ...]) -> list[dict[str, Any]]:
    from nightlights.roads import burning_intervals

    reference = {
        lat: burning_intervals(LONGITUDE, lat, YEAR, step_minutes=REFERENCE_STEP)
        for lat in latitudes
    }
    rows = []
    for step in STEPS:
        hours_error = 0.0
        intervals_changed = 0
        seconds = 0.0
        for lat in latitudes:
            timing = harness.repeat(
                lambda lat=lat, s=step: burning_intervals(LONGITUDE, lat, YEAR, step_minutes=s), 3
            )
            got = timing.value
            seconds += timing.best
            ref = reference[lat]
            hours_error = max(hours_error, abs(got.total_hours - ref.total_hours) * 3600.0)
            intervals_changed += abs(len(got.on) - len(ref.on))
        rows.append(
            {
                "step_minutes": step,
                "seconds_per_year": seconds / len(latitudes),
                "worst_hours_error_s": hours_error,
                "intervals_changed": intervals_changed,
            }
        )
        print(
            f"step {step:5.1f} min: {seconds / len(latitudes):.3f} s per year, worst "
            f"{hours_error:.2e} s, intervals changed {intervals_changed}"
        )
    return rows


def plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    figure, axis = plt.subplots(figsize=(6.5, 4.2))
    rows = document["rows"]
    xs = [r["seconds_per_year"] for r in rows]
    ys = [max(r["worst_hours_error_s"], 1e-6) for r in rows]
    axis.plot(xs, ys, "o-")
    for r, x, y in zip(rows, xs, ys, strict=True):
        label = f"{r['step_minutes']:g} min"
        axis.annotate(label, (x, y), fontsize=8, xytext=(4, 4), textcoords="offset points")
        if r["step_minutes"] == document["default_step_minutes"]:
            axis.plot(x, y, "r*", ms=14)
    axis.set_yscale("log")
    axis.set_xlabel("time per year [s]")
    axis.set_ylabel("worst error of the annual hours [s]\n(identical to the ms: at 1e-6)")
    axis.set_title(
        f"photocell sampling step vs {REFERENCE_STEP:g} min, {len(document['latitudes'])} "
        "latitudes (star: default)",
        fontsize=9,
    )
    figure.tight_layout()
    return figure


def main() -> None:
    from nightlights.roads._burning import STEP_MINUTES

    parser = harness.argument_parser(__doc__, quick="three latitudes")
    args = harness.parse_args(parser)
    latitudes = LATITUDES[::4] if args.quick else LATITUDES
    payload = {
        "reference_step_minutes": REFERENCE_STEP,
        "default_step_minutes": STEP_MINUTES,
        "latitudes": list(latitudes),
        "longitude": LONGITUDE,
        "year": YEAR,
        "rows": sweep(latitudes),
    }
    harness.write_results(args.out, "road_burning", payload, quick=args.quick, plot=plot)


if __name__ == "__main__":
    main()
