"""Compiled (numba) deposit of a geographic window's flux on a tile's local metric grid.

The same binning as :func:`nightlights.sky._tiles.deposit_exact`, which stays the reference the
tests compare this to: every lit source cell is split into k x k sub-points, each carrying
1 / k**2 of the cell's flux, shared bilinearly between the four local cell centres around it
(``linear``, the default; else all into the cell it falls in). Here a sub-point's local position
is not projected by PROJ but interpolated bilinearly between the exactly projected corners of a
lattice of source cells (:func:`nightlights.sky._tiles.lattice_step`): a projection is smooth
over a few kilometres, so that the position error is second order in the lattice's span
(:math:`\\delta \\approx L^2 / 8R` for a span L on a sphere of radius R: under a metre at
:data:`nightlights.sky._tiles.LATTICE_SPAN`). Written as one loop over the lit cells that
scatters straight into the grid, releasing the GIL, so that tiles computed in threads run side
by side and no per-sub-point arrays are made.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nightlights._typing import FloatArray

__all__ = ["deposit_lattice"]


@njit(cache=True, nogil=True)
def _deposit(
    lit_r: np.ndarray,
    lit_c: np.ndarray,
    values: FloatArray,
    k: int,
    node_r: FloatArray,
    node_c: FloatArray,
    gx: FloatArray,
    gy: FloatArray,
    out: FloatArray,
    linear: bool,
) -> None:  # pragma: no cover - compiled; checked against the numpy reference in the tests
    bands, rows, cols = out.shape
    n_r, n_c = node_r.size, node_c.size
    step_r = node_r[1] - node_r[0] if n_r > 1 else 1.0
    step_c = node_c[1] - node_c[0] if n_c > 1 else 1.0
    share = 1.0 / (k * k)
    for i in range(lit_r.size):
        for a in range(k):
            fr = lit_r[i] + (a + 0.5) / k
            p = min(int(fr / step_r), n_r - 2)
            u = (fr - node_r[p]) / (node_r[p + 1] - node_r[p])
            for b in range(k):
                fc = lit_c[i] + (b + 0.5) / k
                q = min(int(fc / step_c), n_c - 2)
                v = (fc - node_c[q]) / (node_c[q + 1] - node_c[q])
                w00, w01 = (1 - u) * (1 - v), (1 - u) * v
                w10, w11 = u * (1 - v), u * v
                x = w00 * gx[p, q] + w01 * gx[p, q + 1]
                x += w10 * gx[p + 1, q] + w11 * gx[p + 1, q + 1]
                y = w00 * gy[p, q] + w01 * gy[p, q + 1]
                y += w10 * gy[p + 1, q] + w11 * gy[p + 1, q + 1]
                if not linear:
                    col = math.floor(x)
                    row = math.floor(y)
                    if 0 <= row < rows and 0 <= col < cols:
                        for band in range(bands):
                            out[band, row, col] += values[band, i] * share
                    continue
                xc, yc = x - 0.5, y - 0.5
                col = math.floor(xc)
                row = math.floor(yc)
                fx, fy = xc - col, yc - row
                for dr in range(2):
                    rr = row + dr
                    if rr < 0 or rr >= rows:
                        continue
                    wr = fy if dr else 1.0 - fy
                    for dc in range(2):
                        cc = col + dc
                        if cc < 0 or cc >= cols:
                            continue
                        w = wr * (fx if dc else 1.0 - fx) * share
                        for band in range(bands):
                            out[band, rr, cc] += values[band, i] * w


def deposit_lattice(
    lit_r: np.ndarray,
    lit_c: np.ndarray,
    values: FloatArray,
    k: int,
    node_r: FloatArray,
    node_c: FloatArray,
    gx: FloatArray,
    gy: FloatArray,
    shape: tuple[int, int],
    linear: bool = True,
) -> FloatArray:
    """Flux per local cell ``(bands, rows, cols)`` [lm] of lit source cells.

    Parameters
    ----------
    lit_r, lit_c
        Rows and columns of the lit cells in the source window [1].
    values
        Their flux ``(bands, n)`` [lm].
    k
        Sub-points per side of a cell [1].
    node_r, node_c
        The lattice's source row and column edges in the window, from 0 to its size, evenly
        spaced but for the last step [1].
    gx, gy
        The local grid's fractional column and row of each lattice node
        ``(node_r.size, node_c.size)`` [1].
    shape
        (rows, cols) of the local grid.
    """
    out = np.zeros((values.shape[0], *shape))
    if lit_r.size:
        _deposit(
            np.ascontiguousarray(lit_r, dtype=np.int64),
            np.ascontiguousarray(lit_c, dtype=np.int64),
            np.ascontiguousarray(values, dtype=np.float64),
            int(k),
            np.ascontiguousarray(node_r, dtype=np.float64),
            np.ascontiguousarray(node_c, dtype=np.float64),
            np.ascontiguousarray(gx, dtype=np.float64),
            np.ascontiguousarray(gy, dtype=np.float64),
            out,
            bool(linear),
        )
    return out
