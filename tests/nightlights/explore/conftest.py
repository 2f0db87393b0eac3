"""Fixtures of the explore tests: a small scene on disk and explore sessions of it.

The scene is a 60 x 60 emission raster at 20 m (EPSG:32635) with 300 lit cells and a tiny kernel
(8 distances, 8 x 16 panorama), so that a session opens and answers in a fraction of a second.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from shapely.geometry import Point

#: Emission grid: rows, cols, cell size [m], top-left corner [m] (EPSG:32635).
ROWS, COLS, CELL = 60, 60, 20.0
LEFT, TOP = 500_000.0, 6_700_000.0
CRS = "EPSG:32635"
#: Lit cells of the scene [1].
N_LIT = 300
#: An observer inside the scene, off the lit cells' grid centres [m].
OBSERVER = (LEFT + 603.0, TOP - 596.0)


@dataclass(frozen=True)
class Scene:
    """Files of the small scene."""

    emission: Path
    kernel: Path
    lights: Path
    flux: np.ndarray  # (rows, cols) [lm m-2], 0 where unlit
    transform: Affine


@pytest.fixture(scope="session")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    """The small scene: emission COG, kernel NetCDF and a few light points, written once."""
    from nightlights.io import Raster
    from nightlights.sky import KernelSpec, build_kernel

    folder = tmp_path_factory.mktemp("explore_scene")
    rng = np.random.default_rng(2023)
    flux = np.zeros((ROWS, COLS))
    lit = rng.choice(ROWS * COLS, N_LIT, replace=False)
    flux.flat[lit] = rng.uniform(0.5, 5.0, N_LIT)  # [lm m-2]
    transform = Affine(CELL, 0.0, LEFT, 0.0, -CELL, TOP)
    emission = Raster(flux[None], transform, CRS, ("lambertian",), ("lm m-2",)).write(
        folder / "emission.tif"
    )
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    kernel = build_kernel(spec, folder / "kernel.nc", progress=False).path
    assert kernel is not None
    rows, cols = np.divmod(lit[:12], COLS)
    lights = folder / "lights.gpkg"
    gpd.GeoDataFrame(
        {"light_id": np.arange(12)},
        geometry=[
            Point(LEFT + (c + 0.5) * CELL, TOP - (r + 0.5) * CELL)
            for r, c in zip(rows, cols, strict=True)
        ],
        crs=CRS,
    ).to_file(lights)
    return Scene(Path(emission), Path(kernel), lights, flux, transform)


@pytest.fixture(scope="session")
def make_session(scene: Scene) -> Callable[..., object]:
    """A factory of fresh explore sessions of the scene with its kernel (keywords go to
    ExploreSession)."""
    from nightlights.explore._session import ExploreSession
    from nightlights.sky import Scene as SkyScene

    def make(**options: object) -> object:
        options.setdefault("progress", False)
        sky = SkyScene(scene.emission, kernel=scene.kernel)
        return ExploreSession(sky, **options)  # type: ignore[arg-type]

    return make


@pytest.fixture(scope="module")
def shared_session(make_session: Callable[..., object]) -> object:
    """One session for a test module's read-only tests (do not edit it)."""
    return make_session()
