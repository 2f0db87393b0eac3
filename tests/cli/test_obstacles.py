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
