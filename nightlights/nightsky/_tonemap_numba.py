"""Compiled (numba) per-pixel steps of the night-vision tone mapping.

The same arithmetic as :func:`nightlights.nightsky.tonemap.blue_shift` and the display end of
:func:`nightlights.nightsky.tonemap.tone_map` (the compressive curve of
:func:`~nightlights.nightsky.tonemap.reinhard_global` and
:func:`~nightlights.nightsky.tonemap.xyz_to_srgb`), which stay the reference the tests compare
this to. Written as one loop over pixels, rows in parallel, so that a 2048 x 1024 picture makes
no full-size temporaries: the numpy form makes about twenty.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from nightlights._typing import FloatArray

__all__ = ["blue_shift_pixels", "display_pixels"]


@njit(cache=True, parallel=True)
def blue_shift_pixels(
    values: FloatArray,
    blue_x: float,
    blue_y: float,
    scotopic_scale: float,
    low: float,
    high: float,
) -> FloatArray:
    """Perceived XYZ of ``(n, 3)`` pixels (:func:`~nightlights.nightsky.tonemap.blue_shift`)."""
    out = np.empty_like(values)
    for i in prange(values.shape[0]):
        x, y, z = values[i, 0], values[i, 1], values[i, 2]
        # mesopic_weight
        if y > 0.0:
            t = min(max((math.log10(y) - low) / (high - low), 0.0), 1.0)
        else:
            t = 0.0
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
    return out


@njit(cache=True, inline="always")
def _encode(linear: float) -> float:
    """Clip to [0, 1] and apply the IEC 61966-2-1 transfer function."""
    v = min(max(linear, 0.0), 1.0)
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1.0 / 2.4) - 0.055


@njit(cache=True, parallel=True)
def display_pixels(
    values: FloatArray,
    valid: np.ndarray,
    scale: float,
    compress: bool,
    matrix: FloatArray,
) -> FloatArray:
    """sRGB in [0, 1] of ``(n, 3)`` XYZ pixels: exposure ``scale``, the compressive curve
    L / (1 + L) when ``compress``, then :func:`~nightlights.nightsky.tonemap.xyz_to_srgb`;
    pixels not ``valid`` are black."""
    out = np.zeros_like(values)
    for i in prange(values.shape[0]):
        if not valid[i]:
            continue
        x, y, z = values[i, 0], values[i, 1], values[i, 2]
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
        mix = np.inf
        for away in (r - grey, g - grey, b - grey):
            if away > 0.0:
                mix = min(mix, (1.0 - grey) / away)
            elif away < 0.0:
                mix = min(mix, grey / -away)
        mix = min(max(mix, 0.0), 1.0)
        out[i, 0] = _encode(grey + mix * (r - grey))
        out[i, 1] = _encode(grey + mix * (g - grey))
        out[i, 2] = _encode(grey + mix * (b - grey))
    return out
