"""The explore web app, in process: every endpoint against the session's own numbers, the bad
requests, the files it refuses to serve or write, and two clients at once."""

from __future__ import annotations

import base64
import io
import json
import os
import re
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
import xarray as xr
from PIL import Image
from starlette.testclient import TestClient

from nightlights.explore._app import (
    LOOPBACK_NAMES,
    STATIC_DIR,
    browser_url,
    create_app,
    is_loopback,
    jsonable,
)
from nightlights.explore._render import raster_png

from .conftest import COLS, CRS, N_LIT, OBSERVER, ROWS, Scene

#: Relative agreement of the API's panorama with skyglow_panorama (the same computation) [1].
RTOL = 1e-6
X, Y = OBSERVER
#: A sky region across the south (azimuth, elevation) [deg].
REGION = [[150.0, 5.0], [210.0, 5.0], [210.0, 40.0], [150.0, 40.0]]


@pytest.fixture(scope="module")
def static_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A page folder: two pages, a link out of it, a file of an unknown type, a hidden file."""
    folder = tmp_path_factory.mktemp("static")
    (folder / "index.html").write_text("<!doctype html><title>explore</title>")
    (folder / "explore.js").write_text("console.log('explore');")
    outside = folder.parent / "secret.js"
    outside.write_text("secret")
    (folder / "link.js").symlink_to(outside)
    (folder / "notes.txt").write_text("not served")
    (folder / ".hidden.js").write_text("not served")
    return folder


@pytest.fixture(scope="module")
def export_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("exports")


@pytest.fixture(scope="module")
def client(shared_session: Any, export_dir: Path, static_dir: Path) -> Iterator[TestClient]:
    """A client of the module's read-only session."""
    app = create_app(shared_session, export_dir=export_dir, static_dir=static_dir)
    with TestClient(app) as test_client:
        yield test_client


@pytest.fixture
def fresh(make_session: Callable[..., Any], tmp_path: Path) -> Iterator[tuple[TestClient, Any]]:
    """A client of a fresh session (to edit) exporting into tmp_path/exports."""
    session = make_session()
    (tmp_path / "exports").mkdir()
    with TestClient(create_app(session, export_dir=tmp_path / "exports")) as test_client:
        yield test_client, session


def error_of(response: Any, status: int, *words: str) -> str:
    """The one-line error of ``response``, checked for ``status`` and ``words``."""
    assert response.status_code == status, response.text
    assert response.headers["content-type"] == "application/json"
    message = response.json()["error"]
    assert isinstance(message, str) and "\n" not in message
    for word in words:
        assert word in message, message
    return message


def decode_image(url: str) -> np.ndarray:
    assert url.startswith("data:image/png;base64,")
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))))


# --- reading -------------------------------------------------------------------------------


def test_info_describes_the_session(client: TestClient, shared_session: Any, scene: Scene) -> None:
    response = client.get("/api/info")
    assert response.status_code == 200
    assert response.headers["cache-control"] == "no-store"
    assert response.headers["x-content-type-options"] == "nosniff"
    info = response.json()
    assert info["crs"] == CRS
    assert "UTM zone 35N" in info["crs_wkt"]
    assert info["shape"] == [ROWS, COLS]
    assert info["bounds"] == pytest.approx(list(shared_session.bounds))
    assert info["cell_size"] == 20.0
    assert info["n_lit"] == N_LIT
    flux = scene.flux.sum() * 20.0 * 20.0  # [lm]
    assert info["total_flux_lm"] == pytest.approx(flux, rel=1e-6)  # float32 file
    assert info["elevation"] == pytest.approx(shared_session.elevation.tolist())
    assert info["azimuth"] == pytest.approx(shared_session.azimuth.tolist())
    assert info["kernel"] == jsonable(shared_session.kernel_info)
    assert (info["has_lights"], info["has_dem"], info["tiles"]) == (False, False, None)
    assert (info["edit_version"], info["can_undo"], info["can_redo"]) == (0, False, False)
    assert Path(info["export_dir"]).is_absolute()
    legend = info["emission_legend"]
    lit = scene.flux[scene.flux > 0]
    assert legend["vmin"] == pytest.approx(lit.min(), rel=1e-6)
    assert legend["vmax"] == pytest.approx(lit.max(), rel=1e-6)
    assert (legend["scale"], legend["cmap"], len(legend["colors"])) == ("log", "magma", 9)


def test_panorama_equals_skyglow_panorama(client: TestClient, scene: Scene) -> None:
    from nightlights.sky import Observer, skyglow_panorama
    from nightlights.sky import Scene as SkyScene

    expected = skyglow_panorama(
        SkyScene(scene.emission, kernel=scene.kernel), Observer(*OBSERVER), progress=False
    ).panorama
    response = client.get("/api/panorama", params={"x": X, "y": Y})
    assert response.status_code == 200
    view = response.json()
    np.testing.assert_allclose(view["luminance"], expected["luminance"].values, rtol=RTOL)
    np.testing.assert_allclose(view["elevation"], expected["elevation"].values, rtol=RTOL)
    np.testing.assert_allclose(view["azimuth"], expected["azimuth"].values, rtol=RTOL)
    zenith = expected.attrs["zenith_luminance_cd_m2"]
    assert view["zenith_luminance"] == pytest.approx(zenith, rel=RTOL)
    assert (view["x"], view["y"]) == (X, Y)


def test_panorama_at_a_position_in_another_crs(client: TestClient) -> None:
    from pyproj import Transformer

    lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(X, Y)
    there = client.get("/api/panorama", params={"x": lon, "y": lat, "crs": "EPSG:4326"}).json()
    here = client.get("/api/panorama", params={"x": X, "y": Y}).json()
    assert (there["x"], there["y"]) == pytest.approx((X, Y), abs=1e-6)
    np.testing.assert_allclose(there["luminance"], here["luminance"], rtol=1e-9)


def test_panorama_height_moves_the_eye(client: TestClient) -> None:
    low = client.get("/api/panorama", params={"x": X, "y": Y}).json()
    high = client.get("/api/panorama", params={"x": X, "y": Y, "height": 50}).json()
    assert high["observer_altitude"] == pytest.approx(low["observer_altitude"] + 48.3)
    # the kernel is tabulated for an eye at 0 m only: the page is told (this module's only
    # request at 50 m; the session warns when it first reads the tables for an altitude)
    assert "warnings" not in low
    (warning,) = high["warnings"]
    assert "outside the kernel's levels" in warning


def test_emission_png_shows_the_lit_cells(client: TestClient, scene: Scene) -> None:
    response = client.get("/api/emission.png", params={"which": "original", "v": 0})
    assert response.status_code == 200
    assert response.headers["content-type"] == "image/png"
    legend = json.loads(response.headers["x-legend"])
    image = np.asarray(Image.open(io.BytesIO(response.content)))
    assert image.shape == (ROWS, COLS, 4)
    np.testing.assert_array_equal(image[..., 3] > 0, scene.flux > 0)  # north up, unlit clear
    _, expected = raster_png(scene.flux, scale="log")
    assert legend["vmin"] == pytest.approx(expected["vmin"], rel=1e-6)
    current = client.get("/api/emission.png")
    assert current.status_code == 200 and current.content == response.content


def test_lights_are_a_geojson_of_points(
    make_session: Callable[..., Any], scene: Scene, tmp_path: Path
) -> None:
    import geopandas as gpd

    session = make_session(lights=scene.lights)
    with TestClient(create_app(session, export_dir=tmp_path)) as test_client:
        collection = test_client.get("/api/lights").json()
        assert test_client.get("/api/info").json()["has_lights"] is True
    expected = gpd.read_file(scene.lights)
    assert collection["type"] == "FeatureCollection"
    assert len(collection["features"]) == len(expected)
    coordinates = [f["geometry"]["coordinates"] for f in collection["features"]]
    np.testing.assert_allclose(coordinates, [[p.x, p.y] for p in expected.geometry])


def test_lights_without_a_layer_are_empty(client: TestClient) -> None:
    assert client.get("/api/lights").json() == {"type": "FeatureCollection", "features": []}


# --- the inverse -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "body",
    [
        {"kind": "q"},
        {"kind": "q", "metric": "zenith"},
        {"kind": "q", "metric": "hemisphere", "height": 10.0},
        {"kind": "s", "region": REGION},
    ],
    ids=["q-pca-norm", "q-zenith", "q-hemisphere", "s"],
)
def test_influence_is_the_sessions(client: TestClient, shared_session: Any, body: dict) -> None:
    response = client.post("/api/influence", json={"x": X, "y": Y, **body})
    assert response.status_code == 200, response.text
    result = response.json()
    options = {k: v for k, v in body.items() if k != "height"}
    view = shared_session.influence(X, Y, height=body.get("height"), **options)
    assert (result["kind"], result["metric"], result["unit"]) == (view.kind, view.metric, "cd m-2")
    assert result["total"] == pytest.approx(view.total, rel=1e-12)
    assert result["n_cells"] == N_LIT
    positive = view.values[view.values > 0]
    assert result["vmin"] == pytest.approx(positive.min(), rel=1e-12)
    assert result["vmax"] == pytest.approx(positive.max(), rel=1e-12)
    if view.metric == "pca-norm":
        assert result["panorama_value"] is None
    else:
        assert result["panorama_value"] == pytest.approx(view.panorama_value, rel=1e-12)
    image = decode_image(result["image"])
    assert image.shape == (ROWS, COLS, 4)
    np.testing.assert_array_equal(image[..., 3] > 0, view.grid > 0)
    assert result["legend"]["scale"] == "log"


def test_dim_is_the_sessions(client: TestClient, shared_session: Any) -> None:
    q = shared_session.influence(X, Y)
    qa, qb = np.quantile(q.values, [0.5, 0.9])
    params = {"qa": float(qa), "qb": float(qb), "gamma": 0.8}
    response = client.post("/api/dim", json={"x": X, "y": Y, **params})
    assert response.status_code == 200, response.text
    result = response.json()
    view = shared_session.dim(X, Y, **params)
    assert result["flux_removed_lm"] == pytest.approx(view.flux_removed, rel=1e-12)
    assert result["flux_removed_percent"] == pytest.approx(view.flux_removed_percent, rel=1e-12)
    assert 0 < result["flux_removed_percent"] < 100
    np.testing.assert_allclose(result["panorama"]["luminance"], view.panorama.luminance, rtol=1e-12)
    assert result["before"]["zenith_magnitude"] == pytest.approx(view.before.zenith_magnitude)
    assert result["panorama"]["zenith_magnitude"] > result["before"]["zenith_magnitude"]
    assert result["method"] == view.method
    fraction = decode_image(result["image"])
    np.testing.assert_array_equal(fraction[..., 3] > 0, np.isfinite(view.fraction))
    assert (result["legend"]["vmin"], result["legend"]["vmax"]) == (0.0, 1.0)
    without = client.post("/api/dim", json={"x": X, "y": Y, **params, "image": False}).json()
    assert "image" not in without and "legend" not in without


def test_dim_by_s_needs_a_region(client: TestClient) -> None:
    body = {"x": X, "y": Y, "by": "s", "qa": 0.0, "qb": 1.0, "gamma": 0.5}
    error_of(client.post("/api/dim", json=body), 400, "region")
    response = client.post("/api/dim", json={**body, "region": REGION})
    assert response.status_code == 200, response.text


def test_least_dimming_meets_the_target(client: TestClient) -> None:
    before = client.get("/api/panorama", params={"x": X, "y": Y}).json()["zenith_magnitude"]
    target = before + 0.3  # [mag arcsec-2], darker
    body = {"x": X, "y": Y, "target": "zenith", "brightness": target}
    response = client.post("/api/least-dimming", json=body)
    assert response.status_code == 200, response.text
    result = response.json()
    assert result["panorama"]["zenith_magnitude"] >= target - 1e-6
    assert result["before"]["zenith_magnitude"] == pytest.approx(before)
    assert 0 < result["flux_removed_percent"] < 100
    assert isinstance(result["method"], str)


def test_least_dimming_of_a_region(client: TestClient) -> None:
    body = {"x": X, "y": Y, "target": "region", "brightness": 25.0, "region": REGION}
    response = client.post("/api/least-dimming", json=body)
    assert response.status_code in (200, 422), response.text
    error_of(client.post("/api/least-dimming", json={**body, "region": None}), 400, "region")


def test_an_unreachable_target_is_422(client: TestClient) -> None:
    body = {"x": X, "y": Y, "target": "zenith", "brightness": 30.0, "max_dimming": 0.01}
    error_of(client.post("/api/least-dimming", json=body), 422)


# --- edits, undo, redo ------------------------------------------------------------------------


def test_edit_undo_redo_round_trip(fresh: tuple[TestClient, Any], scene: Scene) -> None:
    client, session = fresh
    original = client.get("/api/info").json()
    centre = [X, Y]
    response = client.post(
        "/api/edit", json={"op": "paint", "points": [centre], "radius": 50.0, "value": 10.0}
    )
    assert response.status_code == 200, response.text
    painted = response.json()
    assert painted["edit_version"] == session.edit_version == 1
    assert painted["changed_cells"] > 0
    assert painted["total_flux"] == pytest.approx(session.total_flux)
    assert painted["total_flux"] > original["total_flux_lm"]
    assert (painted["can_undo"], painted["can_redo"]) == (True, False)
    png_painted = client.get("/api/emission.png", params={"v": 1}).content
    erased = client.post("/api/edit", json={"op": "erase", "points": [centre], "radius": 50.0})
    assert erased.json()["total_flux"] < painted["total_flux"]
    undone = client.post("/api/undo").json()
    assert undone["total_flux"] == pytest.approx(painted["total_flux"])
    assert client.get("/api/emission.png", params={"v": 3}).content == png_painted
    client.post("/api/undo")
    info = client.get("/api/info").json()
    assert info["total_flux_lm"] == pytest.approx(original["total_flux_lm"])
    assert (info["can_undo"], info["can_redo"]) == (False, True)
    error_of(client.post("/api/undo"), 409, "nothing to undo")
    redone = client.post("/api/redo").json()
    assert redone["total_flux"] == pytest.approx(painted["total_flux"])
    client.post("/api/redo")
    error_of(client.post("/api/redo"), 409, "nothing to redo")
    scaled = client.post(
        "/api/edit",
        json={
            "op": "scale",
            "points": [[X - 500, Y + 300], [X + 500, Y + 300]],
            "radius": 40,
            "value": 0.5,
        },
    ).json()
    assert scaled["total_flux"] < erased.json()["total_flux"]


def test_panorama_follows_the_edits(fresh: tuple[TestClient, Any]) -> None:
    client, _ = fresh
    before = client.get("/api/panorama", params={"x": X, "y": Y}).json()
    client.post("/api/edit", json={"op": "erase", "points": [[X, Y]], "radius": 400.0})
    after = client.get("/api/panorama", params={"x": X, "y": Y}).json()
    original = client.get("/api/panorama", params={"x": X, "y": Y, "which": "original"}).json()
    assert after["zenith_luminance"] < before["zenith_luminance"]
    assert original["luminance"] == before["luminance"]


# --- exports -------------------------------------------------------------------------------


def test_export_emission_is_the_edited_emission(fresh: tuple[TestClient, Any]) -> None:
    client, session = fresh
    client.post("/api/edit", json={"op": "scale", "points": [[X, Y]], "radius": 300, "value": 2})
    response = client.post("/api/export", json={"what": "emission", "name": "edited.tif"})
    assert response.status_code == 200, response.text
    (path,) = response.json()["files"]
    assert Path(path).is_absolute() and Path(path).name == "edited.tif"
    with rasterio.open(path) as dataset:
        written = dataset.read().sum(axis=0)
        assert dataset.crs.to_epsg() == 32635
    expected = session.emission("current")
    np.testing.assert_allclose(np.nan_to_num(written), np.nan_to_num(expected), rtol=1e-6)
    error_of(client.post("/api/export", json={"what": "emission", "name": "edited.tif"}), 409)
    again = {"what": "emission", "name": "edited.tif", "overwrite": True}
    assert client.post("/api/export", json=again).status_code == 200


def test_export_dimming_is_the_dimming(fresh: tuple[TestClient, Any]) -> None:
    client, session = fresh
    params = {"x": X, "y": Y, "qa": 0.0, "qb": 1e-9, "gamma": 0.5}
    response = client.post("/api/export", json={"what": "dimming", "name": "dim.tif", **params})
    assert response.status_code == 200, response.text
    (path,) = response.json()["files"]
    with rasterio.open(path) as dataset:
        written = dataset.read(1)
    view = session.dim(X, Y, qa=0.0, qb=1e-9, gamma=0.5)
    np.testing.assert_allclose(written, view.fraction, rtol=1e-6)
    least = {"x": X, "y": Y, "target": "zenith", "brightness": 40.0, "max_dimming": 0.1}
    error_of(client.post("/api/export", json={"what": "dimming", "name": "l.tif", **least}), 422)
    assert not (Path(path).parent / "l.tif").exists()


def test_export_panorama_writes_both_files(fresh: tuple[TestClient, Any]) -> None:
    client, _ = fresh
    body = {"what": "panorama", "name": "pano", "x": X, "y": Y}
    response = client.post("/api/export", json=body)
    assert response.status_code == 200, response.text
    files = sorted(Path(f) for f in response.json()["files"])
    assert [f.name for f in files] == ["pano.nc", "pano.png"]
    shown = client.get("/api/panorama", params={"x": X, "y": Y}).json()
    with xr.open_dataset(files[0]) as dataset:
        np.testing.assert_allclose(dataset["luminance"].values, shown["luminance"], rtol=1e-5)
    assert Image.open(files[1]).size[0] > 0
    only_png = client.post("/api/export", json={**body, "name": "sky.png"})
    assert [Path(f).name for f in only_png.json()["files"]] == ["sky.png"]
    error_of(client.post("/api/export", json=body), 409, "pano")


def test_export_session_reopens(fresh: tuple[TestClient, Any]) -> None:
    from nightlights.explore._session import ExploreSession

    client, session = fresh
    client.post("/api/edit", json={"op": "erase", "points": [[X, Y]], "radius": 100.0})
    body = {"what": "session", "name": "s.json", "x": X, "y": Y}
    response = client.post("/api/export", json=body)
    assert response.status_code == 200, response.text
    (path,) = response.json()["files"]
    reopened = ExploreSession.open(path, progress=False)
    assert reopened.total_flux == pytest.approx(session.total_flux)
    assert reopened.n_lit == session.n_lit


@pytest.mark.parametrize(
    "name",
    [
        "../x.tif",
        "/etc/passwd",
        "a/b.tif",
        "a\\b.tif",
        ".hidden.tif",
        "a..b.tif",
        "..",
        "",
        "x.tif\x00.png",
        "%2e%2e%2fx.tif",
        "x" * 130 + ".tif",
        "emission.TIFF",
        "emission.png",
    ],
)
def test_export_names_are_plain_file_names(client: TestClient, name: str) -> None:
    error_of(client.post("/api/export", json={"what": "emission", "name": name}), 400, "name")


def test_export_refuses_a_link_in_the_export_folder(
    fresh: tuple[TestClient, Any], tmp_path: Path
) -> None:
    client, _ = fresh
    victim = tmp_path / "victim.tif"
    victim.write_text("keep")
    (tmp_path / "exports" / "link.tif").symlink_to(victim)
    body = {"what": "emission", "name": "link.tif", "overwrite": True}
    error_of(client.post("/api/export", json=body), 400, "link")
    assert victim.read_text() == "keep"
    assert (tmp_path / "exports" / "link.tif").is_symlink()


# --- the page ------------------------------------------------------------------------------


def test_page_and_static_files(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "explore" in page.text
    script = client.get("/static/explore.js")
    assert script.headers["content-type"].startswith("text/javascript")
    assert script.text == "console.log('explore');"
    for name in ("link.js", "notes.txt", ".hidden.js", "missing.js", "index.html/x"):
        error_of(client.get(f"/static/{name}"), 404)


@pytest.mark.parametrize(
    "path",
    [
        "/static/../_app.py",
        "/static/%2e%2e/_app.py",
        "/static/%2E%2E%2F_app.py",
        "/static/..%2f..%2f_app.py",
        "/static/%2e%2e%5c_app.py",
        "/static//etc/passwd",
        "/static/%2fetc%2fpasswd",
        "/static/....//_app.py",
        "/static/link.js%00.js",
    ],
)
def test_static_paths_never_leave_the_whitelist(client: TestClient, path: str) -> None:
    response = client.get(path)
    assert response.status_code == 404
    assert "def create_app" not in response.text and "root:" not in response.text


def test_no_page_folder_is_a_one_line_404(shared_session: Any, tmp_path: Path) -> None:
    app = create_app(shared_session, export_dir=tmp_path, static_dir=tmp_path / "nothing")
    with TestClient(app) as test_client:
        error_of(test_client.get("/"), 404, "page is not installed")
        assert test_client.get("/api/info").status_code == 200


#: A static import or re-export of one of the page's own modules: ``... from "./name.js";``.
MODULE_IMPORT = re.compile(
    r'^(?:import|export)\s*(?:\{[^}]*\}|\*(?:\s+as\s+\w+)?|\w+)\s*from\s*"\./([^"]+)";', re.M
)


def test_the_shipped_page_serves_its_module_graph_as_javascript(
    shared_session: Any, tmp_path: Path
) -> None:
    # The page is one graph of ES modules rooted at explore.js. A browser runs a module only
    # when it comes with a JavaScript type, and the whitelist holds the folder's plain files.
    app = create_app(shared_session, export_dir=tmp_path)
    with TestClient(app) as test_client:
        page = test_client.get("/")
        assert '<script type="module" src="static/explore.js"></script>' in page.text
        reached: set[str] = set()
        waiting = ["explore.js"]
        while waiting:
            name = waiting.pop()
            if name in reached:
                continue
            reached.add(name)
            response = test_client.get(f"/static/{name}")
            assert response.status_code == 200, name
            assert response.headers["content-type"].startswith("text/javascript"), name
            waiting.extend(MODULE_IMPORT.findall(response.text))
    # every module ships and is reached from the entry
    assert reached == {path.name for path in STATIC_DIR.glob("*.js")}
    assert {"api.js", "map.js", "sky.js", "inverse.js"} <= reached


# --- bad requests --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("method", "path", "payload", "status", "words"),
    [
        ("GET", "/api/panorama", {"y": Y}, 400, ["x", "missing"]),
        ("GET", "/api/panorama", {"x": "nan", "y": Y}, 400, ["x=nan", "finite"]),
        ("GET", "/api/panorama", {"x": "inf", "y": Y}, 400, ["x=inf"]),
        ("GET", "/api/panorama", {"x": "east", "y": Y}, 400, ["x='east'"]),
        ("GET", "/api/panorama", {"x": X, "y": Y, "which": "old"}, 400, ["which"]),
        ("GET", "/api/panorama", {"x": X, "y": Y, "height": -5}, 400, ["height"]),
        ("GET", "/api/panorama", {"x": X, "y": Y, "crs": "EPSG:99999"}, 400, []),
        ("GET", "/api/panorama", {"x": X, "y": Y, "zoom": 3}, 400, ["unknown field 'zoom'"]),
        ("GET", "/api/emission.png", {"which": "both"}, 400, ["which"]),
        ("POST", "/api/influence", {"x": X, "y": Y, "kind": "z"}, 400, ["kind", "q, s"]),
        ("POST", "/api/influence", {"x": X, "y": Y, "metric": "max"}, 400, ["metric"]),
        ("POST", "/api/influence", {"y": Y}, 400, ["x", "missing"]),
        ("POST", "/api/influence", {"x": True, "y": Y}, 400, ["x=true"]),
        ("POST", "/api/influence", {"x": "1", "y": Y}, 400, ['x="1"']),
        (
            "POST",
            "/api/influence",
            {"x": X, "y": Y, "kind": "s", "region": REGION[:2]},
            400,
            ["region", "3"],
        ),
        (
            "POST",
            "/api/influence",
            {"x": X, "y": Y, "kind": "s", "region": [[0, 5], [90, 5], [180, "up"]]},
            400,
            ["region[2]"],
        ),
        ("POST", "/api/influence", {"x": X, "y": Y, "kind": "s"}, 400, ["region"]),
        ("POST", "/api/influence", {"x": 9e6, "y": Y}, 400, []),
        ("POST", "/api/dim", {"x": X, "y": Y, "qa": 0, "qb": 1}, 400, ["gamma", "missing"]),
        ("POST", "/api/dim", {"x": X, "y": Y, "qa": 1, "qb": 0, "gamma": 0.5}, 400, []),
        (
            "POST",
            "/api/dim",
            {"x": X, "y": Y, "target": "zenith", "brightness": 22},
            400,
            ["least-dimming"],
        ),
        ("POST", "/api/least-dimming", {"x": X, "y": Y, "brightness": 22}, 400, ["target"]),
        (
            "POST",
            "/api/least-dimming",
            {"x": X, "y": Y, "target": "zenith"},
            400,
            ["brightness", "missing"],
        ),
        ("POST", "/api/edit", {"op": "burn", "points": [[X, Y]], "radius": 5}, 400, ["op"]),
        ("POST", "/api/edit", {"op": "erase", "points": [], "radius": 5}, 400, ["points"]),
        ("POST", "/api/edit", {"op": "erase", "points": [[X]], "radius": 5}, 400, ["points[0]"]),
        ("POST", "/api/edit", {"op": "erase", "points": [[X, Y]], "radius": -5}, 400, []),
        ("POST", "/api/edit", {"op": "paint", "points": [[X, Y]], "radius": 5}, 400, []),
        ("POST", "/api/export", {"what": "nothing", "name": "a.tif"}, 400, ["what"]),
        ("POST", "/api/export", {"what": "emission"}, 400, ["name", "missing"]),
        ("POST", "/api/export", {"what": "session", "name": "s.tif"}, 400, [".json"]),
        ("GET", "/api/nothing", None, 404, ["/api/nothing", "not found"]),
        ("GET", "/nothing.html", None, 404, []),
        ("GET", "/api/edit", None, 405, ["GET", "POST"]),
        ("POST", "/api/info", {}, 405, ["POST"]),
        ("DELETE", "/api/panorama", None, 405, []),
        ("PUT", "/api/export", {}, 405, []),
    ],
)
def test_bad_requests(
    client: TestClient, method: str, path: str, payload: Any, status: int, words: list[str]
) -> None:
    if method == "GET":
        response = client.get(path, params=payload)
    else:
        response = client.request(method, path, json=payload)
    error_of(response, status, *words)


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"{", ["not JSON"]),
        (b"[1, 2]", ["list", "object"]),
        (b'{"x": NaN, "y": 1}', ["NaN"]),
        (b'{"x": Infinity, "y": 1}', ["Infinity"]),
        (b'{"x": 1e400, "y": 1}', ["x=inf", "finite"]),
        (b"\xff\xfe", ["not JSON"]),
        (b"[" * 100_000 + b"]" * 100_000, []),
        # integers beyond a float: the field named, the digits counted (was HTTP 500)
        (b'{"x": ' + b"9" * 400 + b', "y": 1}', ["x=99999", "(400 digits)", "finite"]),
        (b'{"x": 1, "y": -' + b"9" * 400 + b"}", ["y=-9999", "(401 digits)"]),
        (
            b'{"x": 1, "y": 1, "region": [[0, 5], [90, 5], [' + b"9" * 400 + b", 5]]}",
            ["region[2]", "finite"],
        ),
        (b'{"x": ' + b"9" * 5000 + b', "y": 1}', ["not JSON"]),
    ],
    ids=[
        "truncated",
        "array",
        "nan",
        "infinity",
        "overflow",
        "binary",
        "deep",
        "int-400-digits",
        "negative-int-400-digits",
        "int-in-a-pair",
        "int-5000-digits",
    ],
)
def test_bodies_that_are_not_json_objects(
    client: TestClient, content: bytes, words: list[str]
) -> None:
    response = client.post("/api/influence", content=content)
    error_of(response, 400, *words)


def test_a_body_over_the_limit_is_413(shared_session: Any, tmp_path: Path) -> None:
    app = create_app(shared_session, export_dir=tmp_path, max_body=1000)
    with TestClient(app) as test_client:
        points = [[X, Y]] * 200
        big = json.dumps({"op": "erase", "points": points, "radius": 1.0}).encode()
        assert len(big) > 1000
        error_of(test_client.post("/api/edit", content=big), 413, "1000")

        def chunks() -> Iterator[bytes]:  # no Content-Length: counted as it arrives
            for start in range(0, len(big), 100):
                yield big[start : start + 100]

        error_of(test_client.post("/api/edit", content=chunks()), 413)
        huge = {"content-length": "9" * 5000}  # int() of it would raise: was HTTP 500
        error_of(test_client.post("/api/edit", content=big, headers=huge), 413, "(5000 digits)")
        lying = {"content-length": "10"}
        response = test_client.post("/api/edit", content=big, headers=lying)
        assert response.status_code in (400, 413)
    assert shared_session.edit_version == 0


def test_the_default_limit_is_one_mebibyte(client: TestClient) -> None:
    body = b'{"x": 1, "y": 2, "pad": "' + b" " * (1 << 20) + b'"}'
    error_of(client.post("/api/influence", content=body), 413)


# --- the guard -----------------------------------------------------------------------------


def test_cross_origin_posts_are_refused(fresh: tuple[TestClient, Any]) -> None:
    client, session = fresh
    stroke = {"op": "erase", "points": [[X, Y]], "radius": 300.0}
    for origin in ("http://evil.example", "null", "http://testserver.evil.example"):
        error_of(client.post("/api/edit", json=stroke, headers={"origin": origin}), 403, "origin")
    assert session.edit_version == 0
    same = client.post("/api/edit", json=stroke, headers={"origin": "http://testserver"})
    assert same.status_code == 200
    assert client.get("/api/info", headers={"origin": "http://evil.example"}).status_code == 200


def test_a_loopback_server_answers_only_loopback_names(shared_session: Any, tmp_path: Path) -> None:
    app = create_app(shared_session, export_dir=tmp_path, allowed_hosts=LOOPBACK_NAMES)
    with TestClient(app, base_url="http://127.0.0.1:8765") as test_client:
        assert test_client.get("/api/info").status_code == 200
        for host in ("localhost:8765", "[::1]:8765", "LOCALHOST"):
            assert test_client.get("/api/info", headers={"host": host}).status_code == 200
        for host in ("attacker.example:8765", "127.0.0.1.attacker.example", ""):
            error_of(test_client.get("/api/info", headers={"host": host}), 403, "host")


def test_addresses() -> None:
    assert all(map(is_loopback, ["127.0.0.1", "localhost", "::1", "[::1]", "127.0.0.2"]))
    assert not any(map(is_loopback, ["0.0.0.0", "::", "192.168.1.2", "example.org"]))
    assert browser_url("0.0.0.0", 80) == "http://127.0.0.1:80/"
    assert browser_url("::", 8765) == "http://[::1]:8765/"
    assert browser_url("localhost", 1) == "http://localhost:1/"


# --- two clients at once -------------------------------------------------------------------


def test_two_clients_at_once(fresh: tuple[TestClient, Any]) -> None:
    """Two tabs: panoramas stay right while the other edits, the engine is never entered
    twice at once, and every edit counts."""
    client, session = fresh
    active, overlaps = [0], []
    guard = threading.Lock()

    def exclusive(method: Callable[..., Any]) -> Callable[..., Any]:
        def wrapped(*args: Any, **kwargs: Any) -> Any:
            with guard:
                active[0] += 1
                if active[0] > 1:
                    overlaps.append(method.__name__)
            try:
                time.sleep(0.002)  # widen the window for an overlap
                return method(*args, **kwargs)
            finally:
                with guard:
                    active[0] -= 1

        return wrapped

    for name in ("panorama", "edit", "influence"):
        setattr(session, name, exclusive(getattr(session, name)))
    expected = client.get("/api/panorama", params={"x": X, "y": Y, "which": "original"}).json()
    errors: list[str] = []

    def viewer() -> None:
        with TestClient(client.app) as tab:
            for _ in range(8):
                query = {"x": X, "y": Y, "which": "original"}
                view = tab.get("/api/panorama", params=query).json()
                if view["luminance"] != expected["luminance"]:
                    errors.append("panorama changed")
                if tab.post("/api/influence", json={"x": X, "y": Y}).status_code != 200:
                    errors.append("influence failed")

    def editor() -> None:
        with TestClient(client.app) as tab:
            for i in range(8):
                stroke = {"op": "scale", "points": [[X + 10 * i, Y]], "radius": 60, "value": 0.9}
                if tab.post("/api/edit", json=stroke).status_code != 200:
                    errors.append("edit failed")

    threads = [threading.Thread(target=viewer), threading.Thread(target=editor)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert errors == [] and overlaps == []
    assert client.get("/api/info").json()["edit_version"] == session.edit_version == 8


def test_jsonable() -> None:
    value = {"a": np.array([1.0, np.nan, np.inf]), "b": np.float32(2.5), "c": (np.int64(3),)}
    assert jsonable(value) == {"a": [1.0, None, None], "b": 2.5, "c": [3]}
    assert jsonable(Path("/x")) == "/x" and jsonable(float("nan")) is None


@pytest.fixture(autouse=True)
def _no_stray_files(export_dir: Path) -> Iterator[None]:
    """Nothing a test of the read-only client does writes into its export folder."""
    before = set(os.listdir(export_dir))
    yield
    assert set(os.listdir(export_dir)) == before


# --- raster_png ----------------------------------------------------------------------------


def png_pixels(png: bytes) -> np.ndarray:
    image = Image.open(io.BytesIO(png))
    assert image.mode == "RGBA"
    return np.asarray(image)


def test_raster_png_log_scale() -> None:
    grid = np.array([[1.0, 10.0, 100.0], [0.0, -1.0, np.nan]])
    png, legend = raster_png(grid)
    pixels = png_pixels(png)
    assert pixels.shape == (2, 3, 4)
    np.testing.assert_array_equal(pixels[..., 3], [[255, 255, 255], [0, 0, 0]])
    assert (legend["vmin"], legend["vmax"], legend["block"], legend["reduction"]) == (
        1.0,
        100.0,
        1,
        "max",
    )
    assert len(legend["colors"]) == 9 and all(
        re.fullmatch(r"#[0-9a-f]{6}", c) for c in legend["colors"]
    )
    # the ends of the scale are the legend's end colours, the middle value its middle stop
    hexes = ["#{:02x}{:02x}{:02x}".format(*p[:3]) for p in pixels[0].tolist()]
    assert (hexes[0], hexes[1], hexes[2]) == (
        legend["colors"][0],
        legend["colors"][4],
        legend["colors"][-1],
    )


def test_raster_png_linear_scale_and_limits() -> None:
    grid = np.array([[0.0, 0.5, 1.0, 2.0, np.nan]])
    png, legend = raster_png(grid, scale="linear", cmap="viridis", vmin=0.0, vmax=1.0)
    pixels = png_pixels(png)
    np.testing.assert_array_equal(pixels[0, :, 3], [255, 255, 255, 255, 0])  # 0 is shown
    np.testing.assert_array_equal(pixels[0, 2], pixels[0, 3])  # clipped at vmax
    assert (legend["vmin"], legend["vmax"], legend["cmap"]) == (0.0, 1.0, "viridis")


def test_raster_png_keeps_a_bright_cell_when_reduced() -> None:
    grid = np.full((10, 2500), np.nan)
    grid[4, 1234] = 5.0
    grid[0, 0] = 1.0
    png, legend = raster_png(grid, max_size=1024)
    pixels = png_pixels(png)
    assert legend["block"] == 3 and pixels.shape == (4, 834, 4)
    shown = np.argwhere(pixels[..., 3] > 0).tolist()
    assert shown == [[0, 0], [1, 411]]  # 4 // 3, 1234 // 3


def test_raster_png_of_nothing_is_transparent() -> None:
    png, legend = raster_png(np.zeros((3, 3)))
    assert (png_pixels(png)[..., 3] == 0).all()
    assert legend["vmin"] is None and legend["vmax"] is None


@pytest.mark.parametrize(
    ("grid", "options", "words"),
    [
        (np.ones(3), {}, ["(3,)"]),
        (np.ones((0, 3)), {}, ["(0, 3)"]),
        (np.ones((2, 2)), {"scale": "sqrt"}, ["sqrt"]),
        (np.ones((2, 2)), {"cmap": "no-such-map"}, ["no-such-map"]),
        (np.ones((2, 2)), {"vmin": 0.0}, ["vmin=0.0", "> 0"]),
        (np.ones((2, 2)), {"vmax": float("nan")}, ["vmax=nan"]),
        (np.ones((2, 2)), {"vmin": 2.0, "vmax": 1.0}, ["vmin=2.0 > vmax=1.0"]),
        (np.ones((2, 2)), {"max_size": 0}, ["max_size=0"]),
    ],
)
def test_raster_png_refuses(grid: np.ndarray, options: dict, words: list[str]) -> None:
    from nightlights.errors import InputError

    with pytest.raises(InputError) as raised:
        raster_png(grid, **options)
    for word in words:
        assert word in str(raised.value)
