"""What a VIIRS Day/Night Band radiance raster may hold, checked before it becomes emission.

:func:`~nightlights.ground.upward.emission_from_viirs` turns nadir radiance
[nW cm-2 sr-1] into upward flux density [lm m-2]. Three kinds of input pass that conversion
without error and give nonsense, so they are caught here:

- **not radiance**: a raster the toolkit wrote (its ``product`` tag, the ``emission_function``
  band tag, the emission stages' band names) or one whose unit is a photometric one
  (``lm m-2``, ``lx``, ...): :func:`check_radiance_source` refuses it;
- **fill values the file does not declare**: a pixel holding exactly a common fill value
  (:data:`COMMON_FILL_VALUES`: 65535 of unsigned 16-bit products, -999, 1e20, the float32
  extremes, ...) would be read as radiance, 65535 being hundreds of times a city centre's.
  Every such value lies outside the plausible range below, so :func:`clean_radiance` treats
  those pixels as nodata, with a warning naming the values and counts; any other radiance
  above :data:`MAX_PLAUSIBLE_RADIANCE` is kept, with a warning;
- **extents wider than one projection zone**: a geographic raster is projected into the local
  UTM zone of its centre; beyond one zone (6 deg of longitude) lengths at its edges are off by
  the transverse Mercator scale factor (:func:`zone_length_error`), which
  :func:`warn_zone_span` reports until the raster is processed in tiles of their own zones.

References
----------
Elvidge, C. D., Baugh, K., Zhizhin, M., Hsu, F. C. & Ghosh, T. (2017). VIIRS night-time
lights. Int. J. Remote Sens. 38(21), 5860-5879: the annual composites, in which lit urban
cores reach a few hundred nW cm-2 sr-1 and the brightest lit sites a few thousand.
Román, M. O. et al. (2018). NASA's Black Marble nighttime lights product suite. Remote Sens.
Environ. 210, 113-143: radiance stored as unsigned 16-bit integers times 0.1 (at most
6553.4 nW cm-2 sr-1), fill value 65535.
Snyder, J. P. (1987). Map Projections: A Working Manual. USGS Prof. Paper 1395, Eq. 8-16:
the point scale factor of the transverse Mercator projection,
k = k0 / sqrt(1 - (cos(phi) sin(lambda - lambda0))^2) on the sphere.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np
from pyproj import CRS, Proj
from rasterio.warp import transform_bounds

from nightlights._typing import FloatArray
from nightlights.emission_functions import EMISSION_FUNCTION_TAG
from nightlights.errors import DataQualityWarning, InputError
from nightlights.io import Raster
from nightlights.io.styles import PRODUCT_TAG

__all__ = [
    "COMMON_FILL_VALUES",
    "MAX_PLAUSIBLE_RADIANCE",
    "ZONE_WIDTH",
    "check_radiance_source",
    "clean_radiance",
    "warn_zone_span",
    "zone_length_error",
]

#: Largest radiance taken for night lights without a warning [nW cm-2 sr-1]: above the
#: brightest lit sites of the annual composites (a few thousand; urban cores a few hundred,
#: Elvidge et al. 2017) and above the largest value Black Marble can store (6553.4, Román et al.
#: 2018). Higher values are a fill value, an unscaled product or a gas flare, not a city.
MAX_PLAUSIBLE_RADIANCE = 1.0e4

#: Fill values that radiance products use, declared or not [nW cm-2 sr-1 as read]: the
#: unsigned 16-bit maximum and its neighbour (Black Marble's 65535), the signed 16-bit
#: extremes, the customary -999 / -999.9 / -9999, CF's 1e20, netCDF's default float fill and
#: the float32 extremes. Each lies at least 999 below zero (background-subtracted radiance is
#: negative by a few nW cm-2 sr-1 at most) or above :data:`MAX_PLAUSIBLE_RADIANCE`, so a pixel
#: holding one exactly is clearly fill, never light.
COMMON_FILL_VALUES: tuple[float, ...] = (
    65535.0,
    65534.0,
    32767.0,
    -32767.0,
    -32768.0,
    -999.0,
    -999.9,
    -9999.0,
    1.0e20,
    -1.0e20,
    9.969209968386869e36,
    3.4028234663852886e38,
    -3.4028234663852886e38,
)

#: Width of a UTM zone [deg of longitude].
ZONE_WIDTH = 6.0
#: UTM's scale factor on the central meridian [1].
UTM_SCALE = 0.9996

#: Units that name a quantity other than radiance (what the toolkit writes, and photometry).
_NOT_RADIANCE_UNITS = {"lm m-2", "lx", "cd m-2", "cd", "lm", "mag arcsec-2", "w m-2", "1", "m"}
#: Band names of the toolkit's emission products.
_EMISSION_BANDS = {"reflected", "uplight", "upward"}
#: Relative tolerance of a fill value read back from float32 [1].
_FLOAT32_TOLERANCE = 1e-6


def check_radiance_source(raster: Raster, label: str) -> None:
    """Refuse a raster that is recognisably not VIIRS radiance; warn about extra bands.

    Parameters
    ----------
    raster
        The input raster (band 1 is read as radiance [nW cm-2 sr-1]).
    label
        How messages name it.

    Raises
    ------
    InputError
        A product of this toolkit (``product`` tag, ``emission_function`` band tag or the
        emission bands ``reflected``/``uplight``/``upward``), or a band 1 whose unit is not a
        radiance (``lm m-2``, ``lx``, ``cd m-2``, ...).
    """
    expected = (
        "expected a VIIRS day/night-band radiance raster [nW cm-2 sr-1]; an emission raster "
        "is already upward flux density: give it to the sky stages as it is"
    )
    product = raster.tags.get(PRODUCT_TAG)
    if product:
        raise InputError(
            f"{label}: a nightlights {product!r} raster (tag {PRODUCT_TAG}), not radiance; "
            f"{expected}"
        )
    tagged = [i + 1 for i, tags in enumerate(raster.band_tags) if EMISSION_FUNCTION_TAG in tags]
    names = {str(name).lower() for name in raster.descriptions if name}
    if tagged or (raster.count > 1 and names and names <= _EMISSION_BANDS):
        what = f"band tag {EMISSION_FUNCTION_TAG} on band {tagged[0]}" if tagged else "its bands"
        raise InputError(
            f"{label}: a nightlights emission raster ({what}: "
            f"{', '.join(d or '?' for d in raster.descriptions)}), not radiance; {expected}"
        )
    unit = raster.units[0].strip() if raster.units and raster.units[0] else ""
    if unit.lower() in _NOT_RADIANCE_UNITS:
        raise InputError(f"{label}: band 1 is in {unit}, not a radiance; {expected}")
    if raster.count > 1:
        warnings.warn(
            f"{label}: {raster.count} bands; band 1 "
            f"({raster.descriptions[0] or 'unnamed'}) is read as radiance, "
            + ("band 2 is" if raster.count == 2 else f"bands 2-{raster.count} are")
            + " ignored",
            DataQualityWarning,
            stacklevel=3,
        )


def clean_radiance(radiance: FloatArray, label: str) -> FloatArray:
    """Radiance with undeclared fill values as nodata, warning about implausible values.

    Parameters
    ----------
    radiance
        Band 1 of the raster [nW cm-2 sr-1], declared nodata already NaN.
    label
        How messages name the raster.

    Returns
    -------
    numpy.ndarray
        The radiance with the pixels holding exactly one of :data:`COMMON_FILL_VALUES` (to
        float32 precision) set to NaN (a copy when there are any); other values unchanged.

    Warns
    -----
    DataQualityWarning
        Fill values found (their values and counts; treated as nodata), and radiances above
        :data:`MAX_PLAUSIBLE_RADIANCE` that are no fill value (kept as radiance).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     clean = clean_radiance(np.array([[12.0, 65535.0], [np.nan, 3.0]]), "dnb.tif")
    >>> clean.tolist()
    [[12.0, nan], [nan, 3.0]]
    >>> "65535 x1" in str(caught[0].message)
    True
    """
    values = np.asarray(radiance, dtype=float)
    fills = np.asarray(COMMON_FILL_VALUES)
    # only pixels at least 999 from zero can be fill: the candidates are few, the test cheap
    smallest = float(np.min(np.abs(fills))) * (1.0 - _FLOAT32_TOLERANCE)
    with np.errstate(invalid="ignore"):
        candidates = np.flatnonzero((values.ravel() >= smallest) | (values.ravel() <= -smallest))
    found = values.ravel()[candidates]
    match = np.abs(found[:, None] - fills[None, :]) <= _FLOAT32_TOLERANCE * np.abs(fills)
    hit = match.any(axis=1)
    if hit.any():
        counts = match[hit].sum(axis=0)
        shown = ", ".join(f"{fill:g} x{n}" for fill, n in zip(fills, counts, strict=True) if n)
        warnings.warn(
            f"{label}: {_pixels(int(hit.sum()))} a common fill value the file does not "
            f"declare as nodata ({shown}); they are treated as nodata, not as radiance",
            DataQualityWarning,
            stacklevel=3,
        )
        values = values.copy()  # the caller's raster stays as it was
        values.ravel()[candidates[hit]] = np.nan
    with np.errstate(invalid="ignore"):
        high = values > MAX_PLAUSIBLE_RADIANCE
    if high.any():
        found, counts = np.unique(values[high], return_counts=True)
        order = np.argsort(counts)[::-1][:5]
        shown = ", ".join(f"{found[i]:g} x{counts[i]}" for i in order)
        warnings.warn(
            f"{label}: {_pixels(int(high.sum()))} radiances above "
            f"{MAX_PLAUSIBLE_RADIANCE:g} nW cm-2 sr-1 ({shown}; largest "
            f"{float(found[-1]):g}), beyond any city's night lights (urban cores: a few hundred, "
            "the brightest sites: a few thousand); they are taken as radiance: check the "
            "product's scale factor and nodata value",
            DataQualityWarning,
            stacklevel=3,
        )
    return values


def zone_length_error(
    src_crs: CRS, bounds: Sequence[float], target: CRS, *, samples: int = 9
) -> tuple[float, float]:
    """Longitude span of a raster and the largest length error of projecting it to ``target``.

    Parameters
    ----------
    src_crs
        The raster's CRS.
    bounds
        (left, bottom, right, top) in ``src_crs``.
    target
        The projected CRS it is computed in.
    samples
        Points per side of the grid over the footprint where the scale is evaluated [1].

    Returns
    -------
    tuple of float
        Span in longitude [deg] and the largest ``|k - 1|`` over the footprint of the
        meridian and parallel scale factors of ``target`` [1] (inf where the footprint
        leaves the projection's domain).

    Examples
    --------
    >>> utm = CRS.from_epsg(32633)  # central meridian 15 E
    >>> span, error = zone_length_error(CRS.from_epsg(4326), (12.0, 59.0, 18.0, 61.0), utm)
    >>> round(span, 1), round(100 * error, 2)  # [deg], [%]
    (6.0, 0.04)
    >>> span, error = zone_length_error(CRS.from_epsg(4326), (-30.0, 59.0, 60.0, 61.0), utm)
    >>> round(100 * error, 1)  # 45 deg from the central meridian at 59 N [%]
    7.3
    """
    west, south, east, north = transform_bounds(
        src_crs, CRS.from_epsg(4326), *bounds, densify_pts=21
    )
    if east < west:  # across the antimeridian
        east += 360.0
    lon, lat = np.meshgrid(np.linspace(west, east, samples), np.linspace(south, north, samples))
    lon = (lon + 180.0) % 360.0 - 180.0
    factors = Proj(target).get_factors(lon.ravel(), lat.ravel(), errcheck=False)
    scales = np.concatenate(
        [np.asarray(factors.meridional_scale), np.asarray(factors.parallel_scale)]
    )
    error = float(np.max(np.abs(scales - 1.0))) if np.isfinite(scales).all() else math.inf
    return float(east - west), error


def warn_zone_span(src_crs: CRS, bounds: Sequence[float], target: CRS, label: str) -> None:
    """Warn when a raster wider than one UTM zone is projected into one CRS.

    Parameters
    ----------
    src_crs, bounds
        The raster's CRS and (left, bottom, right, top) in it.
    target
        The projected CRS it is computed in.
    label
        How messages name the raster.

    Warns
    -----
    DataQualityWarning
        The raster spans more than :data:`ZONE_WIDTH` of longitude: the message gives the
        largest length error over it (:func:`zone_length_error`).
    """
    span, error = zone_length_error(src_crs, bounds, target)
    if span <= ZONE_WIDTH:
        return
    size = (
        f"up to {100 * error:.2g} %" if math.isfinite(error) else "beyond the projection's domain"
    )
    warnings.warn(
        f"{label}: spans {span:.3g} deg of longitude, more than one UTM zone ({ZONE_WIDTH:g} "
        f"deg), and is computed in one projected CRS ({target.name}): lengths and areas at its "
        f"edges are off by {size} (scale factor of the projection); cut the raster into zones "
        "or give target_crs= a CRS made for the whole extent",
        DataQualityWarning,
        stacklevel=3,
    )


def _pixels(count: int) -> str:
    """``1 pixel holds`` or ``n pixels hold``."""
    return "1 pixel holds" if count == 1 else f"{count} pixels hold"
