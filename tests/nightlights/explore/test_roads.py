"""Road compliance and the road plan in the explorer, against RoadModel.rate, road_plan and
skyglow called directly, through the session and its HTTP API; and the requests it refuses."""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from affine import Affine
from starlette.testclient import TestClient

from nightlights import roads
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import DataQualityWarning, InputError
from nightlights.explore import RoadOptions
from nightlights.explore._app import create_app
from nightlights.explore._session import ExploreSession
from nightlights.inverse.road_sky import lights_emission, sky_matrix
from nightlights.io import Raster
from nightlights.sky import Observer, Scene, skyglow
from nightlights.sky.store import write_kernel

#: The observer of the sky targets, among the streets [m] (EPSG:3067).
X, Y = 250.0, 50.0
#: Agreement of the per-light sky with skyglow on the dimmed lights' own emission: lights of
#: two systems share cells and are dimmed unlike (the per-light approximation) [1].
SKY_RTOL = 0.02


def _grid() -> Raster:
    return Raster(np.zeros((1, 8, 12)), Affine(100.0, 0, -300.0, 0, -100.0, 500.0), "EPSG:3067")


@pytest.fixture(scope="module")
def layers(road_plan_case: Any, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    lights, streets, table, model = road_plan_case
    folder = tmp_path_factory.mktemp("explore_roads")
    lights.to_file(folder / "lights.gpkg")
    streets.to_file(folder / "streets.gpkg")
    emission = lights_emission(model.luminaires, _grid())
    return {
        "lights": folder / "lights.gpkg",
        "streets": folder / "streets.gpkg",
        "table": table,
        "model": model,
        "emission": emission,
    }


def _session(
    layers: dict[str, Any], kernel: Any, emission: Any = None, **options: Any
) -> ExploreSession:
    options.setdefault("streets", layers["streets"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        return ExploreSession(
            Scene(layers["emission"] if emission is None else emission, kernel=kernel),
            lights=layers["lights"],
            road_options=RoadOptions(requirements=layers["table"]),
            height=0.0,
            progress=False,
            **options,
        )


def _statuses(rating: Any) -> list[str]:
    passed = rating["passed"]
    return [
        "not rated" if p is None or (isinstance(p, float) and np.isnan(p)) else
        ("pass" if p else "fail")
        for p in passed.astype(object).tolist()
    ]  # fmt: skip


def _share(streets: Any, status: list[str]) -> float:
    length = streets.geometry.length.to_numpy()
    rated = np.array([s != "not rated" for s in status])
    passed = np.array([s == "pass" for s in status])
    return float(length[passed].sum() / length[rated].sum())


def test_roads_are_rated_at_the_sessions_levels(layers: dict[str, Any], tiny_sky_kernel) -> None:
    session = _session(layers, tiny_sky_kernel)
    model = layers["model"]
    view = session.roads()
    expected = _statuses(model.rate(np.ones(len(model.luminaires))))
    assert list(view.segments["status"]) == expected == ["pass"] * 3
    assert view.summary.share == pytest.approx(1.0)
    # a brush that halves every cell halves every light: the segments fall below 60 % minima
    session.edit("scale", [(200.0, 100.0)], radius=2000.0, value=0.5)
    np.testing.assert_allclose(session.light_levels(), 0.5, rtol=1e-12)
    halved = model.rate(np.full(len(model.luminaires), 0.5))
    view = session.roads()
    assert list(view.segments["status"]) == _statuses(halved)
    assert "fail" in list(view.segments["status"])
    share = _share(model.segments, _statuses(halved))
    assert view.summary.share == pytest.approx(share, rel=1e-9)
    collection = view.to_geojson()
    assert len(collection["features"]) == len(model.segments)
    first = collection["features"][0]["properties"]
    assert set(first) >= {"lighting_class", "status", "binding", "binding_margin"}
    assert collection["summary"]["share_compliant"] == pytest.approx(share, abs=1e-6)
    session.undo()
    np.testing.assert_allclose(session.light_levels(), 1.0, rtol=1e-12)


def test_the_plan_meets_the_sky_and_keeps_the_roads(
    layers: dict[str, Any], tiny_sky_kernel
) -> None:
    session = _session(layers, tiny_sky_kernel)
    model = layers["model"]
    observer = Observer(X, Y, height=0.0)
    full = skyglow(Scene(layers["emission"], kernel=tiny_sky_kernel), observer).zenith_luminance
    magnitude = float(luminance_to_magnitude(0.7 * full))
    view = session.road_plan(X, Y, target_zenith=magnitude)
    assert view.plan.feasible and view.applied
    # the plan re-rated directly: every segment keeps its class
    assert _statuses(model.rate(view.plan.dimming)) == ["pass"] * 3
    assert view.after.summary.share == pytest.approx(1.0)
    np.testing.assert_allclose(session.light_levels(), view.plan.dimming, atol=1e-9)
    # the sky recomputed by skyglow from the dimmed lights' own emission meets the target
    dimmed = lights_emission(model.luminaires, _grid(), dimming=view.plan.dimming)
    after = skyglow(Scene(dimmed, kernel=tiny_sky_kernel), observer).zenith_luminance
    assert after == pytest.approx(view.sky_after, rel=SKY_RTOL)
    assert after <= 0.7 * full * (1 + SKY_RTOL)
    assert view.sky_before == pytest.approx(full, rel=1e-6)
    # the same plan from the CLI's path: sky_matrix on the lights' emission, road_plan
    sky = sky_matrix(
        model.luminaires,
        Scene(layers["emission"], kernel=tiny_sky_kernel),
        [observer],
        target_zenith=magnitude,
    )
    direct = roads.road_plan(model, sky)
    assert view.plan.cost == pytest.approx(direct.cost, rel=1e-3)
    assert view.plan.cost_sky_only == pytest.approx(direct.cost_sky_only, rel=1e-3)
    assert view.plan.cost_of_safety >= -1e-9
    # one edit: undo takes the plan back
    session.undo()
    np.testing.assert_allclose(session.emission(), session.emission("original"))
    np.testing.assert_allclose(session.light_levels(), 1.0)
    session.redo()
    np.testing.assert_allclose(session.light_levels(), view.plan.dimming, atol=1e-9)


def test_roads_only_and_infeasible_plans(layers: dict[str, Any], tiny_sky_kernel) -> None:
    session = _session(layers, tiny_sky_kernel)
    model = layers["model"]
    alone = session.road_plan(apply=False, hours=4000.0)
    direct = roads.road_plan(model, None)
    assert alone.plan.cost == pytest.approx(direct.cost, rel=1e-6)
    saved_kwh = (direct.cost_full - direct.cost) * 4000.0 / 1000.0  # [W] x [h] -> [kWh]
    assert alone.to_dict()["energy_saved_kwh"] == pytest.approx(saved_kwh, rel=1e-6)
    assert not alone.applied and not session.can_undo
    # a sky darker than the roads allow: no plan; the binding segments, nothing applied
    dark = float(luminance_to_magnitude(1e-3 * session.panorama(X, Y).zenith_luminance))
    view = session.road_plan(X, Y, target_zenith=dark)
    assert not view.plan.feasible and not view.applied and not session.can_undo
    assert len(view.plan.binding) >= 1
    assert set(view.to_dict()["binding"][0]) >= {"segment", "lighting_class", "slack"}


def test_roads_need_streets_and_lights(layers: dict[str, Any], tiny_sky_kernel) -> None:
    bare = ExploreSession(
        Scene(layers["emission"], kernel=tiny_sky_kernel), height=0.0, progress=False
    )
    with pytest.raises(InputError, match="streets"):
        bare.roads()
    with pytest.raises(InputError, match="streets"):
        bare.road_plan()
    with pytest.raises(InputError, match="lights="):
        ExploreSession(
            Scene(layers["emission"], kernel=tiny_sky_kernel),
            streets=layers["streets"],
            progress=False,
        )
    client = TestClient(create_app(bare, export_dir=Path(".")))
    for response in (client.get("/api/roads"), client.post("/api/road-plan", json={})):
        assert response.status_code == 409
        assert "street layer" in response.json()["error"]


def test_the_api_rates_plans_and_undoes(layers: dict[str, Any], tiny_sky_kernel, tmp_path) -> None:
    session = _session(layers, tiny_sky_kernel)
    client = TestClient(create_app(session, export_dir=tmp_path))
    assert client.get("/api/info").json()["has_streets"] is True
    collection = client.get("/api/roads").json()
    assert [f["properties"]["status"] for f in collection["features"]] == ["pass"] * 3
    zenith = session.panorama(X, Y).zenith_luminance
    body = {"x": X, "y": Y, "target": "zenith",
            "brightness": float(luminance_to_magnitude(0.7 * zenith))}  # fmt: skip
    result = client.post("/api/road-plan", json=body).json()
    assert result["feasible"] and result["applied"] and result["edit"]["can_undo"]
    assert result["sky"]["after_cd_m2"] <= 0.7 * zenith * (1 + SKY_RTOL)
    assert result["compliance_after"]["share_compliant"] == pytest.approx(1.0)
    model = layers["model"]
    assert result["cost_full"] == pytest.approx(roads.road_plan(model, None).cost_full, rel=1e-9)
    assert len(result["roads"]["features"]) == len(model.segments)
    assert client.post("/api/undo").status_code == 200
    np.testing.assert_allclose(session.light_levels(), 1.0)
    # bad requests
    bad = client.post("/api/road-plan", json={"target": "region", "x": X, "y": Y,
                                              "brightness": 21.0})  # fmt: skip
    assert bad.status_code == 400 and "region" in bad.json()["error"]
    bad = client.post("/api/road-plan", json={"hours": 10_000})
    assert bad.status_code == 400 and "hours" in bad.json()["error"]
    bad = client.post("/api/road-plan", json={"objective": "light"})
    assert bad.status_code == 400 and "objective" in bad.json()["error"]
    bad = client.post("/api/road-plan", json={"target": "zenith", "brightness": 21.0})
    assert bad.status_code == 400 and "x" in bad.json()["error"]
    unreachable = dict(body, min_dimming=1.0)
    assert client.post("/api/road-plan", json=unreachable).status_code == 422


def test_a_session_file_replays_brush_edits_and_plans(
    layers: dict[str, Any], tiny_sky_kernel, tmp_path: Path
) -> None:
    emission = layers["emission"].write(tmp_path / "emission.tif")
    kernel = tmp_path / "kernel.nc"
    write_kernel(tiny_sky_kernel.kernel, kernel)
    levels = np.random.default_rng(3).random(len(layers["model"].luminaires))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        session = ExploreSession(
            Scene(emission, kernel=kernel),
            lights=layers["lights"],
            streets=layers["streets"],
            height=0.0,
            progress=False,
        )
        session.edit("scale", [(200.0, 100.0)], radius=2000.0, value=0.5)
        session.apply_dimming(levels)
        session.edit("scale", [(200.0, 100.0)], radius=2000.0, value=0.5)
        saved = session.save(tmp_path / "session.json")
        reopened = ExploreSession.open(saved, progress=False)
    assert reopened.has_streets
    # the plan sets each light's level; the brush after it halves them all
    np.testing.assert_allclose(reopened.light_levels(), 0.5 * levels, rtol=1e-12)
    np.testing.assert_allclose(reopened.emission(), session.emission(), rtol=1e-12)
    reopened.undo()
    reopened.undo()
    np.testing.assert_allclose(reopened.light_levels(), 0.5, rtol=1e-12)
    with pytest.raises(InputError, match="dimming"):
        session.apply_dimming(levels[:-1])
    # the file keeps no road options: refused
    planned = _session(layers, kernel, emission)
    with pytest.raises(InputError, match="road_options"):
        planned.save(tmp_path / "planned.json")


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        ({"op": "road-plan", "dimming": [0.5, 2.0]}, "dimming [0.5, 2.0]"),
        ({"op": "road-plan", "dimming": []}, "dimming []"),
        ({"op": "road-plan"}, "dimming None"),
        ({"op": "road-plan", "dimming": [1.0], "radius": 3}, "unknown field 'radius'"),
    ],
)
def test_a_saved_plan_is_checked(edit: dict[str, Any], words: str) -> None:
    from nightlights.explore._edits import check_saved_edits

    with pytest.raises(InputError, match=re.escape(f"s.json: edit 1 of 1: {words}")):
        check_saved_edits([edit], "s.json")
