"""The per-light sky matrix of a road plan (nightlights.inverse.road_sky) against the raster
path: the sky recomputed by ``skyglow`` from the dimmed lights' emission, and bad targets."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from affine import Affine

from nightlights import roads
from nightlights.errors import DataQualityWarning, InputError
from nightlights.inverse.road_sky import lights_emission, sky_matrix
from nightlights.io import Raster
from nightlights.sky import Observer, Scene, skyglow

OBSERVER = Observer(250.0, 50.0)


def _grid() -> Raster:
    return Raster(np.zeros((1, 8, 12)), Affine(100.0, 0, -300.0, 0, -100.0, 500.0), "EPSG:3067")


def test_the_sky_targets_hold_when_the_sky_is_recomputed(road_plan_case, tiny_sky_kernel) -> None:
    lights, streets, table, model = road_plan_case
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=tiny_sky_kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.3)
    before = skyglow(scene, OBSERVER).zenith_luminance
    assert sky.before[0] == pytest.approx(before, rel=1e-6)
    plan = roads.road_plan(model, sky)
    assert plan.feasible
    dimmed = Scene(
        lights_emission(model.luminaires, _grid(), dimming=plan.dimming), kernel=tiny_sky_kernel
    )
    after = skyglow(dimmed, OBSERVER).zenith_luminance
    # per-light approximation against the raster path: lights of two systems share cells
    assert after == pytest.approx(plan.sky["after_cd_m2"].iloc[0], rel=0.02)
    assert after <= 0.7 * before * 1.02
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        audited = roads.audit(lights, streets, requirements=table, dimming=plan.dimming)
    assert bool(audited.segments["status"].eq("pass").all())
    # the sky-only plan is never more costly than the joint one
    assert plan.cost_sky_only <= plan.cost + 1e-9 and plan.cost_of_safety >= -1e-9


def test_per_light_sky_matches_the_raster_path_for_random_dimmings(
    road_plan_case, tiny_sky_kernel
) -> None:
    model = road_plan_case[3]
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=tiny_sky_kernel)
    sky = sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=0.5)
    rng = np.random.default_rng(4)
    for _ in range(3):
        delta = rng.random(len(model.luminaires))
        dimmed = Scene(
            lights_emission(model.luminaires, _grid(), dimming=delta), kernel=tiny_sky_kernel
        )
        raster_path = skyglow(dimmed, OBSERVER).zenith_luminance
        assert sky.after(delta)[0] == pytest.approx(raster_path, rel=0.02)


def test_bad_sky_targets_are_refused(road_plan_case, tiny_sky_kernel) -> None:
    model = road_plan_case[3]
    scene = Scene(lights_emission(model.luminaires, _grid()), kernel=tiny_sky_kernel)
    with pytest.raises(InputError, match="zenith_reduction"):
        sky_matrix(model.luminaires, scene, [OBSERVER], zenith_reduction=1.5)
    with pytest.raises(InputError, match="no sky target"):
        sky_matrix(model.luminaires, scene, [OBSERVER])
    with pytest.raises(InputError, match="observers"):
        sky_matrix(model.luminaires, scene, [], zenith_reduction=0.5)
