"""The road minima of a dimming plan as linear constraints :math:`G\\,\\delta \\ge h`.

With :math:`\\delta` the levels of the luminaires and the matrices of
:mod:`nightlights.roads._influence`, every figure a class sets (EN 13201-2:2015, Tables 1-3;
computed as :mod:`nightlights.roads._rating` does) is kept by linear rows, for every section
of a rated segment and every observer of it (:math:`\\bar L_o = \\bar{\\mathsf L}_o\\delta`
the mean of observer :math:`o`'s samples, :math:`r` the requirement):

- average: :math:`\\bar{\\mathsf L}_o\\delta \\ge r` (and :math:`\\bar{\\mathsf E}\\delta
  \\ge r`);
- overall uniformity: :math:`\\mathsf L_p\\delta - r\\,\\bar{\\mathsf L}_o\\delta \\ge 0` for
  every point :math:`p` (illuminance: :math:`\\mathsf E_p\\delta - r\\,\\bar{\\mathsf E}\\delta
  \\ge 0`);
- longitudinal uniformity: :math:`\\mathsf L_p\\delta - r\\,\\mathsf L_q\\delta \\ge 0` for
  every ordered pair of points on the centre line of the observer's lane;
- minimum illuminance: :math:`\\mathsf E_p\\delta \\ge r`;
- edge illuminance ratio: :math:`\\bar{\\mathsf E}_\\text{out}\\delta - r\\,
  \\bar{\\mathsf E}_\\text{in}\\delta \\ge 0` on both edges;
- threshold increment, a *sufficient* linear condition. With :math:`L_v = \\mathsf V_o\\delta`
  and :math:`f_{TI} = 65 L_v / \\bar L^{0.8}` (:math:`\\bar L \\le 5` cd m-2),
  :math:`f_{TI} \\le T \\Leftrightarrow L_v \\le (T/65)\\,\\bar L\\,\\bar L^{-0.2}`; as
  :math:`\\bar L(\\delta) \\le \\bar L_0` (the undimmed average; the matrices are
  non-negative and :math:`\\delta \\le 1`), :math:`\\bar L^{-0.2} \\ge \\bar L_0^{-0.2}`, so
  :math:`(T/65)\\,\\bar L_0^{-0.2}\\,\\bar{\\mathsf L}_o\\delta - \\mathsf V_o\\delta \\ge 0`
  suffices. Above 5 cd m-2, :math:`f_{TI} = 95 L_v / \\bar L^{1.05}` and
  :math:`L_v \\le (T/95)\\,\\bar L\\,\\bar L^{0.05}`: the exponent is positive, so the bound
  runs the other way and needs a *lower* bound of :math:`\\bar L`; an observer with
  :math:`\\bar L_0 > 5` gets :math:`\\bar{\\mathsf L}_o\\delta \\ge 5` and
  :math:`(T/95)\\,5^{0.05}\\,\\bar{\\mathsf L}_o\\delta - \\mathsf V_o\\delta \\ge 0` (it
  stays on the high branch, where :math:`\\bar L^{0.05} \\ge 5^{0.05}`).

A segment that fails a criterion undimmed keeps that criterion at its undimmed value (the
segment's worst section's figure, loosened by :data:`RELAX_ROOM`, replaces the requirement):
the plan may not make it worse, and full output stays feasible with the margin the program
keeps inside every row. Each row carries its segment and a scale (the requirement
times the undimmed level it compares with) that turns a shortfall into a fraction of the
requirement, for the diagnosis of an infeasible plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.sparse as sp
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.roads._classes import CRITERIA
from nightlights.roads._influence import RoadInfluence
from nightlights.roads._metrics import TI_LUMINANCE_BREAK

__all__ = ["RoadRows", "road_rows"]

IntArray = NDArray[np.intp]
#: f_TI formula constants, EN 13201-3:2015, Sec. 9.4 (low and high luminance branches).
_TI_LOW, _TI_HIGH, _EXP_LOW, _EXP_HIGH = 65.0, 95.0, 0.8, 1.05
#: Room given a criterion held at its undimmed figure [1, fraction of the figure]: twice the
#: margin :data:`nightlights.roads._plan.MARGIN` the program keeps inside every row, so that
#: full output meets the held rows (a plan may lose at most this much on a failing segment).
RELAX_ROOM = 2e-6


@dataclass(frozen=True)
class RoadRows:
    """Rows :math:`G\\delta \\ge h` with each row's segment, criterion and scale.

    Attributes
    ----------
    matrix
        :math:`G`, (rows, lights).
    bound
        :math:`h`, (rows,).
    segment
        Segment row of each row.
    criterion
        Criterion name of each row.
    scale
        Requirement times the undimmed level it compares with, per row (> 0).
    relaxed
        Segments whose requirement was relaxed to the undimmed figure (failing undimmed).
    """

    matrix: sp.csr_array
    bound: FloatArray
    segment: IntArray
    criterion: NDArray[np.object_]
    scale: FloatArray
    relaxed: IntArray


def _averaging(group: IntArray, n: int) -> sp.csr_array:
    """(n, len(group)) matrix whose row g averages the members of group g."""
    count = np.bincount(group, minlength=n).astype(float)
    weight = 1.0 / np.maximum(count[group], 1.0)
    return sp.csr_array((weight, (group, np.arange(group.size))), shape=(n, group.size))


def _required(rating: pd.DataFrame, table_name: str, n_sections: int, seg: IntArray) -> FloatArray:
    """Per section: the (possibly relaxed) requirement of a criterion of its segment."""
    req = rating[f"{table_name}_required"].to_numpy(float)
    value = rating[table_name].to_numpy(float)
    kind = CRITERIA[table_name][0]
    fails = np.isfinite(req) & np.isfinite(value)
    # A failing criterion is held at its undimmed figure, loosened by RELAX_ROOM so that full
    # output keeps the margin the program holds inside every row.
    if kind == "minimum":
        req = np.where(fails & (value < req), value * (1.0 - RELAX_ROOM), req)
    else:
        req = np.where(fails & (value > req), value * (1.0 + RELAX_ROOM), req)
    return req[seg] if n_sections else np.zeros(0)


def road_rows(influence: RoadInfluence, rating: pd.DataFrame) -> RoadRows:
    """The rows of the module docstring for every rated segment.

    Parameters
    ----------
    influence
        The matrices of the street layer.
    rating
        The undimmed rating (:meth:`RoadModel.rate` at full output), which gives every
        segment's requirements and undimmed figures.
    """
    fields = influence.fields
    n_lights = influence.luminance.shape[1]
    ones = np.ones(n_lights)
    blocks: list[tuple[sp.csr_array, FloatArray, IntArray, str, FloatArray]] = []
    section_segment = fields.segment

    def add(g: sp.csr_array, h: FloatArray, section: IntArray, name: str, scale: FloatArray):
        keep = np.isfinite(h) & np.isfinite(scale) & (scale > 0)
        if keep.any():
            idx = np.flatnonzero(keep)
            blocks.append(
                (sp.csr_array(g[idx]), h[idx], section_segment[section[idx]], name, scale[idx])
            )

    n = fields.n_sections
    observers = fields.observers
    if len(observers):
        lum = influence.luminance
        obs = influence.sample_observer
        mean_o = sp.csr_array(_averaging(obs, len(observers)) @ lum)
        av0 = mean_o @ ones
        osec = observers.section
        r = _required(rating, "average_luminance", n, section_segment)[osec]
        add(mean_o, r, osec, "average_luminance", r)
        r = _required(rating, "overall_uniformity", n, section_segment)[osec][obs]
        g = lum - sp.diags_array(r) @ mean_o[obs]
        add(sp.csr_array(g), np.zeros(obs.size), osec[obs], "overall_uniformity", r * av0[obs])
        # Longitudinal: ordered pairs on the centre line of each observer's lane.
        point = influence.sample_point
        centre = fields.luminance.column[point] == (3 * observers.lane[obs] + 1)
        rows = np.flatnonzero(centre)
        owner = obs[rows]
        order = np.argsort(owner, kind="stable")
        rows, owner = rows[order], owner[order]
        starts = np.searchsorted(owner, np.unique(owner))
        counts = np.diff(np.append(starts, owner.size))
        p_list, q_list = [], []
        for count in np.unique(counts):
            first = starts[counts == count]
            a, b = np.meshgrid(np.arange(count), np.arange(count), indexing="ij")
            off = a != b
            p_list.append((first[:, None] + a[off][None, :]).ravel())
            q_list.append((first[:, None] + b[off][None, :]).ravel())
        if p_list:
            p = rows[np.concatenate(p_list)]
            q = rows[np.concatenate(q_list)]
            r = _required(rating, "longitudinal_uniformity", n, section_segment)[osec][obs[p]]
            g = lum[p] - sp.diags_array(r) @ lum[q]
            add(
                sp.csr_array(g),
                np.zeros(p.size),
                osec[obs[p]],
                "longitudinal_uniformity",
                r * av0[obs[p]],
            )
        # Threshold increment (sufficient linear conditions).
        ti = _required(rating, "threshold_increment", n, section_segment)[osec]
        high = av0 > TI_LUMINANCE_BREAK
        coef = np.where(
            high,
            ti / _TI_HIGH * TI_LUMINANCE_BREAK ** (_EXP_HIGH - 1.0),
            ti / _TI_LOW * np.maximum(av0, 1e-300) ** (_EXP_LOW - 1.0),
        )
        g = sp.diags_array(coef) @ mean_o - influence.veiling
        add(sp.csr_array(g), np.zeros(len(observers)), osec, "threshold_increment", coef * av0)
        lock = np.where(high & np.isfinite(ti), TI_LUMINANCE_BREAK, np.nan)
        add(mean_o, lock, osec, "threshold_increment", lock)
        strips = fields.strips
        if len(strips):
            key = strips.section * 4 + strips.column
            means = sp.csr_array(_averaging(key, n * 4) @ influence.strips)
            r = _required(rating, "edge_illuminance_ratio", n, section_segment)
            sec = np.arange(n)
            inner0 = np.maximum(means[sec * 4 + 1] @ ones, means[sec * 4 + 2] @ ones)
            for out_strip, in_strip in ((0, 1), (3, 2)):
                g = means[sec * 4 + out_strip] - sp.diags_array(r) @ means[sec * 4 + in_strip]
                add(sp.csr_array(g), np.zeros(n), sec, "edge_illuminance_ratio", r * inner0)
    points = fields.illuminance
    if len(points):
        # only the sections whose class rates illuminance (the others carry the field for D_P)
        rates_luminance = np.zeros(n, dtype=bool)
        rates_luminance[fields.observers.section] = True
        rated = ~rates_luminance[points.section]
        e = sp.csr_array(influence.illuminance[np.flatnonzero(rated)])
        mean_s = sp.csr_array(_averaging(points.section[rated], n) @ e)
        sec = points.section[rated]
        r = _required(rating, "average_illuminance", n, section_segment)
        add(mean_s, r, np.arange(n), "average_illuminance", r)
        r = _required(rating, "minimum_illuminance", n, section_segment)[sec]
        add(e, r, sec, "minimum_illuminance", r)
        r = _required(rating, "overall_uniformity", n, section_segment)[sec]
        g = e - sp.diags_array(r) @ mean_s[sec]
        add(
            sp.csr_array(g), np.zeros(sec.size), sec, "overall_uniformity", r * (mean_s @ ones)[sec]
        )
    relaxed = np.flatnonzero(~rating["passed"].fillna(True).to_numpy(bool))
    if not blocks:
        return RoadRows(
            sp.csr_array((0, n_lights)),
            np.zeros(0),
            np.zeros(0, np.intp),
            np.zeros(0, object),
            np.zeros(0),
            relaxed.astype(np.intp),
        )
    return RoadRows(
        sp.csr_array(sp.vstack([b[0] for b in blocks], format="csr")),
        np.concatenate([b[1] for b in blocks]),
        np.concatenate([b[2] for b in blocks]).astype(np.intp),
        np.concatenate([np.full(b[1].size, b[3], dtype=object) for b in blocks]),
        np.concatenate([b[4] for b in blocks]),
        relaxed.astype(np.intp),
    )
