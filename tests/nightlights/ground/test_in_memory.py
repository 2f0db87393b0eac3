"""The ground stages in memory (nothing written) give the rasters of their file forms."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from affine import Affine
from shapely.geometry import Point

from nightlights.errors import InputError
from nightlights.ground import (
    EmissionResult,
    InfluenceThreshold,
    IrradianceResult,
    emission,
    emission_from_viirs,
    irradiance,
)
from nightlights.io import Raster

CRS = "EPSG:32633"


@dataclass(frozen=True)
class System:
    mounting_height: float = 8.0
    arm_length: float = 1.0
    tilt: float = 5.0
    street_azimuth: float = 90.0
    spd: str = "LED_4000K"


class Photometry:
    vertical_angles = np.arange(0.0, 180.1, 5.0)
    horizontal_angles = np.arange(0.0, 360.1, 10.0)

    def intensity(self, vertical, horizontal):
        v, h = np.asarray(vertical, float), np.asarray(horizontal, float)
        lobe = 1000 * np.cos(np.radians(v)) * (1 + 0.5 * np.cos(np.radians(h - 90)))
        return np.where(v < 90, lobe, 0.0) + 15.0


class Database:
    def get(self, system_id):
        if system_id != "lamp":
            raise KeyError(system_id)
        return System()

    def photometry(self, system_id):
        return Photometry()


@pytest.fixture
def lights() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {"light_id": [1, 2, 3], "system_id": "lamp", "heading": [0.0, 120.0, 250.0]},
        geometry=[Point(40.3, 60.2), Point(90.0, 35.0), Point(130.5, 80.0)],
        crs=CRS,
    )


@pytest.fixture
def dem(tmp_path: Path) -> Path:
    rows, cols = np.mgrid[0:25, 0:25]
    path = tmp_path / "dem.tif"
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=25,
        width=25,
        count=1,
        dtype="float32",
        crs=CRS,
        transform=Affine(10, 0, -30, 0, -10, 200),
    ) as dataset:
        dataset.write((100 + 0.8 * cols + 0.3 * rows).astype(np.float32)[None])
    return path


OPTIONS = {
    "resolution": 2.0,
    "sensors": ("photopic", "scotopic"),
    "bounds": (0, 0, 180, 120),
    "database": Database(),
    "threshold": InfluenceThreshold("energy", 0.02),
    "progress": False,
}


def read(path: Path) -> tuple[np.ndarray, dict, tuple, tuple]:
    with rasterio.open(path) as dataset:
        return (
            dataset.read().astype(np.float64),
            dataset.tags(),
            dataset.descriptions,
            dataset.transform,
        )


def test_irradiance_in_memory_equals_the_file(
    tmp_path: Path, lights: gpd.GeoDataFrame, dem: Path
) -> None:
    path = tmp_path / "lights.gpkg"
    lights.to_file(path)
    out = tmp_path / "e.tif"
    written = irradiance(path, out, dem=dem, **OPTIONS)
    in_memory = irradiance(lights, dem=Raster.read(dem), **OPTIONS)
    assert isinstance(in_memory, IrradianceResult)
    assert written.path == out and in_memory.path is None
    data, tags, descriptions, transform = read(out)
    np.testing.assert_array_equal(in_memory.raster.data, data)
    np.testing.assert_array_equal(written.raster.data, data)
    assert in_memory.raster.descriptions == descriptions == ("photopic", "scotopic")
    assert in_memory.raster.units == ("lx", "W m-2")
    assert in_memory.raster.transform == transform
    assert {k: v for k, v in tags.items() if k in in_memory.raster.tags} == dict(
        in_memory.raster.tags
    )
    assert in_memory.n_lights == written.n_lights == 3
    assert in_memory.n_pairs == written.n_pairs
    assert in_memory.grid == written.grid
    assert in_memory.crs.to_epsg() == 32633


def test_irradiance_writes_nothing_without_output(
    tmp_path: Path, lights: gpd.GeoDataFrame, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    irradiance(lights, **OPTIONS)
    assert list(tmp_path.iterdir()) == []


def test_dem_as_a_data_array(tmp_path: Path, lights: gpd.GeoDataFrame, dem: Path) -> None:
    from_path = irradiance(lights, dem=dem, **OPTIONS)
    from_array = irradiance(lights, dem=Raster.read(dem).to_xarray(), **OPTIONS)
    np.testing.assert_array_equal(from_array.raster.data, from_path.raster.data)


def test_missing_crs_is_named_by_crs(lights: gpd.GeoDataFrame) -> None:
    bare = lights.set_crs(None, allow_override=True)
    result = irradiance(bare, crs=CRS, **OPTIONS)
    reference = irradiance(lights, **OPTIONS)
    np.testing.assert_array_equal(result.raster.data, reference.raster.data)


def test_emission_in_memory_equals_the_file(tmp_path: Path, lights: gpd.GeoDataFrame) -> None:
    lights_path = tmp_path / "lights.gpkg"
    lights.to_file(lights_path)
    ground_path = tmp_path / "e.tif"
    ground = irradiance(lights_path, ground_path, **OPTIONS)
    albedo = Raster(np.array([[[0.1, 0.2], [0.3, 0.25]]]), Affine(100, 0, -10, 0, -100, 130), CRS)
    albedo_path = tmp_path / "albedo.tif"
    albedo.write(albedo_path)
    albedo = Raster.read(albedo_path)  # the float32 values the file form reads
    options = {"resolution": 10.0, "database": Database()}
    out = tmp_path / "m.tif"
    written = emission(ground_path, out, lights=lights_path, albedo=albedo_path, **options)
    in_memory = emission(ground.raster, lights=lights, albedo=albedo, **options)
    as_array = emission(
        ground.raster.to_xarray(), lights=lights, albedo=albedo.to_xarray(), **options
    )
    assert isinstance(in_memory, EmissionResult) and in_memory.path is None
    data, tags, descriptions, _ = read(out)
    for result in (written, in_memory, as_array):
        np.testing.assert_array_equal(result.raster.data, data)
        assert result.raster.descriptions == descriptions == ("reflected", "uplight")
        assert result.total_flux == written.total_flux
    assert float(tags["total_uplight_lm"]) == written.total_flux["uplight"] > 0
    assert tags["source"] == str(ground_path)


def test_emission_albedo_raster_must_cover(tmp_path: Path, lights: gpd.GeoDataFrame) -> None:
    ground = irradiance(lights, **OPTIONS).raster
    small = Raster(np.full((1, 2, 2), 0.2), Affine(10, 0, 0, 0, -10, 120), CRS)
    with pytest.raises(InputError, match="albedo raster leaves"):
        emission(ground, resolution=10.0, albedo=small)


def test_viirs_in_memory_equals_the_file(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    radiance = Raster(
        rng.uniform(0, 50, (1, 12, 14)),
        Affine(15 / 3600, 0, 24.9, 0, -15 / 3600, 60.25),
        "EPSG:4326",
        ("radiance",),
        ("nW cm-2 sr-1",),
    )
    source = tmp_path / "dnb.tif"
    radiance.write(source)
    out = tmp_path / "up.tif"
    written = emission_from_viirs(source, out, spectrum="HPS", resolution=400.0)
    # The float32 file holds the radiance the in-memory raster must start from.
    stored = Raster.read(source)
    in_memory = emission_from_viirs(stored, spectrum="HPS", resolution=400.0)
    as_array = emission_from_viirs(stored.to_xarray(), spectrum="HPS", resolution=400.0)
    data, _, descriptions, transform = read(out)
    for result in (written, in_memory, as_array):
        np.testing.assert_array_equal(result.raster.data, data)
        assert result.raster.transform == transform
        assert result.raster.descriptions == descriptions == ("upward",)
        assert result.total_flux == written.total_flux
    assert in_memory.path is None and written.path == out
    assert in_memory.crs.to_epsg() == 32635
