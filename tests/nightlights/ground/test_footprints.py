"""Obstacle rasters from building footprints: hand-computed cells, missing heights, bad input."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from shapely.geometry import box

from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.ground.footprints import land_use_obstacles, obstacle_rasters
from nightlights.ground.obstacles import ObstacleProperties
from nightlights.io import Raster

CRS = "EPSG:32635"


def _frame(**fields: list[object]) -> gpd.GeoDataFrame:
    geometry = fields.pop("geometry")
    return gpd.GeoDataFrame(fields, geometry=geometry, crs=CRS)


def test_two_buildings_in_one_cell_by_hand() -> None:
    # A: 20 x 20 m, 10 m high; B: 20 x 40 m, 2 levels of 3 m; one 40 m cell of 1600 m2.
    frame = _frame(
        height=[10.0, None], levels=[None, 2], geometry=[box(0, 0, 20, 20), box(20, 0, 40, 40)]
    )
    out = obstacle_rasters(frame, resolution=40.0)
    assert out.shape == (1, 1) and out.descriptions == ("height", "spacing", "filling")
    h, d, f = (float(out.data[b, 0, 0]) for b in range(3))
    assert h == pytest.approx((400 * 10 + 800 * 6) / 1200)
    assert f == pytest.approx(1200 / 1600)
    # Two buildings: lattice pitch sqrt(1600 / 2), block side sqrt(1200 / 2).
    assert d == pytest.approx(math.sqrt(800) - math.sqrt(600))


def test_a_building_over_two_cells_counts_half_in_each() -> None:
    frame = _frame(height=[12.0], geometry=[box(20, 0, 60, 40)])
    out = obstacle_rasters(frame, resolution=40.0)
    assert out.shape == (1, 2)
    np.testing.assert_allclose(out.data[0], [[12.0, 12.0]])
    np.testing.assert_allclose(out.data[2], [[0.5, 0.5]])
    # n = 0.5 building per cell: pitch sqrt(1600 / 0.5), side sqrt(800 / 0.5).
    np.testing.assert_allclose(out.data[1], [[math.sqrt(3200) - math.sqrt(1600)] * 2])


def test_empty_cells_have_no_obstacle_and_the_reference_grid_is_taken(tmp_path: Path) -> None:
    reference = Raster(np.zeros((1, 3, 3)), Affine(40, 0, -40, 0, -40, 80), CRS)
    frame = _frame(height=[9.0], geometry=[box(5, 5, 35, 35)])
    out = obstacle_rasters(frame, reference=reference, output=tmp_path / "obstacles.tif")
    assert out.shape == (3, 3)
    assert out.data[0, 1, 1] == pytest.approx(9.0) and out.data[2, 1, 1] == pytest.approx(
        900 / 1600
    )
    others = np.ones((3, 3), bool)
    others[1, 1] = False
    assert np.all(out.data[0][others] == 0) and np.all(out.data[2][others] == 0)
    assert np.all(np.isnan(out.data[1][others]))
    written = Raster.read(tmp_path / "obstacles.tif")
    assert written.descriptions == ("height", "spacing", "filling")
    np.testing.assert_allclose(written.data, out.data.astype(np.float32), equal_nan=True)


def test_footprints_without_height_are_warned_and_skipped_or_given_a_default() -> None:
    frame = _frame(height=[10.0, None], geometry=[box(0, 0, 20, 40), box(20, 0, 40, 40)])
    with pytest.warns(
        DataQualityWarning, match="1 of 2 footprints have no height or levels; skipped"
    ):
        skipped = obstacle_rasters(frame, resolution=40.0)
    assert float(skipped.data[2, 0, 0]) == pytest.approx(0.5)
    with pytest.warns(DataQualityWarning, match="given 4 m"):
        given = obstacle_rasters(frame, resolution=40.0, default_height=4.0)
    assert float(given.data[0, 0, 0]) == pytest.approx(7.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        obstacle_rasters(frame.iloc[:1], resolution=40.0)


def test_bad_input_is_refused() -> None:
    frame = _frame(height=[-3.0], geometry=[box(0, 0, 20, 20)])
    with pytest.raises(
        InputError, match=r"in-memory footprints feature 0: height -3\.0; expected >= 0"
    ):
        obstacle_rasters(frame, resolution=40.0)
    good = _frame(height=[3.0], geometry=[box(0, 0, 20, 20)])
    with pytest.raises(InputError, match="give one of reference="):
        obstacle_rasters(good)
    with pytest.raises(InputError, match="height_field='tall': no such field"):
        obstacle_rasters(good, resolution=10.0, height_field="tall")
    geographic = Raster(np.zeros((1, 2, 2)), Affine(0.1, 0, 24, 0, -0.1, 60), "EPSG:4326")
    with pytest.raises(CRSError, match="expected a projected CRS in metres"):
        obstacle_rasters(good, reference=geographic)
    with pytest.raises(InputError, match=r"storey_height=0\.0"):
        obstacle_rasters(good, resolution=10.0, storey_height=0.0)


def test_land_use_classes_take_their_table_rows() -> None:
    codes = np.array([[[2.0, 6.0], [np.nan, 99.0]]])
    raster = Raster(codes, Affine(100, 0, 0, 0, -100, 200), CRS)
    own = ObstacleProperties(4.0, 8.0, 0.25)
    with pytest.warns(DataQualityWarning, match="classes 99 not in classes="):
        out = land_use_obstacles(raster, {2: "compact_midrise", 6: own})
    # compact midrise: h 10-25 m, H/W 0.75-2, BSF 0.40-0.70 (Stewart & Oke 2012, Table 2).
    assert out.data[:, 0, 0].tolist() == pytest.approx([17.5, 17.5 / 1.375, 0.55])
    assert out.data[:, 0, 1].tolist() == pytest.approx([4.0, 8.0, 0.25])
    for cell in ((1, 0), (1, 1)):
        assert out.data[0][cell] == 0.0 and out.data[2][cell] == 0.0
    with pytest.raises(InputError, match=r"classes\[2\]='downtown'; expected one of"):
        land_use_obstacles(raster, {2: "downtown"})
