"""PCA storage levers: bases chosen by an error target, bases shared by observer levels (the
sketched basis), float32 rounding, and the accuracy measure (its compiled sums against the
numpy reference)."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.sky._pca_numba import bright_error_sums
from nightlights.sky.pca import (
    BRIGHT_FRACTION,
    _error_sums,
    bright_relative_error,
    compress_kernel,
    decompose_levels,
    pca_compress,
    shared_basis,
    sketched_basis,
)


def _images(rng: np.random.Generator, m: int = 60, p: int = 48, rank: int = 12) -> np.ndarray:
    """Positive images that are sums of ``rank`` smooth profiles with decaying weights."""
    x = np.linspace(0.0, 1.0, p)
    profiles = np.array([np.exp(-((x - c) ** 2) / 0.02) for c in np.linspace(0, 1, rank)])
    weights = rng.random((m, rank)) * 0.5 ** np.arange(rank)
    return weights @ profiles + 1e-3


def _reconstruction(images: np.ndarray, basis: np.ndarray) -> np.ndarray:
    return (images @ basis.T) @ basis


def test_bright_relative_error_counts_only_bright_pixels() -> None:
    exact = np.array([[10.0, 1.0, 0.05], [2.0, 2.0, 2.0]])
    approx = np.array([[11.0, 1.0, 5.0], [2.0, 1.0, 2.0]])
    # bright: 10 (0.1), 1 (0), 2, 2 (0.5), 2; the 0.05 pixel is below 1 % of 10
    assert bright_relative_error(approx, exact) == pytest.approx((0.1 + 0.5) / 5)
    assert bright_relative_error(exact, exact) == 0.0
    assert bright_relative_error(np.zeros((1, 3)), np.zeros((1, 3))) == 0.0


@pytest.mark.parametrize("target", [0.05, 0.01, 0.002])
def test_error_target_gives_the_fewest_bases_that_meet_it(target: float) -> None:
    images = _images(np.random.default_rng(1))
    basis, coefficient, _ = pca_compress(images, error=target)
    k = basis.shape[0]
    assert bright_relative_error(coefficient @ basis, images) <= target
    if k > 1:  # one basis fewer misses the target
        fewer, _, _ = pca_compress(images, n_components=k - 1)
        assert bright_relative_error(_reconstruction(images, fewer), images) > target
    np.testing.assert_allclose(basis @ basis.T, np.eye(k), atol=1e-10)


def test_energy_path_is_unchanged_by_the_error_option() -> None:
    images = _images(np.random.default_rng(2))
    a = pca_compress(images, energy=0.9999)
    b = pca_compress(images, energy=0.9999, error=None)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_shared_basis_serves_every_level() -> None:
    rng = np.random.default_rng(3)
    stacks = [_images(rng), 2.0 * _images(rng) + 1e-2]
    basis, explained, achieved = shared_basis(stacks, error=0.005)
    both = np.concatenate(stacks)
    assert achieved <= 0.005
    assert bright_relative_error(_reconstruction(both, basis), both) == pytest.approx(achieved)
    assert 0.0 < explained <= 1.0 + 1e-12
    # it spans what each level's own basis of the same size spans, nearly
    own, _, _ = pca_compress(stacks[0], n_components=basis.shape[0])
    assert bright_relative_error(_reconstruction(stacks[0], basis), stacks[0]) < 0.01
    assert np.linalg.norm(own - (own @ basis.T) @ basis) < 0.2 * np.sqrt(own.shape[0])


def test_shared_basis_of_one_level_spans_its_own_basis() -> None:
    images = _images(np.random.default_rng(4))
    own, _, _ = pca_compress(images, n_components=6)
    shared, _, _ = shared_basis([images], n_components=6)
    # the same subspace: projecting one basis on the other keeps it
    np.testing.assert_allclose((own @ shared.T) @ shared, own, atol=1e-8)


def _kernel(rng: np.random.Generator) -> np.ndarray:
    """(o, c, r, el, az) tables: 3 observer levels, 2 source levels, 10 distances, 4 x 12."""
    images = _images(rng, m=3 * 2 * 10, p=48)
    levels = np.array([1.0, 0.8, 0.6])[:, None]
    return (images.reshape(3, 20, 48) * levels[..., None]).reshape(3, 2, 10, 4, 12)


def test_compress_kernel_levers_keep_the_layout_and_meet_the_target() -> None:
    kernel = _kernel(np.random.default_rng(5)).astype(np.float32)
    ds = compress_kernel(
        kernel, pca_error=0.01, shared_bases=True, precision="float32", store_tables=False
    )
    assert ds.basis.dims == ("observer_altitude", "component", "elevation", "azimuth")
    assert ds.basis.shape[0] == 3 and ds.coefficient.shape[:3] == (3, 2, 10)
    assert "kernel" not in ds
    # one basis for all levels, stored exactly in float32
    np.testing.assert_array_equal(ds.basis.values[0], ds.basis.values[2])
    for name in ("basis", "coefficient"):
        values = ds[name].values
        np.testing.assert_array_equal(values, values.astype(np.float32).astype(float))
    spectrum = np.fft.rfft(ds.basis.values, axis=-1)
    np.testing.assert_allclose(ds.basis_fft_real.values, spectrum.real, atol=1e-12)
    k = ds.sizes["component"]
    rec = np.einsum("ocrk,okp->ocrp", ds.coefficient.values, ds.basis.values.reshape(3, k, -1))
    measured = bright_relative_error(rec.reshape(-1, 48), kernel.reshape(-1, 48))
    assert measured == pytest.approx(ds.attrs["pca_mean_error"], rel=1e-9)
    assert measured <= 0.01


def test_compress_kernel_reuses_given_decompositions() -> None:
    kernel = _kernel(np.random.default_rng(6))
    levels = decompose_levels(kernel)
    a = compress_kernel(kernel, pca_error=0.01)
    b = compress_kernel(kernel, pca_error=0.01, decompositions=levels)
    np.testing.assert_array_equal(a.basis.values, b.basis.values)
    np.testing.assert_array_equal(a.coefficient.values, b.coefficient.values)
    per_level = compress_kernel(kernel, pca_error=0.01)
    assert per_level.attrs["pca_mean_error"] <= 0.01
    assert "pca_mean_error" not in compress_kernel(kernel).attrs


@pytest.mark.parametrize("exact_type", [np.float32, np.float64])
@pytest.mark.parametrize("approx_type", [np.float32, np.float64])
def test_compiled_error_sums_match_the_numpy_reference(exact_type: type, approx_type: type) -> None:
    """The compiled sums of the accuracy measure against :func:`_error_sums` (the numpy
    reference): bright pixels, a zero image and a negative one, float32 and float64."""
    rng = np.random.default_rng(7)
    exact = rng.lognormal(sigma=2.0, size=(40, 300))
    exact[3] = 0.0
    exact[5] = -exact[5]
    approx = exact * (1.0 + 0.01 * rng.standard_normal(exact.shape))
    got = bright_error_sums(approx.astype(approx_type), exact.astype(exact_type), BRIGHT_FRACTION)
    want = _error_sums(approx.astype(approx_type), exact.astype(exact_type), BRIGHT_FRACTION)
    assert got[1] == want[1] > 0
    assert got[0] == pytest.approx(want[0], rel=1e-12)
    assert bright_error_sums(np.zeros((0, 3)), np.zeros((0, 3)), BRIGHT_FRACTION) == (0.0, 0)


def test_sketch_spanning_every_image_is_the_truncated_svd() -> None:
    """A sketch with as many columns as pixels spans every image: its leading directions are
    those of the SVD of all stacks together, and the coefficients are the projections."""
    images = _images(np.random.default_rng(8))
    basis, coefficients, explained, achieved = sketched_basis(
        [images[:25], images[25:]], n_components=6
    )
    own, _, own_explained = pca_compress(images, n_components=6)
    np.testing.assert_allclose((own @ basis.T) @ basis, own, atol=1e-8)
    np.testing.assert_allclose(basis @ basis.T, np.eye(6), atol=1e-12)
    assert [c.shape for c in coefficients] == [(25, 6), (35, 6)]
    np.testing.assert_allclose(np.concatenate(coefficients), images @ basis.T, rtol=1e-9)
    assert explained == pytest.approx(own_explained[5], rel=1e-9)
    assert np.isnan(achieved)


def test_sketch_grows_when_the_target_needs_more_than_half_of_it() -> None:
    """Sketched with 8 columns first, a target that needs more than 4 bases is sketched again
    with more columns; the error is then met and measured on every image, and the number of
    bases is that of the truncated SVD."""
    images = _images(np.random.default_rng(9), m=200, p=96, rank=24)
    basis, coefficients, _, achieved = sketched_basis([images], error=0.002, columns=8)
    k = basis.shape[0]
    assert k > 4
    assert achieved <= 0.002
    reconstruction = np.concatenate(coefficients) @ basis
    assert bright_relative_error(reconstruction, images) == pytest.approx(achieved, rel=1e-9)
    fewest, _, _ = pca_compress(images, error=0.002)
    assert k == fewest.shape[0]


def test_sketch_of_float32_stacks_reports_the_error_of_the_stored_values() -> None:
    """float32 tables: products in float32, the error measured in float64 on the bases and
    coefficients as a float32 file stores them; zero images take no part."""
    images = _images(np.random.default_rng(10), m=80).astype(np.float32)
    images[7] = 0.0
    basis, coefficients, explained, achieved = sketched_basis(
        [images], error=0.005, dtype=np.float32
    )
    stored_basis = basis.astype(np.float32).astype(float)
    stored = coefficients[0].astype(np.float32).astype(float)
    measured = bright_relative_error(stored @ stored_basis, images.astype(float))
    assert measured == pytest.approx(achieved, rel=1e-9) and achieved <= 0.005
    np.testing.assert_array_equal(coefficients[0][7], 0.0)
    assert 0.0 < explained <= 1.0 + 1e-12
