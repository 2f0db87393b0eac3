"""``emission_from_viirs`` window by window: equal to the whole raster, flux conserved, a wide
geographic raster kept on its grid with geodesic areas, checks counted once, atomic output."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS, Geod

import nightlights.ground._viirs_run as viirs_run
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.ground import _viirs_windows
from nightlights.ground.upward import (
    FLUX_TAG,
    GRID_TAG,
    dnb_luminous_efficacy,
    emission_from_viirs,
    geographic_cell_areas,
    viirs_radiance_to_flux_density,
)
from nightlights.io import Raster

ARCSEC15 = 15 / 3600


def _radiance(
    rows: int, cols: int, transform: Affine, crs: str, seed: int = 0, nodata: float = 0.02
) -> Raster:
    """Lognormal lights over noise about zero (some negative), a few nodata pixels."""
    rng = np.random.default_rng(seed)
    values = rng.normal(0.0, 0.3, (rows, cols))
    lit = rng.random((rows, cols)) < 0.2
    values[lit] += rng.lognormal(2.0, 1.0, int(lit.sum()))
    values[rng.random((rows, cols)) < nodata] = np.nan
    # float32 values: the file holds exactly what the in-memory raster holds
    values = values.astype(np.float32).astype(np.float64)
    return Raster(values[None], transform, crs, ("radiance",), ("nW cm-2 sr-1",))


def _read(path: Path) -> tuple[np.ndarray, Affine, str, dict[str, str]]:
    with rasterio.open(path) as dataset:
        return dataset.read(1).astype(float), dataset.transform, dataset.crs, dataset.tags()


@pytest.fixture
def tiny_windows(monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows of 7 x 7 cells: a small raster is cut into many, with ragged edges."""
    monkeypatch.setattr(_viirs_windows, "WINDOW_CELLS", 7)


@pytest.mark.parametrize(
    ("transform", "crs", "resolution"),
    [
        # kept grid: a projected raster at its own resolution
        (Affine(450, 0, 500_000, 0, -450, 6_700_000), "EPSG:32635", None),
        # reprojected: a geographic city raster to its UTM zone, native and coarser cells
        (Affine(ARCSEC15, 0, 24.9, 0, -ARCSEC15, 60.3), "EPSG:4326", None),
        (Affine(ARCSEC15, 0, 24.9, 0, -ARCSEC15, 60.3), "EPSG:4326", 1000.0),
    ],
)
def test_windowed_file_equals_the_raster_in_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, transform: Affine, crs: str, resolution
) -> None:
    radiance = _radiance(40, 53, transform, crs)
    source = radiance.write(tmp_path / "dnb.tif")
    out = tmp_path / "up.tif"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)  # the negative radiance
        whole = emission_from_viirs(radiance, resolution=resolution, progress=False)
        monkeypatch.setattr(_viirs_windows, "WINDOW_CELLS", 7)
        streamed = emission_from_viirs(source, out, resolution=resolution, progress=False)
        windowed = emission_from_viirs(radiance, resolution=resolution, progress=False)
    assert whole.shape[0] > 7 and whole.shape[1] > 7  # many windows
    values, out_transform, out_crs, tags = _read(out)
    assert out_transform == whole.transform == windowed.transform and out_crs == whole.crs
    # the file and the in-memory raster of the same windows: the same float32 numbers
    np.testing.assert_array_equal(values, windowed.raster.data[0])
    assert streamed.total_flux["upward"] == pytest.approx(windowed.total_flux["upward"], rel=1e-12)
    assert float(tags["total_upward_lm"]) == pytest.approx(streamed.total_flux["upward"])
    # the streamed result holds no raster; it reads the file when asked
    assert streamed._in_memory is None
    np.testing.assert_array_equal(streamed.raster.data[0], values)
    # many windows against one
    expected = whole.raster.data[0]
    np.testing.assert_array_equal(np.isnan(values), np.isnan(expected))
    assert streamed.total_flux["upward"] == pytest.approx(whole.total_flux["upward"], rel=1e-4)
    if resolution is None and crs == "EPSG:32635":
        np.testing.assert_array_equal(values, expected)  # a kept grid: the same pixels
    else:
        # GDAL's average footprint of a cell follows the scale of the chunk it warps: cells
        # differ by a few tenths of a per cent between window sizes, flux by less than 1e-4
        relative = np.abs(values - expected) / expected
        assert np.nanmedian(relative) < 0.02


def test_reprojection_conserves_flux(tmp_path: Path) -> None:
    # Radiance over a geographic city raster: its flux is density x geodesic cell area.
    transform = Affine(ARCSEC15, 0, 24.6, 0, -ARCSEC15, 60.4)
    # no nodata: GDAL's average fills a nodata pixel with its neighbours' mean
    radiance = _radiance(120, 150, transform, "EPSG:4326", seed=3, nodata=0.0)
    # a dark border: the average gives a cell the raster covers in part the mean of that part
    radiance.data[0, :10], radiance.data[0, -10:] = 0.0, 0.0
    radiance.data[0, :, :10], radiance.data[0, :, -10:] = 0.0, 0.0
    clean = np.clip(radiance.data[0], 0, None)
    efficacy = dnb_luminous_efficacy("LED_4000K")
    density = viirs_radiance_to_flux_density(clean, efficacy)
    areas = geographic_cell_areas(transform, 120, "EPSG:4326")
    geodesic = float(density.sum(axis=1) @ areas)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        for resolution in (None, 1500.0):
            result = emission_from_viirs(radiance, resolution=resolution, progress=False)
            assert result.crs.to_epsg() == 32635
            # the projected total differs by UTM's area scale (k^2 = 0.9995 at 25 E, 60 N
            # in zone 35, central meridian 27 E) and the average's overlap weights: -0.11 %
            # at the native cell size, -0.25 % at 1500 m
            assert result.total_flux["upward"] == pytest.approx(geodesic, rel=3e-3)


def test_a_wide_geographic_mosaic_keeps_its_grid(tmp_path: Path) -> None:
    # 70 deg of longitude x 10 deg of latitude in half-degree cells
    step = 0.5
    transform = Affine(step, 0, 10.0, 0, -step, 65.0)
    radiance = _radiance(20, 140, transform, "EPSG:4326", seed=1)
    source = radiance.write(tmp_path / "wide.tif")
    out = tmp_path / "up.tif"
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)  # no zone-span warning
        warnings.filterwarnings("ignore", "Resulting shape", DataQualityWarning)
        warnings.filterwarnings("ignore", ".*negative radiance", DataQualityWarning)
        result = emission_from_viirs(source, out, progress=False)
    assert result.crs.to_epsg() == 4326 and result.geographic
    values, out_transform, crs, tags = _read(out)
    assert crs.to_epsg() == 4326 and out_transform == transform
    assert tags[GRID_TAG] == "geographic" and tags[FLUX_TAG] == "density"
    # the same flux density as a projected grid holds [lm m-2]
    expected = viirs_radiance_to_flux_density(
        np.clip(radiance.data[0], 0, None), dnb_luminous_efficacy("LED_4000K")
    )
    np.testing.assert_allclose(values, expected, rtol=2**-23, equal_nan=True)
    # total = sum of density x each cell's geodesic area, the areas from pyproj.Geod: the
    # polygon of a cell with its parallels densified (a geodesic is no parallel)
    geod = Geod(ellps="WGS84")
    along = np.linspace(10.0, 10.5, 400)
    geod_areas = []
    for row in range(20):
        north, south = 65.0 - step * row, 65.0 - step * (row + 1)
        lons = np.concatenate([along, along[::-1]])
        lats = np.concatenate([np.full(400, south), np.full(400, north)])
        area, _ = geod.polygon_area_perimeter(lons, lats)
        geod_areas.append(abs(area))
    np.testing.assert_allclose(
        geographic_cell_areas(transform, 20, "EPSG:4326"), geod_areas, rtol=1e-6
    )
    total = float(np.nansum(values.astype(np.float64), axis=1) @ np.asarray(geod_areas))
    assert result.total_flux["upward"] == pytest.approx(total, rel=1e-6)
    # a resolution in metres has no meaning on a geographic grid; target_crs= projects
    with pytest.raises(InputError, match="keeps its geographic grid"):
        emission_from_viirs(source, resolution=1000.0, progress=False)
    with pytest.warns(DataQualityWarning, match="more than one UTM zone"):
        forced = emission_from_viirs(
            source, target_crs="EPSG:3035", resolution=50_000.0, progress=False
        )
    assert forced.crs.to_epsg() == 3035


def test_geographic_cell_areas() -> None:
    transform = Affine(1.0, 0, 0, 0, -1.0, 90.0)
    areas = geographic_cell_areas(transform, 180, "EPSG:4326")
    # 360 columns of every row cover the ellipsoid: 4 pi R_q^2, R_q = 6371007.2 m (WGS84)
    assert 360 * areas.sum() == pytest.approx(4 * np.pi * 6371007.18**2, rel=1e-9)
    np.testing.assert_allclose(areas, areas[::-1])  # symmetric about the equator
    sphere = geographic_cell_areas(transform, 180, "+proj=longlat +R=6371000 +no_defs")
    edges = np.radians(90.0 - np.arange(181.0))
    np.testing.assert_allclose(
        sphere, 6371000.0**2 * np.radians(1.0) * -np.diff(np.sin(edges)), rtol=1e-12
    )
    with pytest.raises(CRSError, match="geographic CRS"):
        geographic_cell_areas(transform, 3, "EPSG:32635")


def test_the_checks_warn_once_for_the_whole_raster(tmp_path: Path, tiny_windows: None) -> None:
    transform = Affine(450, 0, 500_000, 0, -450, 6_700_000)
    values = np.full((30, 30), 5.0)
    values[::4, ::5] = 65535.0  # an undeclared fill value in every window
    values[1::6, 2::4] = -1.5  # negative noise
    values[3, 3] = values[25, 28] = 2e4  # implausibly bright, two windows apart
    source = Raster(values[None], transform, "EPSG:32635", ("radiance",)).write(
        tmp_path / "dnb.tif"
    )
    for target in (None, "EPSG:3067"):  # kept grid, and reprojected (checked in a first pass)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            emission_from_viirs(source, target_crs=target, progress=False)
        quality = [w for w in caught if w.category is DataQualityWarning]
        messages = [str(w.message) for w in quality]
        assert len(messages) == 3, messages
        fills, high, negative = messages
        assert f"{(values == 65535).sum()} pixels hold a common fill value" in fills
        assert f"65535 x{(values == 65535).sum()}" in fills
        assert "2 pixels hold radiances above" in high and "20000 x2" in high
        assert f"{(values == -1.5).sum()} pixels have negative radiance" in negative
        assert [w.filename for w in quality] == [__file__] * 3  # pointed at the caller


def test_refused_before_writing(tmp_path: Path, tiny_windows: None) -> None:
    transform = Affine(450, 0, 500_000, 0, -450, 6_700_000)
    values = np.full((20, 20), 5.0)
    values[15, 15] = np.inf
    source = Raster(values[None], transform, "EPSG:32635", ("radiance",)).write(
        tmp_path / "dnb.tif"
    )
    out = tmp_path / "up.tif"
    with pytest.raises(InputError, match="1 pixels hold an infinite radiance"):
        emission_from_viirs(source, out, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dnb.qml", "dnb.tif"]


def test_a_failure_midway_leaves_no_output(
    tmp_path: Path, tiny_windows: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    transform = Affine(450, 0, 500_000, 0, -450, 6_700_000)
    source = _radiance(30, 30, transform, "EPSG:32635").write(tmp_path / "dnb.tif")
    out = tmp_path / "up.tif"
    out.write_bytes(b"the previous output")
    computed = []
    real = viirs_run.window_density

    def failing(*args, **kwargs):
        if len(computed) == 5:
            raise RuntimeError("disk gone")
        computed.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(viirs_run, "window_density", failing)
    with pytest.raises(RuntimeError, match="disk gone"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DataQualityWarning)
            emission_from_viirs(source, out, progress=False)
    assert len(computed) == 5  # 5 of 25 windows were written
    assert out.read_bytes() == b"the previous output"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dnb.qml", "dnb.tif", "up.tif"]


def test_memory_estimate_is_bounded_by_the_window(monkeypatch: pytest.MonkeyPatch) -> None:
    estimates = []
    monkeypatch.setattr(
        viirs_run, "check_memory", lambda estimate, what, option=None: estimates.append(estimate)
    )
    transform = Affine(ARCSEC15, 0, 70, 0, -ARCSEC15, 53)
    national = viirs_run.OutputGrid(transform, 8400, 14400, CRS(4326))
    for in_memory in (False, True):
        viirs_run.check_viirs_memory(
            (8400, 14400), national, "mosaic", kept=True, in_memory=in_memory
        )
    streamed, whole = estimates
    assert streamed < 0.5 * 2**30  # a window and the writer, whatever the raster's size
    assert whole > 3 * 2**30  # the float64 raster held in memory
