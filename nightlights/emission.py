"""Upward emission for skyglow: reflected light plus direct uplight, or from VIIRS.

Two ways to the same product, the upward luminous flux density [lm m-2] of each cell of a
coarse grid, which the skyglow stages take as their source:

1. From an irradiance raster and the light layer (:func:`emission`): the ground reflects
   Lambertianly, :math:`M_\\text{refl} = \\rho E` (albedo :math:`\\rho`, photopic
   illuminance :math:`E`), aggregated to the coarse grid by summing flux (flux-conserving
   block aggregation); and each luminaire's flux above the horizontal, from its photometry
   in the world frame (after tilt and roll), deposited in the cell holding its light point
   and divided by the cell area. The two are separate bands because they leave the ground
   with different angular distributions (Lambertian vs low-angle direct uplight).
2. From a VIIRS Day/Night Band radiance raster (:func:`emission_from_viirs`), for users
   without street data (see :func:`viirs_radiance_to_flux_density`).
"""

from __future__ import annotations

import logging
import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import rasterio
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS
from rasterio.warp import Resampling, calculate_default_transform, reproject

from nightlights.errors import CRSError, DataQualityWarning, EmptyInputError, InputError
from nightlights.io import RasterBand, ensure_projected, read_raster, read_vector, write_cog
from nightlights.irradiance import DatabaseLike, load_database, resolve_luminaires
from nightlights.tiling import RasterGrid

__all__ = [
    "DNB_BAND",
    "block_aggregate",
    "deposit_flux",
    "dnb_luminous_efficacy",
    "emission",
    "emission_from_viirs",
    "flux_density_to_viirs_radiance",
    "viirs_radiance_to_flux_density",
]

logger = logging.getLogger(__name__)

#: VIIRS DNB radiance unit [nW cm-2 sr-1] in SI [W m-2 sr-1].
NANOWATT_PER_CM2 = 1e-9 / 1e-4
#: Maximum luminous efficacy of photopic vision [lm W-1].
K_PHOTOPIC = 683.0
#: Nominal VIIRS Day/Night Band pass band [nm], used as a flat response (Elvidge et al. 2013,
#: "VIIRS night-time lights", Int. J. Remote Sens. 38, 5860: DNB spectral range 500-900 nm).
DNB_BAND = (500.0, 900.0)
#: Default spectrum of satellite-seen city light (an assumption; pass --spectrum HPS for
#: sodium-lit cities).
DEFAULT_VIIRS_SPECTRUM = "LED_4000K"


# --------------------------------------------------------------------------------------
# Pure models


def block_aggregate(values: ArrayLike, factor: int) -> NDArray[np.float64]:
    """Flux-conserving aggregation of a flux-density raster by an integer factor.

    Parameters
    ----------
    values
        Fine raster (rows, cols) of a flux density [lm m-2 or lx]; NaN counts as 0.
    factor
        Fine pixels per coarse pixel along each axis [1].

    Returns
    -------
    numpy.ndarray
        Coarse raster (ceil(rows/factor), ceil(cols/factor)): the flux of the fine pixels
        in each coarse cell divided by the coarse cell's area [same unit]. Edge cells only
        partly covered by the fine raster get the flux of the covered part, so the total
        flux (sum x cell area) is conserved exactly.
    """
    fine = np.nan_to_num(np.asarray(values, dtype=float), nan=0.0)
    if factor < 1:
        raise InputError(f"aggregation factor {factor}; expected an integer >= 1")
    rows, cols = fine.shape
    out_rows, out_cols = -(-rows // factor), -(-cols // factor)
    padded = np.zeros((out_rows * factor, out_cols * factor))
    padded[:rows, :cols] = fine
    return padded.reshape(out_rows, factor, out_cols, factor).sum(axis=(1, 3)) / factor**2


def deposit_flux(
    x: ArrayLike, y: ArrayLike, flux: ArrayLike, grid: RasterGrid
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Deposit point fluxes in the cells that contain them, as flux density.

    Parameters
    ----------
    x, y
        Point positions [m].
    flux
        Flux per point [lm].
    grid
        Target grid.

    Returns
    -------
    density : numpy.ndarray
        (rows, cols) flux per cell area [lm m-2].
    inside : numpy.ndarray
        Which points fell inside the grid.
    """
    px, py, f = (np.asarray(a, dtype=float) for a in (x, y, flux))
    col = np.floor((px - grid.x_min) / grid.resolution).astype(np.int64)
    row = np.floor((grid.y_max - py) / grid.resolution).astype(np.int64)
    inside = (col >= 0) & (col < grid.cols) & (row >= 0) & (row < grid.rows)
    density = np.bincount(
        row[inside] * grid.cols + col[inside], weights=f[inside], minlength=grid.rows * grid.cols
    ).reshape(grid.rows, grid.cols)
    return density / grid.resolution**2, inside


def dnb_luminous_efficacy(
    spectrum: str | tuple[ArrayLike, ArrayLike], *, band: tuple[float, float] = DNB_BAND
) -> float:
    """Lumens per watt of DNB-band radiant power for a source spectrum.

    Parameters
    ----------
    spectrum
        Spectrum name (``ies.spectra.SPDS``) or (wavelengths [nm], relative power).
    band
        Flat stand-in for the DNB relative spectral response [nm].

    Returns
    -------
    float
        :math:`K = 683 \\int S V d\\lambda / \\int_\\text{band} S d\\lambda` [lm W-1].

    Notes
    -----
    Approximation: the DNB response is taken as 1 inside ``band`` and 0 outside. The real
    response rolls off over ~20 nm at both ends; for broad spectra (LED, incandescent) the
    flat band changes K by a few percent, for line spectra (LPS at 589 nm) it is exact.
    """
    from ies import spectra

    source = spectra.get_spd(spectrum) if isinstance(spectrum, str) else None
    wavelengths = np.arange(360.0, 951.0, 1.0)
    if source is not None:
        power = source.on(wavelengths)
    else:
        w, v = (np.asarray(a, dtype=float) for a in spectrum)
        power = np.interp(wavelengths, w, v, left=0.0, right=0.0)
    photopic = spectra.get_sensor("photopic").on(wavelengths)
    response = ((wavelengths >= band[0]) & (wavelengths <= band[1])).astype(float)
    in_band = np.trapezoid(power * response, wavelengths)
    if in_band <= 0:
        raise InputError(f"spectrum {spectrum!r} has no power in the DNB band {band} nm")
    return float(K_PHOTOPIC * np.trapezoid(power * photopic, wavelengths) / in_band)


def viirs_radiance_to_flux_density(radiance: ArrayLike, efficacy: float) -> NDArray[np.float64]:
    """Upward luminous flux density of a Lambertian ground seen by VIIRS DNB.

    Parameters
    ----------
    radiance
        DNB radiance [nW cm-2 sr-1].
    efficacy
        Lumens per DNB watt of the source spectrum (:func:`dnb_luminous_efficacy`)
        [lm W-1].

    Returns
    -------
    numpy.ndarray
        Upward luminous flux density [lm m-2].

    Notes
    -----
    .. math:: M_v = \\pi\\, L\\, 10^{-5}\\, K

    A Lambertian emitter of radiance L has exitance :math:`\\pi L`; :math:`10^{-5}` turns
    nW cm-2 into W m-2. The satellite sees near-nadir radiance, so uplight leaving at low
    angles and light blocked by buildings and trees are outside this model.
    """
    return np.pi * np.asarray(radiance, dtype=float) * NANOWATT_PER_CM2 * efficacy


def flux_density_to_viirs_radiance(flux_density: ArrayLike, efficacy: float) -> NDArray[np.float64]:
    """Inverse of :func:`viirs_radiance_to_flux_density` [nW cm-2 sr-1]."""
    return np.asarray(flux_density, dtype=float) / (np.pi * NANOWATT_PER_CM2 * efficacy)


# --------------------------------------------------------------------------------------
# Stages


@dataclass(frozen=True)
class EmissionResult:
    """What an emission stage wrote: path, grid, CRS and total upward flux per band [lm]."""

    path: str
    grid: RasterGrid
    crs: CRS
    total_flux: dict[str, float]


def emission(
    irradiance_path: str | os.PathLike[str],
    lights_path: str | os.PathLike[str] | None,
    out_path: str | os.PathLike[str],
    *,
    resolution: float,
    albedo: float | str | os.PathLike[str],
    catalog: str | os.PathLike[str] | None = None,
    database: DatabaseLike | None = None,
    skip_unknown: bool = False,
    assume_crs: str | None = None,
) -> EmissionResult:
    """Stage ``emission``: irradiance + lights -> upward flux density, two bands.

    Parameters
    ----------
    irradiance_path
        Output of ``irradiance`` (needs its ``photopic`` band) [lx].
    lights_path
        The light layer that produced it (for the direct uplight); ``None`` for no uplight.
    out_path
        Output float32 COG: band 1 ``reflected``, band 2 ``uplight`` [lm m-2].
    resolution
        Coarse cell size; an integer multiple of the irradiance pixel size [m].
    albedo
        Ground reflectance, a number or a raster resampled to the irradiance grid [1].
    catalog, database
        Luminaire database (folder or object).
    skip_unknown
        Drop lights with unknown system ids instead of failing.
    assume_crs
        CRS of a light layer that has none.

    Notes
    -----
    Lights whose light point falls outside the coarse grid are dropped from the uplight
    band with a :class:`~nightlights.errors.DataQualityWarning` naming their number and
    flux.
    """
    data, meta = read_raster(irradiance_path)
    crs = meta["crs"]
    if crs is None:
        raise CRSError(f"{irradiance_path}: the irradiance raster has no CRS")
    transform = meta["transform"]
    if transform.b != 0 or transform.d != 0 or not math.isclose(transform.a, -transform.e):
        raise InputError(
            f"{irradiance_path}: expected a north-up grid with square pixels, got {transform}"
        )
    fine = transform.a
    band = _photopic_band(meta, irradiance_path)
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise InputError(f"resolution={resolution!r} m; expected a positive number of metres")
    factor = round(resolution / fine)
    if factor < 1 or not math.isclose(factor * fine, resolution, rel_tol=1e-6):
        raise InputError(
            f"resolution={resolution} m is not an integer multiple of the irradiance pixel "
            f"size {fine} m; expected e.g. {max(1, factor) * fine} m"
        )
    illuminance = data[band]
    albedo_grid = _albedo(albedo, illuminance.shape, transform, crs)
    reflected = block_aggregate(albedo_grid * illuminance, factor)
    grid = RasterGrid(transform.c, transform.f, float(resolution), *reflected.shape)
    uplight = np.zeros_like(reflected)
    if lights_path is not None:
        frame = read_vector(lights_path)
        if frame.empty:
            raise EmptyInputError(f"{lights_path}: the light layer holds no lights")
        frame = ensure_projected(frame, source=str(lights_path), assume_crs=assume_crs)
        frame = frame.to_crs(crs)
        luminaires = resolve_luminaires(
            frame,
            database or load_database(catalog),
            source=str(lights_path),
            skip_unknown=skip_unknown,
        )
        flux = luminaires.upward_flux()
        uplight, inside = deposit_flux(
            luminaires.light_point[:, 0], luminaires.light_point[:, 1], flux, grid
        )
        if (~inside).any():
            warnings.warn(
                f"{lights_path}: {(~inside).sum()} lights ({flux[~inside].sum():.4g} lm of "
                "uplight) stand outside the emission grid; left out",
                DataQualityWarning,
                stacklevel=2,
            )
    area = grid.resolution**2
    totals = {"reflected": float(reflected.sum() * area), "uplight": float(uplight.sum() * area)}
    write_cog(
        out_path,
        [
            RasterBand(
                reflected,
                "reflected",
                "lm m-2",
                {"quantity": "upward luminous flux density", "model": "Lambertian, albedo x E"},
            ),
            RasterBand(
                uplight,
                "uplight",
                "lm m-2",
                {"quantity": "upward luminous flux density", "model": "direct luminaire uplight"},
            ),
        ],
        transform=grid.transform,
        crs=crs,
        tags={
            "nightlights_stage": "emission",
            "source": str(irradiance_path),
            "albedo": str(albedo),
            "resolution_m": resolution,
            "total_reflected_lm": totals["reflected"],
            "total_uplight_lm": totals["uplight"],
        },
    )
    return EmissionResult(str(out_path), grid, crs, totals)


def _photopic_band(meta: dict[str, Any], path: str | os.PathLike[str]) -> int:
    for index, (description, tags) in enumerate(
        zip(meta["descriptions"], meta["band_tags"], strict=True)
    ):
        if tags.get("sensor") == "photopic" or description == "photopic":
            return index
    raise InputError(
        f"{path}: no photopic band (band descriptions {meta['descriptions']}); "
        "run irradiance with --sensor photopic"
    )


def _albedo(
    albedo: float | str | os.PathLike[str],
    shape: tuple[int, int],
    transform: Any,
    crs: CRS,
) -> NDArray[np.float64]:
    if isinstance(albedo, (int, float)):
        value = float(albedo)
        if not 0.0 <= value <= 1.0:
            raise InputError(f"albedo={albedo!r}; expected a reflectance in [0, 1]")
        return np.full(shape, value)
    grid = np.full(shape, np.nan)
    try:
        with rasterio.open(albedo) as dataset:
            if dataset.crs is None:
                raise CRSError(f"{albedo}: the albedo raster has no CRS")
            reproject(
                rasterio.band(dataset, 1),
                grid,
                dst_transform=transform,
                dst_crs=crs.to_wkt(),
                dst_nodata=np.nan,
                resampling=Resampling.bilinear,
            )
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{albedo}: cannot read the albedo raster: {exc}") from exc
    if np.isnan(grid).any():
        raise InputError(
            f"{albedo}: the albedo raster leaves {np.isnan(grid).sum()} irradiance pixels "
            "uncovered; expected it to cover the irradiance raster"
        )
    if grid.min() < 0 or grid.max() > 1:
        raise InputError(
            f"{albedo}: albedo values span {grid.min():.3g}..{grid.max():.3g}; expected [0, 1]"
        )
    return grid


def emission_from_viirs(
    viirs_path: str | os.PathLike[str],
    out_path: str | os.PathLike[str],
    *,
    spectrum: str = DEFAULT_VIIRS_SPECTRUM,
    resolution: float | None = None,
    target_crs: str | CRS | None = None,
    band: tuple[float, float] = DNB_BAND,
) -> EmissionResult:
    """Stage ``emission --from-viirs``: DNB radiance -> upward luminous flux density.

    Parameters
    ----------
    viirs_path
        VIIRS DNB radiance raster (band 1) [nW cm-2 sr-1].
    out_path
        Output float32 COG, one band ``upward`` [lm m-2].
    spectrum
        Spectrum of the city's light (``ies.spectra.SPDS``).
    resolution
        Output cell size [m]; default GDAL's estimate of the native pixel size.
    target_crs
        Projected output CRS; default the input's CRS if projected in metres, else the
        local UTM zone of the raster's centre.
    band
        Flat DNB pass band [nm].

    Notes
    -----
    Negative radiances (noise after background subtraction) are set to 0 with a
    :class:`~nightlights.errors.DataQualityWarning`. Resampling uses the area average, so a
    coarser output conserves flux.
    """
    try:
        with rasterio.open(viirs_path) as dataset:
            radiance = dataset.read(1, masked=True).astype(float).filled(np.nan)
            src_crs = CRS.from_user_input(dataset.crs.to_wkt()) if dataset.crs else None
            src_transform = dataset.transform
            width, height, bounds = dataset.width, dataset.height, dataset.bounds
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{viirs_path}: cannot read raster: {exc}") from exc
    if src_crs is None:
        raise CRSError(f"{viirs_path}: the VIIRS raster has no CRS; expected e.g. EPSG:4326")
    negative = radiance < 0
    if negative.any():
        warnings.warn(
            f"{viirs_path}: {negative.sum()} pixels have negative radiance (min "
            f"{np.nanmin(radiance):.3g} nW cm-2 sr-1); set to 0",
            DataQualityWarning,
            stacklevel=2,
        )
        radiance = np.where(negative, 0.0, radiance)
    efficacy = dnb_luminous_efficacy(spectrum, band=band)
    density = viirs_radiance_to_flux_density(radiance, efficacy)
    target = _viirs_target_crs(src_crs, bounds, target_crs, viirs_path)
    kwargs = {} if resolution is None else {"resolution": resolution}
    if resolution is not None and not (math.isfinite(resolution) and resolution > 0):
        raise InputError(f"resolution={resolution!r} m; expected a positive number of metres")
    if target == src_crs and (resolution is None or math.isclose(resolution, src_transform.a)):
        out, transform = density, src_transform
    else:
        transform, cols, rows = calculate_default_transform(
            src_crs.to_wkt(), target.to_wkt(), width, height, *bounds, **kwargs
        )
        out = np.full((rows, cols), np.nan)
        reproject(
            density,
            out,
            src_transform=src_transform,
            src_crs=src_crs.to_wkt(),
            src_nodata=np.nan,
            dst_transform=transform,
            dst_crs=target.to_wkt(),
            dst_nodata=np.nan,
            resampling=Resampling.average,
        )
    pixel_area = abs(transform.a * transform.e)
    total = float(np.nansum(out) * pixel_area)
    write_cog(
        out_path,
        [
            RasterBand(
                out,
                "upward",
                "lm m-2",
                {"quantity": "upward luminous flux density", "model": "VIIRS DNB, Lambertian"},
            )
        ],
        transform=transform,
        crs=target,
        tags={
            "nightlights_stage": "emission_from_viirs",
            "source": str(viirs_path),
            "spectrum": spectrum,
            "dnb_band_nm": f"{band[0]}-{band[1]}",
            "dnb_luminous_efficacy_lm_per_W": efficacy,
            "factor_lm_m2_per_nW_cm2_sr": np.pi * NANOWATT_PER_CM2 * efficacy,
        },
    )
    grid = RasterGrid(transform.c, transform.f, transform.a, *out.shape)
    return EmissionResult(str(out_path), grid, target, {"upward": total})


def _viirs_target_crs(
    src_crs: CRS,
    bounds: Sequence[float],
    target_crs: str | CRS | None,
    source: str | os.PathLike[str],
) -> CRS:
    if target_crs is not None:
        target = CRS.from_user_input(target_crs)
        if not target.is_projected:
            raise CRSError(f"target CRS {target.to_string()} is not projected")
        return target
    import geopandas as gpd
    from shapely.geometry import box

    footprint = gpd.GeoDataFrame(geometry=[box(*bounds)], crs=src_crs)
    projected = ensure_projected(footprint, source=str(source))
    return CRS.from_user_input(projected.crs)
