"""The natural sky's own light: airglow, zodiacal light, integrated starlight and twilight.

The moonless night sky at a dark site is about 22.0 mag arcsec-2 (171 ucd m-2) at the zenith.
Its light is split here as in Schaefer's (1998) model: 60 % airglow, which brightens toward the
horizon with the longer path through its emitting layer (van Rhijn 1921, in the form of
Krisciunas & Schaefer 1991, Eq. 2), and 40 % light from beyond the atmosphere (zodiacal light
and integrated starlight), which does not. All components are dimmed by extinction relative to
the zenith over the layer's path length (Krisciunas & Schaefer 1991). The integrated starlight
follows the smoothed density of the catalogue's faint stars (:func:`starlight_density`), which
draws a Milky Way; the zodiacal light is taken uniform.
Twilight follows Schaefer's (1993, 1998) empirical fit.

Colours: the natural components are given the colour of sunlight (the zodiacal light is
sunlight scattered by dust, the integrated starlight is dominated by Sun-like stars; the
airglow's emission lines are not modelled) and the twilight and the moonlit sky that of
sunlight after Rayleigh scattering (:func:`rayleigh_sunlight_xyz`).

References
----------
1. van Rhijn, P. J. (1921). On the brightness of the sky at night and the total amount of
   starlight. Publ. Astron. Lab. Groningen 31.
2. Krisciunas, K. & Schaefer, B. E. (1991). A model of the brightness of moonlight. PASP 103,
   1033-1039, Eq. 2 (dark sky B_zen 10^(-0.4 k (X - 1)) X, X = (1 - 0.96 sin^2 Z)^(-1/2)).
3. Schaefer, B. E. (1993). Astronomy and the limits of vision. Vistas in Astronomy 36, 311-361
   (twilight brightness; dark sky as 0.4 + 0.6 van Rhijn).
4. Schaefer, B. E. (1998). To the visual limits. Sky & Telescope 95(5), 57-60, and its program
   VISLIMIT.BAS (Astronomical Computing, Sky & Telescope, May 1998): line 2150 (dark sky
   0.4 + 0.6 / sqrt(1 - 0.96 sin^2 Z)) and line 2280-2290 (twilight).
5. Kasten, F. & Young, A. T. (1989). Revised optical air mass tables and approximation formula.
   Applied Optics 28(22), 4735-4738 (the twilight's airmass, via
   :func:`nightlights.nightsky.astro.airmass`).
6. Mamajek, E. E. et al. (2015). IAU 2015 Resolution B3: nominal solar effective temperature
   5772 K.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights.brightness import NATURAL_ZENITH_MAGNITUDE, magnitude_to_luminance
from nightlights.errors import InputError

FloatArray = NDArray[np.float64]

#: Airglow share of the zenith's natural light [1] (Schaefer 1998, VISLIMIT line 2150: 0.6 of
#: the dark sky brightens by van Rhijn's factor, 0.4 does not).
AIRGLOW_FRACTION = 0.6
#: Share of the non-airglow light given to zodiacal light, the rest being integrated starlight
#: [1]. A convenience choice (the two vary with ecliptic and galactic latitude and with the
#: season), not a measured split.
ZODIACAL_SHARE = 0.5
#: 1 - (R / (R + h))^2 of the airglow layer in van Rhijn's factor [1] (Krisciunas & Schaefer
#: 1991, Eq. 2: 0.96, a layer about 130 km above a 6378 km Earth).
VAN_RHIJN_COEFFICIENT = 0.96
#: V-band extinction coefficient [mag airmass-1] (Krisciunas & Schaefer 1991: Mauna Kea 0.172).
EXTINCTION_COEFFICIENT = 0.172
#: V magnitude of the Sun [mag] (Schaefer 1998, VISLIMIT line 2060).
SUN_V_MAGNITUDE = -26.74
#: Nominal effective temperature of the Sun [K] (Mamajek et al. 2015).
SUN_TEMPERATURE = 5772.0
#: Sun elevations that bound civil, nautical and astronomical twilight [deg].
TWILIGHT_LIMITS = (0.0, -6.0, -12.0, -18.0)
#: Smoothing of the catalogue's star density: the von Mises-Fisher kernel's angular standard
#: deviation [deg]; wide enough that a 6.5 mag catalogue (about 4 stars per 100 deg^2 away
#: from the Milky Way) gives a smooth map.
STARLIGHT_SMOOTHING = 8.0
#: Only stars at least this faint enter the density [mag]: brighter stars are drawn as points.
STARLIGHT_FAINT_LIMIT = 4.5


def van_rhijn_factor(
    elevation: ArrayLike, *, coefficient: float = VAN_RHIJN_COEFFICIENT
) -> FloatArray:
    """Brightening of a thin emitting layer toward the horizon.

    .. math:: X = \\left(1 - c \\sin^2 Z\\right)^{-1/2}

    Parameters
    ----------
    elevation
        Elevation of the view direction [deg]; Z = 90 - elevation.
    coefficient
        c = 1 - (R / (R + h))^2 for Earth radius R and layer height h [1].

    Returns
    -------
    numpy.ndarray
        Path length through the layer relative to the zenith [1]; 1 at the zenith,
        1 / sqrt(1 - c) = 5 at the horizon for c = 0.96.

    References
    ----------
    van Rhijn 1921; Krisciunas & Schaefer 1991, Eq. 2.

    Examples
    --------
    >>> [round(float(v), 3) for v in van_rhijn_factor([90.0, 30.0, 0.0])]
    [1.0, 1.89, 5.0]
    """
    if not 0.0 <= coefficient < 1.0:
        raise InputError(f"van Rhijn coefficient {coefficient}: expected 0 <= c < 1")
    zenith_angle = np.radians(90.0 - np.clip(np.asarray(elevation, dtype=float), 0.0, 90.0))
    return 1.0 / np.sqrt(1.0 - coefficient * np.sin(zenith_angle) ** 2)


def extinction_relative_to_zenith(
    elevation: ArrayLike,
    *,
    extinction_coefficient: float = EXTINCTION_COEFFICIENT,
    coefficient: float = VAN_RHIJN_COEFFICIENT,
) -> FloatArray:
    """Transmission of the diffuse night sky's light relative to the zenith.

    .. math:: T = 10^{-0.4 k (X - 1)},\\quad X = \\left(1 - 0.96 \\sin^2 Z\\right)^{-1/2}

    Krisciunas & Schaefer take the path length X of the emitting layer here too, not the
    airmass of a star: the light of the sky near the horizon is emitted along the line of
    sight, much of it close to the observer, and does not cross the whole horizontal airmass.

    Parameters
    ----------
    elevation
        Elevation [deg], at least 0.
    extinction_coefficient
        k [mag airmass-1].
    coefficient
        van Rhijn's coefficient, see :func:`van_rhijn_factor` [1].

    Returns
    -------
    numpy.ndarray
        Relative transmission [1]: 1 at the zenith, 10^(-1.6 k) at the horizon.

    References
    ----------
    Krisciunas & Schaefer 1991, Eq. 2.
    """
    if extinction_coefficient < 0:
        raise InputError(
            f"extinction coefficient {extinction_coefficient}: expected >= 0 [mag airmass-1]"
        )
    x = van_rhijn_factor(elevation, coefficient=coefficient)
    return 10.0 ** (-0.4 * extinction_coefficient * (x - 1.0))


def starlight_density(
    star_elevation: ArrayLike,
    star_azimuth: ArrayLike,
    elevation: ArrayLike,
    azimuth: ArrayLike,
    *,
    smoothing: float = STARLIGHT_SMOOTHING,
    grid_step: float = 4.0,
) -> FloatArray:
    """Smoothed number density of stars relative to its mean over the whole sky [1].

    The density is a sum of von Mises-Fisher kernels (the spherical Gaussian) at the stars,
    evaluated on a grid of ``grid_step`` and interpolated bilinearly to the directions asked for:

    .. math::
        n(\\hat u) = \\sum_i \\frac{\\kappa}{4\\pi \\sinh\\kappa}
        e^{\\kappa \\hat u \\cdot \\hat s_i},\\quad \\kappa = 1 / \\sigma^2,\\quad
        \\text{result} = n / (N / 4\\pi)

    Parameters
    ----------
    star_elevation, star_azimuth
        Positions of the stars over the whole sphere, also below the horizon [deg].
    elevation, azimuth
        Directions where the density is wanted, elevation 0-90 [deg].
    smoothing
        Kernel's angular standard deviation sigma [deg].
    grid_step
        Spacing of the evaluation grid [deg]; a few times smaller than ``smoothing``.

    Returns
    -------
    numpy.ndarray
        Density relative to the all-sky mean [1], shape of ``elevation``; 1 for no stars.
    """
    if not smoothing > 0 or not grid_step > 0:
        raise InputError(f"smoothing {smoothing}, grid step {grid_step}: expected > 0 [deg]")
    star_el = np.radians(np.asarray(star_elevation, dtype=float).ravel())
    star_az = np.radians(np.asarray(star_azimuth, dtype=float).ravel())
    el = np.asarray(elevation, dtype=float)
    az = np.asarray(azimuth, dtype=float)
    if star_el.size == 0:
        return np.ones(np.broadcast(el, az).shape)
    kappa = 1.0 / np.radians(smoothing) ** 2
    grid_el = np.linspace(0.0, 90.0, int(np.ceil(90.0 / grid_step)) + 1)
    grid_az = np.linspace(0.0, 360.0, int(np.ceil(360.0 / grid_step)) + 1)
    gel, gaz = np.meshgrid(np.radians(grid_el), np.radians(grid_az), indexing="ij")
    # Stars more than 5 sigma below the horizon add less than e^-12.5 to any node.
    near = star_el > -5.0 * np.radians(smoothing)
    # kappa / (4 pi sinh kappa) e^(kappa cos)
    #   = kappa / (2 pi (1 - e^(-2 kappa))) e^(kappa (cos - 1)),
    # the exponent kappa (u . s - 1) as one product: (kappa u, -kappa) . (s, 1)
    nodes = np.hstack(
        [kappa * _unit_vectors(gel.ravel(), gaz.ravel()), np.full((gel.size, 1), -kappa)]
    ).astype(np.float32)
    stars = np.hstack(
        [_unit_vectors(star_el[near], star_az[near]), np.ones((int(near.sum()), 1))]
    ).astype(np.float32)
    exponent = nodes @ stars.T
    kernel = np.exp(exponent, out=exponent).sum(axis=1, dtype=np.float64)
    density = kernel * kappa / (2.0 * np.pi * (1.0 - np.exp(-2.0 * kappa)))
    relative = (density / (star_el.size / (4.0 * np.pi))).reshape(gel.shape)
    from scipy.ndimage import map_coordinates

    rows = (np.clip(el, 0.0, 90.0) - grid_el[0]) / (grid_el[1] - grid_el[0])
    cols = np.mod(az, 360.0) / (grid_az[1] - grid_az[0])
    return np.asarray(
        map_coordinates(relative, [rows.ravel(), cols.ravel()], order=1, mode="nearest"),
        dtype=float,
    ).reshape(np.broadcast(el, az).shape)


def _unit_vectors(elevation: FloatArray, azimuth: FloatArray) -> FloatArray:
    """(n, 3) unit vectors (east, north, up) of directions given in radians."""
    cos_el = np.cos(elevation)
    return np.stack([cos_el * np.sin(azimuth), cos_el * np.cos(azimuth), np.sin(elevation)], -1)


@dataclass(frozen=True)
class NaturalSky:
    """Parameters of the moonless natural night sky.

    Attributes
    ----------
    zenith_magnitude
        Zenith brightness with the integrated starlight at its all-sky mean [mag arcsec-2].
    airglow_fraction
        Share of the zenith light from airglow [1].
    zodiacal_share
        Share of the rest given to zodiacal light; the remainder is integrated starlight [1].
    extinction_coefficient
        V-band extinction [mag airmass-1].
    van_rhijn_coefficient
        See :func:`van_rhijn_factor` [1].
    """

    zenith_magnitude: float = NATURAL_ZENITH_MAGNITUDE
    airglow_fraction: float = AIRGLOW_FRACTION
    zodiacal_share: float = ZODIACAL_SHARE
    extinction_coefficient: float = EXTINCTION_COEFFICIENT
    van_rhijn_coefficient: float = VAN_RHIJN_COEFFICIENT

    def __post_init__(self) -> None:
        for name in ("airglow_fraction", "zodiacal_share"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise InputError(f"{name} {value}: expected a fraction in [0, 1]")
        if not np.isfinite(self.zenith_magnitude):
            raise InputError(f"zenith magnitude {self.zenith_magnitude}: expected a number")


def natural_sky_luminance(
    elevation: ArrayLike,
    *,
    starlight: ArrayLike = 1.0,
    sky: NaturalSky | None = None,
) -> dict[str, FloatArray]:
    """Luminance of the moonless natural sky by component.

    .. math::
        L = L_z \\, 10^{-0.4 k (X - 1)} \\left[f_a V(Z) + (1 - f_a)
        \\left(f_z + (1 - f_z) \\rho\\right)\\right]

    with L_z the zenith luminance of ``zenith_magnitude``, V van Rhijn's factor, X the airmass,
    f_a the airglow fraction, f_z the zodiacal share and rho the relative star density.

    Parameters
    ----------
    elevation
        Elevation of the view directions [deg].
    starlight
        Relative density of the integrated starlight, :func:`starlight_density` [1].
    sky
        Parameters (default ``NaturalSky()``).

    Returns
    -------
    dict
        ``airglow``, ``zodiacal_light``, ``starlight`` and ``total`` luminance [cd m-2].

    References
    ----------
    Krisciunas & Schaefer 1991, Eq. 2; Schaefer 1998 (VISLIMIT line 2150).

    Examples
    --------
    >>> parts = natural_sky_luminance([90.0])
    >>> round(float(parts["total"][0] * 1e6), 1)  # 22.0 mag arcsec-2 [ucd m-2]
    171.2
    """
    sky = sky if sky is not None else NaturalSky()
    el = np.asarray(elevation, dtype=float)
    zenith = float(magnitude_to_luminance(sky.zenith_magnitude))
    transmission = extinction_relative_to_zenith(
        el,
        extinction_coefficient=sky.extinction_coefficient,
        coefficient=sky.van_rhijn_coefficient,
    )
    beyond = zenith * (1.0 - sky.airglow_fraction) * transmission
    parts = {
        "airglow": zenith
        * sky.airglow_fraction
        * transmission
        * van_rhijn_factor(el, coefficient=sky.van_rhijn_coefficient),
        "zodiacal_light": beyond * sky.zodiacal_share,
        "starlight": beyond * (1.0 - sky.zodiacal_share) * np.asarray(starlight, dtype=float),
    }
    parts["total"] = parts["airglow"] + parts["zodiacal_light"] + parts["starlight"]
    return parts


def schaefer_twilight(
    elevation: ArrayLike,
    azimuth: ArrayLike,
    sun_elevation: float,
    sun_azimuth: float,
    *,
    extinction_coefficient: float = EXTINCTION_COEFFICIENT,
    sun_magnitude: float = SUN_V_MAGNITUDE,
) -> FloatArray:
    """Luminance of the twilight sky with the Sun below the horizon.

    .. math::
        m = m_\\odot + 32.5 - h_\\odot - \\frac{Z}{360 k}
        - 2.5 \\log_{10}\\left[\\frac{100}{\\rho}\\left(1 - 10^{-0.4 k X}\\right)\\right]

    in V mag arcsec-2, with h the Sun's elevation [deg] (negative), Z the zenith angle of the
    view [deg], rho its angular distance from the Sun [deg] (at least 1) and X its airmass:
    the sky fades by one magnitude per degree of solar depression and is brightest toward the
    Sun. Beyond astronomical twilight (h < -18 deg) it falls below 1 % of the dark sky.

    Parameters
    ----------
    elevation, azimuth
        View directions [deg].
    sun_elevation, sun_azimuth
        The Sun's apparent position [deg]; the elevation must be below 0.
    extinction_coefficient
        k [mag airmass-1].
    sun_magnitude
        V magnitude of the Sun [mag].

    Returns
    -------
    numpy.ndarray
        Twilight luminance [cd m-2].

    References
    ----------
    Schaefer 1993; Schaefer 1998 (VISLIMIT lines 2270-2290). The airmass is Kasten & Young's
    (1989) in place of the program's own fit.

    Examples
    --------
    >>> # zenith, Sun 6 deg below the horizon (end of civil twilight) [mag arcsec-2]
    >>> from nightlights.brightness import luminance_to_magnitude
    >>> m = luminance_to_magnitude(schaefer_twilight([90.0], [0.0], -6.0, 180.0))
    >>> round(float(m[0]), 1)
    13.8
    """
    from nightlights.nightsky.astro import airmass

    if not sun_elevation < 0.0:
        raise InputError(
            f"Sun elevation {sun_elevation:.2f} deg: the twilight model needs the Sun below the "
            "horizon (daylight is not modelled)"
        )
    if not extinction_coefficient > 0:
        raise InputError(
            f"extinction coefficient {extinction_coefficient}: expected > 0 [mag airmass-1]"
        )
    el = np.clip(np.asarray(elevation, dtype=float), 0.0, 90.0)
    az = np.asarray(azimuth, dtype=float)
    rho = np.degrees(
        np.arccos(
            np.clip(_cos_separation(el, az, float(sun_elevation), float(sun_azimuth)), -1.0, 1.0)
        )
    )
    rho = np.maximum(rho, 1.0)
    zenith_angle = 90.0 - el
    x = np.asarray(airmass(el), dtype=float)
    magnitude = (
        sun_magnitude
        + 32.5
        - sun_elevation
        - zenith_angle / (360.0 * extinction_coefficient)
        - 2.5 * np.log10((100.0 / rho) * (1.0 - 10.0 ** (-0.4 * extinction_coefficient * x)))
    )
    return np.asarray(magnitude_to_luminance(magnitude), dtype=float)


def _cos_separation(el1: FloatArray, az1: FloatArray, el2: float, az2: float) -> FloatArray:
    """Cosine of the angle between two horizontal directions given in degrees."""
    e1, e2 = np.radians(el1), np.radians(el2)
    return np.sin(e1) * np.sin(e2) + np.cos(e1) * np.cos(e2) * np.cos(np.radians(az1 - az2))


def twilight_phase(sun_elevation: float) -> str:
    """Name of the sky's phase by the Sun's elevation.

    Parameters
    ----------
    sun_elevation
        The Sun's elevation [deg].

    Returns
    -------
    str
        ``day``, ``civil twilight`` (0 to -6 deg), ``nautical twilight`` (-6 to -12),
        ``astronomical twilight`` (-12 to -18) or ``night``.

    Examples
    --------
    >>> twilight_phase(-3.0), twilight_phase(-20.0)
    ('civil twilight', 'night')
    """
    if sun_elevation >= TWILIGHT_LIMITS[0]:
        return "day"
    names = ("civil twilight", "nautical twilight", "astronomical twilight")
    for name, lower in zip(names, TWILIGHT_LIMITS[1:], strict=True):
        if sun_elevation >= lower:
            return name
    return "night"


@functools.cache
def rayleigh_sunlight_xyz() -> FloatArray:
    """XYZ (Y = 1) of sunlight after Rayleigh scattering: a 5772 K blackbody times lambda^-4.

    Returns
    -------
    numpy.ndarray
        ``(3,)`` tristimulus values with Y = 1 (CIE 1931 2-degree observer, 360-830 nm).
    """
    from ies.spectra import colour_science

    colour = colour_science()

    shape = colour.SpectralShape(360, 830, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    sd = colour.sd_blackbody(SUN_TEMPERATURE, shape)
    wavelengths = np.asarray(sd.wavelengths, dtype=float)
    scattered = colour.SpectralDistribution(
        np.asarray(sd.values, dtype=float) * (550.0 / wavelengths) ** 4, wavelengths
    )
    xyz = np.asarray(colour.sd_to_XYZ(scattered, cmfs, method="Integration"), dtype=float)
    return xyz / xyz[1]
