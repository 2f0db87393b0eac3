"""Monte Carlo reference for the cloudy sky: every order of scattering and reflection.

Checks the analytic model of :mod:`nightlights.sky.clouds`. The layer between the ground and
the cloud base is the clear sky's two-species exponential atmosphere on a flat Earth; the
cloud base reflects a photon's flux with R (Lambertian, downwards) and passes T (the photon
leaves: escaping), the ground reflects A_g (Lambertian, upwards) and absorbs the rest. Photons
leave a uniform disc (a city; radius 0: a point source) with a Lambertian distribution, and
free paths, species and scattering directions are sampled as in the clear sky's Monte Carlo
(:mod:`nightlights.sky.montecarlo`, whose random-number streams, phase-function samplers and
rotation this module shares; the clear sky's Monte Carlo itself is unchanged).

Estimator (next event, Marchuk et al. 1980): every event of weight w (the emission, a
collision, a reflection) is a point source of intensity w I(omega) (the emission's cos / pi, the
phase mixture at a collision, cos / pi of a reflection); for each view ray it adds (i) the
single scattering of that light along the ray below the base (the line-of-sight integral of
:mod:`nightlights.sky.kernel`, Gauss-Legendre nodes after u = u_p + d tan t on each side of the
closest approach), and (ii) its irradiance of the base where the ray ends, reflected with
R / pi and attenuated along the ray. Both are softened by a core radius r0. Light reflected or
scattered any number of times is followed by the photon itself. Weights below 1e-3 play
Russian roulette (survival 0.1, unbiased).

References
----------
[1] Marchuk, G. I. et al. 1980, "The Monte Carlo Methods in Atmospheric Optics", Springer
    (local and next-event estimators).
[2] Steele, G. L., Lea, D. & Flood, C. H. 2014, "Fast splittable pseudorandom number
    generators", OOPSLA 2014 (SplitMix64).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nightlights._signals import held_signals
from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer
from nightlights.sky.montecarlo import view_directions
from nightlights.sky.quadrature import gauss_legendre

__all__ = ["CloudyMonteCarlo", "cloudy_monte_carlo"]


@dataclass(frozen=True)
class CloudyMonteCarlo:
    """Result of :func:`cloudy_monte_carlo`.

    Attributes
    ----------
    luminance
        Shape ``(n_rays,)``: luminance per lumen emitted [cd m-2 lm-1].
    standard_error
        Shape ``(n_rays,)`` [cd m-2 lm-1].
    flux
        Fractions of the emitted flux: ``escaping`` (through the deck), ``ground_absorbed``,
        ``air_absorbed``, ``cloud_absorbed``, ``in_flight`` and ``roulette`` (weight won minus
        weight lost by Russian roulette, zero in expectation) [1].
    photons
        Photon histories [1].
    """

    luminance: FloatArray
    standard_error: FloatArray
    flux: dict[str, float]
    photons: int


def cloudy_monte_carlo(
    elevation: ArrayLike,
    relative_azimuth: ArrayLike,
    distance: ArrayLike,
    cloud: CloudLayer,
    *,
    atmosphere: Atmosphere | None = None,
    disc_radius: float = 0.0,
    photons: int = 2000,
    seed: int = 0,
    nodes: int = 12,
    core_radius: float = 10.0,
    max_events: int = 2000,
) -> CloudyMonteCarlo:
    """Luminance under a cloud deck from a uniform Lambertian disc, by Monte Carlo.

    The observer stands on the ground at ``distance`` from the disc's centre, and
    ``relative_azimuth`` is counted from the direction of the centre.

    Parameters
    ----------
    elevation
        Elevation of the view ray, > 0 [deg].
    relative_azimuth
        Azimuth of the view ray from the direction of the disc's centre [deg].
    distance
        Ground distance from the observer to the disc's centre [m].
    cloud
        The deck (its base height, reflectance and the ground albedo).
    atmosphere
        The air below the base (flat Earth; aerosol albedo honoured); None: the default
        :class:`~nightlights.sky.atmosphere.Atmosphere`.
    disc_radius
        Radius of the emitting disc; 0: a point source [m].
    photons
        Photon histories [1].
    seed
        Seed of the random-number streams (non-negative integer).
    nodes
        Gauss-Legendre nodes per panel of each event's line-of-sight integral [1].
    core_radius
        Softening radius r0 of every event [m].
    max_events
        Events followed per photon at most [1].

    Returns
    -------
    CloudyMonteCarlo
        Luminance per lumen, its standard error and the flux budget.

    Examples
    --------
    >>> mc = cloudy_monte_carlo(90.0, 0.0, 0.0, CloudLayer(1000.0), photons=200, seed=1)
    >>> bool(mc.luminance[0] > 0)
    True
    """
    from nightlights.sky import _clouds_numba as compiled

    atm = Atmosphere() if atmosphere is None else atmosphere
    if photons < 1 or nodes < 1 or max_events < 1:
        raise InputError(
            f"photons {photons!r}, nodes {nodes!r}, max_events {max_events!r}; expected >= 1"
        )
    if not (isinstance(seed, int | np.integer) and 0 <= seed < 2**63):
        raise InputError(f"seed {seed!r}; expected an integer from 0 to 2**63 - 1")
    if not (disc_radius >= 0 and core_radius > 0):
        raise InputError(
            f"disc_radius {disc_radius!r} m, core_radius {core_radius!r} m; expected >= 0, > 0"
        )
    el, az, r = view_directions(elevation, relative_azimuth, distance)
    e, a = np.radians(el), np.radians(az)
    # observer at (-r, 0): the centre lies towards +x, azimuth measured from +x
    rays = np.stack(
        [-r, np.zeros_like(r), np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1
    )
    p = np.zeros(compiled.N_PARAMS)
    p[compiled.P_BETA_M] = atm.molecular_extinction if atm.extinction else 0.0
    p[compiled.P_H_M] = atm.molecular_scale_height
    p[compiled.P_BETA_A] = atm.aerosol_extinction if atm.extinction else 0.0
    p[compiled.P_H_A] = atm.aerosol_scale_height
    p[compiled.P_OMEGA_A] = atm.aerosol_albedo
    p[compiled.P_G] = atm.asymmetry
    p[compiled.P_HEIGHT] = cloud.base_height
    p[compiled.P_R] = cloud.reflectance
    p[compiled.P_T] = cloud.transmittance
    p[compiled.P_GROUND] = cloud.ground_albedo
    p[compiled.P_DISC] = disc_radius
    p[compiled.P_CORE] = core_radius
    p[compiled.P_ISO] = 1.0 if atm.molecular_phase == "isotropic" else 0.0
    x_gl, w_gl = gauss_legendre(nodes)
    with held_signals():
        sums, squares, budget = compiled.transport(
            int(seed), int(photons), rays, x_gl, w_gl, p, int(max_events)
        )
    mean = sums / photons
    variance = np.maximum(squares / photons - mean * mean, 0.0)
    names = (
        "escaping",
        "ground_absorbed",
        "air_absorbed",
        "cloud_absorbed",
        "in_flight",
        "roulette",
    )
    flux = {name: float(value / photons) for name, value in zip(names, budget[1:], strict=True)}
    return CloudyMonteCarlo(
        luminance=mean,
        standard_error=np.sqrt(variance / max(photons - 1, 1)),
        flux=flux,
        photons=int(photons),
    )
