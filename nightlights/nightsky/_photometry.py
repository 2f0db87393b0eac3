"""Stars and the Moon as the eye sees them: colour, illuminance and the limiting magnitude.

Star colours come from B-V through Ballesteros's (2012) temperature and a blackbody; a star's
illuminance from its V magnitude with the zero point of the sky-brightness scale (Cinzano 2005);
stars fainter than the eye's limiting magnitude against the local sky (Schaefer 1990) are left
out of the picture; the Moon's V magnitude follows its phase (Krisciunas & Schaefer 1991). Used
by the composition (:mod:`nightlights.nightsky.render`, which hands these names on).

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
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.brightness import ZERO_POINT_LUMINANCE
from nightlights.errors import InputError
from nightlights.nightsky.tonemap import blackbody_white

__all__ = [
    "ARCSEC2_SR",
    "BV_RANGE",
    "NANOLAMBERT",
    "ZERO_MAGNITUDE_ILLUMINANCE",
    "ballesteros_temperature",
    "moon_v_magnitude",
    "schaefer_limiting_magnitude",
    "star_xyz",
]

#: Solid angle of one square arcsecond [sr].
ARCSEC2_SR = (math.pi / (180.0 * 3600.0)) ** 2
#: Illuminance of a star of V = 0 [lx]: the zero point of the sky-brightness scale
#: (1.08e5 cd m-2 at 0 mag arcsec-2, Cinzano 2005) times one square arcsecond.
ZERO_MAGNITUDE_ILLUMINANCE = ZERO_POINT_LUMINANCE * ARCSEC2_SR
#: One nanolambert [cd m-2]: 1 L = 1e4 / pi cd m-2.
NANOLAMBERT = 1e-9 * 1e4 / math.pi
#: B-V range of Ballesteros's formula [mag]: it diverges at B-V = -0.67.
BV_RANGE = (-0.4, 2.0)


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
