"""Sky brightness in astronomers' units and the Bortle scale.

References
----------
Cinzano, P. (2005). Night sky photometry with Sky Quality Meter. ISTIL Internal Report 9:
the conversion m = -2.5 log10(L / 1.08e5) between luminance [cd m-2] and V-band surface
brightness [mag arcsec-2] used by SQM users.
Bortle, J. E. (2001). Introducing the Bortle dark-sky scale. Sky & Telescope 101(2), 126-129.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Luminance of a surface of 0 mag arcsec-2 [cd m-2] (Cinzano 2005).
ZERO_POINT_LUMINANCE = 1.08e5

#: Zenith sky brightness at the darker edge of Bortle classes 1-9 [mag arcsec-2]: class c
#: covers m >= BORTLE_LOWER_EDGES[c - 1] (and below the previous edge). Bortle (2001) defines
#: the classes by naked-eye criteria, not photometry; this correspondence to SQM readings
#: (21.99, 21.89, 21.69, 20.49, 19.50, 18.94, 18.38, 18.0 mag arcsec-2) is the one commonly
#: quoted by dark-sky associations. A labelled, non-physical convenience.
BORTLE_LOWER_EDGES: tuple[float, ...] = (21.99, 21.89, 21.69, 20.49, 19.50, 18.94, 18.38, 18.00)


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

    Parameters
    ----------
    zenith_magnitude
        Zenith surface brightness [mag arcsec-2].

    Returns
    -------
    numpy.ndarray
        Integer class 1-9 (see :data:`BORTLE_LOWER_EDGES`).
    """
    m = np.asarray(zenith_magnitude, dtype=float)
    edges = np.asarray(BORTLE_LOWER_EDGES)
    # Count the edges the value falls below: 0 -> class 1, 8 -> class 9.
    return 1 + np.sum(m[..., None] < edges, axis=-1)
