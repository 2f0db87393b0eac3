"""Luminaire coordinate frames (Chuang 2011, Sec. 4.3, Eqs. 5-9).

World frame: projected map coordinates, x east, y north, z up [m]. A luminaire's body frame
starts aligned with the world, facing north (+y forward, +x right, +z up) and is rotated in
ZXY order (Chuang 2011, Eq. 6):

1. heading about the vertical axis, clockwise from north (compass bearing) [deg];
2. tilt (pitch) about the body's lateral axis, positive raising the front (+y) [deg];
3. roll about the body's forward axis, positive lowering the right side [deg].

The photometric frame (IES type C) has its z axis pointing down (vertical angle V = 0 at
nadir, 180 at zenith, Chuang 2011, Sec. 4.3 "T_lobe"). Horizontal (C-plane) angles H
increase counterclockwise when the luminaire is viewed from above, and the light system's
``street_azimuth`` C-plane points along the body's forward axis, i.e. along ``heading``.
The type C angle maths is that of :mod:`ies.frames`, applied in the body frame.

The light point (the photometric centre) hangs ``arm_length`` metres from the pole foot
along ``heading``, ``mounting_height`` metres above the ground at the pole foot (Chuang
2011, Eq. 8: a pole translates along z, a mast arm along the facing axis).

Candela tables
--------------
Regular candela tables and world-frame flux profiles of luminaires.

The irradiance kernel looks candela values up millions of times per second, so each
photometry is sampled once onto a regular (vertical, horizontal) grid whose steps divide
every angle of the photometry's own grid. Bilinear interpolation on such a refinement
reproduces the photometry's bilinear interpolation (Chuang 2011, Eq. 4) exactly, because a
bilinear patch restricted to a sub-rectangle is again bilinear. Grids whose angles have no
common step down to 0.1 deg are sampled at 0.25 deg x 0.5 deg (an approximation, logged).

A :class:`FluxProfile` integrates a table over the sphere in the *world* frame (after tilt
and roll), giving the downward and upward flux and the peak intensity at every nadir angle,
from which the region of influence of a luminaire follows.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from ies.frames import direction_from_angles, photometric_angles
from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "FluxProfile",
    "IntensityTable",
    "PhotometryLike",
    "direction_to_photometric",
    "flux_profile",
    "light_points",
    "luminaire_rotation",
    "photometric_to_direction",
]

logger = logging.getLogger(__name__)


def luminaire_rotation(
    heading: ArrayLike, tilt: ArrayLike = 0.0, roll: ArrayLike = 0.0
) -> FloatArray:
    """Rotation matrices from the luminaire body frame to the world frame.

    Parameters
    ----------
    heading
        Compass bearing the luminaire faces, clockwise from north [deg].
    tilt
        Upward tilt of the luminaire's front about its lateral axis [deg].
    roll
        Roll about the luminaire's forward axis, positive lowering the right side [deg].

    Returns
    -------
    numpy.ndarray
        Array (..., 3, 3); ``R @ body_vector`` gives the world vector. Columns are the
        body's right, forward and up axes in world coordinates.

    Notes
    -----
    .. math:: R = R_z(-\\text{heading})\\, R_x(\\text{tilt})\\, R_y(\\text{roll})

    The ZXY order of Chuang's Eq. 6; the heading enters with a minus sign because compass
    bearings turn clockwise seen from above.

    References
    ----------
    Chuang 2011, Sec. 4.3, Eqs. 6-7.

    Examples
    --------
    >>> R = luminaire_rotation(90.0)
    >>> np.round(R @ [0.0, 1.0, 0.0], 12).tolist()  # forward axis now points east
    [1.0, 0.0, 0.0]
    """
    h, t, r = np.broadcast_arrays(
        np.radians(np.asarray(heading, dtype=float)),
        np.radians(np.asarray(tilt, dtype=float)),
        np.radians(np.asarray(roll, dtype=float)),
    )
    ch, sh = np.cos(h), np.sin(h)
    ct, st = np.cos(t), np.sin(t)
    cr, sr = np.cos(r), np.sin(r)
    zeros, ones = np.zeros_like(h), np.ones_like(h)
    # R_z(-heading): compass heading turns the forward axis (+y) clockwise towards +x.
    rz = _stack([[ch, sh, zeros], [-sh, ch, zeros], [zeros, zeros, ones]])
    rx = _stack([[ones, zeros, zeros], [zeros, ct, -st], [zeros, st, ct]])
    ry = _stack([[cr, zeros, sr], [zeros, ones, zeros], [-sr, zeros, cr]])
    return rz @ rx @ ry


def _stack(rows: list[list[FloatArray]]) -> FloatArray:
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def light_points(
    x: ArrayLike,
    y: ArrayLike,
    heading: ArrayLike,
    *,
    mounting_height: ArrayLike,
    arm_length: ArrayLike = 0.0,
    ground_z: ArrayLike = 0.0,
) -> FloatArray:
    """Photometric centres of luminaires from their pole feet.

    Parameters
    ----------
    x, y
        Pole foot in the projected CRS [m].
    heading
        Compass bearing from the pole towards the carriageway [deg].
    mounting_height
        Height of the luminaire above the ground at the pole foot [m].
    arm_length
        Horizontal distance from the pole to the luminaire along ``heading`` [m].
    ground_z
        Ground elevation at the pole foot [m].

    Returns
    -------
    numpy.ndarray
        Array (..., 3) of light points (x, y, z) [m].

    References
    ----------
    Chuang 2011, Sec. 4.3, Eq. 8 (pole: t_z = height; mast: translation along the arm).
    """
    h = np.radians(np.asarray(heading, dtype=float))
    arm = np.asarray(arm_length, dtype=float)
    px = np.asarray(x, dtype=float) + arm * np.sin(h)
    py = np.asarray(y, dtype=float) + arm * np.cos(h)
    pz = np.asarray(ground_z, dtype=float) + np.asarray(mounting_height, dtype=float)
    return np.stack(np.broadcast_arrays(px, py, pz), axis=-1)


def direction_to_photometric(
    direction: ArrayLike,
    rotation: ArrayLike,
    *,
    street_azimuth: ArrayLike = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """Photometric angles (V, H) of world directions leaving a luminaire.

    Parameters
    ----------
    direction
        World vectors (..., 3) from the light point towards the lit point; need not be
        unit vectors [m or 1].
    rotation
        Body-to-world rotations (..., 3, 3) from :func:`luminaire_rotation`, broadcast
        against ``direction``.
    street_azimuth
        C-plane of the photometry that faces the street (the body's forward axis) [deg].

    Returns
    -------
    vertical : numpy.ndarray
        Vertical angle, 0 at nadir, 180 at zenith [deg].
    horizontal : numpy.ndarray
        Horizontal angle in [0, 360), counterclockwise seen from above [deg].

    Notes
    -----
    With body coordinates :math:`b = R^T d` (right, forward, up),

    .. math:: V = \\arccos(-b_z / |b|), \\quad
              H = H_\\text{street} + \\operatorname{atan2}(-b_x, b_y)

    References
    ----------
    Chuang 2011, Sec. 4.3, Eq. 5 (world to lobe frame, T_lobe flips z) and Eq. 2.
    """
    d = np.asarray(direction, dtype=float)
    body = np.einsum("...ji,...j->...i", np.asarray(rotation, dtype=float), d)
    # The photometric frame of ies.frames with x along the street C-plane (forward) and y
    # to the left: (forward, left, up) = (b_y, -b_x, b_z).
    vertical, horizontal = photometric_angles(
        body[..., 1], -body[..., 0], body[..., 2], x_plane=street_azimuth
    )
    # A zero vector (0/0 above) has no direction: call it nadir.
    vertical = np.where(np.isnan(vertical), 0.0, vertical)
    return vertical, horizontal


def photometric_to_direction(
    vertical: ArrayLike,
    horizontal: ArrayLike,
    rotation: ArrayLike,
    *,
    street_azimuth: ArrayLike = 0.0,
) -> FloatArray:
    """World unit vectors of photometric angles; the inverse of :func:`direction_to_photometric`.

    Parameters
    ----------
    vertical
        Vertical angle, 0 at nadir [deg].
    horizontal
        Horizontal (C-plane) angle, counterclockwise seen from above [deg].
    rotation
        Body-to-world rotations (..., 3, 3).
    street_azimuth
        C-plane facing the street [deg].

    Returns
    -------
    numpy.ndarray
        Unit vectors (..., 3) in the world frame [1].
    """
    forward, left, up = direction_from_angles(vertical, horizontal, x_plane=street_azimuth)
    body = np.stack(np.broadcast_arrays(-left, forward, up), axis=-1)
    return np.einsum("...ij,...j->...i", np.asarray(rotation, dtype=float), body)


#: Candidate table steps [deg], largest first.
_STEPS = (5.0, 2.5, 2.0, 1.0, 0.5, 0.25, 0.1)
#: Fallback steps for irregular grids [deg].
_FALLBACK_VERTICAL_STEP = 0.25
_FALLBACK_HORIZONTAL_STEP = 0.5


class PhotometryLike(Protocol):
    """What the table needs from :class:`ies.Photometry`."""

    @property
    def vertical_angles(self) -> FloatArray: ...

    @property
    def horizontal_angles(self) -> FloatArray: ...

    def intensity(self, vertical: ArrayLike, horizontal: ArrayLike) -> FloatArray: ...


@dataclass(frozen=True, eq=False)
class IntensityTable:
    """Luminous intensity on a regular type-C grid, with fast bilinear lookup.

    Attributes
    ----------
    vertical_step
        Grid step of the vertical angle, which runs 0..180 [deg].
    horizontal_step
        Grid step of the horizontal angle, which runs 0..360 inclusive [deg].
    candela
        Intensity, array (n_horizontal, n_vertical) [cd].
    """

    vertical_step: float
    horizontal_step: float
    candela: FloatArray

    def __post_init__(self) -> None:
        n_h, n_v = self.candela.shape
        if not np.isclose((n_v - 1) * self.vertical_step, 180.0) or not np.isclose(
            (n_h - 1) * self.horizontal_step, 360.0
        ):
            raise InputError(
                f"intensity table of shape {self.candela.shape} does not span V 0-180 and "
                f"H 0-360 with steps {self.vertical_step}, {self.horizontal_step} deg"
            )
        if not np.all(np.isfinite(self.candela)) or np.any(self.candela < 0):
            raise InputError("intensity table holds negative or non-finite candela values")

    @classmethod
    def from_function(
        cls,
        intensity: Callable[[FloatArray, FloatArray], ArrayLike],
        *,
        vertical_step: float = 0.5,
        horizontal_step: float = 1.0,
    ) -> IntensityTable:
        """Sample an intensity function on a regular type C grid.

        Parameters
        ----------
        intensity
            ``intensity(vertical, horizontal)`` [cd] of angles [deg].
        vertical_step
            Step of the vertical angle; must divide 180 [deg].
        horizontal_step
            Step of the horizontal angle; must divide 360 [deg].

        Examples
        --------
        >>> table = IntensityTable.from_function(lambda v, h: 100.0 + 0 * v, vertical_step=5.0)
        >>> table.candela.shape, float(table.lookup(42.0, 17.0))
        ((361, 37), 100.0)
        """
        vertical = np.linspace(0.0, 180.0, round(180.0 / vertical_step) + 1)
        horizontal = np.linspace(0.0, 360.0, round(360.0 / horizontal_step) + 1)
        v, h = np.meshgrid(vertical, horizontal)
        values = np.broadcast_to(np.asarray(intensity(v, h % 360.0), dtype=float), v.shape)
        return cls(
            float(vertical[1] - vertical[0]),
            float(horizontal[1] - horizontal[0]),
            np.ascontiguousarray(values, dtype=float),
        )

    @classmethod
    def from_photometry(cls, photometry: PhotometryLike) -> IntensityTable:
        """Sample a photometry on the coarsest regular grid that refines its own grid.

        Parameters
        ----------
        photometry
            Type C photometry with ``vertical_angles``, ``horizontal_angles`` [deg] and
            ``intensity(vertical, horizontal)`` [cd].

        Raises
        ------
        InputError
            The photometry is not type C (types A and B use other angle conventions).
        """
        kind = getattr(photometry, "photometric_type", "C")
        if kind != "C":
            raise InputError(
                f"{getattr(photometry, 'source', 'photometry')}: photometric type {kind}; "
                "ground irradiance needs type C (V from nadir, H around the vertical axis)"
            )
        vertical_step = _common_step(np.asarray(photometry.vertical_angles, dtype=float))
        horizontal_step = _common_step(np.asarray(photometry.horizontal_angles, dtype=float))
        if vertical_step is None or horizontal_step is None:
            logger.info("irregular photometric grid: sampling at 0.25 x 0.5 deg")
        return cls.from_function(
            photometry.intensity,
            vertical_step=vertical_step or _FALLBACK_VERTICAL_STEP,
            horizontal_step=horizontal_step or _FALLBACK_HORIZONTAL_STEP,
        )

    def lookup(self, vertical: ArrayLike, horizontal: ArrayLike) -> FloatArray:
        """Intensity at (vertical, horizontal) by bilinear interpolation [cd].

        Parameters
        ----------
        vertical
            Vertical angle in [0, 180] [deg].
        horizontal
            Horizontal angle in [0, 360) [deg].

        References
        ----------
        Chuang 2011, Sec. 4.2, Eq. 4.
        """
        n_h, n_v = self.candela.shape
        fv = np.asarray(vertical, dtype=float) * (1.0 / self.vertical_step)
        fh = np.asarray(horizontal, dtype=float) * (1.0 / self.horizontal_step)
        iv = np.minimum(fv.astype(np.intp), n_v - 2)
        ih = np.minimum(fh.astype(np.intp), n_h - 2)
        tv = fv - iv
        th = fh - ih
        flat = self.candela.ravel()
        base = ih * n_v + iv
        c00 = flat[base]
        c01 = flat[base + 1]
        c10 = flat[base + n_v]
        c11 = flat[base + n_v + 1]
        lower = c00 + tv * (c01 - c00)
        upper = c10 + tv * (c11 - c10)
        return lower + th * (upper - lower)


def _common_step(angles: FloatArray) -> float | None:
    for step in _STEPS:
        ratio = angles / step
        if np.allclose(ratio, np.round(ratio), rtol=0.0, atol=1e-6):
            return step
    return None


@dataclass(frozen=True)
class FluxProfile:
    """Flux of a mounted luminaire as a function of the world nadir angle.

    Attributes
    ----------
    nadir_angle
        Nodes from 0 (straight down) to 180 (straight up) [deg].
    peak_intensity
        Largest intensity over all azimuths at each node [cd].
    cumulative_flux
        Flux emitted within each nadir angle of straight down [lm].
    """

    nadir_angle: FloatArray
    peak_intensity: FloatArray
    cumulative_flux: FloatArray

    @property
    def total_flux(self) -> float:
        """Total luminous flux [lm]."""
        return float(self.cumulative_flux[-1])

    @property
    def downward_flux(self) -> float:
        """Flux below the horizontal plane [lm]."""
        return float(np.interp(90.0, self.nadir_angle, self.cumulative_flux))

    @property
    def upward_flux(self) -> float:
        """Flux above the horizontal plane (direct uplight) [lm]."""
        return self.total_flux - self.downward_flux


def flux_profile(
    table: IntensityTable,
    *,
    tilt: float = 0.0,
    roll: float = 0.0,
    street_azimuth: float = 0.0,
    nadir_step: float = 0.5,
    azimuth_step: float = 2.0,
) -> FluxProfile:
    """Integrate a mounted luminaire's intensity over world azimuth.

    Parameters
    ----------
    table
        Candela table in the photometric frame.
    tilt, roll
        Mounting rotations (see :mod:`nightlights.ground.frames`) [deg].
    street_azimuth
        C-plane facing the street [deg].
    nadir_step
        Step of the nadir-angle nodes; must divide 90 [deg].
    azimuth_step
        Azimuth step of the midpoint quadrature [deg].

    Returns
    -------
    FluxProfile

    Notes
    -----
    Midpoint rule on each nadir band: :math:`\\Phi = \\sum I \\sin\\theta\\,\\Delta\\theta\\,
    \\Delta\\phi`. The heading does not matter: it turns the lobe about the vertical.
    """
    n_bands = round(180.0 / nadir_step)
    nodes = np.linspace(0.0, 180.0, n_bands + 1)
    step = np.radians(nodes[1] - nodes[0])
    azimuth = np.radians(np.arange(0.0, 360.0, azimuth_step) + azimuth_step / 2)
    rotation = luminaire_rotation(0.0, tilt, roll)

    def intensity(theta: FloatArray) -> FloatArray:
        t, a = np.meshgrid(theta, azimuth, indexing="ij")
        direction = np.stack([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), -np.cos(t)], -1)
        vertical, horizontal = direction_to_photometric(
            direction, rotation, street_azimuth=street_azimuth
        )
        return table.lookup(vertical, horizontal)

    centres = np.radians(nodes[:-1]) + step / 2
    band_flux = intensity(centres).sum(axis=1) * np.sin(centres) * step * np.radians(azimuth_step)
    cumulative = np.concatenate([[0.0], np.cumsum(band_flux)])
    peak = intensity(np.radians(nodes)).max(axis=1)
    return FluxProfile(nodes, peak, cumulative)
