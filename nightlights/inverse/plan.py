"""Dimming plans: ``inverse_reduce`` (Dobashi et al. 2023, Eq. 12) and ``least_dimming``.

Both dim every lit cell of the emission raster by a fraction (both emission bands alike: a
dimmed luminaire loses its reflected light and its uplight together), report the flux removed
and the sky before and after for each observer, and write the dimmed emission, the dimming
raster, a JSON summary and a before/after picture only when given paths (all checked before
the computation, each written atomically).

- :func:`inverse_reduce`: the fraction follows a Q or S raster (Eq. 12).
- :func:`least_dimming`: the fractions that meet zenith or region sky-brightness targets for one
  or several observers while removing the least flux; skyglow is linear in the emission, so
  this is a linear program (a fractional knapsack for one target,
  :func:`~nightlights.inverse.least_flux_dimming`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import luminance_to_magnitude, magnitude_to_luminance
from nightlights.errors import InputError
from nightlights.ground.checks import raster_header
from nightlights.inverse._dimming import dimming_fraction, least_flux_dimming
from nightlights.inverse._region import SkyRegion
from nightlights.inverse.stage import (
    _check_outputs,
    _lit,
    _panorama,
    _panorama_value,
    _region_weights,
    _target_weights,
)
from nightlights.io import Raster, as_raster, source_label
from nightlights.io.jsonfile import dumps_json, non_finite_reason
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import PRODUCT_TAG
from nightlights.sky._flat import flat_keywords
from nightlights.sky.influence import cell_values, region_table, zenith_weights
from nightlights.sky.observer import OBSERVER_HEIGHT, Observer
from nightlights.sky.polar import PolarCells
from nightlights.sky.scene import Scene
from nightlights.sky.setup import RasterInput, prepare_scene

__all__ = ["ReduceResult", "inverse_reduce", "least_dimming"]


@dataclass(frozen=True)
class ReduceResult:
    """What :func:`inverse_reduce` or :func:`least_dimming` computed.

    Attributes
    ----------
    raster
        The dimmed emission, same bands as the input [lm m-2].
    dimming
        One band ``dimming``: the fraction of each cell's flux removed, NaN where unlit [1].
    summary
        Flux removed [lm, %] and the sky before and after for every observer
        (JSON-serialisable).
    path
        The dimmed emission written, or None.
    """

    raster: Raster
    dimming: Raster
    summary: dict[str, Any]
    path: Path | None = None


@flat_keywords(legacy=("output",), observer="none")
def inverse_reduce(
    scene: Scene,
    output: PathLike | None = None,
    *,
    by: RasterInput,
    qa: float,
    qb: float,
    gamma: float = 1.0,
    dimming_output: PathLike | None = None,
    summary_output: PathLike | None = None,
    png: PathLike | None = None,
    progress: bool = True,
) -> ReduceResult:
    """Dim the lights by their Q or S (Dobashi et al. 2023, Eq. 12), on both emission bands.

    gamma_i = clip((Q_i - Q_a) / (Q_b - Q_a), 0, 1) gamma_usr and L_i <- (1 - gamma_i) L_i:
    cells above Q_b lose the fraction gamma_usr of their flux, cells below Q_a keep all of it.

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2]) to dim (:class:`~nightlights.sky.scene.
        Scene`); what it leaves open (turbidity, grid, kernel, DEM) is taken from the scene
        ``by`` recorded (:meth:`~nightlights.sky.scene.Scene.recorded`), so the before/after
        figures are computed as ``by`` was.
    output
        Dimmed emission (COG), written atomically; None writes nothing.
    by
        A Q or S raster of :func:`inverse_q` / :func:`inverse_s` on the emission's grid (or
        the window of it that the kernel reached, NaN around it); its tags name the observer
        (and region) for the before/after figures and the scene.
    qa, qb
        Q_a < Q_b: influence below which nothing is dimmed and above which gamma_usr is
        [cd m-2, the unit of ``by``].
    gamma
        gamma_usr in [0, 1] [1].
    dimming_output
        Dimming raster (COG), band ``dimming`` [1].
    summary_output
        Summary JSON.
    png
        Before/after panoramas side by side.
    progress
        Progress bar while building a kernel.

    Returns
    -------
    ReduceResult
        The dimmed emission, the dimming and the summary.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.inverse import inverse_q
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 9, 11] = flux[0, 2, 2] = 1.0  # near, far
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> scene = Scene(raster, kernel=kernel)
    >>> q = inverse_q(scene, Observer(1000.0, 1000.0)).raster
    >>> qa, qb = np.nanmin(q.data), np.nanmax(q.data)
    >>> result = inverse_reduce(scene, by=q, qa=qa, qb=qb, gamma=0.5)
    >>> float(result.dimming.data[0, 9, 11]), float(result.dimming.data[0, 2, 2])  # near: halved
    (0.5, 0.0)
    >>> round(result.summary["flux_removed_percent"], 1)
    25.0
    """
    outputs = _check_outputs(
        output, dimming_output, summary_output, png, inputs={**scene.inputs, "by": by}
    )
    emission = scene.raster_input("inverse_reduce")
    _check_dense(emission)
    raster = as_raster(emission)
    label = source_label(by, "influence raster")
    influence = as_raster(by)
    # NaN at a lit cell: beyond the kernel's reach (outside the window it reached), no part
    values = np.nan_to_num(_on_grid(raster, influence, label), nan=0.0)
    lit = _lit(raster.data)
    fraction = np.where(lit, dimming_fraction(values, qa, qb, gamma), 0.0)
    tags = influence.tags
    observer = _tag_observer(tags, label)
    region = tags.get("region")
    targets = [("zenith", None)] + ([("region", SkyRegion.parse(region))] if region else [])
    summary, picture = _summary(
        scene.recorded(tags, label).replace(emission=raster),
        fraction,
        [observer],
        [targets],
        weight=tags.get("weight", "solid-angle"),
        progress=progress,
        picture=png is not None,
    )
    summary["rule"] = {
        "equation": "Dobashi et al. 2023, Eq. 12",
        "by": label,
        "metric": tags.get("metric", ""),
        "qa": float(qa),
        "qb": float(qb),
        "gamma": float(gamma),
    }
    return _reduce_outputs(
        raster,
        fraction,
        summary,
        outputs,
        output=output,
        dimming_output=dimming_output,
        summary_output=summary_output,
        png=png,
        picture=picture,
    )


@flat_keywords(legacy=("output",), observer="many")
def least_dimming(
    scene: Scene,
    observers: Sequence[Observer],
    output: PathLike | None = None,
    *,
    target_zenith: float | None = None,
    target_region: Sequence[tuple[str | PathLike | SkyRegion, float]] = (),
    max_dimming: float | RasterInput = 1.0,
    dimming_output: PathLike | None = None,
    summary_output: PathLike | None = None,
    png: PathLike | None = None,
    progress: bool = True,
) -> ReduceResult:
    """The dimming that meets sky-brightness targets while removing the least flux.

    Skyglow is linear in the emission: dimming cell i by the fraction x_i lowers target j by
    A_ji x_i, where A_ji is the cell's part of that target (:func:`inverse_q` ``zenith``,
    :func:`inverse_s`). The plan minimises sum_i flux_i x_i subject to every target being met
    and 0 <= x_i <= max_dimming_i: a fractional knapsack solved exactly by the greedy rule for
    one target, a linear program (HiGHS) for several
    (:func:`~nightlights.inverse.least_flux_dimming`).

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2]) to dim, its terrain, atmosphere and kernel
        (:class:`~nightlights.sky.scene.Scene`).
    observers
        Who must see the targets (:class:`~nightlights.sky.observer.Observer`), inside the
        raster or within the kernel's range of it.
    output
        Dimmed emission (COG), written atomically; None writes nothing.
    target_zenith
        Zenith sky brightness every observer must reach [mag arcsec-2].
    target_region
        (region, brightness) pairs: the region's solid-angle-weighted mean luminance every
        observer must reach [deg, mag arcsec-2].
    max_dimming
        Largest fraction of any cell's flux that may be removed: a number in [0, 1] or a
        raster on the emission grid (safety lighting stays) [1].
    dimming_output, summary_output, png, progress
        As :func:`inverse_reduce`.

    Returns
    -------
    ReduceResult
        The dimmed emission, the dimming and the summary (with the targets, the sky after,
        and the solver used).

    Raises
    ------
    InfeasibleTargetError
        When even the largest allowed dimming misses a target (the message names the best
        reachable value).

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Observer, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 9, 11] = flux[0, 2, 2] = 1.0  # near, far
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> kernel = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... )
    >>> scene = Scene(raster, kernel=kernel)
    >>> plan = least_dimming(scene, [Observer(1000.0, 1000.0)], target_zenith=24.0)
    >>> zenith = plan.summary["observers"][0]["zenith"]
    >>> round(zenith["before_mag_arcsec2"], 2), round(zenith["after_mag_arcsec2"], 2)
    (23.57, 24.0)
    >>> plan.summary["plan"]["method"]
    'greedy'
    """
    if target_zenith is None and not target_region:
        raise InputError("no target: give target_zenith and/or target_region")
    if not observers:
        raise InputError("no observer: the targets are for at least one observer")
    given = [region for region, _ in target_region]
    inputs = {**scene.inputs, "max_dimming": max_dimming, "target_region": given}
    outputs = _check_outputs(output, dimming_output, summary_output, png, inputs=inputs)
    emission = scene.raster_input("least_dimming")
    _check_dense(emission)
    raster = as_raster(emission)
    dense = scene.replace(emission=raster)
    regions = [(SkyRegion.parse(region), float(mag)) for region, mag in target_region]
    targets: list[tuple[str, SkyRegion | None, float]] = []
    if target_zenith is not None:
        targets.append(("zenith", None, float(target_zenith)))
    targets += [("region", region, mag) for region, mag in regions]
    lit = _lit(raster.data)
    cap = _max_dimming(max_dimming, raster)
    contributions, before, goal, labels = [], [], [], []
    scene_cells: PolarCells | None = None
    for index, observer in enumerate(observers):
        setup = prepare_scene(dense, observer, progress=progress)
        cells = setup.polar_cells()
        scene_cells = cells if scene_cells is None else scene_cells
        levels = setup.level_weights(cells)
        for kind, region, mag in targets:
            weights = _target_weights(setup, kind, region)
            tables = [region_table(t, weights) for t in setup.slices]
            contributions.append(cell_values(cells, levels, tables))
            before.append(_panorama_value(setup, cells, weights))
            goal.append(float(magnitude_to_luminance(mag)))
            where = f"observer {index + 1} ({setup.xy[0]:.1f}, {setup.xy[1]:.1f})"
            labels.append(f"{kind} {region.text if region else ''} at {where}".replace("  ", " "))
    assert scene_cells is not None
    flux = scene_cells.flux.sum(axis=0)
    plan = least_flux_dimming(
        np.asarray(contributions),
        flux,
        np.asarray(before),
        np.asarray(goal),
        max_dimming=cap[scene_cells.rows, scene_cells.cols],
        labels=labels,
    )
    fraction = np.zeros(raster.shape)
    fraction[scene_cells.rows, scene_cells.cols] = plan.fraction
    fraction = np.where(lit, fraction, 0.0)
    summary, picture = _summary(
        dense,
        fraction,
        list(observers),
        [[(kind, region) for kind, region, _ in targets]] * len(observers),
        weight="solid-angle",
        progress=progress,
        picture=png is not None,
    )
    summary["plan"] = {
        "method": plan.method,
        "targets": [
            {
                "target": label,
                "asked_mag_arcsec2": float(luminance_to_magnitude(g)),
                "before_cd_m2": float(b),
                "after_cd_m2": float(a),
                "after_mag_arcsec2": float(luminance_to_magnitude(max(a, 0.0))),
            }
            for label, g, b, a in zip(labels, goal, plan.before, plan.after, strict=True)
        ],
    }
    return _reduce_outputs(
        raster,
        fraction,
        summary,
        outputs,
        output=output,
        dimming_output=dimming_output,
        summary_output=summary_output,
        png=png,
        picture=picture,
    )


def _check_dense(emission: RasterInput) -> None:
    """A dimming holds the whole emission grid: the emission, its dimmed copy, the dimming,
    the influence or cap raster and the float32 copies written [B] (refused over the limit)."""
    header = raster_header(emission)
    if header is None:
        return
    cells = float(header.rows) * float(header.cols)
    check_memory(
        cells * 8.0 * (3 * header.count + 4),
        f"dimming the {header.rows} x {header.cols} emission raster "
        f"{source_label(emission, 'emission raster')}",
        option="use a coarser emission raster",
    )


# --- helpers ------------------------------------------------------------------------------------


def _same_grid(raster: Raster, other: Raster, label: str) -> None:
    if other.shape != raster.shape or not other.transform.almost_equals(raster.transform):
        raise InputError(
            f"{label}: grid {other.shape} at {tuple(other.transform)[:6]} differs from the "
            f"emission's {raster.shape} at {tuple(raster.transform)[:6]}; expected the same grid"
        )


def _on_grid(raster: Raster, influence: Raster, label: str) -> FloatArray:
    """The influence's first band on the emission grid: itself, or the window the kernel
    reached (:attr:`InfluenceResult.window`) set into a grid of NaN."""
    t, o = raster.transform, influence.transform
    col, row = ~t @ (o.c, o.f)
    whole = influence.shape == raster.shape and o.almost_equals(t)
    aligned = (
        not whole
        and (o.a, o.b, o.d, o.e) == (t.a, t.b, t.d, t.e)
        and abs(col - round(col)) < 1e-6
        and abs(row - round(row)) < 1e-6
    )
    if not aligned:
        _same_grid(raster, influence, label)
        return influence.data[0]
    row0, col0 = round(row), round(col)
    rows, cols = influence.shape
    if row0 < 0 or col0 < 0 or row0 + rows > raster.shape[0] or col0 + cols > raster.shape[1]:
        _same_grid(raster, influence, label)  # not a window of the grid: refused
    values = np.full(raster.shape, np.nan)
    values[row0 : row0 + rows, col0 : col0 + cols] = influence.data[0]
    return values


def _tag_observer(tags: dict[str, str] | Any, label: str) -> Observer:
    """The observer an influence raster recorded: (x, y) in its CRS and the eye height."""
    try:
        xy = float(tags["observer_x"]), float(tags["observer_y"])
    except (KeyError, ValueError) as exc:
        raise InputError(
            f"{label}: no observer in its tags; expected a raster written by inverse q or inverse s"
        ) from exc
    return Observer(*xy, height=float(tags.get("observer_height_m", OBSERVER_HEIGHT)))


def _max_dimming(value: float | RasterInput, raster: Raster) -> FloatArray:
    if isinstance(value, bool):
        raise InputError(f"max dimming {value!r}; expected a number in [0, 1] or a raster")
    if isinstance(value, int | float):
        cap = np.full(raster.shape, float(value))
        label = f"max dimming {value!r}"
    else:
        label = source_label(value, "max-dimming raster")
        other = as_raster(value)
        _same_grid(raster, other, label)
        cap = np.nan_to_num(other.data[0], nan=0.0)
    if not (np.all(np.isfinite(cap)) and cap.min() >= 0.0 and cap.max() <= 1.0):
        raise InputError(f"{label}: values {cap.min():g}-{cap.max():g}; expected within [0, 1]")
    return cap


def _summary(
    scene: Scene,
    fraction: FloatArray,
    observers: Sequence[Observer],
    targets: Sequence[Sequence[tuple[str, SkyRegion | None]]],
    *,
    weight: str,
    progress: bool,
    picture: bool,
) -> tuple[dict[str, Any], tuple[FloatArray, FloatArray, FloatArray] | None]:
    """Flux removed and, per observer, the zenith (and regions) before and after; with
    ``picture``, the first observer's panoramas before and after and their elevations.
    ``scene`` holds the emission in memory (a Raster)."""
    raster = scene.emission
    assert isinstance(raster, Raster)
    cell_area = raster.resolution**2
    flux = np.nan_to_num(raster.data).sum(axis=0) * cell_area
    removed = float(np.sum(flux * fraction))
    total = float(flux.sum())
    entries = []
    pictures = []
    for observer, wanted in zip(observers, targets, strict=True):
        setup = prepare_scene(scene, observer, progress=progress)
        cells = setup.polar_cells()
        before = _panorama(setup, cells)
        after = _panorama(setup, cells, 1.0 - fraction[cells.rows, cells.cols])
        pictures.append((setup, before, after))
        entry: dict[str, Any] = {"x": setup.xy[0], "y": setup.xy[1]}
        for _, region in wanted:
            weights = (
                zenith_weights(before.shape[0], before.shape[1])
                if region is None
                else _region_weights(setup, region, weight)
            )
            values = {
                "before_cd_m2": float(np.nansum(weights * before)),
                "after_cd_m2": float(np.nansum(weights * after)),
            }
            values["before_mag_arcsec2"] = float(luminance_to_magnitude(values["before_cd_m2"]))
            values["after_mag_arcsec2"] = float(luminance_to_magnitude(values["after_cd_m2"]))
            if region is None:
                entry["zenith"] = values
            else:
                entry.setdefault("regions", []).append(
                    {"region": region.text, "weight": weight, **values}
                )
        entries.append(entry)
    figure = None
    if picture:
        setup, before, after = pictures[0]
        figure = (before, after, setup.slices[0].elevation)
    return {
        "flux_before_lm": total,
        "flux_removed_lm": removed,
        "flux_removed_percent": 100.0 * removed / total if total > 0 else 0.0,
        "lit_cells": int(_lit(raster.data).sum()),
        "dimmed_cells": int(np.sum(fraction > 0)),
        "observers": entries,
    }, figure


def _null_reason(key: str, value: float) -> str:
    """Why a figure of the summary is null in its JSON file."""
    if key.endswith("_mag_arcsec2") and value == math.inf:
        return (
            f"{key}: the luminance is 0 cd m-2 (no artificial light left), a sky brightness "
            "of +inf mag arcsec-2, which strict JSON cannot hold"
        )
    return non_finite_reason(key, value)


def _reduce_outputs(
    raster: Raster,
    fraction: FloatArray,
    summary: dict[str, Any],
    outputs: OutputSet,
    *,
    output: PathLike | None,
    dimming_output: PathLike | None,
    summary_output: PathLike | None,
    png: PathLike | None,
    picture: tuple[FloatArray, FloatArray, FloatArray] | None,
) -> ReduceResult:
    """The dimmed emission and the dimming raster; every asked output written together at
    the end (or none of them)."""
    lit = _lit(raster.data)
    reduced = Raster(
        raster.data * (1.0 - fraction)[None],
        raster.transform,
        raster.crs,
        raster.descriptions,
        raster.units,
        {
            **raster.tags,
            PRODUCT_TAG: "emission",
            "dimmed": "yes",
            "flux_removed_lm": f"{summary['flux_removed_lm']!r}",
        },
        raster.band_tags,
    )
    dimming = Raster(
        np.where(lit, fraction, np.nan)[None],
        raster.transform,
        raster.crs,
        ("dimming",),
        ("1",),
        {PRODUCT_TAG: "dimming", "meaning": "fraction of each cell's upward flux removed"},
    )
    if dimming_output is not None:  # relative to the summary: both move together
        summary["dimming_raster"] = (
            os.path.relpath(dimming_output, Path(summary_output).parent)
            if summary_output is not None
            else str(dimming_output)
        )
    with outputs:
        if output is not None:
            reduced.write(outputs.temporary(output))
        if dimming_output is not None:
            dimming.write(outputs.temporary(dimming_output))
        if summary_output is not None:
            text = dumps_json(summary, reason=_null_reason, indent=2)
            outputs.temporary(summary_output).write_text(text + "\n")
        if png is not None and picture is not None:
            from nightlights.inverse._figures import render_before_after

            render_before_after(*picture, outputs.temporary(png))
    path = Path(output) if output is not None else None
    return ReduceResult(reduced, dimming, summary, path)
