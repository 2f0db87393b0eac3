"""Checks of user input shared by the stages; each raises a one-line :class:`InputError`."""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike

from nightlights.errors import InputError


def check_resolution(value: object, *, name: str = "resolution") -> float:
    """Return ``value`` as a positive, finite pixel size [m] or raise :class:`InputError`.

    Parameters
    ----------
    value
        Pixel size [m].
    name
        Name of the option in the message.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name}={value!r} m; expected a positive number of metres")
    size = float(value)
    if not (math.isfinite(size) and size > 0):
        raise InputError(f"{name}={value!r} m; expected a positive number of metres")
    return size


#: Largest plausible upward flux density of one emission cell [lm m-2]: that of a perfectly
#: white ground (albedo 1) under direct noon sunlight, about 1e5 lx. No artificial lighting of
#: a whole cell reaches it: the brightest cells of cities stay two to three orders of magnitude
#: below (a floodlit stadium, 1-2 klx on grass of albedo about 0.2, gives 200-400 lm m-2; the
#: brightest urban pixels of the VIIRS composites, a few thousand nW cm-2 sr-1, give about
#: 100 lm m-2 with the default LED spectrum, :func:`nightlights.viirs_radiance_to_flux_density`).
#: A value above it is a unit or fill-value error, not light.
MAX_FLUX_DENSITY = 1.0e5


def check_flux_density(values: ArrayLike, *, what: str) -> None:
    """Refuse flux densities that are not finite or above :data:`MAX_FLUX_DENSITY`.

    Parameters
    ----------
    values
        Upward flux densities [lm m-2] (NaN, nodata, is allowed).
    what
        What the values are, for the message (``the paint value``, ``the edited cells``).

    Raises
    ------
    InputError
        An infinite value or one above :data:`MAX_FLUX_DENSITY`.

    Examples
    --------
    >>> check_flux_density([0.0, 2.5, float("nan")], what="the cells")
    >>> check_flux_density([1e308 * 10], what="the cells")
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: the cells: 1 flux density values of inf lm m-2; expected \
finite values up to 100000 lm m-2 (MAX_FLUX_DENSITY: a white ground in full sunlight)
    """
    array = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = np.isinf(array) | (array > MAX_FLUX_DENSITY)
    if bad.any():
        shown = ", ".join(f"{v:g}" for v in np.unique(array[bad])[:3])
        raise InputError(
            f"{what}: {int(bad.sum())} flux density values of {shown} lm m-2; expected finite "
            f"values up to {MAX_FLUX_DENSITY:g} lm m-2 (MAX_FLUX_DENSITY: a white ground in "
            "full sunlight)"
        )
