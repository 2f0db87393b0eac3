"""Stage ``skyglow``: emission raster + observer -> panorama NetCDF (+ PNG)."""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Transformer

from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.io import atomic_output, read_raster
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.brightness import bortle_class, luminance_to_magnitude
from nightlights.sky.colour import (
    TRISTIMULUS_WAVELENGTHS,
    render_colour_panorama,
    tristimulus_flux_ratios,
)
from nightlights.sky.horizon import ground_height, horizon_elevation
from nightlights.sky.panorama import (
    MODES,
    KernelSlice,
    kernel_levels,
    panorama_exact,
    panorama_naive,
    panorama_pca,
)
from nightlights.sky.polar import PolarMap, polar_map_levels
from nightlights.sky.precompute import get_or_build_kernel, read_kernel
from nightlights.sky.render import render_panorama

#: Largest source distance a scene-sized kernel covers [m] (spherical Earth; beyond it
#: sources sit well below the observer's horizon and contribute little).
MAX_KERNEL_RANGE = 300_000.0

FloatArray = NDArray[np.float64]

#: Largest spacing of the source-altitude levels of a scene kernel over terrain [m] (Dobashi
#: et al. 2023 use 62.5 m); at most :data:`MAX_SOURCE_LEVELS` levels span the lit cells.
SOURCE_LEVEL_SPACING = 50.0
MAX_SOURCE_LEVELS = 16


def source_levels(
    heights: ArrayLike,
    *,
    spacing: float = SOURCE_LEVEL_SPACING,
    max_levels: int = MAX_SOURCE_LEVELS,
) -> FloatArray:
    """Source-altitude levels of a scene kernel spanning the altitudes of the lit cells.

    Parameters
    ----------
    heights
        Altitudes of the lit cells (NaN ignored) [m].
    spacing
        Largest spacing between levels [m].
    max_levels
        Most levels (the spacing grows beyond it) [-].

    Returns
    -------
    numpy.ndarray
        Increasing levels from the lowest to the highest lit cell; one level when they all
        stand within 1 m [m].
    """
    h = np.asarray(heights, dtype=float)
    h = h[np.isfinite(h)]
    if h.size == 0:
        return np.zeros(1)
    low, high = float(h.min()), float(h.max())
    if high - low < 1.0:
        return np.array([0.5 * (low + high)])
    count = int(np.clip(np.ceil((high - low) / spacing) + 1, 2, max_levels))
    return np.linspace(low, high, count)


@dataclass(frozen=True)
class SkyglowResult:
    """What ``skyglow`` computed.

    Attributes
    ----------
    panorama
        Dataset with ``luminance`` [cd m-2] and ``sky_brightness`` [mag arcsec-2].
    zenith_luminance
        Mean luminance of the top row [cd m-2].
    zenith_magnitude
        Its sky brightness [mag arcsec-2].
    bortle
        Bortle class of the zenith (non-physical convenience).
    seconds
        Time of the panorama computation after the polar map [s].
    """

    panorama: xr.Dataset
    zenith_luminance: float
    zenith_magnitude: float
    bortle: int
    seconds: float


def scene_kernel_parameters(
    meta: dict[str, Any],
    shape: tuple[int, int],
    observer: tuple[float, float],
    *,
    observer_altitude: float,
    turbidity: float,
    n_el: int,
    n_az: int,
    n_r: int,
    uplight: bool,
    source_altitudes: ArrayLike = (0.0,),
) -> dict[str, Any]:
    """Kernel grid sized to the scene: distances from 10 m to the farthest raster corner, the
    observer's altitude and the source-altitude levels of the lit cells."""
    transform = meta["transform"]
    rows, cols = shape
    corners = [
        (transform.c + transform.a * c, transform.f + transform.e * r)
        for c in (0, cols)
        for r in (0, rows)
    ]
    far = max(np.hypot(x - observer[0], y - observer[1]) for x, y in corners)
    r_max = float(min(MAX_KERNEL_RANGE, max(far * 1.01, 100.0)))
    return {
        "r_min": 10.0,
        "r_max": r_max,
        "n_r": n_r,
        "n_el": n_el,
        "n_az": n_az,
        "observer_altitudes": (float(observer_altitude),),
        "source_altitudes": tuple(float(h) for h in np.ravel(source_altitudes)),
        "atmosphere": Atmosphere(turbidity=turbidity),
        "uplight": uplight,
    }


def skyglow(
    emission_path: str | os.PathLike[str],
    out_nc: str | os.PathLike[str],
    *,
    observer: tuple[float, float],
    observer_crs: str | None = None,
    observer_height: float = 1.7,
    turbidity: float | None = None,
    kernel: str | os.PathLike[str] | xr.Dataset | None = None,
    mode: str = "pca",
    components: int | None = None,
    png: str | os.PathLike[str] | None = None,
    projection: str = "equirectangular",
    polar_out: str | os.PathLike[str] | None = None,
    dem: str | os.PathLike[str] | None = None,
    bands: str = "V",
    spectrum: str = "LED_4000K",
    n_el: int = 64,
    n_az: int = 256,
    n_r: int = 64,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SkyglowResult:
    """Compute what an observer sees: the skyglow panorama of an emission raster.

    Parameters
    ----------
    emission_path
        Upward flux density raster [lm m-2] in a projected CRS; one band = Lambertian, two
        bands = Lambertian + direct uplight (the ``emission`` stage's output).
    out_nc
        Output NetCDF, written atomically.
    observer
        Observer position (x, y) in ``observer_crs`` [m or deg].
    observer_crs
        CRS of ``observer`` (default: the raster's).
    observer_height
        Observer altitude above the (flat) ground [m].
    turbidity
        Atmospheric turbidity (Preetham 1999) [-]; default 2, or the given kernel's.
    kernel
        Precomputed kernel (path or dataset); default: built for the scene or reused from
        the cache.
    mode
        ``pca`` (fast), ``exact`` (no PCA) or ``naive`` (direct integration, slow reference).
    components
        PCA bases used in ``pca`` mode (default: all the kernel stores) [-].
    png
        Optional false-colour picture.
    projection
        ``equirectangular`` or ``fisheye`` for the picture.
    polar_out
        Optional NetCDF of the observer's polar flux map.
    dem
        Terrain heights above sea level [m] in the emission's CRS: the observer stands
        ``observer_height`` above it, every lit cell emits from its own terrain height
        (the kernel is tabulated at :func:`source_levels` and interpolated linearly per cell,
        :func:`~nightlights.sky.polar.polar_map_levels`), and the panorama is masked below
        the terrain horizon (``terrain_mask``).
    bands
        ``V`` (luminance only) or ``RGB``: CIE X, Y, Z panoramas with wavelength-dependent
        scattering and the emission colour of ``spectrum`` (needs scene kernels, so no
        ``kernel``); the PNG is then a colour picture (equirectangular).
    spectrum
        Luminaire spectrum for ``RGB`` (a name in :data:`ies.spectra.SPDS`).
    n_el, n_az, n_r
        Panorama rows and columns and distance bins of a scene kernel [-].
    cache_dir
        Kernel cache folder.
    progress
        Progress bar while building a kernel.
    """
    if mode not in MODES:
        raise InputError(f"mode {mode!r}; expected one of {', '.join(MODES)}")
    data, meta = read_raster(emission_path)
    if meta["crs"] is None or not meta["crs"].is_projected:
        raise CRSError(f"{emission_path}: the emission raster needs a projected CRS in metres")
    if data.shape[0] > 2:
        raise InputError(
            f"{emission_path}: {data.shape[0]} bands; expected 1 (Lambertian) or 2 "
            "(Lambertian + uplight)"
        )
    if np.nanmin(data) < 0:
        raise InputError(f"{emission_path}: negative flux density {np.nanmin(data):g} lm m-2")
    xy = _observer_xy(observer, observer_crs, meta["crs"])
    if observer_height < 0:
        raise InputError(f"observer height {observer_height} m; expected >= 0")
    terrain = _terrain(dem, meta, data, xy, observer_height) if dem is not None else None
    # Altitudes above sea level: without terrain the ground is at 0 m.
    observer_altitude = terrain.eye_altitude if terrain is not None else observer_height
    heights = terrain.heights if terrain is not None else np.zeros(data.shape[1:])
    if bands not in ("V", "RGB"):
        raise InputError(f"bands {bands!r}; expected V or RGB")
    if bands == "RGB" and (kernel is not None or mode == "naive"):
        raise InputError(
            "--bands RGB builds one scene kernel per tristimulus band: give no --kernel and "
            "use mode pca or exact"
        )
    if isinstance(kernel, xr.Dataset):
        table = kernel
    elif kernel is not None:
        table = read_kernel(kernel)
    else:
        params = scene_kernel_parameters(
            meta,
            data.shape[1:],
            xy,
            observer_altitude=observer_altitude,
            source_altitudes=source_levels(heights[np.any(np.nan_to_num(data) != 0, axis=0)]),
            turbidity=2.0 if turbidity is None else turbidity,
            n_el=n_el,
            n_az=n_az,
            n_r=n_r,
            uplight=data.shape[0] == 2,
        )
        table = get_or_build_kernel(cache_dir=cache_dir, progress=progress, **params)
    kernel_turbidity = float(table.attrs.get("turbidity", np.nan))
    if turbidity is not None and kernel is not None and not np.isclose(turbidity, kernel_turbidity):
        raise InputError(
            f"turbidity {turbidity} differs from the kernel's ({kernel_turbidity}); "
            "omit --turbidity or build a kernel for it"
        )
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    offset = _level_offset(heights, data, levels)
    heights = heights - offset
    observer_altitude -= offset
    slices = kernel_levels(table, observer_altitude=observer_altitude)
    tables = slices[0]
    polars = polar_map_levels(
        data,
        meta["transform"],
        xy,
        source_altitude=heights,
        levels=levels,
        distance_edges=tables.distance_edges,
        n_az=tables.n_az,
    )
    polar = _total(polars)
    band_tables: dict[str, list[KernelSlice]] = {}
    if bands == "RGB":
        for band, wavelength in TRISTIMULUS_WAVELENGTHS.items():
            band_params = dict(params)
            band_params["atmosphere"] = Atmosphere(
                turbidity=2.0 if turbidity is None else turbidity, wavelength_nm=wavelength
            )
            band_tables[band] = kernel_levels(
                get_or_build_kernel(cache_dir=cache_dir, progress=progress, **band_params),
                observer_altitude=observer_altitude,
            )
    start = time.perf_counter()
    if mode == "pca":
        luminance = panorama_pca(polars, slices, components=components)
    elif mode == "exact":
        luminance = panorama_exact(polars, slices)
    else:
        luminance = panorama_naive(
            data,
            meta["transform"],
            xy,
            elevation=tables.elevation,
            n_az=tables.n_az,
            observer_altitude=observer_altitude,
            source_altitude=np.nan_to_num(heights),
            atmosphere=Atmosphere(turbidity=kernel_turbidity),
        )
    xyz = None
    if bands == "RGB":
        ratios = tristimulus_flux_ratios(spectrum)
        channels = []
        for band, table_c in band_tables.items():
            scaled = [
                PolarMap(
                    p.flux * ratios[band],
                    p.distance_edges,
                    p.n_az,
                    p.dropped_flux * ratios[band],
                    p.total_flux * ratios[band],
                )
                for p in polars
            ]
            if mode == "pca":
                channels.append(panorama_pca(scaled, table_c, components=components))
            else:
                channels.append(panorama_exact(scaled, table_c))
        xyz = np.maximum(np.stack(channels, axis=-1), 0.0)
        luminance = xyz[..., 1]
    seconds = time.perf_counter() - start
    luminance = np.maximum(luminance, 0.0)  # PCA truncation can ring slightly below zero
    azimuth = (np.arange(tables.n_az) + 0.5) * 360.0 / tables.n_az
    below_terrain = np.zeros(luminance.shape, dtype=bool)
    if terrain is not None:
        horizon = horizon_elevation(
            terrain.dem,
            terrain.transform,
            xy,
            eye_altitude=terrain.eye_altitude,
            n_az=tables.n_az,
        )
        below_terrain = tables.elevation[:, None] < horizon[None, :]
        luminance = np.where(below_terrain, np.nan, luminance)
    magnitude = luminance_to_magnitude(luminance)
    zenith = float(np.nanmean(luminance[0])) if np.isfinite(luminance[0]).any() else 0.0
    zenith_mag = float(luminance_to_magnitude(zenith))
    dataset = xr.Dataset(
        {
            "luminance": (
                ("elevation", "azimuth"),
                luminance,
                {"units": "cd m-2", "long_name": "artificial sky luminance"},
            ),
            "sky_brightness": (
                ("elevation", "azimuth"),
                magnitude,
                {"units": "mag arcsec-2", "long_name": "sky brightness, -2.5 log10(L / 1.08e5)"},
            ),
            "terrain_mask": (
                ("elevation", "azimuth"),
                below_terrain.astype(np.int8),
                {"long_name": "1 where the terrain (DEM) hides the sky"},
            ),
        },
        coords={
            "elevation": (
                "elevation",
                tables.elevation,
                {"units": "degree", "long_name": "elevation of pixel centre"},
            ),
            "azimuth": (
                "azimuth",
                azimuth,
                {"units": "degree", "long_name": "azimuth clockwise from north"},
            ),
        },
        attrs={
            "observer_x": xy[0],
            "observer_y": xy[1],
            "crs": meta["crs"].to_wkt(),
            "observer_height_m": observer_height,
            "source_altitude_m": terrain.source_altitude if terrain is not None else 0.0,
            "source_altitude_levels_m": levels,
            "observer_altitude_m": observer_altitude + offset,
            "kernel_altitude_offset_m": offset,
            "turbidity": kernel_turbidity,
            "kernel_hash": str(table.attrs.get("content_hash", "")),
            "mode": mode,
            "emission": str(emission_path),
            "emitted_flux_lm": float(polar.total_flux.sum()),
            "flux_beyond_kernel_lm": float(polar.dropped_flux.sum()),
            "zenith_luminance_cd_m2": zenith,
            "zenith_sky_brightness": zenith_mag,
            "bortle_class_zenith": int(bortle_class(zenith_mag)),
            "note": "artificial skyglow only (no natural sky background), single scattering",
        },
    )
    if xyz is not None:
        if terrain is not None:
            xyz = np.where(below_terrain[..., None], np.nan, xyz)
        for index, band in enumerate(TRISTIMULUS_WAVELENGTHS):
            dataset[band] = (
                ("elevation", "azimuth"),
                xyz[..., index],
                {
                    "units": "cd m-2",
                    "long_name": f"CIE 1931 {band} tristimulus luminance",
                    "scattering_wavelength_nm": TRISTIMULUS_WAVELENGTHS[band],
                },
            )
        dataset.attrs["spectrum"] = spectrum
    dataset.attrs["bands"] = bands
    with atomic_output(out_nc) as tmp:
        dataset.to_netcdf(tmp, engine="h5netcdf")
    if polar_out is not None:
        write_polar(polar, polar_out)
    if png is not None and xyz is not None:
        render_colour_panorama(
            xyz,
            tables.elevation,
            png,
            title=f"artificial skyglow ({spectrum}), zenith {zenith_mag:.2f} mag arcsec-2",
        )
    elif png is not None:
        render_panorama(
            magnitude,
            tables.elevation,
            azimuth,
            png,
            projection=projection,
            title=f"artificial skyglow, zenith {zenith_mag:.2f} mag arcsec-2",
        )
    return SkyglowResult(dataset, zenith, zenith_mag, int(bortle_class(zenith_mag)), seconds)


@dataclass(frozen=True)
class _Terrain:
    dem: np.ndarray
    transform: Any
    eye_altitude: float
    source_altitude: float  # flux-weighted mean
    heights: np.ndarray  # terrain height of every emission cell (NaN where unlit)


def _total(polars: list[PolarMap]) -> PolarMap:
    """The polar map of all source levels together."""
    return PolarMap(
        np.sum([p.flux for p in polars], axis=0),
        polars[0].distance_edges,
        polars[0].n_az,
        np.sum([p.dropped_flux for p in polars], axis=0),
        np.sum([p.total_flux for p in polars], axis=0),
    )


def _level_offset(heights: np.ndarray, data: np.ndarray, levels: np.ndarray) -> float:
    """Common shift of all altitudes that brings the lit cells within a kernel's source levels.

    A scene kernel always covers them (0 is returned). A given kernel may not (e.g. one built
    with sources at 0 m used over terrain): then observer and sources are shifted together so
    that the observer keeps its height above the sources (the air density is then that of the
    kernel's levels), with a warning.
    """
    lit = np.any(np.nan_to_num(data) != 0, axis=0)
    if not lit.any():
        return 0.0
    low, high = float(np.nanmin(heights[lit])), float(np.nanmax(heights[lit]))
    bottom, top = float(levels.min()), float(levels.max())
    if low >= bottom - 5.0 and high <= top + 5.0:
        return 0.0
    if high - low <= top - bottom:
        offset = low - bottom if low < bottom else high - top
    else:
        offset = 0.5 * (low + high) - 0.5 * (bottom + top)
    warnings.warn(
        f"lit cells stand at {low:g}-{high:g} m but the kernel's source levels span "
        f"{bottom:g}-{top:g} m; observer and sources are shifted by {-offset:+g} m together "
        "(relative heights kept; cells still outside take the nearest level)",
        DataQualityWarning,
        stacklevel=3,
    )
    return offset


def _terrain(
    dem_path: str | os.PathLike[str],
    meta: dict[str, Any],
    emission: np.ndarray,
    xy: tuple[float, float],
    observer_height: float,
) -> _Terrain:
    """Read the DEM; eye altitude, terrain height under every lit cell and their mean [m]."""
    heights, dem_meta = read_raster(dem_path)
    if dem_meta["crs"] is None or not dem_meta["crs"].equals(meta["crs"]):
        raise CRSError(f"{dem_path}: the DEM must be in the emission raster's CRS")
    dem = heights[0]
    ground = ground_height(dem, dem_meta["transform"], *xy)
    # Terrain height under each lit emission cell, weighted by its flux.
    flux = np.nansum(np.nan_to_num(emission, nan=0.0), axis=0)
    rows, cols = np.nonzero(flux)
    source_altitude = 0.0
    cell_heights = np.full(flux.shape, np.nan)
    if rows.size:
        t = meta["transform"]
        cx = t.c + t.a * (cols + 0.5)
        cy = t.f + t.e * (rows + 0.5)
        inv = ~dem_meta["transform"]
        dcol = inv.a * cx + inv.b * cy + inv.c
        drow = inv.d * cx + inv.e * cy + inv.f
        from scipy.ndimage import map_coordinates

        z = map_coordinates(
            np.nan_to_num(dem, nan=ground), [drow - 0.5, dcol - 0.5], order=1, mode="nearest"
        )
        source_altitude = float(np.average(z, weights=flux[rows, cols]))
        cell_heights[rows, cols] = z
    return _Terrain(
        dem, dem_meta["transform"], ground + observer_height, source_altitude, cell_heights
    )


def write_polar(polar: PolarMap, path: str | os.PathLike[str]) -> Path:
    """Write a polar flux map as NetCDF (``flux`` [lm], dims band x distance x azimuth)."""
    edges = polar.distance_edges
    dataset = xr.Dataset(
        {
            "flux": (("band", "distance", "azimuth"), polar.flux, {"units": "lm"}),
            "distance_edges": (("distance_edge",), edges, {"units": "m"}),
        },
        coords={
            "band": np.arange(polar.flux.shape[0]),
            "distance": ("distance", np.sqrt(edges[:-1] * edges[1:]), {"units": "m"}),
            "azimuth": ("azimuth", polar.azimuths, {"units": "degree"}),
        },
        attrs={"dropped_flux_lm": float(polar.dropped_flux.sum())},
    )
    with atomic_output(path) as tmp:
        dataset.to_netcdf(tmp, engine="h5netcdf")
    return Path(path)


def _observer_xy(
    observer: tuple[float, float], observer_crs: str | None, raster_crs: CRS
) -> tuple[float, float]:
    x, y = (float(v) for v in observer)
    if not (np.isfinite(x) and np.isfinite(y)):
        raise InputError(f"observer {observer!r}; expected two finite numbers")
    if observer_crs is None:
        return x, y
    try:
        source = CRS.from_user_input(observer_crs)
    except Exception as exc:  # pyproj raises its own CRSError
        raise CRSError(f"observer CRS {observer_crs!r} is not a CRS: {exc}") from exc
    transformer = Transformer.from_crs(source, raster_crs, always_xy=True)
    tx, ty = transformer.transform(x, y)
    return float(tx), float(ty)
