"""The artificial sky under a cloud deck: an analytic model, separate from the clear sky.

A cloud layer (:class:`CloudLayer`) is a horizontal, horizontally uniform deck whose base lies
at height H above the ground (flat, plane-parallel geometry below the base; the clear-sky
kernel's spherical Earth is not used here). Below the base the air is the clear sky's
two-species atmosphere. The luminance an observer on the ground sees at elevation e, per lumen
of a ground source at distance r, is the sum of three terms:

1. the single scattering of the source's light by the air below the base, the clear sky's
   line-of-sight integral (Dobashi et al. 2023, Eqs. 1-2; :mod:`nightlights.sky.kernel`) with
   the ray stopped at the base, u_b = H / sin e;
2. the cloud base seen through the air below it: a Lambertian reflector of exitance M_c at the
   point P_b where the ray meets the base,

   .. math::
       b_2 = \\frac{M_c(\\rho_b)}{\\pi} e^{-\\tau_H / \\sin e};

3. the diffuse light of the cloud base (radiance M_c / pi, downwards) and of the ground it
   lights (radiance A_g E_g / pi, upwards) scattered once by the air towards the observer,
   each treated as a uniform hemisphere of the radiance above (below) the ray point:

   .. math::
       b_3 = \\int_0^{u_b} \\sum_s \\sigma_s(z) \\left[\\frac{M_c}{\\pi} P_s^{\\downarrow}(e)
           + \\frac{A_g E_g}{\\pi} P_s^{\\uparrow}(e)\\right] e^{-\\tau(O \\to P)} du,

   with P_s the share of the species' phase function over the hemisphere of incoming
   directions (a project choice; the source function of a diffuse field, Chandrasekhar 1960,
   Ch. I).

The cloud-base exitance M_c follows from the irradiance the source puts on the base through
the air below it (direct transmission, slant optical depth tau_H d / H on a flat layer),
reflected with the deck's reflectance R, plus the ground-cloud multiple reflections: the ground
(albedo A_g) reflects what the cloud sends down, and each pass between the two planes is the
Lambertian transfer kernel K. In the Fourier domain (2-D, radial functions):

.. math::
    E_d(\\rho) = I(\\cos\\theta) \\frac{\\cos\\theta}{d^2} e^{-\\tau_H d / H}, \\quad
    K(\\rho) = \\frac{H^2}{\\pi d^4} e^{-\\tau_H d / H}, \\quad d^2 = \\rho^2 + H^2,

    \\hat M_c = \\frac{R \\hat E_d}{1 - R A_g \\hat K^2}, \\qquad \\hat E_g = \\hat K \\hat M_c.

Over a uniform emitting plane (k = 0, K integrates to the diffuse transmittance
t = 2 E_3(tau_H)) this is the geometric series M_c = R t F / (1 - R A_g t^2), which tends to
1 / (1 - A_g R) for clear air (Kocifaj 2014's ground-cloud reflections; ILLUMINA reflects the
light once on the cloud base, Aube et al. 2005, Aube & Simoneau 2018).

The deck's reflectance R and transmittance T come either from an ``albedo`` (R = albedo,
T = 1 - R: a non-absorbing deck) or from its optical depth tau_c by the two-stream relation for
a conservative layer (Bohren 1987):

.. math::
    R = \\frac{(1 - g)\\tau_c}{2 + (1 - g)\\tau_c}, \\qquad T = 1 - R,

with the asymmetry g = 0.85 of water clouds. The light the deck transmits leaves the model (the
air above the deck is not modelled; what it would send back is dimmed by T again).

Partial cover c is a cover-weighted mix: L = (1 - c) L_clear + c L_cloudy. The natural sky is
dimmed by the cover, 1 - c (1 - T) for its diffuse part (the deck passes T of it) and 1 - c for
the stars and the Moon (hidden): :meth:`CloudLayer.natural_sky_factor`,
:meth:`CloudLayer.stars_factor`.

Approximations (own choices): the air below the base scatters once (terms 1 and 3); the
reflected light is attenuated on the direct path only between the planes (what the air
scatters out of the reflected beams comes back in term 3 for the observer's ray but not in the
next reflection); the deck is uniform (a cover raster is read at the observer); the geometry is
flat (the Earth's drop, 196 m at 50 km, is ignored under the deck). The Monte Carlo of
:mod:`nightlights.sky.clouds_montecarlo` treats every order and checks these.

Length: about 790 lines, because the deck, its reflection profiles, the three luminance terms
and the disc quadrature that the tests and the benchmark read them through are one model, read
together; the Monte Carlo that checks it is its own module.

References
----------
[1] Kocifaj, M. 2014, "Modelling the spectral behaviour of night skylight close to artificial
    light sources", MNRAS 439, 3405-3413 (the cloudy sky's radiance from ground sources and
    ground-cloud reflections).
[2] Kocifaj, M. & Solano Lamphar, H. A. 2014, "Quantitative analysis of night skyglow amplified
    by cloudy sky", MNRAS 443, 3665-3674 (amplification larger towards the city's edge).
[3] Solano Lamphar, H. A. & Kocifaj, M. 2016, "Urban night-sky luminance due to different
    cloud types: A numerical experiment", Lighting Res. Technol. 48, 1017-1033.
[4] Aube, M., Franchomme-Fosse, L., Robert-Staehler, P. & Houle, V. 2005, "Light pollution
    modelling and detection in a heterogeneous environment", Proc. SPIE 5982 (ILLUMINA), and
    Aube, M. & Simoneau, A. 2018, "New features to the night sky radiance model ILLUMINA",
    JQSRT 211, 25-34 (cloud reflection by the cloud base).
[5] Bohren, C. F. 1987, "Multiple scattering of light and some of its observable
    consequences", Am. J. Phys. 55, 524-533 (two-stream reflectance of a conservative layer).
[6] Chandrasekhar, S. 1960, "Radiative Transfer", Dover, Ch. I (source function).
[7] Kyba, C. C. M., Ruhtz, T., Fischer, J. & Hoelker, F. 2011, "Cloud coverage acts as an
    amplifier for ecological light pollution in urban ecosystems", PLoS ONE 6, e17307; Jechow,
    A. et al. 2017, "Imaging and mapping the impact of clouds on skyglow with all-sky
    photometry", Sci. Rep. 7, 6741 (measured amplification).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import expn

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere, henyey_greenstein_phase, rayleigh_phase
from nightlights.sky.quadrature import gauss_legendre, tangent_panel_nodes

__all__ = [
    "CLOUD_ASYMMETRY",
    "CloudLayer",
    "CloudProfiles",
    "cloud_luminance",
    "cloud_profiles",
    "disc_luminance",
    "flux_budget",
    "forward_share",
    "hemisphere_phase",
    "transport_depth",
    "two_stream_reflectance",
]

#: Asymmetry of water-cloud droplets in the visible (Bohren 1987) [1].
CLOUD_ASYMMETRY = 0.85
#: Default optical depth of the deck, a stratus deck (Solano Lamphar & Kocifaj 2016 use 5-50
#: for their cloud types) [1].
DEFAULT_CLOUD_OPTICAL_DEPTH = 15.0
#: Albedo of the ground for the light the deck sends back down (grass, asphalt, roofs:
#: 0.1-0.2; the emission stage's default reflectance) [1].
DEFAULT_GROUND_ALBEDO = 0.15
#: Grid of the bounce convolution: cells per base height, and half-width in base heights [1].
GRID_CELLS_PER_HEIGHT = 8  # 0.2 % error against 32 (benchmarks/bench_sky_clouds_knobs.py)
GRID_HALF_WIDTH_HEIGHTS = 40.0
#: Largest side of the bounce grid [cells].
GRID_MAX_CELLS = 2048

Intensity = Callable[[FloatArray], FloatArray]


def _lambertian(cos_zenith: FloatArray) -> FloatArray:
    return np.where(cos_zenith > 0, cos_zenith / np.pi, 0.0)


def two_stream_reflectance(optical_depth: ArrayLike, asymmetry: float = CLOUD_ASYMMETRY) -> Any:
    """Reflectance of a conservative (non-absorbing) layer, two-stream.

    .. math:: R = (1 - g)\\tau / (2 + (1 - g)\\tau)

    Parameters
    ----------
    optical_depth
        Vertical optical depth of the layer [1].
    asymmetry
        Asymmetry parameter g of its scatterers [1].

    Returns
    -------
    numpy.ndarray
        Reflectance [1]; the transmittance is 1 - R.

    References
    ----------
    Bohren 1987 [5].

    Examples
    --------
    >>> round(float(two_stream_reflectance(10.0, 0.85)), 4)
    0.4286
    """
    x = (1.0 - asymmetry) * np.asarray(optical_depth, dtype=float)
    return x / (2.0 + x)


@dataclass(frozen=True)
class CloudLayer:
    """A horizontal cloud deck over the scene.

    Parameters
    ----------
    base_height
        Height of the cloud base above the ground (the observer's ground over a DEM) [m].
    optical_depth
        Vertical optical depth of the deck, for its two-stream reflectance [1].
    albedo
        Reflectance of the cloud base; overrides ``optical_depth`` (T = 1 - albedo) [1].
    cover
        Cloud cover fraction, 0 (clear) to 1 (overcast) [1].
    cover_raster
        Cloud cover fraction per cell (a raster or its path); the stages read it at the
        observer and it replaces ``cover`` there [1].
    ground_albedo
        Albedo of the ground for the light the deck sends down [1].
    asymmetry
        Asymmetry g of the droplets for the two-stream reflectance [1].
    """

    base_height: float
    optical_depth: float = DEFAULT_CLOUD_OPTICAL_DEPTH
    albedo: float | None = None
    cover: float = 1.0
    cover_raster: Any = None
    ground_albedo: float = DEFAULT_GROUND_ALBEDO
    asymmetry: float = CLOUD_ASYMMETRY

    def __post_init__(self) -> None:
        if not (np.isfinite(self.base_height) and self.base_height > 0):
            raise InputError(f"base_height={self.base_height!r}; expected a height > 0 [m]")
        if not (np.isfinite(self.optical_depth) and self.optical_depth >= 0):
            raise InputError(f"optical_depth={self.optical_depth!r}; expected a number >= 0")
        for name in ("albedo", "ground_albedo", "cover"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value <= 1.0:
                raise InputError(f"{name}={value!r}; expected a fraction from 0 to 1")
        if not -1.0 < self.asymmetry < 1.0:
            raise InputError(f"asymmetry={self.asymmetry!r}; expected -1 < g < 1")

    @property
    def reflectance(self) -> float:
        """Reflectance R of the cloud base [1]."""
        if self.albedo is not None:
            return float(self.albedo)
        return float(two_stream_reflectance(self.optical_depth, self.asymmetry))

    @property
    def transmittance(self) -> float:
        """Transmittance T = 1 - R of the (non-absorbing) deck [1]."""
        return 1.0 - self.reflectance

    def check_terrain(self, ground_altitude: float, terrain_altitude: float) -> None:
        """Refuse a deck whose base lies at or below the terrain somewhere in the scene.

        Parameters
        ----------
        ground_altitude
            Altitude of the ground under the observer, where the base height is counted [m].
        terrain_altitude
            Highest terrain altitude in the scene [m].

        Raises
        ------
        InputError
            The base (``ground_altitude + base_height``) is not above ``terrain_altitude``.
        """
        base = ground_altitude + self.base_height
        if not base > terrain_altitude:
            raise InputError(
                f"base_height {self.base_height!r} m puts the cloud base at {base:.0f} m, at or "
                f"below the terrain ({terrain_altitude:.0f} m); expected a base above the terrain"
            )

    def natural_sky_factor(self, cover: float | None = None) -> float:
        """Factor on the natural sky's diffuse light: 1 - c (1 - T) [1]."""
        c = self.cover if cover is None else cover
        return 1.0 - c * (1.0 - self.transmittance)

    def stars_factor(self, cover: float | None = None) -> float:
        """Factor on the stars and the Moon (hidden by the cloudy part): 1 - c [1]."""
        return 1.0 - (self.cover if cover is None else cover)


def _species(atmosphere: Atmosphere, ground_altitude: float) -> list[tuple[float, float, str]]:
    """(scattering coefficient at the ground [m-1], scale height [m], phase) per species."""
    out = []
    if atmosphere.molecular_extinction > 0:
        h = atmosphere.molecular_scale_height
        out.append((atmosphere.molecular_extinction * np.exp(-ground_altitude / h), h, "m"))
    if atmosphere.aerosol_extinction > 0:
        h = atmosphere.aerosol_scale_height
        out.append((atmosphere.aerosol_extinction * np.exp(-ground_altitude / h), h, "a"))
    return out


def _layer_depth(atmosphere: Atmosphere, z: FloatArray, ground_altitude: float) -> FloatArray:
    """Vertical optical depth from the ground to height z [1] (0 without extinction)."""
    z = np.asarray(z, dtype=float)
    if not atmosphere.extinction:
        return np.zeros_like(z)
    tau = np.zeros_like(z)
    for beta, h, _ in _species(atmosphere, ground_altitude):
        tau = tau - beta * h * np.expm1(-z / h)
    return tau


def forward_share(asymmetry: float) -> float:
    """Share of a Henyey-Greenstein phase function in the forward hemisphere [1].

    .. math:: f = \\frac{1 + g}{2 g} - \\frac{1 - g^2}{2 g \\sqrt{1 + g^2}}

    (1/2 for g = 0, as for Rayleigh scattering.)

    Examples
    --------
    >>> round(forward_share(0.7), 3), forward_share(0.0)
    (0.916, 0.5)
    """
    g = float(asymmetry)
    if abs(g) < 1e-9:
        return 0.5
    return (1.0 + g) / (2.0 * g) - (1.0 - g * g) / (2.0 * g * math.sqrt(1.0 + g * g))


def transport_depth(atmosphere: Atmosphere, z: float, ground_altitude: float = 0.0) -> float:
    """Optical depth from the ground to z for the light between the ground and the deck.

    Each species' depth scaled by 1 - omega f, f its forward-hemisphere share: light scattered
    forwards is kept in the beam (the idea of the delta-scaling of Joseph et al. 1976, with the
    hemisphere share for f, a project choice checked against the Monte Carlo).

    Parameters
    ----------
    atmosphere
        The air below the base.
    z
        Height above the ground [m].
    ground_altitude
        Altitude of the ground [m].

    Returns
    -------
    float
        Scaled optical depth [1].
    """
    if not atmosphere.extinction:
        return 0.0
    tau = 0.0
    for beta, h, key in _species(atmosphere, ground_altitude):
        if key == "a":
            keep = 1.0 - atmosphere.aerosol_albedo * forward_share(atmosphere.asymmetry)
        else:
            keep = 0.5
        tau += keep * beta * h * -np.expm1(-z / h)
    return float(tau)


def _mean_extinction(
    atmosphere: Atmosphere, z1: FloatArray, z2: FloatArray, ground_altitude: float
) -> FloatArray:
    """Mean extinction coefficient between heights z1 and z2 (a straight chord's) [m-1]."""
    z1, z2 = np.broadcast_arrays(np.asarray(z1, dtype=float), np.asarray(z2, dtype=float))
    dz = z2 - z1
    small = np.abs(dz) < 1e-6
    safe = np.where(small, 1.0, dz)
    out = np.zeros(z1.shape)
    if not atmosphere.extinction:
        return out
    for beta, h, _ in _species(atmosphere, ground_altitude):
        mean = np.where(
            small,
            np.exp(-0.5 * (z1 + z2) / h),
            -h * np.exp(-z1 / h) * np.expm1(-dz / h) / safe,
        )
        out = out + beta * mean
    return out


def _scattering(
    atmosphere: Atmosphere, z: FloatArray, cos_angle: FloatArray, ground_altitude: float
) -> FloatArray:
    """sigma_s p summed over the species at height z above the ground [m-1 sr-1]."""
    return np.asarray(atmosphere.scattering(np.asarray(z) + ground_altitude, cos_angle))


def hemisphere_phase(atmosphere: Atmosphere, elevation: ArrayLike, *, nodes: int = 24) -> Any:
    """Share of each species' phase function over the incoming hemispheres of a view ray.

    For light reaching an observer who looks at elevation e (light travelling along -v), the
    integral of the phase function p(omega' . (-v)) over the directions omega' travelling
    downwards (light from above) and upwards (light from below).

    Parameters
    ----------
    atmosphere
        Atmosphere (its molecular phase and aerosol asymmetry).
    elevation
        Elevation of the view ray [deg].
    nodes
        Gauss-Legendre nodes in the cosine and in the azimuth [1].

    Returns
    -------
    dict
        ``{"m": (down, up), "a": (down, up)}`` arrays shaped as ``elevation`` [1].

    Examples
    --------
    >>> p = hemisphere_phase(Atmosphere(), 90.0)
    >>> [round(float(v), 3) for v in p["m"]]
    [0.5, 0.5]
    """
    el = np.radians(np.asarray(elevation, dtype=float))
    x, w = gauss_legendre(nodes)
    mu = 0.5 * (x + 1.0)  # |cos| of the incoming direction
    w_mu = 0.5 * w
    phi = np.pi * (x + 1.0)
    w_phi = np.pi * w
    out: dict[str, tuple[FloatArray, FloatArray]] = {}
    view_z = -np.sin(el)[..., None, None]  # light travels along -v
    view_h = np.cos(el)[..., None, None]
    for key in ("m", "a"):
        parts = []
        for sign in (-1.0, 1.0):  # light travelling down (from above), up (from below)
            mz = sign * mu[:, None]
            sin_t = np.sqrt(1.0 - mu[:, None] ** 2)
            cos_angle = mz * view_z - sin_t * np.cos(phi)[None, :] * view_h
            if key == "m":
                p = rayleigh_phase(cos_angle)
                if atmosphere.molecular_phase != "rayleigh":
                    p = np.full(cos_angle.shape, 1.0 / (4.0 * np.pi))
            else:
                p = henyey_greenstein_phase(cos_angle, atmosphere.asymmetry)
            parts.append(np.einsum("...ij,i,j->...", p, w_mu, w_phi))
        out[key] = (parts[0], parts[1])
    return out


@dataclass(frozen=True)
class CloudProfiles:
    """Radial profiles around a unit point source under a deck (per lumen emitted).

    Attributes
    ----------
    rho
        Ground distance from the source [m].
    direct
        Irradiance of the cloud base by the source's direct light [lm m-2 lm-1].
    exitance
        Exitance M_c of the cloud base, all ground-cloud reflections [lm m-2 lm-1].
    ground
        Irradiance E_g of the ground by the deck's light, all reflections [lm m-2 lm-1].
    height
        Base height H [m].
    optical_depth
        Vertical optical depth of the air below the base tau_H [1].
    transport_depth
        The same scaled for the light between the ground and the deck
        (:func:`transport_depth`) [1].
    """

    rho: FloatArray
    direct: FloatArray
    exitance: FloatArray
    ground: FloatArray
    height: float
    optical_depth: float
    transport_depth: float

    def at(self, rho: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Exitance and ground irradiance at distances ``rho`` [m].

        Beyond the grid both continue the last grid value with the Lambertian far field,
        (d_last / d)^4 exp(-tau_t (d - d_last) / H), d the slant distance to the base.
        """
        r = np.asarray(rho, dtype=float)
        m = np.interp(r, self.rho, self.exitance)
        g = np.interp(r, self.rho, self.ground)
        h = self.height
        d_last = np.hypot(self.rho[-1], h)
        d = np.hypot(r, h)
        tail = (d_last / d) ** 4 * np.exp(-self.transport_depth * (d - d_last) / h)
        beyond = r > self.rho[-1]
        return np.where(beyond, self.exitance[-1] * tail, m), np.where(
            beyond, self.ground[-1] * tail, g
        )


def _direct_irradiance(
    rho: FloatArray, height: float, tau: float, intensity: Intensity
) -> FloatArray:
    d = np.hypot(rho, height)
    cos = height / d
    return np.asarray(intensity(cos)) * cos / d**2 * np.exp(-tau * d / height)


def cloud_profiles(
    cloud: CloudLayer,
    atmosphere: Atmosphere,
    *,
    intensity: Intensity | None = None,
    ground_altitude: float = 0.0,
    half_width: float | None = None,
    cells_per_height: int = GRID_CELLS_PER_HEIGHT,
) -> CloudProfiles:
    """Cloud-base exitance and ground irradiance around a unit point source, all reflections.

    The ground-cloud series is summed in the 2-D Fourier domain on a periodic grid (spacing
    H / ``cells_per_height``, half-width ``half_width``); the transfer kernel K is scaled to its
    exact integral 2 E_3(tau_H) so that the grid conserves flux.

    Parameters
    ----------
    cloud
        The deck.
    atmosphere
        The air below the base.
    intensity
        Emission intensity per lumen against the cosine of the zenith angle [cd lm-1];
        None: Lambertian.
    ground_altitude
        Altitude of the ground [m].
    half_width
        Half-width of the grid [m]; None: 40 base heights.
    cells_per_height
        Grid cells per base height [1].

    Returns
    -------
    CloudProfiles
        The radial profiles on the grid's axis.

    Examples
    --------
    >>> p = cloud_profiles(CloudLayer(1000.0, albedo=1.0, ground_albedo=0.0), Atmosphere())
    >>> bool(p.exitance[0] > 0) and bool(np.allclose(p.exitance, p.direct))
    True
    """
    f = intensity if intensity is not None else _lambertian
    h = float(cloud.base_height)
    tau = transport_depth(atmosphere, h, ground_altitude)
    width = GRID_HALF_WIDTH_HEIGHTS * h if half_width is None else float(half_width)
    dx = h / cells_per_height
    n = int(2 * np.ceil(width / dx))
    if n > GRID_MAX_CELLS:
        n = GRID_MAX_CELLS
        dx = 2.0 * width / n
    axis = np.fft.fftfreq(n, d=1.0 / (n * dx))  # 0, dx, ..., -dx
    rho = np.hypot(axis[:, None], axis[None, :])
    direct = _direct_irradiance(rho, h, tau, f)
    kernel = np.exp(-tau * np.hypot(rho, h) / h) * h * h / (np.pi * (rho * rho + h * h) ** 2)
    kernel *= 2.0 * float(expn(3, tau)) / (kernel.sum() * dx * dx)
    reflect, ground = cloud.reflectance, cloud.ground_albedo
    k_hat = np.fft.rfft2(kernel) * dx * dx
    e_hat = np.fft.rfft2(direct)
    m_hat = reflect * e_hat / (1.0 - reflect * ground * k_hat * k_hat)
    exitance = np.fft.irfft2(m_hat, s=direct.shape)
    irradiance = np.fft.irfft2(k_hat * m_hat, s=direct.shape)
    half = n // 2
    r_axis = np.asarray(axis[:half], dtype=float)
    # exact direct term on the axis, the bounces from the grid
    bounce = exitance[0, :half] - reflect * direct[0, :half]
    return CloudProfiles(
        rho=r_axis,
        direct=direct[0, :half],
        exitance=reflect * direct[0, :half] + np.maximum(bounce, 0.0),
        ground=np.maximum(irradiance[0, :half], 0.0),
        height=h,
        optical_depth=float(_layer_depth(atmosphere, np.array(h), ground_altitude)),
        transport_depth=tau,
    )


def flux_budget(
    cloud: CloudLayer,
    atmosphere: Atmosphere,
    *,
    intensity: Intensity | None = None,
    ground_altitude: float = 0.0,
    rings: int = 4000,
) -> dict[str, float]:
    """Where a lumen emitted from the ground goes under the deck (uniform plane = point source).

    Integrates the profiles of :func:`cloud_profiles` over the plane.

    Parameters
    ----------
    cloud, atmosphere, intensity, ground_altitude
        As :func:`cloud_profiles`.
    rings
        Radial quadrature rings [1].

    Returns
    -------
    dict
        ``to_cloud`` (irradiance integral of the base, every pass), ``escaping`` (through the
        deck), ``ground_absorbed``, ``air`` (taken from the direct beams by the air) [1].
    """
    p = cloud_profiles(cloud, atmosphere, intensity=intensity, ground_altitude=ground_altitude)
    r = np.linspace(0.0, p.rho[-1], rings)
    area = 2.0 * np.pi * r

    def integral(values: FloatArray) -> float:
        return float(np.trapezoid(np.interp(r, p.rho, values) * area, r))

    reflect = cloud.reflectance
    exitance = integral(p.exitance)
    ground = integral(p.ground)
    to_cloud = exitance / reflect if reflect > 0 else integral(p.direct)
    ground_up = cloud.ground_albedo * ground
    escaping = cloud.transmittance * to_cloud
    ground_absorbed = (1.0 - cloud.ground_albedo) * ground
    emitted_up = 1.0 + ground_up  # flux leaving the ground upwards, every pass
    air = (emitted_up + exitance) - (to_cloud + ground)
    return {
        "to_cloud": to_cloud,
        "escaping": escaping,
        "ground_absorbed": ground_absorbed,
        "air": air,
    }


def cloud_luminance(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    cloud: CloudLayer,
    atmosphere: Atmosphere,
    *,
    intensity: Intensity | None = None,
    ground_altitude: float = 0.0,
    profiles: CloudProfiles | None = None,
    nodes: int = 16,
    core_radius: float = 1.0,
    terms: bool = False,
) -> Any:
    """Luminance per lumen of a ground point source, seen from the ground under the deck.

    The sum of the three terms of the module docstring; the view rays are the broadcast of the
    three array arguments.

    Parameters
    ----------
    elevation
        Elevation of the view ray, > 0 [deg].
    relative_azimuth
        Azimuth of the view ray from the direction of the source [deg].
    distance
        Ground distance from the observer to the source [m].
    cloud, atmosphere
        The deck and the air below it.
    intensity
        Emission intensity per lumen against the cosine of the zenith angle [cd lm-1];
        None: Lambertian.
    ground_altitude
        Altitude of the ground (observer and source) [m].
    profiles
        Precomputed :func:`cloud_profiles` (same deck, atmosphere and intensity).
    nodes
        Gauss-Legendre nodes per panel of the line-of-sight integrals [1].
    core_radius
        Softening radius of the source [m].
    terms
        Return the three terms (``air``, ``cloud``, ``diffuse``) in a dict instead of their sum.

    Returns
    -------
    numpy.ndarray or dict
        Luminance [cd m-2 lm-1].

    Examples
    --------
    >>> deck = CloudLayer(1000.0, optical_depth=15.0)
    >>> b = cloud_luminance(90.0, 0.0, [0.0, 5e3], deck, Atmosphere())
    >>> bool(b[0] > b[1] > 0)
    True
    """
    f = intensity if intensity is not None else _lambertian
    el, az, r = (
        a.astype(float)
        for a in np.broadcast_arrays(
            np.asarray(elevation, dtype=float),
            np.asarray(relative_azimuth, dtype=float),
            np.asarray(distance, dtype=float),
        )
    )
    if np.any(el <= 0) or np.any(el > 90):
        raise InputError("elevation; expected values in (0, 90] deg")
    if np.any(r < 0):
        raise InputError("distance; expected values >= 0 m")
    if profiles is None:
        profiles = cloud_profiles(
            cloud, atmosphere, intensity=intensity, ground_altitude=ground_altitude
        )
    h = profiles.height
    sin_e = np.sin(np.radians(el))
    cos_e = np.cos(np.radians(el))
    ca, sa = np.cos(np.radians(az)), np.sin(np.radians(az))
    v = np.stack([cos_e * ca, cos_e * sa, sin_e], axis=-1)
    u_b = h / sin_e
    # 1. direct light scattered once below the base
    along = r * v[..., 0]
    miss = np.sqrt(np.maximum(r * r - along * along, 0.0) + core_radius**2)
    u_c = np.clip(along, 0.0, u_b)
    air = np.zeros(el.shape)
    for lo, hi in ((np.zeros_like(u_b), u_c), (u_c, u_b)):
        u, w = tangent_panel_nodes(lo, hi, u_c, miss, nodes)
        px = u * v[..., 0:1] - r[..., None]
        py = u * v[..., 1:2]
        pz = u * v[..., 2:3]
        s2 = np.maximum(px * px + py * py + pz * pz, 1e-12)
        s = np.sqrt(s2)
        cos_scatter = -(px * v[..., 0:1] + py * v[..., 1:2] + pz * v[..., 2:3]) / s
        ext = _mean_extinction(atmosphere, np.zeros_like(pz), pz, ground_altitude)
        value = (
            _scattering(atmosphere, pz, cos_scatter, ground_altitude)
            * f(pz / s)
            / (s2 + core_radius**2)
            * np.exp(-ext * (s + u))
        )
        air = air + np.sum(w * value, axis=-1)
    # 2. the cloud base through the air
    bx = u_b * v[..., 0] - r
    by = u_b * v[..., 1]
    m_b, _ = profiles.at(np.hypot(bx, by))
    down = np.exp(-profiles.optical_depth / sin_e)
    cloud_term = m_b / np.pi * down
    # 3. the deck's and the ground's diffuse light scattered once below the base
    x, w = gauss_legendre(nodes)
    u = 0.5 * u_b[..., None] * (x + 1.0)
    w = 0.5 * u_b[..., None] * w
    px = u * v[..., 0:1] - r[..., None]
    py = u * v[..., 1:2]
    pz = u * v[..., 2:3]
    m_p, g_p = profiles.at(np.hypot(px, py))
    shares = hemisphere_phase(atmosphere, el)
    source = np.zeros(pz.shape)
    for beta, scale, key in _species(atmosphere, ground_altitude):
        albedo = atmosphere.aerosol_albedo if key == "a" else 1.0
        p_down, p_up = shares[key]
        source = source + beta * albedo * np.exp(-pz / scale) * (
            m_p * p_down[..., None] + cloud.ground_albedo * g_p * p_up[..., None]
        )
    attenuation = np.exp(-_layer_depth(atmosphere, pz, ground_altitude) / sin_e[..., None])
    diffuse = np.sum(w * source / np.pi * attenuation, axis=-1)
    if terms:
        return {"air": air, "cloud": cloud_term, "diffuse": diffuse}
    return air + cloud_term + diffuse


def disc_luminance(
    point: Callable[[FloatArray, FloatArray, FloatArray], FloatArray],
    elevation: float,
    relative_azimuth: float,
    distance: float,
    disc_radius: float,
    *,
    radial_nodes: int = 24,
    azimuth_nodes: int = 48,
) -> float:
    """Luminance per lumen of a uniform disc from a point-source luminance function.

    Quadrature in polar coordinates about the observer (the point source's 1 / r peak near the
    observer cancels against the area element): Gauss-Legendre nodes in azimuth over the
    directions that meet the disc and in distance over each direction's chord.

    Parameters
    ----------
    point
        Luminance per lumen of a point source, ``point(elevation, relative_azimuth, distance)``
        [cd m-2 lm-1].
    elevation
        Elevation of the view ray [deg].
    relative_azimuth
        Azimuth of the view ray from the direction of the disc's centre [deg].
    distance
        Ground distance from the observer to the disc's centre [m].
    disc_radius
        Radius of the disc [m].
    radial_nodes, azimuth_nodes
        Quadrature nodes [1].

    Returns
    -------
    float
        Luminance per lumen of the disc's flux [cd m-2 lm-1].

    Examples
    --------
    >>> flat = lambda e, a, r: np.ones_like(r)
    >>> round(disc_luminance(flat, 90.0, 0.0, 3e3, 1e3), 4)  # the quadrature: within 5e-6
    1.0
    """
    d, big_r = float(distance), float(disc_radius)
    if d < big_r:
        x, w = gauss_legendre(azimuth_nodes)
        alpha = np.pi * (x + 1.0)
        w_alpha = np.pi * w
    else:
        half = np.arcsin(min(big_r / max(d, 1e-9), 1.0))
        x, w = gauss_legendre(azimuth_nodes)
        alpha = half * x
        w_alpha = half * w
    chord = np.sqrt(np.maximum(big_r**2 - (d * np.sin(alpha)) ** 2, 0.0))
    r1 = np.maximum(d * np.cos(alpha) - chord, 0.0)
    r2 = np.maximum(d * np.cos(alpha) + chord, r1)
    xr, wr = gauss_legendre(radial_nodes)
    r = r1[:, None] + 0.5 * (r2 - r1)[:, None] * (xr[None, :] + 1.0)
    weights = w_alpha[:, None] * 0.5 * (r2 - r1)[:, None] * wr[None, :] * r
    rel = (relative_azimuth - np.degrees(alpha))[:, None] * np.ones_like(r)
    values = point(np.full(r.shape, float(elevation)), rel, r)
    return float(np.sum(weights * values) / (np.pi * big_r**2))
