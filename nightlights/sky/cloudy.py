"""A scene's cloud deck applied to a clear-sky panorama (the glue of :mod:`nightlights.sky.clouds`).

The cloudy panorama is linear in the emission, as the clear one: per emission band and distance
bin of the observer's polar flux map, a table of the cloudy luminance per lumen
(:func:`~nightlights.sky.clouds.cloud_luminance` at the bin's area-weighted mean distance, the
panorama's elevations and relative azimuths) is convolved with the flux in azimuth by FFT, as
:func:`~nightlights.sky.panorama.panorama_exact` does with the kernel's images. Then

.. math:: L = (1 - c) L_{clear} + c L_{cloudy}

with the cover c at the observer (the deck's ``cover``, or its ``cover_raster`` read at the
observer's cell). With c = 0 the clear panorama is returned as it is (bitwise).

The zenith of that panorama, averaged over azimuth, is the flux of each bin times the azimuth
mean of its table's top row (the azimuth convolution keeps the mean), so per bin one number
per lumen, :func:`cloudy_zenith_per_lumen`: the cloudy counterpart of the clear sky's
:func:`~nightlights.sky.darkness.zenith_per_lumen` that the darkness map convolves with the flux
(the ground-cloud reflections are in the deck's radial profiles, so the table holds them).

Approximations: every source of a distance bin sits at the bin's mean distance (the cloud
terms vary over the base height, so bins much wider than H near the observer blur them); over a
DEM the sources and the observer are taken at the observer's ground altitude for the deck
(a flat layer), and a deck that the scene's terrain reaches is refused.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from nightlights._typing import FloatArray
from nightlights.emission_functions import EmissionFunction
from nightlights.errors import InputError
from nightlights.io.raster import as_raster
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer, cloud_luminance, cloud_profiles

__all__ = ["cloud_cover_at", "cloudy_panorama", "cloudy_zenith_per_lumen"]


def cloud_cover_at(cloud: CloudLayer, xy: tuple[float, float], crs: Any = None) -> float:
    """Cloud cover at a point: the deck's ``cover_raster`` there, else its ``cover`` [1].

    Parameters
    ----------
    cloud
        The deck.
    xy
        Point in the raster's CRS [m].
    crs
        CRS of ``xy``; a cover raster in another CRS is refused.

    Returns
    -------
    float
        Cover fraction [1].
    """
    if cloud.cover_raster is None:
        return float(cloud.cover)
    raster = as_raster(cloud.cover_raster)
    if crs is not None and raster.crs is not None and raster.crs != crs:
        raise InputError(
            f"cover_raster CRS {raster.crs}; expected the emission's CRS {crs} (reproject it)"
        )
    col, row = ~raster.transform @ (float(xy[0]), float(xy[1]))
    i, j = int(np.floor(row)), int(np.floor(col))
    rows, cols = raster.shape
    if not (0 <= i < rows and 0 <= j < cols):
        raise InputError(f"cover_raster does not cover the observer at {xy}; expected it to")
    value = float(raster.data[0, i, j])
    if not 0.0 <= value <= 1.0:
        raise InputError(f"cover_raster value {value!r} at the observer; expected 0 to 1")
    return value


def cloudy_panorama(
    clear: FloatArray,
    flux: FloatArray,
    distance_edges: FloatArray,
    elevation: FloatArray,
    functions: Sequence[EmissionFunction],
    cloud: CloudLayer,
    atmosphere: Atmosphere,
    *,
    cover: float,
    ground_altitude: float = 0.0,
    terrain_top: float | None = None,
) -> tuple[FloatArray, dict[str, float]]:
    """The clear panorama mixed with the cloudy one by the cover.

    Parameters
    ----------
    clear
        Clear-sky panorama ``(n_el, n_az)`` [cd m-2].
    flux
        Polar flux map ``(bands, n_r, n_az)`` [lm] (azimuth bin j centred on
        (j + 0.5) 360 / n_az).
    distance_edges
        Its distance edges ``(n_r + 1,)`` [m].
    elevation
        Panorama rows [deg].
    functions
        Emission function of each band.
    cloud
        The deck.
    atmosphere
        The air below the base.
    cover
        Cover fraction at the observer [1].
    ground_altitude
        Altitude of the observer's ground [m].
    terrain_top
        Highest source altitude of the scene, checked against the base [m].

    Returns
    -------
    tuple
        The panorama [cd m-2] and attributes describing the deck (``cloud_cover``,
        ``cloud_base_height_m``, ``cloud_reflectance``, ``natural_sky_factor``,
        ``stars_factor``).
    """
    if terrain_top is not None:
        cloud.check_terrain(ground_altitude, terrain_top)
    attrs = {
        "cloud_cover": float(cover),
        "cloud_base_height_m": float(cloud.base_height),
        "cloud_reflectance": cloud.reflectance,
        "natural_sky_factor": cloud.natural_sky_factor(cover),
        "stars_factor": cloud.stars_factor(cover),
    }
    if cover == 0.0:
        return clear, attrs
    atm = dataclasses.replace(atmosphere, flat_earth=True)
    n_az = flux.shape[-1]
    rel = np.arange(n_az) * 360.0 / n_az
    edges = np.asarray(distance_edges, dtype=float)
    r1, r2 = edges[:-1], edges[1:]
    mean_r = 2.0 / 3.0 * (r2**3 - r1**3) / np.maximum(r2**2 - r1**2, 1e-300)
    elev = np.clip(np.asarray(elevation, dtype=float), 1e-3, 90.0)
    spectrum = np.zeros((elev.size, n_az // 2 + 1), dtype=complex)
    half_width = max(float(edges[-1]), 40.0 * cloud.base_height)
    for band, function in enumerate(functions[: flux.shape[0]]):
        lit = np.flatnonzero(flux[band].sum(axis=-1) > 0)
        if lit.size == 0:
            continue
        profiles = cloud_profiles(
            cloud,
            atm,
            intensity=function.intensity,
            ground_altitude=ground_altitude,
            half_width=half_width,
        )
        for r_index in lit:
            table = cloud_luminance(
                elev[:, None],
                rel[None, :],
                mean_r[r_index],
                cloud,
                atm,
                intensity=function.intensity,
                ground_altitude=ground_altitude,
                profiles=profiles,
            )
            spectrum += np.fft.rfft(flux[band, r_index])[None, :] * np.fft.rfft(table, axis=-1)
    cloudy = np.maximum(np.fft.irfft(spectrum, n=n_az, axis=-1), 0.0)
    return (1.0 - cover) * clear + cover * cloudy, attrs


def _mean_distances(distance_edges: FloatArray) -> FloatArray:
    """Area-weighted mean distance of each distance bin [m]."""
    edges = np.asarray(distance_edges, dtype=float)
    r1, r2 = edges[:-1], edges[1:]
    return np.asarray(2.0 / 3.0 * (r2**3 - r1**3) / np.maximum(r2**2 - r1**2, 1e-300))


def cloudy_zenith_per_lumen(
    distance_edges: FloatArray,
    elevation: Any,
    n_az: int,
    functions: Sequence[EmissionFunction],
    cloud: CloudLayer,
    atmosphere: Atmosphere,
    *,
    weights: Any = None,
    ground_altitude: float = 0.0,
) -> FloatArray:
    """Overcast zenith luminance per lumen in each distance bin, as :func:`cloudy_panorama`
    reads it.

    .. math:: z^c_b(d) = \\frac{1}{n_\\phi} \\sum_j L_c(e_0, \\phi_j, \\bar r_d)

    with :math:`L_c` :func:`~nightlights.sky.clouds.cloud_luminance` (all ground-cloud
    reflections, through the deck's radial profiles), :math:`e_0` the panorama's top row and
    :math:`\\bar r_d` the bin's area-weighted mean distance: the azimuth mean of the
    panorama's top row is the sum over bins of the flux times this number. With elevation
    weights :math:`w_i` (an instrument's, summing to 1) the rows' azimuth means are summed with
    them, :math:`\\sum_i w_i \\frac{1}{n_\\phi} \\sum_j L_c(e_i, \\phi_j, \\bar r_d)`.

    Parameters
    ----------
    distance_edges
        Distance edges ``(n_r + 1,)`` [m].
    elevation
        Elevation of the panorama's rows, zenith first [deg] (a number: the top row alone).
    n_az
        Azimuth count of the panorama [1].
    functions
        Emission function of each band.
    cloud
        The deck (its cover is not applied).
    atmosphere
        The air below the base.
    weights
        ``(n_el,)`` weights of the rows [1]; None: the top row alone.
    ground_altitude
        Altitude of the ground [m].

    Returns
    -------
    numpy.ndarray
        ``(bands, n_r)`` [cd m-2 lm-1].
    """
    atm = dataclasses.replace(atmosphere, flat_earth=True)
    mean_r = _mean_distances(distance_edges)
    rel = np.arange(n_az) * 360.0 / n_az
    rows = np.atleast_1d(np.asarray(elevation, dtype=float))
    w = np.eye(rows.size)[0] if weights is None else np.asarray(weights, dtype=float)
    if w.shape != rows.shape:
        raise InputError(f"weights of shape {w.shape}; expected one per elevation row {rows.shape}")
    used = np.flatnonzero(w != 0)
    elev = np.clip(rows[used], 1e-3, 90.0)[:, None]
    half_width = max(float(np.max(distance_edges)), 40.0 * cloud.base_height)
    out = np.zeros((len(functions), mean_r.size))
    for band, function in enumerate(functions):
        profiles = cloud_profiles(
            cloud,
            atm,
            intensity=function.intensity,
            ground_altitude=ground_altitude,
            half_width=half_width,
        )
        for r_index, distance in enumerate(mean_r):
            table = cloud_luminance(
                elev,
                rel[None, :],
                distance,
                cloud,
                atm,
                intensity=function.intensity,
                ground_altitude=ground_altitude,
                profiles=profiles,
            )
            out[band, r_index] = float(np.mean(table, axis=-1) @ w[used])
    return out
