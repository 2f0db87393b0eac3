"""Sky brightness in astronomers' units, the Bortle scale and the zenith's natural + artificial sum.

A leaf of units any layer may import: the skyglow stages report the artificial zenith with a
moonless natural sky added (:func:`zenith_summary`), and the night sky
(:func:`nightlights.nightsky.zenith_summary`) adds the natural sky of a given night the same way.

References
----------
Cinzano, P. (2005). Night sky photometry with Sky Quality Meter. ISTIL Internal Report 9:
the conversion m = -2.5 log10(L / 1.08e5) between luminance [cd m-2] and V-band surface
brightness [mag arcsec-2] used by SQM users.
Bortle, J. E. (2001). Introducing the Bortle dark-sky scale. Sky & Telescope 101(2), 126-129.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights.errors import InputError

__all__ = [
    "BORTLE_LOWER_EDGES",
    "NATURAL_ZENITH_LUMINANCE",
    "NATURAL_ZENITH_MAGNITUDE",
    "NON_FINITE_SKY",
    "ZERO_POINT_LUMINANCE",
    "bortle_class",
    "bortle_class_or_reason",
    "luminance_to_magnitude",
    "magnitude_to_luminance",
    "zenith_summary",
]

#: Luminance of a surface of 0 mag arcsec-2 [cd m-2] (Cinzano 2005).
ZERO_POINT_LUMINANCE = 1.08e5

#: Zenith sky brightness at the darker edge of Bortle classes 1-9 [mag arcsec-2]: class c
#: covers m >= BORTLE_LOWER_EDGES[c - 1] (and below the previous edge). Bortle (2001) defines
#: the classes by naked-eye criteria, not photometry; this correspondence to SQM readings
#: (21.99, 21.89, 21.69, 20.49, 19.50, 18.94, 18.38, 18.0 mag arcsec-2) is the one commonly
#: quoted by dark-sky associations. A labelled, non-physical convenience.
BORTLE_LOWER_EDGES: tuple[float, ...] = (21.99, 21.89, 21.69, 20.49, 19.50, 18.94, 18.38, 18.00)

#: Zenith brightness of the moonless natural sky at a dark site [mag arcsec-2] (the dark end
#: of Bortle class 1 is 21.99; 22.0 mag arcsec-2 = 171 ucd m-2 anchors the magnitude scale).
NATURAL_ZENITH_MAGNITUDE = 22.0


def luminance_to_magnitude(luminance: ArrayLike) -> NDArray[np.float64]:
    """Sky brightness from luminance.

    .. math:: m = -2.5 \\log_{10}(L / 1.08\\times10^5)

    Parameters
    ----------
    luminance
        Sky luminance [cd m-2]; zero gives +inf.

    Returns
    -------
    numpy.ndarray
        Surface brightness [mag arcsec-2].

    Examples
    --------
    >>> round(float(luminance_to_magnitude(171e-6)), 2)
    22.0
    """
    value = np.asarray(luminance, dtype=float)
    with np.errstate(divide="ignore"):
        return -2.5 * np.log10(value / ZERO_POINT_LUMINANCE)


def magnitude_to_luminance(magnitude: ArrayLike) -> NDArray[np.float64]:
    """Luminance from sky brightness: L = 1.08e5 x 10^(-0.4 m).

    Parameters
    ----------
    magnitude
        Surface brightness [mag arcsec-2].

    Returns
    -------
    numpy.ndarray
        Luminance [cd m-2].
    """
    return ZERO_POINT_LUMINANCE * 10.0 ** (-0.4 * np.asarray(magnitude, dtype=float))


def bortle_class(zenith_magnitude: ArrayLike) -> NDArray[np.int64]:
    """Bortle class (1 darkest .. 9 inner city) of a zenith sky brightness.

    A sky whose luminance is not a finite number has no class: its magnitude is NaN (NaN
    luminance) or -inf (infinite luminance), and it is refused rather than counted as the
    darkest class. A magnitude of +inf (zero luminance: no light at all) is class 1.

    Parameters
    ----------
    zenith_magnitude
        Zenith surface brightness [mag arcsec-2].

    Returns
    -------
    numpy.ndarray
        Integer class 1-9 (see :data:`BORTLE_LOWER_EDGES`).

    Raises
    ------
    InputError
        A NaN or -inf magnitude (:data:`NON_FINITE_SKY`).

    Examples
    --------
    >>> bortle_class([22.5, 17.5, np.inf]).tolist()
    [1, 9, 1]
    """
    m = np.asarray(zenith_magnitude, dtype=float)
    bad = np.isnan(m) | (m == -np.inf)
    if bad.any():
        first = float(m[bad].flat[0])
        raise InputError(
            f"zenith sky brightness {first} mag arcsec-2 ({int(bad.sum())} of {m.size} "
            f"values): {NON_FINITE_SKY}"
        )
    edges = np.asarray(BORTLE_LOWER_EDGES)
    # Count the edges the value falls below: 0 -> class 1, 8 -> class 9.
    return 1 + np.sum(m[..., None] < edges, axis=-1)


#: Why a sky has no brightness class: what :func:`bortle_class` refuses and what
#: :func:`bortle_class_or_reason` gives with its ``None``.
NON_FINITE_SKY = (
    "the sky luminance is not a finite number (NaN or infinite), so it has no Bortle class; "
    "expected a finite emission whose flux does not overflow"
)


def bortle_class_or_reason(zenith_magnitude: float) -> tuple[int | None, str | None]:
    """Bortle class of one zenith brightness, or None and the reason for a non-finite sky.

    For answers that must stay JSON (a null class with its reason, never a made-up class).

    Parameters
    ----------
    zenith_magnitude
        Zenith surface brightness [mag arcsec-2].

    Returns
    -------
    tuple
        ``(class, None)`` for a finite sky (or +inf: zero luminance), ``(None, reason)``
        for a NaN or -inf magnitude.

    Examples
    --------
    >>> bortle_class_or_reason(21.0)
    (4, None)
    >>> bortle_class_or_reason(float("nan"))[0] is None
    True
    """
    magnitude = float(zenith_magnitude)
    if math.isnan(magnitude) or magnitude == -math.inf:
        return None, NON_FINITE_SKY
    return int(bortle_class(magnitude)), None


#: Luminance of the moonless natural sky at the zenith [cd m-2]: :data:`NATURAL_ZENITH_MAGNITUDE`
#: (171.2 ucd m-2), the zenith of :func:`nightlights.nightsky.natural_sky_luminance` with its
#: default :class:`~nightlights.nightsky.NaturalSky`.
NATURAL_ZENITH_LUMINANCE = float(magnitude_to_luminance(NATURAL_ZENITH_MAGNITUDE))


def zenith_summary(
    artificial_luminance: float, *, natural_luminance: float = NATURAL_ZENITH_LUMINANCE
) -> dict[str, float | int]:
    """Zenith sky brightness natural + artificial, for the summaries of the skyglow stages.

    Parameters
    ----------
    artificial_luminance
        Artificial skyglow at the zenith [cd m-2].
    natural_luminance
        Natural sky at the zenith [cd m-2]; default the moonless natural sky
        (:data:`NATURAL_ZENITH_LUMINANCE`, 22.0 mag arcsec-2).

    Returns
    -------
    dict
        ``zenith_natural_cd_m2``, ``zenith_artificial_cd_m2``, ``zenith_natural_sky_brightness``
        [mag arcsec-2], ``zenith_sky_brightness`` [mag arcsec-2] of their sum and
        ``bortle_class_zenith``.

    Raises
    ------
    InputError
        A negative, NaN or infinite artificial luminance (a non-finite sky has no brightness
        and no Bortle class).

    Examples
    --------
    >>> summary = zenith_summary(3.65e-3)  # the demo's Esplanadi panorama
    >>> round(summary["zenith_sky_brightness"], 2), summary["bortle_class_zenith"]
    (18.63, 7)
    """
    if not math.isfinite(artificial_luminance):
        raise InputError(
            f"artificial zenith luminance {artificial_luminance} cd m-2: {NON_FINITE_SKY}"
        )
    if not artificial_luminance >= 0:
        raise InputError(f"artificial zenith luminance {artificial_luminance}: expected >= 0")
    natural = float(natural_luminance)
    total = natural + float(artificial_luminance)
    magnitude = float(luminance_to_magnitude(total))
    return {
        "zenith_natural_cd_m2": natural,
        "zenith_artificial_cd_m2": float(artificial_luminance),
        "zenith_natural_sky_brightness": float(luminance_to_magnitude(natural)),
        "zenith_sky_brightness": magnitude,
        "bortle_class_zenith": int(bortle_class(magnitude)),
    }
