"""The EN 13201 quality figures of a calculation field: luminance, uniformity, glare, edges.

Luminance (EN 13201-3:2015, Sec. 9.1-9.3), over the points of the field for one observer:

.. math:: L_\\text{av} = \\frac{1}{N} \\sum_i L_i, \\quad U_o = L_\\text{min} / L_\\text{av},
          \\quad U_l = \\min_\\text{lanes} \\frac{L_\\text{min}}{L_\\text{max}}
          \\big|_\\text{lane centre line}

where each lane's centre line is seen by the observer in that lane. The standard rates a
section by the lowest :math:`L_\\text{av}` and :math:`U_o` over its observers: the functions
here return one value per observer, the caller takes the minimum.

Disability glare (EN 13201-3:2015, Sec. 9.4; CIE 140:2000): with :math:`E_k` the illuminance
[lx] from luminaire k at the eye on a plane normal to the line of sight (1 deg below the
horizontal, along the road) and :math:`\\theta_k` [deg] the angle between the line of sight and
the direction to the luminaire,

.. math:: L_v = K(A) \\sum_k E_k / \\theta_k^2, \\quad
          K(A) = 9.86 \\left(1 + (A / 66.4)^4\\right)

(:math:`A` the observer's age, 23 years by default: :math:`K \\approx 10`), valid for
:math:`1.5^\\circ \\le \\theta_k \\le 60^\\circ`; and the threshold increment [%]

.. math:: f_{TI} = 65\\, L_v / L_\\text{av}^{0.8} \\ (L_\\text{av} \\le 5\\,\\text{cd m}^{-2}),
          \\quad 95\\, L_v / L_\\text{av}^{1.05} \\ (L_\\text{av} > 5\\,\\text{cd m}^{-2}).

:func:`glare_geometry` gives :math:`E_k` and :math:`\\theta_k` from luminaires and marks those
counted: ahead of the eye, below the screening angle of a car roof (20 deg above the
horizontal, a modelling choice stated here as it was not checked against the standard's text
in this project) and with :math:`\\theta` in the formula's range. Which luminaires the
standard includes (the first in the field onwards, up to 500 m ahead) is for the caller to
pass.

Edge illuminance ratio (EN 13201-3:2015, Sec. 9.5): the average illuminance on a strip just
outside each carriageway edge over that on a strip just inside it, the lower of the two sides;
strips of width :math:`\\min(5\\,\\text{m}, W/2, \\text{verge})`.

Illuminance classes (C, P; EN 13201-2:2015): average and minimum horizontal illuminance over
the illuminance field, and :math:`U_o = E_\\text{min} / E_\\text{av}`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.roads._geometry import Intensity, intensities, light_array

__all__ = [
    "GlareGeometry",
    "age_factor",
    "average_illuminance",
    "average_luminance",
    "edge_illuminance_ratio",
    "edge_strip_width",
    "glare_geometry",
    "illuminance_uniformity",
    "longitudinal_uniformity",
    "minimum_illuminance",
    "overall_uniformity",
    "threshold_increment",
    "veiling_luminance",
]

#: Age of the reference observer of EN 13201-3 / CIE 140 [year].
REFERENCE_AGE = 23.0
#: Constant of the veiling luminance (CIE 140:2000; EN 13201-3:2015, 9.4) [cd m-2 lx-1 deg2].
VEILING_CONSTANT = 9.86
#: Age scale of the age factor (CIE 140:2000) [year].
AGE_SCALE = 66.4
#: Range of glare angles the veiling luminance formula holds for (CIE 140:2000) [deg].
GLARE_ANGLE_RANGE = (1.5, 60.0)
#: Average luminance where the f_TI formula changes (EN 13201-3:2015, 9.4) [cd m-2].
TI_LUMINANCE_BREAK = 5.0
#: Depression of the line of sight below the horizontal (EN 13201-3:2015, 9.4) [deg].
LINE_OF_SIGHT_DEPRESSION = 1.0
#: Screening angle of a car roof above the horizontal (CIE 140:2000) [deg].
SCREENING_ANGLE = 20.0
#: Widest edge strip (EN 13201-3:2015, 9.5) [m].
EDGE_STRIP_MAX = 5.0


def _field_values(values: ArrayLike, name: str) -> FloatArray:
    array = np.asarray(values, dtype=float)
    if array.ndim < 2 or array.shape[-1] == 0 or array.shape[-2] == 0:
        raise InputError(
            f"{name} of shape {array.shape}; expected a field (..., n_x, n_y) with points"
        )
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise InputError(f"{name} holds negative or non-finite values")
    return array


def average_luminance(luminance: ArrayLike) -> FloatArray:
    """Average luminance of a field, one per observer [cd m-2].

    Parameters
    ----------
    luminance
        Luminance at the field points, (..., n_x, n_y) [cd m-2].

    References
    ----------
    EN 13201-3:2015, Sec. 9.1.

    Examples
    --------
    >>> float(average_luminance([[1.0, 2.0], [3.0, 2.0]]))
    2.0
    """
    return np.asarray(_field_values(luminance, "luminance").mean(axis=(-2, -1)))


def overall_uniformity(luminance: ArrayLike) -> FloatArray:
    """Overall uniformity U_o = L_min / L_av, one per observer [1].

    Parameters
    ----------
    luminance
        Luminance at the field points, (..., n_x, n_y) [cd m-2].

    References
    ----------
    EN 13201-3:2015, Sec. 9.2.

    Examples
    --------
    >>> float(overall_uniformity([[1.0, 2.0], [3.0, 2.0]]))
    0.5
    """
    array = _field_values(luminance, "luminance")
    return _ratio(array.min(axis=(-2, -1)), array.mean(axis=(-2, -1)), "average luminance")


def _ratio(numerator: FloatArray, denominator: FloatArray, what: str) -> FloatArray:
    if np.any(denominator <= 0):
        raise InputError(f"{what} of 0; a uniformity needs a lit field")
    return np.asarray(numerator / denominator)


def longitudinal_uniformity(luminance: ArrayLike, centre_columns: Sequence[int]) -> float:
    """Longitudinal uniformity U_l: the lowest L_min / L_max along a lane centre line [1].

    Parameters
    ----------
    luminance
        Luminance for the observer of each lane, (lanes, n_x, n_y) [cd m-2].
    centre_columns
        Column of each lane's centre line
        (:meth:`~nightlights.roads.CalculationField.lane_centre_columns`).

    References
    ----------
    EN 13201-3:2015, Sec. 9.3.

    Examples
    --------
    >>> field = [[[1, 2, 1], [1, 4, 1]], [[1, 1, 3], [1, 1, 6]]]
    >>> longitudinal_uniformity(field, [1, 2])
    0.5
    """
    array = _field_values(luminance, "luminance")
    columns = list(centre_columns)
    if array.ndim != 3 or array.shape[0] != len(columns):
        raise InputError(
            f"luminance of shape {array.shape} for {len(columns)} lanes; expected "
            "(lanes, n_x, n_y), one field per lane's observer"
        )
    if any(not 0 <= c < array.shape[2] for c in columns):
        raise InputError(f"centre_columns {columns}; expected columns in 0-{array.shape[2] - 1}")
    lines = np.stack([array[j, :, c] for j, c in enumerate(columns)])
    return float(np.min(_ratio(lines.min(axis=1), lines.max(axis=1), "maximum luminance")))


def age_factor(age: float) -> float:
    """K(A) = 9.86 (1 + (A / 66.4)^4) of the veiling luminance [cd m-2 lx-1 deg2].

    Parameters
    ----------
    age
        Observer's age [year].

    Examples
    --------
    >>> round(age_factor(23.0), 3)
    10.002
    """
    if not (np.isfinite(age) and age > 0):
        raise InputError(f"age={age!r} years; expected a positive age")
    return VEILING_CONSTANT * (1.0 + (age / AGE_SCALE) ** 4)


def veiling_luminance(
    eye_illuminance: ArrayLike, glare_angle: ArrayLike, *, age: float = REFERENCE_AGE
) -> float:
    """Veiling luminance L_v = K(A) sum E_k / theta_k^2 [cd m-2].

    Parameters
    ----------
    eye_illuminance
        Illuminance at the eye on a plane normal to the line of sight, one per luminaire [lx].
    glare_angle
        Angle between the line of sight and each luminaire, 1.5-60 [deg].
    age
        Observer's age [year].

    Raises
    ------
    InputError
        An angle outside 1.5-60 deg, where the formula does not hold.

    References
    ----------
    CIE 140:2000, Road lighting calculations; EN 13201-3:2015, Sec. 9.4.

    Examples
    --------
    >>> round(veiling_luminance([0.5], [10.0]), 5)
    0.05001
    """
    e = np.asarray(eye_illuminance, dtype=float)
    theta = np.asarray(glare_angle, dtype=float)
    low, high = GLARE_ANGLE_RANGE
    if np.any((theta < low) | (theta > high)) or not np.all(np.isfinite(theta)):
        raise InputError(
            f"glare_angle {np.unique(theta[~((theta >= low) & (theta <= high))])[:3].tolist()} "
            f"deg; the veiling luminance formula holds for {low}-{high} deg"
        )
    if not np.all(np.isfinite(e)) or np.any(e < 0):
        raise InputError("eye_illuminance holds negative or non-finite values")
    return float(age_factor(age) * np.sum(e / theta**2))


def threshold_increment(veiling: float, average: float) -> float:
    """Threshold increment f_TI [%] from the veiling and the average road luminance.

    Parameters
    ----------
    veiling
        Veiling luminance L_v [cd m-2].
    average
        Average road luminance L_av [cd m-2].

    References
    ----------
    EN 13201-3:2015, Sec. 9.4; CIE 140:2000.

    Examples
    --------
    >>> threshold_increment(0.1, 1.0)
    6.5
    """
    if not (np.isfinite(average) and average > 0):
        raise InputError(f"average={average!r} cd m-2; expected a positive average luminance")
    if not (np.isfinite(veiling) and veiling >= 0):
        raise InputError(f"veiling={veiling!r} cd m-2; expected a non-negative luminance")
    if average <= TI_LUMINANCE_BREAK:
        return float(65.0 * veiling / average**0.8)
    return float(95.0 * veiling / average**1.05)


@dataclass(frozen=True)
class GlareGeometry:
    """Per-luminaire glare terms for one observer (see :func:`glare_geometry`).

    Attributes
    ----------
    eye_illuminance
        Illuminance at the eye normal to the line of sight, (n,) [lx].
    angle
        Angle between the line of sight and the luminaire, (n,) [deg].
    counted
        Whether the luminaire counts: ahead, below the screening angle, angle in 1.5-60 deg.
    """

    eye_illuminance: FloatArray
    angle: FloatArray
    counted: np.ndarray


def glare_geometry(
    observer: ArrayLike,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    *,
    street_azimuth: ArrayLike = 0.0,
    screening_angle: float = SCREENING_ANGLE,
) -> GlareGeometry:
    """Eye illuminance and glare angle of each luminaire for an observer looking along +x.

    Parameters
    ----------
    observer
        Eye (x, y, z) in the road frame [m].
    light_points
        Photometric centres (n, 3) [m].
    rotation
        Body-to-world rotations, (3, 3) or (n, 3, 3).
    intensity
        ``intensity(vertical, horizontal)`` [cd], one or one per luminaire.
    street_azimuth
        C-plane facing the street [deg].
    screening_angle
        Elevation above the horizontal beyond which the car roof hides a luminaire [deg].

    Notes
    -----
    Line of sight :math:`s = (\\cos 1^\\circ, 0, -\\sin 1^\\circ)`; for a luminaire at distance
    :math:`d` in unit direction :math:`u` from the eye, :math:`\\theta = \\arccos(s \\cdot u)`
    and :math:`E = I \\cos\\theta / d^2` with :math:`I` its intensity towards the eye.
    """
    eye = np.asarray(observer, dtype=float)
    if eye.shape != (3,):
        raise InputError(f"observer of shape {eye.shape}; expected one point (x, y, z) [m]")
    lights, rotations = light_array(light_points, rotation)
    candela = intensities(eye[None, :], lights, rotations, intensity, street_azimuth=street_azimuth)
    to_light = lights - eye
    distance = np.linalg.norm(to_light, axis=1)
    unit = to_light / distance[:, None]
    depression = np.radians(LINE_OF_SIGHT_DEPRESSION)
    sight = np.array([np.cos(depression), 0.0, -np.sin(depression)])
    cos_theta = np.clip(unit @ sight, -1.0, 1.0)
    angle = np.degrees(np.arccos(cos_theta))
    eye_illuminance = np.where(cos_theta > 0, candela[:, 0] * cos_theta / distance**2, 0.0)
    elevation = np.degrees(np.arcsin(np.clip(unit[:, 2], -1.0, 1.0)))
    low, high = GLARE_ANGLE_RANGE
    counted = (
        (to_light[:, 0] > 0) & (elevation < screening_angle) & (angle >= low) & (angle <= high)
    )
    return GlareGeometry(eye_illuminance, angle, counted)


def edge_strip_width(carriageway_width: float, verge_width: float = np.inf) -> float:
    """Width of the strips of the edge illuminance ratio [m].

    Parameters
    ----------
    carriageway_width
        Width of the carriageway [m].
    verge_width
        Width of the unobstructed strip beside it [m].

    Examples
    --------
    >>> edge_strip_width(7.0), edge_strip_width(12.0), edge_strip_width(12.0, 2.0)
    (3.5, 5.0, 2.0)
    """
    if not (carriageway_width > 0 and verge_width > 0):
        raise InputError(
            f"carriageway_width={carriageway_width!r}, verge_width={verge_width!r} m; "
            "expected positive widths"
        )
    return float(min(EDGE_STRIP_MAX, carriageway_width / 2.0, verge_width))


def edge_illuminance_ratio(inside: Sequence[ArrayLike], outside: Sequence[ArrayLike]) -> float:
    """Edge illuminance ratio R_EI: the lowest E_av(outside strip) / E_av(inside strip) [1].

    Parameters
    ----------
    inside
        Illuminance at the points of the strip just inside each edge, one array per side [lx].
    outside
        Illuminance at the points of the strip just outside each edge, same sides [lx].

    References
    ----------
    EN 13201-3:2015, Sec. 9.5.

    Examples
    --------
    >>> edge_illuminance_ratio([[10, 12], [8.0]], [[6, 5], [6.0]])
    0.5
    """
    if len(inside) != len(outside) or len(inside) == 0:
        raise InputError(
            f"{len(inside)} inside and {len(outside)} outside strips; expected one of each per side"
        )
    ratios = []
    for near, far in zip(inside, outside, strict=True):
        e_in = _illuminance(near, "inside strip")
        e_out = _illuminance(far, "outside strip")
        ratios.append(
            float(
                _ratio(
                    np.asarray(np.mean(e_out)),
                    np.asarray(np.mean(e_in)),
                    "inside strip illuminance",
                )
            )
        )
    return min(ratios)


def _illuminance(values: ArrayLike, name: str) -> FloatArray:
    array = np.asarray(values, dtype=float)
    if array.size == 0 or not np.all(np.isfinite(array)) or np.any(array < 0):
        raise InputError(f"{name}: expected non-negative, finite illuminance at some points")
    return array


def average_illuminance(illuminance: ArrayLike) -> float:
    """Average horizontal illuminance over a field [lx] (EN 13201-3:2015, Sec. 8).

    Examples
    --------
    >>> average_illuminance([[10.0, 20.0], [30.0, 20.0]])
    20.0
    """
    return float(np.mean(_field_values(illuminance, "illuminance")))


def minimum_illuminance(illuminance: ArrayLike) -> float:
    """Minimum horizontal illuminance over a field [lx] (EN 13201-3:2015, Sec. 8).

    Examples
    --------
    >>> minimum_illuminance([[10.0, 20.0], [30.0, 20.0]])
    10.0
    """
    return float(np.min(_field_values(illuminance, "illuminance")))


def illuminance_uniformity(illuminance: ArrayLike) -> float:
    """Overall uniformity of illuminance U_o = E_min / E_av [1] (EN 13201-2:2015, C classes).

    Examples
    --------
    >>> illuminance_uniformity([[10.0, 20.0], [30.0, 20.0]])
    0.5
    """
    array = _field_values(illuminance, "illuminance")
    return float(_ratio(np.asarray(array.min()), np.asarray(array.mean()), "average illuminance"))
