"""The sparse path: an emission raster read window by window, keeping only its lit cells.

A 20000 x 20000 raster (400 M cells, 3.2 GB as float64) with three lit blocks runs through
``skyglow`` in a subprocess whose address space is limited to 2 GiB; on a small raster the
sparse path equals the dense one (polar map and panorama).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import rasterio
import xarray as xr
from affine import Affine
from rasterio.windows import Window

from nightlights.io import Raster
from nightlights.sky import Observer, Scene
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.panorama import panorama_pca
from nightlights.sky.polar import polar_map, polar_map_levels
from nightlights.sky.setup import prepare_scene
from nightlights.sky.store import write_kernel

SIDE = 20_000
CELL = 10.0  # [m]
BLOCKS = ((9000, 9000), (9600, 10400), (11000, 8800))  # (row, col) of 100 x 100 lit blocks
ORIGIN = (400_000.0, 6_800_000.0)
OBSERVER = "495000,6705000"
ADDRESS_SPACE = 2 * 2**30  # [B]


def _huge_raster(path: Path) -> None:
    """Write only the lit blocks of a tiled, compressed, sparse GeoTIFF (the file is ~20 kB)."""
    profile = {
        "driver": "GTiff",
        "width": SIDE,
        "height": SIDE,
        "count": 1,
        "dtype": "float32",
        "crs": "EPSG:32635",
        "transform": Affine(CELL, 0, ORIGIN[0], 0, -CELL, ORIGIN[1]),
        "tiled": True,
        "blockxsize": 512,
        "blockysize": 512,
        "compress": "deflate",
        "sparse_ok": True,
    }
    with rasterio.open(path, "w", **profile) as dataset:
        for row, col in BLOCKS:
            dataset.write(
                np.full((100, 100), 2.0, np.float32), 1, window=Window(col, row, 100, 100)
            )


_RUN = textwrap.dedent(
    """
    import resource, sys
    resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
    from nightlights_cli.main import cli
    try:
        cli.main(sys.argv[1:], standalone_mode=False)
    finally:
        # VmHWM: this process image's own peak (ru_maxrss carries the parent's over exec)
        status = open("/proc/self/status").read()
        peak = int(status.split("VmHWM:")[1].split()[0]) * 1024
        print(f"peak RSS {{peak}}", file=sys.stderr)
    """
)


def test_skyglow_of_a_huge_sparse_raster_runs_in_2_gib(
    small_kernel: xr.Dataset, tmp_path: Path
) -> None:
    emission, kernel, out = tmp_path / "huge.tif", tmp_path / "kernel.nc", tmp_path / "pano.nc"
    _huge_raster(emission)
    write_kernel(small_kernel, kernel)  # 20 km: every block is within 17 km of the observer
    command = [sys.executable, "-c", _RUN.format(limit=ADDRESS_SPACE), "skyglow"]
    command += [str(emission), str(out), "--observer", OBSERVER, "--kernel", str(kernel)]
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": str(root)}
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "zenith" in done.stderr and "Traceback" not in done.stderr
    peak = int(done.stderr.rsplit("peak RSS ", 1)[1].split()[0])
    assert peak < 1024 * 2**20  # a float64 copy of the raster alone would be 3.2 GB
    panorama = xr.open_dataset(out, engine="h5netcdf")
    assert panorama.attrs["emitted_flux_lm"] == pytest.approx(3 * 100 * 100 * 2.0 * CELL**2)
    assert np.all(np.isfinite(panorama["luminance"].values))
    assert float(panorama["luminance"].max()) > 0


def _small(tmp_path: Path) -> tuple[Path, Raster]:
    flux = np.zeros((2, 60, 50))
    rng = np.random.default_rng(3)
    flux[:, 10:20, 30:42] = rng.uniform(0.1, 2.0, (2, 10, 12))
    flux[0, 45, 5] = 4.0
    flux[1, 50:52, 20] = np.nan
    raster = Raster(flux, Affine(25, 0, 500_000, 0, -25, 6_700_000), "EPSG:32635")
    return raster.write(tmp_path / "small.tif"), Raster.read(tmp_path / "small.tif")


def test_sparse_file_path_equals_the_dense_raster(small_kernel: xr.Dataset, tmp_path: Path) -> None:
    path, raster = _small(tmp_path)
    observer = (500_600.0, 6_699_000.0)
    setup = prepare_scene(
        Scene(path, kernel=small_kernel), Observer(*observer, height=0.0), progress=False
    )
    first = setup.slices[0]
    dense = polar_map(
        raster.data, raster.transform, observer, distance_edges=first.distance_edges, n_az=32
    )
    np.testing.assert_allclose(setup.polar_cells().binned(), dense.flux, rtol=1e-12)
    levels = polar_map_levels(
        raster.data,
        raster.transform,
        observer,
        source_altitude=np.zeros(raster.shape),
        levels=setup.levels,
        distance_edges=first.distance_edges,
        n_az=32,
    )
    expected = np.maximum(panorama_pca(levels, setup.slices), 0.0)
    for source in (path, raster):
        scene = skyglow_panorama(
            Scene(source, kernel=small_kernel), Observer(*observer, height=0.0)
        )
        np.testing.assert_allclose(scene.panorama["luminance"].values, expected, rtol=1e-9)
