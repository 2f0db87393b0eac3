"""PCA compression of kernel tables and the Fourier transform of the bases over azimuth.

Per observer altitude, the images (rows) are normalised to unit norm and decomposed by a
truncated SVD (eigen-decomposition of the smaller Gram matrix); the number of components is the
smallest reaching the explained-energy target (the largest over observer altitudes), or given.
Normalising rows lets faint, distant images weigh as much as bright, nearby ones; the basis is
orthonormal and coefficients are projections of the raw images, so kernel ~= sum_k
coefficient_k basis_k (no mean is subtracted: ``pca_centered = 0``). Basis images are
Fourier-transformed over azimuth (rfft) for the runtime.

Storage levers (all optional; the defaults are the original layout):

- the number of components chosen by an error target (``error``): the smallest number whose
  reconstruction has at most that mean relative error over the pixels brighter than 1 % of
  their image's maximum (:func:`bright_relative_error`, the accuracy measure of the kernel
  benchmarks), instead of an energy fraction that says little about faint pixels;
- one basis shared by every observer altitude (``shared``): the principal directions of all
  levels' normalised images together, found by a randomized range finder
  (:func:`sketched_basis`: the images' row space sketched by a Gaussian test matrix of
  :data:`SKETCH_COLUMNS` columns, then the Rayleigh-Ritz step on the sketch, Halko et al.
  2011, Algs. 4.1 and 5.1), which reads every image twice (and once more to check the error)
  instead of decomposing every level's Gram matrix; the sketch's leading directions are the
  truncated SVD's to well within the error target when it keeps at most half of them
  (``benchmarks/bench_sky_kernel_defaults.py``), and more columns are sketched otherwise;
- coefficients and bases rounded to float32 (``precision``), so that a file stores them
  exactly in half the bytes.

Length: about 870 lines, because the compression, its error-target search and the sketched
basis that the streamed build shares between the observer levels are one PCA of the kernel
tables.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Eq. 4 (PCA) and Eq. 9 (FFT of the bases).

Halko, N., Martinsson, P.-G. & Tropp, J. A. 2011, "Finding Structure with Randomness:
Probabilistic Algorithms for Constructing Approximate Matrix Decompositions", SIAM Review
53(2) 217, Algs. 4.1 (randomized range finder) and 5.1 (direct SVD).
"""

from __future__ import annotations

import contextlib
import functools
import itertools
from collections.abc import Callable, Iterator
from typing import Any, cast

import numpy as np
import scipy.linalg
import xarray as xr
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.sky._pca_numba import bright_error_sums

__all__ = [
    "BRIGHT_FRACTION",
    "PRECISIONS",
    "SKETCH_COLUMNS",
    "LevelDecomposition",
    "bright_relative_error",
    "compress_kernel",
    "decompose_levels",
    "pca_compress",
    "shared_basis",
    "sketched_basis",
]

#: Pixels count in the accuracy measure when brighter than this fraction of their image's
#: maximum [1] (the kernel benchmarks' measure; fainter pixels hardly reach a panorama).
BRIGHT_FRACTION = 0.01

#: Storage precisions of bases and coefficients.
PRECISIONS = ("float64", "float32")

#: Rows of the error-target search: every n-th image when there are more than this many
#: (the chosen number is then checked on all of them) [1].
_SEARCH_ROWS = 4096

#: Principal directions formed first by the error-target search (doubled while too few) [1].
_FIRST_CANDIDATES = 64

#: Samples of at most this many rows keep their bright pixels between the reconstructions of
#: an error-target search (larger ones find them again, bounding the memory) [1].
_CACHED_ROWS = 512


def bright_relative_error(
    approx: FloatArray, exact: FloatArray, *, fraction: float = BRIGHT_FRACTION
) -> float:
    """Mean relative error over the pixels brighter than a fraction of their image's maximum.

    Parameters
    ----------
    approx
        Approximations, shape ``(..., p)``: images of p pixels [any unit].
    exact
        The exact images, same shape [same unit].
    fraction
        A pixel counts when brighter than this fraction of its image's maximum [1].

    Returns
    -------
    float
        mean(|approx - exact| / exact) over the counted pixels of all images; 0 when none
        counts [1].

    Examples
    --------
    >>> exact = np.array([[1.0, 0.5, 0.001]])
    >>> round(bright_relative_error(np.array([[1.02, 0.5, 0.5]]), exact), 12)  # last: faint
    0.01
    """
    total, count = _error_sums(np.asarray(approx), np.asarray(exact), fraction)
    return total / count if count else 0.0


def _error_sums(approx: FloatArray, exact: FloatArray, fraction: float) -> tuple[float, int]:
    """Sum of the relative errors over the bright pixels and their count."""
    peak = exact.max(axis=-1, keepdims=True)
    bright = (exact > fraction * peak) & (peak > 0)
    values = exact[bright].astype(float)
    return float(np.sum(np.abs(approx[bright] - values) / values)), int(values.size)


def _reconstruction_sums(
    x: FloatArray, basis: FloatArray, *, dtype: type = np.float64, rows: int = 512
) -> tuple[float, int]:
    """Sum and count of :func:`bright_relative_error` of the rows of ``x`` projected on the
    orthonormal rows of ``basis`` (rows at a time, so that no copy of ``x`` is made); with
    ``dtype`` float32 the basis and coefficients are rounded as a float32 file stores them."""
    b = basis.astype(dtype).astype(float)
    total, count = 0.0, 0
    for lo in range(0, x.shape[0], rows):
        chunk = np.asarray(x[lo : lo + rows], dtype=float)
        coefficient = (chunk @ b.T).astype(dtype).astype(float)
        part = _error_sums(coefficient @ b, chunk, BRIGHT_FRACTION)
        total, count = total + part[0], count + part[1]
    return total, count


def _orthonormal(basis: FloatArray) -> FloatArray:
    """Orthonormal rows spanning the nearly orthonormal rows of ``basis``, each kept on the
    side of its row: the QR factorisation of ``basis.T`` with a positive diagonal, by Cholesky
    QR twice (two matrix products, no Householder sweep), or Householder QR when the rows are
    too far from orthonormal for it [1]."""
    q = basis
    with _one_thread(), contextlib.suppress(np.linalg.LinAlgError, ValueError):
        for _ in range(2):
            lower = np.linalg.cholesky(q @ q.T)
            q = scipy.linalg.solve_triangular(lower, q, lower=True, check_finite=False)
        k = q.shape[0]
        if np.all(np.isfinite(q)) and np.max(np.abs(q @ q.T - np.eye(k))) < 1e-12:
            return q
    r, _ = np.linalg.qr(basis.T)
    return (r * np.sign(np.sum(r * basis.T, axis=0))).T


@contextlib.contextmanager
def _one_thread() -> Iterator[None]:
    """Run the enclosed LAPACK calls (eigen-decompositions) on one BLAS thread when
    threadpoolctl is installed: their reductions to tridiagonal form scale poorly over
    threads and slow down several-fold on a loaded machine."""
    controller = _threadpools()
    if controller is None:  # pragma: no cover - installed with scikit-learn
        yield
        return
    with controller.limit(limits=1, user_api="blas"):
        yield


@functools.cache
def _threadpools() -> Any:
    """The process's thread pools (threadpoolctl's controller, found once), or None."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - installed with scikit-learn
        return None
    return ThreadpoolController()


def _eigh(gram: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Eigenvalues (descending, clipped at 0) and eigenvectors of a symmetric matrix."""
    with _one_thread():
        lam, vec = np.linalg.eigh(gram)
    order = np.argsort(lam)[::-1]
    return np.clip(lam[order], 0.0, None), vec[:, order]


def _reconstruction_error(x: FloatArray, basis: FloatArray, *, dtype: type = np.float64) -> float:
    """:func:`bright_relative_error` of ``x`` reconstructed from ``basis``
    (:func:`_reconstruction_sums`)."""
    total, count = _reconstruction_sums(x, basis, dtype=dtype)
    return total / count if count else 0.0


def _project(images: FloatArray, basis: FloatArray, rows: int = 4096) -> FloatArray:
    """Coefficients ``images @ basis.T`` in float64, converting float32 images a block of
    rows at a time [same unit as the images]."""
    out = np.empty((images.shape[0], basis.shape[0]))
    for lo in range(0, images.shape[0], rows):
        out[lo : lo + rows] = np.asarray(images[lo : lo + rows], dtype=float) @ basis.T
    return out


def _components_for_error(
    x: list[FloatArray],
    basis: Callable[[int], FloatArray],
    rank: int,
    error: float,
    *,
    dtype: type = np.float64,
    rows: int = _SEARCH_ROWS,
) -> tuple[int, float]:
    """Fewest leading principal directions whose reconstruction of the stacks ``x`` (rows =
    images) meets ``error``.

    ``basis(k)`` gives the k leading directions (orthonormal rows). Candidates double from
    :data:`_FIRST_CANDIDATES` until they meet the target on every n-th row of ``x`` (at most
    ``rows`` rows), then bisection among them (the sample's coefficients on the candidates
    computed once: those of fewer directions are their leading columns); the number is then
    checked on all rows and raised by 10 % steps until it meets the target there (or reaches
    ``rank``). Returns the number and its error on all rows [1].
    """
    step = max(1, -(-sum(part.shape[0] for part in x) // rows))
    sample = np.concatenate([part[::step] for part in x])  # as given (float32 tables)
    bright = _BrightPixels(sample)
    count = max(1, min(_FIRST_CANDIDATES, rank))
    while True:
        candidates = basis(count)
        rounded = candidates.astype(dtype).astype(float)
        projected = _project(sample, rounded, rows=_BLOCK_ROWS)
        if count >= rank or bright.error(projected, rounded, dtype) <= error:
            break
        count = min(2 * count, rank)
    lo, hi = 1, count
    while lo < hi:
        mid = (lo + hi) // 2
        if bright.error(projected[:, :mid], rounded[:mid], dtype) <= error:
            hi = mid
        else:
            lo = mid + 1
    k = lo
    del bright, projected, sample
    achieved = _stacks_error(x, candidates[:k], dtype=dtype)
    while achieved > error and k < rank:
        k = min(rank, max(k + 1, int(k * 1.1)))
        if k > candidates.shape[0]:
            candidates = basis(k)
        achieved = _stacks_error(x, candidates[:k], dtype=dtype)
    return k, achieved


#: Rows reconstructed at a time by the error-target search [1].
_BLOCK_ROWS = 512


class _BrightPixels:
    """The pixels of a sample of images that :func:`bright_relative_error` counts, for the
    many reconstructions of an error-target search: found once (flat indices and values per
    block of :data:`_BLOCK_ROWS` rows) when the sample has at most :data:`_CACHED_ROWS`
    rows, else found again in each block at each reconstruction (bounding the memory)."""

    def __init__(self, sample: FloatArray) -> None:
        self.sample = sample
        self.blocks: list[tuple[NDArray[Any], NDArray[Any]]] | None = None
        if sample.shape[0] <= _CACHED_ROWS:
            self.blocks = [self._find(lo) for lo in range(0, sample.shape[0], _BLOCK_ROWS)]

    def _find(self, lo: int) -> tuple[NDArray[Any], NDArray[Any]]:
        """Flat indices and values (as stored) of the counted pixels of a block."""
        exact = self.sample[lo : lo + _BLOCK_ROWS]
        peak = exact.max(axis=-1, keepdims=True)
        index = np.flatnonzero((exact > BRIGHT_FRACTION * peak) & (peak > 0))
        return index.astype(np.int32 if exact.size < 2**31 else np.int64), exact.ravel()[index]

    def error(self, projected: FloatArray, rounded: FloatArray, dtype: type) -> float:
        """:func:`bright_relative_error` of the sample reconstructed from its coefficients
        ``projected`` on the (rounded) basis ``rounded``, the coefficients rounded to
        ``dtype`` (as :func:`_reconstruction_sums`) [1]."""
        total, count = 0.0, 0
        for block, lo in enumerate(range(0, self.sample.shape[0], _BLOCK_ROWS)):
            index, values = self._find(lo) if self.blocks is None else self.blocks[block]
            coefficient = projected[lo : lo + _BLOCK_ROWS].astype(dtype).astype(float)
            approx = (coefficient @ rounded).ravel()[index]
            exact = values.astype(float)
            total += float(np.sum(np.abs(approx - exact) / exact))
            count += int(index.size)
        return total / count if count else 0.0


def _stacks_error(stacks: list[FloatArray], basis: FloatArray, *, dtype: type) -> float:
    """:func:`bright_relative_error` of all the stacks' images reconstructed from ``basis``."""
    sums = [_reconstruction_sums(stack, basis, dtype=dtype) for stack in stacks]
    return sum(t for t, _ in sums) / max(1, sum(n for _, n in sums))


class LevelDecomposition:
    """Eigen-decomposition of a stack of unit-normalised images (rows), bases on request.

    With m images of p pixels, the eigenvectors of the smaller Gram matrix (m x m, or p x p)
    give the principal directions; :meth:`basis` forms the leading ones (orthonormal rows).

    Parameters
    ----------
    images
        Shape ``(m, p)``, kept as given (float32 tables are converted where used)
        [cd m-2 lm-1].
    """

    def __init__(self, images: FloatArray) -> None:
        self.images = images  # as given (float32 tables are converted where used)
        self._for_error: dict[tuple[float, str], tuple[int, float]] = {}
        x = np.asarray(images, dtype=float)
        norms = np.sqrt(np.einsum("ij,ij->i", x, x))
        keep = norms > 0
        self.empty = not np.any(keep)
        self.keep = keep
        if self.empty:
            self.eigenvalues = np.zeros(1)
            self.explained = np.ones(1)
            self.rank = 1
            return
        self.scale = 1.0 / norms[keep]
        rows = x[keep] if np.sum(keep) < x.shape[0] else x
        self.by_rows = rows.shape[0] <= x.shape[1]
        if self.by_rows:
            # Gram matrix of the normalised rows without forming them: D (X X^T) D, D = 1/|row|
            gram = rows @ rows.T
            gram *= self.scale[:, None]
            gram *= self.scale[None, :]
        else:
            xn = rows * self.scale[:, None]
            gram = xn.T @ xn
        del x, rows
        self.eigenvalues, self.vectors = _eigh(gram)
        self.explained = np.cumsum(self.eigenvalues) / self.eigenvalues.sum()
        self.rank = int(np.sum(self.eigenvalues > self.eigenvalues[0] * 1e-13))

    def components_for_energy(self, energy: float) -> int:
        """Fewest components explaining ``energy`` of the normalised images (at most the
        rank) [1]."""
        k = int(np.searchsorted(self.explained, energy - 1e-12) + 1)
        return max(1, min(k, self.rank))

    def components_for_error(self, error: float, *, dtype: type = np.float64) -> tuple[int, float]:
        """Fewest components whose reconstruction of the images meets ``error``
        (:func:`bright_relative_error`), and the error they reach [1]."""
        key = (error, np.dtype(dtype).name)
        if key not in self._for_error:
            self._for_error[key] = _components_for_error(
                [self.images], self.basis, self.rank, error, dtype=dtype
            )
        return self._for_error[key]

    def basis(self, k: int) -> FloatArray:
        """The ``k`` leading principal directions (at most the rank), orthonormal rows, shape
        ``(k, p)`` [1]."""
        p = self.images.shape[1]
        if self.empty:
            return np.zeros((k, p))
        k = max(1, min(int(k), self.rank))
        if self.by_rows:
            vectors = self.vectors[:, :k] * self.scale[:, None]
            rows = np.asarray(self.images, dtype=float)
            rows = rows[self.keep] if not np.all(self.keep) else rows
            basis = ((rows.T @ vectors) / np.sqrt(self.eigenvalues[:k])[None, :]).T
        else:
            basis = self.vectors[:, :k].T
        return _orthonormal(basis)  # Gram eigenvectors lose a little orthogonality


def pca_compress(
    images: FloatArray,
    *,
    energy: float = 0.999999,
    n_components: int | None = None,
    error: float | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Truncated SVD of a stack of images with unit-normalised rows.

    Parameters
    ----------
    images
        Shape ``(m, p)``: m images of p pixels [cd m-2 lm-1].
    energy
        Explained-energy target of the normalised images, used when ``n_components`` and
        ``error`` are None [1].
    n_components
        Number of components to keep [1].
    error
        Error target: the fewest components whose reconstruction meets it
        (:func:`bright_relative_error`), used when ``n_components`` is None [1].

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
    decomposition = LevelDecomposition(x)
    if decomposition.empty:
        k = n_components or 1
        return np.zeros((k, x.shape[1])), np.zeros((x.shape[0], k)), np.ones(1)
    if n_components is not None:
        k = int(n_components)
    elif error is not None:
        k, _ = decomposition.components_for_error(error)
    else:
        k = decomposition.components_for_energy(energy)
    basis = decomposition.basis(k)
    return basis, x @ basis.T, decomposition.explained


def shared_basis(
    stacks: list[FloatArray] | list[LevelDecomposition],
    *,
    energy: float = 0.999999,
    n_components: int | None = None,
    error: float | None = None,
    dtype: type = np.float64,
) -> tuple[FloatArray, float, float]:
    """One orthonormal basis for several stacks of images (one stack per observer altitude):
    the principal directions of all their normalised images together
    (:func:`sketched_basis`).

    Parameters
    ----------
    stacks
        Per level, shape ``(m_o, p)`` [cd m-2 lm-1], or their decompositions
        (:func:`decompose_levels`; their images are used).
    energy
        Explained-energy target of all normalised images together, used when
        ``n_components`` and ``error`` are None [1].
    n_components
        Number of components [1].
    error
        Error target over the images of every level (:func:`bright_relative_error`) [1].
    dtype
        Storage precision the error is measured in (bases and coefficients rounded to it).

    Returns
    -------
    basis : numpy.ndarray
        Shape ``(k, p)``, orthonormal rows [1].
    explained : float
        Energy of all normalised images the basis explains [1].
    achieved : float
        Its :func:`bright_relative_error` over all images (NaN unless ``error`` is given) [1].
    """
    images = [s.images if isinstance(s, LevelDecomposition) else s for s in stacks]
    basis, _, explained, achieved = sketched_basis(
        images, energy=energy, n_components=n_components, error=error, dtype=dtype
    )
    return basis, explained, achieved


#: Columns of the Gaussian test matrix of :func:`sketched_basis` [1]; the basis keeps at most
#: half of them (else the images are sketched again with twice as many). Dobashi's
#: configuration at the defaults (32,768 images of 16,384 pixels, about 100 bases; the
#: saved tables of ``benchmarks/bench_sky_kernel_defaults.py``): with 256 columns the
#: reconstruction errors at 96 and 103 bases (0.280 %, 0.224 %) equal those after one power
#: iteration more and those of the per-level decompositions merged before; 160 columns give
#: 0.305 % and 0.251 %.
SKETCH_COLUMNS = 256

#: Seed of the sketch's test matrix: fixed, so that a build is reproducible.
_SKETCH_SEED = 20110

#: Rows read (and multiplied) at a time by :func:`sketched_basis` [1].
_SKETCH_ROWS = 4096


def sketched_basis(
    stacks: list[Any],
    *,
    energy: float = 0.999999,
    n_components: int | None = None,
    error: float | None = None,
    dtype: type = np.float64,
    columns: int = SKETCH_COLUMNS,
) -> tuple[FloatArray, list[FloatArray], float, float]:
    """One orthonormal basis for several stacks of images by a randomized range finder, and
    the coefficients of every image on it.

    The images (rows) are normalised to unit norm as in :func:`pca_compress`. Their row space
    is sketched by Z = sum_o X_o^T G_o, G_o Gaussian with l columns, Q an orthonormal basis
    of Z (Halko et al. 2011, Alg. 4.1); the Rayleigh-Ritz step decomposes the l x l Gram
    matrix of the coordinates C = X Q of all images (Alg. 5.1): its eigenvectors W give the
    principal directions (Q W)^T, their energies, and every image's coordinates C W. The
    images are read twice (three times with an error target: the check). The number of
    directions is given, chosen by explained energy, or the fewest meeting the error target
    on every n-th image (at most :data:`_SEARCH_ROWS`) then checked on all of them and
    raised by 10 % steps until met; when it is more than half of l, the images are sketched
    again with twice as many columns (up to the rank, where the sketch is exact). Products
    are summed in the stacks' precision (float32 tables: single-precision products, the
    coordinates within about 1e-6 of float64 ones; the error check is in float64).

    Parameters
    ----------
    stacks
        Per level, an array of shape ``(m_o, p)`` or any object sliced by rows with a
        ``shape`` (read a block of rows at a time, so that a level may stay on disk)
        [cd m-2 lm-1].
    energy, n_components, error, dtype
        As :func:`shared_basis`.
    columns
        Columns l of the first sketch [1].

    Returns
    -------
    basis : numpy.ndarray
        Shape ``(k, p)``, orthonormal rows [1].
    coefficients : list of numpy.ndarray
        Per stack, shape ``(m_o, k)``: the images' coefficients [cd m-2 lm-1].
    explained : float
        Energy of all normalised images the basis explains [1].
    achieved : float
        :func:`bright_relative_error` of all images from the basis and coefficients rounded
        to ``dtype`` (NaN unless ``error`` is given) [1].

    References
    ----------
    Halko, Martinsson & Tropp 2011, Algs. 4.1 and 5.1.
    """
    sizes = [int(stack.shape[0]) for stack in stacks]
    p = int(stacks[0].shape[1])
    width = min(max(columns, 2 * (n_components or 0)), sum(sizes), p)
    norms: list[FloatArray] | None = None
    while True:
        sketch = _Sketch(stacks, width, norms, sample=error is not None and n_components is None)
        norms = sketch.norms
        rows = int(sum(np.count_nonzero(n) for n in norms))
        if rows == 0:
            k = n_components or 1
            return np.zeros((k, p)), [np.zeros((m, k)) for m in sizes], 1.0, float("nan")
        full = min(rows, p)
        explained = np.cumsum(sketch.energies) / rows
        rank = max(1, int(np.sum(sketch.energies > sketch.energies[0] * 1e-13)))
        achieved = float("nan")
        if n_components is not None:
            k = int(n_components)
        elif error is not None:
            k = sketch.search(error, rank, dtype)
        else:
            k = int(np.searchsorted(explained, energy - 1e-12) + 1)
        k = max(1, min(k, rank))
        if error is not None and n_components is None:
            achieved = sketch.check(k, dtype)
            while achieved > error and k < rank:
                k = min(rank, max(k + 1, int(k * 1.1)))
                achieved = sketch.check(k, dtype)
        if k <= width // 2 or width >= full:
            break
        width = min(2 * width, full)
    bounds = np.cumsum([0, *sizes])
    coefficients = [sketch.coefficients(slice(lo, hi), k) for lo, hi in itertools.pairwise(bounds)]
    return sketch.directions[:k], coefficients, float(explained[k - 1]), achieved


class _Sketch:
    """The Rayleigh-Ritz step of :func:`sketched_basis` on a sketch of ``width`` columns:
    ``directions`` (width, p), their ``energies`` (descending), the images' ``norms`` (per
    stack; computed when not given) and their coordinates on the sketch (rows, width; in the
    stacks' precision, which their products have), from which :meth:`coefficients` gives
    the images' coefficients; with ``sample`` every n-th image for the error-target search."""

    def __init__(
        self, stacks: list[Any], width: int, norms: list[FloatArray] | None, *, sample: bool
    ) -> None:
        self.stacks = stacks
        rng = np.random.default_rng(_SKETCH_SEED)
        sketch: FloatArray | None = None
        found = []
        for index, stack in enumerate(stacks):
            for lo, block in _blocks(stack):
                if norms is None:
                    found.append(np.sqrt(np.einsum("ij,ij->i", block, block, dtype=float)))
                    scale = _inverse(found[-1])
                else:
                    scale = _inverse(norms[index][lo : lo + block.shape[0]])
                test = rng.standard_normal((block.shape[0], width)) * scale[:, None]
                part = (block.T @ test.astype(block.dtype)).astype(float)
                sketch = part if sketch is None else sketch + part
        sizes = [int(s.shape[0]) for s in stacks]
        if norms is None:
            flat = np.concatenate(found)
            norms = [flat[lo:hi] for lo, hi in itertools.pairwise(np.cumsum([0, *sizes]))]
        self.norms = norms
        self.scale = np.concatenate(norms)
        assert sketch is not None
        with _one_thread():
            q = np.linalg.qr(sketch)[0]
        del sketch
        step = max(1, -(-sum(sizes) // _SEARCH_ROWS))
        # the coordinates in the products' precision: float32 for float32 tables (any float64
        # block makes them float64)
        self.coordinates = np.zeros((sum(sizes), width), dtype=np.float32)
        gram = np.zeros((width, width))
        rows, row = [], 0
        for index, stack in enumerate(stacks):
            for lo, block in _blocks(stack):
                scale = _inverse(norms[index][lo : lo + block.shape[0]])
                part = block @ q.astype(block.dtype)
                part *= scale[:, None].astype(part.dtype)
                if part.dtype != self.coordinates.dtype:
                    self.coordinates = self.coordinates.astype(part.dtype)
                self.coordinates[row : row + block.shape[0]] = part
                wide = part.astype(float)
                gram += wide.T @ wide
                row += block.shape[0]
                if sample:  # every step-th row of the stack (as _sample_rows), copied
                    rows.append(np.array(block[-lo % step :: step]))
        self.energies, self.vectors = _eigh(gram)
        self.directions = (q @ self.vectors).T
        self.sample = np.concatenate(rows) if sample else None
        self.sample_rows = _sample_rows(stacks, step) if sample else None

    def coefficients(self, rows: Any, k: int) -> FloatArray:
        """The coefficients of the images ``rows`` (a slice or indices over all stacks) on the
        ``k`` leading directions, float64 [unit of the images]."""
        coordinates = np.asarray(self.coordinates[rows], dtype=float)
        out: FloatArray = coordinates @ self.vectors[:, :k]
        out *= self.scale[rows, None]
        return out

    def search(self, error: float, rank: int, dtype: type) -> int:
        """Fewest directions meeting ``error`` on the sample: doubling from
        :data:`_FIRST_CANDIDATES`, then bisection; the products summed in ``dtype``
        (float32: a relative error of about 1e-6 in the reconstruction, for a choice that
        :meth:`check` measures in float64) [1]."""
        assert self.sample is not None and self.sample_rows is not None
        sample = self.sample
        coefficients: NDArray[Any] = self.coefficients(self.sample_rows, rank).astype(dtype)
        directions: NDArray[Any] = self.directions.astype(dtype)

        def meets(k: int) -> bool:
            total, count = 0.0, 0
            for lo in range(0, sample.shape[0], _BLOCK_ROWS):
                approx = coefficients[lo : lo + _BLOCK_ROWS, :k] @ directions[:k]
                part = bright_error_sums(approx, sample[lo : lo + _BLOCK_ROWS], BRIGHT_FRACTION)
                total, count = total + part[0], count + part[1]
            return (total / count if count else 0.0) <= error

        lo, hi = 1, max(1, min(_FIRST_CANDIDATES, rank))
        while hi < rank and not meets(hi):
            lo, hi = hi + 1, min(2 * hi, rank)
        while lo < hi:
            mid = (lo + hi) // 2
            if meets(mid):
                hi = mid
            else:
                lo = mid + 1
        return lo

    def check(self, k: int, dtype: type) -> float:
        """:func:`bright_relative_error` of every image from ``k`` directions and their
        coefficients, both rounded to ``dtype``, in float64 [1]."""
        basis = self.directions[:k].astype(dtype).astype(float)
        total, count, row = 0.0, 0, 0
        for stack in self.stacks:
            for _, block in _blocks(stack):
                for lo in range(0, block.shape[0], _BLOCK_ROWS):
                    rows = slice(row + lo, min(row + lo + _BLOCK_ROWS, row + block.shape[0]))
                    approx = self.coefficients(rows, k).astype(dtype).astype(float) @ basis
                    part = bright_error_sums(approx, block[lo : lo + _BLOCK_ROWS], BRIGHT_FRACTION)
                    total, count = total + part[0], count + part[1]
                row += block.shape[0]
        return total / count if count else 0.0


def _blocks(stack: Any, rows: int = _SKETCH_ROWS) -> Iterator[tuple[int, FloatArray]]:
    """A stack's rows a block at a time, as stored (float32 or float64)."""
    for lo in range(0, int(stack.shape[0]), rows):
        block = np.asarray(stack[lo : lo + rows])
        yield lo, block if block.dtype in (np.float32, np.float64) else block.astype(float)


def _inverse(norms: FloatArray) -> FloatArray:
    """1 / norm, 0 for zero rows (they take no part) [1]."""
    return np.divide(1.0, norms, out=np.zeros_like(norms), where=norms > 0)


def _sample_rows(stacks: list[Any], step: int) -> NDArray[np.intp]:
    """Indices, over all stacks' rows, of every ``step``-th row of each stack."""
    offsets = np.cumsum([0, *(int(s.shape[0]) for s in stacks)])
    return np.concatenate(
        [lo + np.arange(0, int(s.shape[0]), step) for lo, s in zip(offsets, stacks, strict=False)]
    )


def decompose_levels(
    kernel: NDArray[np.floating[Any]], kernel_uplight: NDArray[np.floating[Any]] | None = None
) -> list[LevelDecomposition]:
    """The decomposition of each observer level's images (rows: every source altitude and
    distance, then the same of ``kernel_uplight``).

    Parameters
    ----------
    kernel
        Shape ``(o, c, r, el, az)`` [cd m-2 lm-1].
    kernel_uplight
        Same shape, optional [cd m-2 lm-1].

    Returns
    -------
    list of LevelDecomposition
        One per observer level.
    """
    return [LevelDecomposition(rows) for rows in _level_rows(kernel, kernel_uplight)]


def _level_rows(
    kernel: NDArray[np.floating[Any]], kernel_uplight: NDArray[np.floating[Any]] | None
) -> list[FloatArray]:
    """Each observer level's images as rows ``(n_c n_r [x 2], p)``: every source altitude and
    distance, then the same of ``kernel_uplight`` (views of the tables without it)."""
    n_o, n_c, n_r, n_el, n_az = kernel.shape
    levels = []
    for o in range(n_o):
        rows = kernel[o].reshape(n_c * n_r, n_el * n_az)
        if kernel_uplight is not None:
            rows = np.concatenate([rows, kernel_uplight[o].reshape(n_c * n_r, n_el * n_az)])
        levels.append(cast(FloatArray, rows))  # as given: float32 tables stay float32
    return levels


def compress_kernel(
    kernel: NDArray[np.floating[Any]],
    kernel_uplight: NDArray[np.floating[Any]] | None = None,
    *,
    pca_energy: float = 0.999999,
    n_components: int | None = None,
    store_tables: bool = True,
    pca_error: float | None = None,
    shared_bases: bool = False,
    precision: str = "float64",
    decompositions: list[LevelDecomposition] | None = None,
) -> xr.Dataset:
    """PCA per observer altitude (or one shared by all) and rfft of the basis over azimuth.

    Parameters
    ----------
    kernel
        Shape ``(o, c, r, el, az)`` [cd m-2 lm-1].
    kernel_uplight
        Same shape, optional; shares the basis [cd m-2 lm-1].
    pca_energy
        Explained-energy target [1].
    n_components
        Number of components (overrides ``pca_energy`` and ``pca_error``) [1].
    store_tables
        Include the raw images ``kernel`` (and ``kernel_uplight``) [1].
    pca_error
        Error target choosing the number of components (overrides ``pca_energy``) [1].
    shared_bases
        One basis for every observer altitude (held once, broadcast over the levels).
    precision
        ``"float64"``, or ``"float32"``: bases and coefficients rounded to float32 (the
        spectra are the float64 rfft of the rounded bases).
    decompositions
        The levels' decompositions of these tables (:func:`decompose_levels`), to reuse
        between compressions; computed when None.

    Returns
    -------
    xarray.Dataset
        Variables ``kernel``, ``basis``, ``coefficient``, ``basis_fft_real``,
        ``basis_fft_imag`` (and ``*_uplight``), ``explained_energy``, without coordinates
        [cd m-2 lm-1]; attributes ``pca_components`` and, with an error target,
        ``pca_mean_error`` (the reconstruction's mean relative error, largest over levels).
    """
    n_o, n_c, n_r, n_el, n_az = kernel.shape
    n_pix = n_el * n_az
    dtype = np.float32 if precision == "float32" else np.float64

    explained_k = np.zeros(n_o)
    achieved = float("nan")
    if shared_bases:
        stacks = (
            [level.images for level in decompositions]
            if decompositions
            else _level_rows(kernel, kernel_uplight)
        )
        basis, coefficients, explained, achieved = sketched_basis(
            stacks, energy=pca_energy, n_components=n_components, error=pca_error, dtype=dtype
        )
        basis = basis.astype(dtype).astype(float)
        k = basis.shape[0]
        bases = np.broadcast_to(basis, (n_o, k, n_pix))
        coefs = np.stack(coefficients)
        explained_k[:] = explained
    else:
        levels = decompositions or decompose_levels(kernel, kernel_uplight)
        chosen = []
        for level in levels:
            if level.empty:
                chosen.append(n_components or 1)
            elif n_components is not None:
                chosen.append(int(n_components))
            elif pca_error is not None:
                chosen.append(level.components_for_error(pca_error, dtype=dtype)[0])
            else:
                chosen.append(level.components_for_energy(pca_energy))
        k = max(min(c, level.rank) for c, level in zip(chosen, levels, strict=True))
        n_rows = levels[0].images.shape[0]
        bases = np.zeros((n_o, k, n_pix))
        coefs = np.zeros((n_o, n_rows, k))
        for o, level in enumerate(levels):
            basis = level.basis(k).astype(dtype).astype(float)
            kk = basis.shape[0]  # same number of components for every level (zeros beyond)
            bases[o, :kk] = basis
            coefs[o, :, :kk] = _project(level.images, basis)
            explained_k[o] = level.explained[min(kk, level.explained.size) - 1]
        if pca_error is not None:  # over every level's images together
            sums = [
                _reconstruction_sums(level.images, bases[o], dtype=dtype)
                for o, level in enumerate(levels)
            ]
            achieved = sum(t for t, _ in sums) / max(1, sum(n for _, n in sums))
    coefs = coefs.astype(dtype).astype(float)
    basis_img = bases.reshape(n_o, k, n_el, n_az)
    if shared_bases:  # one spectrum, broadcast like the basis
        spectrum = np.broadcast_to(
            np.fft.rfft(basis_img[0], axis=-1), (n_o, k, n_el, n_az // 2 + 1)
        )
    else:
        spectrum = np.fft.rfft(basis_img, axis=-1)
    dims_k = ("observer_altitude", "source_altitude", "distance", "elevation", "azimuth")
    dims_c = ("observer_altitude", "source_altitude", "distance", "component")
    dims_b = ("observer_altitude", "component", "elevation", "azimuth")
    dims_f = ("observer_altitude", "component", "elevation", "frequency")
    unit = {"units": "cd m-2 lm-1"}
    data = {
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
    if store_tables:  # a float32 copy of the raw images (not made when they are not kept)
        data["kernel"] = (dims_k, kernel.astype(np.float32), unit | {"emission": "lambertian"})
        if kernel_uplight is not None:
            data["kernel_uplight"] = (
                dims_k,
                kernel_uplight.astype(np.float32),
                unit | {"emission": "uplight"},
            )
    if kernel_uplight is not None:
        data["coefficient_uplight"] = (
            dims_c,
            coefs[:, n_c * n_r :].reshape(n_o, n_c, n_r, k),
            unit | {"emission": "uplight"},
        )
    ds = xr.Dataset(data)
    ds.attrs["pca_components"] = k
    if pca_error is not None and n_components is None:
        ds.attrs["pca_mean_error"] = achieved
    return ds.assign_coords(component=np.arange(k), frequency=np.arange(n_az // 2 + 1))
