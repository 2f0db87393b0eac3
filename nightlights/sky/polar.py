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
from numpy.typing import NDArray

from nightlights.errors import DataQualityWarning, InputError

FloatArray = NDArray[np.float64]


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
        Azimuth bins [-].
    max_samples
        Largest k [-].
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
        Azimuth bins [-].
    max_samples
        Largest number of sub-points per cell side [-].

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
    share = np.divide(dropped, total, out=np.zeros_like(total), where=total > 0)
    if np.any(share > 1e-9):
        warnings.warn(
            f"{100 * share.max():.3g} % of the emitted flux lies beyond the kernel's range "
            f"({edges[-1] / 1000:g} km) and is left out",
            DataQualityWarning,
            stacklevel=2,
        )
    return PolarMap(flux, edges, n_az, dropped, total)
