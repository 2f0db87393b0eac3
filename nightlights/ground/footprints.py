"""Obstacle rasters from building footprints or land use: height, spacing, filling per cell.

Each footprint has a height: its height field, or its number of levels times a storey height
(:data:`STOREY_HEIGHT`). On a grid of cell area A, with a_ic the area of footprint i (of total
area A_i and height h_i) inside cell c:

- height: the area-weighted mean height, h_c = sum_i a_ic h_i / sum_i a_ic [m];
- filling factor: the built fraction of the cell, f_c = min(1, B_c / A), B_c = sum_i a_ic [1];
- spacing: the gap between the buildings of a square lattice of n_c equal square blocks that
  cover B_c, n_c = sum_i a_ic / A_i the (fractional) number of buildings in the cell,

  .. math::
      d_c = \\sqrt{A / n_c} - \\sqrt{B_c / n_c} = \\sqrt{A / n_c}\\,(1 - \\sqrt{f_c}) [m].

A cell without buildings has h = 0, f = 0 and no spacing (NaN): no obstacle
(:mod:`nightlights.ground.obstacles`). Footprints without a height or levels are skipped, or
given ``default_height`` (for instance the height of their land use in
:data:`~nightlights.ground.obstacles.LAND_USE_OBSTACLES`), with a
:class:`~nightlights.errors.DataQualityWarning` either way.

Without footprints, :func:`land_use_obstacles` gives each cell of a land-use (land-cover)
raster the defaults of its class (:data:`~nightlights.ground.obstacles.LAND_USE_OBSTACLES`, the
project's choice from Stewart & Oke 2012, Table 2).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
import xarray as xr
from affine import Affine
from pyproj import CRS

from nightlights._typing import FloatArray
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.ground.obstacles import LAND_USE_OBSTACLES, ObstacleProperties
from nightlights.io import Raster
from nightlights.io.raster import as_raster, source_label
from nightlights.io.vector import as_vector

__all__ = [
    "HEIGHT_FIELDS",
    "LEVELS_FIELDS",
    "STOREY_HEIGHT",
    "footprint_heights",
    "land_use_obstacles",
    "obstacle_rasters",
]

#: Height of one storey, for footprints that give levels [m]: the project's choice, the usual
#: 3 m floor-to-floor of residential buildings (OpenStreetMap's ``building:levels`` is read so
#: by most 3-D renderers).
STOREY_HEIGHT = 3.0
#: Fields looked for when no height field is named, in order.
HEIGHT_FIELDS = ("height", "building:height", "HEIGHT", "hauteur")
#: Fields looked for when no levels field is named, in order.
LEVELS_FIELDS = ("building:levels", "levels", "building_levels", "LEVELS", "storeys")


def _field(frame: gpd.GeoDataFrame, given: str | None, names: tuple[str, ...], what: str) -> str:
    """The field to read: the one given (which must exist), or the first of ``names``."""
    if given is not None:
        if given not in frame.columns:
            raise InputError(
                f"{what}={given!r}: no such field; the layer has "
                f"{', '.join(map(str, frame.columns))}"
            )
        return given
    return next((name for name in names if name in frame.columns), "")


def _numbers(frame: gpd.GeoDataFrame, name: str) -> FloatArray:
    """A field as numbers (``"12 m"`` read as 12), NaN where empty or not a number."""
    if not name:
        return np.full(len(frame), np.nan)
    text = frame[name].astype("string").str.replace(r"\s*m$", "", regex=True)
    return np.asarray(pd.to_numeric(text, errors="coerce"), dtype=float)


def footprint_heights(
    frame: gpd.GeoDataFrame,
    *,
    height_field: str | None = None,
    levels_field: str | None = None,
    storey_height: float = STOREY_HEIGHT,
    label: str = "footprints",
) -> FloatArray:
    """Each footprint's height: its height field, else its levels x ``storey_height``.

    Parameters
    ----------
    frame
        The footprints.
    height_field, levels_field
        Fields of the height [m] and of the number of levels [1]; None: the first of
        :data:`HEIGHT_FIELDS` / :data:`LEVELS_FIELDS` the layer has.
    storey_height
        Height of one level, > 0 [m].
    label
        How messages name the layer.

    Returns
    -------
    numpy.ndarray
        Height per footprint [m]; NaN where neither field gives one (or it is 0).

    Raises
    ------
    InputError
        A named field missing, a negative height or level count, a bad storey height.
    """
    if not (math.isfinite(storey_height) and storey_height > 0):
        raise InputError(f"storey_height={storey_height!r}; expected a height > 0 m")
    height = _numbers(frame, _field(frame, height_field, HEIGHT_FIELDS, "height_field"))
    levels = _numbers(frame, _field(frame, levels_field, LEVELS_FIELDS, "levels_field"))
    for name, values in (("height", height), ("levels", levels)):
        bad = np.flatnonzero(values < 0)
        if bad.size:
            raise InputError(
                f"{label} feature {int(bad[0])}: {name} {float(values[bad[0]])!r}; expected >= 0"
            )
    out = np.where(height > 0, height, levels * storey_height)
    return np.where(out > 0, out, np.nan)


def _grid(
    frame: gpd.GeoDataFrame,
    reference: Raster | xr.DataArray | str | os.PathLike[str] | None,
    resolution: float | None,
    label: str,
) -> tuple[Affine, tuple[int, int], CRS, dict[str, str]]:
    """The output grid: the reference's, or cells of ``resolution`` over the footprints."""
    if (reference is None) == (resolution is None):
        raise InputError("give one of reference= (a raster) or resolution= (a cell size in m)")
    if reference is not None:
        raster = as_raster(reference)
        if raster.crs is None or not raster.crs.is_projected:
            raise CRSError(
                f"{source_label(reference, 'reference raster')}: CRS {raster.crs}; expected a "
                "projected CRS in metres (areas and spacings are computed on its grid)"
            )
        return raster.transform, raster.shape, raster.crs, dict(raster.tags)
    step = float(resolution)  # type: ignore[arg-type]
    if not (math.isfinite(step) and step > 0):
        raise InputError(f"resolution={resolution!r}; expected a cell size > 0 m")
    if frame.crs is None or not frame.crs.is_projected:
        raise CRSError(
            f"{label}: CRS {frame.crs}; expected a projected CRS in metres with resolution= "
            "(or give reference=, whose grid is used)"
        )
    x0, y0, x1, y1 = frame.total_bounds
    left, top = math.floor(x0 / step) * step, math.ceil(y1 / step) * step
    cols = max(1, math.ceil((x1 - left) / step))
    rows = max(1, math.ceil((top - y0) / step))
    grid = Affine(step, 0.0, left, 0.0, -step, top)
    return grid, (rows, cols), CRS.from_user_input(frame.crs), {}


def _apply(t: Affine, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """An affine transform applied to coordinate arrays."""
    return t.a * x + t.b * y + t.c, t.d * x + t.e * y + t.f


def _cell_pairs(
    geoms: np.ndarray, transform: Affine, shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(footprint, row, col) of every cell a footprint's bounding box touches."""
    rows, cols = shape
    bounds = shapely.bounds(geoms)
    c_a, r_a = _apply(~transform, bounds[:, 0], bounds[:, 3])
    c_b, r_b = _apply(~transform, bounds[:, 2], bounds[:, 1])
    r0 = np.clip(np.floor(np.minimum(r_a, r_b)), 0, rows).astype(np.int64)
    r1 = np.clip(np.ceil(np.maximum(r_a, r_b)), 0, rows).astype(np.int64)
    c0 = np.clip(np.floor(np.minimum(c_a, c_b)), 0, cols).astype(np.int64)
    c1 = np.clip(np.ceil(np.maximum(c_a, c_b)), 0, cols).astype(np.int64)
    nr, nc = np.maximum(r1 - r0, 0), np.maximum(c1 - c0, 0)
    counts = nr * nc
    which = np.repeat(np.arange(geoms.size), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    row = r0[which] + local // np.repeat(np.maximum(nc, 1), counts)
    col = c0[which] + local % np.repeat(np.maximum(nc, 1), counts)
    return which, row, col


def obstacle_rasters(
    footprints: gpd.GeoDataFrame | str | os.PathLike[str],
    *,
    reference: Raster | xr.DataArray | str | os.PathLike[str] | None = None,
    resolution: float | None = None,
    height_field: str | None = None,
    levels_field: str | None = None,
    storey_height: float = STOREY_HEIGHT,
    default_height: float | None = None,
    layer: str | None = None,
    output: str | os.PathLike[str] | None = None,
) -> Raster:
    """Obstacle height, spacing and filling factor of building footprints on a grid.

    Parameters
    ----------
    footprints
        Building polygons (a GeoDataFrame or any vector file) with a height or levels field.
    reference
        A raster whose grid the output takes (the emission raster); or ``resolution``.
    resolution
        Cell size of a grid over the footprints, in their projected CRS [m].
    height_field, levels_field
        Fields of the height [m] and number of levels [1] (:func:`footprint_heights`).
    storey_height
        Height of one level [m].
    default_height
        Height of the footprints without one [m]; None: they are skipped. Warned either way.
    layer
        Layer of a vector file.
    output
        GeoTIFF to write (a three-band COG, written atomically); None: none.

    Returns
    -------
    Raster
        Bands ``height`` [m], ``spacing`` [m] and ``filling`` [1]
        (:data:`~nightlights.sky.obstacles.OBSTACLE_BANDS` order).

    Raises
    ------
    InputError
        Neither or both of ``reference`` and ``resolution``, bad fields or values.
    CRSError
        Footprints or grid without a CRS, or a geographic CRS with ``resolution``.

    Examples
    --------
    One 20 m x 20 m building of 4 levels in a 40 m cell: a quarter of the cell built, one
    building, so the gap of the lattice is 40 (1 - 1/2) = 20 m:

    >>> from shapely.geometry import box
    >>> frame = gpd.GeoDataFrame({"levels": [4]}, geometry=[box(10, 10, 30, 30)],
    ...                          crs="EPSG:32635")
    >>> out = obstacle_rasters(frame, resolution=40.0)
    >>> [float(out.data[band, 0, 0]) for band in range(3)]
    [12.0, 20.0, 0.25]
    """
    frame, label = as_vector(footprints, layer=layer, name="footprints")
    if frame.crs is None:
        raise CRSError(f"{label}: no CRS; give the footprints a CRS")
    transform, shape, crs, _ = _grid(frame, reference, resolution, label)
    frame = frame.to_crs(crs) if reference is not None else frame
    heights = footprint_heights(
        frame,
        height_field=height_field,
        levels_field=levels_field,
        storey_height=storey_height,
        label=label,
    )
    missing = int(np.sum(np.isnan(heights)))
    if default_height is not None and not (math.isfinite(default_height) and default_height > 0):
        raise InputError(f"default_height={default_height!r}; expected a height > 0 m")
    if missing:
        what = "skipped" if default_height is None else f"given {default_height:g} m"
        warnings.warn(
            f"{label}: {missing} of {len(frame)} footprints have no height or levels; {what} "
            "(default_height= gives them one)",
            DataQualityWarning,
            stacklevel=2,
        )
        if default_height is not None:
            heights = np.where(np.isnan(heights), default_height, heights)
    geoms = np.asarray(frame.geometry.values, dtype=object)
    keep = ~np.isnan(heights) & ~shapely.is_missing(geoms) & (shapely.area(geoms) > 0)
    geoms, heights = geoms[keep], heights[keep]
    which, row, col = _cell_pairs(geoms, transform, shape)
    x0, y0 = _apply(transform, col, row)
    x1, y1 = _apply(transform, col + 1, row + 1)
    cells = shapely.box(
        np.minimum(x0, x1), np.minimum(y0, y1), np.maximum(x0, x1), np.maximum(y0, y1)
    )
    part = shapely.area(shapely.intersection(geoms[which], cells))
    flat = row * shape[1] + col
    size = shape[0] * shape[1]
    built = np.bincount(flat, part, size)
    weighted = np.bincount(flat, part * heights[which], size)
    count = np.bincount(flat, part / shapely.area(geoms)[which], size)
    area = abs(transform.a * transform.e - transform.b * transform.d)
    has = built > 0
    height = np.where(has, weighted / np.where(has, built, 1.0), 0.0)
    filling = np.minimum(built / area, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        spacing = np.where(has, np.sqrt(area / count) * (1.0 - np.sqrt(filling)), np.nan)
    raster = Raster(
        np.stack([height, spacing, filling]).reshape(3, *shape),
        transform,
        crs,
        ("height", "spacing", "filling"),
        ("m", "m", "1"),
        {
            "model": "ILLUMINA obstacles from building footprints",
            "storey_height_m": f"{storey_height:g}",
            "footprints": str(int(keep.sum())),
            "footprints_without_height": str(missing),
        },
    )
    if output is not None:
        raster.write(Path(output))
    return raster


def land_use_obstacles(
    land_use: Raster | xr.DataArray | str | os.PathLike[str],
    classes: Mapping[int, str | ObstacleProperties],
    *,
    output: str | os.PathLike[str] | None = None,
) -> Raster:
    """Obstacle rasters from a land-use raster: each class's default obstacles.

    Parameters
    ----------
    land_use
        Single-band raster of land-use class codes (first band read).
    classes
        Class code -> a name of :data:`~nightlights.ground.obstacles.LAND_USE_OBSTACLES`
        (``compact_midrise``, ``open_lowrise``, ...) or its own properties.
    output
        GeoTIFF to write (a three-band COG, written atomically); None: none.

    Returns
    -------
    Raster
        Bands ``height`` [m], ``spacing`` [m] and ``filling`` [1] on the land-use grid; cells
        of codes not in ``classes`` (warned) and nodata cells have no obstacle.

    Raises
    ------
    InputError
        A class name that is not in the table.

    Examples
    --------
    >>> raster = Raster(np.array([[[2.0, 6.0]]]), Affine(100, 0, 0, 0, -100, 100), "EPSG:32635")
    >>> out = land_use_obstacles(raster, {2: "compact_midrise", 6: "open_lowrise"})
    >>> out.data[0, 0].tolist(), out.data[2, 0].tolist()
    ([17.5, 6.5], [0.55, 0.3])
    """
    raster = as_raster(land_use)
    codes = raster.data[0]
    shape = codes.shape
    height, spacing, filling = np.zeros(shape), np.full(shape, np.nan), np.zeros(shape)
    for code, kind in classes.items():
        if isinstance(kind, ObstacleProperties):
            props = kind
        elif kind in LAND_USE_OBSTACLES:
            props = LAND_USE_OBSTACLES[kind]
        else:
            raise InputError(
                f"classes[{code!r}]={kind!r}; expected one of {', '.join(LAND_USE_OBSTACLES)} "
                "or ObstacleProperties"
            )
        cells = codes == code
        height[cells], spacing[cells], filling[cells] = props.height, props.spacing, props.filling
    unknown = np.setdiff1d(np.unique(codes[np.isfinite(codes)]), list(classes))
    if unknown.size:
        warnings.warn(
            f"{source_label(land_use, 'land-use raster')}: classes "
            f"{', '.join(f'{c:g}' for c in unknown[:10])} not in classes=; no obstacles there",
            DataQualityWarning,
            stacklevel=2,
        )
    out = Raster(
        np.stack([height, spacing, filling]),
        raster.transform,
        raster.crs,
        ("height", "spacing", "filling"),
        ("m", "m", "1"),
        {"model": "ILLUMINA obstacles from land use (Stewart & Oke 2012 defaults)"},
    )
    if output is not None:
        out.write(Path(output))
    return out
