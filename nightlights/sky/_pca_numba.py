"""Compiled (numba) sums of the kernel's accuracy measure, for the PCA's error-target search.

The same sums as :func:`nightlights.sky.pca._error_sums` (which stays the reference the tests
compare this to): over the pixels of each image (row) brighter than a fraction of the image's
maximum, the sum of |approx - exact| / exact and the number of such pixels. Written as one
loop per row (rows in parallel), so that no masks, gathered pixels or float64 copies of
float32 images are made: the shared basis's search and check reconstruct a block of images
and measure it in one pass over its pixels.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

__all__ = ["bright_error_sums"]


@njit(parallel=True, cache=True, fastmath={"reassoc", "nsz", "contract"})
def _sums(
    approx: NDArray[np.floating], exact: NDArray[np.floating], fraction: NDArray[np.floating]
) -> tuple[float, int]:  # pragma: no cover - compiled
    n, p = exact.shape
    totals = np.zeros(n)
    counts = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        peak = exact[i, 0]
        for j in range(1, p):
            peak = max(peak, exact[i, j])
        if not peak > 0:
            continue
        limit = fraction[0] * peak  # in the images' precision, as the numpy reference
        total = 0.0
        count = 0
        for j in range(p):  # branch-free, so that the loop runs on vector registers
            value = float(exact[i, j])
            bright = exact[i, j] > limit
            relative = abs(float(approx[i, j]) - value) / (value if bright else 1.0)
            total += relative if bright else 0.0
            count += 1 if bright else 0
        totals[i] = total
        counts[i] = count
    return totals.sum(), counts.sum()


def bright_error_sums(
    approx: NDArray[np.floating], exact: NDArray[np.floating], fraction: float
) -> tuple[float, int]:
    """Sum of the relative errors over the bright pixels of each image, and their count.

    Parameters
    ----------
    approx
        Reconstructed images, shape ``(n, p)`` [any unit].
    exact
        The images, same shape, float32 or float64 [same unit].
    fraction
        A pixel counts when brighter than this fraction of its image's maximum [1].

    Returns
    -------
    total : float
        Sum of |approx - exact| / exact over the counted pixels [1].
    count : int
        Number of counted pixels [1].
    """
    if exact.shape[0] == 0 or exact.shape[1] == 0:
        return 0.0, 0
    threshold = np.full(1, fraction, dtype=exact.dtype)
    total, count = _sums(np.ascontiguousarray(approx), np.ascontiguousarray(exact), threshold)
    return float(total), int(count)
