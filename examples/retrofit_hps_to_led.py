"""Retrofit: the main roads' high-pressure sodium lanterns replaced by 3000 K LED luminaires.

On the bundled Helsinki scene, the heads of the main-road poles (the ``road_led_large`` and
``street_led_medium`` systems the placement chose) are set once to the SON-TPP 250 W sodium
lantern (``road_hps``, 27,900 lm, before) and once to the full cut-off 3000 K LED luminaire
(``road_led_large``, 10,600 lm, after); the poles, their heights and headings and every other
light stay. For each: ground illuminance (photopic and scotopic), the upward flux (reflected
and direct uplight) and the artificial zenith sky brightness at Esplanadi park in the centre
and at Suomenlinna 3 km south. Both run on one grid, so that they share their skyglow kernels
(cached). Writes nothing. Usage::

    python examples/retrofit_hps_to_led.py [--seed 2011]

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import argparse

import numpy as np

import nightlights as nl
from ies.spectra import K_SCOTOPIC
from nightlights.demo import example_path

#: The light systems on the main roads, and their heads before and after the retrofit.
MAIN_ROAD_SYSTEMS = ("road_led_large", "street_led_medium")
BEFORE, AFTER = "road_hps", "road_led_large"
#: Observers (lon, lat) [deg]: Esplanadi park in the centre, Suomenlinna 3 km south.
OBSERVERS = {"Esplanadi": (24.9480, 60.1675), "Suomenlinna": (24.9880, 60.1455)}
#: Illuminance that counts as lit ground [lx] (EN 13201 class P6 asks for 2 lx on average).
LIT = 1.0


def scenario(lights, head: str, bounds: tuple[float, ...]) -> dict[str, float]:
    """Ground light, upward flux and zenith brightness with the main roads' heads ``head``."""
    main_road = lights["system_id"].isin(MAIN_ROAD_SYSTEMS)
    lights = lights.assign(system_id=np.where(main_road, head, lights["system_id"]))
    lux = nl.irradiance(
        lights, resolution=2.0, sensors=("photopic", "scotopic"), bounds=bounds, progress=False
    ).raster
    photopic, scotopic = (lux.data[lux.descriptions.index(s)] for s in ("photopic", "scotopic"))
    lit = photopic >= LIT
    upward = nl.emission(lux, lights=lights, resolution=50.0, albedo=0.15).raster
    cell = upward.resolution**2  # [m2]
    figures = {
        f"lit area (>= {LIT:g} lx) [ha]": lit.sum() * lux.resolution**2 / 1e4,
        "mean illuminance where lit [lx]": photopic[lit].mean(),
        # the scotopic band is sensor-weighted irradiance: K'_m = 1700 lm/W makes it lux
        "S/P ratio where lit [1]": K_SCOTOPIC * scotopic[lit].sum() / photopic[lit].sum(),
    }
    for band, density in zip(upward.descriptions, upward.data, strict=True):
        figures[f"upward flux, {band} [klm]"] = np.nansum(density) * cell / 1e3
    for name, lonlat in OBSERVERS.items():
        sky = nl.skyglow(nl.Scene(upward), nl.Observer.from_lonlat(*lonlat), progress=False)
        figures[f"zenith at {name} [mag arcsec-2]"] = sky.zenith_magnitude
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2011, help="sampling and placement seed")
    seed = parser.parse_args().seed

    streets = nl.normalize(example_path(), mapping="osm").streets
    lit = nl.sample(streets, network="europe", seed=seed).streets
    lights = nl.place(lit, seed=seed).lights
    retrofitted = int(lights["system_id"].isin(MAIN_ROAD_SYSTEMS).sum())
    print(f"{retrofitted} of {len(lights)} luminaires on the main roads retrofitted")
    # one grid for both: the lights' extent and 200 m around it, on whole 50 m cells
    x0, y0, x1, y1 = lights.total_bounds
    bounds = (
        50 * np.floor((x0 - 200) / 50),
        50 * np.floor((y0 - 200) / 50),
        50 * np.ceil((x1 + 200) / 50),
        50 * np.ceil((y1 + 200) / 50),
    )
    before = scenario(lights, BEFORE, bounds)
    after = scenario(lights, AFTER, bounds)
    print(f"{'':44s} {'HPS':>9s} {'LED 3000K':>9s} {'change':>9s}")
    for key in before:
        change = (
            f"{after[key] - before[key]:+.2f}"
            if "mag" in key
            else f"{100 * (after[key] / before[key] - 1):+.0f} %"
        )
        print(f"{key:44s} {before[key]:9.2f} {after[key]:9.2f} {change:>9s}")


if __name__ == "__main__":
    main()
