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
- **extents wider than one projection zone**: a geographic raster within one zone is projected
  into the local UTM zone of its centre; a wider one keeps its geographic grid, unless a
  ``target_crs=`` projects it into one CRS, where lengths at its edges are off by the
  transverse Mercator scale factor (:func:`zone_length_error`), which :func:`warn_zone_span`
  reports.

A raster read in windows is checked window by window (:class:`RadianceScan`): every check is
per pixel, so the counts add up, and each kind of finding is one warning for the whole raster.

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
from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
from pyproj import CRS, Proj
from rasterio.warp import transform_bounds

from nightlights._typing import FloatArray
from nightlights.emission_functions import EMISSION_FUNCTION_TAG
from nightlights.errors import DataQualityWarning, InputError
from nightlights.io.styles import PRODUCT_TAG

__all__ = [
    "COMMON_FILL_VALUES",
    "MAX_PLAUSIBLE_RADIANCE",
    "ZONE_WIDTH",
    "RadianceScan",
    "RasterMetadata",
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
#: Distinct implausible radiances counted per window, the most frequent first [1]: enough for
#: the five the warning names, bounded for a raster of unscaled values.
_HIGH_VALUES_KEPT = 64


class RasterMetadata(Protocol):
    """What :func:`check_radiance_source` reads of a raster: its metadata, not its pixels
    (a :class:`~nightlights.io.Raster`, or an open file's)."""

    @property
    def count(self) -> int:
        """Bands [1]."""
        ...

    @property
    def descriptions(self) -> tuple[str, ...]:
        """Band names."""
        ...

    @property
    def units(self) -> tuple[str, ...]:
        """Band units."""
        ...

    @property
    def tags(self) -> Mapping[str, str]:
        """Dataset-level metadata."""
        ...

    @property
    def band_tags(self) -> Sequence[Mapping[str, str]]:
        """Metadata per band."""
        ...


def check_radiance_source(raster: RasterMetadata, label: str) -> None:
    """Refuse a raster that is recognisably not VIIRS radiance; warn about extra bands.

    Parameters
    ----------
    raster
        The input raster, or an open file's metadata (band 1 is read as radiance
        [nW cm-2 sr-1]).
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


class RadianceScan:
    """The checks of :func:`clean_radiance` and of the stage, gathered window by window.

    A raster read in windows is cleaned window by window (:meth:`clean`); the counts add up
    over the windows, and :meth:`report` then raises or warns once per kind for the whole
    raster, with the messages a whole-raster check gives. Every test is per pixel (a value
    equal to a fill value, above :data:`MAX_PLAUSIBLE_RADIANCE`, below zero, infinite), so the
    windows' counts add up to the whole raster's exactly as long as each pixel is cleaned in
    one window only. The most frequent implausible values are kept from each window's
    :data:`_HIGH_VALUES_KEPT` most frequent (exact unless a window holds more distinct ones).

    Examples
    --------
    >>> scan = RadianceScan()
    >>> scan.clean(np.array([[12.0, 65535.0]])).tolist()
    [[12.0, nan]]
    >>> scan.clean(np.array([[65535.0, -0.5]])).tolist()
    [[nan, -0.5]]
    >>> int(scan.fills.sum()), scan.negative, scan.lowest
    (2, 1, -0.5)
    """

    def __init__(self) -> None:
        self.infinite = 0
        self.any_value = False
        self.any_radiance = False
        self.fills = np.zeros(len(COMMON_FILL_VALUES), dtype=np.int64)
        self.high = 0
        self.high_values: dict[float, int] = {}
        self.negative = 0
        self.lowest = math.inf

    def clean(self, radiance: FloatArray) -> FloatArray:
        """One window's radiance with its fill values as NaN, counted (see :func:`clean_radiance`).

        Parameters
        ----------
        radiance
            Radiance [nW cm-2 sr-1], declared nodata already NaN.

        Returns
        -------
        numpy.ndarray
            The radiance, fill values set to NaN (a copy when there are any).
        """
        values = np.asarray(radiance, dtype=float)
        self.infinite += int(np.isinf(values).sum())
        self.any_value = self.any_value or bool(np.isfinite(values).any())
        fills = np.asarray(COMMON_FILL_VALUES)
        # only pixels at least 999 from zero can be fill: the candidates are few, the test cheap
        smallest = float(np.min(np.abs(fills))) * (1.0 - _FLOAT32_TOLERANCE)
        with np.errstate(invalid="ignore"):
            candidates = np.flatnonzero(
                (values.ravel() >= smallest) | (values.ravel() <= -smallest)
            )
        found = values.ravel()[candidates]
        match = np.abs(found[:, None] - fills[None, :]) <= _FLOAT32_TOLERANCE * np.abs(fills)
        hit = match.any(axis=1)
        if hit.any():
            self.fills += match[hit].sum(axis=0)
            values = values.copy()  # the caller's raster stays as it was
            values.ravel()[candidates[hit]] = np.nan
        self.any_radiance = self.any_radiance or bool(np.isfinite(values).any())
        with np.errstate(invalid="ignore"):
            high = values > MAX_PLAUSIBLE_RADIANCE
            negative = values < 0
        if high.any():
            self.high += int(high.sum())
            found, counts = np.unique(values[high], return_counts=True)
            kept = np.argsort(counts)[::-1][:_HIGH_VALUES_KEPT]
            for value, count in zip(found[kept], counts[kept], strict=True):
                self.high_values[float(value)] = self.high_values.get(float(value), 0) + int(count)
        if negative.any():
            self.negative += int(negative.sum())
            self.lowest = min(self.lowest, float(np.min(values[negative])))
        return values

    def report(self, label: str, *, stacklevel: int = 3, negative: bool = False) -> None:
        """Raise or warn, once per kind, about what the windows held.

        Parameters
        ----------
        label
            How messages name the raster.
        stacklevel
            Of the warnings, as :func:`warnings.warn` counts it from this method.
        negative
            Warn about negative radiances too (they are set to 0 by the stage).

        Raises
        ------
        InputError
            Infinite radiance; no radiance at all (every pixel nodata, or fill).

        Warns
        -----
        DataQualityWarning
            Fill values (treated as nodata), radiances above :data:`MAX_PLAUSIBLE_RADIANCE`
            (kept), negative radiances (``negative=True``; set to 0).
        """
        expected = "expected radiance values [nW cm-2 sr-1]"
        if self.infinite:
            raise InputError(
                f"{label}: {self.infinite} pixels hold an infinite radiance; expected finite "
                "values [nW cm-2 sr-1] (NaN for nodata)"
            )
        if not self.any_value:
            raise InputError(f"{label}: every pixel is nodata; {expected}")
        if self.fills.any():
            pairs = zip(COMMON_FILL_VALUES, self.fills, strict=True)
            shown = ", ".join(f"{fill:g} x{n}" for fill, n in pairs if n)
            warnings.warn(
                f"{label}: {_pixels(int(self.fills.sum()))} a common fill value the file does "
                f"not declare as nodata ({shown}); they are treated as nodata, not as radiance",
                DataQualityWarning,
                stacklevel=stacklevel,
            )
        if not self.any_radiance:
            raise InputError(f"{label}: every pixel is nodata; {expected}")
        if self.high:
            ranked = sorted(self.high_values.items(), key=lambda item: -item[1])[:5]
            shown = ", ".join(f"{value:g} x{count}" for value, count in ranked)
            warnings.warn(
                f"{label}: {_pixels(self.high)} radiances above "
                f"{MAX_PLAUSIBLE_RADIANCE:g} nW cm-2 sr-1 ({shown}; largest "
                f"{max(self.high_values):g}), beyond any city's night lights (urban cores: a "
                "few hundred, the brightest sites: a few thousand); they are taken as "
                "radiance: check the product's scale factor and nodata value",
                DataQualityWarning,
                stacklevel=stacklevel,
            )
        if negative and self.negative:
            warnings.warn(
                f"{label}: {self.negative} pixels have negative radiance (min "
                f"{self.lowest:.3g} nW cm-2 sr-1); set to 0",
                DataQualityWarning,
                stacklevel=stacklevel,
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

    Notes
    -----
    The tests are per pixel, so a raster read in windows is cleaned window by window with
    :class:`RadianceScan`, which gives these warnings once for the whole raster.

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
    scan = RadianceScan()
    values = scan.clean(radiance)
    scan.any_value = scan.any_radiance = True  # the caller checks for nodata
    scan.infinite = 0
    scan.report(label, stacklevel=4)
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
