"""Pure functions on photometric grids: symmetry unfolding, interpolation and exact integrals.

A candela table is held as ``candela[i, j]`` at horizontal angle ``H[i]`` and vertical angle
``V[j]`` (degrees). Lookups interpolate it bilinearly (Chuang 2011, Sec. 4.2, Eq. 4) or with
a bicubic interpolating spline. Integrals over the sphere are exact for the piecewise-bilinear
interpolant: inside a grid cell the interpolant is linear in V times linear in H, so the solid-
angle integral separates into closed-form node weights (see :func:`node_weights`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import RectBivariateSpline

Kernel = Literal["one", "sin", "cos"]

#: Tolerance for comparing angles read from files [deg].
ANGLE_TOLERANCE = 1e-6


def unfold_type_c(
    horizontal: NDArray[np.float64], candela: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], str]:
    """Unfold a type C table with LM-63 horizontal symmetry to cover 0-360 deg inclusive.

    Parameters
    ----------
    horizontal : ndarray, shape (n_h,)
        Ascending horizontal angles as read from the file [deg].
    candela : ndarray, shape (n_h, n_v)
        Intensities per horizontal plane [cd].

    Returns
    -------
    horizontal : ndarray, shape (m,)
        Ascending angles from 0 to 360 inclusive [deg].
    candela : ndarray, shape (m, n_v)
        Intensities on the unfolded planes; the 360 row repeats the 0 row [cd].
    symmetry : str
        ``"rotational"`` (one plane), ``"0-90"`` (quadrant), ``"0-180"`` (bilateral about
        the 0-180 plane), ``"90-270"`` (bilateral about the 90-270 plane), ``"0-360"``
        (none) or ``"0-360 (360 missing)"``.

    Raises
    ------
    ValueError
        For a range that matches none of the LM-63 symmetries.

    References
    ----------
    ANSI/IES LM-63-19, Sec. 5.15 (horizontal angles of type C photometry).
    """
    h = np.asarray(horizontal, dtype=float)
    cd = np.asarray(candela, dtype=float)
    first, last = h[0], h[-1]

    def close(a: float, b: float) -> bool:
        return abs(a - b) <= ANGLE_TOLERANCE

    if h.size == 1:
        return np.array([0.0, 360.0]), np.vstack([cd, cd]), "rotational"
    if close(first, 0.0) and close(last, 90.0):
        # quadrant: mirror about 90 (H -> 180 - H), then about 180 (H -> 360 - H)
        h2, cd2 = _mirror(h, cd, 180.0)
        h4, cd4 = _mirror(h2, cd2, 360.0)
        return h4, cd4, "0-90"
    if close(first, 0.0) and close(last, 180.0):
        h2, cd2 = _mirror(h, cd, 360.0)
        return h2, cd2, "0-180"
    if close(first, 90.0) and close(last, 270.0):
        # bilateral about the 90-270 plane: I(H) = I(180 - H) = I(540 - H) (mod 360)
        if not np.any(np.abs(h - 180.0) <= ANGLE_TOLERANCE):
            row = np.array([np.interp(180.0, h, column) for column in cd.T])
            position = int(np.searchsorted(h, 180.0))
            h = np.insert(h, position, 180.0)
            cd = np.insert(cd, position, row, axis=0)
        lower = (h > 90.0 + ANGLE_TOLERANCE) & (h <= 180.0 + ANGLE_TOLERANCE)
        upper = (h >= 180.0 - ANGLE_TOLERANCE) & (h < 270.0 - ANGLE_TOLERANCE)
        h_all = np.concatenate([180.0 - h[lower][::-1], h, 540.0 - h[upper][::-1]])
        cd_all = np.vstack([cd[lower][::-1], cd, cd[upper][::-1]])
        return h_all, cd_all, "90-270"
    if close(first, 0.0) and close(last, 360.0):
        return h.copy(), cd.copy(), "0-360"
    if close(first, 0.0) and 180.0 < last < 360.0:
        return np.append(h, 360.0), np.vstack([cd, cd[:1]]), "0-360 (360 missing)"
    raise ValueError(
        f"horizontal angles {first:g}..{last:g} deg match no LM-63 symmetry "
        "(expected one plane, 0-90, 0-180, 90-270 or 0-360)"
    )


def _mirror(
    h: NDArray[np.float64], cd: NDArray[np.float64], axis_sum: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Append the mirror image H -> axis_sum - H of a table covering 0..axis_sum/2."""
    keep = h < axis_sum / 2.0 - ANGLE_TOLERANCE
    mirrored_h = axis_sum - h[keep][::-1]
    return np.concatenate([h, mirrored_h]), np.vstack([cd, cd[keep][::-1]])


def bilinear(
    vertical_grid: NDArray[np.float64],
    horizontal_grid: NDArray[np.float64],
    candela: NDArray[np.float64],
    vertical: ArrayLike,
    horizontal: ArrayLike,
    *,
    periodic: bool,
) -> NDArray[np.float64]:
    """Bilinear interpolation of a candela table at any angles (Chuang 2011, Eq. 4).

    Parameters
    ----------
    vertical_grid : ndarray, shape (n_v,)
        Ascending vertical angles of the table [deg].
    horizontal_grid : ndarray, shape (n_h,)
        Ascending horizontal angles; 0..360 inclusive when ``periodic`` [deg].
    candela : ndarray, shape (n_h, n_v)
        Intensities [cd].
    vertical, horizontal : array_like
        Directions to look up, broadcast against each other [deg].
    periodic : bool
        Wrap ``horizontal`` modulo 360 (type C) instead of returning 0 outside.

    Returns
    -------
    ndarray
        Intensity, 0 outside the measured range, NaN for NaN angles [cd].

    References
    ----------
    Chuang 2011, Sec. 4.2, Eq. 4.
    """
    v, h = np.broadcast_arrays(np.asarray(vertical, float), np.asarray(horizontal, float))
    if periodic:
        h = np.mod(h, 360.0)
    inside = (v >= vertical_grid[0]) & (v <= vertical_grid[-1])
    inside &= (h >= horizontal_grid[0]) & (h <= horizontal_grid[-1])
    j, s = _cell(vertical_grid, v)
    i, t = _cell(horizontal_grid, h)
    c00 = candela[i, j]
    c01 = candela[i, j + 1]
    c10 = candela[i + 1, j]
    c11 = candela[i + 1, j + 1]
    value = (1.0 - t) * ((1.0 - s) * c00 + s * c01) + t * ((1.0 - s) * c10 + s * c11)
    value = np.where(inside, value, 0.0)
    return np.where(np.isnan(v) | np.isnan(h), np.nan, value)


def _cell(grid: NDArray[np.float64], x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray]:
    """Index of the cell [grid[k], grid[k+1]] holding x, and the fraction across it."""
    if grid.size == 1:
        return np.zeros(x.shape, dtype=np.intp), np.zeros(x.shape)
    k = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2)
    width = grid[k + 1] - grid[k]
    fraction = np.where(width > 0, (x - grid[k]) / np.where(width > 0, width, 1.0), 0.0)
    return k, np.clip(fraction, 0.0, 1.0)


class CubicTable:
    """Bicubic interpolating spline of a candela table, clipped to non-negative values.

    The horizontal axis is extended periodically by one turn each side for type C tables, so
    the spline is smooth across 0/360 deg. Like any interpolating cubic it can overshoot next
    to sharp cut-offs; negative overshoot is clipped to 0 cd.

    Parameters
    ----------
    vertical_grid : ndarray, shape (n_v,)
        Ascending vertical angles [deg].
    horizontal_grid : ndarray, shape (n_h,)
        Ascending horizontal angles; 0..360 inclusive when ``periodic`` [deg].
    candela : ndarray, shape (n_h, n_v)
        Intensities [cd].
    periodic : bool
        Whether the horizontal axis wraps at 360 deg.
    """

    def __init__(
        self,
        vertical_grid: NDArray[np.float64],
        horizontal_grid: NDArray[np.float64],
        candela: NDArray[np.float64],
        *,
        periodic: bool,
    ) -> None:
        self.vertical_grid = vertical_grid
        self.horizontal_grid = horizontal_grid
        self.periodic = periodic
        h, cd = horizontal_grid, candela
        if periodic:
            base_h, base_cd = h[:-1], cd[:-1]
            turns = (-1, 0, 1) if base_h.size >= 2 else (-2, -1, 0, 1, 2)
            h = np.concatenate([base_h + 360.0 * k for k in turns])
            cd = np.vstack([base_cd for _ in turns])
        kx = min(3, h.size - 1)
        ky = min(3, vertical_grid.size - 1)
        self._spline = RectBivariateSpline(h, vertical_grid, cd, kx=kx, ky=ky, s=0)

    def __call__(self, vertical: ArrayLike, horizontal: ArrayLike) -> NDArray[np.float64]:
        """Intensity at the given angles, 0 outside the measured range [cd]."""
        v, h = np.broadcast_arrays(np.asarray(vertical, float), np.asarray(horizontal, float))
        if self.periodic:
            h = np.mod(h, 360.0)
        inside = (v >= self.vertical_grid[0]) & (v <= self.vertical_grid[-1])
        inside &= (h >= self.horizontal_grid[0]) & (h <= self.horizontal_grid[-1])
        safe_v = np.where(inside, v, self.vertical_grid[0])
        safe_h = np.where(inside, h, self.horizontal_grid[0])
        value = self._spline.ev(safe_h.ravel(), safe_v.ravel()).reshape(v.shape)
        value = np.where(inside, np.maximum(value, 0.0), 0.0)
        return np.where(np.isnan(v) | np.isnan(h), np.nan, value)


def node_weights(angles_deg: NDArray[np.float64], kernel: Kernel) -> NDArray[np.float64]:
    """Exact quadrature weights of a piecewise-linear function times a kernel.

    For nodes x_0 < ... < x_n (radians) and f linear between nodes,
    ``sum(w * f(x)) == integral(f(x) * k(x) dx)`` exactly, with ``k`` = 1, sin or cos.

    Parameters
    ----------
    angles_deg : ndarray, shape (n,)
        Ascending node angles [deg].
    kernel : {"one", "sin", "cos"}
        Weight function of the solid-angle element [1].

    Returns
    -------
    ndarray, shape (n,)
        Weights [rad] (kernel integrals over radians).
    """
    x = np.radians(np.asarray(angles_deg, dtype=float))
    weights = np.zeros(x.size)
    if x.size < 2:
        return weights
    a, b = x[:-1], x[1:]
    h = b - a
    ok = h > 0
    a, b, h = a[ok], b[ok], h[ok]
    if kernel == "one":
        left = right = h / 2.0
    elif kernel == "sin":
        mean_sin = (np.sin(b) - np.sin(a)) / h
        left = np.cos(a) - mean_sin
        right = -np.cos(b) + mean_sin
    elif kernel == "cos":
        total = np.sin(b) - np.sin(a)
        right = np.sin(b) + (np.cos(b) - np.cos(a)) / h
        left = total - right
    else:  # pragma: no cover - guarded by the Literal type
        raise ValueError(f"unknown kernel {kernel!r}")
    index = np.nonzero(ok)[0]
    np.add.at(weights, index, left)
    np.add.at(weights, index + 1, right)
    return weights


def zone_nodes(grid: NDArray[np.float64], low: float, high: float) -> NDArray[np.float64]:
    """Grid nodes inside [low, high] plus the clipped zone ends (empty if no overlap) [deg]."""
    low_c = max(low, float(grid[0]))
    high_c = min(high, float(grid[-1]))
    if high_c <= low_c:
        return np.empty(0)
    inner = grid[(grid > low_c) & (grid < high_c)]
    return np.concatenate([[low_c], inner, [high_c]])
