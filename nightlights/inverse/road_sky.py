"""Each luminaire's part of a sky target: the per-light sky matrix of a road dimming plan.

Skyglow is linear in the upward emission (Dobashi et al. 2023, Eqs. 13-14). The raster path
(:func:`~nightlights.inverse.least_dimming`) gives, for every lit cell :math:`c` of an
emission raster, its part :math:`C_{jc}` [cd m-2] of sky target :math:`j` (the zenith, or the
solid-angle-weighted mean of a sky region, at one observer) and its upward flux :math:`F_c`
[lm]. A luminaire :math:`k` in cell :math:`c(k)` emits upwards

.. math:: e_k = \\Phi^{\\uparrow}_k + \\rho\\, \\Phi^{\\downarrow}_k

(its direct uplight plus its downward flux reflected by ground of albedo :math:`\\rho`), and
its part of target :math:`j` at dimming :math:`\\delta_k` is taken as

.. math:: S_{jk}\\,\\delta_k, \\qquad S_{jk} = e_k\\, C_{j c(k)} / F_{c(k)} .

Modelling choices (the per-light approximation):

- the reflected light of a luminaire leaves the ground in the cell of its pole (it falls
  within a few mounting heights, small against a cell of 100 m or more);
- a luminaire takes its cell's luminance per lumen, i.e. the cell's mix of Lambertian
  (reflected) and direct-uplight flux: exact when the lights sharing a cell have the same
  mix of up- and downward flux, or are dimmed alike; for every dimming, the sum over the
  lights of a cell at full output is the cell's own part :math:`C_{jc}` when the emission
  raster holds just these lights (:func:`lights_emission`). The test of this module measures
  the error against the raster path with mixed systems sharing cells;
- what the scene's emission holds beyond the lights (other sources) stays:
  :math:`B_j - \\sum_k S_{jk}` is added to every plan's sky.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nightlights._typing import FloatArray
from nightlights.brightness import magnitude_to_luminance
from nightlights.errors import InputError
from nightlights.ground.luminaires import Luminaires
from nightlights.inverse._region import SkyRegion
from nightlights.inverse.stage import _panorama_value, _target_weights
from nightlights.io import Raster, as_raster
from nightlights.roads._plan import SkyMatrix
from nightlights.sky.influence import cell_values, region_table
from nightlights.sky.observer import Observer
from nightlights.sky.scene import Scene
from nightlights.sky.setup import prepare_scene

__all__ = ["ALBEDO", "lights_emission", "sky_matrix", "upward_emission"]

#: Ground albedo of the reflected uplight [1]: the value of the emission stage's examples
#: (``nightlights emission ... --albedo 0.1``), dry asphalt; the stage itself has no default.
ALBEDO = 0.1


def upward_emission(luminaires: Luminaires, albedo: float = ALBEDO) -> FloatArray:
    """:math:`e_k = \\Phi^{\\uparrow}_k + \\rho\\,\\Phi^{\\downarrow}_k` of every light [lm].

    Parameters
    ----------
    luminaires
        The lights.
    albedo
        Ground albedo :math:`\\rho` [1].
    """
    if not 0.0 <= albedo <= 1.0:
        raise InputError(f"albedo={albedo!r}; expected a reflectance in [0, 1]")
    return luminaires.upward_flux() + albedo * luminaires.downward_flux()


def _cells(luminaires: Luminaires, like: Raster) -> tuple[np.ndarray, np.ndarray]:
    col, row = ~like.transform @ (luminaires.light_point[:, 0], luminaires.light_point[:, 1])
    row, col = np.floor(row).astype(np.intp), np.floor(col).astype(np.intp)
    rows, cols = like.shape
    outside = (row < 0) | (col < 0) | (row >= rows) | (col >= cols)
    if outside.any():
        raise InputError(
            f"grid: {int(outside.sum())} lights (e.g. {luminaires.light_id[outside][:5].tolist()})"
            " fall outside the emission grid; expected a grid that holds every light"
        )
    return row, col


def lights_emission(
    luminaires: Luminaires,
    like: Raster,
    *,
    albedo: float = ALBEDO,
    dimming: FloatArray | None = None,
) -> Raster:
    """The lights' upward emission on a grid, each deposited in the cell of its pole.

    Two bands as the emission stage writes them: ``reflected`` (:math:`\\rho\\Phi^\\downarrow`,
    Lambertian) and ``uplight`` (:math:`\\Phi^\\uparrow`) [lm m-2].

    Parameters
    ----------
    luminaires
        The lights.
    like
        A raster whose grid (transform, shape, CRS) the emission takes.
    albedo
        Ground albedo [1].
    dimming
        Level of every light [1] (default 1).
    """
    upward_emission(luminaires, albedo)  # checks the albedo
    level = np.ones(len(luminaires)) if dimming is None else np.asarray(dimming, dtype=float)
    row, col = _cells(luminaires, like)
    data = np.zeros((2, *like.shape))
    area = abs(like.transform.a * like.transform.e)
    np.add.at(data[0], (row, col), albedo * luminaires.downward_flux() * level / area)
    np.add.at(data[1], (row, col), luminaires.upward_flux() * level / area)
    return Raster(data, like.transform, like.crs, ("reflected", "uplight"))


def sky_matrix(
    luminaires: Luminaires,
    scene: Scene,
    observers: Sequence[Observer],
    *,
    target_zenith: float | None = None,
    target_region: Sequence[tuple[str | SkyRegion, float]] = (),
    zenith_reduction: float | None = None,
    albedo: float = ALBEDO,
    progress: bool = False,
) -> SkyMatrix:
    """The sky targets of :func:`~nightlights.inverse.least_dimming` as a per-light matrix.

    Parameters
    ----------
    luminaires
        The lights, in the order of the plan (:attr:`~nightlights.roads.RoadModel.luminaires`).
    scene
        The emission raster (e.g. :func:`lights_emission`), kernel, terrain and atmosphere.
    observers
        Who must see the targets.
    target_zenith
        Zenith sky brightness every observer must reach [mag arcsec-2].
    target_region
        (region, brightness) pairs [deg, mag arcsec-2], as for ``least_dimming``.
    zenith_reduction
        Fraction by which the zenith luminance at every observer must fall [1], in (0, 1].
    albedo
        Ground albedo of the reflected uplight [1].
    progress
        Progress bar while building a kernel.

    Returns
    -------
    SkyMatrix
        The matrix, the sky now and the goals.
    """
    if target_zenith is None and not target_region and zenith_reduction is None:
        raise InputError("no sky target: give target_zenith, target_region and/or zenith_reduction")
    if zenith_reduction is not None and not 0.0 < zenith_reduction <= 1.0:
        raise InputError(f"zenith_reduction={zenith_reduction!r}; expected a fraction in (0, 1]")
    if not observers:
        raise InputError("observers=[]; expected at least one observer of the sky targets")
    raster = as_raster(scene.raster_input("road_plan"))
    dense = scene.replace(emission=raster)
    emitted = upward_emission(luminaires, albedo)
    row, col = _cells(luminaires, raster)
    targets: list[tuple[str, SkyRegion | None, float | None]] = []
    if target_zenith is not None:
        targets.append(("zenith", None, float(magnitude_to_luminance(target_zenith))))
    if zenith_reduction is not None:
        targets.append(("zenith", None, -float(zenith_reduction)))
    for given, mag in target_region:
        parsed = given if isinstance(given, SkyRegion) else SkyRegion.parse(given)
        targets.append(("region", parsed, float(magnitude_to_luminance(mag))))
    rows_s, before, goal, labels = [], [], [], []
    for index, observer in enumerate(observers):
        setup = prepare_scene(dense, observer, progress=progress)
        cells = setup.polar_cells()
        levels = setup.level_weights(cells)
        flux = cells.flux.sum(axis=0)
        per_lumen = np.zeros(raster.shape)
        where = f"observer {index + 1} ({setup.xy[0]:.1f}, {setup.xy[1]:.1f})"
        for kind, region, value in targets:
            weights = _target_weights(setup, kind, region)
            tables = [region_table(t, weights) for t in setup.slices]
            part = cell_values(cells, levels, tables)
            per_lumen[:] = 0.0
            per_lumen[cells.rows, cells.cols] = np.where(
                flux > 0, part / np.maximum(flux, 1e-300), 0
            )
            rows_s.append(emitted * per_lumen[row, col])
            now = _panorama_value(setup, cells, weights)
            before.append(now)
            assert value is not None
            goal.append(now * (1.0 + value) if value < 0 else value)
            text = region.text if region is not None else ""
            how = f" -{-value:g}" if value < 0 else ""
            labels.append(f"{kind}{' ' + text if text else ''}{how} at {where}")
    return SkyMatrix(
        np.asarray(rows_s).reshape(len(labels), len(luminaires)),
        np.asarray(before, dtype=float),
        np.asarray(goal, dtype=float),
        tuple(labels),
    )
