"""Road luminance from reduced luminance coefficient tables (r-tables).

The luminance of a dry road surface at a point P seen by an observer is (CIE 144:2001,
Sec. 2; EN 13201-3:2015, Sec. 7.1)

.. math:: L = \\sum_k r(\\beta_k, \\tan\\gamma_k)\\, \\frac{I_k(C_k, \\gamma_k)}{h_k^2}
          \\times 10^{-4}

where, for luminaire k, :math:`h_k` is its height above P [m], :math:`\\gamma_k` the angle of
incidence at P from the vertical (:math:`\\tan\\gamma_k` = horizontal distance / :math:`h_k`),
:math:`\\beta_k` the angle between the vertical plane of incidence and the vertical plane of
observation, :math:`I_k` its intensity towards P [cd] and :math:`r = q \\cos^3\\gamma` the
reduced luminance coefficient, tabulated in units of :math:`10^{-4}` sr-1. Here
:math:`\\beta = 0` when the luminaire stands beyond P on the observer's line of sight (the
specular direction), 180 deg when it stands behind the observer; tables are symmetric about
the observation plane, so :math:`\\beta \\in [0, 180]`.

Modelling choices:

- interpolation on the table's grid (``interpolation=``): ``"bilinear"`` in
  :math:`(\\beta, \\tan\\gamma)`, ``"bilinear_gamma"`` (bilinear in
  :math:`(\\beta, \\gamma)`, the rows placed at :math:`\\gamma = \\arctan(\\tan\\gamma)`) or
  ``"cubic"`` (the default: the interpolating bicubic spline through the nodes, scipy's
  ``RectBivariateSpline``, negative overshoots set to 0).
  ``benchmarks/bench_rtable_interpolation.py`` compares them against the exact r of
  :func:`synthetic_rtable`'s analytic form (:data:`DEFAULT_INTERPOLATION` says why the spline
  is the default);
- :math:`\\tan\\gamma` beyond the last row: ``beyond="zero"`` (the default, r = 0) or
  ``"last"`` (the last row). The standard's own wording on this case was not available to
  this project when it was written; the default treats the table's range as the range of
  light that reaches the observer, and both choices are offered so the user can follow the
  tool they compare against;
- the observer's viewing angle is that of the tables (1 deg below horizontal, CIE 144), as in
  EN 13201-3, whatever the true angle from 1.5 m at 60 m.

Tables are read from text: ``#`` comments, one header line with the :math:`\\beta` values
[deg] (optionally after a label), then one line per :math:`\\tan\\gamma`: the value followed by
one r per :math:`\\beta` [10^-4 sr-1]; whitespace, comma or semicolon separated. The
published CIE tables (R1-R4, C1-C2) are not bundled: no copy could be verified and licensed
for the project. :func:`synthetic_rtable` is an analytic stand-in for tests and examples only.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.roads._geometry import Intensity, intensities, light_array

__all__ = [
    "BEYOND_RULES",
    "INTERPOLATIONS",
    "RTable",
    "parse_rtable",
    "read_rtable",
    "reduced_luminance_coefficient",
    "road_luminance",
    "synthetic_rtable",
]

#: Units of the tabulated r values [sr-1] (CIE 144:2001: r x 10^4 is tabulated).
R_UNIT = 1e-4
#: What r is beyond the table's last tan(gamma): zero, or the last row.
BEYOND_RULES = ("zero", "last")
#: How r is interpolated between the table's nodes (see the module docstring).
INTERPOLATIONS = ("bilinear", "bilinear_gamma", "cubic")
#: The default interpolation, set by benchmarks/bench_rtable_interpolation.py on the CIE grid of
#: synthetic_rtable against its analytic r: "cubic" was by far the most accurate (use-weighted
#: error in r 0.025 % against 1.0 % bilinear and 0.66 % bilinear in gamma; L_av within 0.01 %
#: and U_o within 0.03 % against 0.6 % and 1.7 % bilinear) at the same speed within the noise
#: of a shared 2-core machine (0.25-0.31 s per 10^6 lookups against 0.27-0.46 s bilinear over
#: two runs). Measured tables are less smooth than this stand-in: "bilinear" stays available
#: for comparison with tools that interpolate linearly.
DEFAULT_INTERPOLATION = "cubic"
#: The beta columns [deg] of the layout of the CIE road-surface tables, used by
#: :func:`synthetic_rtable` (the reader accepts any increasing grid in [0, 180]).
CIE_BETA = (0, 2, 5, 10, 15, 20, 25, 30, 35, 40, 45, 60, 75, 90, 105, 120, 135, 150, 165, 180)
#: The tan(gamma) rows of that layout: 0 to 2 by 0.25, then to 12 by 0.5.
CIE_TAN_GAMMA = (*(0.25 * i for i in range(9)), *(2.5 + 0.5 * i for i in range(20)))
_SEPARATORS = re.compile(r"[\s,;]+")


@dataclass(frozen=True, eq=False)
class RTable:
    """A reduced luminance coefficient table.

    Attributes
    ----------
    beta
        Increasing angles between the planes of incidence and observation, (n_beta,) in
        [0, 180] [deg].
    tan_gamma
        Increasing tangents of the angle of incidence, (n_tan,), from 0 [1].
    r
        Reduced luminance coefficients, (n_tan, n_beta) [10^-4 sr-1].
    name
        Where the table came from, for messages and reports.
    """

    beta: FloatArray
    tan_gamma: FloatArray
    r: FloatArray
    name: str = "r-table"

    def __post_init__(self) -> None:
        b, t, r = (np.asarray(a, dtype=float) for a in (self.beta, self.tan_gamma, self.r))
        where = self.name
        if b.ndim != 1 or b.size < 2 or np.any(np.diff(b) <= 0) or b[0] < 0 or b[-1] > 180:
            raise InputError(
                f"{where}: beta {b.tolist()}; expected at least 2 increasing angles in 0-180 deg"
            )
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0) or t[0] != 0:
            raise InputError(
                f"{where}: tan(gamma) {t.tolist()}; expected at least 2 increasing values from 0"
            )
        if r.shape != (t.size, b.size):
            raise InputError(
                f"{where}: r of shape {r.shape}; expected ({t.size}, {b.size}) "
                "(one row per tan(gamma), one column per beta)"
            )
        if not np.all(np.isfinite(r)) or np.any(r < 0):
            raise InputError(f"{where}: r holds negative or non-finite values")
        for attribute, array in (("beta", b), ("tan_gamma", t), ("r", r)):
            array.setflags(write=False)
            object.__setattr__(self, attribute, array)


def _numbers(tokens: list[str], source: str, line: int) -> list[float]:
    try:
        return [float(token) for token in tokens]
    except ValueError as error:
        raise InputError(f"{source}, line {line}: {error}; expected numbers") from None


def parse_rtable(text: str, *, source: str = "<string>") -> RTable:
    """Parse an r-table from text (the layout of the module docstring).

    Parameters
    ----------
    text
        The table.
    source
        Name of the text in messages.

    Returns
    -------
    RTable

    Raises
    ------
    InputError
        A row of the wrong length, a non-number, grids that do not increase, negative r.

    Examples
    --------
    >>> table = parse_rtable("beta 0 180\\n0 100 100\\n1 50 10\\n")
    >>> table.r.shape, float(reduced_luminance_coefficient(table, 90.0, 0.5))
    ((2, 2), 65.0)
    """
    rows: list[tuple[int, list[str]]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if line:
            rows.append((number, [t for t in _SEPARATORS.split(line) if t]))
    if len(rows) < 3:
        raise InputError(
            f"{source}: {len(rows)} table lines; expected a beta header and at least 2 rows"
        )
    header_line, header = rows[0]
    try:
        float(header[0])
    except ValueError:
        header = header[1:]
    beta = _numbers(header, source, header_line)
    tan_gamma, values = [], []
    for number, tokens in rows[1:]:
        if len(tokens) != len(beta) + 1:
            raise InputError(
                f"{source}, line {number}: {len(tokens)} values; expected tan(gamma) and "
                f"{len(beta)} r values (one per beta of the header)"
            )
        row = _numbers(tokens, source, number)
        tan_gamma.append(row[0])
        values.append(row[1:])
    return RTable(np.array(beta), np.array(tan_gamma), np.array(values), name=source)


def read_rtable(path: str | os.PathLike[str]) -> RTable:
    """Read an r-table file (see :func:`parse_rtable`).

    Parameters
    ----------
    path
        Text file.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as error:
        raise InputError(f"{file}: cannot read the r-table ({error.strerror})") from None
    return parse_rtable(text, source=str(file))


def synthetic_rtable(*, q0: float = 0.07, forward: float = 1.0) -> RTable:
    """A SYNTHETIC r-table from an analytic form, for tests and examples; not a CIE table.

    .. math:: r(\\beta, t) = 10^4\\, q_0\\,
              \\frac{1 + f\\, t\\, (1 + \\cos\\beta) / 2}{(1 + t^2)^{3/2}}

    i.e. :math:`q = q_0 (1 + f t (1 + \\cos\\beta)/2)` times :math:`\\cos^3\\gamma`: diffuse
    at normal incidence, brighter towards the specular direction at grazing incidence. On the
    grid of the CIE layout (:data:`CIE_BETA`, :data:`CIE_TAN_GAMMA`).

    Parameters
    ----------
    q0
        Luminance coefficient at normal incidence [sr-1].
    forward
        Growth of q with tan(gamma) towards beta = 0 [1].
    """
    beta = np.array(CIE_BETA, dtype=float)
    tan_gamma = np.array(CIE_TAN_GAMMA, dtype=float)
    t = tan_gamma[:, None]
    lobe = 1.0 + forward * t * (1.0 + np.cos(np.radians(beta)))[None, :] / 2.0
    r = q0 / R_UNIT * lobe / (1.0 + t * t) ** 1.5
    return RTable(beta, tan_gamma, r, name=f"synthetic (q0={q0}, forward={forward})")


def _bilinear(
    nodes_b: FloatArray, nodes_t: FloatArray, r: FloatArray, b: FloatArray, t: FloatArray
) -> FloatArray:
    """Bilinear interpolation of r (rows t, columns b) at points already inside the grid."""
    ib = np.clip(np.searchsorted(nodes_b, b, side="right") - 1, 0, nodes_b.size - 2)
    it = np.clip(np.searchsorted(nodes_t, t, side="right") - 1, 0, nodes_t.size - 2)
    wb = (b - nodes_b[ib]) / (nodes_b[ib + 1] - nodes_b[ib])
    wt = (t - nodes_t[it]) / (nodes_t[it + 1] - nodes_t[it])
    low = r[it, ib] + wb * (r[it, ib + 1] - r[it, ib])
    high = r[it + 1, ib] + wb * (r[it + 1, ib + 1] - r[it + 1, ib])
    return np.asarray(low + wt * (high - low), dtype=float)


def reduced_luminance_coefficient(
    table: RTable,
    beta: ArrayLike,
    tan_gamma: ArrayLike,
    *,
    beyond: str = "zero",
    interpolation: str = DEFAULT_INTERPOLATION,
) -> FloatArray:
    """r at any (beta, tan gamma), interpolated in the table [10^-4 sr-1].

    Parameters
    ----------
    table
        The r-table.
    beta
        Angle between the planes of incidence and observation; folded into [0, 180] [deg].
    tan_gamma
        Tangent of the angle of incidence, >= 0 [1].
    beyond
        r beyond the last tan(gamma): ``"zero"`` or ``"last"`` (the last row).
    interpolation
        ``"cubic"`` (the default: bicubic interpolating spline, clipped at 0),
        ``"bilinear"`` in (beta, tan gamma) or ``"bilinear_gamma"`` in (beta, gamma); see
        the module docstring and :data:`DEFAULT_INTERPOLATION`.

    References
    ----------
    CIE 144:2001, Road surface and road marking reflection characteristics.

    Examples
    --------
    A table linear in tan(gamma) is reproduced by every method:

    >>> table = parse_rtable("beta 0 90 180\\n0 40 40 40\\n1 30 30 30\\n2 20 20 20\\n3 10 10 10\\n")
    >>> [round(float(reduced_luminance_coefficient(table, 45.0, 1.5, interpolation=m)), 6)
    ...  for m in ("bilinear", "cubic")]
    [25.0, 25.0]
    """
    if beyond not in BEYOND_RULES:
        raise InputError(f"beyond={beyond!r}; expected one of {', '.join(BEYOND_RULES)}")
    if interpolation not in INTERPOLATIONS:
        raise InputError(
            f"interpolation={interpolation!r}; expected one of {', '.join(INTERPOLATIONS)}"
        )
    b = np.abs(np.mod(np.asarray(beta, dtype=float) + 180.0, 360.0) - 180.0)
    t = np.asarray(tan_gamma, dtype=float)
    b, t = np.broadcast_arrays(b, t)
    tb, tt = table.beta, table.tan_gamma
    bc = np.clip(b, tb[0], tb[-1])
    tc = np.clip(t, 0.0, tt[-1])
    if interpolation == "bilinear":
        value = _bilinear(tb, tt, table.r, bc, tc)
    elif interpolation == "bilinear_gamma":
        value = _bilinear(tb, np.arctan(tt), table.r, bc, np.arctan(tc))
    else:
        from scipy.interpolate import RectBivariateSpline

        degree = (min(3, tt.size - 1), min(3, tb.size - 1))
        spline = RectBivariateSpline(tt, tb, table.r, kx=degree[0], ky=degree[1], s=0)
        value = np.maximum(spline.ev(tc, bc), 0.0)
    if beyond == "zero":
        value = np.where(t > tt[-1], 0.0, value)
    return np.asarray(value, dtype=float)


def road_luminance(
    points: ArrayLike,
    observer: ArrayLike,
    light_points: ArrayLike,
    rotation: ArrayLike,
    intensity: Intensity | Sequence[Intensity],
    table: RTable,
    *,
    street_azimuth: ArrayLike = 0.0,
    beyond: str = "zero",
    interpolation: str = DEFAULT_INTERPOLATION,
) -> FloatArray:
    """Road surface luminance at points for one observer (equation of the module docstring).

    Parameters
    ----------
    points
        Points on the road, (..., 3) with z the road surface [m].
    observer
        Observer eye (x, y, z); only its horizontal position sets beta [m].
    light_points
        Photometric centres of the luminaires, (n, 3) [m].
    rotation
        Body-to-world rotations, (3, 3) or (n, 3, 3)
        (:func:`nightlights.ground.frames.luminaire_rotation`).
    intensity
        ``intensity(vertical, horizontal)`` [cd] of type C angles [deg], one for all
        luminaires or one per luminaire.
    table
        The road surface's r-table.
    street_azimuth
        C-plane of each photometry that faces the street [deg].
    beyond
        r beyond the table's last tan(gamma), see :func:`reduced_luminance_coefficient`.
    interpolation
        How r is interpolated in the table, see :func:`reduced_luminance_coefficient`.

    Returns
    -------
    numpy.ndarray
        Luminance, shape of ``points`` without the last axis [cd m-2].

    References
    ----------
    CIE 144:2001, Sec. 2 (reduced luminance coefficient); EN 13201-3:2015, Sec. 7.1.

    Examples
    --------
    A luminaire of 1000 cd everywhere 10 m above the point: r(., 0) = q0 = 0.07 sr-1.

    >>> round(float(road_luminance([0, 0, 0], [-60, 0, 1.5], [[0, 0, 10]], np.eye(3),
    ...                            lambda v, h: 1000.0 + 0 * v, synthetic_rtable())), 12)
    0.7
    """
    p = np.asarray(points, dtype=float)
    if p.shape[-1:] != (3,):
        raise InputError(f"points of shape {p.shape}; expected (..., 3) points (x, y, z) [m]")
    eye = np.asarray(observer, dtype=float)
    if eye.shape != (3,):
        raise InputError(f"observer of shape {eye.shape}; expected one point (x, y, z) [m]")
    lights, rotations = light_array(light_points, rotation)
    flat = p.reshape(-1, 3)
    candela = intensities(flat, lights, rotations, intensity, street_azimuth=street_azimuth)
    height = lights[:, None, 2] - flat[None, :, 2]
    if np.any(height <= 0):
        raise InputError("a luminaire stands at or below a road point; expected h > 0 [m]")
    to_light = lights[:, None, :2] - flat[None, :, :2]
    horizontal = np.hypot(to_light[..., 0], to_light[..., 1])
    view = flat[:, :2] - eye[None, :2]
    cos_beta = np.einsum("nmi,mi->nm", to_light, view) / np.maximum(
        horizontal * np.hypot(view[:, 0], view[:, 1])[None, :], 1e-300
    )
    beta = np.degrees(np.arccos(np.clip(cos_beta, -1.0, 1.0)))
    r = reduced_luminance_coefficient(
        table, beta, horizontal / height, beyond=beyond, interpolation=interpolation
    )
    luminance = np.sum(r * R_UNIT * candela / height**2, axis=0)
    return luminance.reshape(p.shape[:-1])
