"""Quick-look maps: a raster file is read averaged down to the panel, the zoom at full size."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from affine import Affine

import nightlights.maps as maps
from nightlights.io import Raster

TRANSFORM = Affine(2.0, 0.0, 1000.0, 0.0, -2.0, 5000.0)


@pytest.fixture
def raster_file(tmp_path: Path) -> tuple[Path, np.ndarray]:
    rng = np.random.default_rng(3)
    data = rng.lognormal(0, 1, (1, 300, 400))
    raster = Raster(data, TRANSFORM, "EPSG:3067", ("photopic",), ("lx",))
    return raster.write(tmp_path / "e.tif"), data[0].astype(np.float32).astype(float)


def test_a_file_is_read_averaged_down_and_the_zoom_window_alone(
    raster_file, monkeypatch: pytest.MonkeyPatch
) -> None:
    path, data = raster_file
    monkeypatch.setattr(maps, "MAP_PIXELS", 100)
    zoom = (1100.0, 4600.0, 1180.0, 4700.0)  # 40 x 50 pixels from column 50, row 150
    [(whole, extent), (window, zoom_extent)], crs, unit, name = maps._read_images(path, 1, zoom)
    assert whole.shape == (75, 100) and extent == (1000.0, 1800.0, 4400.0, 5000.0)
    np.testing.assert_allclose(whole, data.reshape(75, 4, 100, 4).mean(axis=(1, 3)), rtol=1e-5)
    np.testing.assert_array_equal(window, data[150:200, 50:90])
    assert zoom_extent == (1100.0, 1180.0, 4600.0, 4700.0)
    assert ("TM35FIN" in crs.name, unit, name) == (True, "lx", "photopic")
    # a zoom off the pixel edges takes every pixel it touches; its corners in any order
    [_, (edges, edges_extent)], *_ = maps._read_images(path, 1, (1181.0, 4699.0, 1101.0, 4601.0))
    np.testing.assert_array_equal(edges, data[150:200, 50:91])
    assert edges_extent == (1100.0, 1182.0, 4600.0, 4700.0)
    # a zoom beside the raster draws an empty panel, not an error
    [_, (outside, _)], *_ = maps._read_images(path, 1, (0.0, 0.0, 10.0, 10.0))
    assert outside.shape == (75, 100)


def test_a_file_and_its_raster_draw_a_map(raster_file, tmp_path: Path) -> None:
    path, _ = raster_file
    zoom = (1100.0, 4600.0, 1180.0, 4700.0)
    for source, name in ((path, "from_file.png"), (Raster.read(path), "from_memory.png")):
        out = maps.plot_raster_map(source, tmp_path / name, zoom=zoom, title="lit")
        assert out.stat().st_size > 10_000
