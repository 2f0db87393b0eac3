"""Skyglow model pieces: how much each one changes the luminance of a point source, 1-300 km.

Base: the toolkit's default single-scattering kernel (spherical Earth, extinction on both legs,
turbidity 2, Lambertian emission). Each variant changes one piece: Earth curvature (flat
Earth), extinction (off), aerosols (turbidity 1 = pure air, Garstang's K = 1), emission
function (direct-uplight sin^4 lobe, Garstang's 1986 function for F = G = 0.15), and all of
Garstang's choices together (K = 1 with his emission function), multiple scattering (all orders:
the single-scattering luminance times the Monte Carlo factor of :mod:`nightlights.sky.multiple`),
and everything together (K = 1, Garstang's emission, multiple scattering). Measured: the ratio
variant / base of the luminance at the zenith and 45 deg up towards the source, per lumen of a
ground point source; the distance slopes of every configuration (10-50 km at 45 deg: Walker's law;
zenith 10-50 and 50-150 km); and the table of atmosphere descriptions
(:func:`nightlights.sky.atmosphere.atmosphere_conversion_table`).

Run: ``python benchmarks/bench_sky_model_pieces.py [--quick] [--out DIR]``
(``--quick``: 20 distances instead of 60).
Writes ``sky_model_pieces.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

from collections.abc import Callable

import _harness as harness
import numpy as np

from nightlights.sky.atmosphere import Atmosphere, atmosphere_conversion_table, garstang_atmosphere
from nightlights.sky.kernel import garstang_weights, sky_luminance
from nightlights.sky.multiple import multiple_scattering_factor

#: Garstang's (1986) emission function, F = G = 0.15, as weights of unit-flux shapes.
GARSTANG_MIX = garstang_weights(0.15, 0.15)
#: (label, atmosphere, emission) of each configuration; the first is the base.
CONFIGURATIONS: tuple[tuple[str, Atmosphere, str], ...] = (
    ("base: sphere, extinction, T = 2, Lambertian", Atmosphere(), "lambertian"),
    ("flat Earth", Atmosphere(flat_earth=True), "lambertian"),
    ("no extinction", Atmosphere(extinction=False), "lambertian"),
    ("T = 1 (pure air)", Atmosphere(turbidity=1.0), "lambertian"),
    ("Garstang K = 1", garstang_atmosphere(1.0), "lambertian"),
    ("uplight sin^4 lobe", Atmosphere(), "uplight"),
    ("Garstang emission F = G = 0.15", Atmosphere(), "garstang"),
    ("Garstang K = 1 and emission", garstang_atmosphere(1.0), "garstang"),
    ("multiple scattering (Monte Carlo factor)", Atmosphere(), "lambertian+multiple"),
    ("all: K = 1, Garstang emission, multiple", garstang_atmosphere(1.0), "garstang+multiple"),
)
DIRECTIONS = (("zenith", 90.0), ("45 deg towards the source", 45.0))
#: Distances at which the docs table reads the ratios [km].
TABLE_KM = (1, 10, 50, 100, 300)


def luminance_function(atmosphere: Atmosphere, emission: str) -> Callable[..., np.ndarray]:
    """Luminance per lumen [cd m-2 lm-1] at (elevation [deg], distances [m])."""

    shapes, _, multiple = emission.partition("+")

    def one(shape: str, elevation: float, distance: np.ndarray) -> np.ndarray:
        value = sky_luminance(elevation, 0.0, distance, atmosphere=atmosphere, emission=shape)
        if multiple:
            value = value * multiple_scattering_factor(atmosphere, shape, elevation, 0.0, distance)
        return np.asarray(value)

    def luminance(elevation: float, distance: np.ndarray) -> np.ndarray:
        if shapes == "garstang":
            return np.asarray(
                sum(
                    weight * one(shape, elevation, distance)
                    for shape, weight in GARSTANG_MIX.items()
                )
            )
        return one(shapes, elevation, distance)

    return luminance


def slope(luminance: Callable[..., np.ndarray], elevation: float, low: float, high: float) -> float:
    """Least-squares slope of ln L against ln D at five log-spaced distances [1]."""
    distance = np.geomspace(low, high, 5)
    return float(np.polyfit(np.log(distance), np.log(luminance(elevation, distance)), 1)[0])


def main() -> None:
    parser = harness.argument_parser(__doc__, quick="20 distances instead of 60")
    args = harness.parse_args(parser)
    distance = np.geomspace(1e3, 3e5, 20 if args.quick else 60)
    sky_luminance(90.0, 0.0, 1e4)  # compile
    curves: dict[str, dict[str, list[float]]] = {}
    with harness.Stopwatch() as watch:
        for label, atmosphere, emission in CONFIGURATIONS:
            luminance = luminance_function(atmosphere, emission)
            curves[label] = {
                name: luminance(elevation, distance).tolist() for name, elevation in DIRECTIONS
            }
    base = curves[CONFIGURATIONS[0][0]]
    ratios = {
        label: {
            name: (np.asarray(curve[name]) / np.asarray(base[name])).tolist()
            for name, _ in DIRECTIONS
        }
        for label, curve in curves.items()
    }
    table = []
    reference = luminance_function(CONFIGURATIONS[0][1], CONFIGURATIONS[0][2])
    at = np.array(TABLE_KM, dtype=float) * 1e3
    for label, atmosphere, emission in CONFIGURATIONS[1:]:
        luminance = luminance_function(atmosphere, emission)
        for name, elevation in DIRECTIONS:
            values = luminance(elevation, at) / reference(elevation, at)
            row: dict = {"piece": label, "direction": name}
            row.update({f"at_{km}_km": float(v) for km, v in zip(TABLE_KM, values, strict=True)})
            table.append(row)
    slopes = []
    for label, atmosphere, emission in CONFIGURATIONS:
        luminance = luminance_function(atmosphere, emission)
        near = slope(luminance, 90.0, 10e3, 50e3)
        far = slope(luminance, 90.0, 50e3, 150e3)
        slopes.append(
            {
                "configuration": label,
                "walker_45_deg_10_50_km": slope(luminance, 45.0, 10e3, 50e3),
                "zenith_10_50_km": near,
                "zenith_50_150_km": far,
                "zenith_steepening": far - near,
            }
        )
        print(slopes[-1], flush=True)
    result = {
        "distance_m": distance.tolist(),
        "directions": [name for name, _ in DIRECTIONS],
        "luminance_cd_m2_per_lm": curves,
        "ratio_to_base": ratios,
        "ratio_table": table,
        "slopes": slopes,
        "garstang_emission_weights": GARSTANG_MIX,
        "conversion_table": atmosphere_conversion_table(),
        "seconds": watch.seconds,
        "note": (
            "Single scattering unless the label says multiple (single x the shipped Monte "
            "Carlo factor of nightlights.sky.multiple, all orders). Garstang emission: "
            "Lambertian x "
            f"{GARSTANG_MIX['lambertian']:.3f} + garstang_lobe x "
            f"{GARSTANG_MIX['garstang_lobe']:.3f}. K = 1: Garstang's atmosphere with his "
            "aerosol phase function replaced by Henyey-Greenstein g = 0.687."
        ),
    }
    harness.write_results(args.out, "sky_model_pieces", result, quick=args.quick, plot=plot)


def plot(result: dict):
    plt = harness.pyplot()
    distance_km = np.asarray(result["distance_m"]) / 1e3
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.4), sharey=True)
    styles = ["-", "-", "-", "--", "--", ":", ":", "-.", "-", "-."]
    for ax, direction in zip(axes, result["directions"], strict=True):
        for (label, ratio), style in zip(
            list(result["ratio_to_base"].items())[1:], styles[1:], strict=True
        ):
            ax.loglog(distance_km, ratio[direction], style, label=label)
        ax.axhline(1.0, color="black", lw=0.8)
        ax.set_xlabel("distance of the source [km]")
        ax.set_title(f"{direction}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("luminance / base (sphere, extinction, T = 2, Lambertian)")
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("Skyglow model pieces: each changed alone against the base", fontsize=10)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
