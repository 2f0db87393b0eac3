"""Compiled (numba) polar flux map of the lit cells alone, for interactive observers.

The same map as :meth:`nightlights.sky.polar.PolarCells.binned` per source level
(:func:`nightlights.sky.polar.level_maps` of :func:`nightlights.sky.polar.lit_polar_cells`),
which stays the reference the tests compare this to: every lit cell is split into k x k
sub-points (k from :func:`nightlights.sky.polar.supersampling`), each carrying 1 / k**2 of the
cell's flux into one azimuth bin (Dobashi et al. 2023, Sec. 3.3) and two neighbouring distance
bins, linearly in ln r between the bin centres c (:func:`nightlights.sky.polar.distance_shares`):
w = (ln c_{i+1} - ln r) / (ln c_{i+1} - ln c_i) to bin i, 1 - w to bin i + 1. Written as one
loop over the lit cells that scatters straight into the bins, so that no per-sub-point arrays
are made: a new observer costs one pass over the lit cells.
"""

from __future__ import annotations

import math

import numpy as np
from affine import Affine
from numba import get_num_threads, njit, prange
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.sky.polar import distance_centres

__all__ = ["polar_flux_levels"]

#: Fewest lit cells per thread: below it one private map per thread costs more to clear and
#: sum than the cells take to scatter [1].
_CELLS_PER_CHUNK = 2_000


@njit(cache=True, nogil=True, parallel=True)
def _scatter_parallel(
    cx: FloatArray,
    cy: FloatArray,
    flux: FloatArray,
    levels: FloatArray,
    scale: FloatArray,
    cell: float,
    ox: float,
    oy: float,
    edges: FloatArray,
    log_centres: FloatArray,
    share_bins: bool,
    n_az: int,
    max_samples: int,
    out: FloatArray,
    dropped: FloatArray,
) -> None:
    # one private map per chunk, summed at the end: no two threads write one bin. Chunk c
    # takes every chunks-th cell, so that the costly cells near the observer (many sub-points)
    # are shared out evenly.
    chunks = out.shape[0]
    for chunk in prange(chunks):
        _scatter(
            chunk,
            chunks,
            cx,
            cy,
            flux,
            levels,
            scale,
            cell,
            ox,
            oy,
            edges,
            log_centres,
            share_bins,
            n_az,
            max_samples,
            out[chunk],
            dropped[chunk],
        )


@njit(cache=True, nogil=True)
def _scatter(
    first: int,
    step: int,
    cx: FloatArray,
    cy: FloatArray,
    flux: FloatArray,
    levels: FloatArray,
    scale: FloatArray,
    cell: float,
    ox: float,
    oy: float,
    edges: FloatArray,
    log_centres: FloatArray,
    share_bins: bool,
    n_az: int,
    max_samples: int,
    out: FloatArray,
    dropped: FloatArray,
) -> None:
    n_levels, n_bands = out.shape[0], out.shape[1]
    n_r = edges.size - 1
    bin_width = 2.0 * math.pi / n_az
    for i in range(first, cx.size, step):
        dx0 = cx[i] - ox
        dy0 = cy[i] - oy
        # supersampling(): ceil(2 a / (d * bin width)), clipped to [1, max_samples]
        distance = math.sqrt(dx0 * dx0 + dy0 * dy0)
        needed = math.ceil(2.0 * cell / (max(distance, 1e-9) * bin_width))
        k = int(min(max(needed, 1.0), float(max_samples)))
        share = 1.0 / (k * k) * scale[i]
        for a in range(k):
            # the reference's order of operations, so that sub-points on a bin edge agree
            dx = (cx[i] + ((a + 0.5) / k - 0.5) * cell) - ox
            for b in range(k):
                dy = (cy[i] + ((b + 0.5) / k - 0.5) * cell) - oy
                r = math.sqrt(dx * dx + dy * dy)
                if r >= edges[n_r]:  # beyond the last edge: left out
                    for band in range(n_bands):
                        dropped[band] += flux[band, i] * share
                    continue
                d_bin, w = _distance_bin(r, edges, log_centres, share_bins)
                azimuth = math.degrees(math.atan2(dx, dy))
                if azimuth < 0.0:
                    azimuth += 360.0
                a_bin = min(int(azimuth * n_az / 360.0), n_az - 1)
                lower = share * w
                upper = share * (1.0 - w)
                for level in range(n_levels):
                    v = levels[level, i]
                    if v == 0.0:
                        continue
                    for band in range(n_bands):
                        out[level, band, d_bin, a_bin] += flux[band, i] * lower * v
                        if w < 1.0:
                            out[level, band, d_bin + 1, a_bin] += flux[band, i] * upper * v


@njit(cache=True, nogil=True)
def _distance_bin(
    r: float, edges: FloatArray, log_centres: FloatArray, share_bins: bool
) -> tuple[int, float]:
    """distance_shares() of one sub-point nearer than the last edge: the lower bin and its
    weight; with ``share_bins`` False the former rule (the bin holding r takes all)."""
    n_r = edges.size - 1
    if not share_bins:
        # searchsorted(edges, r, "right") - 1, clipped below at 0
        lo, hi = 0, edges.size
        while lo < hi:
            mid = (lo + hi) // 2
            if edges[mid] <= r:
                lo = mid + 1
            else:
                hi = mid
        return max(lo - 1, 0), 1.0
    log_r = math.log(r) if r > 0.0 else -math.inf
    # searchsorted(log centres, ln r, "right") - 1, clipped to [0, n_r - 1]
    lo, hi = 0, n_r
    while lo < hi:
        mid = (lo + hi) // 2
        if log_centres[mid] <= log_r:
            lo = mid + 1
        else:
            hi = mid
    lower = lo - 1
    if lower < 0 or lower >= n_r - 1:
        return max(min(lower, n_r - 1), 0), 1.0
    return lower, (log_centres[lower + 1] - log_r) / (log_centres[lower + 1] - log_centres[lower])


def polar_flux_levels(
    rows: ArrayLike,
    cols: ArrayLike,
    flux: ArrayLike,
    level_weights: ArrayLike,
    transform: Affine,
    observer: tuple[float, float],
    *,
    distance_edges: ArrayLike,
    n_az: int,
    scale: ArrayLike | None = None,
    max_samples: int = 16,
    _nearest: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Flux of the lit cells per source level, band, distance and azimuth bin.

    Parameters
    ----------
    rows, cols
        Raster row and column of each lit cell, shape ``(n_cells,)``.
    flux
        Shape ``(bands, n_cells)``: upward flux of each cell [lm].
    level_weights
        Shape ``(n_levels, n_cells)``: each cell's share of every source level
        (:func:`nightlights.sky.polar.source_level_weights`) [1].
    transform
        Affine transform of the raster (square cells, north up) [m].
    observer
        Observer (x, y) in the raster CRS [m].
    distance_edges
        Distance bin edges, increasing [m].
    n_az
        Azimuth bins [1].
    scale
        Shape ``(n_cells,)``: factor on each cell's flux, e.g. 1 minus its dimming (default 1)
        [1].
    max_samples
        Largest number of sub-points per cell side [1].
    _nearest
        The former one-bin rule (the bin holding a sub-point takes all its flux), kept as the
        reference of ``benchmarks/bench_sky_distance_bins.py`` [1].

    Returns
    -------
    flux_maps : numpy.ndarray
        Shape ``(n_levels, bands, n_r, n_az)`` [lm].
    dropped : numpy.ndarray
        Shape ``(bands,)``: flux beyond the last distance edge, all levels together [lm].

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> maps, dropped = polar_flux_levels(
    ...     [0], [0], [[4.0]], [[1.0]], Affine(10, 0, 0, 0, -10, 10), (105.0, 5.0),
    ...     distance_edges=np.array([0.0, 50.0, 200.0]), n_az=4,
    ... )
    >>> maps.shape, float(maps[0, 0, 1, 3]), float(dropped[0])
    ((1, 1, 2, 4), 4.0, 0.0)
    """
    r = np.asarray(rows, dtype=np.int64).ravel()
    c = np.asarray(cols, dtype=np.int64).ravel()
    values = np.ascontiguousarray(np.atleast_2d(np.asarray(flux, dtype=float)))
    weights = np.ascontiguousarray(np.atleast_2d(np.asarray(level_weights, dtype=float)))
    if values.shape[1] != r.size or weights.shape[1] != r.size or c.size != r.size:
        raise InputError(
            f"{r.size} cells but flux {values.shape} and level weights {weights.shape}; "
            "expected (bands, n_cells) and (n_levels, n_cells)"
        )
    if (
        transform.b != 0
        or transform.d != 0
        or abs(abs(transform.a) - abs(transform.e)) > 1e-9 * abs(transform.a)
    ):
        raise InputError("emission raster must have square, north-up cells")
    factor = np.ones(r.size) if scale is None else np.asarray(scale, dtype=float).ravel()
    if factor.size != r.size:
        raise InputError(f"scale of {factor.size} values for {r.size} cells")
    edges = np.ascontiguousarray(distance_edges, dtype=float)
    log_centres = np.ascontiguousarray(np.log(distance_centres(edges)))
    cx = np.asarray(transform.c + transform.a * (c + 0.5), dtype=np.float64)
    cy = np.asarray(transform.f + transform.e * (r + 0.5), dtype=np.float64)
    chunks = max(1, min(get_num_threads(), r.size // _CELLS_PER_CHUNK))
    out = np.zeros((chunks, weights.shape[0], values.shape[0], edges.size - 1, int(n_az)))
    dropped = np.zeros((chunks, values.shape[0]))
    _scatter_parallel(
        cx,
        cy,
        np.where(np.isnan(values), 0.0, values) if np.isnan(values).any() else values,
        weights,
        np.ascontiguousarray(factor),
        float(abs(transform.a)),
        float(observer[0]),
        float(observer[1]),
        edges,
        log_centres,
        not _nearest,
        int(n_az),
        int(max_samples),
        out,
        dropped,
    )
    return out.sum(axis=0), dropped.sum(axis=0)
