"""The night sky as an image: natural and artificial light composed in linear CIE XYZ.

A :class:`View` (equirectangular, fisheye or perspective) gives every pixel a direction and a
solid angle (:func:`view_pixels`). The diffuse sky (natural background, twilight, moonlight,
artificial skyglow) is evaluated at the pixel directions as luminance [cd m-2]; point sources
(stars, a Moon smaller than a pixel) are splatted with a pixel-integrated Gaussian whose weights
sum to one, so that a star's illuminance [lx] equals the sum over its pixels of luminance times
solid angle at any resolution (:func:`splat_points`). Star colours come from B-V through
Ballesteros's (2012) temperature and a blackbody; stars fainter than the eye's limiting
magnitude against the local sky (Schaefer 1990) are left out.

Length: 600+ lines because the three projections, the splatting and the composition share the
pixel geometry; split they would pass the same five arrays back and forth.

References
----------
1. Ballesteros, F. J. (2012). New insights into black bodies. EPL 97, 34008, Eq. 14:
   T = 4600 K (1 / (0.92 (B-V) + 1.7) + 1 / (0.92 (B-V) + 0.62)).
2. Schaefer, B. E. (1990). Telescopic limiting magnitudes. PASP 102, 212-229; the visual
   threshold of Hecht (1947) as in Schaefer (1998), VISLIMIT.BAS lines 260-320.
3. Cinzano, P. (2005). Night sky photometry with Sky Quality Meter, ISTIL Internal Report 9:
   0 mag arcsec-2 = 1.08e5 cd m-2, so a 0 mag star gives 1.08e5 cd m-2 x 1 arcsec^2 =
   2.54e-6 lx.
4. Krisciunas, K. & Schaefer, B. E. (1991). A model of the brightness of moonlight. PASP 103,
   1033-1039, Eq. 9 (the Moon's V magnitude by phase angle).
5. Snyder, J. P. (1987). Map Projections: A Working Manual. USGS PP 1395: azimuthal
   equidistant (p. 191) and gnomonic (p. 164) projections.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights import brightness
from nightlights.brightness import ZERO_POINT_LUMINANCE, bortle_class, luminance_to_magnitude
from nightlights.errors import InputError
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

FloatArray = NDArray[np.float64]

PROJECTIONS = ("equirectangular", "fisheye", "perspective")
#: Solid angle of one square arcsecond [sr].
ARCSEC2_SR = (math.pi / (180.0 * 3600.0)) ** 2
#: Illuminance of a star of V = 0 [lx]: the zero point of the sky-brightness scale
#: (1.08e5 cd m-2 at 0 mag arcsec-2, Cinzano 2005) times one square arcsecond.
ZERO_MAGNITUDE_ILLUMINANCE = ZERO_POINT_LUMINANCE * ARCSEC2_SR
#: One nanolambert [cd m-2]: 1 L = 1e4 / pi cd m-2.
NANOLAMBERT = 1e-9 * 1e4 / math.pi
#: Standard deviation of the star point-spread function [pixel]. In the sweep of
#: benchmarks/bench_sky_render.py, 0.7 is the smallest sigma that keeps a star's flux-weighted
#: centroid within 1e-4 pixel of its true position (0.35 is off by up to 0.04 pixel), and the
#: largest share of a star's flux in one pixel then varies by a factor 1.5 with its sub-pixel
#: position (3.3 at 0.25).
PSF_SIGMA = 0.7
#: Half-width of the splatting stencil [sigma]: the Gaussian beyond 3 sigma holds 0.27 % of the
#: flux in each axis; the weights are renormalised, so the flux is kept exactly.
PSF_RADIUS = 3.0
#: Sun elevation below which the twilight is left out [deg]: at -24 deg Schaefer's twilight is
#: 10 magnitudes below the 22 mag arcsec-2 dark sky at the zenith (one magnitude per degree).
TWILIGHT_CUTOFF = -24.0
#: Spacing of the diffuse sky's evaluation grid [deg]: the natural background, twilight and
#: moonlight vary over degrees (the Moon's aureole within a few degrees of it is the steepest).
DIFFUSE_STEP = 0.5
#: B-V range of Ballesteros's formula [mag]: it diverges at B-V = -0.67.
BV_RANGE = (-0.4, 2.0)


# ---------------------------------------------------------------------------------------------
# Views


@dataclass(frozen=True)
class View:
    """What part of the sky is drawn and how.

    Attributes
    ----------
    projection
        ``equirectangular`` (azimuth across, 0-360 deg from north through east; elevation
        down, zenith in the first row, horizon in the last), ``fisheye`` (azimuthal
        equidistant, zenith in the centre, north up, east left as seen from below) or
        ``perspective`` (gnomonic, looking toward ``azimuth``, ``elevation``).
    width, height
        Image size [pixel]; a fisheye is ``width`` square.
    azimuth, elevation
        Perspective view direction [deg].
    field_of_view
        Perspective horizontal field of view [deg], below 180.
    """

    projection: str = "equirectangular"
    width: int = 1024
    height: int = 512
    azimuth: float = 180.0
    elevation: float = 30.0
    field_of_view: float = 90.0

    def __post_init__(self) -> None:
        if self.projection not in PROJECTIONS:
            raise InputError(
                f"projection {self.projection!r}; expected one of {', '.join(PROJECTIONS)}"
            )
        if self.width < 2 or self.height < 2:
            raise InputError(f"image {self.width} x {self.height}: expected at least 2 x 2 pixels")
        if not 0.0 < self.field_of_view < 180.0:
            raise InputError(f"field of view {self.field_of_view}: expected 0-180 deg")
        if not -90.0 <= self.elevation <= 90.0:
            raise InputError(f"view elevation {self.elevation}: expected -90 to 90 deg")

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the image."""
        if self.projection == "fisheye":
            return (self.width, self.width)
        return (self.height, self.width)


@dataclass(frozen=True)
class Pixels:
    """Directions and solid angles of a view's pixels.

    Attributes
    ----------
    view
        The view.
    elevation, azimuth
        ``(rows, cols)`` direction of each pixel centre [deg].
    solid_angle
        ``(rows, cols)`` solid angle of each pixel [sr].
    sky
        ``(rows, cols)`` True where the pixel shows the sky (at or above the horizon).
    pixel_size
        Nominal angular size of a pixel [deg].
    """

    view: View
    elevation: FloatArray
    azimuth: FloatArray
    solid_angle: FloatArray
    sky: NDArray[np.bool_]
    pixel_size: float

    def locate(
        self, elevation: ArrayLike, azimuth: ArrayLike
    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """Fractional (row, column) of directions, pixel (0, 0) centred on (0.0, 0.0).

        Parameters
        ----------
        elevation, azimuth
            Directions [deg].

        Returns
        -------
        tuple
            rows, columns and a mask of the directions inside the image and above the horizon.
        """
        return _locate(self.view, np.asarray(elevation, float), np.asarray(azimuth, float))


def view_pixels(view: View) -> Pixels:
    """Pixel directions and solid angles of a view.

    Parameters
    ----------
    view
        The view.

    Returns
    -------
    Pixels
        Geometry of the image; the solid angles of the sky pixels of an equirectangular view
        sum to 2 pi sr exactly.

    References
    ----------
    Snyder 1987 (azimuthal equidistant, gnomonic).
    """
    rows, cols = view.shape
    if view.projection == "equirectangular":
        d_el = 90.0 / rows
        d_az = 360.0 / cols
        el = 90.0 - (np.arange(rows) + 0.5) * d_el
        az = (np.arange(cols) + 0.5) * d_az
        band = np.radians(d_az) * (
            np.sin(np.radians(el + d_el / 2.0)) - np.sin(np.radians(el - d_el / 2.0))
        )
        # read-only broadcast views: every row shares its elevation, every column its azimuth
        elevation = np.broadcast_to(el[:, None], (rows, cols))
        azimuth = np.broadcast_to(az[None, :], (rows, cols))
        solid = np.broadcast_to(band[:, None], (rows, cols))
        sky = np.broadcast_to(np.True_, (rows, cols))
        return Pixels(view, elevation, azimuth, solid, sky, d_az)
    if view.projection == "fisheye":
        step = 180.0 / rows  # zenith angle per pixel [deg]
        dx, dy = np.meshgrid(np.arange(cols) + 0.5 - cols / 2, np.arange(rows) + 0.5 - rows / 2)
        zenith = np.hypot(dx, dy) * step
        # north up (-dy), east left (-dx): the sky seen from below
        azimuth = np.mod(np.degrees(np.arctan2(-dx, -dy)), 360.0)
        z_rad = np.radians(zenith)
        ratio = np.where(z_rad > 0, np.sin(z_rad) / np.where(z_rad > 0, z_rad, 1.0), 1.0)
        solid = ratio * np.radians(step) ** 2
        sky = zenith <= 90.0
        return Pixels(view, 90.0 - zenith, azimuth, solid, sky, step)
    forward, right, up, focal = _camera(view)
    u, w = np.meshgrid(np.arange(cols) + 0.5 - cols / 2, rows / 2 - (np.arange(rows) + 0.5))
    rays = focal * forward + u[..., None] * right + w[..., None] * up
    norm = np.linalg.norm(rays, axis=-1)
    direction = rays / norm[..., None]
    elevation = np.degrees(np.arcsin(np.clip(direction[..., 2], -1.0, 1.0)))
    azimuth = np.mod(np.degrees(np.arctan2(direction[..., 0], direction[..., 1])), 360.0)
    solid = (focal / norm) ** 3 / focal**2
    return Pixels(view, elevation, azimuth, solid, elevation >= 0.0, view.field_of_view / cols)


def _camera(view: View) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Forward, right and up unit vectors (east, north, up) and the focal length [pixel]."""
    el, az = np.radians(view.elevation), np.radians(view.azimuth)
    forward = np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    right = np.array([np.cos(az), -np.sin(az), 0.0])
    up = np.cross(right, forward)
    focal = (view.width / 2.0) / math.tan(math.radians(view.field_of_view) / 2.0)
    return forward, right, up, focal


def _locate(
    view: View, elevation: FloatArray, azimuth: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    rows, cols = view.shape
    above = elevation >= 0.0
    if view.projection == "equirectangular":
        row = (90.0 - elevation) / (90.0 / rows) - 0.5
        col = np.mod(azimuth, 360.0) / (360.0 / cols) - 0.5
        return row, col, above
    if view.projection == "fisheye":
        radius = (90.0 - elevation) / (180.0 / rows)
        az = np.radians(azimuth)
        col = cols / 2 - radius * np.sin(az) - 0.5
        row = rows / 2 - radius * np.cos(az) - 0.5
        return row, col, above
    forward, right, up, focal = _camera(view)
    el, az = np.radians(elevation), np.radians(azimuth)
    vec = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=-1)
    depth = vec @ forward
    safe = np.where(depth > 1e-9, depth, 1.0)
    col = cols / 2 + focal * (vec @ right) / safe - 0.5
    row = rows / 2 - focal * (vec @ up) / safe - 0.5
    inside = (depth > 1e-9) & (col > -0.5) & (col < cols - 0.5) & (row > -0.5) & (row < rows - 0.5)
    return row, col, above & inside


# ---------------------------------------------------------------------------------------------
# Point sources


def ballesteros_temperature(bv: ArrayLike) -> FloatArray:
    """Effective temperature of a star from its B-V colour index.

    .. math:: T = 4600\\,\\mathrm{K}\\left(\\frac{1}{0.92 (B-V) + 1.7}
        + \\frac{1}{0.92 (B-V) + 0.62}\\right)

    Parameters
    ----------
    bv
        B-V [mag]; clipped to -0.4 .. 2.0 where the formula holds.

    Returns
    -------
    numpy.ndarray
        Temperature [K].

    References
    ----------
    Ballesteros 2012, Eq. 14.

    Examples
    --------
    >>> [round(float(t)) for t in ballesteros_temperature([0.0, 0.65, 1.5])]
    [10125, 5778, 3794]
    """
    b = np.clip(np.asarray(bv, dtype=float), *BV_RANGE)
    return 4600.0 * (1.0 / (0.92 * b + 1.7) + 1.0 / (0.92 * b + 0.62))


def star_xyz(vmag: ArrayLike, bv: ArrayLike) -> FloatArray:
    """Tristimulus illuminance of stars [lx]: Y from V, chromaticity of a blackbody.

    Parameters
    ----------
    vmag
        Apparent V magnitude after extinction [mag].
    bv
        B-V [mag]; NaN gives the equal-energy white (x = y = 1/3).

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` X, Y, Z illuminance [lx]; Y = 2.54e-6 lx x 10^(-0.4 V).

    References
    ----------
    Ballesteros 2012; Cinzano 2005 (zero point).
    """
    y = ZERO_MAGNITUDE_ILLUMINANCE * 10.0 ** (-0.4 * np.asarray(vmag, dtype=float))
    b = np.asarray(bv, dtype=float)
    colour = np.ones((b.size, 3))
    known = np.isfinite(b)
    if known.any():
        colour[known] = blackbody_white(ballesteros_temperature(b[known]))
    return colour * y[:, None]


def schaefer_limiting_magnitude(
    sky_luminance: ArrayLike, *, snellen_ratio: float = 1.0
) -> FloatArray:
    """Faintest star the dark-adapted eye sees against a sky, outside the atmosphere's loss.

    .. math::
        I = c_1 \\left(1 + \\sqrt{c_2 B}\\right)^2,\\quad
        m = -16.57 - 2.5 \\log_{10} I + 5 \\log_{10} S

    with B the sky brightness [nL], I the threshold illuminance [foot-candle] and
    (c_1, c_2) = (10^-9.8, 10^-1.9) for B <= 1500 nL (rods), (10^-8.35, 10^-5.9) above (cones).

    Parameters
    ----------
    sky_luminance
        Luminance of the sky around the star [cd m-2].
    snellen_ratio
        Observer's acuity (1 = 20/20, 2 = 20/10) [1].

    Returns
    -------
    numpy.ndarray
        Limiting magnitude [mag], to compare with the star's magnitude after extinction.

    References
    ----------
    Schaefer 1990; Schaefer 1998 (VISLIMIT lines 260-320), after Hecht 1947.

    Examples
    --------
    >>> round(float(schaefer_limiting_magnitude(171e-6)), 2)  # 22.0 mag arcsec-2
    6.63
    """
    if not snellen_ratio > 0:
        raise InputError(f"Snellen ratio {snellen_ratio}: expected > 0")
    nl = np.maximum(np.asarray(sky_luminance, dtype=float), 0.0) / NANOLAMBERT
    rods = nl <= 1500.0
    c1 = np.where(rods, 10.0**-9.8, 10.0**-8.35)
    c2 = np.where(rods, 10.0**-1.9, 10.0**-5.9)
    threshold = c1 * (1.0 + np.sqrt(c2 * nl)) ** 2
    return -16.57 - 2.5 * np.log10(threshold) + 5.0 * math.log10(snellen_ratio)


def splat_points(
    pixels: Pixels,
    elevation: ArrayLike,
    azimuth: ArrayLike,
    flux: ArrayLike,
    *,
    sigma: float = PSF_SIGMA,
    radius: float = PSF_RADIUS,
    normalise: bool = True,
    out: FloatArray | None = None,
) -> FloatArray:
    """Luminance image of point sources spread by a pixel-integrated Gaussian.

    Each source's weights are the Gaussian of standard deviation ``sigma`` integrated over the
    pixels of a square stencil (error functions, separable), zero on pixels that show no sky,
    and divided by their sum; the pixel's luminance is flux x weight / solid angle, so the sum
    of luminance x solid angle over the image is the source's flux at any resolution.

    Parameters
    ----------
    pixels
        Geometry of the image (:func:`view_pixels`).
    elevation, azimuth
        ``(n,)`` directions of the sources [deg].
    flux
        ``(n,)`` or ``(n, c)`` illuminance of each source, per channel [lx].
    sigma
        Point-spread standard deviation [pixel].
    radius
        Stencil half-width [sigma].
    normalise
        Divide the weights by their sum (exact flux); False keeps the Gaussian's own integral
        over the stencil (for the benchmark of the truncation error).
    out
        C-contiguous ``(rows, cols, c)`` float64 image to add the sources to in place (the sky
        they are drawn on) [cd m-2]; None starts from a black image.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols, c)`` luminance [cd m-2] (``out`` when given); sources outside the view
        are dropped.
    """
    from scipy.special import erf

    if not sigma > 0 or not radius > 0:
        raise InputError(f"PSF sigma {sigma}, radius {radius}: expected > 0")
    values = np.asarray(flux, dtype=float)
    values = values[:, None] if values.ndim == 1 else values
    rows, cols = pixels.view.shape
    channels = values.shape[1]
    if out is None:
        image = np.zeros((rows, cols, channels))
    else:
        if out.shape != (rows, cols, channels) or not out.flags.c_contiguous:
            raise InputError(
                f"splat output {out.shape}: expected a C-contiguous {(rows, cols, channels)} image"
            )
        image = out
    row, col, keep = pixels.locate(elevation, azimuth)
    if not np.any(keep):
        return image
    row, col, values = row[keep], col[keep], values[keep]
    half = max(1, math.ceil(radius * sigma))
    offsets = np.arange(-half, half + 1)
    centre_r = np.floor(row + 0.5).astype(int)
    centre_c = np.floor(col + 0.5).astype(int)
    scale = 1.0 / (math.sqrt(2.0) * sigma)

    def weights_1d(position: FloatArray, centre: NDArray[np.int_]) -> FloatArray:
        lower = (centre[:, None] + offsets[None, :] - 0.5 - position[:, None]) * scale
        return 0.5 * (erf(lower + scale) - erf(lower))

    w_r = weights_1d(row, centre_r)
    w_c = weights_1d(col, centre_c)
    weight = w_r[:, :, None] * w_c[:, None, :]
    rr = centre_r[:, None, None] + offsets[None, :, None]
    cc = centre_c[:, None, None] + offsets[None, None, :]
    if pixels.view.projection == "equirectangular":
        cc = np.mod(cc, cols)
        rr_in = (rr >= 0) & (rr < rows)
    else:
        rr_in = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
    rr, cc = np.broadcast_arrays(rr, cc)
    inside = np.broadcast_to(rr_in, weight.shape)
    rr = np.where(inside, np.clip(rr, 0, rows - 1), 0)
    cc = np.where(inside, np.clip(cc, 0, cols - 1), 0)
    weight = np.where(inside & pixels.sky[rr, cc], weight, 0.0)
    if normalise:
        total = weight.sum(axis=(1, 2))
        weight = np.divide(
            weight, total[:, None, None], out=np.zeros_like(weight), where=total[:, None, None] > 0
        )
    lum_weight = (weight / pixels.solid_angle[rr, cc]).reshape(weight.shape[0], -1)
    flat = (rr * cols + cc).reshape(weight.shape[0], -1)
    # one scatter-add over all channels: index pixel x channels + channel of the flat image
    target = (flat[:, :, None] * channels + np.arange(channels)).ravel()
    from nightlights.nightsky._render_numba import scatter_add

    scatter_add(image.reshape(-1), target, (lum_weight[:, :, None] * values[:, None, :]).ravel())
    return image


def splat_disc(
    pixels: Pixels,
    elevation: float,
    azimuth: float,
    angular_radius: float,
    flux: ArrayLike,
    *,
    sun: tuple[float, float] | None = None,
    phase_angle: float = 0.0,
    out: FloatArray | None = None,
) -> FloatArray:
    """Luminance image of a uniform disc (the Moon), optionally in phase, carrying a flux.

    Pixels are weighted by the fraction of them the disc covers (a linear ramp one pixel wide
    across the rim) times their solid angle, and the weights normalised, so the image holds the
    flux exactly; a disc smaller than two pixels is drawn as a point (:func:`splat_points`).
    With ``sun``, only the lit part is drawn: in the disc's own frame, x toward the Sun along
    the great circle and y across, both in disc radii, a point is lit where
    x >= -cos(phase angle) sqrt(1 - y^2) (the terminator, an ellipse; the same one-pixel ramp).

    Parameters
    ----------
    pixels
        Geometry of the image.
    elevation, azimuth
        Centre of the disc [deg].
    angular_radius
        Radius of the disc [deg].
    flux
        ``(c,)`` illuminance per channel [lx].
    sun
        (azimuth, elevation) of the Sun [deg]; None draws the full disc.
    phase_angle
        Sun-Moon-observer angle [deg]: 0 full, 90 quarter, 180 new.
    out
        C-contiguous ``(rows, cols, c)`` image to add the disc to in place [cd m-2]; None
        starts from a black image.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols, c)`` luminance [cd m-2] (``out`` when given).
    """
    values = np.atleast_1d(np.asarray(flux, dtype=float))
    shape = (*pixels.view.shape, values.size)
    if out is None:
        out = np.zeros(shape)
    elif out.shape != shape:
        raise InputError(f"disc output {out.shape}: expected {shape}")
    if angular_radius < pixels.pixel_size:
        return splat_points(
            pixels,
            np.array([elevation]),
            np.array([azimuth]),
            values[None, :],
            sigma=PSF_SIGMA,
            out=out,
        )
    # only pixels within the disc's elevation band (plus two pixels) can be covered; an
    # equirectangular image's rows share their elevation: the band is a block of rows
    block = slice(None)
    if pixels.view.projection == "equirectangular":
        row_size = np.degrees(np.sqrt(pixels.solid_angle[:, 0]))
        band = np.flatnonzero(
            np.abs(pixels.elevation[:, 0] - elevation) <= angular_radius + 2.0 * row_size
        )
        if band.size == 0:
            return out
        block = slice(int(band[0]), int(band[-1]) + 1)
    sky, pixel_el = pixels.sky[block], pixels.elevation[block]
    solid = pixels.solid_angle[block]
    size = np.degrees(np.sqrt(solid))
    near = sky & (np.abs(pixel_el - elevation) <= angular_radius + 2.0 * size)
    centre = _direction(np.array(elevation), np.array(azimuth))
    points = _direction(pixel_el[near], pixels.azimuth[block][near])
    separation = np.degrees(np.arccos(np.clip(points @ centre, -1.0, 1.0)))
    ramp = size[near] / angular_radius  # one pixel in disc radii
    cover = np.clip((angular_radius - separation) / size[near] + 0.5, 0.0, 1.0)
    if sun is not None:
        toward = _direction(np.array(sun[1]), np.array(sun[0]))
        toward = toward - (toward @ centre) * centre
        norm = np.linalg.norm(toward)
        if norm > 0:
            toward /= norm
            across = np.cross(centre, toward)
            scale = math.radians(angular_radius)
            x = points @ toward / scale
            y = points @ across / scale
            edge = -math.cos(math.radians(phase_angle)) * np.sqrt(np.clip(1.0 - y * y, 0.0, 1.0))
            cover = cover * np.clip((x - edge) / ramp + 0.5, 0.0, 1.0)
    total = (cover * solid[near]).sum()
    if total <= 0:
        return out
    # flux x weight / solid angle, weight / solid angle = cover / total
    luminance = np.zeros(near.shape)
    luminance[near] = cover / total
    out[block] += luminance[..., None] * values[None, None, :]
    return out


def _direction(elevation: FloatArray, azimuth: FloatArray) -> FloatArray:
    """(..., 3) unit vectors (east, north, up) of directions in degrees."""
    el, az = np.radians(elevation), np.radians(azimuth)
    return np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=-1)


def moon_v_magnitude(phase_angle: float) -> float:
    """V magnitude of the Moon at mean distance by phase angle (0 = full).

    .. math:: m = -12.73 + 0.026 |\\alpha| + 4\\times10^{-9} \\alpha^4

    Parameters
    ----------
    phase_angle
        Sun-Moon-Earth angle alpha [deg].

    Returns
    -------
    float
        V magnitude [mag].

    References
    ----------
    Krisciunas & Schaefer 1991, Eq. 9.

    Examples
    --------
    >>> round(moon_v_magnitude(0.0), 2), round(moon_v_magnitude(90.0), 2)
    (-12.73, -10.13)
    """
    alpha = abs(float(phase_angle))
    return -12.73 + 0.026 * alpha + 4e-9 * alpha**4


# ---------------------------------------------------------------------------------------------
# Composition


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
    magnitude = float(luminance_to_magnitude(zenith_total)) if zenith_total > 0 else math.inf
    summary.update(
        {
            "zenith_natural_cd_m2": zenith_natural,
            "zenith_artificial_cd_m2": zenith_artificial,
            "zenith_sky_brightness": magnitude,
            "bortle_class_zenith": int(bortle_class(magnitude)) if math.isfinite(magnitude) else 1,
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
