"""Each lit cell's influence on an observer's sky: Q_i and S_i (Dobashi et al. 2023, Sec. 4).

Skyglow is linear in the emission, so any linear measure of the panorama,
``M[L] = sum_(el, az) W(el, az) L(el, az)`` for pixel weights W, splits exactly into one term per
lit cell. With the PCA kernel (Dobashi Eq. 4), a unit of flux in polar bin (d, a) adds
``sum_k c_dk B_k(el, az - a)`` to the panorama (Eqs. 7-9), so its part of M is

    M_da = sum_k c_dk G_k(a),   G_k(a) = sum_(el, az) W(el, az) B_k(el, az - a),

and G_k is the cross-correlation in azimuth of the weights with basis k, one FFT per basis:
``F[G_k] = sum_el F[W_el] conj(F[B_k,el])``. A cell's value is the sum of M_da over its polar
sub-points (:class:`nightlights.sky.polar.PolarCells`: the same split as the forward polar
map), weighted by its flux and by its share of each source-altitude level, so the values of
all cells add up to the forward panorama's M. The whole raster costs one panorama-sized FFT
per basis plus a table lookup per sub-point. These splits are sky algebra, shared by the inverse
stages (:mod:`nightlights.inverse`) and the many-observer stage (:mod:`nightlights.sky.observers`).

The weights W make the metrics:

- **S_i** (Eqs. 13-14): W = 1 on the pixels of a region of the sky (``pixel``, the paper's sum)
  or W = pixel solid angle / region solid angle (``solid-angle``: S_i is the cell's part of
  the region's mean luminance [cd m-2]);
- **zenith**: W = 1 / n_az on the top row (the forward panorama's zenith luminance);
- **hemisphere**: W = pixel solid angle / visible sky's solid angle (mean sky luminance).

Pixels the terrain hides (NaN in the forward panorama) weigh 0. The reference
(``brute``) sums each sub-point's raw kernel image over the weights directly, without PCA
or FFT.

Q_i (Eqs. 10-11) is not linear in the panorama: Q(r) = sqrt(sum_k c_k^2) is the L2 norm of
the kernel image over the panorama's pixels (the bases are orthonormal), so it depends on the
panorama grid: more rows near the horizon or a finer azimuth step weigh those directions
more, and it carries no solid-angle weighting. Between two observer levels of the kernel,
Q is interpolated linearly between the levels' norms.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Eqs. 4, 7-14.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.sky.panorama import KernelSlice
from nightlights.sky.polar import PolarCells

__all__ = [
    "METRICS",
    "WEIGHTS",
    "cell_values",
    "cell_values_brute",
    "hemisphere_weights",
    "pca_norm_table",
    "pixel_solid_angle",
    "region_table",
    "region_weights",
    "zenith_weights",
]

#: Q metrics: Dobashi's Eq. 10 norm, the zenith and the hemisphere-mean luminance.
METRICS = ("pca-norm", "zenith", "hemisphere")
#: Pixel weights of S: solid angle (the region's mean luminance) or 1 (Dobashi Eq. 14).
WEIGHTS = ("solid-angle", "pixel")


def pixel_solid_angle(elevation: FloatArray, n_az: int) -> FloatArray:
    """Solid angle of one pixel of each panorama row.

    Parameters
    ----------
    elevation
        Row centres, equally spaced over 0-90 deg, zenith first [deg].
    n_az
        Azimuth columns [1].

    Returns
    -------
    numpy.ndarray
        ``(n_el,)`` [sr]; the rows of a full panorama add up to 2 pi.

    Examples
    --------
    >>> import numpy as np
    >>> from nightlights.sky.spec import panorama_elevations
    >>> omega = pixel_solid_angle(panorama_elevations(16), 64)
    >>> bool(np.isclose(omega.sum() * 64, 2 * np.pi))
    True
    """
    el = np.radians(np.asarray(elevation, dtype=float))
    half = 0.5 * np.pi / 2.0 / el.size
    top = np.minimum(el + half, np.pi / 2)
    bottom = np.maximum(el - half, 0.0)
    return (np.sin(top) - np.sin(bottom)) * 2.0 * np.pi / n_az


def region_weights(
    mask: np.ndarray, elevation: FloatArray, *, weight: str = "solid-angle"
) -> FloatArray:
    """Pixel weights of S over a region of the sky.

    Parameters
    ----------
    mask
        ``(n_el, n_az)`` True on the region's visible pixels.
    elevation
        Row centres [deg].
    weight
        ``solid-angle``: solid angle over the region's solid angle (S is then the cell's part
        of the region's mean luminance); ``pixel``: 1 per pixel (Dobashi Eq. 14) [1].

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` [1].
    """
    if weight not in WEIGHTS:
        raise InputError(f"weight {weight!r}; expected one of {', '.join(WEIGHTS)}")
    inside = np.asarray(mask, dtype=bool)
    if not inside.any():
        raise InputError(
            "the sky region covers no visible panorama pixel (pixel centres inside it, above "
            "the terrain); draw it larger or use more panorama rows/columns"
        )
    if weight == "pixel":
        return inside.astype(float)
    omega = np.broadcast_to(pixel_solid_angle(elevation, inside.shape[1])[:, None], inside.shape)
    w = np.where(inside, omega, 0.0)
    return w / w.sum()


def zenith_weights(n_el: int, n_az: int) -> FloatArray:
    """Pixel weights of the zenith luminance: the mean of the top row.

    Parameters
    ----------
    n_el, n_az
        Panorama shape [1].

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` [1].
    """
    w = np.zeros((n_el, n_az))
    w[0] = 1.0 / n_az
    return w


def hemisphere_weights(below_terrain: np.ndarray, elevation: FloatArray) -> FloatArray:
    """Pixel weights of the mean luminance of the visible sky (solid-angle weighted).

    Parameters
    ----------
    below_terrain
        ``(n_el, n_az)`` True where the terrain hides the sky.
    elevation
        Row centres [deg].

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` [1], summing to 1.
    """
    return region_weights(~np.asarray(below_terrain, dtype=bool), elevation)


def pca_norm_table(tables: KernelSlice, components: int | None = None) -> FloatArray:
    """Dobashi's light-pollution level per lumen, Q(r) = sqrt(sum_k c_k^2) (Eq. 10).

    Parameters
    ----------
    tables
        Kernel slice of one source level; with two interleaved observer levels each level's
        norm is taken and the two are added with their weights (already in the coefficients).
    components
        Use only the first ``components`` coefficients (default: all) [1].

    Returns
    -------
    numpy.ndarray
        ``(bands, n_r)`` [cd m-2 lm-1].
    """
    coefficient = tables.coefficient[..., : _components(tables, components)]
    pieces = len(tables.observer_weights)
    return np.sum(
        [np.sqrt(np.sum(coefficient[..., p::pieces] ** 2, axis=-1)) for p in range(pieces)],
        axis=0,
    )


def region_table(
    tables: KernelSlice, weights: FloatArray, components: int | None = None
) -> FloatArray:
    """M per lumen in every polar bin, by PCA and FFT: ``sum_k c_dk G_k(a)``.

    Parameters
    ----------
    tables
        Kernel slice of one source level.
    weights
        ``(n_el, n_az)`` pixel weights W [1].
    components
        Use only the first ``components`` bases (default: all) [1].

    Returns
    -------
    numpy.ndarray
        ``(bands, n_r, n_az)`` [cd m-2 lm-1].
    """
    k = _components(tables, components)
    w = np.asarray(weights, dtype=float)
    if w.shape != (tables.elevation.size, tables.n_az):
        raise InputError(
            f"weights of shape {w.shape}; expected the panorama's "
            f"({tables.elevation.size}, {tables.n_az})"
        )
    rows = np.nonzero(np.any(w != 0, axis=1))[0]
    w_fft = np.fft.rfft(w[rows], axis=-1)  # (rows, n_freq)
    # F[G_k](f) = sum_el F[W_el](f) conj(F[B_k,el](f))
    g_fft = np.einsum("ef,kef->kf", w_fft, np.conj(tables.basis_fft[:k, rows]))
    g = np.fft.irfft(g_fft, n=tables.n_az, axis=-1)  # (k, n_az)
    return np.einsum("bdk,ka->bda", tables.coefficient[..., :k], g)


def cell_values_brute(
    cells: PolarCells,
    level_weights: FloatArray,
    slices: Sequence[KernelSlice],
    weights: FloatArray,
    *,
    chunk: int = 256,
) -> FloatArray:
    """Reference for :func:`region_table` + :func:`cell_values`: each cell's kernel image.

    Every sub-point's raw kernel image (its distance bin, shifted to its azimuth, at each
    source level) is summed over the weights directly, without PCA or FFT (Dobashi et al.
    2023, Eqs. 13-14 as written): the cost grows as cells x pixels.

    Parameters
    ----------
    cells
        The lit cells' polar sub-points.
    level_weights
        ``(n_levels, n_cells)`` [1].
    slices
        One kernel slice with raw tables per source level.
    weights
        ``(n_el, n_az)`` pixel weights W [1].
    chunk
        Sub-points per vectorised step [1].

    Returns
    -------
    numpy.ndarray
        ``(n_cells,)`` [cd m-2].
    """
    w = np.asarray(weights, dtype=float)
    rows = np.nonzero(np.any(w != 0, axis=1))[0]
    w = w[rows]
    out = np.zeros(cells.n_cells)
    for level, tables in zip(level_weights, slices, strict=True):
        if not np.any(level > 0):
            continue
        if not tables.has_tables:
            raise InputError(
                "the kernel stores no raw images (built without tables); the brute-force "
                "reference needs them"
            )
        n_az = tables.n_az
        kernel = tables.kernel[:, :, rows]  # (bands, n_r, rows, n_az)
        columns = np.arange(n_az)
        for start in range(0, cells.cell.size, chunk):
            part = slice(start, start + chunk)
            cell, d, a = cells.cell[part], cells.distance_bin[part], cells.azimuth_bin[part]
            # a unit of flux at azimuth bin a lights pixel (el, j) with kernel column j - a
            shift = (columns[None, :] - a[:, None]) % n_az  # (chunk, n_az)
            scale = cells.share[part] * level[cell]
            for band in range(cells.flux.shape[0]):
                images = np.take_along_axis(kernel[band, d], shift[:, None, :], axis=-1)
                per_lumen = np.einsum("sej,ej->s", images, w)
                out += np.bincount(
                    cell,
                    weights=per_lumen * scale * cells.flux[band, cell],
                    minlength=cells.n_cells,
                )
    return out


def cell_values(
    cells: PolarCells, level_weights: FloatArray, tables: Sequence[FloatArray]
) -> FloatArray:
    """Per-cell sums of a per-lumen table, each cell read at its own source levels.

    Parameters
    ----------
    cells
        The lit cells' polar sub-points.
    level_weights
        ``(n_levels, n_cells)``: each cell's share of each source level [1].
    tables
        One table per level, ``(bands, n_r)`` or ``(bands, n_r, n_az)`` [unit lm-1].

    Returns
    -------
    numpy.ndarray
        ``(n_cells,)`` [unit].
    """
    out = np.zeros(cells.n_cells)
    for weight, table in zip(level_weights, tables, strict=True):
        if np.any(weight > 0):
            out += weight * cells.per_cell(table)
    return out


def _components(tables: KernelSlice, components: int | None) -> int:
    stored = tables.coefficient.shape[-1]
    k = stored if components is None else int(components)
    if not 1 <= k <= stored:
        raise InputError(f"components={components}; the kernel stores 1-{stored}")
    return k
