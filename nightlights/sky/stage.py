"""File stages of the sky: ``build_kernel`` (kernel NetCDF) and ``skyglow`` (panorama NetCDF
or GeoTIFF).

Each stage computes in memory (:func:`nightlights.sky.build.compute_kernel`,
:func:`nightlights.sky.forward.skyglow_panorama`), writes its product only when given an output
path, and returns a frozen result holding the product.

A panorama or polar map written to a ``.tif`` is a GeoTIFF that QGIS opens with its style:
the panorama on a grid of azimuth (x, clockwise from north) and elevation (y) in degrees, in
an engineering CRS of the observer's sky (:data:`SKY_CRS`, not tied to the Earth); the polar
map rasterised in the emission raster's CRS around the observer (:func:`polar_raster`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from affine import Affine
from pyproj import CRS

from nightlights._typing import PathLike
from nightlights.brightness import NATURAL_ZENITH_LUMINANCE, zenith_summary
from nightlights.errors import InputError
from nightlights.io import Raster, atomic_output
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import PRODUCT_TAG
from nightlights.sky._flat import flat_keywords
from nightlights.sky.build import compute_kernel
from nightlights.sky.colour import TRISTIMULUS_WAVELENGTHS, render_colour_panorama
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.instruments import Instrument
from nightlights.sky.observer import Observer
from nightlights.sky.polar import PolarMap
from nightlights.sky.render import render_panorama
from nightlights.sky.scene import Scene
from nightlights.sky.spec import KernelSpec
from nightlights.sky.store import KernelResult, write_kernel

__all__ = [
    "SkyglowResult",
    "build_kernel",
    "panorama_raster",
    "polar_raster",
    "skyglow",
    "write_polar",
]

#: Suffixes that make a panorama or polar map output a GeoTIFF (otherwise NetCDF).
GEOTIFF_SUFFIXES = (".tif", ".tiff")
#: The CRS of a panorama GeoTIFF: an engineering CRS of the observer's sky, x the azimuth
#: clockwise from north and y the elevation above the horizon, both in degrees (ISO 19111
#: engineering CRS; GeoTIFF stores it as a local CS with the degree as its unit).
SKY_CRS = (
    'ENGCRS["sky of an observer: azimuth (x), elevation (y)",EDATUM["observer"],'
    'CS[Cartesian,2],AXIS["azimuth (A)",east,ORDER[1],ANGLEUNIT["degree",0.0174532925199433]],'
    'AXIS["elevation (h)",north,ORDER[2],ANGLEUNIT["degree",0.0174532925199433]]]'
)
#: Cells across the radius of a polar map GeoTIFF [1]: the grid spans twice the outer
#: distance edge in 2 x 256 cells (a display resolution; each cell shows its polar bin).
POLAR_GRID_HALF_CELLS = 256


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
        Bortle class of the zenith (non-physical convenience) [1].
    seconds
        Time of the panorama computation after the polar map [s].
    path
        The panorama NetCDF written, or None when nothing was written.
    instrument
        The instrument whose reading is reported (``instrument=``), or None.
    instrument_luminance
        Its reading of the artificial sky: the V-equivalent luminance it stands for
        [cd m-2]; None without an instrument.
    instrument_magnitude
        Its sky brightness, artificial + natural sky, in its band [mag arcsec-2]; None
        without an instrument.
    """

    panorama: xr.Dataset
    zenith_luminance: float
    zenith_magnitude: float
    bortle: int
    seconds: float
    path: Path | None = None
    instrument: str | None = None
    instrument_luminance: float | None = None
    instrument_magnitude: float | None = None


def _check_output(output: PathLike | None) -> Path | None:
    """The output path, its folder checked to exist and be writable before any work."""
    if output is None:
        return None
    OutputSet(output)
    return Path(output)


def build_kernel(
    spec: KernelSpec | None = None,
    output: PathLike | None = None,
    *,
    backend: str = "auto",
    progress: bool = True,
) -> KernelResult:
    """Precompute a skyglow kernel (tables, PCA, FFT) and optionally write it as NetCDF.

    Parameters
    ----------
    spec
        What to tabulate (axes, atmosphere, emission, quadrature, compression); default
        ``KernelSpec()``.
    output
        NetCDF file to write atomically; None writes nothing.
    backend
        Line-of-sight integrator, one of :data:`nightlights.sky.kernel.BACKENDS`; not part of
        the content hash (the backends agree to ~1e-5) but recorded in the attributes.
    progress
        Show a progress bar.

    Returns
    -------
    KernelResult
        The kernel dataset [cd m-2 lm-1], its specification and the written path.

    References
    ----------
    Dobashi et al. 2023, Sec. 3.3-3.4 (precomputation, PCA, FFT).

    Examples
    --------
    >>> from nightlights.sky import KernelSpec, build_kernel
    >>> spec = KernelSpec(r_max=5000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    >>> result = build_kernel(spec, progress=False)
    >>> result.kernel["kernel"].dims
    ('observer_altitude', 'source_altitude', 'distance', 'elevation', 'azimuth')
    >>> result.kernel["kernel"].shape, result.path is None
    ((1, 1, 8, 8, 16), True)
    """
    spec = spec if spec is not None else KernelSpec()
    target = _check_output(output)
    ds = compute_kernel(spec, backend=backend, progress=progress)
    if target is not None:
        write_kernel(ds, target)
    return KernelResult(ds, spec, target)


@flat_keywords(legacy=("output",), observer="one")
def skyglow(
    scene: Scene,
    observer: Observer,
    output: PathLike | None = None,
    *,
    mode: str = "pca",
    components: int | None = None,
    png: PathLike | None = None,
    projection: str = "equirectangular",
    polar_output: PathLike | None = None,
    bands: str = "V",
    spectrum: str | None = None,
    instrument: str | Instrument | None = None,
    natural_luminance: float | None = None,
    progress: bool = True,
) -> SkyglowResult:
    """Compute what an observer sees: the skyglow panorama of an emission raster.

    Parameters
    ----------
    scene
        The emission, terrain, atmosphere and kernel (:class:`~nightlights.sky.scene.Scene`);
        see :func:`~nightlights.sky.forward.skyglow_panorama` for how each is used.
    observer
        Who looks (:class:`~nightlights.sky.observer.Observer`): position and eye height.
    output
        Panorama file: NetCDF, or a GeoTIFF when it ends in ``.tif`` (bands ``luminance``
        [cd m-2] and ``sky_brightness`` [mag arcsec-2] and, for ``RGB``, ``X``, ``Y``, ``Z``
        [cd m-2], on the azimuth/elevation grid of :func:`panorama_raster`, with its QGIS
        style beside it); None writes nothing. It, ``png`` and ``polar_output`` are all
        checked before the computation and appear together at the end, or none of them.
    mode
        ``pca`` (fast), ``exact`` (no PCA) or ``naive`` (direct integration, slow reference).
    components
        PCA bases used in ``pca`` mode (default: all the kernel stores) [1].
    png
        Optional false-colour picture, written when given.
    projection
        ``equirectangular`` or ``fisheye`` for the picture.
    polar_output
        Optional file of the observer's polar flux map: NetCDF, or a GeoTIFF in the
        emission's CRS when it ends in ``.tif`` (:func:`polar_raster`).
    bands
        ``V`` (luminance only) or ``RGB`` (CIE X, Y, Z; scene kernels only, so a scene
        without ``kernel``);
        the PNG is then a colour picture (equirectangular).
    spectrum
        Luminaire spectrum for ``RGB`` and for the colour term of ``instrument`` (a name in
        :data:`ies.spectra.SPDS`); None: the emission raster's ``spectrum`` tag, else
        LED_4000K (:data:`~nightlights.sky.instrument_units.DEFAULT_SPECTRUM`).
    instrument
        Also report what this instrument (``sqm``, ``sqm-l``, ``tess-w``, ``eye``, or an
        :class:`~nightlights.sky.instruments.Instrument`) reads pointing at the zenith: the
        panorama read with its angular weights, in its band, and with the natural sky.
    natural_luminance
        With an instrument: the natural sky's reading, V-equivalent with its colour term
        [cd m-2]; None: a uniform moonless sky of 22.0 mag arcsec-2 (V).
    progress
        Progress bar while building a kernel.

    Returns
    -------
    SkyglowResult
        The panorama, its zenith figures (and the instrument's) and the written path.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> scene = Scene(raster, kernel=kernel)
    >>> result = skyglow(scene, Observer(1000.0, 1000.0, height=0.0))
    >>> result.path is None, 1 <= result.bortle <= 9
    (True, True)
    """
    target = Path(output) if output is not None else None
    # Every location is checked now; the outputs appear together at the end or not at all.
    outputs = OutputSet(target, png, polar_output, inputs=scene.inputs)
    sky = skyglow_panorama(
        scene,
        observer,
        mode=mode,
        components=components,
        bands=bands,
        spectrum=spectrum,
        instrument=instrument,
        natural_luminance=natural_luminance,
        progress=progress,
    )
    dataset = sky.panorama
    zenith = float(dataset.attrs["zenith_luminance_cd_m2"])
    zenith_mag = float(dataset.attrs["zenith_sky_brightness"])
    dataset.attrs.update(
        _with_natural_sky(zenith, float(dataset.attrs.get("natural_sky_factor", 1.0)))
    )
    with outputs:
        if target is not None and _is_geotiff(target):
            panorama_raster(dataset).write(outputs.temporary(target))
        elif target is not None:
            dataset.to_netcdf(outputs.temporary(target), engine="h5netcdf")
        if polar_output is not None and _is_geotiff(polar_output):
            observer_xy = (float(dataset.attrs["observer_x"]), float(dataset.attrs["observer_y"]))
            polar_raster(sky.polar, observer_xy, dataset.attrs["crs"]).write(
                outputs.temporary(polar_output)
            )
        elif polar_output is not None:
            _polar_dataset(sky.polar).to_netcdf(outputs.temporary(polar_output), engine="h5netcdf")
        if png is not None:
            shown = str(dataset.attrs.get("spectrum", spectrum))
            _render(dataset, outputs.temporary(png), bands, shown, projection, zenith_mag)
    reading = dataset.attrs.get("instrument_luminance_cd_m2")
    return SkyglowResult(
        dataset,
        zenith,
        zenith_mag,
        int(dataset.attrs["bortle_class_zenith"]),
        sky.seconds,
        target,
        instrument=None if instrument is None else str(dataset.attrs["instrument"]),
        instrument_luminance=None if reading is None else float(reading),
        instrument_magnitude=(
            None if reading is None else float(dataset.attrs["instrument_sky_brightness"])
        ),
    )


def _is_geotiff(path: PathLike) -> bool:
    return Path(path).suffix.lower() in GEOTIFF_SUFFIXES


def panorama_raster(panorama: xr.Dataset) -> Raster:
    """A skyglow panorama as a raster on its azimuth/elevation grid (:data:`SKY_CRS`).

    Parameters
    ----------
    panorama
        A ``skyglow`` panorama: ``luminance`` [cd m-2] and ``sky_brightness``
        [mag arcsec-2] (and ``X``, ``Y``, ``Z`` [cd m-2] when present) over ``elevation``
        (equal rows from the zenith down) and ``azimuth`` (equal columns from north) [deg].

    Returns
    -------
    Raster
        x: azimuth 0-360 deg clockwise from north, y: elevation 0-90 deg; the panorama's
        attributes (observer, kernel, zenith figures) as tags; nodata (NaN) where the terrain
        hides the sky.

    Raises
    ------
    InputError
        The panorama's rows or columns are not equally spaced.

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> luminance = np.full((2, 4), 1e-3)
    >>> panorama = xr.Dataset(
    ...     {"luminance": (("elevation", "azimuth"), luminance),
    ...      "sky_brightness": (("elevation", "azimuth"), np.full((2, 4), 18.98))},
    ...     coords={"elevation": [67.5, 22.5], "azimuth": [45.0, 135.0, 225.0, 315.0]},
    ... )
    >>> raster = panorama_raster(panorama)
    >>> raster.bounds, raster.descriptions
    ((0.0, 0.0, 360.0, 90.0), ('luminance', 'sky_brightness'))
    """
    elevation = np.asarray(panorama["elevation"].values, dtype=float)
    azimuth = np.asarray(panorama["azimuth"].values, dtype=float)
    row, column = 90.0 / elevation.size, 360.0 / azimuth.size
    expected_el = 90.0 - (np.arange(elevation.size) + 0.5) * row
    expected_az = (np.arange(azimuth.size) + 0.5) * column
    if not (np.allclose(elevation, expected_el) and np.allclose(azimuth, expected_az)):
        raise InputError(
            "panorama rows or columns are not equally spaced from the zenith and from north; "
            "it cannot be written as a GeoTIFF grid"
        )
    names = [
        name
        for name in ("luminance", "sky_brightness", *TRISTIMULUS_WAVELENGTHS)
        if name in panorama
    ]
    units = {"sky_brightness": "mag arcsec-2"}
    tags = {key: str(value) for key, value in panorama.attrs.items() if key not in ("crs",)}
    tags["observer_crs"] = str(panorama.attrs.get("crs", ""))
    tags["grid"] = "x: azimuth [deg] clockwise from north; y: elevation [deg] above the horizon"
    tags[PRODUCT_TAG] = "panorama"
    return Raster(
        np.stack([np.asarray(panorama[name].values, dtype=float) for name in names]),
        Affine(column, 0.0, 0.0, 0.0, -row, 90.0),
        CRS.from_wkt(SKY_CRS),
        tuple(names),
        tuple(units.get(name, "cd m-2") for name in names),
        tags,
        tuple({"long_name": str(panorama[name].attrs.get("long_name", name))} for name in names),
    )


def polar_raster(
    polar: PolarMap, observer: tuple[float, float], crs: CRS | str, *, half_cells: int = 0
) -> Raster:
    """The observer's polar flux map rasterised around the observer in the emission's CRS.

    Each cell holds the mean upward flux density of the polar bin (distance, azimuth) its
    centre falls in: the bin's flux over its area (Dobashi et al. 2023, Sec. 3.3);
    cells nearer than the first or beyond the last distance edge are nodata.

    .. math:: E_{ij} = \\frac{\\Phi_{ij}}{\\pi (r_{i+1}^2 - r_i^2) / n_{az}}

    Parameters
    ----------
    polar
        The polar map [lm per bin].
    observer
        Observer position (x, y) in ``crs`` [m].
    crs
        The emission raster's projected CRS.
    half_cells
        Cells from the observer to the grid's edge [1]; default :data:`POLAR_GRID_HALF_CELLS`.

    Returns
    -------
    Raster
        One band per emission band, ``flux_density_<k>`` [lm m-2].

    Examples
    --------
    >>> import numpy as np
    >>> from nightlights.sky.polar import PolarMap
    >>> flux = np.ones((1, 2, 4))  # 1 lm in each bin
    >>> polar = PolarMap(flux, np.array([0.0, 10.0, 20.0]), 4, np.zeros(1), np.full(1, 8.0))
    >>> raster = polar_raster(polar, (500.0, 500.0), "EPSG:32635", half_cells=4)
    >>> raster.bounds
    (480.0, 480.0, 520.0, 520.0)
    >>> round(float(raster.data[0, 1, 2]), 5)  # outer ring: 1 lm over pi (20^2 - 10^2) / 4 m2
    0.00424
    """
    half = half_cells or POLAR_GRID_HALF_CELLS
    edges = np.asarray(polar.distance_edges, dtype=float)
    cell = edges[-1] / half
    centres = (np.arange(2 * half) + 0.5) * cell - edges[-1]
    dx, dy = np.meshgrid(centres, -centres)
    distance = np.hypot(dx, dy)
    azimuth = np.degrees(np.arctan2(dx, dy)) % 360.0
    ring = np.asarray(np.searchsorted(edges, distance, side="right"), dtype=np.int64) - 1
    inside = (ring >= 0) & (ring < edges.size - 1)
    sector = np.minimum((azimuth * polar.n_az / 360.0).astype(np.int64), polar.n_az - 1)
    area = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2) / polar.n_az  # [m2] per bin
    density = polar.flux / area[None, :, None]
    data = np.full((polar.flux.shape[0], *distance.shape), np.nan)
    data[:, inside] = density[:, ring[inside], sector[inside]]
    count = data.shape[0]
    x0, y0 = observer
    return Raster(
        data,
        Affine(cell, 0.0, x0 - edges[-1], 0.0, -cell, y0 + edges[-1]),
        CRS.from_user_input(crs),
        tuple(f"flux_density_{k + 1}" for k in range(count)),
        ("lm m-2",) * count,
        {
            PRODUCT_TAG: "polar_emission",
            "observer_x": f"{x0!r}",
            "observer_y": f"{y0!r}",
            "azimuth_bins": str(polar.n_az),
            "distance_edges_m": " ".join(f"{edge:g}" for edge in edges),
            "meaning": "mean upward flux density of the polar bin (distance, azimuth) "
            "around the observer that each cell centre falls in",
            "reference": "Dobashi et al. 2023, Sec. 3.3 (the polar map)",
        },
    )


def _with_natural_sky(artificial: float, factor: float = 1.0) -> dict[str, float | int]:
    """The zenith with a moonless natural sky added (airglow, zodiacal light, starlight:
    22.0 mag arcsec-2, times ``factor`` under a cloud deck), beside the artificial figures,
    which stay as they are."""
    if factor == 1.0:
        summary = zenith_summary(artificial)
    else:
        summary = zenith_summary(artificial, natural_luminance=factor * NATURAL_ZENITH_LUMINANCE)
    return {
        "zenith_natural_cd_m2": float(summary["zenith_natural_cd_m2"]),
        "zenith_total_sky_brightness": float(summary["zenith_sky_brightness"]),
        "bortle_class_zenith_total": int(summary["bortle_class_zenith"]),
    }


def _render(
    dataset: xr.Dataset,
    png: Path,
    bands: str,
    spectrum: str,
    projection: str,
    zenith_mag: float,
) -> None:
    """The panorama's picture: a colour one for ``RGB``, false colour otherwise."""
    elevation = dataset["elevation"].values
    if bands == "RGB":
        xyz = np.stack([dataset[band].values for band in TRISTIMULUS_WAVELENGTHS], axis=-1)
        render_colour_panorama(
            xyz,
            elevation,
            png,
            title=f"artificial skyglow ({spectrum}), zenith {zenith_mag:.2f} mag arcsec-2",
        )
    else:
        render_panorama(
            dataset["sky_brightness"].values,
            elevation,
            dataset["azimuth"].values,
            png,
            projection=projection,
            title=f"artificial skyglow, zenith {zenith_mag:.2f} mag arcsec-2",
        )


def _polar_dataset(polar: PolarMap) -> xr.Dataset:
    edges = polar.distance_edges
    return xr.Dataset(
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


def write_polar(polar: PolarMap, path: PathLike) -> Path:
    """Write a polar flux map as NetCDF (``flux`` [lm], dims band x distance x azimuth).

    Parameters
    ----------
    polar
        Polar flux map.
    path
        Output NetCDF, written atomically.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    with atomic_output(path) as tmp:
        _polar_dataset(polar).to_netcdf(tmp, engine="h5netcdf")
    return Path(path)
