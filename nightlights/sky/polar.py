"""Emission raster -> the observer's polar map (distance x azimuth), conserving flux.

Dobashi et al. (2023, Sec. 3.3) sum the light of every ground cell into bins of distance and
azimuth around the observer; the panorama is then a convolution in azimuth. Here every raster
cell's flux (value x cell area) is split over k x k sub-points, k growing for cells close to
the observer where one cell spans many azimuth bins, so that the map conserves the flux.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from affine import Affine
from numpy.typing import ArrayLike, NDArray

from nightlights._typing import FloatArray
from nightlights.errors import DataQualityWarning, InputError


@dataclass(frozen=True)
class PolarMap:
    """Flux around an observer binned in distance and azimuth.

    Attributes
    ----------
    flux
        Shape ``(bands, n_r, n_az)`` [lm]: upward luminous flux in each bin.
    distance_edges
        Shape ``(n_r + 1,)`` [m].
    n_az
        Azimuth bins; bin j is centred on ``(j + 0.5) 360 / n_az`` [deg], clockwise from north.
    dropped_flux
        Flux beyond the last distance edge, left out [lm] per band.
    total_flux
        Flux of the whole raster [lm] per band.
    """

    flux: FloatArray
    distance_edges: FloatArray
    n_az: int
    dropped_flux: FloatArray
    total_flux: FloatArray

    @property
    def azimuths(self) -> FloatArray:
        """Azimuth bin centres [deg]."""
        return (np.arange(self.n_az) + 0.5) * 360.0 / self.n_az


def supersampling(
    cell_size: float, distance: FloatArray, n_az: int, *, max_samples: int = 16
) -> NDArray[np.int64]:
    """Sub-points per cell side so that sub-points are finer than one azimuth bin.

    A cell of size a at distance d spans about a / d radians; with k x k sub-points each spans
    a / (k d), which should not exceed half an azimuth bin (pi / n_az).

    Parameters
    ----------
    cell_size
        Raster cell size [m].
    distance
        Distance of the cell centre from the observer [m].
    n_az
        Azimuth bins [1].
    max_samples
        Largest k [1].
    """
    bin_width = 2.0 * np.pi / n_az
    needed = np.ceil(2.0 * cell_size / (np.maximum(distance, 1e-9) * bin_width))
    return np.clip(needed, 1, max_samples).astype(np.int64)


def polar_map(
    emission: FloatArray,
    transform: Affine,
    observer: tuple[float, float],
    *,
    distance_edges: FloatArray,
    n_az: int,
    max_samples: int = 16,
    warn: bool = True,
) -> PolarMap:
    """Bin an emission raster into the observer's polar map.

    Parameters
    ----------
    emission
        Shape ``(bands, rows, cols)`` or ``(rows, cols)``: upward flux density [lm m-2];
        NaN counts as no emission.
    transform
        Affine transform of the raster (square cells, north up) [m].
    observer
        Observer position (x, y) in the raster CRS [m].
    distance_edges
        Distance bin edges [m], increasing.
    n_az
        Azimuth bins [1].
    max_samples
        Largest number of sub-points per cell side [1].
    warn
        Warn (:class:`~nightlights.errors.DataQualityWarning`) when flux lies beyond the last
        distance edge [1].

    Returns
    -------
    PolarMap
        Sub-points nearer than the first edge (the observer's own cell) go into the first
        bin, at their own azimuth; sub-points beyond the last edge are dropped and counted.
    """
    data = np.asarray(emission, dtype=float)
    if data.ndim == 2:
        data = data[None]
    if data.ndim != 3:
        raise InputError(f"emission must be (bands, rows, cols); got shape {data.shape}")
    if (
        transform.b != 0
        or transform.d != 0
        or abs(abs(transform.a) - abs(transform.e)) > 1e-9 * abs(transform.a)
    ):
        raise InputError("emission raster must have square, north-up cells")
    edges = np.asarray(distance_edges, dtype=float)
    cell = abs(transform.a)
    bands = data.shape[0]
    values = np.nan_to_num(data, nan=0.0)
    lit = np.nonzero(np.any(values != 0, axis=0))
    total = values.sum(axis=(1, 2)) * cell * cell
    flux = np.zeros((bands, edges.size - 1, n_az))
    if lit[0].size == 0:
        return PolarMap(flux, edges, n_az, np.zeros(bands), total)
    rows, cols = lit
    cx = transform.c + transform.a * (cols + 0.5) + transform.b * (rows + 0.5)
    cy = transform.f + transform.d * (cols + 0.5) + transform.e * (rows + 0.5)
    cell_flux = values[:, rows, cols] * cell * cell
    centre_distance = np.hypot(cx - observer[0], cy - observer[1])
    k = supersampling(cell, centre_distance, n_az, max_samples=max_samples)
    for samples in np.unique(k):
        members = np.nonzero(k == samples)[0]
        offsets = (np.arange(samples) + 0.5) / samples - 0.5
        ox, oy = np.meshgrid(offsets * cell, offsets * cell)
        px = (cx[members, None] + ox.ravel()[None, :]) - observer[0]
        py = (cy[members, None] + oy.ravel()[None, :]) - observer[1]
        r = np.hypot(px, py).ravel()
        azimuth = np.degrees(np.arctan2(px, py)).ravel() % 360.0
        weight = np.repeat(cell_flux[:, members] / samples**2, samples**2, axis=1)
        d_bin = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, None)
        inside = d_bin < edges.size - 1
        a_bin = np.minimum((azimuth * n_az / 360.0).astype(np.int64), n_az - 1)
        index = d_bin[inside] * n_az + a_bin[inside]
        for band in range(bands):
            flux[band] += np.bincount(
                index, weights=weight[band, inside], minlength=flux[band].size
            ).reshape(flux[band].shape)
    dropped = total - flux.sum(axis=(1, 2))
    if warn:
        _warn_dropped(dropped, total, edges)
    return PolarMap(flux, edges, n_az, dropped, total)


def _warn_dropped(dropped: FloatArray, total: FloatArray, edges: FloatArray) -> None:
    share = np.divide(dropped, total, out=np.zeros_like(total), where=total > 0)
    if np.any(share > 1e-9):
        warnings.warn(
            f"{100 * share.max():.3g} % of the emitted flux lies beyond the kernel's range "
            f"({edges[-1] / 1000:g} km) and is left out",
            DataQualityWarning,
            stacklevel=3,
        )


def source_level_weights(altitude: ArrayLike, levels: ArrayLike) -> FloatArray:
    """Weights that split a source between the two kernel levels around its altitude.

    Linear interpolation in the source altitude: a source at h between levels h_j < h_j+1
    gets weight (h_j+1 - h) / (h_j+1 - h_j) on level j and the rest on level j + 1, so that
    sum_l w_l c_k(r, h_l) is the kernel coefficient linearly interpolated to h (Dobashi 2023,
    Sec. 3.4.2 reads c_k at each cell's own altitude). Outside the levels' range the nearest
    level takes the whole weight.

    Parameters
    ----------
    altitude
        Source altitudes, any shape [m].
    levels
        Kernel source-altitude levels, strictly increasing [m].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_levels, *altitude.shape)``; sums to 1 over the first axis [1].
    """
    h = np.asarray(altitude, dtype=float)
    lv = np.asarray(levels, dtype=float).ravel()
    if lv.size == 0 or np.any(np.diff(lv) <= 0):
        raise InputError(f"source levels {lv.tolist()!r}; expected increasing altitudes")
    out = np.zeros((lv.size, *h.shape))
    if lv.size == 1:
        out[0] = 1.0
        return out
    clamped = np.clip(h, lv[0], lv[-1])
    upper = np.clip(np.searchsorted(lv, clamped, side="right"), 1, lv.size - 1)
    lower = upper - 1
    w_upper = (clamped - lv[lower]) / (lv[upper] - lv[lower])
    np.put_along_axis(out, lower[None], (1.0 - w_upper)[None], axis=0)
    np.put_along_axis(out, upper[None], w_upper[None], axis=0)
    return out


def polar_map_levels(
    emission: FloatArray,
    transform: Affine,
    observer: tuple[float, float],
    *,
    source_altitude: ArrayLike,
    levels: ArrayLike,
    distance_edges: FloatArray,
    n_az: int,
    max_samples: int = 16,
) -> list[PolarMap]:
    """Polar maps of an emission raster split by source-altitude level.

    Every cell's flux goes to the two kernel levels around its own altitude with the weights
    of :func:`source_level_weights`; the panorama is then the sum over levels of each level's
    polar map convolved with that level's kernel (:func:`nightlights.sky.panorama.panorama_pca`
    takes the lists), i.e. every lit cell is seen with the kernel of its own altitude instead
    of one scene-wide altitude.

    Parameters
    ----------
    emission
        Shape ``(bands, rows, cols)`` or ``(rows, cols)`` [lm m-2].
    transform
        Raster transform [m].
    observer
        Observer (x, y) [m].
    source_altitude
        Altitude of each cell, shape ``(rows, cols)``, NaN allowed where nothing is lit [m].
    levels
        Kernel source-altitude levels, increasing [m].
    distance_edges, n_az, max_samples
        As :func:`polar_map`.

    Returns
    -------
    list of PolarMap
        One per level, in the order of ``levels``; the flux sums to :func:`polar_map`'s.
    """
    data = np.asarray(emission, dtype=float)
    if data.ndim == 2:
        data = data[None]
    heights = np.asarray(source_altitude, dtype=float)
    if heights.shape != data.shape[1:]:
        raise InputError(
            f"source altitudes of shape {heights.shape} do not match the emission {data.shape[1:]}"
        )
    lit = np.any(np.nan_to_num(data, nan=0.0) != 0, axis=0)
    if np.any(lit & ~np.isfinite(heights)):
        raise InputError("source altitude missing (NaN) under lit emission cells")
    weights = source_level_weights(np.where(lit, heights, 0.0), levels)
    edges = np.asarray(distance_edges, dtype=float)
    bands = data.shape[0]
    maps = [
        polar_map(
            data * weights[level][None],
            transform,
            observer,
            distance_edges=edges,
            n_az=n_az,
            max_samples=max_samples,
            warn=False,
        )
        if np.any(weights[level][lit] > 0)
        else PolarMap(  # no cell near this level: an empty map, without scanning the raster
            np.zeros((bands, edges.size - 1, n_az)), edges, n_az, np.zeros(bands), np.zeros(bands)
        )
        for level in range(weights.shape[0])
    ]
    _warn_dropped(
        np.sum([m.dropped_flux for m in maps], axis=0),
        np.sum([m.total_flux for m in maps], axis=0),
        edges,
    )
    return maps
