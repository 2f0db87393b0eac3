"""A synthetic national VIIRS annual mosaic, written window by window.

:func:`synthetic_mosaic` writes what a national annual composite looks like to the stages that
read it, at any size, without holding it: EPSG:4326 at 15 arcsec (the VIIRS night-time lights
grid, Elvidge et al. 2017), a tiled, compressed float32 GeoTIFF of radiance
[nW cm-2 sr-1]. Its content is made up (no real place), built for the properties that matter
to a windowed reader and to the darkness stage:

- a coast: the eastern part (east of a wavy line) is sea, nodata (NaN);
- a large empty interior: the western :data:`INTERIOR_SHARE` of the land holds no city, only
  background noise;
- cities in clusters: cluster centres uniform over the inhabited land, cities around each
  (Gaussian offsets), each a Gaussian blob whose peak radiance is lognormal (median
  :data:`CITY_MEDIAN_RADIANCE`, a bright city core of a few hundred nW cm-2 sr-1 at the
  upper tail as in the annual composites) and whose radius is lognormal (a few km);
- background: Gaussian noise about zero (negative values, as in background-subtracted
  composites) and sparse lit villages.

Every number here is a modelling choice for a test scene, not a measurement. Each strip of
rows uses its own generator seeded from ``seed`` and the strip's first row, so the file is the
same whatever the order it is written in.

References
----------
Elvidge, C. D., Baugh, K., Zhizhin, M., Hsu, F. C. & Ghosh, T. (2017). VIIRS night-time
lights. Int. J. Remote Sens. 38(21), 5860-5879.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import rasterio
from affine import Affine

#: Rows written at a time [rows]: a multiple of the 512-pixel blocks.
STRIP_ROWS = 512
#: Share of the land (from the west) without cities [1].
INTERIOR_SHARE = 0.45
#: Clusters of cities and cities per cluster [1].
CLUSTERS, CITIES_PER_CLUSTER = 120, 25
#: Median peak radiance of a city and the sigma of its logarithm [nW cm-2 sr-1], [1].
CITY_MEDIAN_RADIANCE, CITY_SIGMA = 20.0, 1.2
#: Median city radius (Gaussian sigma) and the sigma of its logarithm [km], [1].
CITY_MEDIAN_RADIUS_KM, RADIUS_SIGMA = 3.0, 0.6
#: Spread of the cities about their cluster's centre [deg].
CLUSTER_SPREAD_DEG = 1.0
#: Standard deviation of the background noise [nW cm-2 sr-1].
NOISE = 0.3
#: Share of inhabited background pixels holding a lit village, and their median [1], [nW...].
VILLAGE_SHARE, VILLAGE_MEDIAN = 2e-3, 3.0
#: Degrees of latitude per km [deg km-1] (a 6371 km sphere).
DEG_PER_KM = 180.0 / (math.pi * 6371.0)


def synthetic_mosaic(
    path: str | os.PathLike[str],
    *,
    lon: tuple[float, float] = (70.0, 130.0),
    lat: tuple[float, float] = (18.0, 53.0),
    resolution_arcsec: float = 15.0,
    seed: int = 0,
) -> Path:
    """Write a synthetic VIIRS radiance mosaic (EPSG:4326) to ``path``, strip by strip.

    Parameters
    ----------
    path
        GeoTIFF to write (tiled 512 x 512, DEFLATE with the floating-point predictor).
    lon, lat
        West-east and south-north extent [deg].
    resolution_arcsec
        Pixel size [arcsec].
    seed
        Seed of every random draw.

    Returns
    -------
    pathlib.Path
        ``path``. The defaults (60 x 35 deg at 15 arcsec) give 14,400 x 8,400 = 1.2e8 pixels.
    """
    step = resolution_arcsec / 3600.0
    cols = round((lon[1] - lon[0]) / step)
    rows = round((lat[1] - lat[0]) / step)
    transform = Affine(step, 0.0, lon[0], 0.0, -step, lat[1])
    rng = np.random.default_rng(seed)
    coast = _coast(lon, lat)
    cities = _cities(rng, lon, lat, coast)
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 1,
        "dtype": "float32",
        "crs": "EPSG:4326",
        "transform": transform,
        "nodata": float("nan"),
        "tiled": True,
        "blockxsize": 512,
        "blockysize": 512,
        "compress": "DEFLATE",
        "predictor": 3,
        "BIGTIFF": "IF_SAFER",
    }
    x = lon[0] + step * (np.arange(cols) + 0.5)
    with rasterio.open(path, "w", **profile) as dataset:
        dataset.set_band_description(1, "radiance")
        dataset.update_tags(1, units="nW cm-2 sr-1")
        for row in range(0, rows, STRIP_ROWS):
            height = min(STRIP_ROWS, rows - row)
            y = lat[1] - step * (row + np.arange(height) + 0.5)
            strip = _strip(np.random.default_rng([seed, row]), x, y, coast, cities, lon)
            dataset.write(strip[None].astype(np.float32), window=((row, row + height), (0, cols)))
    return Path(path)


def _coast(lon: tuple[float, float], lat: tuple[float, float]) -> tuple[float, float, float]:
    """(longitude at the centre, amplitude, wavelength) of the wavy coast [deg]."""
    width = lon[1] - lon[0]
    return lon[0] + 0.85 * width, 0.05 * width, 0.3 * (lat[1] - lat[0])


def _coast_lon(y: np.ndarray, coast: tuple[float, float, float]) -> np.ndarray:
    """Longitude of the coast at each latitude [deg]."""
    centre, amplitude, wavelength = coast
    return centre + amplitude * np.sin(2 * np.pi * y / wavelength)


def _cities(
    rng: np.random.Generator,
    lon: tuple[float, float],
    lat: tuple[float, float],
    coast: tuple[float, float, float],
) -> np.ndarray:
    """(n, 4): lon [deg], lat [deg], peak radiance [nW cm-2 sr-1], sigma [deg] of each city."""
    west = lon[0] + INTERIOR_SHARE * (coast[0] - lon[0])
    centres = np.column_stack(
        [rng.uniform(west, coast[0], CLUSTERS), rng.uniform(lat[0], lat[1], CLUSTERS)]
    )
    offsets = rng.normal(0.0, CLUSTER_SPREAD_DEG, (CLUSTERS, CITIES_PER_CLUSTER, 2))
    where = (centres[:, None, :] + offsets).reshape(-1, 2)
    peak = CITY_MEDIAN_RADIANCE * rng.lognormal(0.0, CITY_SIGMA, len(where))
    sigma = CITY_MEDIAN_RADIUS_KM * DEG_PER_KM * rng.lognormal(0.0, RADIUS_SIGMA, len(where))
    on_land = (where[:, 0] > west) & (where[:, 0] < _coast_lon(where[:, 1], coast))
    return np.column_stack([where, peak, sigma])[on_land]


def _strip(
    rng: np.random.Generator,
    x: np.ndarray,
    y: np.ndarray,
    coast: tuple[float, float, float],
    cities: np.ndarray,
    lon: tuple[float, float],
) -> np.ndarray:
    """Radiance of the rows at latitudes ``y`` [nW cm-2 sr-1]."""
    values = rng.normal(0.0, NOISE, (len(y), len(x)))
    west = lon[0] + INTERIOR_SHARE * (coast[0] - lon[0])
    inhabited = x > west
    villages = (rng.random(values.shape) < VILLAGE_SHARE) & inhabited[None, :]
    values[villages] += VILLAGE_MEDIAN * rng.lognormal(0.0, 1.0, int(villages.sum()))
    step_x, step_y = x[1] - x[0], y[0] - y[1]
    for city_lon, city_lat, peak, sigma in cities:
        # longitudes shrink with cos(lat): the blob is round on the ground
        sigma_lon = sigma / max(math.cos(math.radians(city_lat)), 1e-3)
        if abs(city_lat - y.mean()) > 4 * sigma + abs(y[0] - y[-1]) / 2:
            continue
        c0 = max(0, int((city_lon - 4 * sigma_lon - x[0]) / step_x))
        c1 = min(len(x), int((city_lon + 4 * sigma_lon - x[0]) / step_x) + 2)
        r0 = max(0, int((y[0] - city_lat - 4 * sigma) / step_y))
        r1 = min(len(y), int((y[0] - city_lat + 4 * sigma) / step_y) + 2)
        if c1 <= c0 or r1 <= r0:
            continue
        dx = (x[c0:c1] - city_lon) / sigma_lon
        dy = (y[r0:r1] - city_lat) / sigma
        values[r0:r1, c0:c1] += peak * np.exp(-0.5 * (dy[:, None] ** 2 + dx[None, :] ** 2))
    values[x[None, :] > _coast_lon(y, coast)[:, None]] = np.nan
    return np.round(values, 2)  # the composites' precision: two decimals


if __name__ == "__main__":
    import sys

    # python benchmarks/_mosaic.py mosaic.tif: the default 60 x 35 deg mosaic
    print(synthetic_mosaic(sys.argv[1] if len(sys.argv) > 1 else "mosaic.tif"))
