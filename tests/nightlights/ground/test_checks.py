"""Range checks, warnings, memory refusals and all-or-nothing outputs of the ground stages."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from pyproj import CRS as CRS_
from shapely.geometry import Point

from nightlights._resources import set_memory_limit
from nightlights.errors import CRSError, DataQualityWarning, InputError, OutputError, ResourceError
from nightlights.ground import InfluenceThreshold, emission, emission_from_viirs, irradiance
from nightlights.ground.checks import (
    IRRADIANCE_FIXED_BYTES,
    LOCAL_TILES_FIXED_BYTES,
    check_finite_raster,
    check_number,
    irradiance_memory,
    parse_crs,
    raster_header,
)
from nightlights.ground.upward import block_aggregate
from nightlights.io import Raster

CRS = "EPSG:3067"


def _lights(height: float | None = None) -> gpd.GeoDataFrame:
    frame = gpd.GeoDataFrame(
        {"system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
        geometry=[Point(0, 0), Point(20, 10)],
        crs=CRS,
    )
    if height is not None:
        frame["mounting_height"] = height
    return frame


@pytest.fixture
def limit() -> object:
    """Restore the process-wide memory limit after a test that sets it."""
    yield set_memory_limit
    set_memory_limit(None)


@pytest.fixture(scope="module")
def ground() -> Raster:
    return irradiance(_lights(), resolution=2.0, progress=False).raster


def _dnb(values: np.ndarray) -> Raster:
    return Raster(
        values[None].astype(float),
        Affine(450, 0, 500_000, 0, -450, 6_700_000),
        CRS_.from_epsg(32635),
        ("radiance",),
        ("nW cm-2 sr-1",),
    )


# --- helpers ---------------------------------------------------------------------------------


def test_parse_crs_names_the_option() -> None:
    assert parse_crs(None, option="crs") is None
    parsed = parse_crs("EPSG:4326", option="crs")
    assert parsed is not None and parsed.to_epsg() == 4326
    with pytest.raises(CRSError, match=r"target_crs='EPSG:99999999' is not a coordinate"):
        parse_crs("EPSG:99999999", option="target_crs")


@pytest.mark.parametrize("value", [math.nan, math.inf, -1.0, "x"])
def test_check_number_refuses_non_finite_and_negative(value: object) -> None:
    with pytest.raises(InputError, match="margin="):
        check_number(value, "margin", "m", minimum=0.0)
    assert check_number(math.inf, "max_radius", "m", positive=True, allow_inf=True) == math.inf


def test_check_finite_raster() -> None:
    check_finite_raster(np.array([[0.0, np.nan, 3.0]]), "r", "illuminance", "lx")
    with pytest.raises(InputError, match="1 pixels hold an infinite illuminance"):
        check_finite_raster(np.array([[0.0, np.inf]]), "r", "illuminance", "lx")
    with pytest.raises(InputError, match="every pixel is nodata"):
        check_finite_raster(np.full((2, 2), np.nan), "r", "illuminance", "lx")
    with pytest.raises(InputError, match="negative illuminance"):
        check_finite_raster(np.array([[-1.0, 1.0]]), "r", "illuminance", "lx")
    check_finite_raster(np.array([[-1.0]]), "r", "radiance", "nW", negative="ignore")


def test_memory_estimate_grows_with_pixels_bands_and_tiles() -> None:
    small = irradiance_memory(100, 100, 1, tile_size=64, workers=2, pairs=1e4)
    fixed = IRRADIANCE_FIXED_BYTES + LOCAL_TILES_FIXED_BYTES  # the first calls' memory
    big = irradiance_memory(1000, 1000, 1, tile_size=64, workers=2, pairs=1e4)
    assert big - fixed > 4 * (small - fixed)
    assert irradiance_memory(100, 100, 3, tile_size=64, workers=2, pairs=1e4) > small
    assert irradiance_memory(100, 100, 1, tile_size=64, workers=8, pairs=1e4) > small
    assert irradiance_memory(100, 100, 1, tile_size=64, workers=2, pairs=1e4, dem=True) > small


def test_a_streamed_raster_costs_its_tiles_not_its_pixels() -> None:
    def estimate(side: int, streamed: bool) -> float:
        return irradiance_memory(side, side, 1, tile_size=1024, workers=2, streamed=streamed)

    # 1e8 pixels held: 2.4 GB; streamed to a file: the first calls, the copy's cache, the
    # style's sample and the tiles in flight
    assert estimate(10_000, False) > 2.2e9
    assert estimate(10_000, True) < 0.3e9
    assert estimate(40_000, True) < 0.3e9  # and the task graph, 20 kB a tile
    # a tiny raster is below the cache: its copy costs what holding it would, and its style
    assert estimate(100, True) == pytest.approx(estimate(100, False) + 16 * 100 * 100)


def test_raster_header_reads_no_pixels(tmp_path: Path, ground: Raster) -> None:
    path = ground.write(tmp_path / "g.tif")
    header = raster_header(path)
    assert header is not None
    assert (header.count, header.rows, header.cols) == (ground.count, *ground.shape)
    assert header.crs is not None and "TM35FIN" in header.crs.name
    assert raster_header(tmp_path / "missing.tif") is None


def test_block_aggregate_with_a_factor_far_above_the_raster() -> None:
    values = np.arange(12.0).reshape(3, 4)
    coarse = block_aggregate(values, 10**6)  # no (1e6 x 1e6) padded copy
    assert coarse.shape == (1, 1)
    assert coarse[0, 0] * 1e12 == pytest.approx(values.sum())
    assert block_aggregate(values, 2).tolist() == [[2.5, 4.5], [8.5 / 4 * 2, 10.5 / 4 * 2]]


# --- irradiance -------------------------------------------------------------------------------


def test_huge_pixels_warn_that_the_raster_is_all_zero() -> None:
    with pytest.warns(DataQualityWarning, match=r"all zero: pixels of 1e\+06 m are larger"):
        result = irradiance(_lights(), resolution=1e6, progress=False)
    assert not result.raster.data.any()


def test_lights_too_dim_for_the_floor_warn_that_the_raster_is_all_zero() -> None:
    floor = InfluenceThreshold("floor", 1e6)
    with pytest.warns(DataQualityWarning, match=r"all zero: no light puts the 1e\+06 lx"):
        result = irradiance(_lights(), resolution=2.0, threshold=floor, progress=False)
    assert not result.raster.data.any()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        (
            "mounting_height",
            1e7,
            r"mounting_height \[10000000.0\] m; expected a number in \(0, 60\]",
        ),
        ("arm_length", -50.0, r"arm_length \[-50.0\] m; expected a number in \[0, 15\]"),
        ("tilt", 1e6, r"tilt \[1000000.0\] deg; expected a number in \[-90, 90\]"),
    ],
)
def test_irradiance_refuses_impossible_mounting(field: str, value: float, message: str) -> None:
    lights = _lights()
    lights[field] = [value, None]
    with pytest.raises(InputError, match=message):
        irradiance(lights, resolution=2.0, progress=False)


def test_unusual_mounting_from_the_layer_warns() -> None:
    with pytest.warns(DataQualityWarning, match=r"unusual mounting_height \[45.0, 45.0\] m"):
        irradiance(_lights(height=45.0), resolution=2.0, progress=False)


def test_coarse_pixels_warn_even_when_a_centre_is_lit() -> None:
    with pytest.warns(DataQualityWarning, match="larger than the lights' regions of influence"):
        irradiance(_lights(), resolution=150.0, bounds=(-75, -75, 75, 75), progress=False)


def test_a_normal_raster_gives_no_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        irradiance(_lights(), resolution=2.0, progress=False)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"margin": math.nan}, "margin=nan"),
        ({"margin": -5.0}, "margin=-5.0"),
        ({"crs": "not a crs"}, "crs='not a crs' is not a coordinate reference system"),
        ({"tile_size": 0}, "tile_size=0"),
        ({"resolution": math.inf}, "resolution=inf"),
    ],
)
def test_irradiance_refuses_bad_options(options: dict[str, object], message: str) -> None:
    kwargs: dict[str, object] = {"resolution": 2.0, "progress": False, **options}
    with pytest.raises(InputError, match=message):
        irradiance(_lights(), **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize("field", ["mounting_height", "arm_length", "tilt", "heading"])
def test_irradiance_refuses_infinite_light_fields(field: str) -> None:
    lights = _lights()
    lights[field] = [math.inf, 1.0]
    with pytest.raises(InputError, match=f"have {field} \\[inf\\]"):
        irradiance(lights, resolution=2.0, progress=False)


def test_irradiance_refuses_a_raster_over_the_memory_limit(limit, tmp_path: Path) -> None:
    limit("64M")
    out = tmp_path / "e.tif"
    with pytest.raises(ResourceError, match=r"x 1 band needs about .* use a coarser resolution="):
        irradiance(_lights(), resolution=0.01, progress=False)
    # written to a file the raster is streamed, never held: its tiles are what is too large
    with pytest.raises(ResourceError, match=r"x 1 band needs about .* use a smaller tile_size="):
        irradiance(_lights(), out, resolution=0.01, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_irradiance_checks_the_output_before_computing(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="does not exist"):
        irradiance(_lights(), tmp_path / "no" / "e.tif", resolution=2.0, progress=False)


# --- emission ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (np.inf, "1 pixels hold an infinite illuminance"),
        (-2.0, "1 pixels hold a negative illuminance"),
    ],
)
def test_emission_refuses_bad_illuminance(ground: Raster, value: float, message: str) -> None:
    data = ground.data.copy()
    data[0, 3, 3] = value
    bad = Raster(data, ground.transform, ground.crs, ground.descriptions, ground.units)
    with pytest.raises(InputError, match=message):
        emission(bad, resolution=20.0, albedo=0.15)


def test_emission_refuses_an_all_nodata_raster(ground: Raster) -> None:
    empty = Raster(
        np.full_like(ground.data, np.nan), ground.transform, ground.crs, ground.descriptions
    )
    with pytest.raises(InputError, match="every pixel is nodata"):
        emission(empty, resolution=20.0, albedo=0.15)


@pytest.mark.parametrize("albedo", [math.nan, math.inf, -0.1, 1.5])
def test_emission_refuses_albedo_outside_0_1(ground: Raster, albedo: float) -> None:
    with pytest.raises(InputError, match="albedo="):
        emission(ground, resolution=20.0, albedo=albedo)


def test_emission_at_a_resolution_far_above_the_raster(ground: Raster) -> None:
    small = emission(ground, resolution=20.0, albedo=0.2)
    huge = emission(ground, resolution=2e6, albedo=0.2)
    assert huge.raster.shape == (1, 1)
    assert huge.total_flux["reflected"] == pytest.approx(small.total_flux["reflected"], 1e-5)


def test_emission_refuses_a_garbage_crs(ground: Raster) -> None:
    with pytest.raises(CRSError, match="crs='garbage'"):
        emission(ground, lights=_lights(), resolution=20.0, albedo=0.2, crs="garbage")


def test_emission_refuses_an_input_over_the_memory_limit(limit, ground: Raster) -> None:
    limit("1K")
    with pytest.raises(ResourceError, match="emission from in-memory irradiance raster"):
        emission(ground, resolution=20.0, albedo=0.2)


# --- VIIRS ------------------------------------------------------------------------------------


def test_viirs_refuses_an_output_grid_over_the_memory_limit(limit, tmp_path: Path) -> None:
    limit("1G")
    out = tmp_path / "v.tif"
    with pytest.raises(
        ResourceError, match=r"cells from in-memory VIIRS raster needs about [0-9.]+ [GT]iB"
    ):
        emission_from_viirs(_dnb(np.full((4, 4), 20.0)), out, resolution=0.01)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("values", "message"),
    [
        (np.array([[1.0, np.inf], [1.0, 1.0]]), "infinite radiance"),
        (np.full((2, 2), np.nan), "every pixel is nodata"),
    ],
)
def test_viirs_refuses_bad_radiance(values: np.ndarray, message: str) -> None:
    with pytest.raises(InputError, match=message):
        emission_from_viirs(_dnb(values))


def test_viirs_refuses_a_resolution_above_the_extent() -> None:
    with pytest.raises(InputError, match="resolution=1e\\+07 m is larger than the raster's"):
        emission_from_viirs(_dnb(np.full((4, 4), 20.0)), resolution=1e7)


def test_viirs_refuses_a_garbage_target_crs() -> None:
    with pytest.raises(CRSError, match="target_crs='nonsense'"):
        emission_from_viirs(_dnb(np.full((4, 4), 20.0)), target_crs="nonsense")
