"""``nightlights obstacles``."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import pytest
from click.testing import CliRunner
from shapely.geometry import box

from nightlights.io import Raster
from nightlights_cli.main import cli


def test_footprints_become_an_obstacle_raster(tmp_path: Path) -> None:
    footprints = tmp_path / "buildings.gpkg"
    gpd.GeoDataFrame(
        {"building:levels": [4, 2]},
        geometry=[box(0, 0, 20, 20), box(40, 0, 60, 20)],
        crs="EPSG:32635",
    ).to_file(footprints)
    out = tmp_path / "obstacles.tif"
    result = CliRunner().invoke(cli, ["obstacles", str(footprints), str(out), "--resolution", "40"])
    assert result.exit_code == 0, result.output
    raster = Raster.read(out)
    assert raster.shape == (1, 2) and raster.descriptions == ("height", "spacing", "filling")
    assert raster.data[0, 0].tolist() == pytest.approx([12.0, 6.0])
    assert raster.data[2, 0].tolist() == pytest.approx([0.25, 0.25])
    again = CliRunner().invoke(cli, ["obstacles", str(footprints), str(out), "--resolution", "40"])
    assert again.exit_code != 0 and "--overwrite" in again.output


def test_neither_grid_is_one_line(tmp_path: Path) -> None:
    footprints = tmp_path / "buildings.gpkg"
    gpd.GeoDataFrame({"height": [4.0]}, geometry=[box(0, 0, 20, 20)], crs="EPSG:32635").to_file(
        footprints
    )
    result = CliRunner().invoke(cli, ["obstacles", str(footprints), str(tmp_path / "o.tif")])
    assert result.exit_code == 1
    assert "give one of --reference (a raster) or --resolution" in result.output


def test_darkness_takes_the_obstacle_raster_into_its_scene(fake_stage, tmp_path: Path) -> None:
    from types import SimpleNamespace

    import numpy as np
    from affine import Affine

    transform = Affine(100, 0, 500_000, 0, -100, 6_700_000)
    flux = np.zeros((1, 20, 20))
    flux[0, 5:8, 12:15] = 1.0
    emission = tmp_path / "emission.tif"
    Raster(flux, transform, "EPSG:32635", ("reflected",), ("lm m-2",)).write(emission)
    obstacles = tmp_path / "obstacles.tif"
    props = np.stack([np.full((20, 20), 10.0), np.full((20, 20), 10.0), np.full((20, 20), 1.0)])
    Raster(props, transform, "EPSG:32635", ("height", "spacing", "filling")).write(obstacles)
    done = SimpleNamespace(raster=Raster(np.ones((2, 20, 20)), transform, "EPSG:32635"), seconds=0)
    recorder = fake_stage("darkness", done)
    args = ["darkness", str(emission), str(tmp_path / "z.tif"), "--obstacles", str(obstacles)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    scene = recorder.args[0]
    assert scene.obstacles == str(obstacles) and scene.inputs["emission"] == str(emission)
    # Full canyons of H/W = 1: the Lambertian share keeps cos(atan 2) of its flux and the
    # Garstang lobe (tagged on its own band) nothing through the gaps.
    assert [t["emission_function"] for t in scene.emission.band_tags] == [
        "lambertian",
        "garstang:1,0",
    ]
    assert scene.emission.data[1].max() == 0.0
    assert 0.0 < scene.emission.data[0].max() < 1.0
