"""Ground illuminance of point luminaires on a raster window: the kernel and its reference.

Each luminaire adds

.. math:: E = I(V, H)\\, \\max(0, \\cos\\beta) / d^2

at every pixel centre of the window inside its region of influence, where (V, H) are the
photometric angles of the direction from the light point to the pixel in the luminaire's
frame (:func:`nightlights.ground.frames.direction_to_photometric`, evaluated inline here for
speed), :math:`\\beta` the angle of incidence on the ground (flat, or the surface normal of a
DEM) and :math:`d` the distance (Chuang 2011, Eq. 11).

Two backends compute it. ``"numba"`` (the default) is the compiled kernel of
:mod:`nightlights.ground._illuminance_numba`: one pass per luminaire over the pixel rows of
its disc, no array per light-pixel pair. ``"numpy"`` is the vectorised reference the tests
compare it to: light-pixel pairs formed from row runs inside each disc and evaluated in numpy
batches. Both light the same pixels, by one test on the pixel's index in the whole grid.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.ground.frames import IntensityTable

if TYPE_CHECKING:
    from nightlights.ground._illuminance_numba import PackedTables

__all__ = ["BACKENDS", "ground_illuminance", "surface_normals"]

#: Irradiance kernels: compiled (the default) and the numpy reference.
BACKENDS = ("numba", "numpy")

#: Closest distance between a light point and a lit point, guarding 1/d^2 when a pixel
#: centre coincides with a light on the ground [m].
MIN_DISTANCE = 0.01

#: Light-pixel pairs evaluated per numpy batch (bounds memory to ~ 40 x this many bytes).
PAIRS_PER_BATCH = 1 << 20


def ground_illuminance(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.intp],
    tables: Sequence[IntensityTable],
    weights: FloatArray,
    *,
    radius: FloatArray | None = None,
    ground_z: FloatArray | None = None,
    normals: FloatArray | None = None,
    backend: str = "numba",
) -> FloatArray:
    r"""Weighted illuminance of point luminaires on a raster window.

    Parameters
    ----------
    shape
        (rows, cols) of the window [pixels].
    origin
        (x, y) of the centre of the window's top-left pixel [m]; rows run south.
    resolution
        Pixel size [m].
    light_point
        Light points (n, 3) [m].
    rotation
        Body-to-world rotations (n, 3, 3) from
        :func:`~nightlights.ground.frames.luminaire_rotation`.
    street_azimuth
        C-plane facing the street per light (n,) [deg].
    table_index
        Index into ``tables`` per light (n,).
    tables
        Candela tables [cd].
    weights
        Band weights (n, bands): the illuminance of light i enters band b times
        ``weights[i, b]`` (1 for photopic lux, the sensor factor for other bands) [band unit
        per lx].
    radius
        Region-of-influence radius per light; ``None`` evaluates every pixel [m].
    ground_z
        Ground elevation at the pixel centres (rows, cols); ``None`` for flat ground at z=0
        [m].
    normals
        Unit surface normals (rows, cols, 3); ``None`` for (0, 0, 1) [1].
    backend
        ``"numba"``: the compiled kernel
        (:mod:`~nightlights.ground._illuminance_numba`); ``"numpy"``: the vectorised
        reference it is tested against (equal to 1e-6 relative on every pixel).

    Returns
    -------
    numpy.ndarray
        Array (bands, rows, cols) [band units].

    Raises
    ------
    InputError
        Unknown ``backend``.

    Notes
    -----
    A light lights the pixel centres within ``radius`` of its light point (horizontal
    distance, evaluated as :math:`dx^2 + dy^2 \le r^2`); the backends share that test, so
    that they light the same pixels.

    References
    ----------
    Chuang 2011, Sec. 5.1, Eq. 11 (with luminous intensity in place of radiant energy).
    """
    values, _ = window_and_pairs(
        shape,
        origin,
        resolution,
        light_point,
        rotation,
        street_azimuth,
        table_index,
        tables,
        weights,
        radius=radius,
        ground_z=ground_z,
        normals=normals,
        backend=backend,
    )
    return values


def check_backend(backend: str) -> str:
    """``backend`` if it names an irradiance kernel (:data:`BACKENDS`), else an InputError."""
    if backend not in BACKENDS:
        raise InputError(f"backend {backend!r}; expected one of {', '.join(BACKENDS)}")
    return backend


def window_and_pairs(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.intp],
    tables: Sequence[IntensityTable] | PackedTables,
    weights: FloatArray,
    *,
    radius: FloatArray | None = None,
    ground_z: FloatArray | None = None,
    normals: FloatArray | None = None,
    offset: tuple[int, int] = (0, 0),
    backend: str = "numba",
) -> tuple[FloatArray, int]:
    """Illuminance of the window at ``offset`` of a grid and the light-pixel pairs evaluated.

    ``origin`` is the centre of the grid's pixel (0, 0); the window's pixel (r, c) is the
    grid's pixel (offset[0] + r, offset[1] + c). ``tables`` may come packed
    (:func:`~nightlights.ground._illuminance_numba.pack_tables`) for the compiled backend.
    """
    check_backend(backend)
    if backend == "numpy":
        if not isinstance(tables, Sequence):
            raise InputError("the numpy backend needs the candela tables, not packed ones")
        return _illuminance_and_pairs(
            shape,
            origin,
            resolution,
            light_point,
            rotation,
            street_azimuth,
            table_index,
            tables,
            weights,
            radius=radius,
            ground_z=ground_z,
            normals=normals,
            offset=offset,
        )
    from nightlights.ground import _illuminance_numba as compiled

    packed_tables = compiled.pack_tables(tables) if isinstance(tables, Sequence) else tables
    out = np.zeros((weights.shape[1], *shape))
    n = len(light_point)
    if n == 0 or shape[0] == 0 or shape[1] == 0:
        return out, 0
    pairs = compiled.window_illuminance(
        out,
        offset,
        origin,
        resolution,
        light_point,
        rotation,
        street_azimuth,
        table_index,
        weights,
        np.full(n, np.inf) if radius is None else radius,
        packed_tables,
        ground_z,
        normals,
    )
    return out, pairs


def _illuminance_and_pairs(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table_index: NDArray[np.intp],
    tables: Sequence[IntensityTable],
    weights: FloatArray,
    *,
    radius: FloatArray | None = None,
    ground_z: FloatArray | None = None,
    normals: FloatArray | None = None,
    offset: tuple[int, int] = (0, 0),
) -> tuple[FloatArray, int]:
    """The numpy kernel on the window at ``offset`` of the grid centred at ``origin``."""
    rows, cols = shape
    n_bands = weights.shape[1]
    out = np.zeros((n_bands, rows * cols))
    n = len(light_point)
    if n == 0 or rows == 0 or cols == 0:
        return out.reshape(n_bands, rows, cols), 0
    segments = _disc_segments(shape, offset, origin, resolution, light_point, radius)
    pairs = 0
    for table_id in np.unique(table_index):
        chosen = table_index[segments.light] == table_id
        for batch in _batches(np.flatnonzero(chosen), segments.length[chosen]):
            pairs += _accumulate(
                out,
                _Segments(
                    segments.light[batch],
                    segments.row[batch],
                    segments.col0[batch],
                    segments.length[batch],
                ),
                shape,
                offset,
                (origin[0], origin[1], resolution),
                light_point,
                rotation,
                street_azimuth,
                tables[table_id],
                weights,
                ground_z,
                normals,
            )
    return out.reshape(n_bands, rows, cols), pairs


@dataclass(frozen=True)
class _Segments:
    """Runs of pixels in one row lit by one light: light index, grid row, first grid column,
    length."""

    light: NDArray[np.intp]
    row: NDArray[np.int64]
    col0: NDArray[np.int64]
    length: NDArray[np.int64]


def _disc_segments(
    shape: tuple[int, int],
    offset: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: FloatArray,
    radius: FloatArray | None,
) -> _Segments:
    """Pixel runs inside each light's region-of-influence disc, clipped to the window.

    Pixel (R, C) of the grid, centred at (x0 + C res, y0 - R res), is inside when
    dx^2 + dy^2 <= radius^2 for its offsets from the light point. Candidate runs one pixel
    wider than the disc are trimmed by that exact test, so that the runs depend on the grid
    index alone, never on the window (and equal the compiled kernel's).
    """
    rows, cols = shape
    row0, col0 = offset
    x0, y0 = origin
    n = len(light_point)
    r = np.full(n, np.inf) if radius is None else np.asarray(radius, dtype=float)
    lx, ly = light_point[:, 0], light_point[:, 1]
    with np.errstate(invalid="ignore"):
        low = np.floor((y0 - (ly + r)) / resolution) - 1.0
        high = np.ceil((y0 - (ly - r)) / resolution) + 1.0
    first_row = np.clip(low, row0, row0 + rows).astype(np.int64)
    last_row = np.clip(high, row0 - 1, row0 + rows - 1).astype(np.int64)
    n_rows = np.maximum(last_row - first_row + 1, 0)
    light = np.repeat(np.arange(n), n_rows)
    row = first_row[light] + (
        np.arange(n_rows.sum()) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    )
    px, r2 = lx[light], r[light] * r[light]
    dy = (y0 - row * resolution) - ly[light]
    dy2 = dy * dy
    keep = dy2 <= r2
    light, row, px, r2, dy2 = light[keep], row[keep], px[keep], r2[keep], dy2[keep]
    half = np.sqrt(r2 - dy2)
    with np.errstate(invalid="ignore"):
        low = np.floor((px - half - x0) / resolution) - 1.0
        high = np.ceil((px + half - x0) / resolution) + 1.0
    first = np.clip(low, col0, col0 + cols).astype(np.int64)
    last = np.clip(high, col0 - 1, col0 + cols - 1).astype(np.int64)

    def outside(col: NDArray[np.int64], index: NDArray[np.intp]) -> NDArray[np.bool_]:
        dx = (x0 + col * resolution) - px[index]
        return ~(dx * dx + dy2[index] <= r2[index])

    for end, step in ((first, 1), (last, -1)):
        index = np.arange(len(light))
        while len(index):
            index = index[first[index] <= last[index]]
            index = index[outside(end[index], index)]
            end[index] += step
    length = last - first + 1
    keep = length > 0
    return _Segments(light[keep], row[keep], first[keep], length[keep])


def _batches(members: NDArray[np.intp], counts: NDArray[np.int64]) -> list[NDArray[np.intp]]:
    if len(members) == 0:
        return []
    group = np.cumsum(counts) // PAIRS_PER_BATCH
    splits = np.flatnonzero(np.diff(group)) + 1
    return np.split(members, splits)


def _accumulate(
    out: FloatArray,
    segments: _Segments,
    shape: tuple[int, int],
    offset: tuple[int, int],
    grid: tuple[float, float, float],
    point: FloatArray,
    rotation: FloatArray,
    street_azimuth: FloatArray,
    table: IntensityTable,
    weights: FloatArray,
    ground_z: FloatArray | None,
    normals: FloatArray | None,
) -> int:
    x0, y0, resolution = grid
    total = int(segments.length.sum())
    segment = np.repeat(np.arange(len(segments.length)), segments.length)
    col = segments.col0[segment] + (
        np.arange(total) - np.repeat(np.cumsum(segments.length) - segments.length, segments.length)
    )
    row = segments.row[segment]
    pair = segments.light[segment]
    pixel = (row - offset[0]) * shape[1] + (col - offset[1])
    # Offsets of the pixel centres (x0 + C res, y0 - R res) from the light points.
    dx = (x0 + col * resolution) - point[pair, 0]
    dy = (y0 - row * resolution) - point[pair, 1]
    dz = -point[pair, 2] if ground_z is None else ground_z.ravel()[pixel] - point[pair, 2]
    # Body coordinates b = R^T d (right, forward, up); Chuang 2011, Eq. 5.
    planar = np.abs(rotation[:, 2, 2] - 1.0) <= 1e-15
    if np.all(planar[segments.light]):
        bx = rotation[:, 0, 0][pair] * dx + rotation[:, 1, 0][pair] * dy
        by = rotation[:, 0, 1][pair] * dx + rotation[:, 1, 1][pair] * dy
        bz = dz
    else:
        column = [[np.ascontiguousarray(rotation[:, i, j]) for j in range(3)] for i in range(3)]
        bx = column[0][0][pair] * dx + column[1][0][pair] * dy + column[2][0][pair] * dz
        by = column[0][1][pair] * dx + column[1][1][pair] * dy + column[2][1][pair] * dz
        bz = column[0][2][pair] * dx + column[1][2][pair] * dy + column[2][2][pair] * dz
    d2 = np.maximum(dx * dx + dy * dy + dz * dz, MIN_DISTANCE**2)
    inv_d = 1.0 / np.sqrt(d2)
    vertical = np.degrees(np.arccos(np.clip(-bz * inv_d, -1.0, 1.0)))
    horizontal = np.degrees(np.arctan2(-bx, by)) + street_azimuth[pair]
    horizontal -= 360.0 * np.floor(horizontal * (1.0 / 360.0))
    intensity = table.lookup(vertical, horizontal)
    if normals is None:
        cos_incidence = -dz * inv_d
    else:
        flat_normals = normals.reshape(-1, 3)
        cos_incidence = (
            -(
                flat_normals[pixel, 0] * dx
                + flat_normals[pixel, 1] * dy
                + flat_normals[pixel, 2] * dz
            )
            * inv_d
        )
    illuminance = intensity * np.maximum(cos_incidence, 0.0) * (inv_d * inv_d)
    for band in range(out.shape[0]):
        band_weight = weights[:, band]
        values = illuminance if np.all(band_weight == 1.0) else illuminance * band_weight[pair]
        out[band] += np.bincount(pixel, weights=values, minlength=out.shape[1])
    return total


def surface_normals(elevation: FloatArray, resolution: float) -> FloatArray:
    """Unit surface normals of a north-up elevation grid (central differences).

    Parameters
    ----------
    elevation
        Ground elevation at the pixel centres (rows, cols); rows run south [m].
    resolution
        Pixel size [m].

    Returns
    -------
    numpy.ndarray
        Unit normals (rows, cols, 3), x east, y north, z up [1].

    Examples
    --------
    >>> surface_normals(np.array([[0.0, 1.0], [0.0, 1.0]]), 1.0)[0, 0].round(6).tolist()
    [-0.707107, 0.0, 0.707107]
    """
    slope_row, slope_col = np.gradient(elevation, resolution)
    # rows run south: dz/dy = -dz/drow.
    normals = np.stack([-slope_col, slope_row, np.ones_like(elevation)], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    return normals
