"""Multiple scattering: all orders over single scattering against distance, by Monte Carlo.

Knob: the scattering orders kept. :func:`nightlights.sky.montecarlo.monte_carlo_luminance`
follows photons from a ground point source through the kernel's atmosphere (sphere) and
estimates the luminance per order along view rays at the zenith and 45 deg up towards and
away from the source, 1-300 km away. Cases: turbidity T = 2 (the kernel's default atmosphere)
and Garstang's clarity K = 1 (:func:`nightlights.sky.atmosphere.garstang_atmosphere`), each
for a Lambertian source and Garstang's psi^4 lobe; Garstang's emission function (F = G = 0.15)
is their mix (:func:`nightlights.sky.kernel.garstang_weights`; the runs are independent, so
the errors add in quadrature). Reported per ray: the ratio (all orders) / (single) with its standard
error, and (orders 1 + 2) / (single), the quantity of Garstang's (1986) double-scattering
factor (about 1.6 at 10 km, 1.95 at 50 km, 2.5 at 150 km for K = 1, values quoted from his
paper at second hand and not re-read here).

Error against cost (T = 2, Lambertian; reference: the main run): single scattering alone
(error 1 - 1 / ratio); single scattering times a smooth factor fitted to the reference ratio
(cubic in ln r per view direction, weights 1 / SE^2; its error is the fit's deviation from the
reference, which includes the reference's own noise); the full Monte Carlo at fewer photons
(other seeds). Cost per view ray: the kernel's time per ray (the factor is a table look-up),
and the Monte Carlo's run time divided by the rays it serves.

Split re-estimate (``--add-split``, added to the previous results): the T = 2 cases' own
photon histories (same photons and seed) estimated again with azimuthal splitting
(:func:`nightlights.sky.montecarlo.monte_carlo_luminance`, ``split_window``), stored under
each case's ``split``; the plain estimates stay the reference of this page.

Run: ``python benchmarks/bench_sky_multiple_scattering.py [--quick] [--add-split] [--out DIR]``
(``--quick``: 4,000 photons per case, a two-point cost sweep).
Writes ``sky_multiple_scattering.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import _harness as harness
import numpy as np

from nightlights.sky import multiple
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere
from nightlights.sky.kernel import garstang_weights, sky_luminance
from nightlights.sky.montecarlo import monte_carlo_luminance

DISTANCES_KM = (1, 2, 3, 5, 7, 10, 15, 20, 30, 50, 70, 100, 150, 200, 300)
#: View directions (elevation, azimuth relative to the source) [deg].
DIRECTIONS = ((90.0, 0.0), (45.0, 0.0), (45.0, 180.0))
EMISSIONS = ("lambertian", "garstang_lobe")
#: Garstang's (1986) double-scattering factors for K = 1, quoted at second hand [km, 1].
GARSTANG_DOUBLE = ((10, 1.6), (50, 1.95), (150, 2.5))
MAX_ORDER = 50
#: Distances of the documentation's ratio table [km].
SHOWN_KM = (1, 3, 10, 30, 50, 100, 150, 300)


def rays() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = np.array(DISTANCES_KM, dtype=float) * 1e3
    el = np.repeat(np.array([d[0] for d in DIRECTIONS]), r.size)
    az = np.repeat(np.array([d[1] for d in DIRECTIONS]), r.size)
    return el, az, np.tile(r, len(DIRECTIONS))


def run(atmosphere: Atmosphere, emission: str, photons: int, seed: int) -> dict:
    el, az, r = rays()
    mc, seconds = harness.timed(
        lambda: monte_carlo_luminance(
            el,
            az,
            r,
            atmosphere=atmosphere,
            emission=emission,
            photons=photons,
            max_order=MAX_ORDER,
            seed=seed,
        )
    )
    single = mc.single
    return {
        "photons": photons,
        "seed": seed,
        "seconds": seconds,
        "events": mc.events,
        "flux": mc.flux,
        "single": single.tolist(),
        "total": mc.total.tolist(),
        "total_se": mc.total_standard_error.tolist(),
        "order2": mc.luminance[1].tolist(),
        "order2_se": mc.standard_error[1].tolist(),
        "ratio": mc.ratio.tolist(),
        "ratio_se": mc.ratio_standard_error.tolist(),
        "ratio_orders_1_2": ((single + mc.luminance[1]) / single).tolist(),
        "ratio_orders_1_2_se": (mc.standard_error[1] / single).tolist(),
    }


def mix(rows: dict[str, dict]) -> dict:
    """Garstang's emission function (F = G = 0.15) from the Lambertian and lobe runs."""
    weights = garstang_weights(0.15, 0.15)
    single = sum(weights[e] * np.array(rows[e]["single"]) for e in EMISSIONS)
    total = sum(weights[e] * np.array(rows[e]["total"]) for e in EMISSIONS)
    order2 = sum(weights[e] * np.array(rows[e]["order2"]) for e in EMISSIONS)
    se = np.sqrt(sum((weights[e] * np.array(rows[e]["total_se"])) ** 2 for e in EMISSIONS))
    se2 = np.sqrt(sum((weights[e] * np.array(rows[e]["order2_se"])) ** 2 for e in EMISSIONS))
    return {
        "weights": weights,
        "ratio": (total / single).tolist(),
        "ratio_se": (se / single).tolist(),
        "ratio_orders_1_2": ((single + order2) / single).tolist(),
        "ratio_orders_1_2_se": (se2 / single).tolist(),
    }


def fitted_factor(ratio: np.ndarray, se: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, list]:
    """Cubic in ln r per view direction, weighted by 1 / SE^2, fitted to the ratio."""
    fit = np.zeros_like(ratio)
    coefficients = []
    n = r.size // len(DIRECTIONS)
    for i in range(len(DIRECTIONS)):
        sl = slice(i * n, (i + 1) * n)
        x = np.log(r[sl] / 1e3)
        w = 1.0 / np.maximum(se[sl], 1e-3 * ratio[sl])
        c = np.polynomial.polynomial.polyfit(x, ratio[sl], 3, w=w)
        fit[sl] = np.polynomial.polynomial.polyval(x, c)
        coefficients.append(c.tolist())
    return fit, coefficients


def error_against_cost(reference: dict, sweep: list[int], kernel_seconds: float) -> dict:
    _, _, r = rays()
    n_rays = r.size
    total_ref = np.array(reference["total"])
    ratio = np.array(reference["ratio"])
    se = np.array(reference["ratio_se"])
    near = r <= 100e3
    fit, coefficients = fitted_factor(ratio, se, r)

    def summary(err: np.ndarray) -> dict:
        return {
            "median_all": float(np.median(err)),
            "median_to_100km": float(np.median(err[near])),
            "max_to_100km": float(np.max(err[near])),
        }

    out = {
        "kernel_seconds_per_ray": kernel_seconds / n_rays,
        "reference_relative_se": summary(np.array(reference["total_se"]) / total_ref),
        "single": summary(1.0 - 1.0 / ratio),
        "single_times_factor": {
            **summary(np.abs(fit / ratio - 1.0)),
            "coefficients_ln_km": dict(
                zip((f"{e:g}/{a:g}" for e, a in DIRECTIONS), coefficients, strict=True)
            ),
        },
        "monte_carlo": [],
    }
    for i, photons in enumerate(sweep):
        row = run(Atmosphere(), "lambertian", photons, seed=100 + i)
        total = np.array(row["total"])
        out["monte_carlo"].append(
            {
                "photons": photons,
                "seconds": row["seconds"],
                "seconds_per_ray": row["seconds"] / n_rays,
                "deviation_from_reference": summary(np.abs(total / total_ref - 1.0)),
                "relative_se": summary(np.array(row["total_se"]) / total),
            }
        )
        print("sweep", photons, out["monte_carlo"][-1], flush=True)
    return out


def _cell(values: list, errors: list, index: int) -> str:
    return f"{values[index]:.2f} ± {errors[index]:.2f}"


def tables(result: dict) -> dict:
    """Records for the documentation's tables (json-table markers)."""
    el = np.array(result["ray_elevation_deg"])
    az = np.array(result["ray_azimuth_deg"])
    km = np.array(result["ray_distance_km"])
    ratio_rows, runs = [], []
    for label, case in result["cases"].items():
        for key in (*EMISSIONS, "garstang_mix"):
            for elevation, azimuth in DIRECTIONS:
                row = {
                    "atmosphere": label,
                    "emission": key,
                    "elevation_deg": elevation,
                    "azimuth_deg": azimuth,
                }
                for d in SHOWN_KM:
                    here = (el == elevation) & (az == azimuth) & (km == d)
                    i = int(np.flatnonzero(here)[0])
                    row[f"{d} km"] = _cell(case[key]["ratio"], case[key]["ratio_se"], i)
                ratio_rows.append(row)
        for key in EMISSIONS:
            run_row = case[key]
            runs.append(
                {
                    "atmosphere": label,
                    "emission": key,
                    "photons": run_row["photons"],
                    "seconds": run_row["seconds"],
                    "events": run_row["events"],
                    "rays": int(km.size),
                    "flux_top": run_row["flux"]["top"],
                    "flux_ground": run_row["flux"]["ground"],
                    "flux_absorbed": run_row["flux"]["absorbed"],
                }
            )
    k1 = result["cases"]["K = 1"]["garstang_mix"]
    comparison = []
    for d, quoted in GARSTANG_DOUBLE:
        i = int(np.flatnonzero((el == 90.0) & (az == 0.0) & (km == d))[0])
        comparison.append(
            {
                "distance_km": d,
                "garstang_quoted": quoted,
                "orders_1_2": _cell(k1["ratio_orders_1_2"], k1["ratio_orders_1_2_se"], i),
                "all_orders": _cell(k1["ratio"], k1["ratio_se"], i),
            }
        )
    cost = result["error_against_cost"]
    kernel = cost["kernel_seconds_per_ray"]
    cost_rows = [
        {"method": "single scattering", "seconds_per_ray": kernel, **cost["single"]},
        {
            "method": "single x fitted factor",
            "seconds_per_ray": kernel,
            **{k: v for k, v in cost["single_times_factor"].items() if k.startswith("m")},
        },
    ]
    for row in cost["monte_carlo"]:
        cost_rows.append(
            {
                "method": f"Monte Carlo, {row['photons']:,} photons (SE)",
                "seconds_per_ray": row["seconds_per_ray"],
                **row["relative_se"],
            }
        )
    return {
        "ratio_table": ratio_rows,
        "garstang_comparison": comparison,
        "cost_table": cost_rows,
        "runs": runs,
    }


def add_split(result: dict, labels: tuple[str, ...] = ("T = 2",)) -> None:
    """Re-estimate the cases' own photon histories (same photons, same seed) with azimuthal
    splitting (:data:`nightlights.sky.multiple.SPLIT_WINDOW`), in place under ``"split"``:
    the plain estimator's heavy tail makes its far values and their standard errors
    uncertain; the split estimate of the same events has a much lighter one."""
    el, az, r = rays()
    for label in labels:
        atmosphere = {"T = 2": Atmosphere(), "K = 1": garstang_atmosphere(1.0)}[label]
        for emission in EMISSIONS:
            case = result["cases"][label][emission]
            mc, seconds = harness.timed(
                lambda a=atmosphere, e=emission, c=case: monte_carlo_luminance(
                    el,
                    az,
                    r,
                    atmosphere=a,
                    emission=e,
                    photons=c["photons"],
                    max_order=MAX_ORDER,
                    seed=c["seed"],
                    split_window=multiple.SPLIT_WINDOW,
                    split_points=multiple.SPLIT_POINTS,
                )
            )
            case["split"] = {
                "split_window": multiple.SPLIT_WINDOW,
                "split_points": multiple.SPLIT_POINTS,
                "seconds": seconds,
                "events": mc.events,
                "total": mc.total.tolist(),
                "total_se": mc.total_standard_error.tolist(),
                "ratio": mc.ratio.tolist(),
                "ratio_se": mc.ratio_standard_error.tolist(),
            }
            print(label, emission, "split", round(seconds, 1), flush=True)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="4,000 photons per case, two sweep points")
    parser.add_argument(
        "--add-split",
        action="store_true",
        help="only add the split re-estimate of the T = 2 cases to the previous results",
    )
    args = harness.parse_args(parser)
    if args.add_split:
        previous = harness.previous_results("sky_multiple_scattering", args.out)
        if previous is None:
            raise SystemExit("no previous results to add the split re-estimate to")
        payload = {k: v for k, v in previous.items() if k not in ("benchmark", "quick", "machine")}
        add_split(payload)
        harness.write_results(
            args.out, "sky_multiple_scattering", payload, quick=previous["quick"], plot=plot
        )
        return
    photons = {"lambertian": 4_000, "garstang_lobe": 4_000}
    sweep = [1_000, 4_000]
    if not args.quick:
        photons = {"lambertian": 300_000, "garstang_lobe": 150_000}
        sweep = [1_000, 3_000, 10_000, 30_000]
    monte_carlo_luminance(90.0, 0.0, 1e3, photons=10, max_order=3)  # compile
    el, az, r = rays()
    result: dict = {
        "distances_km": list(DISTANCES_KM),
        "directions_deg": [list(d) for d in DIRECTIONS],
        "ray_elevation_deg": el.tolist(),
        "ray_azimuth_deg": az.tolist(),
        "ray_distance_km": (r / 1e3).tolist(),
        "max_order": MAX_ORDER,
        "garstang_double_scattering_quoted": GARSTANG_DOUBLE,
        "cases": {},
    }
    atmospheres = {"T = 2": Atmosphere(), "K = 1": garstang_atmosphere(1.0)}
    for label, atmosphere in atmospheres.items():
        rows = {}
        for emission in EMISSIONS:
            rows[emission] = run(atmosphere, emission, photons[emission], seed=0)
            print(label, emission, rows[emission]["seconds"], flush=True)
        result["cases"][label] = {
            "atmosphere": atmosphere.parameters(),
            **rows,
            "garstang_mix": mix(rows),
        }
    sky_luminance(el, az, r)  # compile
    kernel = harness.repeat(lambda: sky_luminance(el, az, r), repeats=5)
    result["error_against_cost"] = error_against_cost(
        result["cases"]["T = 2"]["lambertian"], sweep, kernel.best
    )
    result.update(tables(result))
    result["note"] = (
        "Standard errors are those of the mean over photons; the ray-integrated estimator has "
        "a heavy tail (events passing near a view ray), so errors from few photons are "
        "themselves uncertain. Timings from a shared 2-core machine, noisy."
    )
    harness.write_results(args.out, "sky_multiple_scattering", result, quick=args.quick, plot=plot)


def plot(result: dict):
    plt = harness.pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(13, 10))
    axes = axes.ravel()
    d = np.array(result["ray_distance_km"])
    ray_el = np.array(result["ray_elevation_deg"])
    ray_az = np.array(result["ray_azimuth_deg"])
    styles = {"lambertian": "o-", "garstang_lobe": "s--", "garstang_mix": "^-"}
    for ax, (el, az) in zip(axes[:3], result["directions_deg"], strict=True):
        sel = (ray_el == el) & (ray_az == az)
        for label, case in result["cases"].items():
            for key, style in styles.items():
                row = case[key]
                ax.errorbar(
                    d[sel],
                    np.array(row["ratio"])[sel],
                    yerr=np.array(row["ratio_se"])[sel],
                    fmt=style,
                    ms=3,
                    capsize=2,
                    label=f"{label}, {key.replace('_', ' ')}",
                )
        k1 = result["cases"]["K = 1"]["garstang_mix"]
        ax.errorbar(
            d[sel],
            np.array(k1["ratio_orders_1_2"])[sel],
            yerr=np.array(k1["ratio_orders_1_2_se"])[sel],
            fmt="x:",
            color="k",
            capsize=2,
            label="K = 1, Garstang mix, orders 1+2 only",
        )
        if el == 90.0 and az == 0.0:
            gd = np.array(result["garstang_double_scattering_quoted"], dtype=float)
            ax.plot(gd[:, 0], gd[:, 1], "kD", ms=7, mfc="none", label="Garstang 1986 (quoted)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("distance of the source [km]")
        ax.set_ylabel("(all orders) / (single scattering)")
        side = "zenith" if el == 90.0 else ("towards" if az == 0.0 else "away from")
        ax.set_title(f"elevation {el:g} deg, {side} the source" if el != 90.0 else "zenith")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=6)
    ax = axes[3]
    cost = result["error_against_cost"]
    kernel = cost["kernel_seconds_per_ray"]
    for key, marker in (("median_to_100km", "o"), ("median_all", "s")):
        ax.loglog(kernel, cost["single"][key], "r" + marker, label=f"single ({key})")
        ax.loglog(
            kernel, cost["single_times_factor"][key], "g" + marker, label=f"single x factor ({key})"
        )
        mc = cost["monte_carlo"]
        ax.loglog(
            [m["seconds_per_ray"] for m in mc],
            [m["relative_se"][key] for m in mc],
            "b" + marker + "-",
            label=f"Monte Carlo, relative SE ({key})",
        )
    ax.axhline(cost["reference_relative_se"]["median_to_100km"], color="grey", ls=":")
    ax.set_xlabel("cost per view ray [s]")
    ax.set_ylabel("relative error of the total luminance")
    ax.set_title("T = 2, Lambertian: error against cost")
    ax.legend(fontsize=6)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
