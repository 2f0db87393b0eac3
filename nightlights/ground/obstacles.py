"""Obstacles around the emitting ground: how much of an emission function escapes a street.

The obstacle description is ILLUMINA's (Aubé 2015, Sect. 2; Aubé & Simoneau 2018, Sect. 2.3):
each cell holds an obstacle height h [m], a distance between obstacles d [m] and a filling
factor f [1]. Light leaving the ground between the obstacles is stopped below the obstacle
angle, the elevation of the obstacles' top seen from halfway between them,

.. math::
    \\alpha_0 = \\arctan\\frac{h}{d / 2},

and f is the probability that a low ray meets an obstacle at all (1 - f: gaps between them).

Geometry chosen here (the project's reading of that description, which makes it exact for a
street canyon): the cell's streets are infinite canyons of width d between walls of height h,
the light leaves from the canyon floor's centre line, and the canyons' orientations are
uniformly distributed over the cell. A ray of elevation e at azimuth phi from the canyon axis
meets the wall top at horizontal distance (d / 2) / |sin phi|, so it is stopped when
tan e < (2 h / d) |sin phi|: across the street the obstacle angle is alpha_0, along it the
street is open. Averaged over the orientations, the fraction of rays of elevation e that escape
a canyon is

.. math::
    \\tau(e) = \\frac{2}{\\pi} \\arcsin\\left(\\min\\left(1,
    \\frac{\\tan e}{\\tan \\alpha_0}\\right)\\right),

and with the filling factor the transmission of the cell is t(e) = 1 - f + f tau(e). An
emission function of intensity I(theta) per lumen (theta = 90 deg - e from the vertical) keeps

.. math::
    F = 2 \\pi \\int_0^{\\pi/2} I(\\theta(e))\\, t(e) \\cos e \\, de
      = 1 - f + f\\, G(\\alpha_0), \\qquad G = 2\\pi \\int I \\tau \\cos e\\, de,

of its flux. For the Lambertian floor G is the sky view factor of the canyon floor's centre,
G = <cos^2 alpha(phi)> = 1 / sqrt(1 + (2 h / d)^2) = cos alpha_0 (0.447 for h / d = 1; the
canyon floor's sky view factor, Oke 1987, Sect. 10.1 and Table 10.1). The integral is done by
Gauss-Legendre quadrature in u, tan e = tan alpha_0 sin u (which takes the arcsin's square-root
edge at e = alpha_0 out of the integrand), and above alpha_0, where t = 1.

The stopped light is removed: the walls' reflections back into the street and out of it are
not followed (an underestimate of the escaping light of a bright-walled street). The direct
uplight of the luminaires is taken to leave from the floor as well (their mounting height is
not subtracted from h: an overestimate of its blocking).

Defaults by land use (:data:`LAND_USE_OBSTACLES`) are the project's choice where no obstacle
data is given: the middle of the ranges of the local climate zones of Stewart & Oke (2012,
Table 2): mean building (or tree) height for h, the height-to-width ratio H/W for d = h / (H/W)
and the building surface fraction for f (trees: the project's guess of a 0.5 crown cover).

References
----------
1. Aubé, M. 2015, "Physical behaviour of anthropogenic light propagation into the nocturnal
   environment", Phil. Trans. R. Soc. B 370, 20140117.
2. Aubé, M. & Simoneau, A. 2018, "New features to the night sky radiance model ILLUMINA:
   Hyperspectral support, improved obstacles and cloud reflection", JQSRT 211, 25-34.
3. Oke, T. R. 1987, "Boundary Layer Climates", 2nd ed., Routledge.
4. Stewart, I. D. & Oke, T. R. 2012, "Local Climate Zones for urban temperature studies",
   Bull. Amer. Meteor. Soc. 93, 1879-1900, Table 2.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.emission_functions import EmissionFunction, emission_intensity
from nightlights.errors import InputError

__all__ = [
    "LAND_USE_OBSTACLES",
    "OBSTACLE_NODES",
    "ObstacleProperties",
    "blocked_intensity",
    "check_obstacles",
    "escaping_fraction",
    "obstacle_angle",
    "obstacle_transmission",
]

#: Gauss-Legendre nodes of each of the two pieces of the escaping-fraction integral [1]; the
#: integrands are smooth after the substitution, and 48 nodes reproduce the closed-form
#: Lambertian canyon factor cos(alpha_0) to 1e-12 (tests/nightlights/ground/test_obstacles.py).
OBSTACLE_NODES = 48
#: Obstacle angles [deg] of the table the per-cell escaping fractions are interpolated from
#: (linear in the angle; the step of 0.05 deg keeps the interpolation error below 1e-6).
_TABLE_ANGLES = np.linspace(0.0, 90.0, 1801)


def check_obstacles(height: ArrayLike, spacing: ArrayLike, filling: ArrayLike) -> None:
    """Refuse obstacle values the model cannot take (NaN counts as no obstacle and passes).

    Parameters
    ----------
    height
        Obstacle height, >= 0 [m].
    spacing
        Distance between obstacles, >= 0 [m].
    filling
        Filling factor, in [0, 1] [1].

    Raises
    ------
    InputError
        A negative or infinite height or spacing, or a filling factor outside [0, 1]; the
        message gives the first bad value.

    Examples
    --------
    >>> check_obstacles(-1.0, 20.0, 0.5)
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: obstacle height=-1.0 m; expected a finite height >= 0 m
    """
    checks = (
        ("height", height, "m", "a finite height >= 0 m", lambda v: (v >= 0) & np.isfinite(v)),
        ("spacing", spacing, "m", "a finite distance >= 0 m", lambda v: (v >= 0) & np.isfinite(v)),
        ("filling", filling, "", "a filling factor in [0, 1]", lambda v: (v >= 0) & (v <= 1)),
    )
    for name, value, unit, expected, fine in checks:
        v = np.asarray(value, dtype=float)
        bad = ~np.isnan(v) & ~fine(v)
        if np.any(bad):
            first = float(v[bad].flat[0])
            where = ""
            if v.ndim:
                index = tuple(int(i[0]) for i in np.nonzero(bad))
                where = f" at index {index}" if len(index) > 1 else f" at index {index[0]}"
            shown = f"{first!r} {unit}".rstrip()
            raise InputError(f"obstacle {name}={shown}{where}; expected {expected}")


@dataclass(frozen=True)
class ObstacleProperties:
    """Obstacles of one cell, or uniform over a scene (ILLUMINA's three numbers).

    Attributes
    ----------
    height
        Obstacle height h above the ground, >= 0 [m].
    spacing
        Distance d between obstacles (street width), >= 0 [m].
    filling
        Filling factor f, the fraction of low rays an obstacle meets, in [0, 1] [1].

    Examples
    --------
    >>> round(ObstacleProperties(10.0, 20.0, 1.0).angle, 1)  # atan(10 / 10)
    45.0
    """

    height: float
    spacing: float
    filling: float

    def __post_init__(self) -> None:
        check_obstacles(self.height, self.spacing, self.filling)

    @property
    def angle(self) -> float:
        """Obstacle angle alpha_0 across the street [deg]."""
        return float(obstacle_angle(self.height, self.spacing))


#: Obstacles by land use when no data is given: local climate zones of Stewart & Oke (2012,
#: Table 2), the middle of each range (height [m], H/W [1], building surface fraction [1]), with
#: d = h / (H/W); ``dense_trees``: crown cover 0.5 (the project's guess); ``open``: none.
LAND_USE_OBSTACLES: dict[str, ObstacleProperties] = {
    # LCZ 1: h > 25 m (30 taken), H/W > 2 (2.5 taken), BSF 0.40-0.60.
    "compact_highrise": ObstacleProperties(30.0, 30.0 / 2.5, 0.5),
    # LCZ 2: h 10-25 m, H/W 0.75-2, BSF 0.40-0.70.
    "compact_midrise": ObstacleProperties(17.5, 17.5 / 1.375, 0.55),
    # LCZ 3: h 3-10 m, H/W 0.75-1.5, BSF 0.40-0.70.
    "compact_lowrise": ObstacleProperties(6.5, 6.5 / 1.125, 0.55),
    # LCZ 4: h > 25 m (30 taken), H/W 0.75-1.25, BSF 0.20-0.40.
    "open_highrise": ObstacleProperties(30.0, 30.0 / 1.0, 0.3),
    # LCZ 5: h 10-25 m, H/W 0.3-0.75, BSF 0.20-0.40.
    "open_midrise": ObstacleProperties(17.5, 17.5 / 0.525, 0.3),
    # LCZ 6: h 3-10 m, H/W 0.3-0.75, BSF 0.20-0.40.
    "open_lowrise": ObstacleProperties(6.5, 6.5 / 0.525, 0.3),
    # LCZ 9: h 3-10 m, H/W 0.1-0.25, BSF 0.10-0.20.
    "sparsely_built": ObstacleProperties(6.5, 6.5 / 0.175, 0.15),
    # LCZ A: tree height 3-30 m (16.5), H/W > 1 (1.5 taken); crown cover 0.5 (guess).
    "dense_trees": ObstacleProperties(16.5, 16.5 / 1.5, 0.5),
    # LCZ D, E, F, G: low plants, bare ground, water: no obstacles.
    "open": ObstacleProperties(0.0, 0.0, 0.0),
}


def obstacle_angle(height: ArrayLike, spacing: ArrayLike) -> FloatArray:
    """Obstacle angle across the street, atan(h / (d / 2)) (90 deg where d = 0 < h).

    Parameters
    ----------
    height
        Obstacle height [m].
    spacing
        Distance between obstacles [m].

    Returns
    -------
    numpy.ndarray
        Elevation of the obstacles' top seen from halfway between them [deg]; 0 where h = 0.
    """
    h = np.asarray(height, dtype=float)
    d = np.asarray(spacing, dtype=float)
    return np.degrees(np.arctan2(h, d / 2.0))


def obstacle_transmission(
    elevation: ArrayLike, height: ArrayLike, spacing: ArrayLike, filling: ArrayLike
) -> FloatArray:
    """Fraction of the rays of one elevation that leave the street, t(e) = 1 - f + f tau(e).

    Parameters
    ----------
    elevation
        Elevation of the ray above the horizontal [deg].
    height, spacing, filling
        Obstacle height [m], distance between obstacles [m] and filling factor [1]
        (broadcast against ``elevation``).

    Returns
    -------
    numpy.ndarray
        Transmission [1]: 1 above the obstacle angle, 1 - f at the horizon.

    Examples
    --------
    A ray 30 deg up in a canyon of H/W = 1 (obstacle angle atan 2 = 63.4 deg) clears the
    walls for the street orientations within arcsin(tan 30 / 2) = 16.8 deg of it, either side:
    2 x 16.8 / 180 = 0.186 of them:

    >>> round(float(obstacle_transmission(30.0, 10.0, 10.0, 1.0)), 3)
    0.186
    """
    check_obstacles(height, spacing, filling)
    e = np.radians(np.asarray(elevation, dtype=float))
    f = np.asarray(filling, dtype=float)
    alpha = np.radians(obstacle_angle(height, spacing))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(alpha > 0, np.tan(np.clip(e, 0, None)) / np.tan(alpha), np.inf)
    tau = (2.0 / math.pi) * np.arcsin(np.clip(ratio, 0.0, 1.0))
    return np.asarray(1.0 - f + f * tau, dtype=float)


IntensityLike = str | EmissionFunction | Callable[[FloatArray], FloatArray]


def _intensity(emission: IntensityLike) -> Callable[[FloatArray], FloatArray]:
    """Intensity per lumen as a function of cos(theta): a shape name, a mix or a callable."""
    if isinstance(emission, EmissionFunction):
        return emission.intensity
    if isinstance(emission, str):
        return functools.partial(_shape_intensity, emission)
    return emission


def _shape_intensity(name: str, mu: FloatArray) -> FloatArray:
    return emission_intensity(mu, name)


def _canyon_factor(
    intensity: Callable[[FloatArray], FloatArray], alpha: FloatArray, nodes: int
) -> FloatArray:
    """G(alpha_0): the flux an emission function sends out of a fully filled (f = 1) cell."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    alpha = np.asarray(alpha, dtype=float)[..., None]
    # Below alpha_0: tan e = tan alpha_0 sin u, u in [0, pi/2], tau = 2 u / pi.
    u = (x + 1.0) * math.pi / 4.0
    tan_a = np.tan(np.minimum(alpha, np.radians(89.999999)))
    e = np.arctan(tan_a * np.sin(u))
    de_du = tan_a * np.cos(u) / (1.0 + (tan_a * np.sin(u)) ** 2)
    low = np.sum(
        w * (math.pi / 4.0) * intensity(np.sin(e)) * (2.0 * u / math.pi) * np.cos(e) * de_du,
        axis=-1,
    )
    # Above alpha_0: every ray escapes.
    half = (math.pi / 2.0 - alpha) / 2.0
    e = alpha + (x + 1.0) * half
    high = np.sum(w * half * intensity(np.sin(e)) * np.cos(e), axis=-1)
    return np.asarray(2.0 * math.pi * (low + high), dtype=float)


def escaping_fraction(
    emission: IntensityLike,
    height: ArrayLike,
    spacing: ArrayLike,
    filling: ArrayLike,
    *,
    nodes: int = OBSTACLE_NODES,
) -> FloatArray:
    """Fraction of an emission function's flux that leaves the street: F = 1 - f + f G.

    Parameters
    ----------
    emission
        A registered shape name (``lambertian``, ``uplight``, ``garstang_lobe``), an
        :class:`~nightlights.emission_functions.EmissionFunction` mix, or a function of
        cos(theta) giving the intensity per lumen of upward flux [cd lm-1].
    height, spacing, filling
        Obstacle height [m], distance between obstacles [m] and filling factor [1], scalars
        or arrays broadcast together.
    nodes
        Gauss-Legendre nodes of each piece of the integral [1].

    Returns
    -------
    numpy.ndarray
        Escaping fraction [1]; exactly 1 where h = 0 or f = 0.

    Raises
    ------
    InputError
        Bad obstacle values (:func:`check_obstacles`).

    Examples
    --------
    The floor of a canyon as high as it is wide sees cos(atan 2) = 0.447 of its sky:

    >>> round(float(escaping_fraction("lambertian", 10.0, 10.0, 1.0)), 4)
    0.4472
    """
    check_obstacles(height, spacing, filling)
    h, d, f = np.broadcast_arrays(
        np.asarray(height, dtype=float),
        np.asarray(spacing, dtype=float),
        np.asarray(filling, dtype=float),
    )
    open_ = ~((h > 0) & (f > 0))  # NaN compares False: no obstacle
    alpha = np.radians(obstacle_angle(np.where(open_, 0.0, h), np.where(open_, 1.0, d)))
    intensity = _intensity(emission)
    if alpha.size > _TABLE_ANGLES.size:
        table = _canyon_factor(intensity, np.radians(_TABLE_ANGLES), nodes)
        g = np.interp(np.degrees(alpha), _TABLE_ANGLES, table)
    else:
        g = _canyon_factor(intensity, alpha, nodes)
    out = np.where(open_, 1.0, 1.0 - f + f * g)
    return np.asarray(out, dtype=float)


def blocked_intensity(
    cos_zenith: ArrayLike,
    emission: IntensityLike,
    height: float,
    spacing: float,
    filling: float,
) -> FloatArray:
    """The exact intensity that leaves the street, I(theta) t(90 deg - theta), per lumen
    emitted on the floor (its flux is :func:`escaping_fraction`).

    Parameters
    ----------
    cos_zenith
        Cosine of the angle from the vertical [1].
    emission
        As in :func:`escaping_fraction`.
    height, spacing, filling
        Obstacle height [m], distance between obstacles [m] and filling factor [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1].
    """
    mu = np.asarray(cos_zenith, dtype=float)
    elevation = np.degrees(np.arcsin(np.clip(mu, 0.0, 1.0)))
    t = obstacle_transmission(elevation, height, spacing, filling)
    return np.asarray(_intensity(emission)(mu) * t, dtype=float)
