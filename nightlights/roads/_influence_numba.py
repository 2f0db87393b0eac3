"""Compiled (numba) kernels of the road influence matrices (:mod:`nightlights.roads._influence`).

The same sums as the numpy reference of that module's tests (``road_luminance``,
``glare_geometry`` and a point-by-point illuminance), one loop over points or observers, each
finding its luminaires in a uniform grid of cells as wide as the largest reach, two passes
(count, then fill, each over points in parallel) that write compressed sparse rows directly:

- :func:`surface_rows`: for each road point the luminaires within each one's reach, their
  intensity towards the point (the luminaire's body frame, type C angles, the ground stage's
  bilinear candela lookup, :meth:`nightlights.ground.frames.IntensityTable.lookup`) and the
  horizontal illuminance :math:`I h / d^3`;
- :func:`luminance_rows`: for each (point, observer) sample, :math:`10^{-4} r(\\beta,
  \\tan\\gamma) I / h^2` over the point's luminaires, with r read bilinearly from the r-table
  resampled on a fine regular grid (:func:`resample_rtable`);
- :func:`veiling_rows`: for each observer, :math:`K(A) E / \\theta^2` of every luminaire ahead
  within the glare reach, below the screening angle and 1.5-60 deg from the line of sight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.ground.frames import IntensityTable

__all__ = [
    "PackedCandela",
    "RGrid",
    "light_grid",
    "luminance_rows",
    "pack_candela",
    "surface_rows",
    "veiling_rows",
]

IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class PackedCandela:
    """Candela tables of several light systems in one flat array.

    Attributes
    ----------
    values
        Every table's (n_h, n_v) candela, raveled and concatenated [cd].
    offset, n_v, n_h
        Start of each table in ``values`` and its shape.
    v_step, h_step
        Each table's angle steps [deg].
    """

    values: FloatArray
    offset: IntArray
    n_v: IntArray
    n_h: IntArray
    v_step: FloatArray
    h_step: FloatArray


def pack_candela(tables: tuple[IntensityTable, ...]) -> PackedCandela:
    """Pack the luminaires' candela tables for the kernels."""
    sizes = np.array([t.candela.size for t in tables], dtype=np.int64)
    return PackedCandela(
        np.concatenate([np.ascontiguousarray(t.candela, dtype=float).ravel() for t in tables]),
        np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
        np.array([t.candela.shape[1] for t in tables], dtype=np.int64),
        np.array([t.candela.shape[0] for t in tables], dtype=np.int64),
        np.array([t.vertical_step for t in tables], dtype=float),
        np.array([t.horizontal_step for t in tables], dtype=float),
    )


@dataclass(frozen=True)
class RGrid:
    """An r-table resampled on a regular (tan gamma, beta) grid for bilinear reading.

    Attributes
    ----------
    values
        r on the grid, (n_tan, n_beta) [10^-4 sr-1].
    tan_step, beta_step
        Grid steps [1], [deg].
    tan_max
        The table's last tan(gamma) [1].
    zero_beyond
        r is 0 beyond ``tan_max`` (else the last row).
    """

    values: FloatArray
    tan_step: float
    beta_step: float
    tan_max: float
    zero_beyond: bool


def light_grid(xy: FloatArray, cell: float) -> tuple[float, float, int, int, IntArray, IntArray]:
    """Luminaires sorted into square cells of side ``cell``.

    Returns
    -------
    x0, y0, nx, ny
        Origin [m] and size of the grid.
    start
        Start of each cell's luminaires in ``order`` (nx * ny + 1,).
    order
        Luminaire indices sorted by cell.
    """
    x0, y0 = float(xy[:, 0].min()), float(xy[:, 1].min())
    ix = np.floor((xy[:, 0] - x0) / cell).astype(np.int64)
    iy = np.floor((xy[:, 1] - y0) / cell).astype(np.int64)
    nx, ny = int(ix.max()) + 1, int(iy.max()) + 1
    key = iy * nx + ix
    order = np.argsort(key, kind="stable").astype(np.int64)
    start = np.searchsorted(key[order], np.arange(nx * ny + 1)).astype(np.int64)
    return x0, y0, nx, ny, start, order


@njit(cache=True, nogil=True, inline="always")
def _candela(
    values: FloatArray,
    offset: int,
    n_v: int,
    n_h: int,
    v_step: float,
    h_step: float,
    rotation: FloatArray,
    azimuth: float,
    dx: float,
    dy: float,
    dz: float,
) -> float:  # pragma: no cover - compiled
    # body = R^T d; photometric frame (forward, left, up) = (b_y, -b_x, b_z)
    bx = rotation[0, 0] * dx + rotation[1, 0] * dy + rotation[2, 0] * dz
    by = rotation[0, 1] * dx + rotation[1, 1] * dy + rotation[2, 1] * dz
    bz = rotation[0, 2] * dx + rotation[1, 2] * dy + rotation[2, 2] * dz
    length = math.sqrt(bx * bx + by * by + bz * bz)
    if length == 0.0:
        vertical = 0.0
    else:
        c = -bz / length
        c = min(1.0, max(-1.0, c))
        vertical = math.degrees(math.acos(c))
    horizontal = (math.degrees(math.atan2(-bx, by)) + azimuth) % 360.0
    fv = vertical / v_step
    fh = horizontal / h_step
    iv = min(int(fv), n_v - 2)
    ih = min(int(fh), n_h - 2)
    tv = fv - iv
    th = fh - ih
    base = offset + ih * n_v + iv
    c00 = values[base]
    c01 = values[base + 1]
    c10 = values[base + n_v]
    c11 = values[base + n_v + 1]
    lower = c00 + tv * (c01 - c00)
    upper = c10 + tv * (c11 - c10)
    return lower + th * (upper - lower)


@njit(cache=True, nogil=True, parallel=True)
def surface_rows(
    points: FloatArray,
    light_point: FloatArray,
    rotation: FloatArray,
    azimuth: FloatArray,
    table: IntArray,
    scale: FloatArray,
    reach: FloatArray,
    grid: tuple[float, float, int, int, IntArray, IntArray],
    cell: float,
    values: FloatArray,
    offset: IntArray,
    n_v: IntArray,
    n_h: IntArray,
    v_step: FloatArray,
    h_step: FloatArray,
) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """CSR rows of the road points: (indptr, light, candela, illuminance)."""
    x0, y0, nx, ny, start, order = grid
    n = points.shape[0]
    counts = np.zeros(n + 1, dtype=np.int64)
    for p in prange(n):
        px, py = points[p, 0], points[p, 1]
        cx = math.floor((px - x0) / cell)
        cy = math.floor((py - y0) / cell)
        found = 0
        for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                g = gy * nx + gx
                for q in range(start[g], start[g + 1]):
                    k = order[q]
                    dx = px - light_point[k, 0]
                    dy = py - light_point[k, 1]
                    if dx * dx + dy * dy <= reach[k] * reach[k]:
                        found += 1
        counts[p + 1] = found
    indptr = np.cumsum(counts)
    total = indptr[n]
    light = np.empty(total, dtype=np.int64)
    candela = np.empty(total)
    value = np.empty(total)
    for p in prange(n):
        px, py = points[p, 0], points[p, 1]
        cx = math.floor((px - x0) / cell)
        cy = math.floor((py - y0) / cell)
        at = indptr[p]
        for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                g = gy * nx + gx
                for q in range(start[g], start[g + 1]):
                    k = order[q]
                    dx = px - light_point[k, 0]
                    dy = py - light_point[k, 1]
                    if dx * dx + dy * dy > reach[k] * reach[k]:
                        continue
                    dz = -light_point[k, 2]
                    t = table[k]
                    i = scale[k] * _candela(
                        values, offset[t], n_v[t], n_h[t], v_step[t], h_step[t],
                        rotation[k], azimuth[k], dx, dy, dz,
                    )  # fmt: skip
                    d = math.sqrt(dx * dx + dy * dy + dz * dz)
                    light[at] = k
                    candela[at] = i
                    value[at] = i * light_point[k, 2] / (d * d * d)
                    at += 1
    return indptr, light, candela, value


@njit(cache=True, nogil=True, parallel=True)
def luminance_rows(
    sample_point: IntArray,
    sample_observer: IntArray,
    points: FloatArray,
    eyes: FloatArray,
    indptr: IntArray,
    light: IntArray,
    candela: FloatArray,
    light_point: FloatArray,
    r_values: FloatArray,
    tan_step: float,
    beta_step: float,
    tan_max: float,
    zero_beyond: bool,
) -> tuple[IntArray, FloatArray]:  # pragma: no cover - compiled
    """CSR rows of the luminance samples: (indptr, values); columns are ``light`` of the
    sample's point, in the same order."""
    n = sample_point.shape[0]
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    for s in range(n):
        p = sample_point[s]
        out_ptr[s + 1] = out_ptr[s] + indptr[p + 1] - indptr[p]
    value = np.empty(out_ptr[n])
    n_t, n_b = r_values.shape
    for s in prange(n):
        p = sample_point[s]
        o = sample_observer[s]
        px, py = points[p, 0], points[p, 1]
        vx, vy = px - eyes[o, 0], py - eyes[o, 1]
        view = math.sqrt(vx * vx + vy * vy)
        at = out_ptr[s]
        for q in range(indptr[p], indptr[p + 1]):
            k = light[q]
            lx = light_point[k, 0] - px
            ly = light_point[k, 1] - py
            h = light_point[k, 2]
            horizontal = math.sqrt(lx * lx + ly * ly)
            denominator = max(horizontal * view, 1e-300)
            c = (lx * vx + ly * vy) / denominator
            c = min(1.0, max(-1.0, c))
            beta = math.degrees(math.acos(c))
            tan_gamma = horizontal / h
            if tan_gamma > tan_max:
                if zero_beyond:
                    value[at] = 0.0
                    at += 1
                    continue
                tan_gamma = tan_max
            ft = tan_gamma / tan_step
            fb = beta / beta_step
            it = min(int(ft), n_t - 2)
            ib = min(int(fb), n_b - 2)
            wt = ft - it
            wb = fb - ib
            r0 = r_values[it, ib] + wb * (r_values[it, ib + 1] - r_values[it, ib])
            r1 = r_values[it + 1, ib] + wb * (r_values[it + 1, ib + 1] - r_values[it + 1, ib])
            r = r0 + wt * (r1 - r0)
            value[at] = r * 1e-4 * candela[q] / (h * h)
            at += 1
    return out_ptr, value


@njit(cache=True, nogil=True)
def veiling_rows(
    eyes: FloatArray,
    sight: FloatArray,
    eye_height: float,
    light_point: FloatArray,
    rotation: FloatArray,
    azimuth: FloatArray,
    table: IntArray,
    scale: FloatArray,
    grid: tuple[float, float, int, int, IntArray, IntArray],
    cell: float,
    reach: float,
    depression: float,
    screening: float,
    low: float,
    high: float,
    factor: float,
    values: FloatArray,
    offset: IntArray,
    n_v: IntArray,
    n_h: IntArray,
    v_step: FloatArray,
    h_step: FloatArray,
) -> tuple[IntArray, IntArray, FloatArray]:  # pragma: no cover - compiled
    """CSR rows of the observers' veiling luminance: (indptr, light, value)."""
    x0, y0, nx, ny, start, order = grid
    n = eyes.shape[0]
    cos_d, sin_d = math.cos(math.radians(depression)), math.sin(math.radians(depression))
    counts = np.zeros(n + 1, dtype=np.int64)
    lights_out = []
    values_out = []
    for o in range(n):
        ex, ey = eyes[o, 0], eyes[o, 1]
        sx, sy, sz = sight[o, 0] * cos_d, sight[o, 1] * cos_d, -sin_d
        cx = math.floor((ex - x0) / cell)
        cy = math.floor((ey - y0) / cell)
        found = 0
        for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                g = gy * nx + gx
                for q in range(start[g], start[g + 1]):
                    k = order[q]
                    dx = light_point[k, 0] - ex
                    dy = light_point[k, 1] - ey
                    if dx * dx + dy * dy > reach * reach:
                        continue
                    if dx * sight[o, 0] + dy * sight[o, 1] <= 0.0:
                        continue
                    dz = light_point[k, 2] - eye_height
                    d = math.sqrt(dx * dx + dy * dy + dz * dz)
                    elevation = math.degrees(math.asin(min(1.0, max(-1.0, dz / d))))
                    if elevation >= screening:
                        continue
                    c = (dx * sx + dy * sy + dz * sz) / d
                    c = min(1.0, max(-1.0, c))
                    angle = math.degrees(math.acos(c))
                    if angle < low or angle > high:
                        continue
                    t = table[k]
                    i = scale[k] * _candela(
                        values, offset[t], n_v[t], n_h[t], v_step[t], h_step[t],
                        rotation[k], azimuth[k], -dx, -dy, -dz,
                    )  # fmt: skip
                    e = i * c / (d * d)
                    lights_out.append(k)
                    values_out.append(factor * e / (angle * angle))
                    found += 1
        counts[o + 1] = found
    indptr = np.cumsum(counts)
    light = np.empty(len(lights_out), dtype=np.int64)
    value = np.empty(len(values_out))
    for i in range(len(lights_out)):
        light[i] = lights_out[i]
        value[i] = values_out[i]
    return indptr, light, value
