"""Emission angular distributions of a ground source, per lumen of upward flux.

The shapes the skyglow kernel tabulates (:mod:`nightlights.sky.kernel`): Lambertian reflection,
the direct-uplight lobe sin^n, Garstang's (1986) low-angle psi^4 lobe, an isotropic emitter (for
validation) and a tabulated function; each is normalised to 1 lm into the upper hemisphere.
Kept apart from the line-of-sight integral so that its compiled twin
(:mod:`nightlights.sky._kernel_numba`) can read the same constants without importing the
integrator.

References
----------
1. Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375.
"""

from __future__ import annotations

import functools
import json
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import beta as beta_function

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "EMISSION_MODELS",
    "GARSTANG_LOBE_NORM",
    "TABULATED_PREFIX",
    "UPLIGHT_EXPONENT",
    "emission_intensity",
    "garstang_weights",
    "parse_tabulated_emission",
    "tabulated_emission_intensity",
    "tabulated_norm",
]

#: Emission angular distributions, each normalised to 1 lm emitted into the upper hemisphere.
EMISSION_MODELS = ("lambertian", "uplight", "isotropic", "garstang_lobe")


#: Default exponent n of the direct-uplight lobe sin^n(theta) about the local vertical [1].
UPLIGHT_EXPONENT = 4.0

#: Normalisation c of Garstang's low-angle term c psi^4 / (2 pi): 1 / int_0^{pi/2} psi^4 sin psi
#: dpsi, in closed form 1 / (24 - 12 pi + pi^3 / 2) = 0.55432 (Garstang 1986 rounds it to
#: 0.554) [1].
GARSTANG_LOBE_NORM = 1.0 / (24.0 - 12.0 * math.pi + math.pi**3 / 2.0)

#: Prefix of a tabulated emission function: ``tabulated:{"angles": [...], "intensities":
#: [...]}``, angles from the local vertical [deg], 0 to 90, relative intensities [1].
TABULATED_PREFIX = "tabulated:"


def emission_intensity(
    cos_zenith: ArrayLike, model: str = "lambertian", *, uplight_exponent: float = UPLIGHT_EXPONENT
) -> FloatArray:
    """Luminous intensity per lumen of upward flux, as a function of the emission angle.

    Models (theta = angle from the source's local vertical, 1 lm into the upper hemisphere):

    - ``"lambertian"``: :math:`I = \\cos\\theta / \\pi` (reflection by the ground);
    - ``"uplight"``: :math:`I = \\sin^n\\theta / (\\pi B(1/2, n/2 + 1))`, a lobe peaking at
      the horizon (direct uplight of luminaires, mostly just above the horizontal). For the
      default n = 4 the intensity halves 33 deg above the horizon (sin^4 theta = 1/2 at
      theta = 57 deg), and half the flux leaves within 16 deg of the horizon (see Examples);
    - ``"isotropic"``: :math:`I = 1 / (2\\pi)` (validation);
    - ``"garstang_lobe"``: :math:`I = c\\,\\theta^4 / (2\\pi)`, theta in radians, the
      low-angle term of Garstang's (1986) emission function, with
      :math:`c = 1 / \\int_0^{\\pi/2} \\theta^4 \\sin\\theta\\,d\\theta = 0.5543`
      (:data:`GARSTANG_LOBE_NORM`; Garstang's 0.554). Garstang's full function,
      :math:`(2 G (1 - F) \\cos\\theta + 0.554 F \\theta^4) / (2\\pi)` per lumen of the
      city's output, is the mix of ``"lambertian"`` and this lobe of
      :func:`garstang_weights`.

    Nothing is emitted below the horizontal (cos theta <= 0).

    Parameters
    ----------
    cos_zenith
        Cosine of the angle between the emission direction and the local vertical [1].
    model
        One of :data:`EMISSION_MODELS`, or a tabulated function ``tabulated:<json>``
        (:func:`parse_tabulated_emission`, :func:`tabulated_emission_intensity`).
    uplight_exponent
        Exponent n of the uplight lobe [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1].

    References
    ----------
    .. [1] Normalisation of the sin^n lobe: 2 pi int_0^1 (1 - mu^2)^(n/2) dmu = pi B(1/2, n/2 + 1).
    .. [2] Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375,
       the upward emission function (reconstructed from its published form; the normalisation is
       checked in the Examples).

    Examples
    --------
    Every model puts 1 lm into the upper hemisphere; Garstang's c is 0.554:

    >>> from scipy.integrate import quad
    >>> flux = lambda m: 2 * np.pi * quad(lambda mu: float(emission_intensity(mu, m)), 0, 1)[0]
    >>> [round(flux(m), 9) for m in EMISSION_MODELS]
    [1.0, 1.0, 1.0, 1.0]
    >>> round(GARSTANG_LOBE_NORM, 4)
    0.5543

    Half the flux of the sin^4 lobe leaves within 16 deg of the horizon (emission angles
    74-90 deg from the vertical):

    >>> edge = np.sin(np.radians(16.3))
    >>> near = quad(lambda mu: float(emission_intensity(mu, "uplight")), 0, edge)[0]
    >>> round(2 * np.pi * near, 2)
    0.5
    """
    mu = np.asarray(cos_zenith, dtype=float)
    up = mu > 0
    if model == "lambertian":
        return np.where(up, mu, 0.0) / math.pi
    if model == "uplight":
        norm = math.pi * float(beta_function(0.5, uplight_exponent / 2.0 + 1.0))
        sin2 = np.clip(1.0 - mu * mu, 0.0, 1.0)
        return np.where(up, sin2 ** (uplight_exponent / 2.0), 0.0) / norm
    if model == "isotropic":
        return np.where(up, 1.0 / (2.0 * math.pi), 0.0)
    if model == "garstang_lobe":
        psi = np.arccos(np.clip(mu, 0.0, 1.0))
        return np.where(up, GARSTANG_LOBE_NORM * psi**4, 0.0) / (2.0 * math.pi)
    if isinstance(model, str) and model.startswith(TABULATED_PREFIX):
        _, angles, intensities = parse_tabulated_emission(model)
        return tabulated_emission_intensity(mu, angles, intensities)
    raise InputError(f"emission model {model!r}; expected one of {EMISSION_MODELS}")


@functools.lru_cache(maxsize=64)
def parse_tabulated_emission(text: str) -> tuple[str, FloatArray, FloatArray]:
    """The angles and relative intensities of a tabulated emission function.

    Parameters
    ----------
    text
        ``tabulated:{"angles": [...], "intensities": [...]}``: emission angles from the local
        vertical, increasing from 0 (straight up) to 90 (horizontal) [deg], and the relative
        intensity at each (>= 0, not all 0) [1].

    Returns
    -------
    canonical : str
        The text in canonical form (compact JSON, floats).
    angles : numpy.ndarray
        [deg], read-only.
    intensities : numpy.ndarray
        As given (not normalised) [1], read-only.

    Raises
    ------
    InputError
        Not of that form.

    Examples
    --------
    >>> parse_tabulated_emission('tabulated:{"angles": [0, 90], "intensities": [1, 1]}')[0]
    'tabulated:{"angles":[0.0,90.0],"intensities":[1.0,1.0]}'
    """
    body = text[len(TABULATED_PREFIX) :] if text.startswith(TABULATED_PREFIX) else None
    try:
        table: Any = json.loads(body) if body is not None else None
        angles: FloatArray = np.array(table["angles"], dtype=np.float64)
        intensities: FloatArray = np.array(table["intensities"], dtype=np.float64)
    except (ValueError, TypeError, KeyError):
        raise InputError(
            f'emission function {text[:80]!r}; expected tabulated:{{"angles": [deg, 0 to 90], '
            '"intensities": [relative, one per angle]}'
        ) from None
    fine = (
        angles.ndim == 1
        and angles.shape == intensities.shape
        and angles.size >= 2
        and bool(np.all(np.isfinite(angles)) and np.all(np.isfinite(intensities)))
    )
    if not fine or angles[0] != 0.0 or angles[-1] != 90.0 or np.any(np.diff(angles) <= 0):
        raise InputError(
            f"tabulated emission angles {angles.tolist()!r}; expected >= 2 increasing angles "
            "from 0 to 90 deg, one finite intensity each"
        )
    if np.any(intensities < 0) or not np.any(intensities > 0):
        raise InputError(
            f"tabulated emission intensities {intensities.tolist()!r}; expected >= 0, not all 0"
        )
    canonical = TABULATED_PREFIX + json.dumps(
        {"angles": angles.tolist(), "intensities": intensities.tolist()}, separators=(",", ":")
    )
    angles.flags.writeable = False
    intensities.flags.writeable = False
    return canonical, angles, intensities


def tabulated_emission_intensity(
    cos_zenith: ArrayLike, angles: ArrayLike, intensities: ArrayLike
) -> FloatArray:
    """Intensity per lumen of upward flux of a tabulated emission function.

    The relative intensity t(theta) is interpolated linearly in the emission angle theta
    between the tabulated angles and scaled to 1 lm into the upper hemisphere,

    .. math::
        I(\\theta) = \\frac{t(\\theta)}{2\\pi \\int_0^{\\pi/2} t(\\theta)
        \\sin\\theta \\, d\\theta},

    the integral exact for the piecewise-linear t: on a segment [a, b] with slope m,
    t_a (cos a - cos b) + m (sin b - sin a - (b - a) cos b).

    Parameters
    ----------
    cos_zenith
        Cosine of the emission direction's angle from the local vertical [1].
    angles
        Tabulated angles from the vertical, 0 to 90, increasing [deg].
    intensities
        Relative intensities at ``angles`` [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1]; 0 below the horizontal.

    Examples
    --------
    A table of cos theta at 1 deg steps is the Lambertian shape, 1 / pi straight up (to
    3e-5, the linear interpolation):

    >>> deg = np.arange(91.0)
    >>> round(float(tabulated_emission_intensity(1.0, deg, np.cos(np.radians(deg)))) * np.pi, 4)
    1.0
    """
    mu = np.asarray(cos_zenith, dtype=float)
    theta = np.degrees(np.arccos(np.clip(mu, 0.0, 1.0)))
    value = np.interp(theta, np.asarray(angles, dtype=float), np.asarray(intensities, dtype=float))
    return np.where(mu > 0, value, 0.0) * tabulated_norm(angles, intensities)


def tabulated_norm(angles: ArrayLike, intensities: ArrayLike) -> float:
    """1 / (2 pi int_0^{pi/2} t(theta) sin theta dtheta) for a piecewise-linear t(theta)
    [cd lm-1 per unit of t] (see :func:`tabulated_emission_intensity`)."""
    a = np.radians(np.asarray(angles, dtype=float))
    t = np.asarray(intensities, dtype=float)
    lo, hi = a[:-1], a[1:]
    slope = np.diff(t) / (hi - lo)
    piece = t[:-1] * (np.cos(lo) - np.cos(hi)) + slope * (
        np.sin(hi) - np.sin(lo) - (hi - lo) * np.cos(hi)
    )
    return 1.0 / (2.0 * math.pi * float(np.sum(piece)))


def garstang_weights(upward_fraction: float, reflectance: float) -> dict[str, float]:
    """Garstang's (1986) emission function as a mix of unit-flux shapes.

    Garstang's intensity per lumen of a city's output,
    :math:`I = (2 G (1 - F) \\cos\\psi + 0.554 F \\psi^4) / (2\\pi)`, sends
    G (1 - F) + F lumens upwards: F directly (the low-angle lobe) and G (1 - F) by reflection
    of the downward flux (Lambertian). Per lumen of upward flux it is

    .. math::
        I = w_L \\frac{\\cos\\psi}{\\pi} + (1 - w_L) \\frac{c \\psi^4}{2\\pi},
        \\quad w_L = \\frac{G (1 - F)}{G (1 - F) + F}.

    Parameters
    ----------
    upward_fraction
        F, the fraction of the luminaires' flux emitted directly upwards, in [0, 1] [1].
    reflectance
        G, the ground's reflectance (albedo) for the downward flux, in [0, 1] [1].

    Returns
    -------
    dict
        Weights of ``"lambertian"`` and ``"garstang_lobe"``, summing to 1 [1].

    References
    ----------
    .. [1] Garstang, R. H. 1986, PASP 98, 364-375 (the upward emission function).

    Examples
    --------
    >>> {k: round(v, 3) for k, v in garstang_weights(0.15, 0.15).items()}
    {'lambertian': 0.459, 'garstang_lobe': 0.541}
    """
    f, g = float(upward_fraction), float(reflectance)
    if not (0.0 <= f <= 1.0 and 0.0 <= g <= 1.0) or g * (1.0 - f) + f <= 0.0:
        raise InputError(
            f"Garstang F={upward_fraction!r}, G={reflectance!r}; expected both in [0, 1] and "
            "some upward flux (F > 0 or G > 0)"
        )
    reflected = g * (1.0 - f)
    lambertian = reflected / (reflected + f)
    return {"lambertian": lambertian, "garstang_lobe": 1.0 - lambertian}
