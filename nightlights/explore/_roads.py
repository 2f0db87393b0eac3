"""Road lighting in the explorer: segment compliance at the session's dimming, and a plan.

The session's state is its emission raster; a street layer and its lights
(:func:`nightlights.roads.road_model`) are rated on it as follows.

*Each light's level.* Light :math:`k` in cell :math:`c(k)` of the raster has the level

.. math:: \\ell_k = p_k\\, F_{c(k)} / R_k ,

with :math:`F_c` the cell's current upward flux (all bands), :math:`p_k` the level the last
applied plan gave the light (1 before any) and :math:`R_k` its cell's flux when that plan was
applied (the original raster's before any). A brush edit therefore dims (or brightens) every
light of the cells it touches alike, an applied plan sets each light's own level, and an edit
after a plan scales the plan's levels. Lights whose cell is unlit in the original raster, or
outside it, keep :math:`p_k` (the raster holds nothing of them). The segments are rated by
:meth:`nightlights.roads.RoadModel.rate` at :math:`\\ell`, as ``nightlights streets audit``
with a dimming field.

*The sky targets per light.* The explorer's least-dimming target (the zenith, or the
solid-angle mean of a sky region, at the current observer) gives each lit cell its part
:math:`C_{jc}` [cd m-2] (:meth:`~nightlights.explore.ExploreSession.influence`, the zenith
Q or the region's S). A cell holding lights is taken to be made by them: its part at full
output (the original raster) is shared in proportion to the lights' upward emission
:math:`e_k = \\Phi^\\uparrow_k + \\rho\\Phi^\\downarrow_k`
(:func:`nightlights.inverse.road_sky.upward_emission`),

.. math:: S_{jk} = C^\\text{orig}_{j c(k)}\\, e_k / \\sum_{k' \\in c(k)} e_{k'} ,

and what the cells without lights make now is the fixed part of the sky,
:math:`B_j - \\sum_{c \\ni \\text{lights}} C^\\text{now}_{jc}`. This is
:func:`nightlights.inverse.sky_matrix`'s per-light approximation with the cell's flux taken
from the raster rather than from the photometry: when the raster is the lights' emission
(:func:`~nightlights.inverse.road_sky.lights_emission`) the two are the same matrix.

*Applying a plan.* Every cell holding lights is set to its original flux density times
:math:`\\sum_k \\delta_k e_k / \\sum_k e_k` (all bands alike), in one undoable edit; its sky
is then exactly what the matrix predicts. The sky after is recomputed from the edited raster
(not taken from the solver), and so is the compliance (:math:`\\ell = \\delta`).

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Eqs. 13-14 (a cell's part of a sky region).
EN 13201-2:2015, Tables 1-3, and EN 13201-3:2015 (the classes and the figures rated, see
:mod:`nightlights.roads`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from affine import Affine
from pyproj import CRS, Transformer

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.roads._audit import AuditSummary, RoadModel, road_model, summarise
from nightlights.roads._plan import RoadPlan, SkyMatrix

__all__ = ["RoadOptions", "RoadPlanView", "RoadView", "SessionRoads"]

#: Per-segment fields the road view sends to the map.
POPUP_FIELDS = ("segment", "lighting_class", "status", "binding", "binding_margin", "reason")


@dataclass(frozen=True)
class RoadOptions:
    """How the explorer builds its road model (the keywords of
    :func:`nightlights.roads.road_model`; None: its defaults).

    Attributes
    ----------
    catalog
        Luminaire database.
    rtable
        The road surface's r-table (path or :class:`~nightlights.roads.RTable`).
    requirements
        Requirements by class (TOML path or mapping; default EN 13201-2:2015 Tables 1-3).
    selection
        Class selection rules (TOML path or :class:`~nightlights.roads.ClassSelection`).
    """

    catalog: str | os.PathLike[str] | None = None
    rtable: Any = None
    requirements: str | os.PathLike[str] | Mapping[str, Mapping[str, float]] | None = None
    selection: Any = None


@dataclass(frozen=True)
class RoadView:
    """The street segments rated at the session's current levels.

    Attributes
    ----------
    segments
        One row per segment (in the raster's CRS): ``segment`` (its row in the model),
        ``lighting_class``, ``status`` (``pass``, ``fail``, ``not rated``), ``binding`` and
        ``binding_margin`` (the criterion closest to failing, its margin [1]), ``reason``.
    summary
        Share of the rated length that keeps its class, overall and per class.
    levels
        Level of every light of the model [1].
    """

    segments: Any  # geopandas.GeoDataFrame
    summary: AuditSummary
    levels: FloatArray

    def to_geojson(self) -> dict[str, Any]:
        """The segments as a GeoJSON FeatureCollection (raster CRS) with the summary."""
        import shapely

        features = []
        frame = self.segments
        records = frame[list(POPUP_FIELDS)].to_dict(orient="records")
        for geometry, record in zip(frame.geometry.to_numpy(), records, strict=True):
            coords = shapely.get_coordinates(geometry).tolist()
            margin = record["binding_margin"]
            record["binding_margin"] = (
                None if margin is None or not math.isfinite(float(margin)) else float(margin)
            )
            record["segment"] = int(record["segment"])
            record["lighting_class"] = record["lighting_class"] or None
            record["binding"] = record["binding"] or None
            features.append(
                {
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": coords},
                    "properties": record,
                }
            )
        return {
            "type": "FeatureCollection",
            "features": features,
            "summary": self.summary.to_dict(),
        }


@dataclass(frozen=True)
class RoadPlanView:
    """A road plan solved on the session, and what it does.

    Attributes
    ----------
    plan
        The plan (:func:`nightlights.roads.road_plan`): dimming, costs, binding segments.
    applied
        Whether the plan was applied to the session's emission (feasible plans are).
    sky_before, sky_after
        The target's luminance at the observer before and after, recomputed by the
        session [cd m-2] (after: NaN when not applied, or no target).
    goal
        The target's luminance [cd m-2] (NaN: no sky target).
    target
        What the target is.
    before, after
        The segments rated before (the session's levels) and after (the plan's).
    """

    plan: RoadPlan
    applied: bool
    sky_before: float
    sky_after: float
    goal: float
    target: str
    before: RoadView
    after: RoadView

    def to_dict(self) -> dict[str, Any]:
        """The plan's figures as JSON-ready numbers (the segments as GeoJSON)."""
        plan = self.plan
        unit = "W" if plan.objective == "energy" else "lm"
        return {
            "feasible": bool(plan.feasible),
            "applied": self.applied,
            "objective": plan.objective,
            "unit": unit,
            "lights": len(plan.dimming),
            "lights_dimmed": int(np.sum(plan.dimming < 1.0 - 1e-9)),
            "cost_full": plan.cost_full,
            "cost": plan.cost,
            "saved": plan.saved,
            "saved_share": plan.saved / plan.cost_full if plan.cost_full > 0 else None,
            "hours": _finite(plan.hours),
            "energy_saved_kwh": _finite(plan.energy_saved / 1000.0),
            "cost_sky_only": plan.cost_sky_only,
            "cost_of_safety": plan.cost_of_safety,
            "target": self.target,
            "sky": {
                "goal_cd_m2": _finite(self.goal),
                "before_cd_m2": _finite(self.sky_before),
                "after_cd_m2": _finite(self.sky_after),
                "predicted_cd_m2": (
                    _finite(float(plan.sky["after_cd_m2"].iloc[0])) if len(plan.sky) else None
                ),
            },
            "compliance_before": self.before.summary.to_dict(),
            "compliance_after": self.after.summary.to_dict(),
            "binding": [
                {key: _plain(value) for key, value in row.items()}
                for row in plan.binding.to_dict(orient="records")
            ],
            "dimming": plan.dimming,
            "light_id": [_plain(v) for v in plan.light_id.tolist()],
        }


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


class SessionRoads:
    """A street layer's road model placed on a session's raster (module docstring).

    Parameters
    ----------
    lights, streets
        The light and street layers (paths or GeoDataFrames).
    options
        How the road model is built.
    transform, shape, crs
        The session raster's grid.
    original
        Shape ``(rows, cols)``: the original raster's flux density, all bands [lm m-2].
    """

    def __init__(
        self,
        lights: Any,
        streets: Any,
        options: RoadOptions,
        *,
        transform: Affine,
        shape: tuple[int, int],
        crs: CRS,
        original: FloatArray,
    ) -> None:
        from nightlights.inverse.road_sky import upward_emission

        self.model: RoadModel = road_model(
            lights,
            streets,
            catalog=options.catalog,
            rtable=options.rtable,
            requirements=options.requirements,
            selection=options.selection,
        )
        self.crs = crs
        model_crs = self.model.segments.crs
        points = self.model.luminaires.light_point
        x, y = points[:, 0], points[:, 1]
        if model_crs is not None and CRS.from_user_input(model_crs) != crs:
            x, y = Transformer.from_crs(model_crs, crs, always_xy=True).transform(x, y)
        col, row = ~transform @ (np.asarray(x), np.asarray(y))
        row, col = np.floor(row).astype(np.intp), np.floor(col).astype(np.intp)
        self.inside = (row >= 0) & (col >= 0) & (row < shape[0]) & (col < shape[1])
        self.row = np.where(self.inside, row, 0)
        self.col = np.where(self.inside, col, 0)
        self.shape = shape
        self.emitted = upward_emission(self.model.luminaires)
        flat = self.row * shape[1] + self.col
        _, index = np.unique(flat[self.inside], return_inverse=True)
        self.cell_emitted = np.zeros(len(flat))
        if index.size:
            cell_total = np.bincount(index, weights=self.emitted[self.inside])
            self.cell_emitted[self.inside] = cell_total[index]
        original = np.nan_to_num(np.asarray(original, dtype=float), nan=0.0)
        self.original_flux = np.where(self.inside, original[self.row, self.col], 0.0)
        self.represented = self.inside & (self.original_flux > 0) & (self.cell_emitted > 0)
        self._segments = self.model.segments.to_crs(crs) if model_crs is not None else None

    @property
    def n_lights(self) -> int:
        """Lights of the model [1]."""
        return len(self.model.luminaires)

    def initial(self) -> tuple[FloatArray, FloatArray]:
        """(p, R) before any plan: every light at 1, its cell's original flux."""
        return np.ones(self.n_lights), self.original_flux.copy()

    def levels(
        self, current: FloatArray, state: tuple[FloatArray, FloatArray] | None
    ) -> FloatArray:
        """Every light's level :math:`\\ell_k = p_k F_{c(k)} / R_k` [1].

        Parameters
        ----------
        current
            Shape ``(rows, cols)``: the current flux density, all bands [lm m-2].
        state
            (p, R) of the last applied plan, or None.
        """
        p, reference = self.initial() if state is None else state
        now = np.nan_to_num(np.asarray(current, dtype=float), nan=0.0)
        flux = np.where(self.inside, now[self.row, self.col], 0.0)
        ratio = np.ones(self.n_lights)
        np.divide(flux, reference, out=ratio, where=self.represented & (reference > 0))
        return np.asarray(p * ratio, dtype=float)

    def view(self, levels: FloatArray) -> RoadView:
        """The segments rated at ``levels``."""
        rating = self.model.rate(levels)
        segments = self.model.segments
        segments = segments[[segments.geometry.name]].copy()
        segments["segment"] = np.arange(len(segments))
        classes = rating["lighting_class"].astype(object)
        segments["lighting_class"] = classes.where(classes.notna(), "").to_numpy()
        passed = rating["passed"]
        status = np.where(passed.fillna(False).to_numpy(bool), "pass", "fail")
        status = np.where(passed.isna().to_numpy(), "not rated", status)
        segments["status"] = status
        binding = rating["binding"].astype(object)
        segments["binding"] = binding.where(binding.notna(), "").to_numpy()
        segments["binding_margin"] = pd.to_numeric(rating["binding_margin"]).to_numpy()
        reason = self.model.reason.copy()
        reason[(reason == "") & (status == "not rated")] = "no requirement applies"
        segments["reason"] = reason
        # lengths in the street layer's own CRS; the map's geometry in the raster's
        summary = summarise(segments, self.model.rtable.name)
        if self._segments is not None:
            import geopandas as gpd

            segments = gpd.GeoDataFrame(
                segments.drop(columns=segments.geometry.name),
                geometry=self._segments.geometry.to_numpy(),
                crs=self.crs,
            )
        return RoadView(segments, summary, levels)

    def sky_matrix(
        self,
        original_part: FloatArray,
        current_part: FloatArray,
        before: float,
        goal: float,
        label: str,
    ) -> SkyMatrix:
        """One sky target as a per-light matrix (module docstring).

        Parameters
        ----------
        original_part, current_part
            Shape ``(rows, cols)``: each cell's part of the target in the original and the
            current raster [cd m-2] (NaN or 0 where unlit).
        before
            The target's luminance now [cd m-2].
        goal
            The luminance it must not exceed [cd m-2].
        label
            What the target is.
        """
        part = np.nan_to_num(np.asarray(original_part, dtype=float), nan=0.0)
        now = np.nan_to_num(np.asarray(current_part, dtype=float), nan=0.0)
        share = np.zeros(self.n_lights)
        np.divide(self.emitted, self.cell_emitted, out=share, where=self.represented)
        contribution = np.where(self.represented, part[self.row, self.col] * share, 0.0)
        cells = np.unique((self.row * self.shape[1] + self.col)[self.represented])
        fixed = max(float(before) - float(now.flat[cells].sum()), 0.0)
        return SkyMatrix(
            contribution[None, :],
            np.array([fixed + contribution.sum()]),
            np.array([float(goal)]),
            (label,),
        )

    def cell_values(
        self, dimming: FloatArray, original: FloatArray
    ) -> tuple[np.ndarray, np.ndarray, FloatArray]:
        """The cells holding lights and their flux density at a plan's dimming.

        Parameters
        ----------
        dimming
            Level of every light [1].
        original
            Shape ``(bands, rows, cols)``: the original flux density [lm m-2].

        Returns
        -------
        rows, cols, values
            The cells and their new flux density ``(bands, n)`` [lm m-2].
        """
        flat = (self.row * self.shape[1] + self.col)[self.represented]
        kept = np.asarray(dimming, dtype=float)[self.represented] * self.emitted[self.represented]
        cells, index = np.unique(flat, return_inverse=True)
        level = np.bincount(index, weights=kept) / np.bincount(
            index, weights=self.emitted[self.represented]
        )
        rows, cols = np.divmod(cells, self.shape[1])
        values = np.asarray(original, dtype=float)[:, rows, cols] * level[None, :]
        return rows, cols, values

    def after_plan(
        self, dimming: FloatArray, rows: np.ndarray, cols: np.ndarray, values: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """(p, R) once a plan is applied: the plan's levels, their cells' new flux.

        Parameters
        ----------
        dimming
            The plan's level of every light [1].
        rows, cols, values
            The cells set and their flux density ``(bands, n)`` (:meth:`cell_values`).
        """
        reference = self.original_flux.copy()
        if rows.size:
            cells = rows * self.shape[1] + cols
            flat = self.row * self.shape[1] + self.col
            where = np.clip(np.searchsorted(cells, flat), 0, cells.size - 1)
            hit = self.represented & (cells[where] == flat)
            total = np.nansum(np.asarray(values, dtype=float), axis=0)
            reference[hit] = total[where[hit]]
        return np.asarray(dimming, dtype=float).copy(), reference


def no_streets() -> InputError:
    """The error of a road query on a session without a street layer."""
    return InputError(
        "streets=None: the session has no street layer; expected a session opened with streets="
    )
