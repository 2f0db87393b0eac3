"""Clouds: the zenith amplification under a 1 km overcast deck, and the analytic model against
its Monte Carlo.

City: a uniform Lambertian disc 10 km across (radius 5 km) on a flat Earth, turbidity 2,
550 nm. Its flux is set so that the clear zenith at its centre (single scattering, the
clear-sky kernel's integral) reads 18.0 mag arcsec-2 with the natural sky (22.0 mag arcsec-2,
171 ucd m-2) added: a bright city centre.

1. Amplification against the distance from the centre, 0-60 km: (cloudy artificial + natural
   x :meth:`~nightlights.sky.clouds.CloudLayer.natural_sky_factor`) / (clear artificial +
   natural), for a deck at 1 km of optical depth 15 (two-stream R = 0.53, ground albedo 0.15),
   and the artificial-only ratio; compared with the measured range 3-10 (Kyba et al. 2011,
   Jechow et al. 2017).
2. Analytic model (:func:`~nightlights.sky.clouds.cloud_luminance` over the disc) against the
   Monte Carlo (:func:`~nightlights.sky.clouds_montecarlo.cloudy_monte_carlo`, all orders) at
   1-50 km from the centre, the zenith and 45 deg up towards the city, for base heights 1 and
   3 km and cloud optical depths 5 and 30; and the Monte Carlo's flux closure.

Run: ``python benchmarks/bench_sky_clouds.py [--quick] [--out DIR]``
(``--quick``: 4000 photons instead of 40000, 12 distances instead of 61).
Writes ``sky_clouds.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

from typing import Any

import _harness as harness
import numpy as np

from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer, cloud_luminance, cloud_profiles, disc_luminance
from nightlights.sky.clouds_montecarlo import cloudy_monte_carlo
from nightlights.sky.kernel import sky_luminance

RADIUS = 5000.0  # city radius [m]
NATURAL = 1.08e5 * 10 ** (-0.4 * 22.0)  # natural sky, 22.0 mag arcsec-2 [cd m-2]
CENTRE_CLEAR = 1.08e5 * 10 ** (-0.4 * 18.0)  # clear zenith with natural at the centre [cd m-2]
MC_KM = (1.0, 5.0, 10.0, 20.0, 50.0)
HEIGHTS = (1000.0, 3000.0)
HALF_WIDTH = 80e3  # bounce grid half-width, past the farthest cloud point [m]
DEPTHS = (5.0, 30.0)


def _point(cloud: CloudLayer, atmosphere: Atmosphere) -> Any:
    profiles = cloud_profiles(cloud, atmosphere, half_width=HALF_WIDTH)
    return lambda e, a, r: cloud_luminance(e, a, r, cloud, atmosphere, profiles=profiles)


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="4000 photons, 12 distances")
    args = harness.parse_args(parser)
    atmosphere = Atmosphere(flat_earth=True)
    photons = 4000 if args.quick else 40000
    distances = np.linspace(0.0, 60e3, 12 if args.quick else 61)

    def clear(e: Any, a: Any, r: Any) -> Any:
        return sky_luminance(e, a, r, atmosphere=atmosphere)

    with harness.Stopwatch() as watch:
        deck = CloudLayer(1000.0, optical_depth=15.0)
        cloudy = _point(deck, atmosphere)
        clear_zenith = np.array([disc_luminance(clear, 90.0, 0.0, d, RADIUS) for d in distances])
        cloudy_zenith = np.array([disc_luminance(cloudy, 90.0, 0.0, d, RADIUS) for d in distances])
        flux = (CENTRE_CLEAR - NATURAL) / clear_zenith[0]  # [lm]
        natural_cloudy = NATURAL * deck.natural_sky_factor()
        amplification = (flux * cloudy_zenith + natural_cloudy) / (flux * clear_zenith + NATURAL)
        artificial = cloudy_zenith / clear_zenith
    curve_seconds = watch.seconds
    comparisons = []
    for height in HEIGHTS:
        for depth in DEPTHS:
            cloud = CloudLayer(height, optical_depth=depth)
            point = _point(cloud, atmosphere)
            rows = []
            elevation = np.repeat([90.0, 45.0], len(MC_KM))
            km = np.tile(MC_KM, 2)
            with harness.Stopwatch() as mc_watch:
                mc = cloudy_monte_carlo(
                    elevation,
                    0.0,
                    km * 1e3,
                    cloud,
                    atmosphere=atmosphere,
                    disc_radius=RADIUS,
                    photons=photons,
                    seed=7,
                )
            for i, (e, d) in enumerate(zip(elevation, km, strict=True)):
                analytic = disc_luminance(point, float(e), 0.0, float(d) * 1e3, RADIUS)
                rows.append(
                    {
                        "elevation_deg": float(e),
                        "distance_km": float(d),
                        "analytic": analytic,
                        "monte_carlo": float(mc.luminance[i]),
                        "monte_carlo_error": float(mc.standard_error[i]),
                        "relative_difference": analytic / float(mc.luminance[i]) - 1.0,
                    }
                )
            budget = mc.flux
            comparisons.append(
                {
                    "base_height_m": height,
                    "optical_depth": depth,
                    "reflectance": cloud.reflectance,
                    "rows": rows,
                    "monte_carlo_seconds": mc_watch.seconds,
                    "monte_carlo_flux": budget,
                    "closure_error": budget["escaping"]
                    + budget["ground_absorbed"]
                    + budget["air_absorbed"]
                    + budget["cloud_absorbed"]
                    + budget["in_flight"]
                    - 1.0,
                }
            )
    worst = max(abs(r["relative_difference"]) for c in comparisons for r in c["rows"])
    result = {
        "city_radius_m": RADIUS,
        "city_flux_lm": float(flux),
        "natural_cd_m2": NATURAL,
        "deck": {"base_height_m": 1000.0, "optical_depth": 15.0, "reflectance": deck.reflectance},
        "distance_km": (distances / 1e3).tolist(),
        "clear_zenith_cd_m2": (flux * clear_zenith + NATURAL).tolist(),
        "cloudy_zenith_cd_m2": (flux * cloudy_zenith + natural_cloudy).tolist(),
        "amplification": amplification.tolist(),
        "artificial_amplification": artificial.tolist(),
        "amplification_centre": float(amplification[0]),
        "amplification_max": float(amplification.max()),
        "amplification_max_km": float(distances[int(np.argmax(amplification))] / 1e3),
        "below_one_from_km": float(distances[int(np.argmax(amplification < 1.0))] / 1e3),
        "curve_seconds": curve_seconds,
        "photons": photons,
        "comparisons": comparisons,
        "worst_relative_difference": worst,
    }
    harness.write_results(args.out, "sky_clouds", result, quick=args.quick, plot=plot)


def plot(result: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    km = np.array(result["distance_km"])
    left.plot(km, result["amplification"], "k-", label="with natural sky")
    left.plot(km, result["artificial_amplification"], "b--", label="artificial only")
    left.axhspan(3.0, 10.0, color="orange", alpha=0.2, label="measured 3-10 (city centres)")
    left.axhline(1.0, color="grey", lw=0.8)
    left.axvline(result["city_radius_m"] / 1e3, color="grey", ls=":", label="city edge")
    left.set_yscale("log")
    left.set_xlabel("distance from the city centre [km]")
    left.set_ylabel("zenith cloudy / clear")
    left.set_title("1 km overcast deck (tau 15) over a 10 km city")
    left.legend(fontsize=8)
    markers = {90.0: "o", 45.0: "s"}
    for c in result["comparisons"]:
        for e in (90.0, 45.0):
            rows = [r for r in c["rows"] if r["elevation_deg"] == e]
            right.plot(
                [r["distance_km"] for r in rows],
                [100 * r["relative_difference"] for r in rows],
                marker=markers[e],
                label=f"H {c['base_height_m'] / 1e3:g} km, tau {c['optical_depth']:g}, "
                f"{'zenith' if e == 90 else '45 deg'}",
            )
    right.axhspan(-10, 10, color="green", alpha=0.1)
    right.set_xscale("log")
    right.set_xlabel("distance from the city centre [km]")
    right.set_ylabel("analytic / Monte Carlo - 1 [%]")
    right.set_title("analytic model against Monte Carlo")
    right.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
