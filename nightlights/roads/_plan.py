"""A dimming plan that keeps the roads lit: least energy (or flux) under sky targets.

Every luminaire :math:`k` gets a level :math:`\\delta_k \\in [\\delta_\\min, 1]` from one
sparse linear program (HiGHS [1], its dual simplex warm-started between rounds):

.. math:: \\min_\\delta \\sum_k w_k\\,\\delta_k \\quad\\text{s.t.}\\quad
          S\\,\\delta \\le T - B_\\text{fixed}, \\qquad G\\,\\delta \\ge h, \\qquad
          \\delta_\\min \\le \\delta_k \\le 1,

with :math:`w_k` the power [W] (least energy) or the luminous flux [lm] (least flux) of
light :math:`k`, :math:`S` the per-light sky matrix (:func:`nightlights.inverse.sky_matrix`),
:math:`T` the sky targets and :math:`G\\delta \\ge h` the road minima of every rated segment at
its class (:mod:`nightlights.roads._plan_rows`). The same program without :math:`G` is the
*sky-only* plan; the difference of the two objectives is the cost of safety, what the road
minima keep (never negative: the sky-only program has fewer rows). When no plan meets both,
a second program adds one slack :math:`s_g \\ge 0` per segment to its rows
(:math:`G_i\\delta + \\text{scale}_i\\, s_g \\ge h_i`) and minimises :math:`\\sum_g s_g`: the
segments with :math:`s_g > 0` bind, by :math:`s_g` (a fraction of the requirement, or of the
requirement times the undimmed level for the ratio criteria).

The road rows are many (one per point and observer for the uniformities, one per ordered
pair of points on a lane's centre line), and few of them bind. They are generated lazily
(row generation): the first program holds the sky rows and one road row per observer,
section or edge (averages, glare, edge ratio); every row its solution breaks joins, and the
program is solved again from the last basis (a few dual simplex steps), until a solution
breaks none. Each program's rows are a subset of
the full program's, so its optimum is a lower bound on the full one; the last solution keeps
every row, so it is the full program's optimum (with ``coefficient_floor=0``; by default the
thinned program's, below).

**Thinned rows** (``coefficient_floor``, by default): a road row holds every light whose
light reaches its points, most of them by a tiny part (a light 100 m off adds a thousandth
of the nearest one's); those dense rows make every simplex basis dense, and the exact
program slow (benchmark). A coefficient :math:`a_k` below the floor times its row's largest
leaves the row, its term :math:`a_k\\delta_k` moved to the bound at its worst case over
:math:`\\delta_k \\in [\\delta_\\min, 1]` (:math:`a_k` or :math:`a_k\\delta_\\min`,
whichever is larger, for a row :math:`a\\delta \\le b`). Every plan that keeps the thinned
rows keeps the given ones, so the plan is feasible and its cost an upper bound of the
optimum; the termination check runs on the given rows. A row that full output keeps but its
thinned form would not (a segment held at its failing undimmed figure, which full output
only just keeps) enters whole, so full output stays feasible; and when the thinned program
is infeasible all the same (the sky rows), the exact one is solved before a plan is called
infeasible. The same rows with each dropped term
at its best case are a relaxation whose optimum bounds the optimum from below: the
benchmark brackets the exact optimum between the two and charts the gap against the time
(``coefficient_floor=0`` is the exact program, the reference).

Lights in no road row (far from every rated segment) take :math:`\\delta_\\min` outside the
program: the sky rows' coefficients and the costs are non-negative, so lowering such a light
never breaks a row and never costs more.

The plan is not taken on the solver's word: its compliance is :meth:`RoadModel.rate` at the
dimming, and its sky is :meth:`SkyMatrix.after`.

A schedule (:func:`road_plan_schedule`) solves one plan per period, each with its own sky
targets (e.g. none before midnight, the target after), and weights the energy by each
period's hours a year.

References
----------
1. Huangfu, Q. and Hall, J. A. J. (2018). Parallelizing the dual revised simplex method.
   Mathematical Programming Computation 10, 119-142 (HiGHS).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.optimize import linprog

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.ground.luminaires import load_database
from nightlights.roads._audit import RoadModel
from nightlights.roads._energy import _input_watts
from nightlights.roads._plan_rows import RoadRows, road_rows

__all__ = [
    "OBJECTIVES",
    "PlanPeriod",
    "RoadPlan",
    "SkyMatrix",
    "road_plan",
    "road_plan_schedule",
]

#: What a plan minimises: the power or the luminous flux of the lights kept.
OBJECTIVES = ("energy", "flux")
#: HiGHS primal feasibility tolerance [row units]; rows are scaled to a requirement of 1
#: (``benchmarks/bench_road_plan.py`` charts it against the violation found by re-rating).
TOLERANCE = 1e-9
#: Margin kept inside every row [1, fraction of the requirement], so that a plan that meets
#: its rows within the solver's tolerance still passes when re-rated (margins >= 0).
MARGIN = 1e-6
#: Slack above which a segment binds in the diagnosis [1, fraction of the requirement].
BINDING_SLACK = 1e-7
#: Road rows in the first round of the lazy program: one per observer, section or edge; the
#: point rows (uniformity, minimum) join as a solution breaks them.
SEED_CRITERIA = ("average_luminance", "average_illuminance", "edge_illuminance_ratio")
#: Rounds of the lazy program before it falls back to every row at once.
MAX_ROUNDS = 50
#: Road-row coefficients below this fraction of their row's largest enter HiGHS as their
#: worst case (module docstring) [1]; 0 keeps every coefficient, the exact program.
#: ``benchmarks/bench_road_plan.py`` charts the time against the objective's gap to it.
COEFFICIENT_FLOOR = 1e-3


@dataclass(frozen=True)
class SkyMatrix:
    """Sky targets and each light's part of them.

    Attributes
    ----------
    contribution
        (targets, lights): :math:`S_{jk}`, light k's part of target j at full output [cd m-2].
    before
        (targets,): each target's luminance now, every source of the scene [cd m-2].
    goal
        (targets,): the luminance each target must not exceed [cd m-2].
    labels
        What each target is (kind, region and observer).
    """

    contribution: FloatArray
    before: FloatArray
    goal: FloatArray
    labels: tuple[str, ...]

    @property
    def fixed(self) -> FloatArray:
        """(targets,): the part of the sky no light of the plan makes [cd m-2] (at least 0)."""
        return np.maximum(self.before - self.contribution.sum(axis=1), 0.0)

    def after(self, dimming: FloatArray) -> FloatArray:
        """(targets,): each target's luminance at a dimming, by the matrix [cd m-2]."""
        return self.fixed + self.contribution @ np.asarray(dimming, dtype=float)

    def only(self, active: Sequence[bool]) -> SkyMatrix:
        """The targets where ``active`` is true."""
        keep = np.asarray(active, dtype=bool)
        labels = tuple(label for label, k in zip(self.labels, keep, strict=True) if k)
        return SkyMatrix(self.contribution[keep], self.before[keep], self.goal[keep], labels)


@dataclass(frozen=True)
class RoadPlan:
    """A per-light dimming that keeps the roads lit under sky targets, and what it does.

    Attributes
    ----------
    feasible
        Whether a plan meets every sky target and every road minimum.
    light_id
        The lights (n,).
    dimming
        Level of each light [1] in [delta_min, 1] (all 1 when infeasible).
    sky
        Per target: ``target``, ``goal_cd_m2``, ``before_cd_m2``, ``after_cd_m2``.
    before, after
        Compliance per segment at full output and at the plan (:meth:`RoadModel.rate`).
    cost, cost_full, cost_sky_only
        Objective at the plan, at full output and at the sky-only plan [W or lm].
    objective
        ``"energy"`` or ``"flux"``.
    binding
        When infeasible: per binding segment ``segment``, ``lighting_class``, ``slack``
        (fraction of the requirement) and ``criteria``.
    relaxed
        Segments failing their class undimmed, held at their undimmed figures.
    hours
        Hours a year the plan runs, for the energy [h] (NaN if not given).
    """

    feasible: bool
    light_id: np.ndarray
    dimming: FloatArray
    sky: pd.DataFrame
    before: pd.DataFrame
    after: pd.DataFrame
    cost: float
    cost_full: float
    cost_sky_only: float
    objective: str
    binding: pd.DataFrame = field(default_factory=pd.DataFrame)
    relaxed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    hours: float = float("nan")

    @property
    def saved(self) -> float:
        """Objective saved against full output [W or lm]."""
        return self.cost_full - self.cost

    @property
    def cost_of_safety(self) -> float:
        """What the road minima keep against the sky-only plan [W or lm] (>= 0)."""
        return self.cost - self.cost_sky_only

    @property
    def energy_saved(self) -> float:
        """Energy saved a year [Wh] (energy objective and ``hours`` given; else NaN)."""
        return self.saved * self.hours if self.objective == "energy" else float("nan")


@dataclass(frozen=True)
class PlanPeriod:
    """A period of a night with its own sky targets.

    Attributes
    ----------
    name
        Label (e.g. ``"after midnight"``).
    hours
        Burning hours a year in this period [h].
    sky
        Sky targets in force, or None (only the road minima).
    """

    name: str
    hours: float
    sky: SkyMatrix | None = None


def _weights(model: RoadModel, objective: str, weights: ArrayLike | None) -> FloatArray:
    n = len(model.luminaires)
    if weights is not None:
        w = np.asarray(weights, dtype=float)
        if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise InputError(
                f"weights of shape {w.shape}; expected {n} finite non-negative numbers, one "
                "per light"
            )
        return w
    lum = model.luminaires
    if objective == "flux":
        return lum.upward_flux() + lum.downward_flux()
    database = load_database(None)
    watts = np.array([_input_watts(database, name) for name in lum.names])
    power = watts[lum.table_index] * lum.intensity_scale
    if not np.all(np.isfinite(power)):
        raise InputError(
            "weights=None: the photometry of some lights states no input watts; expected "
            "weights (power per light [W]) or objective='flux'"
        )
    return power


class _Program:
    """One HiGHS model that takes rows as they come and re-solves from its last basis."""

    def __init__(self, w: FloatArray, low: float, tolerance: float) -> None:
        # highspy's bare binding: its Highs wrapper prints a banner when made
        from highspy import _core

        self.highs = _core._Highs()
        self.highs.setOptionValue("output_flag", False)
        self.highs.setOptionValue("primal_feasibility_tolerance", tolerance)
        self.n = w.size
        norm = max(float(w.max()), 1e-300) if w.size else 1.0
        self.highs.addVars(self.n, np.full(self.n, float(low)), np.ones(self.n))
        self.highs.changeColsCost(self.n, np.arange(self.n, dtype=np.int32), w / norm)
        self.optimal = _core.HighsModelStatus.kOptimal

    def add(self, a: sp.csr_array, upper: FloatArray) -> None:
        """Add rows ``a x <= upper``."""
        if a.shape[0] == 0:
            return
        a = sp.csr_array(a)
        a.sort_indices()
        self.highs.addRows(
            a.shape[0],
            np.full(a.shape[0], -np.inf),
            np.asarray(upper, dtype=float),
            a.nnz,
            a.indptr[:-1].astype(np.int32),
            a.indices.astype(np.int32),
            a.data.astype(float),
        )

    def solve(self, low: float) -> np.ndarray | None:
        self.highs.run()
        if self.highs.getModelStatus() != self.optimal:
            return None
        x = np.asarray(self.highs.getSolution().col_value, dtype=float)
        return np.clip(x, low, 1.0)


def _thin(
    a: sp.csr_array, upper: FloatArray, floor: float, low: float, relax: bool = False
) -> tuple[sp.csr_array, FloatArray]:
    """Rows ``a x <= upper`` without their coefficients below ``floor`` times their row's
    largest, each dropped term moved to the bound at its worst value over
    :math:`x_k \\in [\\text{low}, 1]` (module docstring): every ``x`` that keeps the thinned
    rows keeps the given ones; a row that ``x = 1`` keeps but its thinned form would not
    stays whole. ``relax``: at its best value instead (a relaxation, whose optimum bounds the
    program's from below)."""
    a = sp.csr_array(a, copy=True)
    upper = np.asarray(upper, dtype=float)
    if floor <= 0.0 or a.nnz == 0:
        return a, upper
    length = np.diff(a.indptr)
    size = np.abs(a.data)
    largest = np.zeros(a.shape[0])
    filled = length > 0
    largest[filled] = np.maximum.reduceat(size, a.indptr[:-1][filled])
    small = size < floor * np.repeat(largest, length)
    worst = np.where((a.data > 0) != relax, a.data, a.data * low)
    row = np.repeat(np.arange(a.shape[0]), length)
    if not relax:
        # a row that full output keeps stays whole where its worst case would close it
        m = a.shape[0]
        given = np.bincount(row, weights=a.data, minlength=m)
        kept = np.bincount(row[~small], weights=a.data[~small], minlength=m)
        moved = np.bincount(row[small], weights=worst[small], minlength=m)
        whole = (given <= upper) & (kept + moved > upper)
        small &= ~whole[row]
    upper = upper - np.bincount(row[small], weights=worst[small], minlength=a.shape[0])
    a.data[small] = 0.0
    a.eliminate_zeros()
    return a, upper


def _solve(
    w: FloatArray,
    sky: SkyMatrix | None,
    rows: RoadRows | None,
    low: float,
    tolerance: float,
    floor: float = 0.0,
    relax: bool = False,
) -> np.ndarray | None:
    """The program of the module docstring, its road rows generated lazily (module
    docstring): solve with the rows in play, add every row the solution breaks, re-solve from
    the last basis, repeat. Lights in no road row sit at ``low`` outside the program. Rows
    enter HiGHS thinned by ``floor`` (:func:`_thin`); ``relax``: relaxed instead, and the
    rows checked are the relaxed ones (a lower bound of the optimum, for the benchmark)."""
    n = w.size
    x = np.full(n, float(low))
    if rows is not None and rows.bound.size:
        used = np.flatnonzero(np.diff(sp.csc_array(rows.matrix).indptr) > 0)
    else:
        used = np.zeros(0, dtype=np.intp)
    program = _Program(w[used], low, tolerance)
    if sky is not None and len(sky.labels):
        scale = np.maximum(np.abs(sky.goal), 1e-300)
        room = sky.goal - sky.fixed - sky.contribution @ x + sky.contribution[:, used] @ x[used]
        if np.any(room / scale - MARGIN < 0) and used.size == 0:
            return None
        program.add(sp.csr_array(sky.contribution[:, used] / scale[:, None]), room / scale - MARGIN)
    if used.size == 0:
        return x
    assert rows is not None
    # rows a x <= b over every light (scaled in place: no copy of the matrix by columns)
    matrix = sp.csr_array(rows.matrix)
    road_a = sp.csr_array((matrix.data.copy(), matrix.indices, matrix.indptr), shape=matrix.shape)
    road_a.data *= np.repeat(-1.0 / rows.scale, np.diff(matrix.indptr))
    road_b = -rows.bound / rows.scale - MARGIN
    if relax:
        road_a, road_b = _thin(road_a, road_b, floor, low, relax=True)
        floor = 0.0
    column = np.full(n, -1, dtype=np.int64)
    column[used] = np.arange(used.size)

    def add(chosen: np.ndarray) -> None:
        a, b = _thin(road_a[chosen], road_b[chosen], floor, low)
        a = sp.csr_array((a.data, column[a.indices], a.indptr), shape=(a.shape[0], used.size))
        program.add(a, b)

    active = np.isin(rows.criterion, SEED_CRITERIA)
    add(np.flatnonzero(active))
    full = x.copy()
    for _ in range(MAX_ROUNDS + 1):
        if _ == MAX_ROUNDS:  # pragma: no cover - the rounds never ran out in the benchmarks
            rest = np.flatnonzero(~active)
            active[rest] = True
            add(rest)
        solution = program.solve(low)
        if solution is None:
            return None  # a subset of the rows is already infeasible
        full[used] = solution
        broken = np.flatnonzero((road_a @ full - road_b > 0.0) & ~active)
        if not broken.size:
            return full
        active[broken] = True
        add(broken)
    return None  # pragma: no cover


def _diagnose(
    model: RoadModel, sky: SkyMatrix | None, rows: RoadRows, low: float, tolerance: float
) -> pd.DataFrame:
    """Least total per-segment slack that makes the program feasible (module docstring)."""
    n = len(model.luminaires)
    segs, inverse = np.unique(rows.segment, return_inverse=True)
    m = segs.size
    road = -(sp.diags_array(1.0 / rows.scale) @ rows.matrix)
    slack = -sp.csr_array(
        (np.ones(rows.bound.size), (np.arange(rows.bound.size), inverse)),
        shape=(rows.bound.size, m),
    )
    blocks = [sp.hstack([road, slack])]
    bounds = [-rows.bound / rows.scale]
    if sky is not None and len(sky.labels):
        scale = np.maximum(np.abs(sky.goal), 1e-300)
        blocks.insert(
            0,
            sp.hstack(
                [
                    sp.csr_array(sky.contribution / scale[:, None]),
                    sp.csr_array((len(sky.labels), m)),
                ]
            ),
        )
        bounds.insert(0, (sky.goal - sky.fixed) / scale)
    cost = np.concatenate([np.zeros(n), np.ones(m)])
    result = linprog(
        cost,
        A_ub=sp.vstack(blocks, format="csr"),
        b_ub=np.concatenate(bounds),
        bounds=[(low, 1.0)] * n + [(0.0, None)] * m,
        method="highs",
        options={"primal_feasibility_tolerance": tolerance},
    )
    if result.status != 0:  # the sky targets alone are out of reach
        return pd.DataFrame({"segment": [], "lighting_class": [], "slack": [], "criteria": []})
    s = np.asarray(result.x[n:])
    delta = np.asarray(result.x[:n])
    binding = np.flatnonzero(s > BINDING_SLACK)
    criteria = []
    residual = (rows.matrix @ delta - rows.bound) / rows.scale
    for b in binding:
        mine = (inverse == b) & (residual < -BINDING_SLACK)
        criteria.append(",".join(sorted(set(rows.criterion[mine]))))
    segment = segs[binding]
    return pd.DataFrame(
        {
            "segment": segment,
            "lighting_class": model.classes.to_numpy(dtype=object)[segment],
            "slack": s[binding],
            "criteria": criteria,
        }
    ).sort_values("slack", ascending=False, ignore_index=True)


def _sky_frame(sky: SkyMatrix | None, dimming: FloatArray) -> pd.DataFrame:
    if sky is None:
        return pd.DataFrame({"target": [], "goal_cd_m2": [], "before_cd_m2": [], "after_cd_m2": []})
    return pd.DataFrame(
        {
            "target": list(sky.labels),
            "goal_cd_m2": sky.goal,
            "before_cd_m2": sky.before,
            "after_cd_m2": sky.after(dimming),
        }
    )


def road_plan(
    model: RoadModel,
    sky: SkyMatrix | None,
    *,
    objective: str = "energy",
    min_dimming: float = 0.0,
    weights: ArrayLike | None = None,
    hours: float = float("nan"),
    tolerance: float = TOLERANCE,
    coefficient_floor: float = COEFFICIENT_FLOOR,
) -> RoadPlan:
    """The least-energy (or least-flux) dimming that meets the sky and keeps every class.

    Parameters
    ----------
    model
        The rated street layer and its lights (:func:`~nightlights.roads.road_model`).
    sky
        The sky targets as a per-light matrix (:func:`~nightlights.inverse.sky_matrix`), or
        None for the road minima alone.
    objective
        ``"energy"`` (power of each light, from its photometry) or ``"flux"``.
    min_dimming
        Lowest level any light may take, delta_min in [0, 1] [1].
    weights
        Cost of each light at full output (overrides ``objective``'s) [W or lm].
    hours
        Hours a year the plan runs [h], for :attr:`RoadPlan.energy_saved`.
    tolerance
        HiGHS primal feasibility tolerance [1, rows scaled to a requirement of 1].
    coefficient_floor
        Road-row coefficients below this fraction of their row's largest enter the program
        at their worst case (module docstring) [1]: a plan that keeps every row, at a cost a
        little above the optimum, found much faster. 0: the exact program (the reference).

    Returns
    -------
    RoadPlan
        The dimming and its figures, re-rated by :meth:`RoadModel.rate`.
    """
    if objective not in OBJECTIVES:
        raise InputError(f"objective={objective!r}; expected one of {', '.join(OBJECTIVES)}")
    if not 0.0 <= min_dimming <= 1.0:
        raise InputError(f"min_dimming={min_dimming!r}; expected a level in [0, 1]")
    if not (0.0 < tolerance < 1e-3):
        raise InputError(f"tolerance={tolerance!r}; expected a number in (0, 1e-3)")
    if not 0.0 <= coefficient_floor < 1.0:
        raise InputError(
            f"coefficient_floor={coefficient_floor!r}; expected a fraction in [0, 1) (0: exact)"
        )
    n = len(model.luminaires)
    if sky is not None and sky.contribution.shape != (len(sky.labels), n):
        raise InputError(
            f"sky: a matrix of shape {sky.contribution.shape}; expected ({len(sky.labels)}, {n}) "
            "(built from this model's lights)"
        )
    w = _weights(model, objective, weights)
    before = model.rate(np.ones(n))
    rows = road_rows(model.influence, before)
    full = np.ones(n)
    sky_only = _solve(w, sky, None, min_dimming, tolerance)
    if sky_only is None:
        raise InputError(
            "sky: the sky targets are out of reach even with every light at min_dimming "
            f"({min_dimming:g}); expected targets above the sky the other sources leave"
        )
    joint = _solve(w, sky, rows, min_dimming, tolerance, coefficient_floor)
    if joint is None and coefficient_floor > 0.0:
        # thinned rows are tighter than the given ones: the exact program decides
        joint = _solve(w, sky, rows, min_dimming, tolerance, 0.0)
    feasible = joint is not None
    binding = pd.DataFrame()
    if joint is None:
        binding = _diagnose(model, sky, rows, min_dimming, tolerance)
        joint = full
    return RoadPlan(
        feasible=feasible,
        light_id=model.luminaires.light_id.copy(),
        dimming=joint,
        sky=_sky_frame(sky, joint),
        before=before,
        after=model.rate(joint),
        cost=float(w @ joint),
        cost_full=float(w.sum()),
        cost_sky_only=float(w @ sky_only),
        objective=objective,
        binding=binding,
        relaxed=rows.relaxed,
        hours=float(hours),
    )


def road_plan_schedule(
    model: RoadModel, periods: Sequence[PlanPeriod], **options: object
) -> list[RoadPlan]:
    """One plan per period of the night (module docstring).

    Parameters
    ----------
    model
        As :func:`road_plan`.
    periods
        The periods, each with its hours a year and sky targets.
    **options
        Passed to :func:`road_plan` (``objective``, ``min_dimming``, ...).

    Returns
    -------
    list of RoadPlan
        A plan per period; the year's energy saved is the sum of their ``energy_saved``.
    """
    if not periods:
        raise InputError("periods=[]; expected at least one period of the night")
    for period in periods:
        if not (np.isfinite(period.hours) and period.hours >= 0):
            raise InputError(f"periods: {period.name!r} has hours={period.hours!r}; expected >= 0")
    return [
        road_plan(model, period.sky, hours=period.hours, **options)  # type: ignore[arg-type]
        for period in periods
    ]
