"""Emission raster -> the observer's polar map (distance x azimuth), conserving flux.

Dobashi et al. (2023, Sec. 3.3) sum the light of every ground cell into bins of distance and
azimuth around the observer; the panorama is then a convolution in azimuth. Here every raster
cell's flux (value x cell area) is split over k x k sub-points, k growing for cells close to
the observer where one cell spans many azimuth bins, so that the map conserves the flux.

A sub-point at distance r shares its flux between the two distance bins whose centres
c_i <= r < c_{i+1} enclose it, linearly in ln r (:func:`distance_shares`):

.. math::

    w_i = \\frac{\\ln c_{i+1} - \\ln r}{\\ln c_{i+1} - \\ln c_i}
    \\ \\text{to bin } i, \\qquad 1 - w_i \\ \\text{to bin } i + 1,

with c_i = sqrt(e_i e_{i+1}) the geometric centres of the bin edges e (the kernel's
``distance`` coordinate, :attr:`~nightlights.sky.spec.KernelSpec.distances`). Below the first
centre all the flux goes to bin 0, between the last centre and the last edge all to the last
bin; beyond the last edge it is left out (and counted as dropped). The weights sum to 1, so
the map still conserves the flux, and the panorama of a lone source, the kernel read through
these weights, is the kernel interpolated linearly in ln r between its bin images: it varies
smoothly with the source's distance instead of stepping at every bin edge (with 64 bins from
10 m to 30 km, one bin per sub-point saws the zenith of a lone 100 m cell moved from 3 to 7 km
by up to 12.9 % about a smooth fit, sharing by 0.39 %:
``benchmarks/bench_sky_distance_bins.py``). Beyond Dobashi et al. 2023, who bin each cell into
one distance bin.

Length: about 700 lines, because the cells, their sub-points and the distance shares they are
binned with are one construction that the forward map, the inverse and the darkness stencil
all read; apart, each piece would serve only the others.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 3.3.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
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


def lit_mask(emission: FloatArray) -> NDArray[np.bool_]:
    """Cells with non-zero flux in any band (NaN is no emission), without copying the raster.

    Parameters
    ----------
    emission
        Shape ``(bands, rows, cols)`` or ``(rows, cols)`` [lm m-2].

    Returns
    -------
    numpy.ndarray
        Boolean ``(rows, cols)``.

    Examples
    --------
    >>> import numpy as np
    >>> lit_mask(np.array([[[0.0, np.nan, 2.0]], [[0.0, 0.0, 0.0]]])).tolist()
    [[False, False, True]]
    """
    data = np.asarray(emission)
    if data.ndim == 2:
        data = data[None]
    return np.asarray(np.any(data > 0, axis=0) | np.any(data < 0, axis=0))


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


def distance_centres(distance_edges: ArrayLike) -> FloatArray:
    """The distance bin centres between which a sub-point's flux is shared.

    The geometric centres sqrt(e_i e_{i+1}), the kernel's ``distance`` coordinate
    (:attr:`~nightlights.sky.spec.KernelSpec.distances`); a first edge at or below 0 (a polar
    map that reaches the observer, never a kernel's: its edges are > 0) has no geometric
    centre, and that bin takes the arithmetic one, e_1 / 2.

    Parameters
    ----------
    distance_edges
        Distance bin edges, increasing [m].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_r,)`` [m].

    Examples
    --------
    >>> distance_centres([10.0, 100.0, 1000.0]).round(6).tolist()
    [31.622777, 316.227766]
    >>> distance_centres([0.0, 50.0, 200.0]).tolist()
    [25.0, 100.0]
    """
    e = np.asarray(distance_edges, dtype=float).ravel()
    centres = np.sqrt(np.maximum(e[:-1], 0.0) * e[1:])
    if centres.size and e[0] <= 0:
        centres[0] = 0.5 * e[1]
    return np.asarray(centres, dtype=float)


def distance_shares(
    distance: ArrayLike, distance_edges: ArrayLike
) -> tuple[NDArray[np.int64], FloatArray]:
    """The two distance bins a sub-point shares its flux between, and the lower one's weight.

    Linear in ln r between the bin centres c (:func:`distance_centres`): a sub-point at
    c_i <= r < c_{i+1} gives w = (ln c_{i+1} - ln r) / (ln c_{i+1} - ln c_i) of its flux to
    bin i and 1 - w to bin i + 1. Below the first centre bin 0 takes it all, from the last
    centre to the last edge the last bin; at or beyond the last edge the lower bin is ``n_r``
    (left out) and w = 1.

    Parameters
    ----------
    distance
        Distances from the observer, any shape [m].
    distance_edges
        Distance bin edges, increasing [m].

    Returns
    -------
    lower : numpy.ndarray
        The lower bin i, the shape of ``distance``; ``n_r`` beyond the last edge.
    weight : numpy.ndarray
        w, the lower bin's share of the flux (the upper bin i + 1 takes 1 - w) [1].

    Examples
    --------
    >>> edges = [10.0, 100.0, 1000.0, 10000.0]
    >>> centre = distance_centres(edges)[1]  # 316 m
    >>> lower, weight = distance_shares([20.0, centre, 1000.0, 5000.0, 1e4], edges)
    >>> lower.tolist(), weight.round(6).tolist()
    ([0, 1, 1, 2, 3], [1.0, 1.0, 0.5, 1.0, 1.0])
    """
    r = np.asarray(distance, dtype=float)
    edges = np.asarray(distance_edges, dtype=float).ravel()
    centres = distance_centres(edges)
    log_c = np.log(centres)
    n_r = centres.size
    lower = np.clip(np.searchsorted(centres, r, side="right") - 1, 0, n_r - 1)
    upper = np.minimum(lower + 1, n_r - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = (log_c[upper] - np.log(r)) / (log_c[upper] - log_c[lower])
    # below the first centre and from the last one on: one bin takes it all
    weight = np.where((r < centres[0]) | (upper == lower), 1.0, weight)
    lower = np.where(r >= edges[-1], n_r, lower)
    return lower.astype(np.int64), np.asarray(weight, dtype=float)


def _nearest_bin(
    distance: ArrayLike, distance_edges: ArrayLike
) -> tuple[NDArray[np.int64], FloatArray]:
    """The former one-bin rule, as :func:`distance_shares` returns it: the bin that holds r
    takes all (w = 1); kept as the reference of ``benchmarks/bench_sky_distance_bins.py``."""
    r = np.asarray(distance, dtype=float)
    edges = np.asarray(distance_edges, dtype=float).ravel()
    lower = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, edges.size - 1)
    return lower.astype(np.int64), np.ones(r.shape)


@dataclass(frozen=True)
class PolarCells:
    """The lit cells of a raster and where their sub-points fall in an observer's polar grid.

    The one geometry behind :func:`polar_map` (flux per bin) and the per-cell inverse
    quantities (:mod:`nightlights.inverse`): every lit cell is split into k x k sub-points
    (:func:`supersampling`), each carrying 1 / k**2 of the cell's flux into one azimuth bin
    and two neighbouring distance bins (:func:`distance_shares`). Each entry below is one
    (sub-point, distance bin) pair, ``share`` = 1 / k**2 times the bin's weight; a sub-point
    whose flux goes to one bin has one entry. Sub-points beyond the last distance edge are
    left out. Every quantity of a cell, forward (:meth:`binned`) or inverse (:meth:`per_cell`),
    reads these entries, so the inverse stays the transpose of the forward map.

    Attributes
    ----------
    rows, cols
        Raster row and column of each lit cell, shape ``(n_cells,)``.
    flux
        Shape ``(bands, n_cells)``: upward flux of each lit cell [lm].
    cell
        Shape ``(n_sub,)``: the lit cell each entry's sub-point belongs to.
    distance_bin, azimuth_bin
        Shape ``(n_sub,)``: the entry's bin.
    share
        Shape ``(n_sub,)``: the fraction of its cell's flux the entry carries [1].
    distance_edges
        Shape ``(n_r + 1,)`` [m].
    n_az
        Azimuth bins [1].
    total_flux
        Flux of the whole raster per band [lm].
    """

    rows: NDArray[np.int64]
    cols: NDArray[np.int64]
    flux: FloatArray
    cell: NDArray[np.int64]
    distance_bin: NDArray[np.int64]
    azimuth_bin: NDArray[np.int64]
    share: FloatArray
    distance_edges: FloatArray
    n_az: int
    total_flux: FloatArray

    @property
    def n_cells(self) -> int:
        """Number of lit cells."""
        return int(self.rows.size)

    def bin_index(self) -> NDArray[np.int64]:
        """Flat (distance, azimuth) bin of each entry, shape ``(n_sub,)``."""
        return self.distance_bin * self.n_az + self.azimuth_bin

    def binned(self, weights: FloatArray | None = None) -> FloatArray:
        """Flux per (band, distance, azimuth) bin, each cell's flux scaled by ``weights``.

        Parameters
        ----------
        weights
            Shape ``(n_cells,)``: factor on each cell's flux (default 1) [1].

        Returns
        -------
        numpy.ndarray
            Shape ``(bands, n_r, n_az)`` [lm].
        """
        bands = self.flux.shape[0]
        n_r = self.distance_edges.size - 1
        out = np.zeros((bands, n_r, self.n_az))
        if self.cell.size == 0:
            return out
        index = self.bin_index()
        scale = self.share if weights is None else self.share * weights[self.cell]
        for band in range(bands):
            out[band] = np.bincount(
                index, weights=self.flux[band, self.cell] * scale, minlength=n_r * self.n_az
            ).reshape(n_r, self.n_az)
        return out

    def per_cell(self, table: FloatArray) -> FloatArray:
        """A quantity per unit flux in each bin, summed over each cell's sub-points.

        Parameters
        ----------
        table
            Shape ``(bands, n_r, n_az)`` or ``(bands, n_r)`` (the same for every azimuth):
            the quantity per lumen in each bin [unit lm-1].

        Returns
        -------
        numpy.ndarray
            Shape ``(n_cells,)``: sum over bands and sub-points of flux x share x table [unit].
        """
        values = np.asarray(table, dtype=float)
        out = np.zeros(self.n_cells)
        if self.cell.size == 0:
            return out
        for band in range(self.flux.shape[0]):
            if values.ndim == 2:
                per_lumen = values[band, self.distance_bin]
            else:
                per_lumen = values[band, self.distance_bin, self.azimuth_bin]
            out += np.bincount(
                self.cell,
                weights=per_lumen * self.share * self.flux[band, self.cell],
                minlength=self.n_cells,
            )
        return out


def polar_cells(
    emission: FloatArray,
    transform: Affine,
    observer: tuple[float, float],
    *,
    distance_edges: FloatArray,
    n_az: int,
    max_samples: int = 16,
    lit: NDArray[np.bool_] | None = None,
) -> PolarCells:
    """Split the lit cells of an emission raster into sub-points of the observer's polar grid.

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
    lit
        The raster's :func:`lit_mask`, when already known.

    Returns
    -------
    PolarCells
        Sub-points share their flux between two distance bins (:func:`distance_shares`);
        those nearer than the first centre (the observer's own cell) go into the first
        distance bin, at their own azimuth; sub-points beyond the last edge are left out.
    """
    data = np.asarray(emission, dtype=float)
    if data.ndim == 2:
        data = data[None]
    if data.ndim != 3:
        raise InputError(f"emission must be (bands, rows, cols); got shape {data.shape}")
    rows, cols = np.nonzero(lit_mask(data) if lit is None else lit)
    return lit_polar_cells(
        rows,
        cols,
        data[:, rows, cols],
        transform,
        observer,
        distance_edges=distance_edges,
        n_az=n_az,
        max_samples=max_samples,
    )


def lit_polar_cells(
    rows: ArrayLike,
    cols: ArrayLike,
    values: ArrayLike,
    transform: Affine,
    observer: tuple[float, float],
    *,
    distance_edges: FloatArray,
    n_az: int,
    max_samples: int = 16,
) -> PolarCells:
    """:func:`polar_cells` of the lit cells alone (the sparse form of a raster).

    Parameters
    ----------
    rows, cols
        Raster row and column of each lit cell, shape ``(n_cells,)``.
    values
        Shape ``(bands, n_cells)``: their upward flux density [lm m-2]; NaN counts as none.
    transform
        Affine transform of the raster (square cells, north up) [m].
    observer
        Observer position (x, y) in the raster CRS [m].
    distance_edges, n_az, max_samples
        As :func:`polar_cells`.

    Returns
    -------
    PolarCells
        The cells in the order given.
    """
    return _lit_polar_cells(
        rows,
        cols,
        values,
        transform,
        observer,
        distance_edges=distance_edges,
        n_az=n_az,
        max_samples=max_samples,
        bins=distance_shares,
    )


def _lit_polar_cells(
    rows: ArrayLike,
    cols: ArrayLike,
    values: ArrayLike,
    transform: Affine,
    observer: tuple[float, float],
    *,
    distance_edges: FloatArray,
    n_az: int,
    max_samples: int,
    bins: Callable[[ArrayLike, ArrayLike], tuple[NDArray[np.int64], FloatArray]],
) -> PolarCells:
    """:func:`lit_polar_cells` with the distance rule ``bins`` (:func:`distance_shares`, or
    :func:`_nearest_bin`, the former one-bin rule the benchmark compares to)."""
    rows = np.asarray(rows, dtype=np.int64).ravel()
    cols = np.asarray(cols, dtype=np.int64).ravel()
    density = np.asarray(values, dtype=float)
    if density.ndim == 1:
        density = density[None]
    if density.ndim != 2 or density.shape[1] != rows.size:
        raise InputError(
            f"values of shape {density.shape}; expected (bands, {rows.size}) for the lit cells"
        )
    if (
        transform.b != 0
        or transform.d != 0
        or abs(abs(transform.a) - abs(transform.e)) > 1e-9 * abs(transform.a)
    ):
        raise InputError("emission raster must have square, north-up cells")
    edges = np.asarray(distance_edges, dtype=float)
    n_r = edges.size - 1
    cell = abs(transform.a)
    cell_flux = np.nan_to_num(density, nan=0.0) * cell * cell
    total = cell_flux.sum(axis=1)
    cx = transform.c + transform.a * (cols + 0.5) + transform.b * (rows + 0.5)
    cy = transform.f + transform.d * (cols + 0.5) + transform.e * (rows + 0.5)
    k = supersampling(
        cell, np.hypot(cx - observer[0], cy - observer[1]), n_az, max_samples=max_samples
    )
    members_all, d_all, a_all, share_all = [], [], [], []
    for samples in np.unique(k):
        members = np.nonzero(k == samples)[0]
        offsets = (np.arange(samples) + 0.5) / samples - 0.5
        ox, oy = np.meshgrid(offsets * cell, offsets * cell)
        px = (cx[members, None] + ox.ravel()[None, :]) - observer[0]
        py = (cy[members, None] + oy.ravel()[None, :]) - observer[1]
        r = np.hypot(px, py).ravel()
        azimuth = np.degrees(np.arctan2(px, py)).ravel() % 360.0
        lower, weight = bins(r, edges)
        inside = lower < n_r
        a_bin = np.minimum((azimuth * n_az / 360.0).astype(np.int64), n_az - 1)
        member = np.repeat(members, samples**2)
        # the lower bin's entries, then the upper bin's of the sub-points that share
        shared = inside & (weight < 1.0)
        members_all += [member[inside], member[shared]]
        d_all += [lower[inside], lower[shared] + 1]
        a_all += [a_bin[inside], a_bin[shared]]
        share_all += [weight[inside] / samples**2, (1.0 - weight[shared]) / samples**2]

    def join(parts: list[np.ndarray], dtype: type) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)

    return PolarCells(
        rows=rows.astype(np.int64),
        cols=cols.astype(np.int64),
        flux=cell_flux,
        cell=join(members_all, np.int64),
        distance_bin=join(d_all, np.int64),
        azimuth_bin=join(a_all, np.int64),
        share=join(share_all, np.float64),
        distance_edges=edges,
        n_az=int(n_az),
        total_flux=total,
    )


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
        Sub-points share their flux between two distance bins (:func:`distance_shares`);
        those nearer than the first centre (the observer's own cell) go into the first bin,
        at their own azimuth; sub-points beyond the last edge are dropped and counted.
    """
    cells = polar_cells(
        emission,
        transform,
        observer,
        distance_edges=distance_edges,
        n_az=n_az,
        max_samples=max_samples,
    )
    return _map_of(cells, None, warn=warn)


def _map_of(cells: PolarCells, weights: FloatArray | None, *, warn: bool) -> PolarMap:
    """The polar map of the cells' flux scaled by ``weights`` (default 1)."""
    flux = cells.binned(weights)
    if weights is None:
        total = cells.total_flux
    else:
        total = (cells.flux * weights[None, :]).sum(axis=1)
    dropped = total - flux.sum(axis=(1, 2))
    if warn:
        _warn_dropped(dropped, total, cells.distance_edges)
    return PolarMap(flux, cells.distance_edges, cells.n_az, dropped, total)


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
    lit = lit_mask(data)
    if np.any(lit & ~np.isfinite(heights)):
        raise InputError("source altitude missing (NaN) under lit emission cells")
    cells = polar_cells(
        data,
        transform,
        observer,
        distance_edges=distance_edges,
        n_az=n_az,
        max_samples=max_samples,
        lit=lit,
    )
    return level_maps(cells, source_level_weights(heights[cells.rows, cells.cols], levels))


def level_maps(cells: PolarCells, weights: FloatArray) -> list[PolarMap]:
    """One polar map per source level: each cell's flux scaled by its level weight.

    Parameters
    ----------
    cells
        The lit cells in the observer's polar grid.
    weights
        Shape ``(n_levels, n_cells)``: each cell's share of every level
        (:func:`source_level_weights`) [1].

    Returns
    -------
    list of PolarMap
        One per level; warns (:class:`~nightlights.errors.DataQualityWarning`) once when
        flux lies beyond the last distance edge.
    """
    maps = [_map_of(cells, weights[level], warn=False) for level in range(weights.shape[0])]
    _warn_dropped(
        np.sum([m.dropped_flux for m in maps], axis=0),
        np.sum([m.total_flux for m in maps], axis=0),
        cells.distance_edges,
    )
    return maps
