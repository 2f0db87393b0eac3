"""Interactive latency of ``nightlights explore``: a new observer, a slider move, the page.

Scene: a 2000 x 2000 raster of 10 m cells with 1e5 lit cells clustered like a city (the
generator of ``bench_inverse_qs.py``), two emission bands (Lambertian + 10 % uplight). Kernel:
Dobashi's panorama grid (64 elevations x 256 azimuths), 64 distance bins from 10 m to the
raster's diagonal, one observer and one source level, with the uplight table, and 128 PCA
bases (every image: the PCA is exact to float precision). The observer is dragged along a path
of 40 positions across the raster.

1. A new observer -> a new panorama, on the server (:meth:`ExploreSession.panorama`): median
   and 95th percentile over the path, against the number of PCA bases used (the knob: 8-128),
   with the error of the panorama against the exact (no-PCA) panorama of the stage
   (``skyglow_panorama(mode="exact")``): the largest relative error over the pixels above 1 %
   of the brightest. Also the polar map alone, compiled scatter against the numpy reference
   (``lit_polar_cells`` + ``level_maps``), the PCA panorama (Eqs. 7-9) alone with the stored
   bases and with 128 (on random tables of the kernel's shape: the kernel's PCA is exact with
   fewer), and the stage's whole in-memory call for the same observer (what a panorama cost
   before the engine). Target: <= 20 ms with 128 bases.
2. A slider move -> the dimmed panorama (:meth:`ExploreSession.dim`, Eq. 12 on Q, the Q map
   already computed): median over 40 moves. Target: <= 30 ms.
3. The HTTP round trip of ``GET /api/panorama`` from the app served on loopback (the JSON
   included), median.
4. In the browser (when Chromium, chromedriver and selenium are there): the time from a click
   on the map to the panorama drawn, read from the page's Performance API timings, median over
   20 clicks. Target: <= 100 ms.

Run: ``python benchmarks/bench_explore_latency.py [--quick] [--out DIR]`` (``--quick``: a
1000 x 1000 raster with 25 000 lit cells, a 32 x 128 kernel, 10 positions, no browser).
Writes ``explore_latency.json`` and ``.png`` (see ``_harness.py`` for where).
Timings come from a shared 2-core machine and are noisy.
"""

from __future__ import annotations

import math
import statistics
import threading
import time
from typing import Any

import _harness as harness
import numpy as np
import xarray as xr
from bench_inverse_qs import city

from nightlights.explore import ExploreSession
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene
from nightlights.sky._polar_numba import polar_flux_levels
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.panorama import KernelSlice, panorama_pca
from nightlights.sky.polar import PolarMap, level_maps, lit_polar_cells
from nightlights.sky.store import get_or_build_kernel

CELL = 10.0  # [m]
BASES = (8, 16, 32, 64, 128)
TARGET_OBSERVER_S = 0.020
TARGET_SLIDER_S = 0.030
TARGET_PAGE_S = 0.100


def kernel(side: int, quick: bool) -> xr.Dataset:
    n_el, n_az = (32, 128) if quick else (64, 256)
    spec = KernelSpec(
        r_min=10.0,
        r_max=1.01 * side * CELL * math.sqrt(2),
        n_distance=64,
        n_elevation=n_el,
        n_azimuth=n_az,
        observer_altitudes=(1.7,),
        uplight=True,
        n_components=128,
    )
    return get_or_build_kernel(spec, progress=False).kernel


def path(side: int, count: int) -> list[tuple[float, float]]:
    """A drag across the raster: a loop through the city and the countryside [m]."""
    t = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    half = side * CELL / 2
    return [
        (half + 0.6 * half * math.cos(a) + 3.7, half + 0.45 * half * math.sin(2 * a) + 1.3)
        for a in t
    ]


def relative_error(luminance: np.ndarray, exact: np.ndarray) -> float:
    bright = exact > 0.01 * np.nanmax(exact)
    return float(np.max(np.abs(luminance[bright] - exact[bright]) / exact[bright]))


def observer_rows(
    raster: Raster, table: xr.Dataset, positions: list[tuple[float, float]], stored: int
) -> list[dict[str, Any]]:
    """Section 1: time and error against the bases used."""
    exact = {
        xy: skyglow_panorama(
            Scene(raster, kernel=table), Observer(*xy), mode="exact", progress=False
        )
        .panorama["luminance"]
        .values
        for xy in positions[:: max(1, len(positions) // 8)]
    }
    rows = []
    for bases in sorted({b for b in BASES if b < stored} | {stored}):
        session = ExploreSession(Scene(raster, kernel=table), components=bases, progress=False)
        session.panorama(*positions[0])  # compile and read the kernel levels
        times = []
        for xy in positions:
            start = time.perf_counter()
            session.panorama(*xy)
            times.append(time.perf_counter() - start)
        errors = [relative_error(session.panorama(*xy).luminance, ref) for xy, ref in exact.items()]
        rows.append(
            {
                "bases": bases,
                "median_s": statistics.median(times),
                "p95_s": float(np.percentile(times, 95)),
                "max_relative_error": max(errors),
            }
        )
        print(rows[-1], flush=True)
    return rows


def polar_times(
    raster: Raster, table: xr.Dataset, positions: list[tuple[float, float]]
) -> dict[str, float]:
    """The polar map alone: compiled scatter against the numpy reference, median [s]."""
    cells = raster.lit_cells()
    edges = table["distance_edges"].values
    n_az = table.sizes["azimuth"]
    flux = np.nan_to_num(cells.values) * CELL * CELL
    weights = np.ones((1, cells.n_cells))

    def compiled(xy: tuple[float, float]) -> None:
        polar_flux_levels(
            cells.rows, cells.cols, flux, weights, raster.transform, xy,
            distance_edges=edges, n_az=n_az,
        )  # fmt: skip

    def reference(xy: tuple[float, float]) -> None:
        split = lit_polar_cells(
            cells.rows, cells.cols, cells.values, raster.transform, xy,
            distance_edges=edges, n_az=n_az,
        )  # fmt: skip
        level_maps(split, weights)

    compiled(positions[0])
    out = {}
    for name, call in (("compiled", compiled), ("numpy", reference)):
        times = [harness.timed(lambda xy=xy, c=call: c(xy))[1] for xy in positions]
        out[f"polar_{name}_s"] = statistics.median(times)
    return out


def pca_time(table: xr.Dataset, bases: int) -> float:
    """Eqs. 7-9 alone with ``bases`` bases on the kernel's grid, median [s]: the kernel's PCA
    reaches float precision with fewer bases than 128, so the cost of 128 is measured on
    random tables of the same shape (the values do not change the arithmetic)."""
    rng = np.random.default_rng(0)
    n_r, n_el, n_az = table.sizes["distance"], table.sizes["elevation"], table.sizes["azimuth"]
    tables = KernelSlice(
        kernel=np.zeros((2, n_r, n_el, 0)),
        coefficient=rng.random((2, n_r, bases)),
        basis_fft=rng.random((bases, n_el, n_az // 2 + 1)) + 0j,
        distance_edges=table["distance_edges"].values,
        elevation=table["elevation"].values,
    )
    polar = PolarMap(rng.random((2, n_r, n_az)), tables.distance_edges, n_az, np.zeros(2),
                     np.zeros(2))  # fmt: skip
    panorama_pca(polar, tables)
    return statistics.median(
        harness.timed(lambda: panorama_pca(polar, tables))[1] for _ in range(20)
    )


def stage_time(raster: Raster, table: xr.Dataset, positions: list[tuple[float, float]]) -> float:
    """The stage's in-memory panorama for one observer (checks, lit cells, polar map, PCA)."""
    times = [
        harness.timed(
            lambda xy=xy: skyglow_panorama(
                Scene(raster, kernel=table), Observer(*xy), progress=False
            )
        )[1]
        for xy in positions[:5]
    ]
    return statistics.median(times)


def slider_time(session: ExploreSession, xy: tuple[float, float], moves: int) -> dict[str, float]:
    """Section 2: dimmed panoramas as Q_b slides, the Q map computed once."""
    q = session.influence(*xy, kind="q", metric="pca-norm")
    low, high = np.nanpercentile(q.values, [50, 99.9])
    first = harness.timed(lambda: session.dim(*xy, by="q", qa=low, qb=high, gamma=0.8))[1]
    times = []
    for qb in np.linspace(low * 1.01, high, moves):
        start = time.perf_counter()
        session.dim(*xy, by="q", qa=float(low), qb=float(qb), gamma=0.8)
        times.append(time.perf_counter() - start)
    return {"slider_median_s": statistics.median(times), "slider_first_s": first}


def serve(session: ExploreSession) -> tuple[Any, threading.Thread, int]:
    """The app on a free loopback port, in a background thread."""
    import socket

    import uvicorn

    from nightlights.explore import create_app

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = uvicorn.Server(
        uvicorn.Config(create_app(session, export_dir="."), port=port, log_level="error")
    )
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    return server, thread, port


def http_time(session: ExploreSession, positions: list[tuple[float, float]]) -> float:
    """Section 3: ``GET /api/panorama`` from a real server on loopback, JSON included, over
    one kept-alive connection, median [s]."""
    import http.client
    from urllib.parse import urlencode

    server, thread, port = serve(session)
    connection = http.client.HTTPConnection("127.0.0.1", port)
    try:
        times = []
        for x, y in positions:
            start = time.perf_counter()
            # a position the session has not seen (its caches would answer at once)
            query = urlencode({"x": x + 0.37, "y": y - 0.21})
            connection.request("GET", "/api/panorama?" + query)
            response = connection.getresponse()
            body = response.read()
            if response.status != 200:
                raise RuntimeError(body.decode())
            times.append(time.perf_counter() - start)
    finally:
        connection.close()
        server.should_exit = True
        thread.join(timeout=10)
    return statistics.median(times)


def browser_time(session: ExploreSession, clicks: int) -> dict[str, Any] | None:
    """Section 4: click on the map -> panorama drawn, from the page's timings [s]."""
    import shutil

    chromium, driver_path = shutil.which("chromium"), shutil.which("chromedriver")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None
    if chromium is None or driver_path is None:
        return None
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    server, thread, port = serve(session)
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--window-size=1400,900"):
        options.add_argument(flag)
    driver = webdriver.Chrome(options=options, service=Service(driver_path))
    try:
        driver.get(f"http://127.0.0.1:{port}/")
        time.sleep(2.0)
        canvas = driver.find_element(By.CSS_SELECTOR, "#map canvas, canvas#map")
        width, height = canvas.size["width"], canvas.size["height"]
        rng = np.random.default_rng(0)
        for _ in range(clicks):
            dx = int(rng.uniform(-0.3, 0.3) * width)
            dy = int(rng.uniform(-0.3, 0.3) * height)
            ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click().perform()
            time.sleep(0.4)
        timings = driver.execute_script("return window.__exploreTimings || []")
    finally:
        driver.quit()
        server.should_exit = True
        thread.join(timeout=10)
    # one record per update: its kind, the time from the event to the canvas drawn and its
    # parts (queue, request, server, drawing) [ms]
    panoramas = [t for t in timings if t.get("kind") == "panorama"][-clicks:]
    values = [float(t["ms"]) / 1000.0 for t in panoramas]
    if not values:
        return None
    parts = {
        f"page_{name.removesuffix('_ms')}_median_s": statistics.median(
            float(t[name]) for t in panoramas
        )
        / 1000.0
        for name in ("queue_ms", "request_ms", "server_ms", "draw_ms")
        if all(t.get(name) is not None for t in panoramas)
    }
    return {
        "page_median_s": statistics.median(values),
        "page_p95_s": float(np.percentile(values, 95)),
        "page_samples": len(values),
        **parts,
    }


def plot(document: dict[str, Any]) -> Any:
    plt = harness.pyplot()
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    rows = document["observer"]
    bases = [r["bases"] for r in rows]
    left.plot(
        [1e3 * r["median_s"] for r in rows],
        [r["max_relative_error"] for r in rows],
        "o-",
        label="new observer (median)",
    )
    for r in rows:
        left.annotate(f"{r['bases']}", (1e3 * r["median_s"], r["max_relative_error"]),
                      textcoords="offset points", xytext=(4, 4))  # fmt: skip
    left.axvline(1e3 * TARGET_OBSERVER_S, color="grey", ls="--", label="target 20 ms")
    left.set_xlabel("time per new observer [ms]")
    left.set_ylabel("max relative error vs exact panorama")
    left.set_yscale("log")
    left.set_title(f"PCA bases used ({min(bases)}-{max(bases)})")
    left.legend()
    figures = document["figures"]
    names = [
        ("polar map, numpy", figures["polar_numpy_s"]),
        ("polar map, compiled", figures["polar_compiled_s"]),
        (f"PCA, {document['scene']['bases_stored']} bases", figures["pca_stored_s"]),
        ("PCA, 128 bases", figures["pca_128_s"]),
        ("stage call (before)", figures["stage_s"]),
        ("new observer", rows[-1]["median_s"]),
        ("slider move", figures["slider_median_s"]),
        ("HTTP round trip", figures["http_median_s"]),
    ]
    if figures.get("page_median_s") is not None:
        names.append(("click -> drawn (page)", figures["page_median_s"]))
    right.barh([n for n, _ in names], [1e3 * v for _, v in names], color="tab:blue")
    right.axvline(1e3 * TARGET_OBSERVER_S, color="grey", ls="--")
    right.axvline(1e3 * TARGET_SLIDER_S, color="grey", ls=":")
    right.axvline(1e3 * TARGET_PAGE_S, color="grey", ls="-.")
    right.set_xscale("log")
    right.set_xlabel("median time [ms] (lines: 20, 30, 100 ms targets)")
    right.set_title(f"{document['scene']['lit_cells']} lit cells, {document['scene']['side']}^2")
    figure.tight_layout()
    return figure


def main() -> None:
    parser = harness.argument_parser(
        __doc__, quick="1000 x 1000, 25 000 lit cells, 32 x 128 kernel, 10 positions, no browser"
    )
    args = harness.parse_args(parser)
    side, lit, count = (1000, 25_000, 10) if args.quick else (2000, 100_000, 40)
    raster = city(side, n_lit=lit)
    table = kernel(side, args.quick)
    stored = int(table.sizes["component"])
    positions = path(side, count)
    rows = observer_rows(raster, table, positions, stored)
    session = ExploreSession(Scene(raster, kernel=table), progress=False)
    figures: dict[str, Any] = {
        **polar_times(raster, table, positions),
        "stage_s": stage_time(raster, table, positions),
        "pca_stored_s": pca_time(table, stored),
        "pca_128_s": pca_time(table, 128),
        **slider_time(session, positions[0], count),
        "http_median_s": http_time(session, positions),
    }
    if not args.quick:
        page = browser_time(session, 20)
        figures.update(page or {"page_median_s": None})
    print(figures, flush=True)
    harness.write_results(
        args.out,
        "explore_latency",
        {
            "scene": {
                "side": side,
                "lit_cells": lit,
                "cell_m": CELL,
                "positions": count,
                "bases_stored": stored,
            },
            "targets_s": {
                "observer": TARGET_OBSERVER_S,
                "slider": TARGET_SLIDER_S,
                "page": TARGET_PAGE_S,
            },
            "observer": rows,
            "figures": figures,
        },
        quick=args.quick,
        plot=plot,
    )


if __name__ == "__main__":
    main()
