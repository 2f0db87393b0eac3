"""Checks of user input shared by the stages; each raises a one-line :class:`InputError`."""

from __future__ import annotations

import math
import numbers

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
