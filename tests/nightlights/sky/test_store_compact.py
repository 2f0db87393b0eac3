"""The compact kernel file: derived spectra, a shared basis stored once, float32, deflate."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from nightlights.sky.build import compute_kernel
from nightlights.sky.panorama import kernel_slice
from nightlights.sky.spec import KernelSpec
from nightlights.sky.store import read_kernel, write_kernel

LEVELS = {
    "r_min": 20.0,
    "r_max": 20_000.0,
    "n_distance": 10,
    "n_elevation": 6,
    "n_azimuth": 16,
    "source_altitudes": (0.0, 100.0),
    "observer_altitudes": (0.0, 100.0, 200.0),
    "nodes": 8,
}


@pytest.fixture(scope="module")
def per_level() -> xr.Dataset:
    return compute_kernel(KernelSpec(**LEVELS), progress=False)


@pytest.fixture(scope="module")
def lean() -> xr.Dataset:
    spec = KernelSpec(
        **LEVELS, store_tables=False, precision="float32", shared_bases=True, pca_error=0.01
    )
    return compute_kernel(spec, progress=False)


def _same_in_memory(back: xr.Dataset, ds: xr.Dataset) -> None:
    assert set(back.data_vars) == set(ds.data_vars)
    for name in ds.data_vars:
        assert back[name].dims == ds[name].dims, name
        assert back[name].dtype == ds[name].dtype, name
    for name in ("basis", "coefficient", "distance_edges"):
        np.testing.assert_array_equal(back[name].values, ds[name].values)
    for name in ("basis_fft_real", "basis_fft_imag"):  # recomputed on reading
        np.testing.assert_allclose(back[name].values, ds[name].values, rtol=0, atol=1e-12)
    assert back.attrs["content_hash"] == ds.attrs["content_hash"]


def test_compact_file_reads_back_the_in_memory_kernel(tmp_path: Path, per_level) -> None:
    path = write_kernel(per_level, tmp_path / "k.nc")
    _same_in_memory(read_kernel(path), per_level)
    with h5py.File(path) as f:  # derived spectra are not stored; variables are deflated
        assert "basis_fft_real" not in f and f["basis"].compression == "gzip"
    original = write_kernel(per_level, tmp_path / "original.nc", compact=False)
    with h5py.File(original) as f:
        assert "basis_fft_real" in f
    _same_in_memory(read_kernel(original), per_level)
    assert path.stat().st_size < original.stat().st_size


def test_shared_float32_kernel_is_stored_once_and_renders_the_same(tmp_path: Path, lean) -> None:
    path = write_kernel(lean, tmp_path / "lean.nc")
    with h5py.File(path) as f:
        assert f["basis"].dims[0].label != "observer_altitude" and f["basis"].ndim == 3
        assert f["basis"].dtype == np.float32 and f["coefficient"].dtype == np.float32
    back = read_kernel(path)
    _same_in_memory(back, lean)
    assert back.attrs["shared_bases"] == 1 and back.attrs["precision"] == "float32"
    # between levels: the same slice from the file as from memory
    read, built = (
        kernel_slice(ds, observer_altitude=150.0, source_altitude=40.0) for ds in (back, lean)
    )
    np.testing.assert_allclose(read.coefficient, built.coefficient, rtol=1e-12)
    np.testing.assert_allclose(read.basis_fft, built.basis_fft, rtol=0, atol=1e-12)
    per_level_size = (
        write_kernel(
            compute_kernel(KernelSpec(**LEVELS, store_tables=False), progress=False),
            tmp_path / "per_level.nc",
            compact=False,
        )
        .stat()
        .st_size
    )
    assert path.stat().st_size < per_level_size / 2
