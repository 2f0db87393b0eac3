"""The explore page in a real browser: headless Chromium driven by Selenium.

One walk through the page against the real app served by uvicorn: place the observer, compare
the zenith brightness shown with the API's, drag the observer, draw a sky region, dim by its S
map, paint and undo, export the emission. The latencies the page records are printed (run with
``-s``), not asserted: performance targets are checked by the benchmarks.

With ``NIGHTLIGHTS_SCREENSHOTS=<folder>`` the walk saves ``explore_overview.png``,
``explore_region.png`` and ``explore_dimming.png`` there; with ``NIGHTLIGHTS_EXPLORE_SESSION=
<session file>`` it explores that session instead of the small synthetic scene.
"""

from __future__ import annotations

import contextlib
import json
import os
import threading
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from affine import Affine

pytest.importorskip("selenium", reason="selenium is not installed")
uvicorn = pytest.importorskip("uvicorn", reason="uvicorn is not installed")

from selenium import webdriver  # noqa: E402
from selenium.common.exceptions import WebDriverException  # noqa: E402
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.remote.webelement import WebElement  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")

if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
    pytest.skip(
        f"the browser test needs Chromium at {CHROMIUM} and its driver at {CHROMEDRIVER}",
        allow_module_level=True,
    )

#: Window of the walk [CSS px]: the layout's design size.
WINDOW = (1400, 900)
#: Longest wait for the page to answer one action [s].
WAIT = 15.0


# --- the scene and the server --------------------------------------------------------------


def _synthetic_session(folder: Path) -> Any:
    """A 48 x 48 scene of 100 m cells: a town of 5 lm m-2 at its peak and scattered lights,
    with a small kernel (8 km) and a light layer of one point per lit cell, all on disk."""
    import geopandas as gpd
    from affine import Affine
    from pyproj import CRS
    from shapely import points

    from nightlights.explore._session import ExploreSession
    from nightlights.io import Raster
    from nightlights.sky import KernelSpec, Scene, build_kernel

    n = 48
    rng = np.random.default_rng(7)
    rows, cols = np.mgrid[0:n, 0:n]
    distance = np.hypot(cols - 30, rows - 20)  # [cells]
    flux = np.where(distance < 6, 5.0 * np.exp(-distance / 3), 0.0)  # [lm m-2]
    flux[rng.random((n, n)) < 0.05] += 0.3
    transform = Affine(100.0, 0.0, 500_000.0, 0.0, -100.0, 6_704_800.0)
    lit_rows, lit_cols = np.nonzero(flux > 0)
    x = transform.c + (lit_cols + 0.5) * transform.a  # cell centres [m]
    y = transform.f + (lit_rows + 0.5) * transform.e
    lights = folder / "lights.gpkg"
    gpd.GeoDataFrame(geometry=points(np.column_stack([x, y])), crs="EPSG:32635").to_file(lights)
    spec = KernelSpec(r_max=8000.0, n_distance=16, n_elevation=16, n_azimuth=64)
    kernel = build_kernel(spec, folder / "kernel.nc", progress=False).path
    emission = Raster(flux[None], transform, CRS.from_epsg(32635)).write(folder / "emission.tif")
    # from files, so that the session file can name them
    return ExploreSession(Scene(emission, kernel=kernel), lights=lights, progress=False)


@contextlib.contextmanager
def _serving(session: Any, export_dir: Path) -> Iterator[str]:
    """The app of ``session`` on a free loopback port in a background thread: its URL."""
    from nightlights.explore._app import LOOPBACK_NAMES, bind, create_app

    app = create_app(session, export_dir=export_dir, allowed_hosts=LOOPBACK_NAMES)
    sock = bind("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = uvicorn.Server(
        uvicorn.Config(app, log_config=None, log_level="warning", access_log=False, lifespan="off")
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + WAIT
    while not server.started:
        if time.monotonic() > deadline or not thread.is_alive():
            pytest.fail("the explore app did not start")
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{port}/"
    finally:
        server.should_exit = True
        thread.join(WAIT)
        sock.close()


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """The app on a free loopback port in a background thread: (its URL, the export folder)."""
    from nightlights.explore._session import ExploreSession

    folder = tmp_path_factory.mktemp("explore_browser")
    given = os.environ.get("NIGHTLIGHTS_EXPLORE_SESSION")
    session = ExploreSession.open(given, progress=False) if given else _synthetic_session(folder)
    export_dir = folder / "exports"
    export_dir.mkdir()
    with _serving(session, export_dir) as url:
        yield url, export_dir


@pytest.fixture(scope="module")
def browser() -> Iterator[webdriver.Chrome]:
    """Headless Chromium at the layout's design size, its console log kept."""
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in (
        "--headless=new",
        f"--window-size={WINDOW[0]},{WINDOW[1]}",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--force-device-scale-factor=1",
    ):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    except WebDriverException as exc:
        pytest.skip(f"Chromium did not start: {exc.msg or exc}".splitlines()[0])
    try:
        # the viewport itself (the window size includes the browser's frame)
        driver.execute_cdp_cmd(
            "Emulation.setDeviceMetricsOverride",
            {"width": WINDOW[0], "height": WINDOW[1], "deviceScaleFactor": 1, "mobile": False},
        )
        yield driver
    finally:
        driver.quit()


# --- helpers -------------------------------------------------------------------------------


def _get_json(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=WAIT) as response:
        return json.load(response)


def _wait(driver: webdriver.Chrome, condition: Callable[[], Any], what: str) -> Any:
    """Poll ``condition`` until it is truthy; fail naming ``what`` and the page's status."""

    def check(_: Any) -> Any:
        return condition()

    try:
        return WebDriverWait(driver, WAIT, poll_frequency=0.05).until(check)
    except Exception:
        status = driver.find_element(By.ID, "status").text
        pytest.fail(f"waiting for {what}: the page's status line reads {status!r}")


def _timings(driver: webdriver.Chrome) -> list[dict[str, Any]]:
    return driver.execute_script("return window.__exploreTimings.slice()")


def _text(driver: webdriver.Chrome, element_id: str) -> str:
    return driver.find_element(By.ID, element_id).text


def _observer(driver: webdriver.Chrome) -> tuple[float, float]:
    canvas = driver.find_element(By.ID, "map")
    return (
        float(canvas.get_attribute("data-observer-x") or "nan"),
        float(canvas.get_attribute("data-observer-y") or "nan"),
    )


def _click_at(driver: webdriver.Chrome, element: WebElement, dx: float, dy: float) -> None:
    """Click ``element`` at (dx, dy) CSS px from its centre."""
    ActionChains(driver).move_to_element_with_offset(element, int(dx), int(dy)).click().perform()


def _export(driver: webdriver.Chrome, what: str) -> list[str]:
    """Click an export button; the paths the page then lists."""
    driver.execute_script("document.getElementById('export-files').replaceChildren()")
    driver.find_element(By.CSS_SELECTOR, f'button[data-export="{what}"]').click()
    return sorted(
        _wait(
            driver,
            lambda: [
                item.text for item in driver.find_elements(By.CSS_SELECTOR, "#export-files li")
            ],
            f"the {what} export",
        )
    )


def _screenshot(driver: webdriver.Chrome, name: str) -> None:
    folder = os.environ.get("NIGHTLIGHTS_SCREENSHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(Path(folder) / name))


# --- the walk ------------------------------------------------------------------------------


def test_walk_through_the_page(browser: webdriver.Chrome, served: tuple[str, Path]) -> None:
    url, export_dir = served
    driver = browser
    driver.get(url)
    _wait(driver, lambda: driver.execute_script("return document.body.dataset.ready"), "ready")
    info = _get_json(url + "api/info")
    map_canvas = driver.find_element(By.ID, "map")

    # Place the observer: the panorama's numbers are the API's for that point.
    _click_at(driver, map_canvas, -40, 30)
    _wait(driver, lambda: len(_timings(driver)) >= 1, "the first panorama")
    x, y = _observer(driver)
    left, bottom, right, top = info["bounds"]
    assert left < x < right and bottom < y < top
    expected = _get_json(f"{url}api/panorama?x={x!r}&y={y!r}")
    assert float(_text(driver, "zenith-mag")) == pytest.approx(
        expected["zenith_magnitude"], abs=0.01
    )
    assert _text(driver, "bortle") == str(expected["bortle"])
    assert float(_text(driver, "latency-ms")) >= 0
    _wait(driver, lambda: not driver.find_element(By.ID, "qa").get_attribute("disabled"), "Q map")
    _screenshot(driver, "explore_overview.png")

    # Drag the observer marker: the panorama follows and ends at the released position.
    before_drag = len(_timings(driver))
    drag = ActionChains(driver).move_to_element_with_offset(map_canvas, -40, 30).click_and_hold()
    for _ in range(8):
        drag.move_by_offset(12, -6).pause(0.03)
    drag.release().perform()
    _wait(driver, lambda: _observer(driver)[0] > x, "the observer to move")
    moved = _observer(driver)
    _wait(
        driver,
        lambda: (
            driver.execute_script("return document.getElementById('sky-label').textContent")
            and len(_timings(driver)) > before_drag
            and abs(
                float(_text(driver, "zenith-mag"))
                - _get_json(f"{url}api/panorama?x={moved[0]!r}&y={moved[1]!r}")["zenith_magnitude"]
            )
            <= 0.01
        ),
        "the panorama at the released position",
    )

    # Draw a region on the equirectangular panorama and close it on its first vertex.
    panorama = driver.find_element(By.ID, "pano-eq")
    width = panorama.size["width"]
    height = panorama.size["height"]
    corners = [(-0.3, 0.3), (0.1, 0.3), (0.1, -0.2), (-0.3, -0.2), (-0.3, 0.3)]
    for fx, fy in corners:
        _click_at(driver, panorama, fx * width, fy * height)
        time.sleep(0.35)  # apart enough not to be a double click
    overlay = driver.find_element(By.ID, "overlay")
    _wait(driver, lambda: overlay.get_attribute("value") == "s", "the S map")
    qa = driver.find_element(By.ID, "qa")
    _wait(driver, lambda: not qa.get_attribute("disabled"), "the S slider range")
    _screenshot(driver, "explore_region.png")

    # Move Q_a down: the dimmed sky, the flux removed and on release the dimming map.
    qa.click()
    for _ in range(5):
        qa.send_keys(Keys.ARROW_LEFT)
    _wait(
        driver,
        lambda: (
            float(driver.find_element(By.ID, "flux-removed").get_attribute("data-value") or 0) > 0
        ),
        "the flux removed",
    )
    _wait(driver, lambda: overlay.get_attribute("value") == "dimming", "the dimming map")
    assert "lm" in _text(driver, "flux-removed")
    _screenshot(driver, "explore_dimming.png")

    # The least-flux dimming: a reachable zenith target is met; an unreachable one is the
    # server's one-line 422 reason on the status line.
    undimmed = _get_json(f"{url}api/panorama?x={moved[0]!r}&y={moved[1]!r}")["zenith_magnitude"]
    target = round(undimmed + 0.3, 2)
    driver.find_element(By.CSS_SELECTOR, '#target option[value="zenith"]').click()
    for element_id, value in (("target-mag", f"{target:.2f}"), ("max-dimming", "1")):
        field = driver.find_element(By.ID, element_id)
        field.clear()
        field.send_keys(value)
    driver.find_element(By.ID, "solve").click()
    _wait(driver, lambda: _text(driver, "status").startswith("least-flux"), "the dimming")
    assert float(_text(driver, "zenith-mag")) >= target - 0.01
    field = driver.find_element(By.ID, "max-dimming")
    field.clear()
    field.send_keys("0.001")
    driver.find_element(By.ID, "solve").click()
    status = driver.find_element(By.ID, "status")
    _wait(driver, lambda: "error" in (status.get_attribute("class") or ""), "the 422 reason")
    assert status.text and "\n" not in status.text

    # The dimming on show (the least-flux one) exports as a COG.
    assert _export(driver, "dimming") == [str((export_dir / "explore-dimming.tif").resolve())]
    assert (export_dir / "explore-dimming.tif").is_file()

    # Paint a stroke, then undo it with Ctrl+Z.
    driver.find_element(By.CSS_SELECTOR, 'input[name="tool"][value="paint"]').click()
    paint = driver.find_element(By.ID, "paint-value")
    paint.clear()
    paint.send_keys("2")
    stroke = ActionChains(driver).move_to_element_with_offset(map_canvas, 60, -60).click_and_hold()
    for _ in range(4):
        stroke.move_by_offset(10, 5).pause(0.02)
    stroke.release().perform()
    _wait(driver, lambda: _get_json(url + "api/info")["edit_version"] == 1, "the edit")
    edited = _get_json(url + "api/info")
    assert edited["can_undo"] and edited["total_flux_lm"] != info["total_flux_lm"]
    _wait(driver, lambda: driver.find_element(By.ID, "undo").is_enabled(), "the undo button")
    ActionChains(driver).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
    _wait(driver, lambda: _get_json(url + "api/info")["edit_version"] == 2, "the undo")
    undone = _get_json(url + "api/info")
    assert not undone["can_undo"] and undone["can_redo"]
    assert undone["total_flux_lm"] == pytest.approx(info["total_flux_lm"], rel=1e-12)
    _wait(driver, lambda: driver.find_element(By.ID, "redo").is_enabled(), "the redo button")

    # Export the emission, the panorama and the session: the page lists the written paths.
    for what, names in (
        ("emission", ["explore-emission.tif"]),
        ("panorama", ["explore-panorama.nc", "explore-panorama.png"]),
        ("session", ["explore-session.json"]),
    ):
        assert _export(driver, what) == [str((export_dir / name).resolve()) for name in names]
    assert all((export_dir / name).is_file() for name in os.listdir(export_dir))

    # No script errors on the way.
    errors = [
        entry["message"]
        for entry in driver.get_log("browser")
        if entry["level"] == "SEVERE" and "Failed to load resource" not in entry["message"]
    ]
    assert errors == []

    timings = _timings(driver)
    for kind in sorted({t["kind"] for t in timings}):
        rows = [t for t in timings if t["kind"] == kind]
        median = {
            part: float(np.nanmedian([t[part] for t in rows]))
            for part in ("ms", "queue_ms", "request_ms", "draw_ms", "server_ms")
        }
        print(
            f"explore page {kind}: {len(rows)} updates, event to canvas median "
            f"{median['ms']:.1f} ms (max {max(t['ms'] for t in rows):.1f}): queued "
            f"{median['queue_ms']:.1f}, request {median['request_ms']:.1f} (engine "
            f"{median['server_ms']:.1f}), drawing {median['draw_ms']:.1f} ms"
        )


def test_road_compliance_and_the_plan(
    browser: webdriver.Chrome, road_plan_case: Any, tiny_sky_kernel: Any, tmp_path: Path
) -> None:
    """The road layer and the plan button on a session with streets: the share the page shows
    is the API's, and the plan it applies is one edit that Undo takes back."""
    import warnings

    from nightlights.errors import DataQualityWarning
    from nightlights.explore import RoadOptions
    from nightlights.explore._session import ExploreSession
    from nightlights.inverse.road_sky import lights_emission
    from nightlights.io import Raster
    from nightlights.sky import Scene

    lights, streets, table, model = road_plan_case
    lights.to_file(tmp_path / "lights.gpkg")
    streets.to_file(tmp_path / "streets.gpkg")
    grid = Raster(np.zeros((1, 8, 12)), Affine(100.0, 0, -300.0, 0, -100.0, 500.0), "EPSG:3067")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        session = ExploreSession(
            Scene(lights_emission(model.luminaires, grid), kernel=tiny_sky_kernel),
            lights=tmp_path / "lights.gpkg",
            streets=tmp_path / "streets.gpkg",
            road_options=RoadOptions(requirements=table),
            progress=False,
        )
    driver = browser
    with _serving(session, tmp_path) as url:
        driver.get(url)
        _wait(driver, lambda: driver.execute_script("return document.body.dataset.ready"), "ready")
        assert driver.find_element(By.ID, "show-roads").is_selected()
        share = _get_json(url + "api/roads")["summary"]["share_compliant"]
        _wait(driver, lambda: _text(driver, "roads-share") == f"{100 * share:.1f} %", "the share")
        driver.find_element(By.ID, "road-sky").click()  # the road minima alone: no observer
        driver.find_element(By.ID, "road-plan").click()
        _wait(driver, lambda: "Applied" in _text(driver, "road-plan-result"), "the plan")
        assert session.can_undo and not driver.find_element(By.ID, "undo").get_attribute("disabled")
        driver.find_element(By.ID, "undo").click()
        _wait(driver, lambda: not session.can_undo, "the undo")
    errors = [
        entry["message"]
        for entry in driver.get_log("browser")
        if entry["level"] == "SEVERE" and "Failed to load resource" not in entry["message"]
    ]
    assert errors == []
