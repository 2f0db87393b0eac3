"""Stage ``irradiance``: a light layer to a geo-referenced ground illuminance raster.

Reads (or takes) the light layer, resolves its luminaires, adds area sources and terrain,
chooses the grid, runs the tiled kernel (:func:`~nightlights.ground.tiles.compute_irradiance`)
and returns the bands as a :class:`~nightlights.io.Raster`, written as a float32
Cloud-Optimised GeoTIFF when an output path is given (Chuang 2011, Secs. 4.3-5.2).
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import geopandas as gpd
import numpy as np
from pyproj import CRS

from nightlights._parallel import check_scheduler
from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights._validate import check_resolution
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.ground.area_lights import AreaLightOptions, read_area_lights
from nightlights.ground.checks import (
    BYTES_PER_TILE,
    DEM_BYTES_PER_PIXEL,
    IRRADIANCE_BYTES_PER_PIXEL,
    check_number,
    irradiance_memory,
    parse_crs,
)
from nightlights.ground.illuminance import check_backend, surface_normals
from nightlights.ground.influence import InfluenceThreshold
from nightlights.ground.luminaires import (
    DatabaseLike,
    Luminaires,
    band_unit,
    load_database,
    resolve_luminaires,
    sample_elevation,
    sensor_factors,
)
from nightlights.ground.tiles import (
    RasterGrid,
    balanced_tile_size,
    compute_irradiance,
    grid_from_bounds,
)
from nightlights.io import (
    CogWriter,
    OutputSet,
    Raster,
    as_vector,
    ensure_projected,
    raster_on_grid,
)
from nightlights.io.styles import PRODUCT_TAG

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["IrradianceResult", "ground_on_grid", "irradiance"]

#: How :func:`irradiance` writes its raster (:func:`~nightlights.io.write_cog`): ZSTD at
#: level 1 with the floating-point predictor, the blocks compressed on every core, overviews
#: by averaging. The lower mantissa bits of a lit float32 raster hardly compress, so that
#: DEFLATE's default level takes about twice as long for a file within a few per cent of the
#: size; an average is the mean illuminance of the coarser pixel (never negative, unlike the
#: COG driver's default cubic convolution near a cut-off) and takes less time to compute.
COG_OPTIONS: dict[str, Any] = {
    "compress": "ZSTD",
    "level": 1,
    "num_threads": "ALL_CPUS",
    "overview_resampling": "AVERAGE",
}


@dataclass(frozen=True)
class IrradianceResult:
    """What :func:`irradiance` computed.

    Attributes
    ----------
    n_lights
        Luminaires (including area pseudo-lights) that light at least one pixel.
    n_pairs
        Light-pixel evaluations [1].
    grid
        The raster's grid.
    crs
        The raster's projected CRS.
    path
        The written raster, or ``None`` when no output was asked for.
    """

    n_lights: int
    n_pairs: int
    grid: RasterGrid
    crs: CRS
    path: Path | None = None
    _in_memory: Raster | None = field(default=None, repr=False)

    @functools.cached_property
    def raster(self) -> Raster:
        """One band per sensor: ``photopic`` illuminance [lx], other sensors sensor-weighted
        irradiance [W m-2]; the values of the float32 file.

        A stage that wrote a file streamed its tiles there and kept no raster: this reads the
        file (whole, as float64) on first access, as it is then, with the metadata GDAL keeps
        in it (band tags carry the unit too).
        """
        if self._in_memory is not None:
            return self._in_memory
        assert self.path is not None
        return Raster.read(self.path)


def irradiance(
    lights: gpd.GeoDataFrame | str | os.PathLike[str],
    output: str | os.PathLike[str] | None = None,
    *,
    resolution: float,
    sensors: Sequence[str] = ("photopic",),
    bounds: Sequence[float] | None = None,
    margin: float | None = None,
    catalog: str | os.PathLike[str] | None = None,
    database: DatabaseLike | None = None,
    dem: Raster | xr.DataArray | str | os.PathLike[str] | None = None,
    threshold: InfluenceThreshold | None = None,
    area_sources: gpd.GeoDataFrame | str | os.PathLike[str] | None = None,
    exitance_field: str = "exitance",
    area_options: AreaLightOptions | None = None,
    skip_unknown: bool = False,
    crs: str | CRS | None = None,
    scheduler: str | Any | None = None,
    tile_size: int = 1024,
    progress: bool = True,
    backend: str = "numba",
) -> IrradianceResult:
    """Ground illuminance of a light layer, one band per sensor.

    Parameters
    ----------
    lights
        Point layer of ``streets place`` (``system_id``, ``heading`` [deg]; optional
        ``light_id``, ``mounting_height`` [m], ``arm_length`` [m], ``tilt`` [deg], ``roll``
        [deg]), or its path. Geographic input is reprojected to its UTM zone.
    output
        Float32 Cloud-Optimised GeoTIFF to write (:data:`COG_OPTIONS`); ``None`` writes
        nothing.
    resolution
        Pixel size [m].
    sensors
        Band per sensor: ``photopic`` gives illuminance [lx], others (``ies.spectra.SENSORS``)
        sensor-weighted irradiance [W m-2].
    bounds
        (xmin, ymin, xmax, ymax) in the lights' CRS [m]; default the lights' extent grown by
        ``margin``.
    margin
        Growth of the default extent [m]; default the largest region-of-influence radius.
    catalog
        Luminaire database folder; default the bundled one.
    database
        A database object (overrides ``catalog``).
    dem
        Elevation raster [m] for ground height and surface normals (a
        :class:`~nightlights.io.Raster`, a DataArray or a path); default flat z = 0.
    threshold
        Region of influence (default :class:`~nightlights.ground.InfluenceThreshold`).
    area_sources
        Polygon layer of area sources, or its path (see :mod:`nightlights.ground.area_lights`).
    exitance_field
        Field of ``area_sources`` holding luminous exitance [lm m-2].
    area_options
        :class:`~nightlights.ground.AreaLightOptions` (default panel height and spacing).
    skip_unknown
        Drop lights with unknown system ids instead of failing.
    crs
        CRS of a light layer that has none.
    scheduler
        ``dask.distributed`` address or Client; default local threads.
    tile_size
        Tile edge [pixels].
    progress
        Show a progress bar.
    backend
        Illuminance kernel: ``"numba"`` (compiled, the default) or ``"numpy"`` (the
        reference; equal to 1e-6 relative on every pixel, several times slower).

    Returns
    -------
    IrradianceResult
        The raster, the number of lights that light it and of light-pixel evaluations, and
        the written path.

    Raises
    ------
    InputError
        Bad resolution, bounds, sensors or light fields (naming the lights).
    EmptyInputError
        No lights and no area sources.
    CRSError
        The light layer has no CRS and ``crs`` is not given, or ``crs`` is not a CRS.
    ResourceError
        The raster and the tiles in flight would need more memory than allowed
        (:func:`nightlights._resources.check_memory`); checked before allocating.
    OutputError
        ``output`` cannot be written (checked before computing).

    Warns
    -----
    DataQualityWarning
        Pixels larger than every region of influence, or an all-zero raster (with the
        reason: lights too high or dim to reach the threshold, pixels that miss the regions,
        regions outside the bounds).

    Notes
    -----
    Each luminaire adds :math:`E = I(V, H) \\max(0, \\cos\\beta) / d^2` to every pixel centre
    inside its region of influence (Chuang 2011, Eq. 11). Lights outside the raster still
    contribute where their region of influence reaches into it; lights whose region does not
    touch the raster are ignored, with a :class:`~nightlights.errors.DataQualityWarning`
    giving their number.

    References
    ----------
    Chuang 2011, Sec. 5.1, Eq. 11.

    Examples
    --------
    Two street lights of the bundled catalogue facing each other across a street:

    >>> import geopandas as gpd
    >>> from shapely.geometry import Point
    >>> lights = gpd.GeoDataFrame(
    ...     {"system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
    ...     geometry=[Point(0, 0), Point(20, 10)],
    ...     crs="EPSG:3067",
    ... )
    >>> result = irradiance(lights, resolution=2.0, progress=False)
    >>> result.raster.descriptions, result.raster.units, result.n_lights
    (('photopic',), ('lx',), 2)
    >>> round(float(result.raster.band("photopic").max()), 1)  # [lx]
    12.0
    """
    threshold = threshold or InfluenceThreshold()
    check_backend(backend)
    resolution = check_resolution(resolution)
    if margin is not None:
        margin = check_number(margin, "margin", "m", minimum=0.0)
    if isinstance(tile_size, bool) or not isinstance(tile_size, int) or tile_size < 1:
        raise InputError(f"tile_size={tile_size!r}; expected a whole number of pixels >= 1")
    if not sensors:
        raise InputError("no sensors requested; expected at least one (e.g. photopic)")
    assume_crs = parse_crs(crs, option="crs")
    scheduler = check_scheduler(scheduler)  # an address is parsed and probed before any work
    if output is not None:
        # the output's folder is checked before anything is computed; no input is replaced
        OutputSet(
            output,
            inputs={
                "lights": lights,
                "dem": dem,
                "area_sources": area_sources,
                "catalog": catalog,
            },
        )
    frame, label = as_vector(lights, name="lights")
    frame = ensure_projected(frame, source=label, assume_crs=assume_crs)
    layer_crs = CRS.from_user_input(frame.crs)
    if frame.empty and area_sources is None:
        raise EmptyInputError(f"{label}: the light layer holds no lights")
    parts: list[Luminaires] = []
    if not frame.empty:
        database = database or load_database(catalog)
        ground_at_pole = None
        if dem is not None:
            ground_at_pole = sample_elevation(dem, frame, source=label)
        parts.append(
            resolve_luminaires(
                frame,
                database,
                source=label,
                skip_unknown=skip_unknown,
                ground_elevation=ground_at_pole,
            )
        )
    if area_sources is not None:
        parts.append(
            read_area_lights(
                area_sources,
                exitance_field=exitance_field,
                crs=layer_crs,
                options=area_options or AreaLightOptions(),
                dem=dem,
            )
        )
    luminaires = Luminaires.concatenate(parts) if len(parts) > 1 else parts[0]
    if len(luminaires) == 0:
        raise EmptyInputError(f"{label}: no usable lights remain")
    radius = luminaires.radius(threshold)
    weights = sensor_factors(luminaires.spectra, sensors, names=luminaires.names)
    weights = weights[luminaires.table_index]
    weights = weights * luminaires.intensity_scale[:, None]
    if bounds is None:
        reach = float(np.max(radius)) if margin is None else float(margin)
        if not math.isfinite(reach):
            raise InputError("threshold 'none' gives unbounded regions: name bounds= or margin=")
        x, y = luminaires.light_point[:, 0], luminaires.light_point[:, 1]
        bounds = (x.min() - reach, y.min() - reach, x.max() + reach, y.max() + reach)
        bounds = (
            *bounds[:2],
            max(bounds[2], bounds[0] + resolution),
            max(bounds[3], bounds[1] + resolution),
        )
    grid = grid_from_bounds(bounds, resolution)
    _check_memory(
        grid,
        len(sensors),
        radius,
        tile_size,
        dem is not None,
        scheduler is None,
        backend,
        streamed=output is not None,
    )
    coarse = _coarse_pixels(radius, resolution)
    ground_z = normals = None
    if dem is not None:
        ground_z, normals = ground_on_grid(dem, grid, layer_crs)
    tags = {
        PRODUCT_TAG: "irradiance",
        "nightlights_stage": "irradiance",
        "resolution_m": resolution,
        "threshold": f"{threshold.kind}:{threshold.value}",
        "max_radius_m": threshold.max_radius,
        "lights": len(luminaires),
        "kernel": backend,
        "reference": "Chuang 2011, Sec. 5.1, Eq. 11",
    }
    units = tuple(band_unit(sensor) for sensor in sensors)
    band_tags = tuple(
        {
            "sensor": sensor,
            "quantity": "illuminance" if sensor == "photopic" else "sensor-weighted irradiance",
        }
        for sensor in sensors
    )
    kernel = functools.partial(
        compute_irradiance,
        grid,
        luminaires,
        weights,
        radius,
        ground_z=ground_z,
        normals=normals,
        scheduler=scheduler,
        tile_size=tile_size,
        progress=progress,
        backend=backend,
    )
    raster = None
    if output is None:
        computed = kernel()
        assert computed.bands is not None
        tags["light_pixel_evaluations"] = computed.n_pairs
        raster = Raster(
            computed.bands.astype(np.float64),
            grid.transform,
            layer_crs,
            descriptions=tuple(sensors),
            units=units,
            tags={key: str(value) for key, value in tags.items()},
            band_tags=band_tags,
        )
    else:
        # the tiles go to the file as they are computed: memory holds the tiles in flight
        # and the writer's block cache, never the raster
        writer = CogWriter(
            output,
            shape=(len(sensors), grid.rows, grid.cols),
            transform=grid.transform,
            crs=layer_crs,
            descriptions=tuple(sensors),
            units=units,
            band_tags=band_tags,
            tags=tags,
            **COG_OPTIONS,
        )
        with writer:
            computed = kernel(
                write=lambda tile, values: writer.write(values, row=tile.row0, col=tile.col0)
            )
            # the count is known once the tiles are done, before the file is finished
            writer.update_tags(light_pixel_evaluations=computed.n_pairs)
    n_lights, n_pairs, lit = computed.n_lights, computed.n_pairs, computed.lit
    del computed
    if not lit:
        reason = _zero_reason(luminaires, radius, threshold, coarse, n_lights)
        warnings.warn(
            f"{label}: the irradiance raster is all zero: {reason}",
            DataQualityWarning,
            stacklevel=2,
        )
    elif coarse:
        warnings.warn(f"{label}: {coarse}", DataQualityWarning, stacklevel=2)
    return IrradianceResult(
        n_lights,
        n_pairs,
        grid,
        layer_crs,
        None if output is None else Path(output),
        raster,
    )


def _check_memory(
    grid: RasterGrid,
    bands: int,
    radius: FloatArray,
    tile_size: int,
    dem: bool,
    local: bool,
    backend: str,
    streamed: bool,
) -> None:
    """Refuse a grid whose estimated peak memory is over the limit (before allocating)."""
    pixels = float(grid.rows) * float(grid.cols)
    with np.errstate(over="ignore"):
        pairs = float(np.sum(np.minimum(np.pi * radius**2 / grid.resolution**2, pixels)))
    workers = os.cpu_count() or 1
    # the compiled kernel's tiles are smaller on a small grid (compute_irradiance's rule)
    in_flight = balanced_tile_size(grid, tile_size, workers) if backend == "numba" else tile_size
    estimate = irradiance_memory(
        grid.rows,
        grid.cols,
        bands,
        tile_size=in_flight,
        workers=workers,
        pairs=pairs,
        dem=dem,
        local=local,
        backend=backend,
        streamed=streamed,
    )
    # The grid's own arrays; the rest is tiles in flight and the task graph.
    raster_part = 0 if streamed else bands * IRRADIANCE_BYTES_PER_PIXEL
    grid_part = pixels * (raster_part + (DEM_BYTES_PER_PIXEL if dem else 0))
    n_tiles = math.ceil(grid.rows / tile_size) * math.ceil(grid.cols / tile_size)
    if n_tiles * BYTES_PER_TILE > estimate / 2:
        hint = "use a larger tile_size="
    elif grid_part < estimate / 2:
        hint = "use a smaller tile_size="
    else:
        hint = "use a coarser resolution= (or smaller bounds=)"
    check_memory(
        estimate,
        f"the irradiance raster of {grid.rows} x {grid.cols} pixels x {bands} "
        f"band{'s' if bands != 1 else ''}",
        option=hint,
    )


def _coarse_pixels(radius: FloatArray, resolution: float) -> str | None:
    """A warning when pixels are coarser than every region of influence, else None."""
    finite = radius[np.isfinite(radius)]
    if len(finite) < len(radius) or not len(finite):
        return None
    largest = float(finite.max())
    if largest <= 0 or resolution <= largest:
        return None
    return (
        f"pixels of {resolution:g} m are larger than the lights' regions of influence "
        f"(largest radius {largest:.3g} m): pixel centres miss most of the light; expected "
        f"resolution= below {largest:.3g} m"
    )


def _zero_reason(
    luminaires: Luminaires,
    radius: FloatArray,
    threshold: InfluenceThreshold,
    coarse: str | None,
    n_lit: int,
) -> str:
    """Why an irradiance raster came out all zero, for the warning."""
    if len(radius) and not np.any(radius > 0):
        highest = float(np.max(luminaires.mounting_height))
        if threshold.kind == "floor":
            return (
                f"no light puts the {threshold.value:g} lx of threshold= on the ground "
                f"(mounting heights up to {highest:.4g} m): the lights are too high or too dim"
            )
        return "no light sends light down to the ground"
    if coarse:
        return coarse
    if n_lit == 0:
        return "no light's region of influence reaches the raster; check bounds="
    return "no pixel centre falls inside a light's region of influence"


def ground_on_grid(
    dem: Raster | xr.DataArray | str | os.PathLike[str], grid: RasterGrid, crs: CRS
) -> tuple[FloatArray, FloatArray]:
    """DEM resampled (bilinear) to ``grid`` and its unit surface normals.

    Parameters
    ----------
    dem
        Elevation raster [m]: a :class:`~nightlights.io.Raster`, a DataArray or a path.
    grid
        Target grid.
    crs
        CRS of the grid; a DEM without a CRS is taken to be in it.

    Returns
    -------
    elevation : numpy.ndarray
        (rows, cols) [m].
    normals : numpy.ndarray
        (rows, cols, 3) unit normals, z up [1].

    Raises
    ------
    InputError
        The DEM cannot be read or does not cover the grid.
    """
    elevation = raster_on_grid(
        dem, transform=grid.transform, shape=(grid.rows, grid.cols), crs=crs, name="DEM"
    )
    return elevation, surface_normals(elevation, grid.resolution)
