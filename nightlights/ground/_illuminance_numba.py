"""Compiled (numba) ground illuminance of point luminaires on a raster window.

The same sum as the numpy reference :func:`nightlights.ground.illuminance.ground_illuminance`
(which the tests compare this to, pixel by pixel, to 1e-6 relative): every luminaire adds

.. math:: E = I(V, H)\\, \\max(0, \\cos\\beta) / d^2

to each pixel centre inside its region of influence [1, Eq. 11]. One pass per luminaire over
the pixel rows of its disc; per row run, one loop computes the photometric angles and
:math:`\\max(0, \\cos\\beta) / d^2` (free of calls and branches, so that the compiler turns it
into SIMD code: the arc tangent is fdlibm's polynomial [2] with a branch-free reduction,
:func:`_atan2`), a second the bilinear candela lookup [1, Eq. 4]. No array per light-pixel
pair is made: the buffers hold one row.

Which pixels a luminaire lights, and the order in which luminaires add to a pixel, depend on
the pixel's index in the whole grid, never on the window, and every pixel goes through the
same arithmetic (fused multiply-adds allowed, no reassociation): a raster cut into any tiles,
on any scheduler, gives the same bits (tested).

References
----------
1. Chuang 2011, Secs. 4.2 and 5.1.
2. Sun Microsystems, fdlibm 5.3, ``s_atan.c`` (1993): the polynomial ``aT[0..10]``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.ground.frames import IntensityTable

__all__ = ["PackedTables", "pack_tables", "window_illuminance"]

#: Closest distance between a light point and a lit point [m]; the reference's
#: ``nightlights.ground.illuminance.MIN_DISTANCE``, repeated here so that this module does
#: not import the reference.
MIN_DISTANCE = 0.01

_DEGREES = 180.0 / math.pi
_QUARTER_PI = 0.25 * math.pi
_HALF_PI = 0.5 * math.pi
#: tan(pi / 8): above it the arc tangent's argument is reduced by pi / 4 [1].
_TAN_PI_8 = math.tan(math.pi / 8.0)
# arctan(u) = u - u (z S1(w) + w S2(w)), z = u^2, w = z^2, for |u| <= 7/16: the polynomial of
# fdlibm's s_atan.c [2], within 1 ulp of math.atan on |u| <= tan(pi / 8) (tested via _atan2).
_AT0 = 3.33333333333329318027e-01
_AT1 = -1.99999999998764832476e-01
_AT2 = 1.42857142725034663711e-01
_AT3 = -1.11111104054623557880e-01
_AT4 = 9.09088713343650656196e-02
_AT5 = -7.69187620504482999495e-02
_AT6 = 6.66107313738753120669e-02
_AT7 = -5.83357013379057348645e-02
_AT8 = 4.97687799461593236017e-02
_AT9 = -3.65315727442169155270e-02
_AT10 = 1.62858201153657823623e-02


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _atan2(y: float, x: float) -> float:  # pragma: no cover - compiled
    """math.atan2(y, x) without branches or calls, to ~1e-16 (0 for y = x = 0) [rad].

    With s = min(|x|, |y|) and l = max(|x|, |y|), arctan(s / l) is in [0, pi/4]; above
    tan(pi/8) it is pi/4 + arctan((s - l) / (s + l)), so that the polynomial's argument
    stays within tan(pi/8) and one division serves both cases. The octant follows from the
    signs and the larger component.
    """
    ay = abs(y)
    ax = abs(x)
    large = ay if ay > ax else ax
    small = ax if ay > ax else ay
    b = 1.0 if small > _TAN_PI_8 * large else 0.0
    denominator = large + b * small
    u = (small - b * large) / (denominator if denominator > 0.0 else 1.0)
    z = u * u
    w = z * z
    s1 = z * (_AT0 + w * (_AT2 + w * (_AT4 + w * (_AT6 + w * (_AT8 + w * _AT10)))))
    s2 = w * (_AT1 + w * (_AT3 + w * (_AT5 + w * (_AT7 + w * _AT9))))
    angle = b * _QUARTER_PI + (u - u * (s1 + s2))
    angle = _HALF_PI - angle if ay > ax else angle
    angle = math.pi - angle if x < 0.0 else angle
    return -angle if y < 0.0 else angle


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _photometric(
    dx: float,
    dy: float,
    dz: float,
    rot: tuple[float, float, float, float, float, float, float, float, float],
    azimuth: float,
    scale_v: float,
    scale_h: float,
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Table coordinates (fv, fh) of direction d from the light, and 1 / |d|."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    # body coordinates b = R^T d (right, forward, up); Chuang 2011, Eq. 5
    bx = r00 * dx + r10 * dy + r20 * dz
    by = r01 * dx + r11 * dy + r21 * dz
    bz = r02 * dx + r12 * dy + r22 * dz
    min2 = MIN_DISTANCE * MIN_DISTANCE
    d2_raw = dx * dx + dy * dy + dz * dz
    d2 = d2_raw if d2_raw > min2 else min2
    inv_d = 1.0 / math.sqrt(d2)
    # V = arccos(-b_z / d) as atan2(|b_xy|, -b_z); closer than MIN_DISTANCE, the
    # reference's clipped cosine
    cos_v = -bz * inv_d
    cos_v = cos_v if cos_v < 1.0 else 1.0
    cos_v = cos_v if cos_v > -1.0 else -1.0
    near = d2_raw <= min2
    sin_v = 1.0 - cos_v * cos_v if near else bx * bx + by * by
    sin_v = math.sqrt(sin_v if sin_v > 0.0 else 0.0)
    fv = _atan2(sin_v, cos_v if near else -bz) * scale_v
    # H = H_street + atan2(-b_x, b_y), wrapped into [0, 360)
    horizontal = _atan2(-bx, by) * _DEGREES + azimuth
    horizontal -= 360.0 * np.floor(horizontal * (1.0 / 360.0))
    return fv, horizontal * scale_h, inv_d


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _row_flat(
    fv: FloatArray,
    fh: FloatArray,
    factor: FloatArray,
    n: int,
    x0: float,
    first: int,
    resolution: float,
    dy: float,
    px: float,
    pz: float,
    rot: tuple[float, float, float, float, float, float, float, float, float],
    azimuth: float,
    scale_v: float,
    scale_h: float,
) -> None:  # pragma: no cover - compiled
    """(fv, fh) and cos(incidence) / d^2 on flat ground, z = 0, at columns first.. of a row."""
    dz = -pz
    for k in range(n):
        dx = (x0 + (first + k) * resolution) - px
        fv[k], fh[k], inv_d = _photometric(dx, dy, dz, rot, azimuth, scale_v, scale_h)
        cos_incidence = -dz * inv_d
        factor[k] = (cos_incidence if cos_incidence > 0.0 else 0.0) * (inv_d * inv_d)


@njit(cache=True, nogil=True, error_model="numpy")
def _row_terrain(
    fv: FloatArray,
    fh: FloatArray,
    factor: FloatArray,
    n: int,
    x0: float,
    first: int,
    resolution: float,
    dy: float,
    px: float,
    pz: float,
    rot: tuple[float, float, float, float, float, float, float, float, float],
    azimuth: float,
    scale_v: float,
    scale_h: float,
    ground_z: FloatArray,
    normals: FloatArray,
) -> None:  # pragma: no cover - compiled
    """As :func:`_row_flat` over a DEM: ground heights (n,) and unit normals (n, 3)."""
    for k in range(n):
        dx = (x0 + (first + k) * resolution) - px
        dz = ground_z[k] - pz
        fv[k], fh[k], inv_d = _photometric(dx, dy, dz, rot, azimuth, scale_v, scale_h)
        cos_incidence = -(normals[k, 0] * dx + normals[k, 1] * dy + normals[k, 2] * dz) * inv_d
        factor[k] = (cos_incidence if cos_incidence > 0.0 else 0.0) * (inv_d * inv_d)


@njit(cache=True, nogil=True, error_model="numpy")
def _row_lookup(
    values: FloatArray,
    fv: FloatArray,
    fh: FloatArray,
    factor: FloatArray,
    n: int,
    candela: FloatArray,
    offset: int,
    n_v: int,
    n_h: int,
) -> None:  # pragma: no cover - compiled
    """Bilinear candela at (fv, fh) times ``factor`` (Chuang 2011, Eq. 4), into ``values``."""
    top_v = n_v - 1.0
    top_h = n_h - 1.0
    for k in range(n):
        # NaN and rounding past the table's ends clamp
        v = fv[k] if fv[k] >= 0.0 else 0.0
        v = v if v <= top_v else top_v
        h = fh[k] if fh[k] >= 0.0 else 0.0
        h = h if h <= top_h else top_h
        iv = min(int(v), n_v - 2)
        ih = min(int(h), n_h - 2)
        tv = v - iv
        th = h - ih
        # unsigned (the clamps keep it >= 0): no negative-index wraparound per load
        base = np.uint64(offset + ih * n_v + iv)
        c00 = candela[base]
        c01 = candela[base + np.uint64(1)]
        c10 = candela[base + np.uint64(n_v)]
        c11 = candela[base + np.uint64(n_v + 1)]
        lower = c00 + tv * (c01 - c00)
        upper = c10 + tv * (c11 - c10)
        values[k] = (lower + th * (upper - lower)) * factor[k]


@njit(cache=True, nogil=True, error_model="numpy")
def _inside(col: int, x0: float, resolution: float, px: float, dy2: float, r2: float) -> bool:
    dx = (x0 + col * resolution) - px
    return dx * dx + dy2 <= r2  # pragma: no cover - compiled


@dataclass(frozen=True, eq=False)
class PackedTables:
    """Candela tables in one flat array, as the compiled kernel reads them.

    Attributes
    ----------
    candela
        All tables' candela values, each table row-major (horizontal, vertical) [cd].
    offset
        Start of each table in ``candela`` (tables,).
    shape
        (n_horizontal, n_vertical) of each table (tables, 2).
    scale
        (1 / vertical step, 1 / horizontal step) of each table (tables, 2) [deg-1].
    """

    candela: FloatArray
    offset: NDArray[np.int64]
    shape: NDArray[np.int64]
    scale: FloatArray


def pack_tables(tables: Sequence[IntensityTable]) -> PackedTables:
    """Pack candela tables for :func:`window_illuminance`.

    Parameters
    ----------
    tables
        Candela tables [cd].
    """
    sizes = [table.candela.size for table in tables]
    return PackedTables(
        np.concatenate([table.candela.ravel() for table in tables]).astype(np.float64),
        np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
        np.array([table.candela.shape for table in tables], dtype=np.int64).reshape(-1, 2),
        np.array(
            [(1.0 / table.vertical_step, 1.0 / table.horizontal_step) for table in tables],
            dtype=np.float64,
        ).reshape(-1, 2),
    )


#: Stand-ins for the DEM arrays on flat ground (never read).
_NO_GROUND = np.zeros((0, 0))
_NO_NORMALS = np.zeros((0, 0, 3))


def window_illuminance(
    out: FloatArray,
    offset: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.intp],
    weights: FloatArray,
    radius: FloatArray,
    tables: PackedTables,
    ground_z: FloatArray | None = None,
    normals: FloatArray | None = None,
) -> int:
    """Add the weighted illuminance of point luminaires to a raster window (compiled).

    Parameters
    ----------
    out
        Window (bands, rows, cols), float64, added to in place [band units].
    offset
        (row, col) of the window's top-left pixel in the grid [pixels].
    origin
        (x, y) of the centre of the grid's top-left pixel (row 0, column 0) [m].
    resolution
        Pixel size [m].
    light_point, rotation, street_azimuth, table_index, weights
        As :func:`nightlights.ground.illuminance.ground_illuminance` [m], [1], [deg], [1],
        [band unit per lx].
    radius
        Region-of-influence radius per light; ``inf`` lights every pixel [m].
    tables
        :func:`pack_tables` of the lights' candela tables.
    ground_z
        Ground elevation at the window's pixel centres (rows, cols); ``None`` for z = 0 [m].
    normals
        Unit surface normals of the window (rows, cols, 3); ``None`` for (0, 0, 1) [1].

    Returns
    -------
    int
        Light-pixel evaluations [1].
    """
    _, rows, cols = out.shape
    terrain = ground_z is not None or normals is not None
    if terrain:
        ground_z = np.zeros((rows, cols)) if ground_z is None else ground_z
        if normals is None:
            normals = np.zeros((rows, cols, 3))
            normals[..., 2] = 1.0
    return int(
        _window(
            out,
            int(offset[0]),
            int(offset[1]),
            float(origin[0]),
            float(origin[1]),
            float(resolution),
            np.ascontiguousarray(light_point, dtype=np.float64),
            np.ascontiguousarray(rotation, dtype=np.float64),
            np.ascontiguousarray(street_azimuth, dtype=np.float64),
            np.ascontiguousarray(table_index, dtype=np.int64),
            np.ascontiguousarray(weights, dtype=np.float64),
            np.ascontiguousarray(radius, dtype=np.float64),
            tables.candela,
            tables.offset,
            tables.shape,
            tables.scale,
            np.ascontiguousarray(ground_z if terrain else _NO_GROUND, dtype=np.float64),
            np.ascontiguousarray(normals if terrain else _NO_NORMALS, dtype=np.float64),
            terrain,
        )
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _window(
    out: FloatArray,
    row0: int,
    col0: int,
    x0: float,
    y0: float,
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.int64],
    weights: FloatArray,
    radius: FloatArray,
    candela: FloatArray,
    table_offset: NDArray[np.int64],
    table_shape: NDArray[np.int64],
    table_scale: FloatArray,
    ground_z: FloatArray,
    normals: FloatArray,
    terrain: bool,
) -> int:  # pragma: no cover - compiled
    # ``out`` is the window at global row ``row0`` and column ``col0`` of a grid whose pixel
    # (R, C) has its centre at (x0 + C res, y0 - R res). A light lights pixel (R, C) when
    # dx^2 + dy^2 <= radius^2 for the centre's offsets from the light point: the reference's
    # test, evaluated the same way.
    n_bands, rows, cols = out.shape
    fv = np.empty(cols)
    fh = np.empty(cols)
    factor = np.empty(cols)
    values = np.empty(cols)
    pairs = 0
    for i in range(light_point.shape[0]):
        px, py, pz = light_point[i, 0], light_point[i, 1], light_point[i, 2]
        r = radius[i]
        r2 = r * r
        table = table_index[i]
        offset = table_offset[table]
        n_h, n_v = table_shape[table, 0], table_shape[table, 1]
        scale_v = table_scale[table, 0] * _DEGREES
        scale_h = table_scale[table, 1]
        m = rotation[i]
        rot = (m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])
        # rows whose centre may lie within r of the light (one row of margin: the exact test
        # below decides), clipped to the window before converting to integers
        low = np.floor((y0 - (py + r)) / resolution) - 1.0
        high = np.ceil((y0 - (py - r)) / resolution) + 1.0
        first_row = int(min(max(low, float(row0)), float(row0 + rows)))
        last_row = int(min(max(high, float(row0 - 1)), float(row0 + rows - 1)))
        for row in range(first_row, last_row + 1):
            dy = (y0 - row * resolution) - py
            dy2 = dy * dy
            if not dy2 <= r2:
                continue
            half = math.sqrt(r2 - dy2)
            low = np.floor((px - half - x0) / resolution) - 1.0
            high = np.ceil((px + half - x0) / resolution) + 1.0
            first = int(min(max(low, float(col0)), float(col0 + cols)))
            last = int(min(max(high, float(col0 - 1)), float(col0 + cols - 1)))
            while first <= last and not _inside(first, x0, resolution, px, dy2, r2):
                first += 1
            while last >= first and not _inside(last, x0, resolution, px, dy2, r2):
                last -= 1
            if first > last:
                continue
            pairs += last - first + 1
            n = last - first + 1
            local = row - row0
            if terrain:
                _row_terrain(
                    fv,
                    fh,
                    factor,
                    n,
                    x0,
                    first,
                    resolution,
                    dy,
                    px,
                    pz,
                    rot,
                    street_azimuth[i],
                    scale_v,
                    scale_h,
                    ground_z[local, first - col0 : last - col0 + 1],
                    normals[local, first - col0 : last - col0 + 1],
                )
            else:
                _row_flat(
                    fv,
                    fh,
                    factor,
                    n,
                    x0,
                    first,
                    resolution,
                    dy,
                    px,
                    pz,
                    rot,
                    street_azimuth[i],
                    scale_v,
                    scale_h,
                )
            _row_lookup(values, fv, fh, factor, n, candela, offset, n_v, n_h)
            start = first - col0
            for band in range(n_bands):
                weight = weights[i, band]
                for k in range(n):
                    out[band, local, start + k] += weight * values[k]
    return pairs
