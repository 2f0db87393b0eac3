"""Dimming the lights: Dobashi et al.'s reduction rule (Eq. 12) and the least-flux dimming.

Dobashi et al. (2023, Sec. 4.1) dim each light source by a rate that grows with its influence
Q_i on the light pollution (Eq. 12):

.. math:: \\gamma_i = \\mathrm{clip}\\!\\left(\\frac{Q_i - Q_a}{Q_b - Q_a}, 0, 1\\right)
          \\gamma_\\mathrm{usr},

so that sources with Q_i < Q_a are unchanged and, at gamma_usr = 1, those with Q_i > Q_b are
switched off. The paper limits both gamma_i and gamma_usr to [0, 1]; here the ratio is clipped
first and gamma_usr scales it, so gamma_usr is the largest dimming any source receives.

Skyglow is linear in the emission, so the dimming that meets sky-brightness targets while
removing the least flux is a linear program: with x_i in [0, m_i] the dimmed fraction of cell
i, F_i its flux [lm], c_ji the luminance [cd m-2] it adds to target j at full emission, B_j the
luminance now and T_j the target,

.. math:: \\min_x \\sum_i F_i x_i \\quad\\text{s.t.}\\quad
          B_j - \\sum_i c_{ji} x_i \\le T_j, \\quad 0 \\le x_i \\le m_i.

One target is a fractional knapsack, solved exactly by the greedy rule (dim the cells with the
largest luminance removed per lumen first); several targets go to HiGHS (scipy's ``linprog``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError, NightlightsError

#: Methods of :func:`least_flux_dimming`.
METHODS = ("auto", "greedy", "lp")
#: Lit cells from which the linear program's constraint matrix is passed as a sparse matrix.
SPARSE_FROM_CELLS = 2000
#: Relative slack [1] when comparing luminances that should agree up to rounding: the best
#: reachable luminance with a target, ``before`` with the sum of the contributions.
ROUNDING = 1e-9
#: Tolerance [1] by which ``before`` may fall short of the sum of the contributions (the two
#: usually come from different computations of the same sky).
CONSISTENCY = 1e-6
#: HiGHS options. Presolve is off: on one constraint with many columns it took 130 s at 1e5
#: cells against 0.25 s without it (benchmarks/bench_inverse_lp.py), and it gains nothing on
#: these small dense programs. Feasibility tolerances apply to constraints scaled to a required
#: reduction of 1 [1].
HIGHS_OPTIONS = {
    "presolve": False,
    "primal_feasibility_tolerance": 1e-10,
    "dual_feasibility_tolerance": 1e-10,
}
#: Largest violation of a target [1, relative to its required reduction] accepted from HiGHS.
SOLVER_SLACK = 1e-7


def dimming_fraction(influence: ArrayLike, qa: float, qb: float, gamma: float) -> FloatArray:
    """Dimming fraction of each light source from its influence (Dobashi et al. 2023, Eq. 12).

    .. math:: \\gamma_i = \\mathrm{clip}\\!\\left(\\frac{Q_i - Q_a}{Q_b - Q_a}, 0, 1\\right)
              \\gamma_\\mathrm{usr}

    Parameters
    ----------
    influence
        Influence Q_i of each source, any shape, in the unit of its map (Q or S raster);
        NaN (unlit) gives 0.
    qa
        Influence below which a source is left unchanged, same unit.
    qb
        Influence above which a source gets the full dimming ``gamma``, same unit; > ``qa``.
    gamma
        Largest dimming gamma_usr [1], in [0, 1].

    Returns
    -------
    numpy.ndarray
        Dimming fraction gamma_i [1] in [0, gamma], the shape of ``influence``; the dimmed
        flux is ``(1 - gamma_i) F_i``.

    Raises
    ------
    InputError
        If ``qa`` or ``qb`` is not finite, ``qa >= qb``, or ``gamma`` is outside [0, 1].

    References
    ----------
    Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, ACM TOG 42(6) 219, Sec. 4.1, Eq. 12.

    Examples
    --------
    >>> dimming_fraction([0.5, 1.0, 2.0, 3.0, float("nan")], qa=1.0, qb=3.0, gamma=0.8).tolist()
    [0.0, 0.0, 0.4, 0.8, 0.0]
    """
    if not (np.isfinite(qa) and np.isfinite(qb)):
        raise InputError(f"qa and qb must be finite, got qa={qa}, qb={qb}")
    if not qa < qb:
        raise InputError(f"qa must be below qb (Dobashi et al. 2023, Eq. 12), got {qa} >= {qb}")
    if not 0.0 <= gamma <= 1.0:
        raise InputError(f"gamma must be in [0, 1], got {gamma}")
    q = np.asarray(influence, dtype=float)
    ratio = np.clip((q - qa) / (qb - qa), 0.0, 1.0)  # Dobashi 2023, Eq. 12
    return np.where(np.isnan(q), 0.0, ratio * gamma)


@dataclass(frozen=True)
class DimmingPlan:
    """The dimming of every lit cell that meets luminance targets, and what it does.

    Attributes
    ----------
    fraction
        Shape ``(n_cells,)``: dimming fraction x_i [1] of each cell, in [0, max_dimming_i];
        the cell keeps ``(1 - x_i)`` of its flux.
    removed_flux
        Flux removed, sum_i F_i x_i [lm].
    total_flux
        Flux of all cells before dimming, sum_i F_i [lm].
    before
        Shape ``(n_targets,)``: luminance of each target before dimming [cd m-2].
    after
        Shape ``(n_targets,)``: luminance of each target after dimming [cd m-2].
    method
        ``"greedy"`` (one target needing dimming, exact) or ``"lp"`` (linear program).
    """

    fraction: FloatArray
    removed_flux: float
    total_flux: float
    before: FloatArray
    after: FloatArray
    method: str


class InfeasibleTargetError(InputError):
    """A luminance target that no dimming within the allowed maximum can reach.

    Attributes
    ----------
    label
        The target's name (its label, or ``"target j"``).
    target
        The luminance asked for [cd m-2].
    best
        The lowest luminance reachable, every cell at its maximum dimming [cd m-2].
    """

    def __init__(
        self,
        message: str,
        *,
        label: str = "",
        target: float = float("nan"),
        best: float = float("nan"),
    ) -> None:
        super().__init__(message)
        self.label = label
        self.target = target
        self.best = best


def least_flux_dimming(
    contribution: ArrayLike,
    flux: ArrayLike,
    before: ArrayLike,
    target: ArrayLike,
    *,
    max_dimming: float | ArrayLike = 1.0,
    method: str = "auto",
    labels: Sequence[str] | None = None,
) -> DimmingPlan:
    """The dimming that meets every luminance target while removing the least flux.

    .. math:: \\min_x \\sum_i F_i x_i \\quad\\text{s.t.}\\quad
              B_j - \\sum_i c_{ji} x_i \\le T_j, \\quad 0 \\le x_i \\le m_i

    Targets already met (B_j <= T_j) need no dimming and are left out; cells that add nothing
    to any unmet target stay at x_i = 0.

    Parameters
    ----------
    contribution
        Shape ``(n_targets, n_cells)`` (or ``(n_cells,)`` for one target): luminance c_ji that
        cell i adds to target j at full emission [cd m-2], >= 0.
    flux
        Shape ``(n_cells,)``: flux F_i of each cell [lm], >= 0.
    before
        Shape ``(n_targets,)``: luminance B_j of each target now [cd m-2], at least the sum of
        its contributions (the rest, e.g. light from outside the raster, cannot be dimmed).
    target
        Shape ``(n_targets,)``: the luminance T_j each target must not exceed [cd m-2].
    max_dimming
        Largest dimming fraction m_i [1] in [0, 1], one for all cells or shape ``(n_cells,)``.
    method
        ``"auto"`` (greedy where at most one target needs dimming, else the linear program),
        ``"greedy"`` (one target only) or ``"lp"``.
    labels
        Names of the targets, for error messages (default ``"target j"``).

    Returns
    -------
    DimmingPlan
        The dimming fractions, the flux removed and the targets' luminance before and after.

    Raises
    ------
    InputError
        On arrays of the wrong shape, negative or non-finite values, ``max_dimming`` outside
        [0, 1], an unknown ``method``, or ``"greedy"`` with several targets.
    InfeasibleTargetError
        If a target cannot be reached even with every cell at its maximum dimming; the message
        names the first such target, its value and the best reachable one in cd m-2 and
        mag arcsec-2.
    NightlightsError
        If the linear program solver fails.

    Notes
    -----
    One target is the fractional knapsack problem: cell i buys a luminance reduction of up to
    c_i m_i at a price of F_i / c_i lumens per cd m-2, so the greedy rule (cells that add light
    but carry no flux first, at their maximum, then by c_i / F_i descending, each up to its
    maximum, the last one fractionally) is exactly optimal: any other feasible dimming buys
    part of the reduction from a cell of lower c/F while a cell of higher c/F is not at its
    maximum, and moving that part to the higher-ratio cell keeps the reduction and does not
    increase the flux (Dantzig 1957). Several targets are solved by HiGHS (``scipy.optimize.
    linprog``, ``method="highs"``) with each constraint scaled to a required reduction of 1 and
    the flux to a total of 1, presolve off, and a sparse constraint matrix from
    :data:`SPARSE_FROM_CELLS` cells.

    References
    ----------
    Dantzig, G. B. 1957, "Discrete-variable extremum problems", Operations Research 5(2),
    266-288 (the greedy solution of the fractional knapsack).

    Examples
    --------
    Two cells lighting one target: the one with more light per lumen is dimmed first.

    >>> plan = least_flux_dimming([[2e-4, 1e-4]], [1000.0, 1000.0], [4e-4], [2.5e-4])
    >>> plan.fraction.tolist(), plan.removed_flux, plan.method
    ([0.75, 0.0], 750.0, 'greedy')
    """
    c, f, b, t, m = _checked(contribution, flux, before, target, max_dimming)
    n_targets, n_cells = c.shape
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "greedy" and n_targets > 1:
        raise InputError(f"method 'greedy' solves one target, got {n_targets} targets; use 'lp'")
    if labels is not None and len(labels) != n_targets:
        raise InputError(f"labels must name the {n_targets} targets, got {len(labels)} labels")
    _check_reachable(c, b, t, m, labels)

    unmet = np.flatnonzero(b > t)
    if method == "lp" or (method == "auto" and unmet.size > 1):
        x = _linear_program(c[unmet], f, b[unmet] - t[unmet], m)
        chosen = "lp"
    else:
        x = np.zeros(n_cells)
        if unmet.size:
            x = _greedy(c[unmet[0]], f, b[unmet[0]] - t[unmet[0]], m)
        chosen = "greedy"
    after = b - c @ x
    slack = np.maximum(SOLVER_SLACK * (b - t), ROUNDING * b)
    if unmet.size and np.any((after - t)[unmet] > slack[unmet]):
        worst = unmet[np.argmax((after - t)[unmet])]
        raise NightlightsError(
            f"the {chosen} dimming misses {_label(labels, worst)}: {after[worst]:.6g} cd m-2 "
            f"for a target of {t[worst]:.6g} cd m-2"
        )
    return DimmingPlan(
        fraction=x,
        removed_flux=float(f @ x),
        total_flux=float(f.sum()),
        before=b,
        after=after,
        method=chosen,
    )


def _checked(
    contribution: ArrayLike,
    flux: ArrayLike,
    before: ArrayLike,
    target: ArrayLike,
    max_dimming: float | ArrayLike,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The inputs as float arrays of consistent shapes, or a one-line InputError."""
    c = np.asarray(contribution, dtype=float)
    if c.ndim == 1:
        c = c[None, :]
    if c.ndim != 2:
        raise InputError(f"contribution must be (n_targets, n_cells), got shape {c.shape}")
    n_targets, n_cells = c.shape
    f = np.asarray(flux, dtype=float)
    b = np.atleast_1d(np.asarray(before, dtype=float))
    t = np.atleast_1d(np.asarray(target, dtype=float))
    m = np.asarray(max_dimming, dtype=float)
    m = np.full(n_cells, float(m)) if m.ndim == 0 else m
    for name, array, shape in (
        ("flux", f, (n_cells,)),
        ("before", b, (n_targets,)),
        ("target", t, (n_targets,)),
        ("max_dimming", m, (n_cells,)),
    ):
        if array.shape != shape:
            raise InputError(
                f"{name} must have shape {shape} to match contribution {c.shape}, got {array.shape}"
            )
    for name, array in (("contribution", c), ("flux", f), ("before", b), ("target", t)):
        if not np.all(np.isfinite(array)):
            raise InputError(f"{name} must be finite, got {array[~np.isfinite(array)][0]}")
    for name, array, unit in (("contribution", c, "cd m-2"), ("flux", f, "lm")):
        if np.any(array < 0):
            raise InputError(f"{name} must be >= 0, got {array.min():.6g} {unit}")
    if not np.all((m >= 0) & (m <= 1)):
        raise InputError(f"max_dimming must be in [0, 1], got {m[~((m >= 0) & (m <= 1))][0]}")
    total = c.sum(axis=1)
    short = b < total * (1 - CONSISTENCY)
    if np.any(short):
        j = int(np.argmax(short))
        raise InputError(
            f"before[{j}] = {b[j]:.6g} cd m-2 is less than the sum of its cells' "
            f"contributions, {total[j]:.6g} cd m-2; expected before >= that sum"
        )
    return c, f, b, t, m


def _label(labels: Sequence[str] | None, j: int) -> str:
    return f"target {j}" if labels is None else str(labels[j])


def _check_reachable(
    c: FloatArray, b: FloatArray, t: FloatArray, m: FloatArray, labels: Sequence[str] | None
) -> None:
    """Raise InfeasibleTargetError for the first target above reach with every cell at m."""
    best = b - c @ m
    out = np.flatnonzero(best > t + ROUNDING * b)
    if not out.size:
        return
    j = int(out[0])
    lowest = max(float(best[j]), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        asked_mag = float(luminance_to_magnitude(t[j]))
        best_mag = float(luminance_to_magnitude(lowest))
    raise InfeasibleTargetError(
        f"{_label(labels, j)} asks for {t[j]:.4g} cd m-2 ({asked_mag:.2f} mag arcsec-2) but "
        f"the best reachable, every cell at its maximum dimming, is {lowest:.4g} cd m-2 "
        f"({best_mag:.2f} mag arcsec-2)",
        label=_label(labels, j),
        target=float(t[j]),
        best=lowest,
    )


def _greedy(c: FloatArray, f: FloatArray, reduction: float, m: FloatArray) -> FloatArray:
    """Least-flux dimming for one target: the fractional knapsack's greedy solution.

    Parameters
    ----------
    c
        Shape ``(n_cells,)``: contribution of each cell [cd m-2].
    f
        Shape ``(n_cells,)``: flux [lm].
    reduction
        Luminance to remove [cd m-2], > 0 and reachable.
    m
        Shape ``(n_cells,)``: maximum dimming [1].
    """
    x = np.zeros(c.size)
    useful = (c > 0) & (m > 0)
    free = useful & (f == 0)
    x[free] = m[free]  # light without flux costs nothing: dim it fully first
    remaining = reduction - float(c[free] @ m[free])
    if remaining <= 0:
        return x
    paid = np.flatnonzero(useful & (f > 0))
    if not paid.size:  # reachable up to rounding by the free cells alone
        return x
    order = paid[np.argsort(-(c[paid] / f[paid]), kind="stable")]
    gains = np.cumsum(c[order] * m[order])
    last = min(int(np.searchsorted(gains, remaining)), order.size - 1)
    x[order[:last]] = m[order[:last]]
    done = gains[last - 1] if last else 0.0
    i = order[last]
    x[i] = min(max((remaining - done) / c[i], 0.0), m[i])
    return x


def _linear_program(
    c: FloatArray, f: FloatArray, reduction: FloatArray, m: FloatArray
) -> FloatArray:
    """Least-flux dimming for the unmet targets (rows of ``c``) by HiGHS.

    Parameters
    ----------
    c
        Shape ``(n_unmet, n_cells)``: contributions [cd m-2].
    f
        Shape ``(n_cells,)``: flux [lm].
    reduction
        Shape ``(n_unmet,)``: luminance each target must lose [cd m-2], > 0.
    m
        Shape ``(n_cells,)``: maximum dimming [1].
    """
    from scipy import sparse
    from scipy.optimize import linprog

    x = np.zeros(f.size)
    if not reduction.size:
        return x
    active = np.flatnonzero((c > 0).any(axis=0) & (m > 0))
    # Scaled rows: sum_i (c_ji / R_j) x_i >= 1; scaled cost: flux over the total flux.
    rows = c[:, active] / reduction[:, None]
    scale = float(f[active].sum()) or 1.0
    matrix: Any = -rows
    if active.size >= SPARSE_FROM_CELLS:
        matrix = sparse.csc_array(matrix)  # HiGHS stores columns
    result = linprog(
        f[active] / scale,
        A_ub=matrix,
        b_ub=-np.ones(reduction.size),
        bounds=np.column_stack([np.zeros(active.size), m[active]]),
        method="highs",
        options=HIGHS_OPTIONS,
    )
    if result.status != 0 or result.x is None:
        raise NightlightsError(
            f"the linear program of {reduction.size} targets and {active.size} cells failed: "
            f"{result.message} (HiGHS status {result.status})"
        )
    x[active] = np.clip(result.x, 0.0, m[active])
    return x
