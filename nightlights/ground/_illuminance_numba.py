"""Compiled (numba) ground illuminance of point luminaires on a raster window.

The same sum as the numpy reference :func:`nightlights.ground.illuminance.ground_illuminance`
(which the tests compare this to, pixel by pixel, to 1e-6 relative): every luminaire adds

.. math:: E = I(V, H)\\, \\max(0, \\cos\\beta) / d^2

to each pixel centre inside its region of influence [1, Eq. 11]. The window is done in blocks
of :data:`BLOCK` x :data:`BLOCK` pixels (512 KiB of float64 a band, which stays in a core's
L2 cache while the luminaires add to it); in each block, one pass per luminaire over the pixel
rows of its disc. Per row run, three loops, the first two free of calls and branches so that
the compiler turns them into SIMD code:

1. the reduced arc-tangent arguments of V and H and :math:`\\max(0, \\cos\\beta) / d^2`:

   * the light's body coordinates :math:`b = R^T d` [1, Eq. 5] with the row's terms hoisted;
   * :math:`V = \\operatorname{atan2}(|b_{xy}|, -b_z)` and
     :math:`H = H_{street} + \\operatorname{atan2}(-b_x, b_y)`, each reduced without branches
     to an offset plus :math:`\\arctan u` with :math:`|u| \\le \\tan(\\pi/8)`
     (:func:`_reduce`); the two reductions' divisions and :math:`1/d` share one division,
     :math:`q = 1 / (D_1 D_2 d)`, so that a pixel costs two square roots and one division
     (within a few ulp of three divisions);
   * rows farther than ``MIN_DISTANCE`` from the light point skip the reference's
     near-light clipping (:func:`_pixel_far`, the same bits as :func:`_pixel` there);
   * on flat ground the loop runs over a whole number of SIMD widths (``_LANES``), the few
     pixels past the run computed and left unread, so that no pixel falls to a scalar loop;

2. the arc tangents, fdlibm's polynomial [2] (:func:`_arctan`), and from them the
   candela-table cell and the fractions within it (:func:`_row_cells`);
3. the bilinear candela [1, Eq. 4] from the cell's four corners, read as two pairs of
   vertical neighbours (:attr:`PackedTables.pairs`), times the factor, added to the row
   (fused for one band).

The first two loops were one until the arithmetic of a pixel (some 140 vector instructions,
a dependency chain of two square roots, a division and a polynomial) outgrew what the core
overlaps from one iteration to the next; split, each overlaps its iterations, which cut the
time per pixel by about a fifth (``benchmarks/bench_irradiance_throughput.py``). No array
per light-pixel pair is made: the buffers hold one row of a block.

Which pixels a luminaire lights, and the order in which luminaires add to a pixel, depend on
the pixel's index in the whole grid, never on the window, and every pixel goes through the
same arithmetic (fused multiply-adds allowed, no reassociation): a raster cut into any tiles,
on any scheduler, gives the same bits (tested).

Length: the per-pixel steps (reduction, arc tangent, near and far pixels, flat and terrain
rows, cells, fused and banded lookups) are small functions that the compiler inlines into one loop
each; they share the constants and conventions of one kernel.

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

from nightlights._typing import ComplexArray, FloatArray
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
#: Below this an arc tangent's denominator is scaled up by _TINY_SCALE (see :func:`_reduced`).
_TINY = 2.0**-500
_TINY_SCALE = 2.0**600


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _reduce(
    y: float, x: float, upper: bool
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """atan2(y, x) as ``offset + arctan(numerator / denominator)``, with |ratio| <= tan(pi/8).

    With s = min(|x|, |y|) and l = max(|x|, |y|), arctan(s / l) is in [0, pi/4]; above
    tan(pi/8) it is pi/4 + arctan((s - l) / (s + l)), so that the polynomial's argument
    stays within tan(pi/8). The octant's reflections (pi/2 - a when |y| > |x|, pi - a when
    x < 0, -a when y < 0) move into the offset and the sign of the numerator (the arc
    tangent is odd), so that the angle is one addition once the ratio's arc tangent is
    known. Returns (numerator, denominator, offset [rad]); a zero denominator (x = y = 0)
    becomes 1.
    """
    ay = y if upper else abs(y)
    ax = abs(x)
    swap = ay > ax
    large = ay if swap else ax
    small = ax if swap else ay
    b = 1.0 if small > _TAN_PI_8 * large else 0.0
    denominator = large + b * small
    numerator = small - b * large
    offset = b * _QUARTER_PI
    offset = _HALF_PI - offset if swap else offset
    sign = -1.0 if swap else 1.0
    offset = math.pi - offset if x < 0.0 else offset
    sign = -sign if x < 0.0 else sign
    if not upper:
        offset = -offset if y < 0.0 else offset
        sign = -sign if y < 0.0 else sign
    return sign * numerator, denominator if denominator > 0.0 else 1.0, offset


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _arctan(u: float) -> float:  # pragma: no cover - compiled
    """arctan(u) for |u| <= tan(pi/8): fdlibm's polynomial [2] [rad]."""
    z = u * u
    w = z * z
    s1 = z * (_AT0 + w * (_AT2 + w * (_AT4 + w * (_AT6 + w * (_AT8 + w * _AT10)))))
    s2 = w * (_AT1 + w * (_AT3 + w * (_AT5 + w * (_AT7 + w * _AT9))))
    return u - u * (s1 + s2)


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _atan2(y: float, x: float) -> float:  # pragma: no cover - compiled
    """math.atan2(y, x) without branches or calls, to ~1e-16 (0 for y = x = 0) [rad]."""
    numerator, denominator, offset = _reduce(y, x, False)
    return offset + _arctan(numerator / denominator)


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _reduced(
    sin_v: float, cos_v: float, bx: float, by: float, distance: float
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """Reduced arc-tangent arguments of V and H, and 1 / ``distance``.

    V = atan2(sin_v, cos_v) and H - H_street = atan2(-b_x, b_y), each as
    ``offset + arctan(u)`` (:func:`_reduce`). The two ratios and 1 / ``distance`` share one
    division: with q = 1 / (D1 D2 distance), N1 / D1 = N1 D2 distance q,
    N2 / D2 = N2 D1 distance q and 1 / distance = D1 D2 q (a few ulp).
    Returns (u_V, offset_V, u_H, offset_H, 1 / distance).
    """
    n1, d1, offset_v = _reduce(sin_v, cos_v, True)
    n2, d2, offset_h = _reduce(-bx, by, False)
    # a pixel all but straight below the light has |b_xy| down to the subnormals, where
    # D1 D2 distance would underflow and q overflow: scale N2 and D2 by a power of two (their
    # ratio is unchanged, exactly; D1, distance >= MIN_DISTANCE / 2 keep the product normal)
    scale = _TINY_SCALE if d2 < _TINY else 1.0
    n2 *= scale
    d2 *= scale
    q = 1.0 / (d1 * d2 * distance)
    inv_d = d1 * d2 * q
    q = distance * q
    return n1 * (d2 * q), offset_v, n2 * (d1 * q), offset_h, inv_d


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _pixel(
    bx: float, by: float, bz: float, d2_raw: float
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """:func:`_reduced` of body direction b with |b|^2 = ``d2_raw``, at any distance.

    V = arccos(-b_z / d) is atan2(|b_xy|, -b_z); closer than MIN_DISTANCE, the reference's
    arccos of the clipped cosine -b_z / MIN_DISTANCE, and d = MIN_DISTANCE.
    """
    min2 = MIN_DISTANCE * MIN_DISTANCE
    near = d2_raw <= min2
    distance = math.sqrt(d2_raw if d2_raw > min2 else min2)
    cos_v = -bz * (1.0 / MIN_DISTANCE)
    cos_v = cos_v if cos_v < 1.0 else 1.0
    cos_v = cos_v if cos_v > -1.0 else -1.0
    sin_v = 1.0 - cos_v * cos_v if near else bx * bx + by * by
    sin_v = math.sqrt(sin_v if sin_v > 0.0 else 0.0)
    cos_v = cos_v if near else -bz
    return _reduced(sin_v, cos_v, bx, by, distance)


@njit(cache=True, nogil=True, error_model="numpy", inline="always", fastmath={"contract"})
def _pixel_far(
    bx: float, by: float, bz: float, d2_raw: float
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """:func:`_pixel` for |b|^2 = ``d2_raw`` > MIN_DISTANCE^2 (the same bits, fewer steps)."""
    return _reduced(math.sqrt(bx * bx + by * by), -bz, bx, by, math.sqrt(d2_raw))


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _row_flat(
    u_v: FloatArray,
    offset_v: FloatArray,
    u_h: FloatArray,
    offset_h: FloatArray,
    factor: FloatArray,
    n: int,
    x0: float,
    first: int,
    resolution: float,
    dy: float,
    px: float,
    pz: float,
    rot: tuple[float, float, float, float, float, float, float, float, float],
) -> None:  # pragma: no cover - compiled
    """:func:`_reduced` and cos(incidence) / d^2 on flat ground, z = 0, at columns first.."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    dz = -pz
    # body coordinates b = R^T d (right, forward, up) [1, Eq. 5], the row's terms hoisted
    cx = r10 * dy + r20 * dz
    cy = r11 * dy + r21 * dz
    cz = r12 * dy + r22 * dz
    dyz2 = dy * dy + dz * dz
    if dyz2 > MIN_DISTANCE * MIN_DISTANCE:
        # no pixel of the row is within MIN_DISTANCE of the light point
        for k in range(n):
            dx = (x0 + (first + k) * resolution) - px
            u_v[k], offset_v[k], u_h[k], offset_h[k], inv_d = _pixel_far(
                r00 * dx + cx, r01 * dx + cy, r02 * dx + cz, dx * dx + dyz2
            )
            cos_incidence = -dz * inv_d
            factor[k] = (cos_incidence if cos_incidence > 0.0 else 0.0) * (inv_d * inv_d)
        return
    for k in range(n):
        dx = (x0 + (first + k) * resolution) - px
        u_v[k], offset_v[k], u_h[k], offset_h[k], inv_d = _pixel(
            r00 * dx + cx, r01 * dx + cy, r02 * dx + cz, dx * dx + dyz2
        )
        cos_incidence = -dz * inv_d
        factor[k] = (cos_incidence if cos_incidence > 0.0 else 0.0) * (inv_d * inv_d)


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _row_terrain(
    u_v: FloatArray,
    offset_v: FloatArray,
    u_h: FloatArray,
    offset_h: FloatArray,
    factor: FloatArray,
    n: int,
    x0: float,
    first: int,
    resolution: float,
    dy: float,
    px: float,
    pz: float,
    rot: tuple[float, float, float, float, float, float, float, float, float],
    ground_z: FloatArray,
    normals: FloatArray,
) -> None:  # pragma: no cover - compiled
    """As :func:`_row_flat` over a DEM: ground heights (n,) and unit normals (n, 3)."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    cx = r10 * dy
    cy = r11 * dy
    cz = r12 * dy
    dy2 = dy * dy
    for k in range(n):
        dx = (x0 + (first + k) * resolution) - px
        dz = ground_z[k] - pz
        u_v[k], offset_v[k], u_h[k], offset_h[k], inv_d = _pixel(
            r00 * dx + cx + r20 * dz,
            r01 * dx + cy + r21 * dz,
            r02 * dx + cz + r22 * dz,
            dx * dx + dy2 + dz * dz,
        )
        cos_incidence = -(normals[k, 0] * dx + normals[k, 1] * dy + normals[k, 2] * dz) * inv_d
        factor[k] = (cos_incidence if cos_incidence > 0.0 else 0.0) * (inv_d * inv_d)


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
def _row_cells(
    cell: NDArray[np.int64],
    u_v: FloatArray,
    offset_v: FloatArray,
    u_h: FloatArray,
    offset_h: FloatArray,
    n: int,
    azimuth: float,
    table: tuple[float, float, float, float, float, float, float],
) -> None:  # pragma: no cover - compiled
    """Candela-table cells of a row run from :func:`_row_flat`'s reduced arguments.

    V = offset_V + arctan(u_V) and H = H_street + offset_H + arctan(u_H), wrapped into
    [0, 360) (``azimuth`` is in [0, 360]). Writes the flat index of each cell's (0, 0)
    corner to ``cell`` and the fractions (tv, th) within it, as the bilinear lookup
    [1, Eq. 4] reads them, over ``u_v`` and ``u_h``.
    """
    scale_v, scale_h, top_v, top_h, last_v, last_h, n_v = table
    for k in range(n):
        vertical = (offset_v[k] + _arctan(u_v[k])) * scale_v
        horizontal = (offset_h[k] + _arctan(u_h[k])) * _DEGREES + azimuth
        horizontal = horizontal + 360.0 if horizontal < 0.0 else horizontal
        horizontal = horizontal - 360.0 if horizontal >= 360.0 else horizontal
        horizontal *= scale_h
        # NaN and rounding past the table's ends clamp
        v = vertical if vertical >= 0.0 else 0.0
        v = v if v <= top_v else top_v
        h = horizontal if horizontal >= 0.0 else 0.0
        h = h if h <= top_h else top_h
        iv = np.floor(v)
        iv = iv if iv < last_v else last_v
        ih = np.floor(h)
        ih = ih if ih < last_h else last_h
        cell[k] = np.int64(ih * n_v + iv)
        u_v[k] = v - iv
        u_h[k] = h - ih


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _bilinear(
    pairs: ComplexArray, offset: int, n_v: int, cell: int, tv: float, th: float
) -> float:  # pragma: no cover - compiled
    """Bilinear candela in the cell at flat index ``cell`` (Chuang 2011, Eq. 4) [cd]."""
    # unsigned (the clamps keep it >= 0): no negative-index wraparound per load; one
    # 16-byte load reads a corner and its vertical neighbour
    base = np.uint64(offset + cell)
    near = pairs[base]
    far = pairs[base + np.uint64(n_v)]
    c00 = near.real
    c01 = near.imag
    c10 = far.real
    c11 = far.imag
    lower = c00 + tv * (c01 - c00)
    upper = c10 + tv * (c11 - c10)
    return lower + th * (upper - lower)


@njit(cache=True, nogil=True, error_model="numpy")
def _row_add(
    out: FloatArray,
    weight: float,
    cell: NDArray[np.int64],
    tv: FloatArray,
    th: FloatArray,
    factor: FloatArray,
    n: int,
    pairs: ComplexArray,
    offset: int,
    n_v: int,
) -> None:  # pragma: no cover - compiled
    """Add ``weight`` x candela x ``factor`` to the row run ``out`` (one band)."""
    for k in range(n):
        out[k] += weight * (_bilinear(pairs, offset, n_v, cell[k], tv[k], th[k]) * factor[k])


@njit(cache=True, nogil=True, error_model="numpy")
def _row_lookup(
    values: FloatArray,
    cell: NDArray[np.int64],
    tv: FloatArray,
    th: FloatArray,
    factor: FloatArray,
    n: int,
    pairs: ComplexArray,
    offset: int,
    n_v: int,
) -> None:  # pragma: no cover - compiled
    """Candela x ``factor`` into ``values`` (several bands)."""
    for k in range(n):
        values[k] = _bilinear(pairs, offset, n_v, cell[k], tv[k], th[k]) * factor[k]


@njit(cache=True, nogil=True, error_model="numpy")
def _inside(col: int, x0: float, resolution: float, px: float, dy2: float, r2: float) -> bool:
    dx = (x0 + col * resolution) - px
    return dx * dx + dy2 <= r2  # pragma: no cover - compiled


@dataclass(frozen=True, eq=False)
class PackedTables:
    """Candela tables in one flat array, as the compiled kernel reads them.

    Attributes
    ----------
    pairs
        All tables' candela values c, each table row-major (horizontal, vertical), as the
        real parts, and each value's successor along the flat array as the imaginary part,
        (c[j], c[j + 1]): a cell's two corners at one horizontal angle in one 16-byte load
        (the last imaginary part, never read, is 0) [cd].
    offset
        Start of each table in ``pairs`` (tables,).
    shape
        (n_horizontal, n_vertical) of each table (tables, 2).
    scale
        (1 / vertical step, 1 / horizontal step) of each table (tables, 2) [deg-1].
    """

    pairs: ComplexArray
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
    candela = np.concatenate([table.candela.ravel() for table in tables]).astype(np.float64)
    pairs = candela.astype(np.complex128)
    pairs.imag[:-1] = candela[1:]
    return PackedTables(
        pairs,
        np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
        np.array([table.candela.shape for table in tables], dtype=np.int64).reshape(-1, 2),
        np.array(
            [(1.0 / table.vertical_step, 1.0 / table.horizontal_step) for table in tables],
            dtype=np.float64,
        ).reshape(-1, 2),
    )


#: Edge of the blocks in which :func:`window_illuminance` adds the lights [pixels]: a float64
#: block of 256 x 256 pixels (512 KiB a band) stays in a core's L2 cache.
BLOCK = 256

#: The flat-ground loop runs over whole multiples of this many pixels (the SIMD width and
#: more), so that no pixel of a row falls to a scalar remainder loop; the extra pixels'
#: values stay unread in the buffers.
_LANES = 8

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
            # in [0, 360], so that one turn wraps H = H_street + atan2(-b_x, b_y)
            np.ascontiguousarray(np.mod(street_azimuth, 360.0), dtype=np.float64),
            np.ascontiguousarray(table_index, dtype=np.int64),
            np.ascontiguousarray(weights, dtype=np.float64),
            np.ascontiguousarray(radius, dtype=np.float64),
            tables.pairs,
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
    pairs: ComplexArray,
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
    # test, evaluated the same way. The window is done in blocks of BLOCK x BLOCK pixels,
    # each with all the lights in their order, so that the block being added to stays in
    # the core's cache.
    _, rows, cols = out.shape
    buffers = np.empty((6, min(cols, BLOCK) + _LANES))
    cell = np.empty(min(cols, BLOCK) + _LANES, dtype=np.int64)
    evaluations = 0
    for block_row in range(row0, row0 + rows, BLOCK):
        for block_col in range(col0, col0 + cols, BLOCK):
            evaluations += _block(
                out,
                row0,
                col0,
                block_row,
                min(block_row + BLOCK, row0 + rows),
                block_col,
                min(block_col + BLOCK, col0 + cols),
                cell,
                buffers,
                x0,
                y0,
                resolution,
                light_point,
                rotation,
                street_azimuth,
                table_index,
                weights,
                radius,
                pairs,
                table_offset,
                table_shape,
                table_scale,
                ground_z,
                normals,
                terrain,
            )
    return evaluations


@njit(cache=True, nogil=True, error_model="numpy")
def _block(
    out: FloatArray,
    row0: int,
    col0: int,
    top: int,
    bottom: int,
    left: int,
    right: int,
    cell: NDArray[np.int64],
    buffers: FloatArray,
    x0: float,
    y0: float,
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.int64],
    weights: FloatArray,
    radius: FloatArray,
    pairs: ComplexArray,
    table_offset: NDArray[np.int64],
    table_shape: NDArray[np.int64],
    table_scale: FloatArray,
    ground_z: FloatArray,
    normals: FloatArray,
    terrain: bool,
) -> int:  # pragma: no cover - compiled
    """The lights' sum on grid rows top..bottom - 1, columns left..right - 1 of ``out``."""
    n_bands = out.shape[0]
    # the reduced arguments u_V and u_H become the fractions tv and th in place
    tv = buffers[0]
    th = buffers[1]
    factor = buffers[2]
    values = buffers[3]
    offset_v = buffers[4]
    offset_h = buffers[5]
    evaluations = 0
    for i in range(light_point.shape[0]):
        px, py, pz = light_point[i, 0], light_point[i, 1], light_point[i, 2]
        r = radius[i]
        r2 = r * r
        # rows whose centre may lie within r of the light (one row of margin: the exact test
        # below decides), clipped to the block before converting to integers
        low = np.floor((y0 - (py + r)) / resolution) - 1.0
        high = np.ceil((y0 - (py - r)) / resolution) + 1.0
        first_row = int(min(max(low, float(top)), float(bottom)))
        last_row = int(min(max(high, float(top - 1)), float(bottom - 1)))
        # the columns of every row below lie within these (a light west or east of the
        # block has none in it)
        low = np.floor((px - r - x0) / resolution) - 1.0
        high = np.ceil((px + r - x0) / resolution) + 1.0
        if first_row > last_row or not (high >= left and low <= right - 1):
            continue
        t = table_index[i]
        offset = table_offset[t]
        n_h, n_v = table_shape[t, 0], table_shape[t, 1]
        table = (
            table_scale[t, 0] * _DEGREES,
            table_scale[t, 1],
            n_v - 1.0,
            n_h - 1.0,
            n_v - 2.0,
            n_h - 2.0,
            float(n_v),
        )
        m = rotation[i]
        rot = (m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])
        for row in range(first_row, last_row + 1):
            dy = (y0 - row * resolution) - py
            dy2 = dy * dy
            if not dy2 <= r2:
                continue
            half = math.sqrt(r2 - dy2)
            low = np.floor((px - half - x0) / resolution) - 1.0
            high = np.ceil((px + half - x0) / resolution) + 1.0
            first = int(min(max(low, float(left)), float(right)))
            last = int(min(max(high, float(left - 1)), float(right - 1)))
            while first <= last and not _inside(first, x0, resolution, px, dy2, r2):
                first += 1
            while last >= first and not _inside(last, x0, resolution, px, dy2, r2):
                last -= 1
            if first > last:
                continue
            evaluations += last - first + 1
            n = last - first + 1
            # on flat ground, whole SIMD widths (the pixels past the run are left unread)
            width = n if terrain else (n + _LANES - 1) // _LANES * _LANES
            local = row - row0
            if terrain:
                _row_terrain(
                    tv,
                    offset_v,
                    th,
                    offset_h,
                    factor,
                    n,
                    x0,
                    first,
                    resolution,
                    dy,
                    px,
                    pz,
                    rot,
                    ground_z[local, first - col0 : last - col0 + 1],
                    normals[local, first - col0 : last - col0 + 1],
                )
            else:
                _row_flat(
                    tv,
                    offset_v,
                    th,
                    offset_h,
                    factor,
                    width,
                    x0,
                    first,
                    resolution,
                    dy,
                    px,
                    pz,
                    rot,
                )
            _row_cells(cell, tv, offset_v, th, offset_h, width, street_azimuth[i], table)
            start = first - col0
            if n_bands == 1:
                _row_add(
                    out[0, local, start : start + n],
                    weights[i, 0],
                    cell,
                    tv,
                    th,
                    factor,
                    n,
                    pairs,
                    offset,
                    n_v,
                )
                continue
            _row_lookup(values, cell, tv, th, factor, n, pairs, offset, n_v)
            for band in range(n_bands):
                weight = weights[i, band]
                for k in range(n):
                    out[band, local, start + k] += weight * values[k]
    return evaluations
