"""The in-memory Raster: file and xarray round trips, and refused shapes and metadata."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS

from nightlights.errors import CRSError, InputError, OutputError
from nightlights.io import Raster, as_raster

TRANSFORM = Affine(2.0, 0, 500_000, 0, -2.0, 6_700_000)


@pytest.fixture
def raster() -> Raster:
    rng = np.random.default_rng(4)
    data = rng.uniform(0, 30, (2, 5, 7)).astype(np.float32).astype(np.float64)
    data[1, 0, 0] = np.nan
    return Raster(
        data,
        TRANSFORM,
        "EPSG:32635",
        ("photopic", "scotopic"),
        ("lx", "W m-2"),
        {"nightlights_stage": "test", "resolution_m": "2.0"},
        ({"sensor": "photopic"}, {"sensor": "scotopic"}),
    )


def test_file_round_trip(tmp_path: Path, raster: Raster) -> None:
    path = raster.write(tmp_path / "r.tif")
    with rasterio.open(path) as dataset:
        assert dataset.dtypes == ("float32", "float32")
        assert dataset.descriptions == ("photopic", "scotopic")
        assert dataset.units == ("lx", "W m-2")
    back = Raster.read(path)
    np.testing.assert_array_equal(back.data, raster.data)
    assert back.transform == raster.transform
    assert back.crs is not None and back.crs.to_epsg() == 32635
    assert back.descriptions == raster.descriptions and back.units == raster.units
    assert back.tags["nightlights_stage"] == "test" and back.tags["resolution_m"] == "2.0"
    assert back.band_tags[1]["sensor"] == "scotopic"
    np.testing.assert_array_equal(as_raster(path).data, raster.data)


def test_xarray_round_trip(raster: Raster) -> None:
    array = raster.to_xarray()
    assert array.dims == ("band", "y", "x")
    assert array["x"].values[0] == 500_001.0 and array["y"].values[0] == 6_699_999.0
    back = Raster.from_xarray(array)
    np.testing.assert_array_equal(back.data, raster.data)
    assert back.transform == raster.transform
    assert back.crs == raster.crs
    assert back.descriptions == raster.descriptions and back.units == raster.units
    assert back.tags == raster.tags
    assert as_raster(array).shape == (5, 7)
    assert as_raster(raster) is raster


def test_properties(raster: Raster) -> None:
    assert raster.count == 2 and raster.shape == (5, 7) and raster.resolution == 2.0
    assert raster.bounds == (500_000.0, 6_699_990.0, 500_014.0, 6_700_000.0)
    assert raster.band_index("scotopic") == 1
    np.testing.assert_array_equal(raster.band("photopic"), raster.data[0])
    assert raster.projected_crs() == CRS.from_epsg(32635)
    single = Raster(np.zeros((3, 4)), TRANSFORM, None)
    assert single.count == 1 and single.descriptions == ("",) and single.units == ("",)


def test_validation_errors(tmp_path: Path, raster: Raster) -> None:
    with pytest.raises(InputError, match=r"shape \(4,\); expected \(bands, rows, cols\)"):
        Raster(np.zeros(4), TRANSFORM, None)
    with pytest.raises(InputError, match="2 bands but 1 descriptions"):
        Raster(np.zeros((2, 3, 3)), TRANSFORM, None, ("a",))
    with pytest.raises(InputError, match="2 bands but 3 units"):
        Raster(np.zeros((2, 3, 3)), TRANSFORM, None, units=("lx", "lx", "lx"))
    with pytest.raises(InputError, match="no band 'mesopic'"):
        raster.band("mesopic")
    with pytest.raises(InputError, match="north-up grid with square pixels"):
        _ = Raster(np.zeros((1, 2, 2)), Affine(2.0, 0, 0, 0, -3.0, 0), None).resolution
    with pytest.raises(CRSError, match="expected a projected CRS"):
        Raster(np.zeros((1, 2, 2)), TRANSFORM, "EPSG:4326").projected_crs()
    with pytest.raises(OutputError, match="no CRS"):
        Raster(np.zeros((1, 2, 2)), TRANSFORM, None).write(tmp_path / "x.tif")
    with pytest.raises(InputError, match="no such file"):
        Raster.read(tmp_path / "missing.tif")
    (tmp_path / "bad.tif").write_bytes(b"not a raster")
    with pytest.raises(InputError, match="cannot read raster"):
        Raster.read(tmp_path / "bad.tif")
    with pytest.raises(InputError, match="no 'transform' attribute"):
        Raster.from_xarray(raster.to_xarray().drop_attrs())
    with pytest.raises(InputError, match=r"expected a Raster, an xarray\.DataArray or a path"):
        as_raster(np.zeros((1, 2, 2)))  # type: ignore[arg-type]


def test_read_then_write_keeps_units_and_band_tags(tmp_path: Path) -> None:
    raster = Raster(
        np.ones((2, 3, 4)),
        Affine(10, 0, 0, 0, -10, 30),
        "EPSG:32635",
        ("reflected", "uplight"),
        ("lm m-2", "lm m-2"),
        {"source": "test"},
        ({"kind": "lambertian"}, {"kind": "uplight"}),
    )
    first = Raster.read(raster.write(tmp_path / "a.tif"))
    again = Raster.read(first.write(tmp_path / "b.tif"))
    assert again.units == ("lm m-2", "lm m-2")
    assert again.band_tags[1]["kind"] == "uplight"
    assert again.tags["source"] == "test"
    assert np.array_equal(again.data, raster.data)


# --- the sparse form: lit cells read window by window -------------------------------------


def _sparse_file(path: Path, *, nodata: float | None) -> np.ndarray:
    """A 2-band float32 file over several windows with zeros, NaN, nodata, inf and values."""
    data = np.zeros((2, 700, 300), np.float32)
    data[0, 5, 7] = 2.0
    data[1, 5, 8] = 3.0  # lit in the second band only
    data[:, 650, 299] = (1.0, np.nan)  # lit in one band, NaN in the other
    data[0, 400, 10] = np.inf
    data[:, 100:110, 0] = np.nan
    if nodata is not None:
        data[:, 200:205, 5] = nodata
    profile = {
        "driver": "GTiff",
        "width": 300,
        "height": 700,
        "count": 2,
        "dtype": "float32",
        "crs": "EPSG:32635",
        "transform": Affine(10, 0, 0, 0, -10, 7000),
        "tiled": True,
        "blockxsize": 64,
        "blockysize": 64,
        "compress": "deflate",
        "nodata": nodata,
    }
    with rasterio.open(path, "w", **profile) as dataset:
        dataset.write(data)
    return data


@pytest.mark.parametrize("nodata", [None, -9999.0])
def test_read_lit_cells_equals_the_dense_raster(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, nodata: float | None
) -> None:
    from nightlights.io import raster as raster_module

    monkeypatch.setattr(raster_module, "WINDOW_CELLS", 300 * 64)  # several windows
    path = tmp_path / "sparse.tif"
    _sparse_file(path, nodata=nodata)
    sparse = raster_module.read_lit_cells(path)
    dense = Raster.read(path).lit_cells()
    for name in ("rows", "cols"):
        np.testing.assert_array_equal(getattr(sparse, name), getattr(dense, name))
    np.testing.assert_array_equal(sparse.values, dense.values)
    assert sparse.rows.tolist() == [5, 5, 400, 650] and sparse.cols.tolist() == [7, 8, 10, 299]
    assert np.isnan(sparse.values[1, 3]) and sparse.values[0, 3] == 1.0
    assert sparse.infinite_values == dense.infinite_values == 1
    assert sparse.nodata_cells == dense.nodata_cells == 10 + (5 if nodata is not None else 0)
    assert sparse.shape == (700, 300) and sparse.crs == CRS.from_epsg(32635)
    assert sparse.lit_bounds() == (70.0, 7000 - 6510.0, 3000.0, 7000 - 50.0)


def test_lit_cells_dense_window_round_trips() -> None:
    data = np.zeros((1, 50, 60))
    data[0, 10, 20] = 1.0
    data[0, 30, 45] = 2.0
    cells = Raster(data, Affine(10, 0, 0, 0, -10, 500), "EPSG:32635").lit_cells()
    window, transform = cells.dense()
    assert window.shape == (1, 21, 26) and window.sum() == 3.0
    assert (transform.c, transform.f) == (200.0, 400.0) and window[0, 20, 25] == 2.0


def test_read_lit_cells_missing_file_is_an_input_error(tmp_path: Path) -> None:
    from nightlights.io.raster import read_lit_cells

    with pytest.raises(InputError, match="no such file"):
        read_lit_cells(tmp_path / "missing.tif")
