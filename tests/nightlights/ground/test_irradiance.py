"""Ground illuminance (Chuang 2011, Secs. 4.3-5.1): analytic validations and bad input."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from affine import Affine
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Point

from nightlights.errors import CRSError, DataQualityWarning, EmptyInputError, InputError
from nightlights.ground import (
    InfluenceThreshold,
    IntensityTable,
    flux_profile,
    ground_illuminance,
    influence_radius,
    irradiance,
    luminaire_rotation,
)

CRS = "EPSG:32633"


def cosine_lobe(peak: float = 1000.0):
    return lambda v, h: np.where(v < 90, peak * np.cos(np.radians(v)), 0.0)


def asymmetric_lobe(v: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Throws towards C90 (the street side in the fake systems below)."""
    return np.where(
        v < 90, 1000 * np.cos(np.radians(v)) * (1 + 0.8 * np.cos(np.radians(h - 90))), 0
    )


@dataclass(frozen=True)
class FakeSystem:
    mounting_height: float = 10.0
    arm_length: float = 0.0
    tilt: float = 0.0
    street_azimuth: float = 90.0
    spd: str = "led"


class FakePhotometry:
    def __init__(self, func) -> None:
        self.vertical_angles = np.arange(0.0, 180.1, 2.5)
        self.horizontal_angles = np.arange(0.0, 360.1, 5.0)
        self._func = func

    def intensity(self, vertical, horizontal):
        return self._func(np.asarray(vertical, float), np.asarray(horizontal, float))


class FakeDatabase:
    def __init__(self, **lobes) -> None:
        self.systems = {name: FakeSystem() for name in lobes}
        self._lobes = lobes

    def get(self, system_id: str) -> FakeSystem:
        return self.systems[system_id]

    def photometry(self, system_id: str) -> FakePhotometry:
        return FakePhotometry(self._lobes[system_id])


def single(
    table: IntensityTable,
    shape,
    origin,
    resolution,
    point,
    heading=0.0,
    tilt=0.0,
    street_azimuth=0.0,
    radius=None,
    **kwargs,
) -> np.ndarray:
    return ground_illuminance(
        shape,
        origin,
        resolution,
        np.array([point], float),
        luminaire_rotation([heading], [tilt]),
        np.array([street_azimuth]),
        np.zeros(1, int),
        [table],
        np.ones((1, 1)),
        radius=None if radius is None else np.array([radius]),
        **kwargs,
    )[0]


@settings(max_examples=40, deadline=None)
@given(st.floats(2.0, 40.0), st.floats(-20, 20), st.floats(-20, 20), st.floats(1, 1e5))
def test_isotropic_source_follows_inverse_square_and_cosine_law(
    height: float, x: float, y: float, intensity: float
) -> None:
    """E = I cos(i) / d^2 = I h / d^3 for an isotropic source (exact up to rounding)."""
    table = IntensityTable.from_function(lambda v, h: np.full_like(v, intensity))
    values = single(table, (5, 7), (-3.0, 2.0), 1.0, (x, y, height))
    cx = -3.0 + np.arange(7)
    cy = 2.0 - np.arange(5)
    dx, dy = cx[None, :] - x, cy[:, None] - y
    distance = np.sqrt(dx**2 + dy**2 + height**2)
    np.testing.assert_allclose(values, intensity * height / distance**3, rtol=1e-12)


@pytest.mark.parametrize("y", [2.2250738585e-313, 5e-324, -3e-310, 1e-160, 1e-300, 0.0])
@pytest.mark.parametrize("x", [0.0, 1e-320, -2e-315])
def test_a_light_a_subnormal_distance_off_a_pixel_centre(x: float, y: float) -> None:
    # the pixel straight below: its horizontal angle comes from subnormal offsets
    table = IntensityTable.from_function(lambda v, h: np.full_like(v, 3.0))
    values = single(table, (5, 7), (-3.0, 2.0), 1.0, (x, y, 2.0))
    cx = -3.0 + np.arange(7)
    cy = 2.0 - np.arange(5)
    distance = np.sqrt((cx[None, :] - x) ** 2 + (cy[:, None] - y) ** 2 + 2.0**2)
    np.testing.assert_allclose(values, 3.0 * 2.0 / distance**3, rtol=1e-12)


def test_energy_conservation_on_a_large_raster() -> None:
    """Flux on the ground = downward flux of the luminaire (asymmetric lobe), within 1 %."""
    table = IntensityTable.from_function(asymmetric_lobe, vertical_step=2.5, horizontal_step=5)
    downward = flux_profile(table, tilt=10.0).downward_flux
    values = single(table, (801, 801), (-400.0, 400.0), 1.0, (0.2, 0.3, 8.0), heading=30, tilt=10.0)
    assert values.sum() * 1.0**2 == pytest.approx(downward, rel=0.01)


def test_symmetric_photometry_gives_a_symmetric_lobe() -> None:
    table = IntensityTable.from_function(lambda v, h: 500 * (1 + np.sin(np.radians(v))))
    values = single(table, (61, 61), (-30.0, 30.0), 1.0, (0.0, 0.0, 6.0), heading=17.0)
    np.testing.assert_allclose(values, values[:, ::-1], rtol=1e-9)
    np.testing.assert_allclose(values, values[::-1, :], rtol=1e-9)
    np.testing.assert_allclose(values, values.T, rtol=1e-9)


def test_heading_rotates_the_lobe() -> None:
    table = IntensityTable.from_function(asymmetric_lobe)
    north = single(table, (41, 41), (-20.0, 20.0), 1.0, (0, 0, 8.0), street_azimuth=90.0)
    east = single(
        table, (41, 41), (-20.0, 20.0), 1.0, (0, 0, 8.0), heading=90.0, street_azimuth=90.0
    )
    # The street side faces the heading: the lobe throws north, then east.
    assert north[:20].sum() > 2 * north[21:].sum()
    np.testing.assert_allclose(east, np.rot90(north, k=-1), rtol=1e-9, atol=1e-12)


def test_tilt_moves_the_lobe_forward() -> None:
    table = IntensityTable.from_function(cosine_lobe())
    x = np.arange(-50, 51, 1.0)
    centroids = []
    for tilt in (0.0, 15.0, 30.0):
        values = single(table, (101, 101), (-50.0, 50.0), 1.0, (0, 0, 8.0), heading=90.0, tilt=tilt)
        centroids.append((values.sum(axis=0) * x).sum() / values.sum())
    assert centroids[0] == pytest.approx(0.0, abs=1e-9)
    assert 0 < centroids[1] < centroids[2]


def test_light_point_on_the_ground_stays_finite() -> None:
    table = IntensityTable.from_function(lambda v, h: np.ones_like(v))
    values = single(table, (3, 3), (-1.0, 1.0), 1.0, (0, 0, 0.0))
    assert np.all(np.isfinite(values))


@pytest.mark.parametrize("fraction", [0.2, 0.05, 0.01])
def test_energy_threshold_bounds_the_lost_flux(fraction: float) -> None:
    table = IntensityTable.from_function(asymmetric_lobe)
    profile = flux_profile(table)
    radius = influence_radius(profile, np.array([8.0]), InfluenceThreshold("energy", fraction))
    full = single(table, (601, 601), (-300.0, 300.0), 1.0, (0, 0, 8.0))
    cut = single(table, (601, 601), (-300.0, 300.0), 1.0, (0, 0, 8.0), radius=radius[0])
    lost = (full.sum() - cut.sum()) / full.sum()
    assert 0 <= lost <= fraction
    assert radius[0] < 300


@pytest.mark.parametrize("floor", [1.0, 0.1, 0.01])
def test_floor_threshold_bounds_the_pixel_error(floor: float) -> None:
    table = IntensityTable.from_function(asymmetric_lobe)
    radius = influence_radius(
        flux_profile(table), np.array([8.0]), InfluenceThreshold("floor", floor)
    )
    full = single(table, (401, 401), (-200.0, 200.0), 1.0, (0, 0, 8.0), street_azimuth=90)
    cut = single(
        table, (401, 401), (-200.0, 200.0), 1.0, (0, 0, 8.0), street_azimuth=90, radius=radius[0]
    )
    assert np.max(full - cut) <= floor


def test_threshold_parse_and_validation() -> None:
    assert InfluenceThreshold.parse("floor:0.05") == InfluenceThreshold("floor", 0.05)
    assert InfluenceThreshold.parse("none").kind == "none"
    for bad in ("energy:1.5", "floor:-1", "lux:3", "energy:abc"):
        with pytest.raises(InputError):
            InfluenceThreshold.parse(bad)


def test_dem_tilted_plane_uses_the_surface_normal() -> None:
    """On a plane sloping up to the east, E = I cos(incidence)/d^2 with the plane normal."""
    table = IntensityTable.from_function(lambda v, h: np.full_like(v, 1000.0))
    slope = 0.2
    cx = -5.0 + np.arange(11)
    ground = np.broadcast_to(slope * cx[None, :], (11, 11)).copy()
    normal = np.array([-slope, 0.0, 1.0]) / np.hypot(slope, 1)
    normals = np.broadcast_to(normal, (11, 11, 3)).copy()
    values = single(
        table, (11, 11), (-5.0, 5.0), 1.0, (0, 0, 10.0), ground_z=ground, normals=normals
    )
    cy = 5.0 - np.arange(11)
    to_light = np.stack(
        [-cx[None, :] + 0 * cy[:, None], -cy[:, None] + 0 * cx[None, :], 10.0 - ground], -1
    )
    d = np.linalg.norm(to_light, axis=-1)
    expected = 1000 * (to_light @ normal) / d**3
    np.testing.assert_allclose(values, expected, rtol=1e-12)


# ---------------------------------------------------------------- stage


def write_lights(path: Path, rows: list[dict], crs: str | None = CRS) -> Path:
    frame = gpd.GeoDataFrame(
        [{k: v for k, v in row.items() if k not in ("x", "y")} for row in rows],
        geometry=[Point(row["x"], row["y"]) for row in rows],
        crs=crs,
    )
    frame.to_file(path, layer="lights", driver="GPKG")
    return path


def light(light_id: int, x: float, y: float, system_id: str | None = "cone", **extra) -> dict:
    return {"light_id": light_id, "x": x, "y": y, "system_id": system_id, "heading": 0.0, **extra}


@pytest.fixture
def database() -> FakeDatabase:
    return FakeDatabase(cone=cosine_lobe(), throw=asymmetric_lobe)


def test_stage_writes_a_cog_matching_the_kernel(tmp_path: Path, database: FakeDatabase) -> None:
    lights = write_lights(
        tmp_path / "lights.gpkg",
        [
            light(1, 500_010.0, 6_000_010.0, mounting_height=8.0),
            light(2, 500_040.0, 6_000_020.0, system_id="throw", heading=45.0, arm_length=2.0),
        ],
    )
    out = tmp_path / "e.tif"
    result = irradiance(
        lights,
        out,
        resolution=2.0,
        bounds=(500_000, 6_000_000, 500_060, 6_000_040),
        database=database,
        threshold=InfluenceThreshold("none"),
        tile_size=7,
        progress=False,
    )
    with rasterio.open(out) as dataset:
        data = dataset.read(1)
        assert dataset.descriptions == ("photopic",)
        assert dataset.units == ("lx",)
        assert dataset.crs.to_epsg() == 32633
        assert dataset.transform == Affine(2.0, 0, 500_000, 0, -2.0, 6_000_040)
        assert dataset.dtypes == ("float32",)
    assert result.n_lights == 2
    # Pixel (row 15, col 5) centre = (500011, 6000009): direct sum of both lights.
    x, y = 500_011.0, 6_000_009.0
    e1 = 1000 * (8.0 / np.sqrt(66)) ** 2 / 66  # cosine lobe: I = I0 cos V, cos i = cos V
    hx, hy = 500_040 + 2 * np.sin(np.pi / 4), 6_000_020 + 2 * np.cos(np.pi / 4)
    d = np.array([x - hx, y - hy, -10.0])
    rotation = luminaire_rotation(45.0)
    body = rotation.T @ d
    v = np.degrees(np.arccos(-body[2] / np.linalg.norm(d)))
    h = (np.degrees(np.arctan2(-body[0], body[1])) + 90) % 360
    e2 = asymmetric_lobe(np.array(v), np.array(h)) * 10 / np.linalg.norm(d) ** 3
    assert data[15, 5] == pytest.approx(e1 + e2, rel=1e-4)


def test_stage_default_extent_covers_the_regions(tmp_path: Path, database: FakeDatabase) -> None:
    lights = write_lights(tmp_path / "l.gpkg", [light(1, 1000.0, 2000.0)])
    result = irradiance(
        lights, tmp_path / "e.tif", resolution=1.0, database=database, progress=False
    )
    xmin, ymin, xmax, ymax = result.grid.bounds
    radius = influence_radius(
        flux_profile(IntensityTable.from_function(cosine_lobe())),
        np.array([10.0]),
        InfluenceThreshold(),
    )[0]
    assert xmin <= 1000 - radius and xmax >= 1000 + radius
    assert ymin <= 2000 - radius and ymax >= 2000 + radius


def test_unknown_system_ids_are_named(tmp_path: Path, database: FakeDatabase) -> None:
    lights = write_lights(
        tmp_path / "l.gpkg",
        [
            light(7, 0.0, 0.0),
            light(8, 10.0, 0.0, system_id="nope"),
            light(9, 5.0, 5.0, system_id=None),
        ],
    )
    with pytest.raises(InputError, match=r"lights \[8, 9\]"):
        irradiance(lights, tmp_path / "e.tif", resolution=1.0, database=database, progress=False)
    assert not (tmp_path / "e.tif").exists()
    with pytest.warns(DataQualityWarning, match=r"\[8, 9\].*dropped"):
        result = irradiance(
            lights,
            tmp_path / "e.tif",
            resolution=1.0,
            database=database,
            skip_unknown=True,
            progress=False,
        )
    assert result.n_lights == 1


def test_lights_outside_the_raster(tmp_path: Path, database: FakeDatabase) -> None:
    """A light just outside still lights the edge; one far away is ignored with a warning."""
    lights = write_lights(
        tmp_path / "l.gpkg",
        [
            light(1, -5.0, 50.0),
            light(2, 5000.0, 5000.0),
        ],
    )
    with pytest.warns(DataQualityWarning, match="1 of 2 lights light no pixel"):
        result = irradiance(
            lights,
            tmp_path / "e.tif",
            resolution=1.0,
            bounds=(0, 0, 100, 100),
            database=database,
            progress=False,
        )
    with rasterio.open(tmp_path / "e.tif") as dataset:
        data = dataset.read(1)
    assert data[50, 0] > data[50, 5] > 0
    assert result.n_lights == 1


def test_bad_inputs(tmp_path: Path, database: FakeDatabase) -> None:
    no_crs = write_lights(tmp_path / "nocrs.gpkg", [light(1, 0.0, 0.0)], crs=None)
    with pytest.raises(CRSError, match="no coordinate reference system"):
        irradiance(no_crs, tmp_path / "e.tif", resolution=1.0, database=database, progress=False)
    empty = tmp_path / "empty.gpkg"
    gpd.GeoDataFrame(
        {"light_id": [], "system_id": [], "heading": []}, geometry=[], crs=CRS
    ).to_file(empty, driver="GPKG")
    with pytest.raises(EmptyInputError):
        irradiance(empty, tmp_path / "e.tif", resolution=1.0, database=database, progress=False)
    good = write_lights(tmp_path / "l.gpkg", [light(1, 0.0, 0.0)])
    for resolution in (0.0, -1.0, float("nan")):
        with pytest.raises(InputError, match="resolution"):
            irradiance(
                good, tmp_path / "e.tif", resolution=resolution, database=database, progress=False
            )
    with pytest.raises(InputError, match="bounds"):
        irradiance(
            good,
            tmp_path / "e.tif",
            resolution=1.0,
            bounds=(10, 0, 0, 10),
            database=database,
            progress=False,
        )
    low = write_lights(tmp_path / "low.gpkg", [light(3, 0.0, 0.0, mounting_height=-1.0)])
    with pytest.raises(InputError, match=r"lights \[3\].*mounting_height"):
        irradiance(low, tmp_path / "e.tif", resolution=1.0, database=database, progress=False)
    assert not (tmp_path / "e.tif").exists()


def test_tiles_do_not_change_the_result(tmp_path: Path, database: FakeDatabase) -> None:
    rng = np.random.default_rng(3)
    rows = [
        light(
            i,
            *rng.uniform(0, 200, 2),
            system_id=["cone", "throw"][i % 2],
            heading=float(rng.uniform(0, 360)),
            tilt=float(rng.uniform(0, 20)),
        )
        for i in range(30)
    ]
    lights = write_lights(tmp_path / "l.gpkg", rows)
    outputs = []
    for tile_size in (37, 1000):
        out = tmp_path / f"e{tile_size}.tif"
        irradiance(
            lights,
            out,
            resolution=2.0,
            bounds=(0, 0, 200, 200),
            database=database,
            tile_size=tile_size,
            progress=False,
        )
        with rasterio.open(out) as dataset:
            outputs.append(dataset.read(1))
    np.testing.assert_array_equal(outputs[0], outputs[1])


def test_flat_dem_equals_no_dem(tmp_path: Path, database: FakeDatabase) -> None:
    lights = write_lights(tmp_path / "l.gpkg", [light(1, 50.0, 50.0, heading=30.0)])
    dem = tmp_path / "dem.tif"
    with rasterio.open(
        dem,
        "w",
        driver="GTiff",
        height=30,
        width=30,
        count=1,
        dtype="float32",
        crs=CRS,
        transform=Affine(5, 0, -10, 0, -5, 120),
    ) as dataset:
        dataset.write(np.full((1, 30, 30), 250.0, np.float32))
    outputs = []
    for kwargs in ({}, {"dem": dem}):
        out = tmp_path / f"e{len(kwargs)}.tif"
        irradiance(
            lights,
            out,
            resolution=1.0,
            bounds=(0, 0, 100, 100),
            database=database,
            progress=False,
            **kwargs,
        )
        with rasterio.open(out) as dataset:
            outputs.append(dataset.read(1))
    np.testing.assert_allclose(outputs[0], outputs[1], rtol=1e-6)
    with pytest.raises(InputError, match="DEM"):
        irradiance(
            lights,
            tmp_path / "x.tif",
            resolution=1.0,
            bounds=(0, 0, 500, 500),
            database=database,
            dem=dem,
            progress=False,
        )


def test_a_failing_tile_leaves_the_old_output(
    tmp_path: Path, database: FakeDatabase, monkeypatch: pytest.MonkeyPatch
) -> None:
    import nightlights.ground.illuminance as module

    lights = write_lights(tmp_path / "l.gpkg", [light(1, 50.0, 50.0), light(2, 150.0, 50.0)])
    out = tmp_path / "e.tif"
    out.write_bytes(b"previous result")
    original = module.window_and_pairs

    def flaky(*args, **kwargs):
        if kwargs["offset"][1] >= 100:
            raise MemoryError("tile east of x=100 failed")
        return original(*args, **kwargs)

    monkeypatch.setattr(module, "window_and_pairs", flaky)
    with pytest.raises(MemoryError):
        irradiance(
            lights,
            out,
            resolution=1.0,
            bounds=(0, 0, 200, 100),
            database=database,
            tile_size=50,
            progress=False,
        )
    assert out.read_bytes() == b"previous result"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.tif", "l.gpkg"]
