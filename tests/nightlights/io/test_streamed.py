"""CogWriter: windows from many threads make the same COG as write_cog; failures leave nothing."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine

from nightlights.errors import OutputError
from nightlights.io import CogWriter, RasterBand, write_cog

TRANSFORM = Affine(2.0, 0.0, 1000.0, 0.0, -2.0, 5000.0)


def writer(path: Path, shape=(2, 700, 900), **options) -> CogWriter:
    return CogWriter(
        path,
        shape=shape,
        transform=TRANSFORM,
        crs="EPSG:3067",
        descriptions=("photopic", "melanopic"),
        units=("lx", "W m-2"),
        band_tags=({"sensor": "photopic"}, {"sensor": "melanopic"}),
        tags={"nightlights_stage": "irradiance"},
        **options,
    )


def test_windows_from_threads_make_the_cog_write_cog_makes(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    data = (rng.lognormal(0, 2, (2, 700, 900)) * (rng.random((700, 900)) > 0.3)).astype(np.float32)
    windows = [(r, c) for r in range(0, 700, 128) for c in range(0, 900, 128)]
    with writer(tmp_path / "streamed.tif", compress="ZSTD", level=1) as out:

        def work(part: list[tuple[int, int]]) -> None:
            for r, c in part:
                out.write(data[:, r : r + 128, c : c + 128], row=r, col=c)

        threads = [threading.Thread(target=work, args=(windows[i::4],)) for i in range(4)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        out.update_tags(light_pixel_evaluations=12)
    write_cog(
        tmp_path / "whole.tif",
        [RasterBand(data[0], "photopic", "lx"), RasterBand(data[1], "melanopic", "W m-2")],
        transform=TRANSFORM,
        crs="EPSG:3067",
        compress="ZSTD",
        level=1,
    )
    with rasterio.open(tmp_path / "streamed.tif") as a, rasterio.open(tmp_path / "whole.tif") as b:
        assert a.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert a.overviews(1) == b.overviews(1) == [2]
        np.testing.assert_array_equal(a.read(), data)
        np.testing.assert_array_equal(
            a.read(out_shape=(2, 350, 450)), b.read(out_shape=(2, 350, 450))
        )
        assert a.descriptions == ("photopic", "melanopic") and a.units == ("lx", "W m-2")
        assert a.tags()["light_pixel_evaluations"] == "12"
        assert a.tags(2)["sensor"] == "melanopic" and a.crs.to_epsg() == 3067
        assert a.transform == TRANSFORM
    # the style is chosen from the bands (an illuminance ramp), like write_cog's
    assert (tmp_path / "streamed.qml").read_text().count("<item") > 3
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "streamed.qml",
        "streamed.tif",
        "whole.qml",
        "whole.tif",
    ]


def test_windows_never_written_are_nodata(tmp_path: Path) -> None:
    with writer(tmp_path / "w.tif", shape=(2, 40, 50)) as out:
        out.write(np.ones((2, 40, 25)), row=0, col=0)
    with rasterio.open(tmp_path / "w.tif") as dataset:
        data = dataset.read()
    assert (data[:, :, :25] == 1).all() and np.isnan(data[:, :, 25:]).all()


def test_a_failure_leaves_neither_the_output_nor_the_scratch_file(tmp_path: Path) -> None:
    (tmp_path / "w.tif").write_bytes(b"the previous run")
    with pytest.raises(RuntimeError, match="a tile failed"):
        with writer(tmp_path / "w.tif", shape=(2, 40, 50)) as out:
            out.write(np.ones((2, 40, 25)), row=0, col=0)
            raise RuntimeError("a tile failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.tif"]
    assert (tmp_path / "w.tif").read_bytes() == b"the previous run"


def test_bad_shapes_folders_and_closed_writers_are_output_errors(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="expected"):
        writer(tmp_path / "w.tif", shape=(2, 0, 5))
    with pytest.raises(OutputError, match="2 bands but"):
        CogWriter(
            tmp_path / "w.tif",
            shape=(2, 4, 5),
            transform=TRANSFORM,
            crs="EPSG:3067",
            descriptions=("photopic",),
            units=("lx",),
        )
    with pytest.raises(OutputError, match="does not exist"):
        writer(tmp_path / "no" / "w.tif")
    closed = writer(tmp_path / "w.tif", shape=(2, 4, 5))
    with pytest.raises(OutputError, match="not open"):
        closed.write(np.ones((2, 4, 5)), row=0, col=0)
    assert list(tmp_path.iterdir()) == []
