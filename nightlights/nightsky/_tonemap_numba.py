"""Compiled (numba) steps of the night-vision tone mapping.

The same arithmetic as the numpy reference in :mod:`nightlights.nightsky.tonemap`
(:func:`~nightlights.nightsky.tonemap.log_average_luminance`,
:func:`~nightlights.nightsky.tonemap.blue_shift`, the acuity blur, the compressive curve of
:func:`~nightlights.nightsky.tonemap.reinhard_global` and
:func:`~nightlights.nightsky.tonemap.xyz_to_srgb`), which stays the reference the tests compare
this to. Two passes over the image, rows in parallel, and no full-size temporaries (the numpy
form makes about twenty):

1. :func:`perceived_pixels`: the valid pixels, the sum of log luminance for the adaptation
   and, for the eye, the blue shift;
2. :func:`display_pixels` / :func:`display_codes`: for each output row, the blur down the
   columns into a one-row buffer, the blur across it, the display curve and the sRGB encoding.
   The 8-bit form looks the code value up (a 4096-entry table and the 255 thresholds where the
   code steps up) instead of raising each channel to the power 1/2.4.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from nightlights._typing import FloatArray

__all__ = ["display_codes", "display_pixels", "perceived_pixels"]


@njit(cache=True, parallel=True)
def perceived_pixels(
    values: FloatArray,
    floor: float,
    blue: bool,
    blue_x: float,
    blue_y: float,
    scotopic_scale: float,
    low: float,
    high: float,
) -> tuple[FloatArray, np.ndarray, float, int]:
    """Clean ``(n, 3)`` XYZ pixels, sum their log luminance and (``blue``) blue-shift them.

    A pixel is valid where its three values are finite; valid pixels keep max(value, 0), the
    others become 0. With ``blue`` the result is the perceived XYZ of
    :func:`~nightlights.nightsky.tonemap.blue_shift` (the mesopic range 10^low-10^high
    cd m-2). Returns the pixels, the valid flags, the sum over valid pixels of log(floor + Y)
    and their number (the log-average luminance is exp(sum / number)).
    """
    n = values.shape[0]
    out = np.empty((n, 3))
    valid = np.empty(n, dtype=np.bool_)
    log_sum = 0.0
    count = 0
    # below 10^low the mesopic weight is 0, above 10^high it is 1: no logarithm needed there
    y_low, y_high = 10.0**low, 10.0**high
    for i in prange(n):
        x, y, z = values[i, 0], values[i, 1], values[i, 2]
        ok = math.isfinite(x) and math.isfinite(y) and math.isfinite(z)
        valid[i] = ok
        if ok:
            x, y, z = max(x, 0.0), max(y, 0.0), max(z, 0.0)
            log_sum += math.log(floor + y)
            count += 1
        else:
            x, y, z = 0.0, 0.0, 0.0
        if not blue:
            out[i, 0], out[i, 1], out[i, 2] = x, y, z
            continue
        # mesopic_weight
        if y <= y_low:
            t = 0.0
        elif y >= y_high:
            t = 1.0
        else:
            t = min(max((math.log10(y) - low) / (high - low), 0.0), 1.0)
        s = t * t * (3.0 - 2.0 * t)
        # chromaticity, the blue point where there is no light
        total = x + y + z
        if total > 0.0:
            x_chrom, y_chrom = x / total, y / total
        else:
            x_chrom, y_chrom = blue_x, blue_y
        x_new = (1.0 - s) * blue_x + s * x_chrom
        y_new = (1.0 - s) * blue_y + s * y_chrom
        # scotopic_luminance
        scotopic = 0.0
        if x > 0.0:
            scotopic = max(y * (1.33 * (1.0 + (y + z) / x) - 1.68), 0.0)
        lum = scotopic_scale * (1.0 - s) * scotopic + s * y
        out[i, 0] = x_new * lum / y_new
        out[i, 1] = lum
        out[i, 2] = (1.0 - x_new - y_new) * lum / y_new
    return out, valid, log_sum, count


@njit(cache=True)
def _blur_down(
    values: FloatArray, valid: np.ndarray, weights: FloatArray, i: int, line: FloatArray
) -> FloatArray:
    """Row ``i`` of the ``(rows, cols, 3)`` image blurred down the columns by ``weights`` (odd
    length, edges extended by the nearest row, scipy.ndimage's ``mode="nearest"``) into
    ``line[:, :3]``, and of the valid mask into ``line[:, 3]``."""
    rows, cols = valid.shape
    radius = (weights.size - 1) // 2
    line[:] = 0.0
    for t in range(-radius, radius + 1):
        source = min(max(i + t, 0), rows - 1)
        w = weights[t + radius]
        for j in range(cols):
            line[j, 0] += w * values[source, j, 0]
            line[j, 1] += w * values[source, j, 1]
            line[j, 2] += w * values[source, j, 2]
            if valid[source, j]:
                line[j, 3] += w
    return line


@njit(cache=True, inline="always")
def _blur_across(
    line: FloatArray, weights: FloatArray, j: int, renormalise: bool
) -> tuple[float, float, float]:
    """Pixel ``j`` of a :func:`_blur_down` line blurred across it; with ``renormalise``
    divided by the blurred valid mask (0 where it is 0)."""
    cols = line.shape[0]
    radius = (weights.size - 1) // 2
    x = y = z = cover = 0.0
    for t in range(-radius, radius + 1):
        w = weights[t + radius]
        source = min(max(j + t, 0), cols - 1)
        x += w * line[source, 0]
        y += w * line[source, 1]
        z += w * line[source, 2]
        cover += w * line[source, 3]
    if renormalise:
        if cover > 0.0:
            return x / cover, y / cover, z / cover
        return 0.0, 0.0, 0.0
    return x, y, z


@njit(cache=True, inline="always")
def _linear_srgb(
    x: float, y: float, z: float, scale: float, compress: bool, matrix: FloatArray
) -> tuple[float, float, float]:
    """Linear sRGB in [0, 1] of one XYZ pixel: exposure ``scale``, the compressive curve
    L / (1 + L) when ``compress``, then the gamut mapping of
    :func:`~nightlights.nightsky.tonemap.xyz_to_srgb`."""
    if compress:
        scaled = scale * y
        ratio = (scaled / (1.0 + scaled)) / y if y > 0.0 else 0.0
    else:
        ratio = scale
    x, y, z = x * ratio, y * ratio, z * ratio
    if math.isnan(x):
        x = 0.0
    if math.isnan(y):
        y = 0.0
    if math.isnan(z):
        z = 0.0
    luminance = max(y, 0.0)
    grey = min(luminance, 1.0)
    # XYZ to linear sRGB; a luminance above 1 is white at that chromaticity
    norm = luminance if luminance > 1.0 else 1.0
    r = (x * matrix[0, 0] + y * matrix[0, 1] + z * matrix[0, 2]) / norm
    g = (x * matrix[1, 0] + y * matrix[1, 1] + z * matrix[1, 2]) / norm
    b = (x * matrix[2, 0] + y * matrix[2, 1] + z * matrix[2, 2]) / norm
    # the least desaturation toward the grey of the same luminance that fits the gamut
    mix = 1.0
    for away in (r - grey, g - grey, b - grey):
        if away > 0.0:
            mix = min(mix, (1.0 - grey) / away)
        elif away < 0.0:
            mix = min(mix, grey / -away)
    mix = max(mix, 0.0)
    return (
        min(max(grey + mix * (r - grey), 0.0), 1.0),
        min(max(grey + mix * (g - grey), 0.0), 1.0),
        min(max(grey + mix * (b - grey), 0.0), 1.0),
    )


@njit(cache=True, inline="always")
def _encode(linear: float) -> float:
    """The IEC 61966-2-1 transfer function of a linear value in [0, 1]."""
    return 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1.0 / 2.4) - 0.055


@njit(cache=True, inline="always")
def _code(linear: float, table: np.ndarray, thresholds: FloatArray) -> int:
    """8-bit code of a linear value in [0, 1]: the number of ``thresholds`` at or below it,
    started from the ``table`` entry of its bin and corrected by at most a step or two."""
    code = int(table[int(linear * (table.size - 1))])
    while code < thresholds.size and linear >= thresholds[code]:
        code += 1
    while code > 0 and linear < thresholds[code - 1]:
        code -= 1
    return code


@njit(cache=True, parallel=True)
def display_pixels(
    values: FloatArray,
    valid: np.ndarray,
    weights: FloatArray,
    renormalise: bool,
    scale: float,
    compress: bool,
    matrix: FloatArray,
) -> FloatArray:
    """sRGB in [0, 1] of a ``(rows, cols, 3)`` XYZ image: blurred by ``weights`` down and
    across (``[1.0]``: no blur; ``renormalise``: by the blurred ``(rows, cols)`` valid mask),
    then :func:`_linear_srgb` and the transfer function; pixels not ``valid`` are black."""
    rows, cols = valid.shape
    out = np.zeros((rows, cols, 3))
    for i in prange(rows):
        line = _blur_down(values, valid, weights, i, np.empty((cols, 4)))
        for j in range(cols):
            if not valid[i, j]:
                continue
            x, y, z = _blur_across(line, weights, j, renormalise)
            r, g, b = _linear_srgb(x, y, z, scale, compress, matrix)
            out[i, j, 0] = _encode(r)
            out[i, j, 1] = _encode(g)
            out[i, j, 2] = _encode(b)
    return out


@njit(cache=True, parallel=True)
def display_codes(
    values: FloatArray,
    valid: np.ndarray,
    weights: FloatArray,
    renormalise: bool,
    scale: float,
    compress: bool,
    matrix: FloatArray,
    table: np.ndarray,
    thresholds: FloatArray,
) -> np.ndarray:
    """8-bit sRGB code values of :func:`display_pixels`, floor(255 v + 0.5), looked up with
    :func:`_code` (``thresholds``: the 255 ascending linear values where the code steps up;
    ``table``: the code at each of its entries spread evenly over [0, 1])."""
    rows, cols = valid.shape
    out = np.zeros((rows, cols, 3), dtype=np.uint8)
    for i in prange(rows):
        line = _blur_down(values, valid, weights, i, np.empty((cols, 4)))
        for j in range(cols):
            if not valid[i, j]:
                continue
            x, y, z = _blur_across(line, weights, j, renormalise)
            r, g, b = _linear_srgb(x, y, z, scale, compress, matrix)
            out[i, j, 0] = _code(r, table, thresholds)
            out[i, j, 1] = _code(g, table, thresholds)
            out[i, j, 2] = _code(b, table, thresholds)
    return out
