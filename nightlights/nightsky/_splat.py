"""Point sources and discs drawn into a sky picture with their flux kept exactly.

Point sources (stars, a Moon smaller than a pixel) are splatted with a pixel-integrated Gaussian
whose weights sum to one, so that a star's illuminance [lx] equals the sum over its pixels of
luminance times solid angle at any resolution (:func:`splat_points`); a larger Moon is a disc
whose pixels weigh the part of them it covers, lit up to its terminator (:func:`splat_disc`).
Used by the composition (:mod:`nightlights.nightsky.render`, which hands these names on).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.nightsky._view import Pixels

__all__ = ["PSF_RADIUS", "PSF_SIGMA", "splat_disc", "splat_points"]

#: Standard deviation of the star point-spread function [pixel]. In the sweep of
#: benchmarks/bench_sky_render.py, 0.7 is the smallest sigma that keeps a star's flux-weighted
#: centroid within 1e-4 pixel of its true position (0.35 is off by up to 0.04 pixel), and the
#: largest share of a star's flux in one pixel then varies by a factor 1.5 with its sub-pixel
#: position (3.3 at 0.25).
PSF_SIGMA = 0.7
#: Half-width of the splatting stencil [sigma]: the Gaussian beyond 3 sigma holds 0.27 % of the
#: flux in each axis; the weights are renormalised, so the flux is kept exactly.
PSF_RADIUS = 3.0


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
