"""City case: a uniform city 10 km across emitting 1e9 lm upwards, each skyglow model piece.

The city is a uniform disc of radius 5 km on the sea-level sphere whose upward flux, 1e9 lm, has
Garstang's (1986) emission function (F = G = 0.15: 0.459 Lambertian + 0.541 psi^4 lobe per
upward lumen) in Garstang's clear atmosphere (K = 1, :func:`garstang_atmosphere`). Observers at
sea level at its centre and 20 and 50 km from its centre look at the zenith and 45 deg up
towards the centre (at the centre, 45 deg up in any direction). The luminance is the point-source
luminance of each model integrated over the disc (a polar grid on the disc: Gauss-Legendre in
radius, even in angle; its error is measured by doubling it).

Model pieces (each per upward lumen, times the city's flux density):

- single scattering, the toolkit's kernel (:func:`sky_luminance`): flat Earth or sphere, with
  or without extinction (the pieces of the model-pieces chart);
- single scattering x the tabulated multiple-scattering factor
  (:func:`nightlights.sky.multiple.multiple_scattering_factor`, per emission shape);
- the full Monte Carlo (:func:`monte_carlo_luminance`, all orders): its order 1 is the kernel's
  integral without noise, so single scattering comes from the kernel on the disc grid and the
  orders >= 2 from the Monte Carlo on a coarser grid of the disc (2 radii x 6 angles), in
  independent batches (seeds) whose spread gives the standard error;
- Garstang's model, reconstructed (:func:`nightlights.sky.garstang.garstang_sky_luminance`:
  his geometry, aerosol function and extinction; single scattering only);
- Walker's (1977) empirical law, 45 deg up towards the city only: the artificial sky there is
  0.01 P D^-2.5 times the natural sky (P inhabitants, D in km). Assumed: 1000 lm of luminaire
  output per inhabitant (the per-capita output Garstang 1986 used for US cities when comparing
  his model with Walker's law; quoted from the restatements, not re-read), so P = the city's
  total output / 1000 lm, with the total output = upward flux / 0.2774 (the upward fraction of
  Garstang's function, :func:`garstang_upward_flux`); the natural sky taken as 22.0 mag
  arcsec-2 (171 ucd m-2, the toolkit's moonless natural zenith; the natural sky 45 deg up is
  somewhat brighter, which would raise Walker's figure in proportion).

Also, for a point source, the kernel against Garstang's reconstruction in the same atmosphere
and emission: the exponent of the zenith glow of a uniform lit plane from beyond radius d
(validation 5, asserted in ``tests/nightlights/sky/test_garstang.py``) for K = 0.5 and 1 and
three emission functions, and the luminance ratio reconstruction / kernel at 1-300 km.

Run: ``python benchmarks/bench_sky_city_case.py [--quick] [--out DIR]``
(``--quick``: a coarser disc grid and 2 x 300 photons instead of 6 x 5,000).
Writes ``sky_city_case.json`` and ``.png`` (see ``_harness.py`` for where).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import _harness as harness
import numpy as np

from nightlights.brightness import luminance_to_magnitude, magnitude_to_luminance
from nightlights.emission_functions import garstang_weights
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere
from nightlights.sky.garstang import garstang_sky_luminance, garstang_upward_flux
from nightlights.sky.kernel import sky_luminance
from nightlights.sky.montecarlo import monte_carlo_luminance
from nightlights.sky.multiple import multiple_scattering_factor, multiple_scattering_table

#: Radius of the city [m] (10 km across).
CITY_RADIUS = 5e3
#: Upward flux of the city [lm].
UPWARD_FLUX = 1e9
#: Garstang's clarity K of the atmosphere [1].
CLARITY = 1.0
#: Garstang's F (direct upward fraction) and G (ground reflectance) [1].
UPWARD_FRACTION, REFLECTANCE = 0.15, 0.15
#: Weights of the kernel's unit-flux shapes that make Garstang's emission function.
MIX = garstang_weights(UPWARD_FRACTION, REFLECTANCE)
#: Observers' distances from the city's centre [km] and the view elevations [deg].
OBSERVER_KM = (0.0, 20.0, 50.0)
ELEVATIONS = (90.0, 45.0)
#: Walker (1977): artificial / natural sky 45 deg up towards a city = 0.01 P D^-2.5 (D in km).
WALKER_COEFFICIENT, WALKER_EXPONENT = 0.01, -2.5
#: Luminaire output per inhabitant assumed for Walker's law [lm] (see the module docstring).
LUMENS_PER_PERSON = 1000.0
#: Natural sky taken as the reference of Walker's law [mag arcsec-2].
NATURAL_SKY_MAG = 22.0
#: Disc grid (radii x angles) of the model pieces, of the convergence reference, and of the
#: Monte Carlo's orders >= 2.
GRID, REFERENCE_GRID, MONTE_CARLO_GRID = (24, 48), (48, 96), (2, 6)

PointLuminance = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def case_label(km: float, elevation: float) -> str:
    """Column name of an observer and view direction."""
    where = "centre" if km == 0 else f"{km:g} km"
    view = "zenith" if elevation == 90.0 else f"{elevation:g} deg towards"
    return f"{where}, {view}"


CASES = [(km, el) for km in OBSERVER_KM for el in ELEVATIONS]
LABELS = [case_label(km, el) for km, el in CASES]


def disc_elements(
    observer_km: float, grid: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ground distance [m], azimuth from the view direction (towards the centre) [deg] and
    area [m2] of the disc's grid elements seen from an observer ``observer_km`` from the
    centre (a plane: the disc is small against the Earth's radius)."""
    n_radius, n_angle = grid
    x, w = np.polynomial.legendre.leggauss(n_radius)
    radius = 0.5 * CITY_RADIUS * (x + 1.0)
    angle = (np.arange(n_angle) + 0.5) * 2.0 * math.pi / n_angle
    rho, phi = np.meshgrid(radius, angle, indexing="ij")
    area = (0.5 * CITY_RADIUS * w * radius)[:, None] * (2.0 * math.pi / n_angle)
    area = np.broadcast_to(area, rho.shape)
    east = rho * np.cos(phi) - observer_km * 1e3  # element relative to the observer
    north = rho * np.sin(phi)
    distance = np.hypot(east, north)
    # the view direction: towards the centre (-east), or east from the centre itself
    azimuth = np.degrees(np.arctan2(north, east if observer_km == 0 else -east))
    return distance.ravel(), azimuth.ravel(), area.ravel()


def city_luminance(point: PointLuminance, grid: tuple[int, int] = GRID) -> np.ndarray:
    """Luminance of every case [cd m-2] from a point-source luminance per upward lumen."""
    density = UPWARD_FLUX / (math.pi * CITY_RADIUS**2)
    values = []
    for km, elevation in CASES:
        distance, azimuth, area = disc_elements(km, grid)
        b = point(np.full(distance.shape, elevation), azimuth, distance)
        values.append(float(np.sum(b * area) * density))
    return np.array(values)


def kernel_mix(atmosphere: Atmosphere, *, multiple: bool = False) -> PointLuminance:
    """The kernel with Garstang's emission function, optionally x the multiple factor."""

    def point(elevation: np.ndarray, azimuth: np.ndarray, distance: np.ndarray) -> np.ndarray:
        total = np.zeros(distance.shape)
        for shape, weight in MIX.items():
            b = sky_luminance(elevation, azimuth, distance, atmosphere=atmosphere, emission=shape)
            if multiple:
                b = b * multiple_scattering_factor(atmosphere, shape, elevation, azimuth, distance)
            total += weight * b
        return total

    return point


def garstang_point(extinction: bool) -> PointLuminance:
    """Garstang's reconstructed model per upward lumen."""
    per_upward = 1.0 / garstang_upward_flux(UPWARD_FRACTION, REFLECTANCE)

    def point(elevation: np.ndarray, azimuth: np.ndarray, distance: np.ndarray) -> np.ndarray:
        value = garstang_sky_luminance(
            elevation,
            azimuth,
            distance,
            clarity=CLARITY,
            upward_fraction=UPWARD_FRACTION,
            reflectance=REFLECTANCE,
            extinction=extinction,
        )
        return np.asarray(value * per_upward)

    return point


def monte_carlo_multiple(photons: int, batches: int) -> dict:
    """Orders >= 2 of every case [cd m-2] from the Monte Carlo, per batch (seed)."""
    atmosphere = garstang_atmosphere(CLARITY)
    density = UPWARD_FLUX / (math.pi * CITY_RADIUS**2)
    rays = [disc_elements(km, MONTE_CARLO_GRID) for km, _ in CASES]
    elevation = np.concatenate(
        [np.full(r[0].size, el) for r, (_, el) in zip(rays, CASES, strict=True)]
    )
    azimuth = np.concatenate([r[1] for r in rays])
    distance = np.concatenate([r[0] for r in rays])
    area = np.concatenate([r[2] for r in rays])
    case = np.repeat(np.arange(len(CASES)), [r[0].size for r in rays])
    per_batch = np.zeros((batches, len(CASES)))
    seconds = 0.0
    events = 0
    for batch in range(batches):
        for shape, weight in MIX.items():
            with harness.Stopwatch() as watch:
                run = monte_carlo_luminance(
                    elevation,
                    azimuth,
                    distance,
                    atmosphere=atmosphere,
                    emission=shape,
                    photons=photons,
                    seed=1 + batch,
                )
            seconds += watch.seconds
            events += run.events
            multiple = run.total - run.single
            per_batch[batch] += weight * np.bincount(case, multiple * area) * density
        print(f"Monte Carlo batch {batch + 1}/{batches}: {seconds:.0f} s so far", flush=True)
    return {
        "per_batch": per_batch,
        "mean": per_batch.mean(axis=0),
        "standard_error": per_batch.std(axis=0, ddof=1) / math.sqrt(batches),
        "rays": int(distance.size),
        "seconds": seconds,
        "events": events,
    }


def walker_luminance() -> np.ndarray:
    """Walker's law for the cases 45 deg up towards the city (NaN elsewhere) [cd m-2]."""
    total_output = UPWARD_FLUX / garstang_upward_flux(UPWARD_FRACTION, REFLECTANCE)
    people = total_output / LUMENS_PER_PERSON
    natural = float(magnitude_to_luminance(NATURAL_SKY_MAG))
    return np.array(
        [
            WALKER_COEFFICIENT * people * km**WALKER_EXPONENT * natural
            if km > 0 and el == 45.0
            else math.nan
            for km, el in CASES
        ]
    )


def lit_plane_tail_exponent(distance: np.ndarray, zenith: np.ndarray) -> float:
    """Exponent n of the zenith glow of a uniform lit plane from beyond radius d, fitted over
    d = 10-100 km: d ln(int_d^inf L(r) 2 pi r dr) / d ln d (trapezoids in ln r)."""
    per_log = zenith * 2.0 * math.pi * distance**2
    pieces = 0.5 * (per_log[1:] + per_log[:-1]) * np.diff(np.log(distance))
    beyond = np.append(np.cumsum(pieces[::-1])[::-1], 0.0)
    fit = (distance >= 1e4) & (distance <= 1e5)
    return float(np.polyfit(np.log(distance[fit]), np.log(beyond[fit]), 1)[0])


def validation(clarities: tuple[float, ...] = (0.5, 1.0)) -> tuple[list[dict], list[dict]]:
    """The kernel against Garstang's reconstruction for a point source: the lit-plane tail
    exponents (validation 5; the test asserts them) and the luminance ratios, 1-300 km."""
    distance = np.geomspace(1e3, 1e6, 121)
    shapes = {
        "Garstang's function": (0.15, 0.15),
        "Lambertian": (0.0, 0.15),
        "psi^4 lobe": (1.0, 0.15),
    }
    tails = []
    for clarity in clarities:
        atmosphere = garstang_atmosphere(clarity)
        for name, (f, g) in shapes.items():
            weights = garstang_weights(f, g)
            kernel = sum(
                w * sky_luminance(90.0, 0.0, distance, atmosphere=atmosphere, emission=shape)
                for shape, w in weights.items()
                if w > 0
            )
            garstang = garstang_sky_luminance(
                90.0, 0.0, distance, clarity=clarity, upward_fraction=f, reflectance=g
            )
            n_kernel = lit_plane_tail_exponent(distance, np.asarray(kernel))
            n_garstang = lit_plane_tail_exponent(distance, garstang)
            tails.append(
                {
                    "clarity": clarity,
                    "emission": name,
                    "kernel": n_kernel,
                    "garstang": n_garstang,
                    "difference": n_kernel - n_garstang,
                }
            )
    at_km = (1, 3, 10, 30, 100, 300)
    ratios = []
    for clarity in clarities:
        point = kernel_mix(garstang_atmosphere(clarity))
        for elevation, azimuth in ((90.0, 0.0), (45.0, 0.0), (45.0, 180.0)):
            d = np.array(at_km, dtype=float) * 1e3
            el, az = np.full(d.shape, elevation), np.full(d.shape, azimuth)
            value = garstang_sky_luminance(el, az, d, clarity=clarity) / garstang_upward_flux(
                UPWARD_FRACTION, REFLECTANCE
            )
            row: dict = {"clarity": clarity, "elevation_deg": elevation, "azimuth_deg": azimuth}
            row.update(
                {
                    f"{km} km": float(v)
                    for km, v in zip(at_km, value / point(el, az, d), strict=True)
                }
            )
            ratios.append(row)
    return tails, ratios


def main() -> None:
    parser = harness.argument_parser(
        __doc__, quick="a coarser disc grid and 2 x 300 photons instead of 6 x 5,000"
    )
    args = harness.parse_args(parser)
    grid = (12, 24) if args.quick else GRID
    photons, batches = (300, 2) if args.quick else (5_000, 6)
    sky_luminance(90.0, 0.0, 1e4)  # compile
    pieces: dict[str, PointLuminance] = {}
    for flat in (True, False):
        for extinction in (False, True):
            earth = "flat Earth" if flat else "sphere"
            light = "extinction" if extinction else "no extinction"
            atmosphere = garstang_atmosphere(CLARITY, flat_earth=flat, extinction=extinction)
            pieces[f"single, {earth}, {light}"] = kernel_mix(atmosphere)
    kernel = garstang_atmosphere(CLARITY)
    pieces["single x tabulated multiple-scattering factor"] = kernel_mix(kernel, multiple=True)
    pieces["Garstang reconstructed, single, no extinction"] = garstang_point(False)
    pieces["Garstang reconstructed, single"] = garstang_point(True)
    luminance: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    for label, point in pieces.items():
        with harness.Stopwatch() as watch:
            luminance[label] = city_luminance(point, grid)
        seconds[label] = watch.seconds
        print(f"{label}: {np.round(luminance[label], 6)} ({watch.seconds:.1f} s)", flush=True)
    single = luminance["single, sphere, extinction"]
    reference = city_luminance(kernel_mix(kernel), REFERENCE_GRID)
    coarse = city_luminance(kernel_mix(kernel), MONTE_CARLO_GRID)
    tails, point_ratios = validation()
    monte_carlo = monte_carlo_multiple(photons, batches)
    full = single + monte_carlo["mean"]
    luminance["Monte Carlo, all orders"] = full
    luminance["Walker's law"] = walker_luminance()
    order = [
        "single, flat Earth, no extinction",
        "single, flat Earth, extinction",
        "single, sphere, no extinction",
        "single, sphere, extinction",
        "single x tabulated multiple-scattering factor",
        "Monte Carlo, all orders",
        "Garstang reconstructed, single, no extinction",
        "Garstang reconstructed, single",
        "Walker's law",
    ]
    keys = [f"c{i}" for i in range(len(CASES))]

    def records(transform: Callable[[np.ndarray], np.ndarray]) -> list[dict]:
        rows = []
        for label in order:
            values = transform(luminance[label])
            row: dict = {"piece": label}
            row.update(
                {
                    k: (None if not np.isfinite(v) else float(v))
                    for k, v in zip(keys, values, strict=True)
                }
            )
            rows.append(row)
        return rows

    error_row: dict = {"piece": "Monte Carlo standard error [%]"}
    error_row.update(
        {
            k: float(100.0 * se / v)
            for k, se, v in zip(keys, monte_carlo["standard_error"], full, strict=True)
        }
    )
    ratios = []
    for label in order[:-1]:
        row: dict = {"piece": label}
        row.update({k: float(v) for k, v in zip(keys, luminance[label] / single, strict=True)})
        ratios.append(row)
    result = {
        "cases": [
            {"key": k, "label": lab, "observer_km": km, "elevation_deg": el}
            for k, lab, (km, el) in zip(keys, LABELS, CASES, strict=True)
        ],
        "city": {
            "radius_m": CITY_RADIUS,
            "upward_flux_lm": UPWARD_FLUX,
            "clarity": CLARITY,
            "upward_fraction_F": UPWARD_FRACTION,
            "reflectance_G": REFLECTANCE,
            "emission_weights": MIX,
            "atmosphere": "Garstang K = 1 (garstang_atmosphere), 550 nm, sea level",
        },
        "luminance_cd_m2": records(lambda v: v),
        "magnitude_mag_arcsec2": [*records(luminance_to_magnitude), error_row],
        "ratio_to_single_sphere_extinction": ratios,
        "disc_grid": {
            "grid": list(grid),
            "reference_grid": list(REFERENCE_GRID),
            "relative_change_against_reference": (single / reference - 1.0).tolist(),
            "monte_carlo_grid": list(MONTE_CARLO_GRID),
            "single_on_monte_carlo_grid_relative_change": (coarse / reference - 1.0).tolist(),
        },
        "monte_carlo": {
            "photons_per_batch_and_shape": photons,
            "batches": batches,
            "rays": monte_carlo["rays"],
            "events": monte_carlo["events"],
            "seconds": monte_carlo["seconds"],
            "multiple_cd_m2": monte_carlo["mean"].tolist(),
            "multiple_standard_error_cd_m2": monte_carlo["standard_error"].tolist(),
            "multiple_per_batch_cd_m2": monte_carlo["per_batch"].tolist(),
        },
        "walker": {
            "law": "artificial / natural = 0.01 P D^-2.5, D in km, 45 deg up towards the city",
            "lumens_per_person": LUMENS_PER_PERSON,
            "people": UPWARD_FLUX
            / garstang_upward_flux(UPWARD_FRACTION, REFLECTANCE)
            / LUMENS_PER_PERSON,
            "natural_sky_mag_arcsec2": NATURAL_SKY_MAG,
        },
        "tail_exponents": tails,
        "point_source_garstang_over_kernel": point_ratios,
        "multiple_scattering_tables": {
            shape: {"source": table.source, "photons": table.photons}
            for shape, table in ((shape, multiple_scattering_table(kernel, shape)) for shape in MIX)
        },
        "seconds": seconds,
    }
    harness.write_results(args.out, "sky_city_case", result, quick=args.quick, plot=plot)


def plot(result: dict):
    plt = harness.pyplot()
    labels = [case["label"] for case in result["cases"]]
    keys = [case["key"] for case in result["cases"]]
    fig, ax = plt.subplots(figsize=(11.0, 5.0))
    markers = "os^vDPXh*"
    rows = result["luminance_cd_m2"]
    percent = result["magnitude_mag_arcsec2"][-1]  # the Monte Carlo's standard errors [%]
    for i, (row, marker) in enumerate(zip(rows, markers, strict=True)):
        x = np.arange(len(keys)) + (i - len(rows) / 2) * 0.07
        y = np.array([np.nan if row[k] is None else row[k] for k in keys])
        if row["piece"] == "Monte Carlo, all orders":
            error = np.array([percent[k] for k in keys]) / 100.0 * y
            ax.errorbar(x, y, yerr=error, fmt=marker, label=row["piece"], ms=6, capsize=2)
        else:
            ax.plot(x, y, marker, label=row["piece"], ms=6)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(keys)), labels, fontsize=8)
    ax.set_ylabel("sky luminance [cd m-2]")
    ax.grid(True, which="both", axis="y", alpha=0.3)
    natural = float(magnitude_to_luminance(NATURAL_SKY_MAG))
    ax.axhline(natural, color="black", lw=0.8, ls="--")
    ax.text(len(keys) - 0.6, natural * 1.1, "natural sky 22.0", fontsize=7, ha="right")
    secondary = ax.secondary_yaxis(
        "right",
        functions=(
            lambda v: luminance_to_magnitude(np.maximum(v, 1e-30)),
            lambda m: magnitude_to_luminance(m),
        ),
    )
    secondary.set_yticks(np.arange(13.0, 24.0))
    secondary.yaxis.set_major_formatter(lambda value, _: f"{value:.0f}")
    secondary.yaxis.set_minor_formatter(lambda value, _: "")
    secondary.set_ylabel("[mag arcsec-2]")
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(
        "Uniform city 10 km across, 1e9 lm upwards, Garstang K = 1, F = G = 0.15", fontsize=10
    )
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    main()
