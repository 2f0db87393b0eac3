"""Upward emission for skyglow: reflected light plus direct uplight, or from VIIRS.

Two ways to the same product, the upward luminous flux density [lm m-2] of each cell of a
coarse grid, which the skyglow stages take as their source:

1. From an irradiance raster and the light layer (:func:`emission`): the ground reflects
   Lambertianly, :math:`M_\\text{refl} = \\rho E` (albedo :math:`\\rho`, photopic
   illuminance :math:`E`), aggregated to the coarse grid by summing flux (flux-conserving
   block aggregation); and each luminaire's flux above the horizontal, from its photometry
   in the world frame (after tilt and roll), deposited in the cell holding its light point
   and divided by the cell area. The two are separate bands because they leave the ground
   with different angular distributions (Lambertian vs low-angle direct uplight), tagged
   ``emission_function`` = ``lambertian`` and ``uplight``.
2. From a VIIRS Day/Night Band radiance raster (:func:`emission_from_viirs`), for users
   without street data (see :func:`viirs_radiance_to_flux_density`): one band tagged with
   the emission function that turned its nadir radiance into flux.

Length: about 700 lines, because the two routes to one product share its result
(:class:`EmissionResult`), its conversions and its checked writing; their window loops, grids
and memory estimates are in :mod:`nightlights.ground._emission_run` and
:mod:`nightlights.ground._viirs_run`.
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from collections.abc import Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import geopandas as gpd
import numpy as np
from affine import Affine
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS

from ies import spectra
from nightlights._typing import FloatArray
from nightlights._validate import check_resolution
from nightlights.emission_functions import EMISSION_FUNCTION_TAG, EmissionFunction
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.ground import _emission_run
from nightlights.ground._emission_run import (
    Albedo,
    EmissionRun,
    Uplight,
    cell_index,
    cell_sums,
    check_emission_memory,
    open_irradiance,
    output_grid,
)
from nightlights.ground._viirs_run import (
    FLUX_TAG,
    GRID_TAG,
    ViirsRun,
    geographic_cell_areas,
    source_crs,
)
from nightlights.ground._windows import ArraySource, FileSource, OutputGrid
from nightlights.ground.checks import parse_crs
from nightlights.ground.luminaires import DatabaseLike, load_database, resolve_luminaires
from nightlights.ground.tiles import RasterGrid
from nightlights.io import (
    OutputSet,
    Raster,
    as_raster,
    as_vector,
    ensure_projected,
    source_label,
)
from nightlights.io.streamed import CACHE_MB
from nightlights.io.styles import PRODUCT_TAG

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "DEFAULT_VIIRS_SPECTRUM",
    "DNB_BAND",
    "FLUX_TAG",
    "GRID_TAG",
    "EmissionResult",
    "block_aggregate",
    "deposit_flux",
    "dnb_luminous_efficacy",
    "emission",
    "emission_from_viirs",
    "flux_density_to_viirs_radiance",
    "geographic_cell_areas",
    "viirs_radiance_to_flux_density",
]

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


def block_aggregate(values: ArrayLike, factor: int) -> FloatArray:
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
    if factor < 1:
        raise InputError(f"aggregation factor {factor}; expected an integer >= 1")
    fine = np.nan_to_num(np.asarray(values, dtype=float), nan=0.0)
    return cell_sums(fine, factor) / float(factor) ** 2


def deposit_flux(
    x: ArrayLike, y: ArrayLike, flux: ArrayLike, grid: RasterGrid
) -> tuple[FloatArray, NDArray[np.bool_]]:
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
    f = np.asarray(flux, dtype=float)
    row, col, inside = cell_index(x, y, grid)
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


def viirs_radiance_to_flux_density(
    radiance: ArrayLike, efficacy: float, *, zenith_intensity: float = 1.0 / math.pi
) -> FloatArray:
    """Upward luminous flux density of a ground seen at nadir by VIIRS DNB.

    Parameters
    ----------
    radiance
        DNB radiance [nW cm-2 sr-1].
    efficacy
        Lumens per DNB watt of the source spectrum (:func:`dnb_luminous_efficacy`)
        [lm W-1].
    zenith_intensity
        Intensity straight up per lumen of upward flux of the emission function,
        I_1(0): 1 / pi for a Lambertian ground (default), w_L / pi for Garstang's function
        (only its Lambertian part shines straight up) [cd lm-1].

    Returns
    -------
    numpy.ndarray
        Upward luminous flux density [lm m-2].

    Notes
    -----
    .. math:: M_v = \\frac{L\\, 10^{-5}\\, K}{I_1(0)} \\quad (= \\pi L 10^{-5} K
        \\text{ for a Lambertian ground})

    The satellite sees the intensity straight up, I(0) = M_v A I_1(0), from a cell of area A,
    as the luminance L_v = I(0) / A = M_v I_1(0); :math:`10^{-5}` turns nW cm-2 into W m-2.
    Flux leaving at low angles is inferred only through the emission function; light blocked
    by buildings and trees is outside this model.
    """
    if not (np.isfinite(zenith_intensity) and zenith_intensity > 0):
        raise InputError(
            f"zenith_intensity {zenith_intensity!r} cd lm-1; expected > 0 (an emission "
            "function that sends no light straight up cannot be inferred from nadir radiance)"
        )
    lambertian = np.pi * np.asarray(radiance, dtype=float) * NANOWATT_PER_CM2 * efficacy
    return lambertian * ((1.0 / math.pi) / zenith_intensity)


def flux_density_to_viirs_radiance(
    flux_density: ArrayLike, efficacy: float, *, zenith_intensity: float = 1.0 / math.pi
) -> FloatArray:
    """DNB radiance of an upward luminous flux density; the inverse of
    :func:`viirs_radiance_to_flux_density`.

    Parameters
    ----------
    flux_density
        Upward luminous flux density [lm m-2].
    efficacy
        Lumens per DNB watt of the source spectrum [lm W-1].
    zenith_intensity
        Intensity straight up per lumen of upward flux, I_1(0) (default Lambertian,
        1 / pi) [cd lm-1].

    Returns
    -------
    numpy.ndarray
        DNB radiance [nW cm-2 sr-1].
    """
    lambertian = np.asarray(flux_density, dtype=float) / (np.pi * NANOWATT_PER_CM2 * efficacy)
    return lambertian * (zenith_intensity / (1.0 / math.pi))


@dataclass(frozen=True)
class EmissionResult:
    """What an emission stage computed.

    Attributes
    ----------
    path
        The written raster, or ``None`` when no output was asked for.
    total_flux
        Total upward flux per band [lm]: flux density x cell area, the geodesic area of each
        cell on a geographic grid (:func:`geographic_cell_areas`).
    transform
        Affine transform of the raster's top-left corner [m, or deg on a geographic grid].
    shape
        (rows, cols) [cells].
    crs
        The raster's CRS: projected, or geographic where a VIIRS raster wider than one UTM
        zone keeps its own grid (:func:`emission_from_viirs`).
    """

    path: Path | None
    total_flux: Mapping[str, float]
    transform: Affine
    shape: tuple[int, int]
    crs: CRS
    _in_memory: Raster | None = field(default=None, repr=False)

    @classmethod
    def of(
        cls, raster: Raster, path: Path | None, total_flux: Mapping[str, float]
    ) -> EmissionResult:
        """The result of a raster held in memory."""
        assert raster.crs is not None
        return cls(path, dict(total_flux), raster.transform, raster.shape, raster.crs, raster)

    @functools.cached_property
    def raster(self) -> Raster:
        """Upward luminous flux density [lm m-2]: bands ``reflected`` and ``uplight``
        (:func:`emission`) or ``upward`` (:func:`emission_from_viirs`); the values of the
        float32 file.

        A stage that streamed its windows to a file kept no raster: this reads the file
        (whole, as float64) on first access.
        """
        if self._in_memory is not None:
            return self._in_memory
        assert self.path is not None
        return Raster.read(self.path)

    @property
    def geographic(self) -> bool:
        """Whether the grid is geographic (cells in degrees, flux density per geodesic area)."""
        return bool(self.crs.is_geographic)

    @property
    def grid(self) -> RasterGrid:
        """The raster's grid (in the CRS's units)."""
        return RasterGrid.from_transform(self.transform, self.shape)


def emission(
    irradiance: Raster | xr.DataArray | str | os.PathLike[str],
    output: str | os.PathLike[str] | None = None,
    *,
    lights: gpd.GeoDataFrame | str | os.PathLike[str] | None = None,
    resolution: float,
    albedo: float | Raster | xr.DataArray | str | os.PathLike[str],
    catalog: str | os.PathLike[str] | None = None,
    database: DatabaseLike | None = None,
    skip_unknown: bool = False,
    crs: str | CRS | None = None,
    progress: bool = True,
) -> EmissionResult:
    """Upward luminous flux density from ground illuminance and the lights, two bands.

    Parameters
    ----------
    irradiance
        Output of :func:`~nightlights.ground.irradiance` (needs its ``photopic`` band) [lx]:
        a :class:`~nightlights.io.Raster`, a DataArray or a path.
    output
        Float32 Cloud-Optimised GeoTIFF to write; ``None`` writes nothing.
    lights
        The light layer that produced it (for the direct uplight), or its path; ``None``
        for no uplight.
    resolution
        Coarse cell size; an integer multiple of the irradiance pixel size [m].
    albedo
        Ground reflectance [1]: a number, or a raster (Raster, DataArray or path) resampled
        bilinearly to the irradiance grid.
    catalog
        Luminaire database folder; default the bundled one.
    database
        A database object (overrides ``catalog``).
    skip_unknown
        Drop lights with unknown system ids instead of failing.
    crs
        CRS of a light layer that has none.
    progress
        Show a progress bar (with the time remaining) over the windows.

    Returns
    -------
    EmissionResult
        Band 1 ``reflected``, band 2 ``uplight`` [lm m-2] and their total flux [lm]. With a
        raster file in and an output file, the windows were streamed to the file and the
        result holds no raster: its ``raster`` reads the file on first access.

    Raises
    ------
    InputError
        Resolution not a multiple of the pixel size, no photopic band, infinite, negative
        or no illuminance values, albedo outside [0, 1] or not covering the raster.
    CRSError
        The irradiance or albedo raster has no CRS, the irradiance raster is geographic, or
        ``crs`` is not a CRS.
    ResourceError
        A window, or the output grid held in memory when no output file is written (or the
        irradiance is not a file), would need more memory than allowed (checked before
        reading).
    OutputError
        ``output`` cannot be written (checked before reading).

    Notes
    -----
    The ground reflects Lambertianly, :math:`M_\\text{refl} = \\rho E`, aggregated to the
    coarse grid by summing flux; each luminaire's flux above the horizontal, in the world
    frame, is deposited in the cell holding its light point. Lights whose light point falls
    outside the coarse grid are dropped from the uplight band with a
    :class:`~nightlights.errors.DataQualityWarning` naming their number and flux.

    The raster is computed in windows of the output grid
    (:mod:`nightlights.ground._emission_run`), each reading only its own irradiance pixels
    (and a window of an albedo raster with the bilinear kernel's halo) and written to
    ``output`` as it is done (:class:`~nightlights.io.CogWriter`): memory is bounded by a
    window, whatever the raster's size. The checks of the whole raster are counted over the
    windows and raised before the output is finished, so a refused raster leaves no output.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely.geometry import Point
    >>> from nightlights.ground import irradiance
    >>> lights = gpd.GeoDataFrame(
    ...     {"system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
    ...     geometry=[Point(0, 0), Point(20, 10)],
    ...     crs="EPSG:3067",
    ... )
    >>> ground = irradiance(lights, resolution=2.0, progress=False).raster
    >>> result = emission(ground, lights=lights, resolution=20.0, albedo=0.15, progress=False)
    >>> result.raster.descriptions
    ('reflected', 'uplight')
    >>> {band: round(flux) for band, flux in result.total_flux.items()}
    {'reflected': 1193, 'uplight': 0}
    """
    label = source_label(irradiance, "irradiance raster")
    assume_crs = parse_crs(crs, option="crs")
    check_resolution(resolution)
    inputs = {"irradiance": irradiance, "lights": lights, "albedo": albedo, "catalog": catalog}
    if output is not None:
        OutputSet(output, inputs=inputs)  # checked before reading
    albedo_text = (
        str(albedo)
        if isinstance(albedo, (int, float, str, os.PathLike))
        else source_label(albedo, "albedo raster")
    )
    tags = {
        PRODUCT_TAG: "emission",
        "nightlights_stage": "emission",
        "source": label,
        "albedo": albedo_text,
        "resolution_m": resolution,
    }

    def totals_tags(totals: Mapping[str, float]) -> dict[str, Any]:
        return {
            **tags,
            "total_reflected_lm": totals["reflected"],
            "total_uplight_lm": totals["uplight"],
        }

    band_tags = (
        {
            "quantity": "upward luminous flux density",
            "model": "Lambertian, albedo x E",
            EMISSION_FUNCTION_TAG: "lambertian",
        },
        {
            "quantity": "upward luminous flux density",
            "model": "direct luminaire uplight",
            EMISSION_FUNCTION_TAG: "uplight",
        },
    )
    streamed = output is not None and isinstance(irradiance, (str, os.PathLike))
    with ExitStack() as stack:
        source, copied = open_irradiance(irradiance, label, stack)
        grid, factor = output_grid(source, label, resolution)
        side = _emission_run.WINDOW_CELLS
        run = EmissionRun(
            label,
            source,
            factor,
            grid,
            Albedo.open(albedo, OutputGrid(source.transform, *source.shape, source.crs), stack),
            side,
            progress=progress,
        )
        check_emission_memory(run, in_memory=not streamed, copied_bands=copied)
        if lights is not None:
            run.uplight = _uplight(
                lights, grid, side, assume_crs, database or load_database(catalog), skip_unknown
            )
        if streamed:
            assert output is not None
            totals = run.streamed(Path(output), totals_tags, band_tags)
            return EmissionResult(
                Path(output), totals, grid.transform, (grid.rows, grid.cols), grid.crs
            )
        result, totals = run.in_memory(totals_tags, band_tags)
    outputs = None if output is None else OutputSet(output, inputs=inputs)
    return EmissionResult.of(result, _write(result, output, outputs), totals)


def _uplight(
    lights: gpd.GeoDataFrame | str | os.PathLike[str],
    grid: OutputGrid,
    side: int,
    assume_crs: CRS | None,
    database: DatabaseLike,
    skip_unknown: bool,
) -> Uplight:
    """The uplight of the lights standing on the grid; a warning for those outside it."""
    frame, lights_label = as_vector(lights, name="lights")
    if frame.empty:
        raise EmptyInputError(f"{lights_label}: the light layer holds no lights")
    frame = ensure_projected(frame, source=lights_label, assume_crs=assume_crs)
    frame = frame.to_crs(grid.crs)
    luminaires = resolve_luminaires(frame, database, source=lights_label, skip_unknown=skip_unknown)
    flux = luminaires.upward_flux()
    coarse = RasterGrid.from_transform(grid.transform, (grid.rows, grid.cols))
    row, col, inside = cell_index(
        luminaires.light_point[:, 0], luminaires.light_point[:, 1], coarse
    )
    if (~inside).any():
        warnings.warn(
            f"{lights_label}: {(~inside).sum()} lights ({flux[~inside].sum():.4g} lm of "
            "uplight) stand outside the emission grid; left out",
            DataQualityWarning,
            stacklevel=3,
        )
    return Uplight(row[inside], col[inside], flux[inside], grid, side)


def emission_from_viirs(
    viirs: Raster | xr.DataArray | str | os.PathLike[str],
    output: str | os.PathLike[str] | None = None,
    *,
    spectrum: str = DEFAULT_VIIRS_SPECTRUM,
    resolution: float | None = None,
    target_crs: str | CRS | None = None,
    band: tuple[float, float] = DNB_BAND,
    emission_function: str = "lambertian",
    progress: bool = True,
) -> EmissionResult:
    """Upward luminous flux density from a VIIRS Day/Night Band radiance raster.

    Parameters
    ----------
    viirs
        VIIRS DNB radiance (band 1) [nW cm-2 sr-1]: a :class:`~nightlights.io.Raster`, a
        DataArray or a path.
    output
        Float32 Cloud-Optimised GeoTIFF to write, one band ``upward`` [lm m-2]; ``None``
        writes nothing.
    spectrum
        Spectrum of the city's light (``ies.spectra.SPDS``).
    resolution
        Output cell size of a projected output [m]; default GDAL's estimate of the native
        pixel size.
    target_crs
        Projected output CRS; default the input's CRS if projected in metres, the input's own
        geographic grid if it spans more than one UTM zone
        (:data:`~nightlights.ground.viirs_input.ZONE_WIDTH` of longitude), else the local UTM
        zone of the raster's centre.
    band
        Flat DNB pass band [nm].
    emission_function
        Angular emission function of the city's light (``lambertian`` or ``garstang:F,G``,
        :class:`~nightlights.emission_functions.EmissionFunction`): it sets the flux the nadir
        radiance implies (:func:`viirs_radiance_to_flux_density`) and is written as the
        band's ``emission_function`` tag, which the skyglow stage reads. Garstang's
        F = G = 0.15 gives 1 / 0.459 = 2.18 times the Lambertian flux: its low-angle lobe is
        invisible from nadir.
    progress
        Show a progress bar (with the time remaining) over the windows.

    Returns
    -------
    EmissionResult
        One band ``upward`` [lm m-2] and its total flux [lm]. With a raster file in and an
        output file, the windows were streamed to the file and the result holds no raster:
        its ``raster`` reads the file on first access.

    Raises
    ------
    CRSError
        The raster has no CRS, or ``target_crs`` is not a projected CRS.
    InputError
        Bad resolution (or one given for a geographic output), a spectrum without power in the
        band, infinite radiance, no radiance at all, an output grid that gets no value, or an
        input that is recognisably not radiance (a raster of this toolkit, a photometric unit:
        :func:`~nightlights.ground.viirs_input.check_radiance_source`).
    ResourceError
        A window, or the output grid held in memory when no output file is written, would
        need more memory than allowed (checked before reading).
    OutputError
        ``output`` cannot be written (checked before reading).

    Notes
    -----
    :math:`M_v = \\pi L 10^{-5} K` (:func:`viirs_radiance_to_flux_density`). Negative
    radiances (noise after background subtraction) are set to 0 with a
    :class:`~nightlights.errors.DataQualityWarning`. Pixels holding a common fill value the
    file does not declare (65535, -999, 1e20, ...) are nodata, and radiances above
    :data:`~nightlights.ground.viirs_input.MAX_PLAUSIBLE_RADIANCE` are kept; both with a
    :class:`~nightlights.errors.DataQualityWarning`
    (:func:`~nightlights.ground.viirs_input.clean_radiance`), one per kind for the whole
    raster, as is a raster wider than one UTM zone projected into one CRS
    (:func:`~nightlights.ground.viirs_input.warn_zone_span`). Resampling uses the area
    average, so a coarser output conserves flux.

    The raster is computed in windows of the output grid
    (:mod:`nightlights.ground._viirs_windows`), each reading only the source pixels it needs
    and written to ``output`` as it is done (:class:`~nightlights.io.CogWriter`): memory is
    bounded by a window, whatever the raster's size. A geographic raster wider than one UTM
    zone keeps its grid by default: its cells hold flux density [lm m-2] as a projected
    grid's do (dataset tags ``grid`` = ``geographic``, ``flux`` = ``density``), and its flux
    is the density times each cell's geodesic area (:func:`geographic_cell_areas`), which
    the darkness stage uses in its own local projections.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> dnb = Raster(np.full((1, 4, 4), 20.0), Affine(450, 0, 500_000, 0, -450, 6_700_000),
    ...              "EPSG:32635", ("radiance",), ("nW cm-2 sr-1",))
    >>> result = emission_from_viirs(dnb, spectrum="LED_4000K", progress=False)
    >>> result.raster.descriptions, result.raster.shape
    (('upward',), (4, 4))
    >>> round(float(result.raster.data[0, 0, 0]), 4)  # [lm m-2]
    0.2543
    """
    import rasterio

    label = source_label(viirs, "VIIRS raster")
    function = EmissionFunction.parse(emission_function, source="emission_function")
    zenith_intensity = float(function.intensity(1.0))
    if zenith_intensity <= 0:
        raise InputError(
            f"emission_function {function.tag!r} sends no light straight up, so nadir radiance "
            "cannot give its flux; expected lambertian or garstang:F,G with G (1 - F) > 0"
        )
    if resolution is not None:
        resolution = check_resolution(resolution)
    target_crs = parse_crs(target_crs, option="target_crs")
    if output is not None:
        OutputSet(output, inputs={"viirs": viirs})  # checked before reading
    efficacy = dnb_luminous_efficacy(spectrum, band=band)
    factor = np.pi * NANOWATT_PER_CM2 * efficacy * ((1.0 / math.pi) / zenith_intensity)
    tags = {
        PRODUCT_TAG: "emission",
        "nightlights_stage": "emission_from_viirs",
        "source": label,
        "spectrum": spectrum,
        "dnb_band_nm": f"{band[0]}-{band[1]}",
        "dnb_luminous_efficacy_lm_per_W": efficacy,
        "factor_lm_m2_per_nW_cm2_sr": factor,
        EMISSION_FUNCTION_TAG: function.tag,
        FLUX_TAG: "density",
    }
    band_tags = {
        "quantity": "upward luminous flux density",
        "model": f"VIIRS DNB, {function.tag}",
        EMISSION_FUNCTION_TAG: function.tag,
    }
    run = ViirsRun(
        label,
        lambda radiance: viirs_radiance_to_flux_density(
            radiance, efficacy, zenith_intensity=zenith_intensity
        ),
        resolution,
        target_crs,
        progress,
    )
    if not isinstance(viirs, (str, os.PathLike)):
        raster = as_raster(viirs)
        source = ArraySource(raster.data[0], raster.transform, source_crs(raster.crs, label))
        computed, total = run.in_memory(source, raster, tags, band_tags)
        outputs = None if output is None else OutputSet(output)
        return EmissionResult.of(computed, _write(computed, output, outputs), {"upward": total})
    path = Path(viirs)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    try:
        with rasterio.Env(GDAL_CACHEMAX=CACHE_MB), rasterio.open(path) as dataset:
            crs = None if dataset.crs is None else CRS.from_user_input(dataset.crs.to_wkt())
            source_file = FileSource(dataset, dataset.transform, source_crs(crs, label))
            if output is None:
                computed, total = run.in_memory(source_file, source_file, tags, band_tags)
                return EmissionResult.of(computed, None, {"upward": total})
            grid, total = run.streamed(source_file, Path(output), tags, band_tags)
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{path}: cannot read raster: {exc}") from exc
    return EmissionResult(
        Path(output), {"upward": total}, grid.transform, (grid.rows, grid.cols), grid.crs
    )


def _write(
    raster: Raster, output: str | os.PathLike[str] | None, outputs: OutputSet | None
) -> Path | None:
    """Write ``raster`` to ``output`` through its checked :class:`~nightlights.io.OutputSet`."""
    if output is None or outputs is None:
        return None
    with outputs:
        raster.write(outputs.temporary(output))
    return Path(output)
