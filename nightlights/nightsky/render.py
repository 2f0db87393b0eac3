"""The night sky as an image: natural and artificial light composed in linear CIE XYZ.

The diffuse sky (natural background, twilight, moonlight, artificial skyglow) is evaluated on a
grid of directions as luminance [cd m-2] and interpolated to the pixels of a :class:`View`; the
Moon and the stars the eye can see against the local sky are drawn into it with their flux
kept exactly (:func:`render_sky`). The pieces live beside it and are handed on here: the view
geometry (:mod:`nightlights.nightsky._view`: :class:`View`, :func:`view_pixels`), star and Moon
photometry (:mod:`nightlights.nightsky._photometry`: :func:`ballesteros_temperature`,
:func:`star_xyz`, :func:`schaefer_limiting_magnitude`, :func:`moon_v_magnitude`) and the
splatting (:mod:`nightlights.nightsky._splat`: :func:`splat_points`, :func:`splat_disc`).

References
----------
1. Schaefer, B. E. (1993). Astronomy and the limits of vision. Vistas in Astronomy 36, 311-361
   (twilight brightness, the cutoff of :data:`TWILIGHT_CUTOFF`).
2. Cinzano, P. (2005). Night sky photometry with Sky Quality Meter, ISTIL Internal Report 9
   (the magnitude scale of the zenith summary).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nightlights import brightness
from nightlights._typing import FloatArray
from nightlights.brightness import NON_FINITE_SKY, bortle_class, luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.nightsky._photometry import (
    ARCSEC2_SR,
    BV_RANGE,
    NANOLAMBERT,
    ZERO_MAGNITUDE_ILLUMINANCE,
    ballesteros_temperature,
    moon_v_magnitude,
    schaefer_limiting_magnitude,
    star_xyz,
)
from nightlights.nightsky._splat import PSF_RADIUS, PSF_SIGMA, splat_disc, splat_points
from nightlights.nightsky._view import PROJECTIONS, Pixels, View, view_pixels
from nightlights.nightsky.background import (
    EXTINCTION_COEFFICIENT,
    STARLIGHT_FAINT_LIMIT,
    SUN_TEMPERATURE,
    NaturalSky,
    natural_sky_luminance,
    rayleigh_sunlight_xyz,
    schaefer_twilight,
    starlight_density,
    twilight_phase,
)
from nightlights.nightsky.tonemap import blackbody_white

__all__ = [
    "ARCSEC2_SR",
    "BV_RANGE",
    "DIFFUSE_STEP",
    "NANOLAMBERT",
    "PROJECTIONS",
    "PSF_RADIUS",
    "PSF_SIGMA",
    "TWILIGHT_CUTOFF",
    "ZERO_MAGNITUDE_ILLUMINANCE",
    "Pixels",
    "SkyImage",
    "SkyOptions",
    "View",
    "ballesteros_temperature",
    "moon_v_magnitude",
    "panorama_lookup",
    "render_sky",
    "schaefer_limiting_magnitude",
    "splat_disc",
    "splat_points",
    "star_xyz",
    "view_pixels",
    "zenith_summary",
]

#: Sun elevation below which the twilight is left out [deg]: at -24 deg Schaefer's twilight is
#: 10 magnitudes below the 22 mag arcsec-2 dark sky at the zenith (one magnitude per degree).
TWILIGHT_CUTOFF = -24.0
#: Spacing of the diffuse sky's evaluation grid [deg]: the natural background, twilight and
#: moonlight vary over degrees (the Moon's aureole within a few degrees of it is the steepest).
DIFFUSE_STEP = 0.5


@dataclass(frozen=True)
class SkyOptions:
    """What the sky is made of.

    Attributes
    ----------
    natural
        Draw the natural sky (background, twilight, Moon, stars).
    artificial
        Draw the artificial skyglow of a panorama.
    stars, moon
        Draw stars; draw the Moon and its light on the sky.
    limiting_magnitude
        Leave out the stars the eye cannot see against the local sky (Schaefer 1990).
    snellen_ratio
        Observer's acuity for the limiting magnitude [1].
    extinction_coefficient
        V-band extinction of starlight and the sky [mag airmass-1].
    natural_sky
        Parameters of the moonless background.
    psf_sigma
        Star point-spread standard deviation [pixel].
    spectrum
        Luminaire spectrum that colours a luminance-only panorama (a name in
        :data:`ies.spectra.SPDS`).
    diffuse_step
        Spacing of the grid on which the diffuse sky is evaluated before bilinear
        interpolation to the pixels [deg].
    """

    natural: bool = True
    artificial: bool = True
    stars: bool = True
    moon: bool = True
    limiting_magnitude: bool = True
    snellen_ratio: float = 1.0
    extinction_coefficient: float = EXTINCTION_COEFFICIENT
    natural_sky: NaturalSky = field(default_factory=NaturalSky)
    psf_sigma: float = PSF_SIGMA
    spectrum: str = "LED_4000K"
    diffuse_step: float = DIFFUSE_STEP

    def __post_init__(self) -> None:
        if not 0.0 < self.diffuse_step <= 10.0:
            raise InputError(f"diffuse step {self.diffuse_step}: expected 0-10 deg")


@dataclass(frozen=True)
class SkyImage:
    """A rendered sky in linear units.

    Attributes
    ----------
    xyz
        ``(rows, cols, 3)`` CIE XYZ luminance [cd m-2]; NaN where there is no sky.
    pixels
        Geometry of the image.
    summary
        Figures for the legend and the NetCDF attributes: ``zenith_natural_cd_m2``,
        ``zenith_artificial_cd_m2``, their sum in ``zenith_sky_brightness`` [mag arcsec-2],
        ``bortle_class_zenith``, ``sun_elevation_deg``, ``sky_phase``, ``moon_elevation_deg``,
        ``moon_illuminated_fraction``, ``stars_drawn``, ``zenith_limiting_magnitude``.
    """

    xyz: FloatArray
    pixels: Pixels
    summary: dict[str, Any]

    @property
    def luminance(self) -> FloatArray:
        """``(rows, cols)`` luminance Y [cd m-2]."""
        return self.xyz[..., 1]


def _bilinear(grid: FloatArray, rows: ArrayLike, cols: ArrayLike) -> FloatArray:
    """Bilinear interpolation of ``(n_rows, n_cols, c)`` at fractional rows and columns.

    Rows are clamped to the grid; columns are periodic with the last column equal to the first.
    """
    from scipy.ndimage import map_coordinates

    r = np.asarray(rows, dtype=float)
    c = np.mod(np.asarray(cols, dtype=float), grid.shape[1] - 1.0)
    coords = np.stack([r.ravel(), c.ravel()])
    channels = [
        map_coordinates(grid[..., i], coords, order=1, mode="nearest", prefilter=False)
        for i in range(grid.shape[-1])
    ]
    return np.stack(channels, axis=-1).reshape(*r.shape, grid.shape[-1])


def _bilinear_separable(
    grid: FloatArray, rows: FloatArray, cols: FloatArray, *, compiled: bool = True
) -> FloatArray:
    """:func:`_bilinear` on the product of fractional ``rows`` and ``cols``: (rows, cols, c).

    ``compiled`` runs one parallel loop (:mod:`._render_numba`); False the numpy reference.
    """
    r = np.clip(rows, 0.0, grid.shape[0] - 1.0)
    r0 = np.minimum(r.astype(np.intp), grid.shape[0] - 2)
    c = np.mod(cols, grid.shape[1] - 1.0)
    c0 = np.minimum(c.astype(np.intp), grid.shape[1] - 2)
    if compiled:
        from nightlights.nightsky._render_numba import bilinear_separable

        return bilinear_separable(np.ascontiguousarray(grid), r0, r - r0, c0, c - c0)
    fr = (r - r0)[:, None, None]
    along = grid[r0] * (1.0 - fr) + grid[r0 + 1] * fr
    fc = (c - c0)[None, :, None]
    return along[:, c0] * (1.0 - fc) + along[:, c0 + 1] * fc


def panorama_lookup(panorama: Any, elevation: ArrayLike, azimuth: ArrayLike) -> FloatArray:
    """Bilinear lookup of a skyglow panorama at directions, periodic in azimuth.

    Parameters
    ----------
    panorama
        Dataset with ``luminance`` [cd m-2] (and optionally ``X``, ``Y``, ``Z``) on
        (elevation, azimuth) pixel centres [deg].
    elevation, azimuth
        Directions [deg]; elevations beyond the first and last rows take those rows.

    Returns
    -------
    numpy.ndarray
        ``(..., c)`` values: c = 3 (X, Y, Z) when the panorama has them, else 1 (luminance).
    """
    from scipy.ndimage import map_coordinates

    el_axis = np.asarray(panorama["elevation"].values, dtype=float)
    az_axis = np.asarray(panorama["azimuth"].values, dtype=float)
    names = ["X", "Y", "Z"] if all(b in panorama for b in "XYZ") else ["luminance"]
    order = np.argsort(el_axis)
    el_sorted = el_axis[order]
    el = np.asarray(elevation, dtype=float)
    az = np.asarray(azimuth, dtype=float)
    rows = np.interp(el, el_sorted, np.arange(el_sorted.size))
    step = 360.0 / az_axis.size
    cols = np.mod(az - az_axis[0], 360.0) / step
    out = []
    for name in names:
        grid = np.asarray(panorama[name].values, dtype=float)[order]
        grid = np.concatenate([grid, grid[:, :1]], axis=1)  # wrap the last column to the first
        out.append(map_coordinates(grid, [rows.ravel(), cols.ravel()], order=1, mode="nearest"))
    return np.stack(out, axis=-1).reshape(*el.shape, len(names))


def render_sky(
    time: Any,
    lon: float,
    lat: float,
    *,
    view: View | None = None,
    panorama: Any = None,
    options: SkyOptions | None = None,
    catalog: Any = None,
) -> SkyImage:
    """Compose the night sky of a place and time in linear CIE XYZ.

    Parameters
    ----------
    time
        Aware datetime, ISO 8601 text or numpy datetime64 (UTC).
    lon, lat
        Observer's longitude and latitude [deg].
    view
        Projection and size (default ``View()``: equirectangular 1024 x 512).
    panorama
        Skyglow panorama dataset (``nightlights skyglow``) for the artificial light, or None.
    options
        What to draw (default ``SkyOptions()``).
    catalog
        Star catalogue (default the shipped Bright Star Catalogue).

    Returns
    -------
    SkyImage
        The image and the figures of its legend.
    """
    return _render_sky(time, lon, lat, view, panorama, options, catalog, compiled=True)


def _render_sky(
    time: Any,
    lon: float,
    lat: float,
    view: View | None,
    panorama: Any,
    options: SkyOptions | None,
    catalog: Any,
    *,
    compiled: bool,
) -> SkyImage:
    """:func:`render_sky`; ``compiled`` interpolates the diffuse sky of an equirectangular view
    in one compiled loop and draws the Moon and stars into it in place, False is the numpy
    reference (full-size temporaries, each source drawn on its own image and added)."""
    from nightlights.nightsky.astro import airmass, star_positions
    from nightlights.nightsky.catalog import load_catalog
    from nightlights.nightsky.moon import moon_sky_brightness, moon_state, sun_position

    view = view if view is not None else View()
    options = options if options is not None else SkyOptions()
    if not (options.natural or options.artificial):
        raise InputError("nothing to draw: both the natural and the artificial sky are off")
    if options.artificial and panorama is None and not options.natural:
        raise InputError("artificial sky asked for without a skyglow panorama")
    pixels = view_pixels(view)
    k = options.extinction_coefficient
    summary: dict[str, Any] = {}
    sun_az, sun_el = (float(v) for v in sun_position(time, lon, lat))
    summary["sun_elevation_deg"] = sun_el
    summary["sky_phase"] = twilight_phase(sun_el)
    if options.natural and sun_el >= 0.0:
        raise InputError(
            f"Sun at {sun_el:.1f} deg above the horizon at {time}: daylight is not modelled"
        )
    stars = catalog if catalog is not None else load_catalog()
    star_az, star_el = (np.asarray(v, dtype=float) for v in star_positions(stars, time, lon, lat))
    moon = moon_state(time, lon, lat) if options.natural and options.moon else None
    if moon is not None:
        summary["moon_elevation_deg"] = float(moon.elevation)
        summary["moon_illuminated_fraction"] = float(moon.illuminated_fraction)
    # The diffuse sky on a grid of diffuse_step, interpolated to the pixels.
    grid_el = np.linspace(0.0, 90.0, math.ceil(90.0 / options.diffuse_step) + 1)
    grid_az = np.linspace(0.0, 360.0, math.ceil(360.0 / options.diffuse_step) + 1)
    node_el, node_az = np.meshgrid(grid_el, grid_az, indexing="ij")
    grid = np.zeros((*node_el.shape, 3))
    if options.natural:
        faint = stars.vmag >= STARLIGHT_FAINT_LIMIT
        density = starlight_density(star_el[faint], star_az[faint], node_el, node_az)
        natural = natural_sky_luminance(node_el, starlight=density, sky=options.natural_sky)
        grid += natural["total"][..., None] * blackbody_white(SUN_TEMPERATURE)
        if sun_el > TWILIGHT_CUTOFF:
            twilight = schaefer_twilight(node_el, node_az, sun_el, sun_az, extinction_coefficient=k)
            grid += twilight[..., None] * rayleigh_sunlight_xyz()
        if moon is not None and moon.elevation > -1.0:
            moonlight = moon_sky_brightness(moon, node_el, node_az, extinction_coefficient=k)
            grid += np.nan_to_num(np.asarray(moonlight, dtype=float))[..., None] * (
                rayleigh_sunlight_xyz()
            )
    zenith_natural = float(grid[-1, 0, 1])
    zenith_artificial = 0.0
    if options.artificial and panorama is not None:
        glow = panorama_lookup(panorama, node_el, node_az)
        zenith_artificial = float(panorama_lookup(panorama, [90.0], [0.0])[0, glow.shape[-1] // 2])
        if glow.shape[-1] == 1:
            from nightlights.sky.colour import tristimulus_flux_ratios

            ratios = tristimulus_flux_ratios(options.spectrum)
            glow = glow * np.array([ratios["X"], 1.0, ratios["Z"]])
        grid += glow
    step = (grid_el[1] - grid_el[0], grid_az[1] - grid_az[0])
    if view.projection == "equirectangular":  # separable: rows share elevation, columns azimuth
        xyz = _bilinear_separable(
            grid, pixels.elevation[:, 0] / step[0], pixels.azimuth[0] / step[1], compiled=compiled
        )
    else:
        xyz = _bilinear(grid, pixels.elevation / step[0], pixels.azimuth / step[1])
    if moon is not None and moon.elevation >= 0.0:
        m_moon = moon_v_magnitude(moon.phase_angle) + k * float(airmass(moon.elevation))
        moon_flux = ZERO_MAGNITUDE_ILLUMINANCE * 10.0 ** (-0.4 * m_moon)
        moon_image = splat_disc(
            pixels,
            moon.elevation,
            moon.azimuth,
            moon.angular_radius,
            moon_flux * blackbody_white(SUN_TEMPERATURE),
            sun=(sun_az, sun_el),
            phase_angle=moon.phase_angle,
            out=xyz if compiled else None,
        )
        if not compiled:
            xyz += moon_image
    drawn = 0
    if options.natural and options.stars:
        up = star_el >= 0.0
        s_el, s_az = star_el[up], star_az[up]
        vmag = stars.vmag[up] + k * np.asarray(airmass(s_el), dtype=float)
        visible = pixels.locate(s_el, s_az)[2]
        if options.limiting_magnitude:
            local = _bilinear(grid[..., 1:2], s_el / step[0], s_az / step[1])[:, 0]
            limit = schaefer_limiting_magnitude(local, snellen_ratio=options.snellen_ratio)
            visible &= vmag <= limit
        flux = star_xyz(vmag[visible], stars.bv[up][visible])
        stars_image = splat_points(
            pixels,
            s_el[visible],
            s_az[visible],
            flux,
            sigma=options.psf_sigma,
            out=xyz if compiled else None,
        )
        if not compiled:
            xyz += stars_image
        drawn = int(visible.sum())
    if not pixels.sky.all():
        xyz[~pixels.sky] = np.nan
    zenith_total = zenith_natural + zenith_artificial
    if not math.isfinite(zenith_total):
        raise InputError(
            f"zenith luminance {zenith_total} cd m-2 (natural {zenith_natural}, artificial "
            f"{zenith_artificial}): {NON_FINITE_SKY}"
        )
    magnitude = float(luminance_to_magnitude(zenith_total)) if zenith_total > 0 else math.inf
    summary.update(
        {
            "zenith_natural_cd_m2": zenith_natural,
            "zenith_artificial_cd_m2": zenith_artificial,
            "zenith_sky_brightness": magnitude,
            "bortle_class_zenith": int(bortle_class(magnitude)),  # no light (+inf mag): 1
            "stars_drawn": drawn,
            "zenith_limiting_magnitude": float(schaefer_limiting_magnitude(zenith_total)),
        }
    )
    return SkyImage(xyz, pixels, summary)


def zenith_summary(
    artificial_luminance: float,
    *,
    time: Any = None,
    lon: float | None = None,
    lat: float | None = None,
    options: SkyOptions | None = None,
) -> dict[str, Any]:
    """Zenith sky brightness natural + artificial, for the summaries of the skyglow stages.

    Parameters
    ----------
    artificial_luminance
        Artificial skyglow at the zenith [cd m-2].
    time
        Instant (UTC); with ``lon`` and ``lat`` the natural sky of that night (star density,
        twilight, Moon). None takes the moonless natural sky of :class:`SkyOptions`'s
        :class:`~nightlights.nightsky.background.NaturalSky` (22.0 mag arcsec-2).
    lon, lat
        Observer's longitude and latitude [deg], with ``time``.
    options
        What the natural sky holds (default ``SkyOptions()``).

    Returns
    -------
    dict
        ``zenith_natural_cd_m2``, ``zenith_artificial_cd_m2``, ``zenith_sky_brightness``
        [mag arcsec-2] of their sum, ``zenith_natural_sky_brightness`` and
        ``bortle_class_zenith`` (:func:`nightlights.brightness.zenith_summary` with this
        natural sky).

    Examples
    --------
    >>> summary = zenith_summary(3.65e-3)  # the demo's Esplanadi panorama
    >>> round(summary["zenith_sky_brightness"], 2), summary["bortle_class_zenith"]
    (18.63, 7)
    """
    options = options if options is not None else SkyOptions()
    if not math.isfinite(artificial_luminance):
        raise InputError(
            f"artificial zenith luminance {artificial_luminance} cd m-2: {NON_FINITE_SKY}"
        )
    if not artificial_luminance >= 0:
        raise InputError(f"artificial zenith luminance {artificial_luminance}: expected >= 0")
    if time is None:
        natural = float(natural_sky_luminance([90.0], sky=options.natural_sky)["total"][0])
    else:
        if lon is None or lat is None:
            raise InputError("zenith summary at a time needs lon and lat")
        tiny = View("equirectangular", 8, 2)
        natural = render_sky(
            time, lon, lat, view=tiny, options=replace(options, artificial=False, stars=False)
        ).summary["zenith_natural_cd_m2"]
    return brightness.zenith_summary(artificial_luminance, natural_luminance=natural)
