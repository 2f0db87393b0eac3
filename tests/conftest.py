"""Shared fixtures."""

from __future__ import annotations

import contextlib
import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

DATA = Path(__file__).parent / "data"


@pytest.fixture
def data_dir() -> Path:
    """The folder of test data files (see tests/data/README.md)."""
    return DATA


@contextlib.contextmanager
def _read_only(folder: Path) -> Iterator[Path]:
    """Make ``folder`` unwritable for this process (chmod, or ``chattr +i`` for root)."""
    folder.mkdir(exist_ok=True)
    folder.chmod(0o555)
    immutable = False
    try:
        if os.access(folder, os.W_OK):  # root ignores the mode bits
            done = subprocess.run(["chattr", "+i", str(folder)], capture_output=True)
            immutable = done.returncode == 0
        try:
            (folder / ".probe").write_text("")
        except OSError:
            yield folder
        else:
            (folder / ".probe").unlink()
            pytest.skip("cannot make a folder read-only here")
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
        folder.chmod(0o755)


@pytest.fixture
def read_only() -> Callable[[Path], contextlib.AbstractContextManager[Path]]:
    """A context manager that makes a folder unwritable for this process (skips if it cannot)."""
    return _read_only


@pytest.fixture(scope="session")
def tiny_sky_kernel() -> object:
    """A coarse sky kernel with uplight to 3 km (6 distances, 4 elevations, 8 azimuths), built
    once per session for the tests that need a sky but not its accuracy."""
    from nightlights.sky import KernelSpec, build_kernel

    spec = KernelSpec(r_max=3000.0, n_distance=6, n_elevation=4, n_azimuth=8, uplight=True)
    return build_kernel(spec, progress=False)


@pytest.fixture(scope="session")
def road_plan_case() -> tuple[object, object, dict[str, dict[str, float]], object]:
    """Three classed streets (M4, M3, P3), their placed lights, requirements every segment
    meets undimmed with room (60 % of its minima, 150 % of its glare) and the road model:
    ``(lights, streets, requirements, model)``."""
    import warnings

    import geopandas as gpd
    import numpy as np
    from shapely import LineString

    from nightlights import roads
    from nightlights.errors import DataQualityWarning
    from nightlights.streets import place

    streets = gpd.GeoDataFrame(
        {
            "source_id": ["a", "b", "c"],
            "width": [7.0, 12.0, 6.0],
            "lanes": [2, 4, 2],
            "lit": [True] * 3,
            "arrangement": ["single_sided", "opposite", "staggered"],
            "spacing": [30.0, 40.0, 25.0],
            "mounting_height": [8.0, 10.0, 6.0],
            "system_id": ["street_led_small", "road_led_large", "street_led_small"],
            "lighting_class": ["M4", "M3", "P3"],
        },
        geometry=[
            LineString([(0, 0), (300, 0)]),
            LineString([(0, 100), (200, 150), (400, 100)]),
            LineString([(500, 0), (500, 200)]),
        ],
        crs="EPSG:3067",
    )
    lights = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0).lights
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        first = roads.road_model(lights, streets)
        table: dict[str, dict[str, float]] = {}
        for _, row in first.rate().iterrows():
            entry = table.setdefault(str(row["lighting_class"]), {})
            for name in roads.CRITERIA:
                if f"{name}_required" not in row or not np.isfinite(row[f"{name}_required"]):
                    continue
                kind = roads.CRITERIA[name][0]
                value = row[name] * (0.6 if kind == "minimum" else 1.5)
                keep = min if kind == "minimum" else max  # every segment passes undimmed
                entry[name] = keep(entry.get(name, value), value)
        model = roads.road_model(lights, streets, requirements=table)
    return lights, streets, table, model
