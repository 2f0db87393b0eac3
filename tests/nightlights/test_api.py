"""The public face: ``import nightlights as nl``.

The stages are imported lazily, each name resolves, and a notebook-style run from streets to
the sky entirely in memory writes no file and gives the panorama the CLI gives.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

import nightlights as nl
from nightlights.demo import example_path
from nightlights_cli.main import cli

SEED = 2011
#: A small kernel for the test scene (Lambertian and uplight, eye height 1.7 m).
KERNEL_OPTIONS = {
    "r_min": 10.0,
    "r_max": 10_000.0,
    "n_distance": 24,
    "n_elevation": 16,
    "n_azimuth": 64,
    "uplight": True,
    "observer_altitudes": (1.7,),
}
ESPLANADI = (24.9480, 60.1675)
IRRADIANCE_RESOLUTION = 2.0  # [m]
EMISSION_RESOLUTION = 50.0  # [m]
ALBEDO = 0.15


def test_import_is_light() -> None:
    code = (
        "import sys, nightlights; "
        "print(sorted(m for m in ('xarray', 'geopandas', 'numba', 'dask', 'matplotlib', "
        "'rasterio', 'pgmpy', 'nightlights.sky', 'nightlights.ground', 'nightlights.streets') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"


def test_every_public_name_resolves() -> None:
    for name in nl.__all__:
        assert getattr(nl, name) is not None, name
    assert set(nl.__all__) <= set(dir(nl))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        nl.nothing  # noqa: B018


@pytest.mark.parametrize(
    "name",
    [
        "normalize",
        "sample",
        "fit",
        "place",
        "irradiance",
        "emission",
        "emission_from_viirs",
        "build_kernel",
        "skyglow",
        "inverse_q",
        "inverse_s",
        "inverse_reduce",
        "least_dimming",
        "darkness",
        "learn",
        "sky_render",
        "run",
        "load_project",
        "observers",
    ],
)
def test_stage_documented(name: str) -> None:
    doc = getattr(nl, name).__doc__
    for section in ("Parameters", "Returns", "Examples"):
        assert section in doc, f"nl.{name} lacks a {section} section"


def test_help_shows_the_stage() -> None:
    out = subprocess.run(
        [sys.executable, "-c", "import nightlights as nl; help(nl.skyglow)"],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PAGER": "cat"},
    ).stdout
    assert "skyglow(scene" in out
    assert "observer" in out


def _in_memory_panorama() -> xr.Dataset:
    streets = nl.normalize(example_path(), mapping="osm").streets
    streets = nl.sample(streets, seed=SEED).streets
    lights = nl.place(streets, seed=SEED).lights
    ground = nl.irradiance(lights, resolution=IRRADIANCE_RESOLUTION, progress=False)
    upward = nl.emission(
        ground.raster, lights=lights, resolution=EMISSION_RESOLUTION, albedo=ALBEDO
    )
    kernel = nl.build_kernel(nl.KernelSpec(**KERNEL_OPTIONS), progress=False)
    sky = nl.skyglow(
        nl.Scene(upward.raster, kernel=kernel), nl.Observer.from_lonlat(*ESPLANADI), progress=False
    )
    for result in (ground, upward, kernel, sky):
        assert result.path is None
    return sky.panorama


def _cli_panorama(work: Path) -> xr.Dataset:
    k = KERNEL_OPTIONS
    kernel_options = [
        *("--r-min", str(k["r_min"]), "--r-max", str(k["r_max"])),
        *("--n-distance", str(k["n_distance"]), "--n-elevation", str(k["n_elevation"])),
        *("--n-azimuth", str(k["n_azimuth"]), "--observer-altitude", "1.7", "--uplight"),
    ]
    w = {name: str(work / name) for name in ("norm.gpkg", "lit.gpkg", "lights.gpkg")}
    w |= {name: str(work / name) for name in ("irr.tif", "em.tif", "kernel.nc", "sky.nc")}
    steps = [
        ["streets", "normalize", str(example_path()), w["norm.gpkg"]],
        ["streets", "sample", w["norm.gpkg"], w["lit.gpkg"], "--seed", str(SEED)],
        ["streets", "place", w["lit.gpkg"], w["lights.gpkg"], "--seed", str(SEED)],
        ["irradiance", w["lights.gpkg"], w["irr.tif"], "--resolution", str(IRRADIANCE_RESOLUTION)],
        [
            *("emission", w["irr.tif"], w["lights.gpkg"], w["em.tif"]),
            *("--resolution", str(EMISSION_RESOLUTION), "--albedo", str(ALBEDO)),
        ],
        ["kernel", "build", w["kernel.nc"], *kernel_options],
        [
            *("skyglow", w["em.tif"], w["sky.nc"], "--kernel", w["kernel.nc"]),
            *("--observer", "{},{}".format(*ESPLANADI), "--observer-crs", "EPSG:4326"),
        ],
    ]
    runner = CliRunner()
    for args in steps:
        result = runner.invoke(cli, args, catch_exceptions=False)
        assert result.exit_code == 0, (args, result.output)
    with xr.open_dataset(w["sky.nc"]) as ds:
        return ds.load()


def test_streets_to_sky_in_memory_equals_cli(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    memory_dir = tmp_path / "memory"
    memory_dir.mkdir()
    monkeypatch.chdir(memory_dir)
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(tmp_path / "cache"))
    in_memory = _in_memory_panorama()
    assert list(memory_dir.iterdir()) == []
    assert not (tmp_path / "cache").exists()
    from_files = _cli_panorama(tmp_path)
    assert in_memory.luminance.dims == from_files.luminance.dims
    np.testing.assert_allclose(
        in_memory.luminance.values, from_files.luminance.values, rtol=1e-6, atol=0.0
    )
    np.testing.assert_allclose(
        in_memory.sky_brightness.values, from_files.sky_brightness.values, rtol=0, atol=1e-6
    )
    assert float(in_memory.luminance.max()) > 0.0
