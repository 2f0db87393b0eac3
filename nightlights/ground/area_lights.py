"""Area light sources as Voronoi pseudo-lights (Chuang 2011, Sec. 5.2).

A lit area seen from above (a parking lot under a canopy of luminaires, a sports field, a
lit forecourt) is given as a polygon with a luminous exitance M [lm m-2]: the flux per
unit area it sends down onto the ground.

Emission model (chosen here, documented because the thesis leaves it open): the polygon is a
horizontal, uniformly emitting Lambertian panel at ``height`` metres above the ground,
radiating downwards only, so an element dA has intensity :math:`(M\\,dA/\\pi)\\cos V` for
nadir angles V < 90 deg and none upwards. All its flux M A lands on the ground.

Following Chuang, the panel is replaced by a few pseudo point lights: generator points on a
square grid of ``spacing`` inside the polygon, their Voronoi cells clipped to the polygon,
one pseudo-light at each clipped cell's centroid carrying the cell's flux M x area. The
total flux is exact for any number of pseudo-lights; the ground pattern converges as
the spacing shrinks relative to the height (``benchmarks/bench_area_lights.py``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS

from nightlights._typing import FloatArray
from nightlights.errors import EmptyInputError, InputError
from nightlights.ground.frames import IntensityTable, luminaire_rotation
from nightlights.ground.luminaires import Luminaires, sample_elevation
from nightlights.io import as_vector, ensure_projected

if TYPE_CHECKING:
    import xarray as xr

    from nightlights.io import Raster

__all__ = [
    "AreaLightOptions",
    "PseudoLights",
    "area_luminaires",
    "lambertian_panel_table",
    "pseudo_lights",
    "read_area_lights",
    "rectangle_illuminance",
]


@dataclass(frozen=True)
class AreaLightOptions:
    """Knobs of the area-source model.

    Attributes
    ----------
    height
        Height of the emitting panel above the ground [m]. Default 8 m, a common mounting
        height of parking-lot and canopy luminaires (an assumption, not a measurement).
    spacing
        Grid spacing of the pseudo-light generators [m]. Default ``height / 2``, which keeps
        the ground illuminance within about 1 % of the exact panel
        (``benchmarks/bench_area_lights.py``).
    spectrum
        Spectrum name (``ies.spectra``) of the area sources; needed for non-photopic bands.
    """

    height: float = 8.0
    spacing: float | None = None
    spectrum: str | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.height) and self.height > 0):
            raise InputError(f"area_options.height={self.height!r} m; expected > 0")
        if self.spacing is not None and not (math.isfinite(self.spacing) and self.spacing > 0):
            raise InputError(f"area_options.spacing={self.spacing!r} m; expected > 0")

    @property
    def grid_spacing(self) -> float:
        """Spacing in use [m]."""
        return self.spacing if self.spacing is not None else self.height / 2.0


@dataclass(frozen=True)
class PseudoLights:
    """Pseudo point lights of area sources.

    Attributes
    ----------
    x, y
        Positions (cell centroids) [m].
    flux
        Flux carried by each pseudo-light (exitance x cell area) [lm].
    source
        Index of the polygon each pseudo-light belongs to.
    cells
        Voronoi cells clipped to their polygon.
    """

    x: FloatArray
    y: FloatArray
    flux: FloatArray
    source: NDArray[np.intp]
    cells: NDArray[np.object_]


def pseudo_lights(polygons: ArrayLike, exitance: ArrayLike, *, spacing: float) -> PseudoLights:
    """Voronoi pseudo-lights of polygons with uniform exitance.

    Parameters
    ----------
    polygons
        Shapely polygons or multipolygons in a projected CRS.
    exitance
        Luminous exitance per polygon [lm m-2].
    spacing
        Generator grid spacing [m].

    Returns
    -------
    PseudoLights
        At least one pseudo-light per non-empty polygon; empty input gives empty arrays.

    References
    ----------
    Chuang 2011, Sec. 5.2, Fig. 22.
    """
    geometries = np.asarray(polygons, dtype=object).ravel()
    exitance = np.broadcast_to(np.asarray(exitance, dtype=float), geometries.shape)
    xs: list[FloatArray] = []
    ys: list[FloatArray] = []
    fluxes: list[FloatArray] = []
    sources: list[NDArray[np.intp]] = []
    all_cells: list[NDArray[np.object_]] = []
    for index, (polygon, value) in enumerate(zip(geometries, exitance, strict=True)):
        if polygon is None or polygon.is_empty or polygon.area <= 0:
            continue
        cells = _voronoi_cells(polygon, spacing)
        centroids = shapely.centroid(cells)
        xs.append(shapely.get_x(centroids))
        ys.append(shapely.get_y(centroids))
        fluxes.append(value * shapely.area(cells))
        sources.append(np.full(len(cells), index, dtype=np.intp))
        all_cells.append(cells)
    if not xs:
        empty = np.zeros(0)
        return PseudoLights(empty, empty, empty, np.zeros(0, np.intp), np.zeros(0, object))
    return PseudoLights(
        np.concatenate(xs),
        np.concatenate(ys),
        np.concatenate(fluxes),
        np.concatenate(sources),
        np.concatenate(all_cells),
    )


def _voronoi_cells(polygon: shapely.Geometry, spacing: float) -> NDArray[np.object_]:
    xmin, ymin, xmax, ymax = polygon.bounds
    # Grid aligned to the polygon's bounds, centred so that a rectangle gets a regular
    # lattice of cell centres.
    nx = max(1, round((xmax - xmin) / spacing))
    ny = max(1, round((ymax - ymin) / spacing))
    gx = xmin + (np.arange(nx) + 0.5) * (xmax - xmin) / nx
    gy = ymin + (np.arange(ny) + 0.5) * (ymax - ymin) / ny
    px, py = (a.ravel() for a in np.meshgrid(gx, gy))
    points = shapely.points(px, py)
    inside = points[shapely.contains(polygon, points)]
    if len(inside) == 0:
        inside = np.array([polygon.representative_point()], dtype=object)
    if len(inside) == 1:
        return np.array([polygon], dtype=object)
    diagram = shapely.voronoi_polygons(shapely.multipoints(inside), extend_to=polygon.envelope)
    cells = shapely.intersection(np.asarray(shapely.get_parts(diagram)), polygon)
    cells = cells[~shapely.is_empty(cells) & (shapely.area(cells) > 0)]
    return np.asarray(cells, dtype=object)


def lambertian_panel_table() -> IntensityTable:
    """Candela table of one lumen emitted downwards by a Lambertian panel element [cd lm-1].

    :math:`I(V) = \\cos V / \\pi` for V < 90 deg, 0 above; integrates to 1 lm.
    """
    return IntensityTable.from_function(
        lambda v, h: np.where(v < 90.0, np.cos(np.radians(v)) / np.pi, 0.0),
        vertical_step=0.25,
        horizontal_step=90.0,
    )


def area_luminaires(
    lights: PseudoLights,
    *,
    height: float,
    spectrum: str | None = None,
    ground_z: FloatArray | None = None,
) -> Luminaires:
    """Kernel-ready luminaires for pseudo-lights (ids -1, -2, ...).

    Parameters
    ----------
    lights
        Pseudo-lights.
    height
        Panel height above the ground [m].
    spectrum
        Spectrum name of the sources.
    ground_z
        Ground elevation under each pseudo-light [m]; default 0.
    """
    n = len(lights.x)
    ground = np.zeros(n) if ground_z is None else np.asarray(ground_z, dtype=float)
    # Region of influence from the whole source's flux (see Luminaires.influence_scale).
    source_flux = np.asarray(
        np.bincount(lights.source, weights=lights.flux)[lights.source] if n else lights.flux,
        dtype=np.float64,
    )
    return Luminaires(
        light_id=-(np.arange(n, dtype=np.int64) + 1),
        light_point=np.column_stack([lights.x, lights.y, ground + height]).reshape(-1, 3),
        rotation=luminaire_rotation(np.zeros(n)).reshape(-1, 3, 3),
        street_azimuth=np.zeros(n),
        mounting_height=np.full(n, float(height)),
        tilt=np.zeros(n),
        roll=np.zeros(n),
        table_index=np.zeros(n, dtype=np.intp),
        intensity_scale=lights.flux,
        tables=(lambertian_panel_table(),),
        spectra=(spectrum,),
        names=("area_source",),
        influence_scale=source_flux,
    )


def read_area_lights(
    areas: gpd.GeoDataFrame | str | os.PathLike[str],
    *,
    exitance_field: str,
    crs: CRS | str,
    options: AreaLightOptions,
    dem: Raster | xr.DataArray | str | os.PathLike[str] | None = None,
) -> Luminaires:
    """Turn a polygon layer of area sources into pseudo-light luminaires.

    Parameters
    ----------
    areas
        Polygon layer with a luminous exitance field, or its path.
    exitance_field
        Field name holding the exitance [lm m-2].
    crs
        Projected CRS of the output raster; the layer is reprojected to it.
    options
        Panel height, spacing and spectrum.
    dem
        Elevation raster [m] (a :class:`~nightlights.io.Raster`, a DataArray or a path);
        default flat ground at z = 0.

    Raises
    ------
    InputError
        Missing field, non-polygon features, negative or non-numeric exitance (naming the
        features).
    """
    frame, path = as_vector(areas, name="area sources")
    if frame.empty:
        raise EmptyInputError(f"{path}: the area-source layer holds no polygons")
    frame = ensure_projected(frame, source=path).to_crs(crs)
    if exitance_field not in frame:
        raise InputError(
            f"{path}: no field {exitance_field!r} (fields: {', '.join(map(str, frame.columns))});"
            " name the luminous-exitance field with exitance_field="
        )
    exitance = pd.to_numeric(frame[exitance_field], errors="coerce").to_numpy(float)
    bad = ~(np.isfinite(exitance) & (exitance >= 0))
    if bad.any():
        raise InputError(
            f"{path}: features {np.flatnonzero(bad)[:10].tolist()} have {exitance_field} "
            f"{frame[exitance_field].to_numpy()[bad][:5].tolist()}; expected lm m-2 >= 0"
        )
    kinds = frame.geometry.geom_type.isin(["Polygon", "MultiPolygon"])
    if not kinds.all():
        raise InputError(
            f"{path}: features {np.flatnonzero(~kinds.to_numpy())[:10].tolist()} are not "
            "polygons; expected (multi)polygons of lit areas"
        )
    lights = pseudo_lights(frame.geometry.to_numpy(), exitance, spacing=options.grid_spacing)
    ground = None
    if dem is not None and len(lights.x):
        points = gpd.GeoDataFrame(geometry=gpd.points_from_xy(lights.x, lights.y), crs=crs)
        ground = sample_elevation(dem, points, source=f"{path} pseudo-lights")
    return area_luminaires(
        lights, height=options.height, spectrum=options.spectrum, ground_z=ground
    )


def rectangle_illuminance(
    x: ArrayLike,
    y: ArrayLike,
    bounds: tuple[float, float, float, float],
    *,
    exitance: float,
    height: float,
) -> FloatArray:
    """Exact illuminance under a horizontal Lambertian rectangle (the reference model).

    Parameters
    ----------
    x, y
        Ground points [m].
    bounds
        Rectangle (xmin, ymin, xmax, ymax) [m].
    exitance
        Luminous exitance of the rectangle [lm m-2].
    height
        Height of the rectangle above the ground [m].

    Returns
    -------
    numpy.ndarray
        Illuminance [lx].

    Notes
    -----
    :math:`E = M\\,F_{dA \\to \\text{rect}}`, with the view factor from a differential
    element to a parallel rectangle whose corner lies above it,

    .. math:: F = \\frac{1}{2\\pi}\\left[\\frac{A}{\\sqrt{1+A^2}}
              \\arctan\\frac{B}{\\sqrt{1+A^2}} + \\frac{B}{\\sqrt{1+B^2}}
              \\arctan\\frac{A}{\\sqrt{1+B^2}}\\right],\\quad A = a/h,\\ B = b/h,

    combined for any point by signed superposition of four corner rectangles.

    References
    ----------
    Howell, J. R., A Catalog of Radiation Heat Transfer Configuration Factors, 3rd ed.,
    factor B-3 (differential planar element to a parallel rectangle).
    """
    px = np.asarray(x, dtype=float)
    py = np.asarray(y, dtype=float)
    xmin, ymin, xmax, ymax = bounds

    def corner(a: FloatArray, b: FloatArray) -> FloatArray:
        big_a, big_b = np.abs(a) / height, np.abs(b) / height
        ra, rb = np.sqrt(1 + big_a**2), np.sqrt(1 + big_b**2)
        value = (big_a / ra * np.arctan(big_b / ra) + big_b / rb * np.arctan(big_a / rb)) / (
            2 * np.pi
        )
        return np.sign(a) * np.sign(b) * value

    factor = (
        corner(xmax - px, ymax - py)
        - corner(xmin - px, ymax - py)
        - corner(xmax - px, ymin - py)
        + corner(xmin - px, ymin - py)
    )
    return exitance * factor
