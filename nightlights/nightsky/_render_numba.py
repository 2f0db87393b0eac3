"""Compiled (numba) bilinear interpolation of the diffuse sky onto an equirectangular image.

The same arithmetic as :func:`nightlights.nightsky.render._bilinear_separable` (the numpy
reference the tests compare this to), written as one loop over the output pixels, rows in
parallel: the numpy form makes four temporaries of the full image.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from nightlights._typing import FloatArray

__all__ = ["bilinear_separable"]


@njit(cache=True, parallel=True)
def bilinear_separable(
    grid: FloatArray,
    row0: np.ndarray,
    row_fraction: FloatArray,
    col0: np.ndarray,
    col_fraction: FloatArray,
) -> FloatArray:
    """``(rows, cols, c)`` bilinear interpolation of ``grid`` (n_rows, n_cols, c) between grid
    rows ``row0``, ``row0 + 1`` and columns ``col0``, ``col0 + 1`` with the given fractions."""
    rows, cols, channels = row0.size, col0.size, grid.shape[2]
    out = np.empty((rows, cols, channels))
    for i in prange(rows):
        r, fr = row0[i], row_fraction[i]
        for j in range(cols):
            c, fc = col0[j], col_fraction[j]
            for k in range(channels):
                left = grid[r, c, k] * (1.0 - fr) + grid[r + 1, c, k] * fr
                right = grid[r, c + 1, k] * (1.0 - fr) + grid[r + 1, c + 1, k] * fr
                out[i, j, k] = left * (1.0 - fc) + right * fc
    return out
