"""``emission`` (irradiance -> upward emission) window by window: equal to the whole raster
(albedo x E block sums, an albedo raster resampled bilinearly, uplight per cell), the checks of
the whole raster, atomic output, a memory estimate bounded by the window."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS
from shapely.geometry import Point

import nightlights.ground._emission_run as emission_run
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.ground import RasterGrid, block_aggregate, deposit_flux, emission
from nightlights.ground._windows import ArraySource
from nightlights.io import Raster, raster_on_grid

EPSG = "EPSG:32633"
#: The irradiance grid of the tests: 1 m pixels.
X0, Y0 = 500_000.0, 6_700_000.0
TRANSFORM = Affine(1.0, 0, X0, 0, -1.0, Y0)
#: Irradiance pixels per emission cell.
FACTOR = 3


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
        # a 20 cd isotropic part: 40 pi lm of uplight per light
        return np.where(v < 90, 1000 * np.cos(np.radians(v)), 0.0) + 20.0 + 0 * horizontal


class Database:
    def get(self, system_id):
        return System()

    def photometry(self, system_id):
        return Photometry()


def _ground(rows: int = 50, cols: int = 41, seed: int = 0) -> np.ndarray:
    """Pools of light over a dim background, a few nodata pixels; float32 values."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:rows, 0:cols]
    values = 0.2 * rng.gamma(2.0, 1.0, (rows, cols))
    for cy, cx in ((8, 8), (20, 21), (37, 11), (44, 35)):  # pools across window edges
        values += 40.0 * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / 30.0)
    values[rng.random((rows, cols)) < 0.02] = np.nan
    return values.astype(np.float32).astype(np.float64)


def _irradiance_file(path: Path, photopic: np.ndarray) -> Path:
    """A two-band irradiance file (scotopic first, photopic second), nodata declared as -1."""
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=photopic.shape[0],
        width=photopic.shape[1],
        count=2,
        dtype="float32",
        crs=EPSG,
        transform=TRANSFORM,
        nodata=-1.0,
    ) as out:
        values = np.where(np.isnan(photopic), -1.0, photopic)
        out.write(np.stack([0.4 * values, values]).astype(np.float32))
        for band, name in ((1, "scotopic"), (2, "photopic")):
            out.set_band_description(band, name)
            out.update_tags(band, sensor=name)
    return path


def _albedo_file(path: Path, transform: Affine, shape: tuple[int, int], crs: str) -> Path:
    rng = np.random.default_rng(7)
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=shape[0],
        width=shape[1],
        count=1,
        dtype="float32",
        crs=crs,
        transform=transform,
    ) as out:
        out.write(rng.uniform(0.05, 0.3, shape).astype(np.float32), 1)
    return path


def _lights(path: Path) -> Path:
    """Lights in cells on window edges (windows of 4 cells of 3 m), one outside the grid."""
    offsets = [(0.5, 0.5), (11.9, 11.9), (12.1, 12.1), (23.5, 23.5), (40.9, 49.8)]
    offsets += [(11.0, 40.0), (11.2, 39.6), (400.0, -100.0)]
    gpd.GeoDataFrame(
        {"system_id": ["lamp"] * len(offsets), "heading": 0.0},
        geometry=[Point(X0 + dx, Y0 - dy) for dx, dy in offsets],
        crs=EPSG,
    ).to_file(path, driver="GPKG")
    return path


def _reference(ground: np.ndarray, albedo: float | np.ndarray, lights: Path) -> np.ndarray:
    """The whole raster at once: albedo x E block sums and the lights' uplight per cell."""
    reflected = block_aggregate(albedo * ground, FACTOR)
    rows, cols = reflected.shape
    grid = RasterGrid(TRANSFORM.c, TRANSFORM.f, float(FACTOR), rows, cols)
    frame = gpd.read_file(lights)
    from nightlights.ground import resolve_luminaires

    luminaires = resolve_luminaires(frame, Database())
    uplight, _ = deposit_flux(
        luminaires.light_point[:, 0], luminaires.light_point[:, 1], luminaires.upward_flux(), grid
    )
    return np.stack([reflected, uplight])


def _albedo_cases(folder: Path) -> dict[str, tuple[object, float | None]]:
    """Albedo inputs and the tolerance of their windowed result against the whole grid."""
    return {
        "uniform": (0.15, 0.0),
        # coarser, same CRS: bilinear from 4 albedo pixels (halo of the warper)
        "coarse": (
            _albedo_file(
                folder / "coarse.tif", Affine(5.0, 0, X0 - 5, 0, -5.0, Y0 + 5), (13, 11), EPSG
            ),
            0.0,
        ),
        # finer, same CRS: GDAL stretches the bilinear kernel over 8 x 8 albedo pixels, so
        # that it reaches 4 albedo pixels beyond a read's footprint
        "fine": (
            _albedo_file(
                folder / "fine.tif", Affine(0.125, 0, X0 - 1, 0, -0.125, Y0 + 1), (416, 344), EPSG
            ),
            0.0,
        ),
        # geographic, as land-cover products are: pixels of about 1 m
        "geographic": (
            _albedo_file(
                folder / "geographic.tif",
                Affine(2e-5, 0, 14.9999, 0, -1e-5, 60.4364),
                (80, 60),
                "EPSG:4326",
            ),
            1e-4,
        ),
    }


@pytest.mark.parametrize("albedo_case", ["uniform", "coarse", "fine", "geographic"])
@pytest.mark.parametrize(
    "read_pixels",
    [
        1 << 22,  # one read per window
        40,  # reads of 2 x 2 cells
        4,  # reads of 2 x 2 pixels: parts of a cell summed into it
    ],
)
def test_windowed_file_equals_the_whole_raster(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, albedo_case: str, read_pixels: int
) -> None:
    ground = _ground()
    source = _irradiance_file(tmp_path / "ground.tif", ground)
    lights = _lights(tmp_path / "lights.gpkg")
    albedo, tolerance = _albedo_cases(tmp_path)[albedo_case]
    options = {"lights": lights, "resolution": float(FACTOR), "database": Database()}
    with pytest.warns(DataQualityWarning, match="1 lights"):
        whole = emission(Raster.read(source), albedo=albedo, progress=False, **options)
    monkeypatch.setattr(emission_run, "WINDOW_CELLS", 4)
    monkeypatch.setattr(emission_run, "READ_PIXELS", read_pixels)
    out = tmp_path / "up.tif"
    with pytest.warns(DataQualityWarning, match="1 lights"):
        streamed = emission(source, out, albedo=albedo, progress=False, **options)
    # the whole raster at once, as the stage computed it before it had windows
    if isinstance(albedo, float):
        grid = albedo
    else:
        grid = raster_on_grid(
            albedo,
            transform=TRANSFORM,
            shape=ground.shape,
            crs=CRS.from_user_input(EPSG),
            name="albedo raster",
        )
    expected = _reference(ground, grid, lights).astype(np.float32)
    with rasterio.open(out) as dataset:
        values = dataset.read()
        assert dataset.descriptions == ("reflected", "uplight")
        assert dataset.transform == whole.transform == streamed.transform
        assert dataset.shape == whole.shape == (17, 14)
        tags = dataset.tags()
    assert whole.shape[0] > 4 * 4  # many windows, ragged at the edges
    np.testing.assert_allclose(values, expected, rtol=tolerance + 1e-6, atol=1e-6)
    np.testing.assert_allclose(whole.raster.data, values, rtol=tolerance + 1e-6, atol=1e-6)
    assert expected[1].sum() > 0 and np.count_nonzero(expected[1]) == 6
    area = float(FACTOR) ** 2
    for band, name in enumerate(("reflected", "uplight")):
        total = float(expected[band].astype(float).sum() * area)
        assert streamed.total_flux[name] == pytest.approx(total, rel=tolerance + 1e-6)
        assert whole.total_flux[name] == pytest.approx(total, rel=tolerance + 1e-6)
        assert float(tags[f"total_{name}_lm"]) == pytest.approx(streamed.total_flux[name])
    # the streamed result holds no raster; it reads the file when asked
    assert streamed._in_memory is None and whole._in_memory is not None
    np.testing.assert_array_equal(streamed.raster.data, values)
    assert streamed.crs == whole.crs and tags["albedo"] == str(albedo)


def test_whole_cells_sum_as_the_whole_raster(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Reads of whole cells add the same numbers in the same order: equal to the last bit."""
    ground = _ground(seed=3)
    expected = block_aggregate(0.2 * ground, FACTOR)
    monkeypatch.setattr(emission_run, "WINDOW_CELLS", 5)
    monkeypatch.setattr(emission_run, "READ_PIXELS", 2 * FACTOR * 2 * FACTOR)
    source = ArraySource(ground, TRANSFORM, CRS.from_user_input(EPSG))
    grid, factor = emission_run.output_grid(source, "ground", 3.0)
    albedo = emission_run.Albedo("albedo", 0.2)
    run = emission_run.EmissionRun("ground", source, factor, grid, albedo, 5, progress=False)
    out = np.zeros((2, *expected.shape))

    def sink(values: np.ndarray, row: int, col: int) -> None:
        out[:, row : row + values.shape[1], col : col + values.shape[2]] = values

    run.run(sink)
    np.testing.assert_array_equal(out[0], expected)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (np.inf, "1 pixels hold an infinite illuminance"),
        (-2.0, "1 pixels hold a negative illuminance"),
        (np.nan, "every pixel is nodata"),
    ],
)
def test_the_checks_are_those_of_the_whole_raster(
    value: float, message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    values = np.full((12, 20), np.nan if np.isnan(value) else 1.0)
    values[9, 3] = value  # in the last row of windows
    path = Raster(values[None], TRANSFORM, EPSG, ("photopic",)).write(tmp_path / "bad.tif")
    with pytest.raises(InputError, match=message):
        emission(Raster.read(path), resolution=3.0, albedo=0.2, progress=False)
    monkeypatch.setattr(emission_run, "WINDOW_CELLS", 2)
    monkeypatch.setattr(emission_run, "READ_PIXELS", 9)
    out = tmp_path / "up.tif"
    with pytest.raises(InputError, match=message):
        emission(path, out, resolution=3.0, albedo=0.2, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.qml", "bad.tif"]


def test_an_albedo_raster_is_checked_as_a_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ground = _ground()
    source = _irradiance_file(tmp_path / "ground.tif", ground)
    # covers the top 30 rows only
    partial = _albedo_file(tmp_path / "part.tif", TRANSFORM, (30, 41), EPSG)
    with pytest.raises(InputError) as whole:
        emission(Raster.read(source), resolution=3.0, albedo=partial, progress=False)
    monkeypatch.setattr(emission_run, "WINDOW_CELLS", 4)
    monkeypatch.setattr(emission_run, "READ_PIXELS", 40)
    with pytest.raises(InputError) as windowed:
        emission(source, tmp_path / "up.tif", resolution=3.0, albedo=partial, progress=False)
    assert str(windowed.value) == str(whole.value)
    assert "pixels of the grid" in str(whole.value)
    bright = Raster(np.full((1, 60, 50), 0.2), Affine(1.0, 0, X0 - 5, 0, -1.0, Y0 + 5), EPSG)
    bright.data[0, 40, 30] = 1.5
    with pytest.raises(InputError, match=r"albedo values span 0\.2\.\.1\.\d+; expected \[0, 1\]"):
        emission(source, tmp_path / "up.tif", resolution=3.0, albedo=bright, progress=False)
    assert not (tmp_path / "up.tif").exists()


def test_a_geographic_irradiance_raster_is_refused(tmp_path: Path) -> None:
    raster = Raster(
        np.ones((1, 4, 4)), Affine(0.001, 0, 24, 0, -0.001, 60), "EPSG:4326", ("photopic",)
    )
    with pytest.raises(CRSError, match="geographic grid"):
        emission(raster, resolution=0.002, albedo=0.2, progress=False)


def test_a_failure_midway_leaves_no_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = _irradiance_file(tmp_path / "ground.tif", _ground())
    out = tmp_path / "up.tif"
    out.write_bytes(b"the previous output")
    monkeypatch.setattr(emission_run, "WINDOW_CELLS", 4)
    computed = []
    real = emission_run.EmissionRun.reflected

    def failing(self, window):
        if len(computed) == 7:
            raise RuntimeError("disk gone")
        computed.append(window)
        return real(self, window)

    monkeypatch.setattr(emission_run.EmissionRun, "reflected", failing)
    with pytest.raises(RuntimeError, match="disk gone"):
        emission(source, out, resolution=3.0, albedo=0.2, progress=False)
    assert len(computed) == 7  # 7 of 20 windows were written
    assert out.read_bytes() == b"the previous output"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ground.tif", "up.tif"]


class _Header:
    """A band of any size, never read: for the memory estimate."""

    def __init__(self, rows: int, cols: int) -> None:
        self.shape = (rows, cols)
        self.transform = Affine(1.0, 0, 0, 0, -1.0, 0)
        self.crs = CRS.from_epsg(3067)

    def read(self, row: int, col: int, rows: int, cols: int) -> np.ndarray:
        raise AssertionError("the estimate reads nothing")


@pytest.mark.parametrize("factor", [1, 10, 5000])
def test_memory_estimate_is_bounded_by_the_window(
    monkeypatch: pytest.MonkeyPatch, factor: int
) -> None:
    estimates = []
    monkeypatch.setattr(
        emission_run, "check_memory", lambda estimate, what, option=None: estimates.append(estimate)
    )
    for size in (10_000, 100_000, 400_000):  # 10^8 to 1.6 x 10^11 irradiance pixels
        source = _Header(size, size)
        grid, _ = emission_run.output_grid(source, "ground", float(factor))
        albedo = emission_run.Albedo("albedo", 0.15)
        run = emission_run.EmissionRun("ground", source, factor, grid, albedo, 2048)
        emission_run.check_emission_memory(run, in_memory=False)
        emission_run.check_emission_memory(run, in_memory=True)
    _, small_whole, medium_streamed, _, large_streamed, large_whole = estimates
    # a read, a window and the writer, whatever the raster's size
    assert large_streamed < 0.6 * 2**30
    if factor < 100:  # windows and the writer's cache full from 10^10 pixels on
        assert large_streamed == pytest.approx(medium_streamed, rel=1e-6)
    if factor == 1:
        assert small_whole > 3 * 2**30  # the output held in memory
        assert large_whole > 100 * 2**30
