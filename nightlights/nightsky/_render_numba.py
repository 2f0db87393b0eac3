"""Compiled (numba) loops of the night-sky image: the diffuse sky's interpolation and the
scatter of star splats.

The same arithmetic as their numpy references, which the tests compare these to:
:func:`bilinear_separable` is :func:`nightlights.nightsky.render._bilinear_separable` (whose
numpy form makes four temporaries of the full image), :func:`scatter_add` is
``numpy.add.at`` (several times slower on the 700,000 values of all catalogue stars).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from nightlights._typing import FloatArray

__all__ = ["bilinear_separable", "scatter_add"]


@njit(cache=True, parallel=True)
def bilinear_separable(
    grid: FloatArray,
    row0: np.ndarray,
    row_fraction: FloatArray,
    col0: np.ndarray,
    col_fraction: FloatArray,
) -> FloatArray:
    """``(rows, cols, c)`` bilinear interpolation of ``grid`` (n_rows, n_cols, c) between grid
    rows ``row0``, ``row0 + 1`` and columns ``col0``, ``col0 + 1`` with the given fractions:
    along the grid's columns first, then across (the reference's order, so the same sums)."""
    rows, cols = row0.size, col0.size
    grid_cols, channels = grid.shape[1], grid.shape[2]
    out = np.empty((rows, cols, channels))
    for i in prange(rows):
        r, fr = row0[i], row_fraction[i]
        line = np.empty((grid_cols, channels))
        for j in range(grid_cols):
            for k in range(channels):
                line[j, k] = grid[r, j, k] * (1.0 - fr) + grid[r + 1, j, k] * fr
        for j in range(cols):
            c, fc = col0[j], col_fraction[j]
            for k in range(channels):
                out[i, j, k] = line[c, k] * (1.0 - fc) + line[c + 1, k] * fc
    return out


@njit(cache=True)
def scatter_add(target: FloatArray, index: np.ndarray, values: FloatArray) -> None:
    """``target[index[n]] += values[n]`` for every n in order, repeated indices accumulating
    (``numpy.add.at(target, index, values)``); ``target`` is 1-D."""
    for n in range(index.size):
        target[index[n]] += values[n]
