"""Tests of nightlights.io: atomic writes, COG output, GeoPackage schema, CRS policy."""

from __future__ import annotations

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import rasterio
import shapely
from affine import Affine

from nightlights.errors import CRSError, InputError, OutputError
from nightlights.io import (
    Raster,
    RasterBand,
    atomic_output,
    ensure_projected,
    read_vector,
    write_cog,
    write_gpkg,
)


def test_atomic_output_leaves_nothing_on_failure(tmp_path) -> None:
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("crash mid-write")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]
    with atomic_output(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"


def test_atomic_output_needs_existing_directory(tmp_path) -> None:
    with (
        pytest.raises(OutputError, match="does not exist"),
        atomic_output(tmp_path / "missing" / "x.tif"),
    ):
        pass


def test_write_cog_is_tiled_compressed_with_overviews_and_metadata(tmp_path) -> None:
    rng = np.random.default_rng(0)
    data = rng.random((1200, 1100)).astype(np.float32)
    data[0, 0] = np.nan
    path = write_cog(
        tmp_path / "x.tif",
        [RasterBand(data, "illuminance photopic", "lx"), RasterBand(2 * data, "scotopic", "lx")],
        transform=Affine(1.0, 0, 500000.0, 0, -1.0, 6700000.0),
        crs="EPSG:3067",
        tags={"model": "test"},
    )
    with rasterio.open(path) as src:
        assert src.driver == "GTiff" and src.dtypes == ("float32", "float32")
        assert src.profile["tiled"] and src.profile["blockxsize"] == 512
        assert src.compression.name.lower() == "deflate"
        assert src.overviews(1), "COG must carry overviews"
        assert src.descriptions == ("illuminance photopic", "scotopic")
        assert src.units == ("lx", "lx")
        assert src.tags()["model"] == "test"
        assert src.crs.to_epsg() == 3067
        assert np.isnan(src.nodata)
        assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
    back = Raster.read(path)
    assert back.data.shape == (2, 1200, 1100)
    assert np.array_equal(back.data[0], data.astype(np.float64), equal_nan=True)
    assert back.units == ("lx", "lx")


def test_write_cog_rejects_mismatched_bands(tmp_path) -> None:
    with pytest.raises(OutputError, match="one shape"):
        write_cog(
            tmp_path / "x.tif",
            [RasterBand(np.zeros((3, 3)), "a", "lx"), RasterBand(np.zeros((3, 4)), "b", "lx")],
            transform=Affine.identity(),
            crs="EPSG:3067",
        )
    assert not (tmp_path / "x.tif").exists()


def test_write_gpkg_explicit_types_and_nulls(tmp_path) -> None:
    frame = gpd.GeoDataFrame(
        {"n": [1, None], "x": ["1.5", "2"], "flag": [True, None], "name": [3, "b"]},
        geometry=[shapely.Point(0, 0), shapely.Point(1, 1)],
        crs="EPSG:3067",
    )
    path = write_gpkg(
        frame,
        tmp_path / "a.gpkg",
        layer="pts",
        schema={"n": "int", "x": "float", "flag": "bool", "name": "str"},
    )
    info = pyogrio.read_info(path, layer="pts")
    types = dict(zip(info["fields"], info["dtypes"], strict=True))
    assert types == {"n": "int64", "x": "float64", "flag": "bool", "name": "object"}
    back = read_vector(path)
    assert back["n"].isna().iloc[1] and back["x"].tolist() == [1.5, 2.0]


def test_write_gpkg_refuses_missing_crs(tmp_path) -> None:
    frame = gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)])
    with pytest.raises(OutputError, match="without a CRS"):
        write_gpkg(frame, tmp_path / "a.gpkg", layer="x")


def test_read_vector_missing_and_unreadable(tmp_path) -> None:
    with pytest.raises(InputError, match="no such file"):
        read_vector(tmp_path / "nope.gpkg")
    bad = tmp_path / "bad.gpkg"
    bad.write_bytes(b"not a geopackage")
    with pytest.raises(InputError, match="cannot read"):
        read_vector(bad)


def test_crs_policy() -> None:
    line = shapely.LineString([(24.9, 60.1), (25.0, 60.2)])
    geographic = gpd.GeoDataFrame(geometry=[line], crs="EPSG:4326")
    assert ensure_projected(geographic).crs.to_epsg() == 32635
    none = gpd.GeoDataFrame(geometry=[line])
    with pytest.raises(CRSError, match="no coordinate reference system"):
        ensure_projected(none, source="x.shp")
    assert ensure_projected(none, assume_crs="EPSG:4326").crs.to_epsg() == 32635
    projected = gpd.GeoDataFrame(geometry=[shapely.Point(0, 0)], crs="EPSG:3067")
    assert ensure_projected(projected) is projected
    with pytest.raises(CRSError, match="not projected in metres"):
        ensure_projected(projected, target_crs="EPSG:4326")
    feet = gpd.GeoDataFrame(geometry=[shapely.Point(0, 0)], crs="EPSG:2227")  # US survey feet
    assert ensure_projected(feet).crs.is_projected
    assert ensure_projected(feet).crs.to_epsg() != 2227


def test_as_vector_takes_frames_and_paths(tmp_path) -> None:
    from nightlights.io import as_vector

    frame = gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)], crs="EPSG:32635")
    same, label = as_vector(frame, name="lights")
    assert same is frame and label == "in-memory lights"
    path = tmp_path / "points.gpkg"
    frame.to_file(path)
    read, label = as_vector(path, name="lights")
    assert label == str(path) and list(read["a"]) == [1]
    with pytest.raises(InputError, match="names a layer inside a file"):
        as_vector(frame, layer="lines")
    with pytest.raises(InputError, match="expected a GeoDataFrame or a vector file path"):
        as_vector(42, name="streets")
