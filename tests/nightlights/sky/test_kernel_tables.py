"""Kernel tables: dataset contract, PCA + FFT, NetCDF round trip, cache and specification."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nightlights.errors import InputError
from nightlights.sky import store
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.build import compute_kernel
from nightlights.sky.kernel import sky_luminance
from nightlights.sky.pca import pca_compress
from nightlights.sky.spec import KernelSpec, panorama_elevations, relative_azimuths
from nightlights.sky.store import get_or_build_kernel, kernel_cache_path, read_kernel, write_kernel


def _tables(*, progress: bool = False, **parameters: object) -> xr.Dataset:
    """The kernel dataset of ``KernelSpec(**parameters)``."""
    return compute_kernel(KernelSpec(**parameters), progress=progress)  # type: ignore[arg-type]


SMALL = {
    "r_min": 20.0,
    "r_max": 50_000.0,
    "n_distance": 12,
    "n_elevation": 8,
    "n_azimuth": 16,
    "source_altitudes": (0.0, 200.0),
    "observer_altitudes": (0.0, 500.0),
    "nodes": 16,
}


@pytest.fixture(scope="module")
def small_kernel() -> xr.Dataset:
    """On the exact path: the tests below check the reference PCA (per level, float64, by
    explained energy) to 1e-9 and its reconstruction to the energy target."""
    return compute_kernel(KernelSpec.exact(**SMALL, uplight=True), progress=False)


def test_grids_follow_the_contract() -> None:
    np.testing.assert_allclose(panorama_elevations(4), [78.75, 56.25, 33.75, 11.25])
    np.testing.assert_allclose(relative_azimuths(4), [0.0, 90.0, 180.0, 270.0])


def test_dataset_layout(small_kernel: xr.Dataset) -> None:
    ds = small_kernel
    assert ds.kernel.dims == (
        "observer_altitude",
        "source_altitude",
        "distance",
        "elevation",
        "azimuth",
    )
    assert ds.kernel.shape == (2, 2, 12, 8, 16)
    assert ds.kernel_uplight.shape == ds.kernel.shape
    assert ds.basis.dims == ("observer_altitude", "component", "elevation", "azimuth")
    assert ds.coefficient.dims == ("observer_altitude", "source_altitude", "distance", "component")
    assert ds.basis_fft_real.sizes["frequency"] == 16 // 2 + 1
    edges = ds.distance_edges.values
    assert (
        edges.size == 13
        and edges[0] == pytest.approx(20.0)
        and edges[-1] == pytest.approx(50_000.0)
    )
    np.testing.assert_allclose(ds.distance.values, np.sqrt(edges[:-1] * edges[1:]))
    np.testing.assert_allclose(ds.elevation.values, panorama_elevations(8))
    np.testing.assert_allclose(ds.azimuth.values, relative_azimuths(16))
    for key in (
        "turbidity",
        "aerosol_scale_height",
        "asymmetry",
        "wavelength_nm",
        "earth_radius",
        "flat_earth",
        "nodes",
        "pca_energy",
        "pca_centered",
        "content_hash",
    ):
        assert key in ds.attrs
    assert ds.attrs["pca_centered"] == 0
    assert ds.kernel.attrs["units"] == "cd m-2 lm-1"
    assert np.all(ds.kernel.values >= 0)


def test_kernel_is_symmetric_in_relative_azimuth(small_kernel: xr.Dataset) -> None:
    k = small_kernel.kernel.values
    mirrored = k[..., (-np.arange(16)) % 16]
    np.testing.assert_array_equal(k, mirrored)
    # the brightest column looks towards the source
    assert np.all(k[0, 0, :, -1].argmax(axis=-1) == 0)


def test_bin_value_is_area_weighted_average_of_point_kernel() -> None:
    edges = np.array([1000.0, 1100.0])
    ds = _tables(
        distance_edges=edges,
        n_elevation=4,
        n_azimuth=8,
        nodes=16,
        sub_distances=2,
        supersample=1,
        multiple_scattering="single",  # the single-scattering integral itself
        progress=False,
    )
    # two Gauss-Legendre nodes in ln r, weights r^2 (equal Gauss weights)
    frac = 0.5 * (1.0 + np.array([-1.0, 1.0]) / math.sqrt(3.0))
    r_sub = np.exp(np.log(1000.0) + frac * np.log(1.1))
    w = r_sub**2 / np.sum(r_sub**2)
    el = panorama_elevations(4)[:, None, None]
    az = relative_azimuths(8)[None, :, None]
    expect = np.sum(sky_luminance(el, az, r_sub[None, None, :], nodes=16) * w, axis=-1)
    np.testing.assert_allclose(ds.kernel.values[0, 0, 0], expect, rtol=1e-6)
    # and the converged annulus mean (64-point midpoint rule in ln r) to 1e-5
    fine = np.exp(np.log(1000.0) + (np.arange(64) + 0.5) / 64 * np.log(1.1))
    w_fine = fine**2 / np.sum(fine**2)
    converged = np.sum(sky_luminance(el, az, fine[None, None, :], nodes=16) * w_fine, axis=-1)
    np.testing.assert_allclose(ds.kernel.values[0, 0, 0], converged, rtol=1e-5)


def test_pca_reconstructs_kernel(small_kernel: xr.Dataset) -> None:
    ds = small_kernel
    basis = ds.basis.values
    for o in range(2):
        gram = basis[o].reshape(basis.shape[1], -1) @ basis[o].reshape(basis.shape[1], -1).T
        np.testing.assert_allclose(gram, np.eye(basis.shape[1]), atol=1e-9)
        for name, coef in (("kernel", "coefficient"), ("kernel_uplight", "coefficient_uplight")):
            k = ds[name].values[o].astype(float)
            rec = np.einsum("crk,kea->crea", ds[coef].values[o], basis[o])
            bright = k > 0.01 * k.max(axis=(-2, -1), keepdims=True)
            rel = np.abs(rec - k)[bright] / k[bright]
            assert rel.mean() < 0.02  # target: 2 % mean over pixels > 1 % of max


def test_basis_fft_is_rfft_over_azimuth(small_kernel: xr.Dataset) -> None:
    spectrum = np.fft.rfft(small_kernel.basis.values, axis=-1)
    np.testing.assert_allclose(small_kernel.basis_fft_real.values, spectrum.real, atol=1e-12)
    np.testing.assert_allclose(small_kernel.basis_fft_imag.values, spectrum.imag, atol=1e-12)


def test_pca_compress_energy_and_components() -> None:
    rng = np.random.default_rng(1)
    rows = rng.normal(size=(3, 40))
    images = rng.uniform(0.1, 10.0, size=(30, 3)) @ rows
    basis, coef, explained = pca_compress(images, energy=0.999999)
    assert basis.shape[0] == 3
    np.testing.assert_allclose(coef @ basis, images, rtol=1e-8, atol=1e-8)
    assert explained[2] == pytest.approx(1.0)
    one, _, _ = pca_compress(images, n_components=1)
    assert one.shape == (1, 40)
    # fewer bases than the rank: reconstruction is worse, not broken
    _, c1, _ = pca_compress(images, n_components=1)
    assert np.linalg.norm(c1 @ one - images) > 1e-3 * np.linalg.norm(images)


def test_n_components_respected() -> None:
    ds = _tables(
        r_min=50.0,
        r_max=20_000.0,
        n_distance=8,
        n_elevation=4,
        n_azimuth=8,
        nodes=12,
        n_components=3,
        progress=False,
    )
    assert ds.sizes["component"] == 3


def test_content_hash_deterministic_and_sensitive() -> None:
    a = KernelSpec(**SMALL).content_hash
    assert a == KernelSpec(**SMALL).content_hash
    assert a != KernelSpec(**SMALL, atmosphere=Atmosphere(turbidity=3.0)).content_hash
    assert a != KernelSpec(**{**SMALL, "n_azimuth": 32}).content_hash


def test_write_read_round_trip(tmp_path: Path, small_kernel: xr.Dataset) -> None:
    path = write_kernel(small_kernel, tmp_path / "k.nc")
    back = read_kernel(path)
    xr.testing.assert_allclose(back.kernel, small_kernel.kernel)
    np.testing.assert_array_equal(back.coefficient.values, small_kernel.coefficient.values)
    assert back.attrs["content_hash"] == small_kernel.attrs["content_hash"]
    assert not list(tmp_path.glob(".*tmp*"))


def test_read_kernel_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        read_kernel(tmp_path / "missing.nc")
    bad = tmp_path / "bad.nc"
    bad.write_text("not netcdf")
    with pytest.raises(InputError, match=r"bad\.nc"):
        read_kernel(bad)
    other = tmp_path / "other.nc"
    xr.Dataset({"x": ("a", [1.0])}).to_netcdf(other, engine="h5netcdf")
    with pytest.raises(InputError, match="not a skyglow kernel"):
        read_kernel(other)


def test_cache_reuses_matching_kernel(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    params = {
        "r_min": 50.0,
        "r_max": 10_000.0,
        "n_distance": 4,
        "n_elevation": 4,
        "n_azimuth": 8,
        "nodes": 8,
    }
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(tmp_path))
    first = get_or_build_kernel(KernelSpec(**params), progress=False)
    path = kernel_cache_path(KernelSpec(**params))
    assert path.is_file() and path.parent == tmp_path / "sky" and first.path == path

    def fail(*_: object, **__: object) -> None:
        raise AssertionError("rebuilt although a matching cache exists")

    monkeypatch.setattr(store, "compute_kernel", fail)
    again = get_or_build_kernel(KernelSpec(**params), progress=False)
    np.testing.assert_array_equal(again.kernel.kernel.values, first.kernel.kernel.values)
    assert again.spec == first.spec
    with pytest.raises(AssertionError, match="rebuilt"):
        get_or_build_kernel(KernelSpec(**{**params, "n_distance": 5}), progress=False)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"r_min": 0.0}, "distance grid"),
        ({"distance_edges": [10.0, 5.0]}, "distance_edges"),
        ({"n_azimuth": 7}, "n_az"),
        ({"source_altitudes": ()}, "source_altitudes"),
        ({"pca_energy": 1.5}, "pca_energy"),
        ({"sub_distances": 0}, "sub_distances"),
    ],
)
def test_bad_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        KernelSpec(**kwargs)


def test_pixels_next_to_a_visible_source_are_pixel_averaged() -> None:
    """A source 300 m up, 510 m away is seen at 30.5 deg: its pixel holds a 1/d peak.

    Reference: the solid-angle-weighted mean over 64 x 64 directions in that pixel. The
    centre sample alone is > 5x too bright; 8 x 8 supersampling is within 10 %.
    """
    edges = np.array([500.0, 520.0])
    kw = {"distance_edges": edges, "source_altitudes": (300.0,), "n_elevation": 16, "n_azimuth": 32}
    kw |= {"sub_distances": 1, "progress": False}
    centre = _tables(supersample=1, **kw).kernel.values[0, 0, 0, 10, 0]
    averaged = _tables(**kw).kernel.values[0, 0, 0, 10, 0]
    m = 64
    off = (np.arange(m) + 0.5) / m - 0.5
    el = panorama_elevations(16)[10] + off[:, None] * 90.0 / 16
    az = off[None, :] * 360.0 / 32
    b = sky_luminance(el, az, np.sqrt(500.0 * 520.0), source_altitude=300.0)
    weight = np.cos(np.radians(el))
    reference = float((b * weight).sum() / (weight.sum() * m))
    assert centre > 5 * reference
    assert averaged == pytest.approx(reference, rel=0.1)


def test_altitude_levels_are_sorted_and_distinct() -> None:
    ds = _tables(
        r_min=10.0,
        r_max=1000.0,
        n_distance=2,
        n_elevation=2,
        n_azimuth=4,
        source_altitudes=(100.0, 0.0),
        observer_altitudes=(50.0, 0.0),
        progress=False,
    )
    assert ds.source_altitude.values.tolist() == [0.0, 100.0]
    assert ds.observer_altitude.values.tolist() == [0.0, 50.0]
    assert KernelSpec(source_altitudes=(100.0, 0.0)) == KernelSpec(source_altitudes=(0.0, 100.0))
    with pytest.raises(InputError, match="distinct"):
        KernelSpec(source_altitudes=(0.0, 0.0))


def test_pca_only_kernel_is_smaller_and_renders_the_same(tmp_path: Path) -> None:
    from affine import Affine

    from nightlights.sky.panorama import kernel_slice, panorama_exact, panorama_pca
    from nightlights.sky.polar import polar_map

    kwargs = {**SMALL, "uplight": True, "progress": False}
    full = _tables(**kwargs)
    lean = _tables(store_tables=False, **kwargs)
    assert "kernel" not in lean and "kernel_uplight" not in lean
    assert "coefficient_uplight" in lean and lean.attrs["store_tables"] == 0
    assert lean.attrs["content_hash"] != full.attrs["content_hash"]
    write_kernel(full, tmp_path / "full.nc")
    write_kernel(lean, tmp_path / "lean.nc")
    assert (tmp_path / "lean.nc").stat().st_size < (tmp_path / "full.nc").stat().st_size
    lean = read_kernel(tmp_path / "lean.nc")
    emission = np.zeros((2, 20, 20))
    emission[:, 5:8, 12:15] = 1.0
    transform = Affine(100.0, 0, 0, 0, -100.0, 2000.0)
    panoramas = []
    for ds in (full, lean):
        tables = kernel_slice(ds, observer_altitude=0.0)
        polar = polar_map(
            emission,
            transform,
            (1000.0, 1000.0),
            distance_edges=tables.distance_edges,
            n_az=tables.n_az,
        )
        panoramas.append(panorama_pca(polar, tables))
    np.testing.assert_allclose(panoramas[1], panoramas[0], rtol=1e-12)
    with pytest.raises(InputError, match="no raw images"):
        panorama_exact(polar, tables)
