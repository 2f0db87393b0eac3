"""Kernel slices between precomputed altitude levels, on synthetic contract-format kernels."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from nightlights.sky.panorama import kernel_slice, panorama_exact, panorama_pca
from nightlights.sky.polar import PolarMap

N_R, N_EL, N_AZ, N_K = 6, 4, 16, 3
H_O = np.array([0.0, 400.0])
H_C = np.array([0.0, 100.0])


def _synthetic_kernel(seed: int = 0, *, flip_second_level: bool = True) -> xr.Dataset:
    """Random rank-3 kernels per observer level in the dataset format of the contract.

    The second observer level gets bases of opposite sign (and coefficients of opposite sign),
    which an SVD is free to return: the kernels are unchanged, averaging the bases is not.
    """
    rng = np.random.default_rng(seed)
    basis = rng.random((H_O.size, N_K, N_EL, N_AZ))
    coefficient = rng.random((H_O.size, H_C.size, N_R, N_K))
    if flip_second_level:
        basis[1] *= -1.0
        coefficient[1] *= -1.0
    kernel = np.einsum("ocdk,okea->ocdea", coefficient, basis)
    spectrum = np.fft.rfft(basis, axis=-1)
    edges = np.geomspace(1.0, 10_000.0, N_R + 1)
    return xr.Dataset(
        {
            "kernel": (
                ("observer_altitude", "source_altitude", "distance", "elevation", "azimuth"),
                kernel,
            ),
            "coefficient": (
                ("observer_altitude", "source_altitude", "distance", "component"),
                coefficient,
            ),
            "basis": (("observer_altitude", "component", "elevation", "azimuth"), basis),
            "basis_fft_real": (
                ("observer_altitude", "component", "elevation", "frequency"),
                spectrum.real,
            ),
            "basis_fft_imag": (
                ("observer_altitude", "component", "elevation", "frequency"),
                spectrum.imag,
            ),
            "distance_edges": (("distance_edge",), edges),
        },
        coords={
            "observer_altitude": H_O,
            "source_altitude": H_C,
            "distance": np.sqrt(edges[1:] * edges[:-1]),
            "elevation": 90.0 - (np.arange(N_EL) + 0.5) * 90.0 / N_EL,
            "azimuth": np.arange(N_AZ) * 360.0 / N_AZ,
            "component": np.arange(N_K),
        },
        attrs={"pca_centered": 0},
    )


def _polar(seed: int = 1) -> PolarMap:
    flux = np.random.default_rng(seed).random((1, N_R, N_AZ))
    return PolarMap(flux, np.geomspace(1.0, 10_000.0, N_R + 1), N_AZ, np.zeros(1), flux.sum((1, 2)))


@pytest.mark.parametrize("h_o", [0.0, 100.0, 250.0, 400.0])
@pytest.mark.parametrize("h_c", [0.0, 30.0, 100.0])
def test_pca_equals_exact_between_levels(h_o: float, h_c: float) -> None:
    """Regression: between observer levels, averaging bases of two SVDs gave panoramas off by
    tens of per cent (here they cancel); keeping both levels' bases is exact to rounding."""
    tables = kernel_slice(_synthetic_kernel(), observer_altitude=h_o, source_altitude=h_c)
    pca, exact = panorama_pca(_polar(), tables), panorama_exact(_polar(), tables)
    np.testing.assert_allclose(pca, exact, rtol=1e-10, atol=1e-12 * np.abs(exact).max())


def test_slice_is_the_bilinear_interpolation_of_the_kernel() -> None:
    ds = _synthetic_kernel()
    tables = kernel_slice(ds, observer_altitude=100.0, source_altitude=30.0)
    k = ds["kernel"].values
    expected = 0.75 * (0.7 * k[0, 0] + 0.3 * k[0, 1]) + 0.25 * (0.7 * k[1, 0] + 0.3 * k[1, 1])
    np.testing.assert_allclose(tables.kernel[0], expected, rtol=1e-12)
    reconstructed = np.einsum(
        "dk,kea->dea", tables.coefficient[0], np.fft.irfft(tables.basis_fft, n=N_AZ, axis=-1)
    )
    np.testing.assert_allclose(reconstructed, expected, rtol=1e-10, atol=1e-12)


def test_components_of_two_levels_are_interleaved() -> None:
    """At a level the slice holds its K bases; between levels 2K, level by level per rank."""
    ds = _synthetic_kernel()
    assert kernel_slice(ds, observer_altitude=400.0).coefficient.shape[-1] == N_K
    between = kernel_slice(ds, observer_altitude=100.0)
    assert between.coefficient.shape[-1] == 2 * N_K
    level_0 = np.fft.rfft(ds["basis"].values[0, 0], axis=-1)
    level_1 = np.fft.rfft(ds["basis"].values[1, 0], axis=-1)
    np.testing.assert_allclose(between.basis_fft[0], level_0, atol=1e-12)
    np.testing.assert_allclose(between.basis_fft[1], level_1, atol=1e-12)
    # Truncating to the first 2 components keeps the leading basis of each level.
    assert np.isfinite(panorama_pca(_polar(), between, components=2)).all()
