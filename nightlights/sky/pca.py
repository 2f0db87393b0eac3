"""PCA compression of kernel tables and the Fourier transform of the bases over azimuth.

Per observer altitude, the images (rows) are normalised to unit norm and decomposed by a
truncated SVD (eigen-decomposition of the smaller Gram matrix); the number of components is the
smallest reaching the explained-energy target (the largest over observer altitudes), or given.
Normalising rows lets faint, distant images weigh as much as bright, nearby ones; the basis is
orthonormal and coefficients are projections of the raw images, so kernel ~= sum_k
coefficient_k basis_k (no mean is subtracted: ``pca_centered = 0``). Basis images are
Fourier-transformed over azimuth (rfft) for the runtime.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Eq. 4 (PCA) and Eq. 9 (FFT of the bases).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from nightlights._typing import FloatArray

__all__ = ["compress_kernel", "pca_compress"]


def pca_compress(
    images: FloatArray, *, energy: float = 0.999999, n_components: int | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Truncated SVD of a stack of images with unit-normalised rows.

    Parameters
    ----------
    images
        Shape ``(m, p)``: m images of p pixels [cd m-2 lm-1].
    energy
        Explained-energy target of the normalised images, used when ``n_components`` is None [1].
    n_components
        Number of components to keep [1].

    Returns
    -------
    basis : numpy.ndarray
        Shape ``(k, p)``, orthonormal rows [1].
    coefficient : numpy.ndarray
        Shape ``(m, k)``: projections of the images on the basis [cd m-2 lm-1].
    explained : numpy.ndarray
        Cumulative explained energy of the normalised images, shape ``(min(m, p),)`` [1].

    References
    ----------
    Dobashi et al. 2023, Eq. 4 and Sec. 3.4.1 (PCA of the precomputed images).
    """
    x = np.asarray(images, dtype=float)
    norms = np.sqrt(np.einsum("ij,ij->i", x, x))
    keep = norms > 0
    scale = 1.0 / norms[keep]
    m, p = int(keep.sum()), x.shape[1]
    if m == 0:
        k = n_components or 1
        return np.zeros((k, x.shape[1])), np.zeros((x.shape[0], k)), np.ones(1)
    xk = x[keep] if m < x.shape[0] else x
    if m <= p:
        # Gram matrix of the normalised rows without forming them: D (X X^T) D, D = 1 / |row|
        gram = xk @ xk.T
        gram *= scale[:, None]
        gram *= scale[None, :]
        lam, vec = np.linalg.eigh(gram)
    else:
        xn = xk * scale[:, None]
        lam, vec = np.linalg.eigh(xn.T @ xn)
    order = np.argsort(lam)[::-1]
    lam = np.clip(lam[order], 0.0, None)
    vec = vec[:, order]
    explained = np.cumsum(lam) / lam.sum()
    rank = int(np.sum(lam > lam[0] * 1e-13))
    if n_components is None:
        k = int(np.searchsorted(explained, energy - 1e-12) + 1)
    else:
        k = int(n_components)
    k = max(1, min(k, rank))
    if m <= p:
        basis = (xk.T @ (vec[:, :k] * scale[:, None])) / np.sqrt(lam[:k])[None, :]
        basis = basis.T
    else:
        basis = vec[:, :k].T
    # re-orthonormalise (Gram eigenvectors lose a little orthogonality)
    q, _ = np.linalg.qr(basis.T)
    basis = (q * np.sign(np.sum(q * basis.T, axis=0))).T
    return basis, x @ basis.T, explained


def compress_kernel(
    kernel: NDArray[np.floating[Any]],
    kernel_uplight: NDArray[np.floating[Any]] | None = None,
    *,
    pca_energy: float = 0.999999,
    n_components: int | None = None,
    store_tables: bool = True,
) -> xr.Dataset:
    """PCA per observer altitude and rfft of the basis over azimuth.

    Parameters
    ----------
    kernel
        Shape ``(o, c, r, el, az)`` [cd m-2 lm-1].
    kernel_uplight
        Same shape, optional; shares the basis [cd m-2 lm-1].
    pca_energy
        Explained-energy target [1].
    n_components
        Number of components (overrides ``pca_energy``) [1].
    store_tables
        Include the raw images ``kernel`` (and ``kernel_uplight``) [1].

    Returns
    -------
    xarray.Dataset
        Variables ``kernel``, ``basis``, ``coefficient``, ``basis_fft_real``,
        ``basis_fft_imag`` (and ``*_uplight``) without coordinates [cd m-2 lm-1].
    """
    n_o, n_c, n_r, n_el, n_az = kernel.shape
    n_pix = n_el * n_az

    def stack(o: int) -> FloatArray:
        rows = [kernel[o].reshape(n_c * n_r, n_pix)]
        if kernel_uplight is not None:
            rows.append(kernel_uplight[o].reshape(n_c * n_r, n_pix))
        return np.concatenate(rows, axis=0).astype(float)

    results = [
        pca_compress(stack(o), energy=pca_energy, n_components=n_components) for o in range(n_o)
    ]
    k = max(basis.shape[0] for basis, _, _ in results)
    n_rows = results[0][1].shape[0]
    bases = np.zeros((n_o, k, n_pix))
    coefs = np.zeros((n_o, n_rows, k))
    explained_k = np.zeros(n_o)
    for o in range(n_o):
        basis, coef, explained = results[o]
        if basis.shape[0] < k:  # same number of components for every observer altitude
            basis, coef, explained = pca_compress(stack(o), n_components=k)
        kk = basis.shape[0]
        bases[o, :kk] = basis
        coefs[o, :, :kk] = coef
        explained_k[o] = explained[min(kk, explained.size) - 1]
    basis_img = bases.reshape(n_o, k, n_el, n_az)
    spectrum = np.fft.rfft(basis_img, axis=-1)
    dims_k = ("observer_altitude", "source_altitude", "distance", "elevation", "azimuth")
    dims_c = ("observer_altitude", "source_altitude", "distance", "component")
    dims_b = ("observer_altitude", "component", "elevation", "azimuth")
    dims_f = ("observer_altitude", "component", "elevation", "frequency")
    unit = {"units": "cd m-2 lm-1"}
    data = {
        "kernel": (dims_k, kernel.astype(np.float32), unit | {"emission": "lambertian"}),
        "basis": (dims_b, basis_img, {"units": "1"}),
        "coefficient": (
            dims_c,
            coefs[:, : n_c * n_r].reshape(n_o, n_c, n_r, k),
            unit | {"emission": "lambertian"},
        ),
        "basis_fft_real": (dims_f, spectrum.real, {"units": "1", "transform": "rfft over azimuth"}),
        "basis_fft_imag": (dims_f, spectrum.imag, {"units": "1", "transform": "rfft over azimuth"}),
        "explained_energy": (("observer_altitude",), explained_k, {"units": "1"}),
    }
    if kernel_uplight is not None:
        data["kernel_uplight"] = (
            dims_k,
            kernel_uplight.astype(np.float32),
            unit | {"emission": "uplight"},
        )
    if not store_tables:
        data.pop("kernel")
        data.pop("kernel_uplight", None)
    if kernel_uplight is not None:
        data["coefficient_uplight"] = (
            dims_c,
            coefs[:, n_c * n_r :].reshape(n_o, n_c, n_r, k),
            unit | {"emission": "uplight"},
        )
    ds = xr.Dataset(data)
    return ds.assign_coords(component=np.arange(k), frequency=np.arange(n_az // 2 + 1))
