"""RP-8's quality figures of a road section, from the same fields as EN 13201's.

ANSI/IES RP-8 states uniformity as ratios of a larger to a smaller value, each a maximum:

.. math::

    \\frac{L_{avg}}{L_{min}}, \\qquad \\frac{L_{max}}{L_{min}}, \\qquad
    \\frac{L_{v,max}}{L_{avg}}, \\qquad \\frac{E_{avg}}{E_{min}},

over the luminance field of one observer (the whole road area, where EN 13201's longitudinal
uniformity takes a lane's centre line), the greatest veiling luminance :math:`L_{v,max}` over
the observer positions against the average luminance (where EN 13201 takes the threshold
increment, :math:`f_{TI} = 65 L_v / L_{av}^{0.8}`), and the illuminance field. A minimum of 0
gives an infinite ratio, which fails any requirement
(:func:`~nightlights.roads.compliance`). The criteria's names in a requirement table are the
functions' names (:data:`~nightlights.roads.CRITERIA`).

References
----------
1. ANSI/IES RP-8, "Recommended Practice: Lighting Roadway and Parking Facilities" (the
   luminance and illuminance criteria).
2. W. van Bommel, "Road Lighting: Fundamentals, Technology and Application", Springer 2015,
   Sec. 9.3 (RP-8's criteria against CIE's).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "illuminance_average_to_minimum",
    "luminance_average_to_minimum",
    "luminance_maximum_to_minimum",
    "veiling_luminance_ratio",
]


def _field(values: ArrayLike, name: str) -> FloatArray:
    array = np.asarray(values, dtype=float)
    if array.ndim < 2 or array.shape[-1] == 0 or array.shape[-2] == 0:
        raise InputError(f"{name} of shape {array.shape}; expected a field (..., n_x, n_y)")
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise InputError(f"{name} holds negative or non-finite values")
    return array


def _over(numerator: FloatArray, minimum: FloatArray) -> FloatArray:
    """numerator / minimum, +inf where the minimum is 0 (the numerator then > 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(minimum > 0, numerator / np.where(minimum > 0, minimum, 1.0), np.inf)
    if np.any((minimum == 0) & (numerator == 0)):
        raise InputError("a field that is dark everywhere; a uniformity needs a lit field")
    return np.asarray(ratio)


def luminance_average_to_minimum(luminance: ArrayLike) -> FloatArray:
    """L_avg / L_min over the field, one per observer [1] (the reciprocal of EN's U_o).

    Parameters
    ----------
    luminance
        Luminance at the field points, (..., n_x, n_y) [cd m-2].

    Examples
    --------
    >>> float(luminance_average_to_minimum([[1.0, 2.0], [3.0, 2.0]]))
    2.0
    """
    array = _field(luminance, "luminance")
    return _over(array.mean(axis=(-2, -1)), array.min(axis=(-2, -1)))


def luminance_maximum_to_minimum(luminance: ArrayLike) -> FloatArray:
    """L_max / L_min over the whole field, one per observer [1].

    Examples
    --------
    >>> float(luminance_maximum_to_minimum([[1.0, 2.0], [3.0, 2.0]]))
    3.0
    """
    array = _field(luminance, "luminance")
    return _over(array.max(axis=(-2, -1)), array.min(axis=(-2, -1)))


def veiling_luminance_ratio(veiling: ArrayLike, average: float) -> float:
    """L_v,max / L_avg: the greatest veiling luminance over the observer positions against the
    average road luminance [1].

    Parameters
    ----------
    veiling
        Veiling luminance at each observer position [cd m-2]
        (:func:`~nightlights.roads.veiling_luminance`).
    average
        Average road luminance [cd m-2].

    Examples
    --------
    >>> veiling_luminance_ratio([0.1, 0.25, 0.2], 1.0)
    0.25
    """
    values = np.asarray(veiling, dtype=float)
    if values.size == 0 or not np.all(np.isfinite(values)) or np.any(values < 0):
        raise InputError(f"veiling = {veiling!r}; expected one or more numbers >= 0 [cd m-2]")
    if not (np.isfinite(average) and average > 0):
        raise InputError(f"average={average!r}; expected a luminance > 0 [cd m-2]")
    return float(values.max() / average)


def illuminance_average_to_minimum(illuminance: ArrayLike) -> float:
    """E_avg / E_min over the illuminance field [1].

    Parameters
    ----------
    illuminance
        Horizontal illuminance at the field points, (n_x, n_y) [lx].

    Examples
    --------
    >>> illuminance_average_to_minimum([[4.0, 8.0], [12.0, 8.0]])
    2.0
    """
    array = _field(illuminance, "illuminance")
    return float(_over(np.asarray(array.mean()), np.asarray(array.min())))
