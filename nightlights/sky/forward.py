"""The skyglow panorama of a scene: an emission raster, an observer, a kernel and a terrain.

:func:`skyglow_panorama` is the in-memory form of the ``skyglow`` stage: a raster of upward flux
density in, a :class:`SkyglowScene` out (an :class:`xarray.Dataset` of sky luminance and
brightness, and the polar flux map it came from), no output files.
It resamples the emission into the observer's polar grid (:mod:`nightlights.sky.polar`) and
convolves it in azimuth with the kernel (:mod:`nightlights.sky.panorama`).

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 3.3.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from nightlights._typing import FloatArray
from nightlights.brightness import NON_FINITE_SKY, bortle_class, luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.sky._flat import flat_keywords
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer
from nightlights.sky.cloudy import cloud_cover_at, cloudy_panorama
from nightlights.sky.colour import TRISTIMULUS_WAVELENGTHS, tristimulus_flux_ratios
from nightlights.sky.instrument_units import DEFAULT_SPECTRUM, emission_spectrum, instrument_sky
from nightlights.sky.instruments import Instrument
from nightlights.sky.kernel import UPLIGHT_EXPONENT
from nightlights.sky.multiple import scattering_note
from nightlights.sky.observer import Observer
from nightlights.sky.panorama import (
    MODES,
    KernelSlice,
    band_slice,
    kernel_levels,
    panorama_exact,
    panorama_naive,
    panorama_pca,
)
from nightlights.sky.polar import PolarMap, level_maps
from nightlights.sky.scene import Scene
from nightlights.sky.setup import SceneSetup, prepare_scene
from nightlights.sky.store import get_or_build_kernel

__all__ = ["SkyglowScene", "panorama_zenith", "skyglow_panorama"]


@dataclass(frozen=True)
class SkyglowScene:
    """What :func:`skyglow_panorama` computed: the panorama and the polar map it came from.

    Attributes
    ----------
    panorama
        Sky luminance and brightness over (elevation, azimuth).
    polar
        The observer's polar flux map, all source levels together [lm].
    seconds
        Time of the panorama computation after the polar map [s].
    """

    panorama: xr.Dataset
    polar: PolarMap
    seconds: float


@flat_keywords(legacy=("observer", "kernel", "dem"), observer="one")
def skyglow_panorama(
    scene: Scene,
    observer: Observer,
    *,
    mode: str = "pca",
    components: int | None = None,
    bands: str = "V",
    spectrum: str | None = None,
    instrument: str | Instrument | None = None,
    natural_luminance: float | None = None,
    progress: bool = True,
) -> SkyglowScene:
    """What an observer sees: the skyglow panorama of an emission raster, in memory.

    Parameters
    ----------
    scene
        The emission, terrain, atmosphere and kernel (:class:`~nightlights.sky.scene.Scene`).
        Each emission band has the emission function of its ``emission_function`` tag
        (lambertian, uplight, garstang:F,G); without tags one band is read as
        garstang:0.15,0.15 and two bands as Lambertian + direct uplight (the ``emission``
        stage's output, which tags them), see
        :func:`~nightlights.sky.setup.band_emission_functions`. Over a DEM the observer stands
        on the terrain, every lit cell emits from its own terrain height (the kernel is
        tabulated at :func:`~nightlights.sky.spec.source_levels` and interpolated linearly per
        cell), and the panorama is masked below the terrain horizon (``terrain_mask``).
    observer
        Who looks (:class:`~nightlights.sky.observer.Observer`): position and eye height.
    mode
        ``pca`` (fast), ``exact`` (no PCA) or ``naive`` (direct integration with the kernel's
        atmosphere, slow reference).
    components
        PCA bases used in ``pca`` mode (default: all the kernel stores) [1].
    bands
        ``V`` (luminance only) or ``RGB``: CIE X, Y, Z panoramas with wavelength-dependent
        scattering and the emission colour of ``spectrum`` (needs scene kernels, so a scene
        without ``kernel``).
    spectrum
        Luminaire spectrum for ``RGB`` and for the colour term of ``instrument`` (a name in
        :data:`ies.spectra.SPDS`); None: the emission raster's ``spectrum`` tag, else
        :data:`~nightlights.sky.instrument_units.DEFAULT_SPECTRUM` (LED_4000K).
    instrument
        Also report what this instrument reads pointing at the zenith (a key of
        :data:`~nightlights.sky.instruments.INSTRUMENTS` or an
        :class:`~nightlights.sky.instruments.Instrument`): the panorama read with its
        angular weights, in its band, and with the natural sky
        (:mod:`nightlights.sky.instrument_units`); None: no instrument figures.
    natural_luminance
        With an instrument: the natural sky's reading, V-equivalent with its colour term
        [cd m-2]; None: a uniform moonless sky of 22.0 mag arcsec-2 (V).
    progress
        Progress bar while building a kernel.

    Returns
    -------
    SkyglowScene
        ``panorama``: a Dataset of ``luminance`` [cd m-2], ``sky_brightness``
        [mag arcsec-2] and ``terrain_mask`` over (elevation, azimuth) [deg] (and ``X``, ``Y``,
        ``Z`` [cd m-2] for ``RGB``), with the observer, kernel and zenith figures and each
        band's emission function (``emission_functions``, ``emission_function_sources``) in
        the attributes (with an instrument also ``instrument``, ``instrument_spectrum``,
        ``instrument_luminance_cd_m2``, ``instrument_natural_cd_m2`` and
        ``instrument_sky_brightness`` [mag arcsec-2]: :meth:`InstrumentSky.summary
        <nightlights.sky.instrument_units.InstrumentSky.summary>`); ``polar``: the observer's
        polar flux map [lm]; ``seconds``: the time of the panorama after the polar map [s].

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    >>> scene = Scene(raster, kernel=build_kernel(spec, progress=False))
    >>> result = skyglow_panorama(scene, Observer(1000.0, 1000.0, height=0.0))
    >>> pano = result.panorama
    >>> pano["luminance"].shape, bool(pano.attrs["zenith_luminance_cd_m2"] > 0)
    ((8, 16), True)
    """
    if mode not in MODES:
        raise InputError(f"mode {mode!r}; expected one of {', '.join(MODES)}")
    if bands not in ("V", "RGB"):
        raise InputError(f"bands {bands!r}; expected V or RGB")
    if bands == "RGB" and (scene.kernel is not None or mode == "naive"):
        raise InputError(
            "bands='RGB' builds one scene kernel per tristimulus band: give a scene without "
            "kernel= and use mode='pca' or 'exact'"
        )
    reader = instrument_sky(
        instrument,
        spectrum=spectrum,
        natural_luminance=natural_luminance,
        emission=scene.emission,
        label=scene.label,
    )
    if spectrum is None:
        spectrum = reader.spectrum if reader is not None else _colour_spectrum(bands, scene)
    setup = prepare_scene(scene, observer, progress=progress, clouds=True)
    xy, table, levels = setup.xy, setup.table, setup.levels
    label, terrain, spec = setup.label, setup.terrain, setup.spec
    observer_altitude, offset, slices = setup.observer_altitude, setup.offset, setup.slices
    kernel_turbidity = float(table.attrs.get("turbidity", np.nan))
    tables = slices[0]
    cells = setup.polar_cells()
    polars = level_maps(cells, setup.level_weights(cells))
    polar = _total(polars)
    band_tables: dict[str, list[KernelSlice]] = {}
    if bands == "RGB" and spec is not None:
        for band, wavelength in TRISTIMULUS_WAVELENGTHS.items():
            band_spec = dataclasses.replace(
                spec, atmosphere=dataclasses.replace(spec.atmosphere, wavelength_nm=wavelength)
            )
            band_tables[band] = [
                band_slice(level, setup.functions)
                for level in kernel_levels(
                    get_or_build_kernel(
                        band_spec, cache_dir=scene.cache_dir, progress=progress
                    ).kernel,
                    observer_altitude=observer_altitude,
                )
            ]
    start = time.perf_counter()
    if mode == "pca":
        luminance = panorama_pca(polars, slices, components=components)
    elif mode == "exact":
        luminance = panorama_exact(polars, slices)
    else:
        window, window_transform = setup.emission.dense()
        window_heights = _dense_heights(setup)
        luminance = panorama_naive(
            window,
            window_transform,
            xy,
            elevation=tables.elevation,
            n_az=tables.n_az,
            observer_altitude=observer_altitude,
            source_altitude=window_heights,
            atmosphere=_kernel_atmosphere(table),
            uplight_exponent=float(table.attrs.get("uplight_exponent", UPLIGHT_EXPONENT)),
            functions=setup.functions,
            multiple_scattering=str(table.attrs.get("multiple_scattering", "single")),
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
    cloud_attrs: dict[str, float] = {}
    if scene.clouds is not None:
        clear = luminance
        luminance, cloud_attrs = _with_clouds(scene.clouds, luminance, polar, tables, setup)
        if xyz is not None:  # the deck is grey: the colour follows the luminance
            with np.errstate(divide="ignore", invalid="ignore"):
                gain = np.where(clear > 0, luminance / clear, 1.0)
            xyz = xyz * gain[..., None]
    below_terrain = setup.below_terrain()
    if terrain is not None:
        luminance = np.where(below_terrain, np.nan, luminance)
        if xyz is not None:
            xyz = np.where(below_terrain[..., None], np.nan, xyz)
    dataset = _panorama_dataset(luminance, below_terrain, tables.elevation, xyz)
    dataset.attrs = {
        "observer_x": xy[0],
        "observer_y": xy[1],
        "crs": setup.crs.to_wkt(),
        "observer_height_m": observer.height,
        "source_altitude_m": terrain.source_altitude if terrain is not None else 0.0,
        "source_altitude_levels_m": levels,
        "observer_altitude_m": observer_altitude + offset,
        "kernel_altitude_offset_m": offset,
        "turbidity": kernel_turbidity,
        "kernel_hash": str(table.attrs.get("content_hash", "")),
        "mode": mode,
        "emission": label,
        "emission_functions": "; ".join(f.tag for f in setup.functions),
        "emission_function_sources": "; ".join(setup.function_notes),
        "emitted_flux_lm": float(polar.total_flux.sum()),
        "flux_beyond_kernel_lm": float(polar.dropped_flux.sum()),
        **dataset.attrs,
        "note": "artificial skyglow only (no natural sky background), "
        + scattering_note(table.attrs),
    }
    if xyz is not None:
        dataset.attrs["spectrum"] = spectrum
    dataset.attrs["bands"] = bands
    dataset.attrs.update(cloud_attrs)
    if reader is not None:
        weights = reader.panorama_weights(tables.elevation, dataset["azimuth"].values)
        dataset.attrs.update(reader.summary(reader.read(luminance, weights)))
    return SkyglowScene(dataset, polar, seconds)


def _with_clouds(
    cloud: CloudLayer,
    luminance: FloatArray,
    polar: PolarMap,
    tables: KernelSlice,
    setup: SceneSetup,
) -> tuple[FloatArray, dict[str, float]]:
    """The panorama under the scene's cloud deck (:mod:`nightlights.sky.cloudy`)."""
    ground = setup.observer_altitude + setup.offset - setup.observer_height
    top = float(np.max(setup.heights)) + setup.offset if setup.terrain is not None else None
    return cloudy_panorama(
        luminance,
        polar.flux,
        polar.distance_edges,
        tables.elevation,
        setup.functions,
        cloud,
        _kernel_atmosphere(setup.table),
        cover=cloud_cover_at(cloud, setup.xy, setup.crs),
        ground_altitude=max(ground, 0.0),
        terrain_top=top,
    )


def _colour_spectrum(bands: str, scene: Scene) -> str:
    """The spectrum of an ``RGB`` panorama without ``spectrum=``: the emission raster's tag,
    else :data:`~nightlights.sky.instrument_units.DEFAULT_SPECTRUM` (a ``V`` panorama needs
    none, and its emission is not opened for it)."""
    if bands != "RGB":
        return DEFAULT_SPECTRUM
    return emission_spectrum(scene.emission) or DEFAULT_SPECTRUM


def _panorama_dataset(
    luminance: FloatArray,
    below_terrain: np.ndarray,
    elevation: FloatArray,
    xyz: FloatArray | None,
) -> xr.Dataset:
    """Panorama variables and coordinates, with the zenith figures in the attributes."""
    n_az = luminance.shape[1]
    azimuth = (np.arange(n_az) + 0.5) * 360.0 / n_az
    magnitude = luminance_to_magnitude(luminance)
    zenith = panorama_zenith(luminance, below_terrain)
    if not np.isfinite(zenith):
        bad = int(np.sum(~np.isfinite(luminance[~below_terrain.astype(bool)])))
        raise InputError(
            f"the skyglow panorama has {bad} open-sky pixels whose luminance is not finite: "
            f"{NON_FINITE_SKY}"
        )
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
        coords=panorama_coords(elevation, azimuth),
        attrs={
            "zenith_luminance_cd_m2": zenith,
            "zenith_sky_brightness": zenith_mag,
            "bortle_class_zenith": int(bortle_class(zenith_mag)),
        },
    )
    if xyz is not None:
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
    return dataset


def panorama_zenith(luminance: FloatArray, below_terrain: np.ndarray | None = None) -> float:
    """Zenith luminance of a panorama: the mean of its top row where the sky is open [cd m-2].

    Parameters
    ----------
    luminance
        Shape ``(n_el, n_az)``, zenith row first: sky luminance [cd m-2], NaN where the
        terrain hides the sky.
    below_terrain
        Same shape, True where the terrain hides the sky (None: all open).

    Returns
    -------
    float
        The mean of the open pixels of the top row; 0 where the terrain hides all of it; NaN
        when any open-sky pixel is not finite (an overflowing emission): such a sky has no
        zenith brightness and no Bortle class, and is never reported as a dark one.

    Examples
    --------
    >>> panorama_zenith(np.array([[1.0, 3.0], [5.0, 5.0]]))
    2.0
    >>> panorama_zenith(np.array([[1.0, np.inf], [5.0, 5.0]]))
    nan
    """
    values = np.asarray(luminance, dtype=float)
    hidden = (
        np.zeros(values.shape, dtype=bool)
        if below_terrain is None
        else np.asarray(below_terrain, dtype=bool)
    )
    if not np.isfinite(values[~hidden]).all():
        return math.nan
    top = np.where(hidden[0], np.nan, values[0])
    return float(np.nanmean(top)) if np.isfinite(top).any() else 0.0


def panorama_coords(elevation: FloatArray, azimuth: FloatArray) -> dict[str, Any]:
    """The (elevation, azimuth) coordinates of a sky grid dataset, pixel centres [deg],
    azimuth clockwise from north: the convention every panorama file shares."""
    return {
        "elevation": (
            "elevation",
            elevation,
            {"units": "degree", "long_name": "elevation of pixel centre"},
        ),
        "azimuth": (
            "azimuth",
            azimuth,
            {"units": "degree", "long_name": "azimuth clockwise from north"},
        ),
    }


def _kernel_atmosphere(table: xr.Dataset) -> Atmosphere:
    """The atmosphere a kernel was built with, from its attributes."""
    if "turbidity" not in table.attrs:
        raise InputError(
            "the kernel has no atmosphere attributes; naive mode integrates with the kernel's "
            "atmosphere"
        )
    return Atmosphere.from_parameters(table.attrs)


def _dense_heights(setup: SceneSetup) -> FloatArray:
    """The lit cells' source altitudes on the window of :meth:`LitCells.dense` [m]."""
    cells = setup.emission
    if cells.n_cells == 0:
        return np.zeros((0, 0))
    row0, col0 = int(cells.rows.min()), int(cells.cols.min())
    shape = (int(cells.rows.max()) + 1 - row0, int(cells.cols.max()) + 1 - col0)
    out = np.zeros(shape)
    out[cells.rows - row0, cells.cols - col0] = setup.heights
    return out


def _total(polars: list[PolarMap]) -> PolarMap:
    """The polar map of all source levels together."""
    return PolarMap(
        np.sum([p.flux for p in polars], axis=0),
        polars[0].distance_edges,
        polars[0].n_az,
        np.sum([p.dropped_flux for p in polars], axis=0),
        np.sum([p.total_flux for p in polars], axis=0),
    )
