"""CLI: nightlights irradiance and nightlights emission."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from affine import Affine
from click.testing import CliRunner
from shapely.geometry import Point, box

from cli.main import cli

CRS = "EPSG:3067"


@pytest.fixture
def lights(tmp_path: Path) -> Path:
    path = tmp_path / "lights.gpkg"
    gpd.GeoDataFrame(
        {
            "light_id": [1, 2, 3],
            "street_id": ["a", "a", "b"],
            "system_id": ["street_led_medium", "street_led_small", "road_hps"],
            "heading": [90.0, 270.0, 0.0],
            "mounting_height": [10.0, None, 12.0],
            "arm_length": [1.0, 0.5, None],
            "tilt": [0.0, 5.0, 0.0],
            "side": ["left", "right", "center"],
            "arrangement": ["opposite", "opposite", "central"],
        },
        geometry=[Point(385_000, 6_672_000), Point(385_020, 6_672_000), Point(385_010, 6_672_040)],
        crs=CRS,
    ).to_file(path, layer="lights", driver="GPKG")
    return path


def test_irradiance_then_emission(lights: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    out = tmp_path / "e.tif"
    result = runner.invoke(
        cli,
        [
            "irradiance",
            str(lights),
            str(out),
            "--resolution",
            "2",
            "--sensor",
            "photopic",
            "--sensor",
            "scotopic",
            "--tile-size",
            "64",
        ],
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as dataset:
        assert dataset.descriptions == ("photopic", "scotopic")
        assert dataset.units == ("lx", "W m-2")
        assert dataset.crs.to_epsg() == 3067
        photopic, scotopic = dataset.read().astype(float)
    assert photopic.max() > 10  # tens of lux under a street light
    # Sensor band = k x lux per light; k(scotopic) is within (0, 1/683 * 2.5) for these SPDs.
    ratio = scotopic[photopic > 1] / photopic[photopic > 1]
    assert np.all((ratio > 0) & (ratio < 2.5 / 683))
    emission_out = tmp_path / "m.tif"
    result = runner.invoke(
        cli,
        [
            "emission",
            str(out),
            str(lights),
            str(emission_out),
            "--resolution",
            "20",
            "--albedo",
            "0.1",
        ],
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(emission_out) as dataset:
        assert dataset.descriptions == ("reflected", "uplight")
        reflected, uplight = dataset.read().astype(float)
    assert reflected.sum() * 400 == pytest.approx(0.1 * photopic.sum() * 4, rel=1e-4)
    assert uplight.sum() > 0  # street_led_medium has ~50 lm of uplight


def test_irradiance_with_area_sources(lights: Path, tmp_path: Path) -> None:
    areas = tmp_path / "areas.gpkg"
    gpd.GeoDataFrame(
        {"exitance": [20.0]}, geometry=[box(385_100, 6_672_000, 385_140, 6_672_030)], crs=CRS
    ).to_file(areas, driver="GPKG")
    out = tmp_path / "e.tif"
    result = CliRunner().invoke(
        cli,
        [
            "irradiance",
            str(lights),
            str(out),
            "--resolution",
            "2",
            "--area-sources",
            str(areas),
            "--bounds",
            "384900,6671900,385300,6672200",
        ],
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as dataset:
        data = dataset.read(1)
        row, col = dataset.index(385_120, 6_672_015)
    assert data[row, col] > 5  # under the lit area


def test_errors_are_one_line(lights: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    result = runner.invoke(
        cli, ["irradiance", str(lights), str(tmp_path / "e.tif"), "--resolution", "0"]
    )
    assert result.exit_code != 0
    assert "InputError: resolution=0.0 m" in result.output
    assert "Traceback" not in result.output
    result = runner.invoke(
        cli,
        [
            "irradiance",
            str(lights),
            str(tmp_path / "e.tif"),
            "--resolution",
            "1",
            "--threshold",
            "fancy:2",
        ],
    )
    assert result.exit_code != 0 and "threshold" in result.output
    result = runner.invoke(cli, ["emission", "a.tif", "--resolution", "10"])
    assert result.exit_code != 0 and "IRRADIANCE.tif LIGHTS OUT.tif" in result.output
    assert not (tmp_path / "e.tif").exists()


def test_emission_from_viirs(tmp_path: Path) -> None:
    source = tmp_path / "dnb.tif"
    with rasterio.open(
        source,
        "w",
        driver="GTiff",
        height=4,
        width=5,
        count=1,
        dtype="float32",
        crs="EPSG:32635",
        transform=Affine(500, 0, 385_000, 0, -500, 6_673_000),
    ) as dataset:
        dataset.write(np.full((1, 4, 5), 25.0, np.float32))
    out = tmp_path / "up.tif"
    result = CliRunner().invoke(
        cli, ["emission", "--from-viirs", str(source), str(out), "--spectrum", "HPS"]
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as dataset:
        assert dataset.descriptions == ("upward",)
        assert dataset.tags()["spectrum"] == "HPS"
        assert np.allclose(dataset.read(1), dataset.read(1)[0, 0]) and dataset.read(1)[0, 0] > 0
