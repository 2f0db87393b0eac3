"""Darkest spot: where in the bundled Helsinki scene is the zenith sky darkest?

Streets -> predicted streetlights -> ground illuminance -> upward emission -> the artificial
zenith sky brightness with an observer at every 50 m cell (``nl.darkness``, one FFT
convolution of the emission with the zenith kernel). Prints the darkest and the brightest
observer positions with their artificial zenith brightness and the sky they see with the
moonless natural sky (22.0 mag arcsec-2) added. The same steps over a larger emission raster
(a VIIRS mosaic with ``nl.emission_from_viirs``) answer "the darkest spot within 50 km of a
city". Writes nothing.
Usage::

    python examples/darkest_spot.py [--seed 2011]

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import argparse

import numpy as np
from pyproj import Transformer

import nightlights as nl
from nightlights.demo import example_path

#: Zenith brightness of the moonless natural sky [mag arcsec-2] (the DESIGN's 22.0 convention).
NATURAL_SKY = 22.0
#: Luminance of 0 mag arcsec-2 [cd m-2] (Cinzano 2005; the DESIGN's magnitude scale).
ZERO_POINT = 1.08e5
#: The darkness map's kernel: 48 distance bins, a 32 x 128 panorama (the demo's), cached.
KERNEL_GRID = {"n_distance": 48, "n_elevation": 32, "n_azimuth": 128}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2011, help="sampling and placement seed")
    seed = parser.parse_args().seed

    streets = nl.normalize(example_path(), mapping="osm").streets
    lit = nl.sample(streets, network="europe", seed=seed).streets
    lights = nl.place(lit, seed=seed).lights
    lux = nl.irradiance(lights, resolution=2.0, progress=False).raster
    upward = nl.emission(lux, lights=lights, resolution=50.0, albedo=0.15).raster

    # the observer's eye 1.7 m above every cell of the emission grid
    zenith = nl.darkness(nl.Scene(upward, **KERNEL_GRID), progress=False).raster
    bands = list(zenith.descriptions)
    magnitude = zenith.data[bands.index("zenith_sky_brightness")]
    luminance = zenith.data[bands.index("zenith_luminance")]  # [cd m-2]
    natural = ZERO_POINT * 10 ** (-0.4 * NATURAL_SKY)
    to_lonlat = Transformer.from_crs(zenith.crs, "EPSG:4326", always_xy=True)
    print(
        f"{magnitude.size} observer positions on {zenith.resolution:.0f} m cells, "
        f"{len(lights)} luminaires"
    )
    for label, index in (
        ("darkest", np.nanargmax(magnitude)),
        ("brightest", np.nanargmin(magnitude)),
    ):
        row, col = np.unravel_index(index, magnitude.shape)
        x, y = zenith.transform * (col + 0.5, row + 0.5)
        lon, lat = to_lonlat.transform(x, y)
        total = -2.5 * np.log10((luminance[row, col] + natural) / ZERO_POINT)
        print(
            f"{label:9s} {lon:.4f} E {lat:.4f} N (x {x:.0f} m, y {y:.0f} m): zenith "
            f"{magnitude[row, col]:.2f} mag arcsec-2 artificial, {total:.2f} with the natural sky"
        )


if __name__ == "__main__":
    main()
