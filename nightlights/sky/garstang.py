"""Garstang's single-scattering model of artificial skyglow, reconstructed as published.

An independent numpy reconstruction of the model of Garstang (1986, 1989, 1991) [1-3] for a
ground point source, kept as a check on the toolkit's kernel
(:func:`nightlights.sky.kernel.sky_luminance`), which it does not call. What it takes from the
papers, each piece a pure function:

- the emission function of a city, :func:`garstang_emission_function`: a Lambertian term for
  the light reflected by the ground (reflectance G) and a low-angle psi^4 term for the light the
  luminaires send directly upwards (fraction F) [1];
- his spherical-Earth geometry (Earth radius E, observer and source on the sea-level sphere):
  the distance u0 below which the line of sight is still under the source's horizon, the source
  distance s, the emission angle psi and the scattering angle omega = theta + phi of each point
  of the line of sight, in the closed forms of [1, 2] (:func:`garstang_geometry`);
- his atmosphere: molecules with inverse scale height c = 0.104 km-1 (9.6 km) and sea-level
  scattering coefficient N_m0 sigma_R; aerosols with inverse scale height a = 0.657 + 0.059 K
  km-1 and scattering 11.11 K (extinction 11.778 K) times the molecular coefficient at sea level
  [1, 4] (the constants are :mod:`nightlights.sky.atmosphere`'s);
- his aerosol angular scattering function in three pieces [3]
  (:func:`nightlights.sky.atmosphere.garstang_aerosol_phase`, not a Henyey-Greenstein stand-in)
  and the Rayleigh function for molecules;
- his extinction along both legs, an exponential atmosphere integrated along a straight path
  with his second-order correction for the Earth's curvature, which keeps near-horizontal paths
  finite (:func:`garstang_path_length`) [2, 4].

The luminance is the line-of-sight integral of [1, 4] (Cinzano et al. 2000, Eqs. 3-8):

.. math::
    b = \\int_{u_0}^{u_{top}} \\left[\\beta_m(h) f_m(\\omega) + \\beta_a(h) f_a(\\omega)\\right]
        \\frac{I(\\psi)\\,\\xi_2}{s^2}\\,\\xi_1\\,du,

with beta the scattering coefficients at the height h of the point, f the angular scattering
functions [sr-1], I the emission function [cd lm-1] and xi_1, xi_2 the transmissions of the
observer's and the source's legs. It is integrated by Gauss-Legendre panels whose edges follow
the heights of the atmosphere and the closest approach of the line of sight to the source
(:func:`garstang_sky_luminance`); the kernel uses a different substitution.

What is reconstructed from restatements (Cinzano et al. 2000 [4], whose model the world atlas of
Cinzano et al. 2001 [5] uses) rather than re-read from the papers: the geometry and
extinction formulas (Cinzano et al. 2000 [4], Appendix A, Eqs. A1-A2, with the correction of the
distance s that Garstang 1989 [2], Eq. 7 gives: the angle in it is theta, not chi), the
constants of the atmosphere (Cinzano et al. 2000, Eqs. 10-14; the V-band Rayleigh cross-section
4.6e-27 cm2, the one that reproduces the 0.33 mag vertical extinction quoted for K = 1), the
aerosol function (Cinzano et al. 2000, Eq. 14) and the factor 16 / (9 pi) of the curvature
correction, which Garstang (1989) [2] writes for nearly horizontal paths as
u - (8 / 27 pi) c u^3 / E (reproduced here in that limit, see :func:`garstang_path_length`).

Against the kernel in Garstang's atmosphere and emission (``test_garstang.py``): point-source
luminance within 10 % at the zenith and 45 deg up towards the source, 1-300 km; the exponent of
a uniform lit plane's zenith glow within 0.015 for K = 0.5 and 1.

What is left out: his approximation for double scattering (a factor applied to the singly
scattered light; its published form is not restated here with enough certainty to be
reconstructed, so this module is single scattering only); the observer's and the source's
altitudes (both on the sea-level sphere here, where Garstang allows heights above sea level);
his treatment of a city as an extended source (integrate the point source over the city, as the
city-case benchmark does); and the natural sky.

References
----------
[1] Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375.
[2] Garstang, R. H. 1989, "Night-sky brightness at observatories and sites", PASP 101, 306-329.
[3] Garstang, R. H. 1991, "Dust and light pollution", PASP 103, 1109-1116.
[4] Cinzano, P., Falchi, F., Elvidge, C. D. & Baugh, K. E. 2000, "The artificial night sky
    brightness mapped from DMSP satellite Operational Linescan System measurements", MNRAS 318,
    641-657, Eqs. 3-14 and Appendix A (restatement of Garstang's model).
[5] Cinzano, P., Falchi, F. & Elvidge, C. D. 2001, "The first World Atlas of the artificial night
    sky brightness", MNRAS 328, 689-707 (the same model, used for the atlas).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.emission_functions import GARSTANG_LOBE_NORM
from nightlights.errors import InputError
from nightlights.sky.atmosphere import (
    GARSTANG_AEROSOL_EXTINCTION_RATIO,
    GARSTANG_AEROSOL_SCATTERING_RATIO,
    GARSTANG_MOLECULAR_INVERSE_SCALE_HEIGHT,
    GARSTANG_MOLECULAR_SCATTERING,
    garstang_aerosol_inverse_scale_height,
    garstang_aerosol_phase,
    rayleigh_phase,
)

__all__ = [
    "GARSTANG_EARTH_RADIUS",
    "GARSTANG_LOBE_COEFFICIENT",
    "GarstangGeometry",
    "garstang_emission_function",
    "garstang_geometry",
    "garstang_path_length",
    "garstang_sky_luminance",
    "garstang_upward_flux",
]

#: Radius of the sea-level sphere [m] (the toolkit's; Garstang's E) [1].
GARSTANG_EARTH_RADIUS = 6.371e6
#: Garstang's coefficient of the psi^4 term of his emission function, 0.554 (the reciprocal of
#: int_0^{pi/2} psi^4 sin psi dpsi = 1.80402, rounded) [1].
GARSTANG_LOBE_COEFFICIENT = 0.554
#: Factor of Garstang's curvature correction of the extinction along a path, 16 / (9 pi) [2, 4].
CURVATURE_FACTOR = 16.0 / (9.0 * math.pi)
#: The line of sight is integrated up to this many molecular scale heights (exp(-20) = 2e-9) [1].
TOP_SCALE_HEIGHTS = 20.0
#: Gauss-Legendre nodes per panel of the line of sight; 8 reach 1e-4 relative against
#: adaptive quadrature (tests) [1].
DEFAULT_NODES = 8
#: Panel edges at these heights of the line of sight [m]: the aerosol layer (scale height
#: 1.4 km at K = 1) and the molecular one (9.6 km) each get several panels.
_EDGE_HEIGHTS = np.concatenate([[0.0], np.geomspace(50.0, 190e3, 22)])
#: Panel edges at these multiples of the miss distance on both sides of the closest approach.
_EDGE_MISS = np.array([0.05, 0.15, 0.4, 1.0, 2.5, 6.0, 15.0])


def garstang_emission_function(
    cos_zenith: ArrayLike, *, upward_fraction: float = 0.15, reflectance: float = 0.15
) -> FloatArray:
    """Garstang's (1986) emission function of a city, per lumen of its luminaires' output.

    .. math::
        I(\\psi) = \\frac{1}{2\\pi}\\left[2 G (1 - F) \\cos\\psi + 0.554 F \\psi^4\\right],
        \\quad 0 \\le \\psi \\le \\pi / 2,

    psi (radians) the emission direction's angle from the local vertical; zero below the
    horizontal. The first term is the fraction 1 - F emitted downwards and reflected by a
    Lambertian ground of reflectance G; the second the fraction F emitted directly upwards,
    mostly close to the horizontal. It puts :func:`garstang_upward_flux` lumens upwards per
    lumen of output.

    Parameters
    ----------
    cos_zenith
        Cosine of the emission angle psi from the local vertical [1].
    upward_fraction
        F, the fraction of the luminaires' flux emitted directly upwards, 0 to 1 [1].
    reflectance
        G, the reflectance of the ground, 0 to 1 [1].

    Returns
    -------
    numpy.ndarray
        Intensity per lumen of the city's output [cd lm-1].

    References
    ----------
    Garstang 1986 [1]; restated by Cinzano et al. 2000 [4].

    Examples
    --------
    >>> round(float(garstang_emission_function(1.0, upward_fraction=0.0, reflectance=1.0)), 4)
    0.3183
    """
    f, g = _fractions(upward_fraction, reflectance)
    mu = np.asarray(cos_zenith, dtype=float)
    psi = np.arccos(np.clip(mu, 0.0, 1.0))
    # Garstang 1986, the emission function of a city
    value = (2.0 * g * (1.0 - f) * mu + GARSTANG_LOBE_COEFFICIENT * f * psi**4) / (2.0 * math.pi)
    return np.asarray(np.where(mu > 0.0, value, 0.0))


def garstang_upward_flux(upward_fraction: float = 0.15, reflectance: float = 0.15) -> float:
    """Upward flux of :func:`garstang_emission_function` per lumen of the city's output.

    .. math:: 2\\pi \\int_0^{\\pi/2} I(\\psi) \\sin\\psi\\,d\\psi = G (1 - F) + 0.554 F / 0.55432

    (0.55432 is the exact reciprocal of int psi^4 sin psi dpsi: Garstang's rounding makes the
    lobe carry 0.9994 F.)

    Parameters
    ----------
    upward_fraction
        F [1].
    reflectance
        G [1].

    Returns
    -------
    float
        Upward flux per lumen of output [1].

    Examples
    --------
    >>> round(garstang_upward_flux(0.15, 0.15), 4)
    0.2774
    """
    f, g = _fractions(upward_fraction, reflectance)
    return g * (1.0 - f) + GARSTANG_LOBE_COEFFICIENT * f / GARSTANG_LOBE_NORM


def _fractions(upward_fraction: float, reflectance: float) -> tuple[float, float]:
    f, g = float(upward_fraction), float(reflectance)
    if not (0.0 <= f <= 1.0 and 0.0 <= g <= 1.0) or g * (1.0 - f) + f <= 0.0:
        raise InputError(
            f"Garstang F={upward_fraction!r}, G={reflectance!r}; expected both in [0, 1] and "
            "some upward flux (F > 0 or G > 0)"
        )
    return f, g


def _moments(k: FloatArray) -> FloatArray:
    """int_0^1 x^2 exp(-k x) dx for k >= 0, without cancellation at small k."""
    k = np.asarray(k, dtype=float)
    small = k < 0.5
    ks = np.where(small, k, 0.0)
    series = np.zeros_like(ks)
    term = np.ones_like(ks)
    for n in range(14):  # sum_n (-k)^n / (n! (n + 3)); 14 terms reach 1e-16 at k = 0.5
        series += term / (n + 3)
        term = term * (-ks) / (n + 1)
    kl = np.where(small, 1.0, k)
    closed = (2.0 - (kl * kl + 2.0 * kl + 2.0) * np.exp(-kl)) / kl**3
    return np.asarray(np.where(small, series, closed))


def garstang_path_length(
    length: ArrayLike,
    cos_zenith: ArrayLike,
    inverse_scale_height: float,
    *,
    earth_radius: float = GARSTANG_EARTH_RADIUS,
) -> FloatArray:
    """Garstang's density-weighted length of a straight path from sea level.

    The integral of exp(-k h) along a path of length x leaving sea level at zenith angle z,
    with the height to second order in x over a sphere of radius E
    (h = x cos z + x^2 sin^2 z / 2E) and Garstang's factor 16 / (9 pi) on the curvature term:

    .. math::
        p = \\frac{1}{k\\cos z}\\left[1 - e^{-k x \\cos z}
            + \\frac{16\\,p_3 \\tan^2 z}{9\\pi \\cdot 2 k E}\\right],
        \\quad p_3 = (k^2 x^2 \\cos^2 z + 2 k x \\cos z + 2) e^{-k x \\cos z} - 2,

    written here as x (1 - e^{-q}) / q - (16 / 9 pi) k x^3 sin^2 z m(q) / 2E with q = k x cos z
    and m(q) = int_0^1 t^2 e^{-q t} dt, which stays finite at z = 90 deg, where it is
    Garstang's (1989) x - (8 / 27 pi) k x^3 / E. The optical depth of the path is the
    sea-level extinction coefficient times p.

    The cubic has its maximum at x* = sqrt(9 pi E / 8k) for a horizontal path, where it equals
    the exact horizontal value sqrt(pi E / 2k) (which is what the factor 16 / (9 pi) achieves);
    beyond x* it would decrease, so paths are cut at x* (a horizontal path from sea level has
    met all but a negligible part of the species by then). Against the exact straight path over
    the sphere it overestimates the column of nearly horizontal paths by up to 7.6 % (molecules,
    300 km) and is within 0.5 % from 20 deg elevation up (tests).

    Parameters
    ----------
    length
        Path length x, >= 0 [m].
    cos_zenith
        Cosine of the path's zenith angle at its start, 0 to 1 [1].
    inverse_scale_height
        k, the species' inverse scale height, > 0 [m-1].
    earth_radius
        E [m].

    Returns
    -------
    numpy.ndarray
        Density-weighted length p [m].

    References
    ----------
    Garstang 1986 [1]; Garstang 1989 [2], p. 309 (the horizontal limit); Cinzano et al. 2000
    [4], Eq. A2.

    Examples
    --------
    Vertically, the whole atmosphere is one scale height:

    >>> round(float(garstang_path_length(1e6, 1.0, 1e-4)))
    10000
    """
    k = float(inverse_scale_height)
    if not k > 0 or not earth_radius > 0:
        raise InputError(
            f"inverse scale height {inverse_scale_height!r} m-1, earth_radius {earth_radius!r} m;"
            " expected both > 0"
        )
    # beyond its maximum the cubic would fall: hold it there (see Notes)
    x = np.minimum(np.asarray(length, dtype=float), _cubic_maximum(k, earth_radius))
    mu = np.clip(np.asarray(cos_zenith, dtype=float), 0.0, 1.0)
    q = k * x * mu
    tiny = q < 1e-12
    straight = x * np.where(tiny, 1.0 - q / 2.0, -np.expm1(-q) / np.where(tiny, 1.0, q))
    curvature = CURVATURE_FACTOR * k * x**3 * (1.0 - mu * mu) * _moments(q) / (2.0 * earth_radius)
    # Cinzano 2000, Eq. A2: p1 = [1 - exp(-q) + 16 p3 tan^2 z / (9 pi 2 k E)] / (k cos z)
    return np.asarray(straight - curvature)


def _cubic_maximum(inverse_scale_height: float, earth_radius: float) -> float:
    """x* = sqrt(9 pi E / 8k), where Garstang's horizontal path length x - (8/27 pi) k x^3 / E
    peaks at the exact horizontal value sqrt(pi E / 2k) [m]."""
    return math.sqrt(9.0 * math.pi * earth_radius / (8.0 * inverse_scale_height))


@dataclass(frozen=True)
class GarstangGeometry:
    """Points of a line of sight in Garstang's geometry (:func:`garstang_geometry`).

    Attributes
    ----------
    height
        Height h of the point above the sea-level sphere [m].
    source_distance
        Straight distance s from the source to the point [m].
    cos_emission
        Cosine of the emission angle psi at the source (from its local vertical) [1].
    cos_scattering
        Cosine of the scattering angle omega = theta + phi at the point [1].
    """

    height: FloatArray
    source_distance: FloatArray
    cos_emission: FloatArray
    cos_scattering: FloatArray


def _horizon_distance(
    zenith: FloatArray, azimuth: FloatArray, chi: FloatArray, earth_radius: float
) -> FloatArray:
    """u0 of Cinzano 2000, Eq. 21: where the line of sight rises above the source's horizon."""
    denominator = np.sin(zenith) * np.cos(azimuth) * np.sin(chi) + np.cos(zenith) * np.cos(chi)
    numerator = 2.0 * earth_radius * np.sin(chi / 2.0) ** 2
    with np.errstate(divide="ignore"):
        return np.asarray(np.where(denominator > 0.0, numerator / denominator, np.inf))


def garstang_geometry(
    distance_along_sight: ArrayLike,
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    *,
    earth_radius: float = GARSTANG_EARTH_RADIUS,
) -> GarstangGeometry:
    """Garstang's spherical-Earth geometry of a point Q on the observer's line of sight.

    Observer O and source C on a sphere of radius E, a ground distance D apart
    (chi = D / E); the line of sight at zenith angle z = 90 deg - elevation and azimuth beta
    from the direction of the source; Q at distance u along it:

    .. math::
        l = 2E\\sin\\frac{\\chi}{2},\\quad
        q_1 = E(\\sin\\chi\\sin z\\cos\\beta + \\cos\\chi\\cos z - \\cos z),\\quad
        \\cos\\theta = q_1 / l,

        s^2 = (u - l)^2 + 4 u l \\sin^2\\frac{\\theta}{2},\\quad
        h = E\\left[\\sqrt{1 + (u^2 + 2 u E\\cos z)/E^2} - 1\\right],

        \\cos\\phi = \\frac{l^2 + s^2 - u^2}{2 l s},\\quad
        \\cos\\psi = \\frac{u \\sin z \\cos\\beta \\sin\\chi + u\\cos z\\cos\\chi
            - 2E\\sin^2(\\chi/2)}{s},\\quad \\omega = \\theta + \\phi.

    Parameters
    ----------
    distance_along_sight
        u, distance of Q from the observer along the line of sight, >= 0 [m].
    elevation
        Elevation of the line of sight, 0-90 [deg].
    relative_azimuth
        Azimuth of the line of sight from the direction of the source, beta [deg].
    distance
        Ground distance D from the observer to the source, > 0 [m].
    earth_radius
        E [m].

    Returns
    -------
    GarstangGeometry
        Height, source distance, cos psi and cos omega, all of the broadcast shape.

    References
    ----------
    Cinzano et al. 2000 [4], Appendix A, Eq. A1; Garstang 1989 [2], Eqs. 6-7 (s with theta).

    Examples
    --------
    Straight up from an observer 10 km from the source, 10 km up: emission at 45 deg from the
    source's vertical on a flat Earth, 0.07 deg more on the sphere (the vertical tilts by
    D / E = 0.09 deg):

    >>> g = garstang_geometry(10e3, 90.0, 0.0, 10e3)
    >>> round(float(np.degrees(np.arccos(g.cos_emission))), 2)
    45.07
    """
    u, el, az, d = np.broadcast_arrays(
        *(
            np.asarray(a, dtype=float)
            for a in (distance_along_sight, elevation, relative_azimuth, distance)
        )
    )
    e = float(earth_radius)
    z = np.radians(90.0 - el)
    beta = np.radians(az)
    chi = d / e
    sin_half = np.sin(chi / 2.0)
    chord = 2.0 * e * sin_half  # l, Cinzano 2000, Eq. A1
    q1 = e * (np.sin(chi) * np.sin(z) * np.cos(beta) + np.cos(chi) * np.cos(z) - np.cos(z))
    cos_theta = np.clip(q1 / chord, -1.0, 1.0)
    theta = np.arccos(cos_theta)
    # Garstang 1989, Eq. 7: s^2 = (u - l)^2 + 4 u l sin^2(theta / 2)
    s = np.sqrt((u - chord) ** 2 + 4.0 * u * chord * np.sin(theta / 2.0) ** 2)
    x = (u * u + 2.0 * u * e * np.cos(z)) / (e * e)
    height = e * x / (np.sqrt(1.0 + x) + 1.0)  # E (sqrt(1 + x) - 1) without cancellation
    safe_s = np.maximum(s, 1e-9)
    cos_phi = np.clip((chord**2 + s**2 - u**2) / (2.0 * chord * safe_s), -1.0, 1.0)
    omega = np.minimum(theta + np.arccos(cos_phi), math.pi)
    # Cinzano 2000, Eq. A1: q2 = u sin z cos beta sin chi + u cos z cos chi - 2 E sin^2(chi/2)
    q2 = u * np.sin(z) * np.cos(beta) * np.sin(chi) + u * np.cos(z) * np.cos(chi)
    q2 = q2 - 2.0 * e * sin_half**2
    return GarstangGeometry(
        height=np.asarray(height),
        source_distance=np.asarray(s),
        cos_emission=np.asarray(np.clip(q2 / safe_s, -1.0, 1.0)),
        cos_scattering=np.asarray(np.cos(omega)),
    )


def _panel_edges(
    zenith: FloatArray,
    azimuth: FloatArray,
    chi: FloatArray,
    earth_radius: float,
    top: float,
) -> tuple[FloatArray, FloatArray]:
    """Panel edges along each line of sight, shape (rays, edges), and the first edge u0."""
    e = earth_radius
    cos_z = np.cos(zenith)[:, None]
    heights = np.append(_EDGE_HEIGHTS[_EDGE_HEIGHTS < top], top)[None, :]
    # u at which the line of sight reaches height h over the sphere
    at_height = -e * cos_z + np.sqrt((e * cos_z) ** 2 + heights**2 + 2.0 * e * heights)
    chord = 2.0 * e * np.sin(chi / 2.0)
    q1 = e * (np.sin(chi) * np.sin(zenith) * np.cos(azimuth) + np.cos(chi) * np.cos(zenith))
    q1 = q1 - e * np.cos(zenith)
    closest = q1[:, None]  # closest approach to the source, u_c = l cos theta
    miss = np.sqrt(np.maximum(chord**2 - q1**2, 0.0))[:, None]
    near = np.concatenate([closest - miss * _EDGE_MISS, closest, closest + miss * _EDGE_MISS], 1)
    start = _horizon_distance(zenith, azimuth, chi, e)
    finite_start = np.where(np.isfinite(start), start, 0.0)[:, None]
    u_top = at_height[:, -1:]
    edges = np.concatenate([finite_start, at_height, near], 1)
    edges = np.sort(np.clip(edges, finite_start, u_top), axis=1)
    return edges, start


def garstang_sky_luminance(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    *,
    clarity: float = 1.0,
    upward_fraction: float = 0.15,
    reflectance: float = 0.15,
    extinction: bool = True,
    earth_radius: float = GARSTANG_EARTH_RADIUS,
    nodes: int = DEFAULT_NODES,
) -> FloatArray:
    """Sky luminance of Garstang's single-scattering model per lumen of a point city's output.

    The line-of-sight integral of Garstang (1986) as restated by Cinzano et al. (2000, Eqs. 3-8):

    .. math::
        b = \\int_{u_0}^{u_{top}} \\beta_{m,0}\\left[e^{-c h} f_m(\\omega)
            + 11.11 K e^{-a h} f_a(\\omega)\\right] \\frac{I(\\psi)\\,\\xi_2}{s^2}\\,\\xi_1\\,du,
        \\qquad \\xi = \\exp\\left\\{-\\beta_{m,0}\\left[p_c + 11.778 K p_a\\right]\\right\\},

    beta_m0 = N_m0 sigma_R the molecular scattering coefficient at sea level, f_m the Rayleigh
    and f_a Garstang's aerosol function (both per steradian, 1 over the sphere), I
    :func:`garstang_emission_function`, p the density-weighted lengths of
    :func:`garstang_path_length` along the observer's leg (length u, zenith angle z) for xi_1 and
    the source's leg (length s, zenith angle psi) for xi_2, c and a the inverse scale heights of
    molecules and aerosols
    (:func:`~nightlights.sky.atmosphere.garstang_aerosol_inverse_scale_height`).
    Observer and source on the sea-level sphere; single scattering only (see the module
    docstring for what is left out).

    Parameters
    ----------
    elevation
        Elevation of the line of sight, > 0 (0 or below gives 0) [deg].
    relative_azimuth
        Azimuth of the line of sight from the direction of the source [deg].
    distance
        Ground distance from the observer to the source, > 0 [m].
    clarity
        Garstang's K, >= 0 (1 = a clear night) [1].
    upward_fraction
        F of the emission function [1].
    reflectance
        G of the emission function [1].
    extinction
        Attenuate both legs (xi_1, xi_2); off sets them to 1.
    earth_radius
        Radius of the sea-level sphere [m].
    nodes
        Gauss-Legendre nodes per panel of the line of sight (about 40 panels) [1].

    Returns
    -------
    numpy.ndarray
        Luminance per lumen of the city's output (not of its upward flux: divide by
        :func:`garstang_upward_flux` for that) [cd m-2 lm-1].

    References
    ----------
    Garstang 1986 [1], 1989 [2], 1991 [3]; Cinzano et al. 2000 [4], Eqs. 3-14, A1-A2.

    Examples
    --------
    >>> b = garstang_sky_luminance(90.0, 0.0, [10e3, 50e3])
    >>> bool(b[0] > b[1] > 0)
    True
    """
    k = float(clarity)
    if not (math.isfinite(k) and k >= 0.0):
        raise InputError(f"clarity {clarity!r}; expected Garstang's K >= 0")
    if nodes < 1:
        raise InputError(f"nodes {nodes!r}; expected >= 1")
    if not earth_radius > 0:
        raise InputError(f"earth_radius {earth_radius!r} m; expected > 0")
    garstang_emission_function(1.0, upward_fraction=upward_fraction, reflectance=reflectance)
    el, az, d = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (elevation, relative_azimuth, distance))
    )
    if np.any(~np.isfinite(d)) or np.any(d <= 0):
        raise InputError("source distance; expected finite values > 0 m")
    shape = el.shape
    el, az, d = (a.ravel() for a in (el, az, d))
    out = np.zeros(el.size)
    up = el > 0.0
    if not np.any(up):
        return out.reshape(shape)
    e = float(earth_radius)
    c_mol = GARSTANG_MOLECULAR_INVERSE_SCALE_HEIGHT
    c_aer = float(garstang_aerosol_inverse_scale_height(k))
    top = TOP_SCALE_HEIGHTS / c_mol
    zenith = np.radians(90.0 - np.minimum(el[up], 90.0))
    beta = np.radians(az[up])
    chi = d[up] / e
    edges, start = _panel_edges(zenith, beta, chi, e, top)
    x_gl, w_gl = np.polynomial.legendre.leggauss(nodes)
    lo, hi = edges[:, :-1], edges[:, 1:]
    half = 0.5 * (hi - lo)
    u = (0.5 * (hi + lo))[:, :, None] + half[:, :, None] * x_gl  # (rays, panels, nodes)
    weight = half[:, :, None] * w_gl
    rays = (u.shape[0], 1, 1)
    geometry = garstang_geometry(
        u,
        90.0 - np.degrees(zenith).reshape(rays),
        np.degrees(beta).reshape(rays),
        (chi * e).reshape(rays),
        earth_radius=e,
    )
    mu_psi = geometry.cos_emission
    s = geometry.source_distance
    # Cinzano 2000, Eqs. 10-14: scattering per unit volume and steradian
    scattering = GARSTANG_MOLECULAR_SCATTERING * (
        np.exp(-c_mol * geometry.height) * rayleigh_phase(geometry.cos_scattering)
        + GARSTANG_AEROSOL_SCATTERING_RATIO
        * k
        * np.exp(-c_aer * geometry.height)
        * garstang_aerosol_phase(geometry.cos_scattering)
    )
    intensity = garstang_emission_function(
        mu_psi, upward_fraction=upward_fraction, reflectance=reflectance
    )
    integrand = scattering * intensity / np.maximum(s, 1e-9) ** 2
    if extinction:
        cos_z = np.cos(zenith).reshape(rays)
        integrand = integrand * _transmission(u, cos_z, k, c_aer, e)
        integrand = integrand * _transmission(s, np.clip(mu_psi, 0.0, 1.0), k, c_aer, e)
    integrand = np.where(np.isfinite(start).reshape(rays) & (mu_psi > 0.0), integrand, 0.0)
    out[up] = np.sum(integrand * weight, axis=(1, 2))
    return out.reshape(shape)


def _transmission(
    length: FloatArray, cos_zenith: FloatArray, clarity: float, aerosol_k: float, e: float
) -> FloatArray:
    """xi of Cinzano 2000, Eq. A2: molecules plus 11.778 K aerosols along one leg."""
    molecular = garstang_path_length(
        length, cos_zenith, GARSTANG_MOLECULAR_INVERSE_SCALE_HEIGHT, earth_radius=e
    )
    depth = molecular
    if clarity > 0.0:
        aerosol = garstang_path_length(length, cos_zenith, aerosol_k, earth_radius=e)
        depth = molecular + GARSTANG_AEROSOL_EXTINCTION_RATIO * clarity * aerosol
    return np.asarray(np.exp(-GARSTANG_MOLECULAR_SCATTERING * depth))
