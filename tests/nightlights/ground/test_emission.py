"""Upward emission: reflected light, direct uplight, and the VIIRS conversion."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from affine import Affine
from shapely.geometry import Point

from nightlights.errors import DataQualityWarning, InputError
from nightlights.ground import (
    InfluenceThreshold,
    RasterGrid,
    block_aggregate,
    deposit_flux,
    dnb_luminous_efficacy,
    emission,
    emission_from_viirs,
    flux_density_to_viirs_radiance,
    irradiance,
    resolve_luminaires,
    viirs_radiance_to_flux_density,
)

CRS = "EPSG:32633"


@dataclass(frozen=True)
class System:
    mounting_height: float = 8.0
    arm_length: float = 0.0
    tilt: float = 0.0
    street_azimuth: float = 0.0
    spd: str = "LED_4000K"


class Photometry:
    vertical_angles = np.arange(0.0, 180.1, 5.0)
    horizontal_angles = np.arange(0.0, 360.1, 10.0)

    def intensity(self, vertical, horizontal):
        v = np.asarray(vertical, float)
        # 1000 cd cosine lobe downwards plus 20 cd isotropic: uplight 40 pi lm untilted.
        return (
            np.where(v < 90, 1000 * np.cos(np.radians(v)), 0.0)
            + 20.0
            + 0 * np.asarray(horizontal, float)
        )


class Database:
    def __init__(self) -> None:
        self.systems = {"lamp": System()}

    def get(self, system_id):
        return self.systems[system_id]

    def photometry(self, system_id):
        return Photometry()


def write_lights(path: Path, points: list[tuple[float, float]], **fields) -> Path:
    gpd.GeoDataFrame(
        {"light_id": np.arange(len(points)), "system_id": "lamp", "heading": 0.0, **fields},
        geometry=[Point(p) for p in points],
        crs=CRS,
    ).to_file(path, driver="GPKG")
    return path


def test_block_aggregate_conserves_flux_with_partial_edges() -> None:
    rng = np.random.default_rng(0)
    fine = rng.uniform(0, 10, (23, 17))
    coarse = block_aggregate(fine, 5)
    assert coarse.shape == (5, 4)
    assert coarse.sum() * 25 == pytest.approx(fine.sum())
    assert coarse[0, 0] == pytest.approx(fine[:5, :5].mean())


def test_deposit_flux() -> None:
    grid = RasterGrid(0.0, 100.0, 10.0, 10, 10)
    density, inside = deposit_flux([5, 7, 55, -1], [95, 91, 45, 50], [10, 30, 5, 99], grid)
    assert density[0, 0] == pytest.approx(40 / 100)
    assert density[5, 5] == pytest.approx(5 / 100)
    assert inside.tolist() == [True, True, True, False]


@pytest.fixture
def scene(tmp_path: Path) -> tuple[Path, Path]:
    lights = write_lights(tmp_path / "l.gpkg", [(100.3, 100.2), (130.0, 95.0)])
    out = tmp_path / "e.tif"
    irradiance(
        lights,
        out,
        resolution=1.0,
        bounds=(-200, -200, 400, 400),
        database=Database(),
        threshold=InfluenceThreshold("none"),
        progress=False,
    )
    return lights, out


def test_reflected_band_integrates_to_albedo_times_ground_flux(scene, tmp_path: Path) -> None:
    lights, irradiance_tif = scene
    with rasterio.open(irradiance_tif) as dataset:
        ground_flux = dataset.read(1).astype(float).sum() * 1.0
    result = emission(
        irradiance_tif,
        tmp_path / "m.tif",
        lights=lights,
        resolution=50.0,
        albedo=0.15,
        database=Database(),
    )
    with rasterio.open(tmp_path / "m.tif") as dataset:
        reflected, uplight = dataset.read().astype(float)
        assert dataset.descriptions == ("reflected", "uplight")
        assert dataset.units == ("lm m-2", "lm m-2")
        assert dataset.res == (50.0, 50.0)
    assert reflected.sum() * 2500 == pytest.approx(0.15 * ground_flux, rel=1e-5)
    # Downward flux per light: 1000 pi (cosine) + 40 pi (isotropic lower half); the raster
    # holds nearly all of it.
    assert ground_flux == pytest.approx(2 * 1040 * np.pi, rel=0.01)
    # Uplight: 20 cd isotropic over the upper hemisphere = 40 pi lm per light, in its cell.
    assert uplight.sum() * 2500 == pytest.approx(2 * 40 * np.pi, rel=1e-4)
    # Each light's uplight lies in the cell holding it: rows 5 and 6 of column 6.
    assert uplight[5, 6] * 2500 == pytest.approx(40 * np.pi, rel=1e-4)
    assert uplight[6, 6] * 2500 == pytest.approx(40 * np.pi, rel=1e-4)
    assert result.total_flux["uplight"] == pytest.approx(80 * np.pi, rel=1e-4)


def test_uplight_equals_the_photometry_of_the_bundled_systems() -> None:
    from ies.library import load_library

    database = load_library()
    names = sorted(database.systems)
    frame = gpd.GeoDataFrame(
        {"system_id": names, "heading": 0.0},
        geometry=[Point(i, 0) for i in range(len(names))],
        crs=CRS,
    )
    luminaires = resolve_luminaires(frame, database)
    for name, flux in zip(names, luminaires.upward_flux(), strict=True):
        photometry = database.photometry(name)
        # Same distribution, integrated by two quadratures: agree within 0.1 % of the total.
        assert flux == pytest.approx(
            photometry.upward_flux(), abs=1e-3 * photometry.luminous_flux()
        )


def test_tilt_adds_uplight(tmp_path: Path) -> None:
    frame = gpd.GeoDataFrame(
        {"system_id": ["lamp"] * 2, "heading": 0.0, "tilt": [0.0, 30.0]},
        geometry=[Point(0, 0), Point(5, 0)],
        crs=CRS,
    )
    flux = resolve_luminaires(frame, Database()).upward_flux()
    # Tilted cosine lobe: (1 - cos 30)/2 of 1000 pi goes up, plus the isotropic 40 pi.
    expected = 40 * np.pi + 1000 * np.pi * (1 - np.cos(np.radians(30))) / 2
    assert flux[0] == pytest.approx(40 * np.pi, rel=1e-4)
    assert flux[1] == pytest.approx(expected, rel=2e-3)


def test_emission_bad_inputs(scene, tmp_path: Path) -> None:
    lights, irradiance_tif = scene
    with pytest.raises(InputError, match="integer multiple"):
        emission(
            irradiance_tif,
            tmp_path / "m.tif",
            lights=lights,
            resolution=2.5,
            albedo=0.1,
            database=Database(),
        )
    with pytest.raises(InputError, match="albedo"):
        emission(
            irradiance_tif,
            tmp_path / "m.tif",
            lights=lights,
            resolution=10,
            albedo=1.5,
            database=Database(),
        )
    far = write_lights(tmp_path / "far.gpkg", [(100.0, 100.0), (9000.0, 0.0)])
    with pytest.warns(DataQualityWarning, match="1 lights"):
        emission(
            irradiance_tif,
            tmp_path / "m.tif",
            lights=far,
            resolution=10,
            albedo=0.1,
            database=Database(),
        )


def test_albedo_raster(scene, tmp_path: Path) -> None:
    _, irradiance_tif = scene
    albedo = tmp_path / "albedo.tif"
    with rasterio.open(
        albedo,
        "w",
        driver="GTiff",
        height=2,
        width=2,
        count=1,
        dtype="float32",
        crs=CRS,
        transform=Affine(400, 0, -250, 0, -400, 450),
    ) as dataset:
        dataset.write(np.full((1, 2, 2), 0.3, np.float32))
    emission(irradiance_tif, tmp_path / "a.tif", resolution=20, albedo=albedo)
    emission(irradiance_tif, tmp_path / "b.tif", resolution=20, albedo=0.3)
    with rasterio.open(tmp_path / "a.tif") as a, rasterio.open(tmp_path / "b.tif") as b:
        np.testing.assert_allclose(a.read(1), b.read(1), rtol=1e-6)


def test_dnb_efficacy_of_a_555_nm_line_is_683() -> None:
    """A monochromatic 555 nm source: K = 683 V(555) = 683 lm/W (SI definition)."""
    wavelengths = np.arange(540.0, 571.0, 0.5)
    line = np.exp(-0.5 * ((wavelengths - 555.0) / 1.0) ** 2)
    assert dnb_luminous_efficacy((wavelengths, line)) == pytest.approx(683.0, rel=2e-3)
    # Broad spectra lose efficacy to the red/near-infrared part of the band.
    for name in ("HPS", "LED_4000K", "incandescent"):
        assert 0 < dnb_luminous_efficacy(name) < 683
    assert dnb_luminous_efficacy("incandescent") < 0.5 * dnb_luminous_efficacy("HPS")
    with pytest.raises(InputError, match="no power"):
        dnb_luminous_efficacy((np.array([950.0, 960.0]), np.array([1.0, 1.0])))


def test_viirs_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    radiance = rng.uniform(0, 80, (20, 30))
    source = tmp_path / "dnb.tif"
    with rasterio.open(
        source,
        "w",
        driver="GTiff",
        height=20,
        width=30,
        count=1,
        dtype="float64",
        crs=CRS,
        transform=Affine(450, 0, 500_000, 0, -450, 6_000_000),
    ) as dataset:
        dataset.write(radiance[None])
    out = tmp_path / "up.tif"
    result = emission_from_viirs(source, out, spectrum="HPS")
    with rasterio.open(out) as dataset:
        flux_density = dataset.read(1).astype(float)
        efficacy = float(dataset.tags()["dnb_luminous_efficacy_lm_per_W"])
        assert dataset.units == ("lm m-2",)
    assert result.crs.to_epsg() == 32633
    np.testing.assert_allclose(flux_density, np.pi * radiance * 1e-5 * efficacy, rtol=1e-6)
    back = flux_density_to_viirs_radiance(flux_density, efficacy)
    np.testing.assert_allclose(back, radiance, rtol=1e-6)
    np.testing.assert_allclose(
        flux_density_to_viirs_radiance(viirs_radiance_to_flux_density(radiance, 400.0), 400.0),
        radiance,
        rtol=1e-12,
    )


def test_viirs_geographic_input_goes_to_utm(tmp_path: Path) -> None:
    source = tmp_path / "dnb.tif"
    step = 15 / 3600
    with rasterio.open(
        source,
        "w",
        driver="GTiff",
        height=40,
        width=40,
        count=1,
        dtype="float32",
        crs="EPSG:4326",
        transform=Affine(step, 0, 24.9, 0, -step, 60.2),
    ) as dataset:
        dataset.write(np.full((1, 40, 40), 10.0, np.float32))
    with pytest.warns(DataQualityWarning, match="negative"):
        with rasterio.open(source, "r+") as dataset:
            data = dataset.read()
            data[0, 0, 0] = -1.0
            dataset.write(data)
        result = emission_from_viirs(source, tmp_path / "up.tif", spectrum="LED_4000K")
    assert result.crs.to_epsg() == 32635  # Helsinki: UTM 35N
    with rasterio.open(tmp_path / "up.tif") as dataset:
        values = dataset.read(1, masked=True)
    expected = viirs_radiance_to_flux_density(10.0, dnb_luminous_efficacy("LED_4000K"))
    assert np.ma.median(values) == pytest.approx(expected, rel=1e-5)
