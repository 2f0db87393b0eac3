"""Plausible luminaire data: mounting geometry (height, arm length, tilt) and flux.

A value outside :attr:`PlausibleRange.low` .. :attr:`PlausibleRange.high` cannot describe a
streetlight (a negative arm, a tilt past the vertical, a pole taller than any lighting mast)
and is an error; a value inside that range but outside the usual one is legal but surprising
and deserves a warning. The readers of the luminaire database (:mod:`ies.library`) and the
street placement stage of nightlights check their values against these ranges.

The bounds are deliberately wide. Allowed: a light centre above the ground and below
60 m (high masts reach about 50 m), an arm of 0-15 m (long arms over wide carriageways reach
about 10 m), a tilt between straight down and straight up. Usual: columns of 2.5-30 m, arms
up to 5 m, tilts of -15 to 30 deg (road luminaires are mostly mounted at 0-15 deg above the
horizontal to limit glare and upward light).

Photometric files get the same treatment: candela values that overflow once scaled, or a
table whose luminous flux is not a finite number, are errors naming the file, line and
token; a flux above :data:`MAX_LUMINAIRE_FLUX` is a warning.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ies.errors import PhotometryError

if TYPE_CHECKING:
    from ies.photometry import Photometry

#: Integrated flux above which a file is implausible for one luminaire [lm]: ten times the
#: output of the largest single-lamp luminaires (about 1e6 lm from a 10-15 kW xenon
#: searchlight). Readers warn above it (a wrong candela multiplier or units, usually).
MAX_LUMINAIRE_FLUX = 1e7


@dataclass(frozen=True)
class PlausibleRange:
    """Allowed and usual values of one quantity.

    Attributes
    ----------
    name : str
        Quantity (field) name.
    unit : str
        Unit of the bounds, as written in messages (``m``, ``deg``).
    low, high : float
        Allowed range; outside it a value is impossible [unit].
    usual_low, usual_high : float
        Usual range; outside it (but allowed) a value is surprising [unit].
    low_open : bool
        Whether ``low`` itself is excluded (a mounting height must be > 0).

    Examples
    --------
    >>> height = MOUNTING_RANGES["mounting_height"]
    >>> height.impossible([-1.0, 8.0, 45.0, 1e7]).tolist()
    [True, False, False, True]
    >>> height.unusual([-1.0, 8.0, 45.0, 1e7]).tolist()
    [False, False, True, False]
    >>> height.expected
    'a number in (0, 60] m'
    """

    name: str
    unit: str
    low: float
    high: float
    usual_low: float
    usual_high: float
    low_open: bool = False

    def impossible(self, values: ArrayLike) -> NDArray[np.bool_]:
        """True where a value is not finite or outside the allowed range.

        Parameters
        ----------
        values : array_like
            Values [unit]; missing values (NaN) count as impossible.

        Returns
        -------
        ndarray of bool
            Same shape as ``values``.
        """
        array = np.asarray(values, dtype=float)
        with np.errstate(invalid="ignore"):
            below = array <= self.low if self.low_open else array < self.low
            return ~np.isfinite(array) | below | (array > self.high)

    def unusual(self, values: ArrayLike) -> NDArray[np.bool_]:
        """True where a value is allowed but outside the usual range.

        Parameters
        ----------
        values : array_like
            Values [unit].

        Returns
        -------
        ndarray of bool
            Same shape as ``values``.
        """
        array = np.asarray(values, dtype=float)
        with np.errstate(invalid="ignore"):
            outside = (array < self.usual_low) | (array > self.usual_high)
        return outside & ~self.impossible(array)

    @property
    def interval(self) -> str:
        """The allowed range as an interval with its unit (``(0, 60] m``)."""
        opening = "(" if self.low_open else "["
        return f"{opening}{self.low:g}, {self.high:g}] {self.unit}".rstrip()

    @property
    def expected(self) -> str:
        """The allowed range in words, for error messages."""
        return f"a number in {self.interval}"

    @property
    def usual(self) -> str:
        """The usual range in words, for warnings."""
        return f"{self.usual_low:g}-{self.usual_high:g} {self.unit}".rstrip()


#: Mounting geometry of a light system: height of the light centre above the ground,
#: horizontal mast-arm outreach, and tilt above the horizontal.
MOUNTING_RANGES: dict[str, PlausibleRange] = {
    "mounting_height": PlausibleRange("mounting_height", "m", 0.0, 60.0, 2.5, 30.0, True),
    "arm_length": PlausibleRange("arm_length", "m", 0.0, 15.0, 0.0, 5.0),
    "tilt": PlausibleRange("tilt", "deg", -90.0, 90.0, -15.0, 30.0),
}


def check_magnitudes(
    values: NDArray[np.float64],
    factor: float,
    *,
    error: Callable[[str, int], PhotometryError],
) -> None:
    """Refuse candela values that overflow once scaled by the file's multipliers.

    Parameters
    ----------
    values : ndarray
        Candela values as stored in the file, in file order [cd or cd/klm].
    factor : float
        Product of the multipliers the reader applies [1].
    error : callable
        ``error(message, index)`` builds the exception for the value at ``index`` of
        ``values`` (naming the file, line and token).

    Raises
    ------
    PhotometryError
        A scaled value is not finite, or the values are so large that the luminous flux
        of the table (at most :math:`4\\pi \\max I`) is not a finite number.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = values * factor
        flux_bound = 4.0 * np.pi * (float(np.max(scaled)) if scaled.size else 0.0)
    bad = np.flatnonzero(~np.isfinite(scaled))
    if bad.size:
        raise error(f"candela value x multipliers ({factor:g}) is not a finite number", int(bad[0]))
    if not np.isfinite(flux_bound):
        raise error(
            "candela value too large: the luminous flux would not be a finite number",
            int(np.argmax(scaled)),
        )


def implausible_flux(photometry: Photometry) -> str | None:
    """A warning text when the integrated flux exceeds :data:`MAX_LUMINAIRE_FLUX`, else None.

    Parameters
    ----------
    photometry : Photometry
        A freshly read table.

    Returns
    -------
    str or None
        What is implausible and the usual causes.
    """
    flux = photometry.luminous_flux()
    if flux <= MAX_LUMINAIRE_FLUX:
        return None
    return (
        f"integrated flux {flux:.3g} lm is implausible for one luminaire (more than "
        f"{MAX_LUMINAIRE_FLUX:.0e} lm); check the candela multiplier and units"
    )


__all__ = [
    "MAX_LUMINAIRE_FLUX",
    "MOUNTING_RANGES",
    "PlausibleRange",
    "check_magnitudes",
    "implausible_flux",
]
