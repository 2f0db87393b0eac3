"""Skyglow kernel tables: the bin images over distance, source and observer altitude.

Each bin image is the area-weighted average of :func:`nightlights.sky.kernel.sky_luminance`
over ``sub_distances`` Gauss-Legendre nodes in ln r inside the bin (weights r^2 d ln r, i.e.
flux spread evenly over the annulus; 1 = the geometric bin centre), optionally averaged over
``sub_pixels`` x ``sub_pixels`` directions inside each pixel (solid-angle weights). Pixels next
to the source direction, where rays graze the source, are always averaged over ``supersample``
x ``supersample`` directions and at least 4 distances. Relative azimuths are symmetric: only
0-180 deg are computed and mirrored. The tables are then compressed
(:func:`nightlights.sky.pca.compress_kernel`).

With ``altitude_step`` > 1 only some (observer, source) altitude pairs are integrated: pairs
of equal height difference h_c - h_o share the geometry, and along each such line the images
change with the observer's altitude through the air's density and transmission only, smoothly
and nearly exponentially; the skipped pairs are interpolated log-linearly
(:func:`altitude_pairs`, :func:`interpolate_pairs`; errors in
``benchmarks/bench_sky_kernel_altitudes.py``).

Dataset layout (read by :mod:`nightlights.sky.panorama`): coordinates ``observer_altitude``,
``source_altitude``, ``distance`` (bin centres; edges in ``distance_edges``), ``elevation``
(pixel centres 90 - (i + 0.5) 90 / n_elevation), ``azimuth`` (relative to the source,
k 360 / n_azimuth), ``component``, ``frequency``; variables ``kernel`` (+ ``kernel_uplight``,
``kernel_garstang_lobe``, ``kernel_tabulated``, ``kernel_<table>`` of a registered shape:
:func:`~nightlights.emission_functions.kernel_table_names`), ``basis``, ``coefficient`` (+
the same ``coefficient_*``), ``basis_fft_real``, ``basis_fft_imag``, ``explained_energy``;
attributes from :meth:`KernelSpec.to_attrs`. Every emission shape's images go into one PCA per
observer altitude, so all shapes share the bases and differ only in their coefficients; a band
whose emission function mixes shapes reads the same mix of coefficient tables (skyglow is
linear in the emission function). With ``shared_bases`` one basis serves every observer
altitude (the same array for each level); with ``pca_error`` the attribute ``pca_mean_error``
holds the reconstruction's measured error.

Streaming: a kernel with one shared basis and without raw tables (:func:`streams`, the
defaults of ``nightlights kernel build``) is built through a temporary folder: each integrated
altitude pair is computed and saved; then each observer level is assembled from them,
interpolated, multiplied by the multiple-scattering factor (computed once for all pairs) and
saved; the shared basis is found from the levels read back a block of images at a
time (:func:`~nightlights.sky.pca.sketched_basis`: a random sketch of all images, the
Rayleigh-Ritz step on it, the number of bases chosen on a sample and checked on every image),
which gives every image's coefficients with it. The memory held is one level's images while
it is assembled, then a block of images, the search's sample of at most 4096 of them, the
sketch and every image's coordinates on it (the order of the output), not the tables.

Length: about 900 lines, because the bin integration, the streamed build, the choice of the
altitude pairs it integrates (and the interpolation of the others) and the assembly of the
dataset are the one build path of a kernel.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 3.3-3.4.1.
"""

from __future__ import annotations

import itertools
import logging
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from rich.progress import (
    BarColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights.emission_functions import emission_shape
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.geometry import source_frame
from nightlights.sky.kernel import sky_luminance_grid
from nightlights.sky.multiple import apply_multiple_scattering, factor_images
from nightlights.sky.pca import LevelDecomposition, compress_kernel, sketched_basis
from nightlights.sky.quadrature import gauss_legendre
from nightlights.sky.spec import KernelSpec

__all__ = [
    "MAX_INTERPOLATED_SPAN",
    "SUPERSAMPLE_DISTANCES",
    "InterpolatedPair",
    "altitude_pairs",
    "compute_kernel",
    "interpolate_pairs",
    "kernel_dataset",
    "kernel_memory",
    "kernel_tables",
    "streams",
    "table_names",
]

log = logging.getLogger(__name__)

#: Largest observer-altitude span [m] across which an altitude pair is interpolated
#: (:func:`altitude_pairs`): the span measured by ``benchmarks/bench_sky_kernel_altitudes.py``,
#: 15 levels of Dobashi's 62.5 m grid (0.07 % mean error, 0.26 % for the worst pair); farther
#: apart levels are integrated rather than interpolated over an unmeasured span.
MAX_INTERPOLATED_SPAN = 15 * 62.5

#: Distances per bin (Gauss-Legendre in ln r) averaged in the supersampled pixels next to the
#: source direction, at least: there the image changes fastest with distance (the source moves
#: across the pixel within one bin).
SUPERSAMPLE_DISTANCES = 4


def table_names(emission: str) -> tuple[str, str]:
    """The (image, coefficient) variables of an emission shape, from its registry row
    (:func:`~nightlights.emission_functions.kernel_table_names`; a tabulated function's
    text: the ``tabulated`` pair)."""
    names = emission_shape(emission).table_names
    if names is None:
        raise InputError(f"emission shape {emission[:40]!r} has no kernel table")
    return names


def _sub_distances(edges: FloatArray, n: int) -> tuple[FloatArray, FloatArray]:
    """Gauss-Legendre nodes in ln r inside each bin and their area weights.

    The bin image is the mean over the annulus, int b r^2 d ln r / int r^2 d ln r; with n
    Gauss-Legendre nodes x_i in ln r the weights are w_i r_i^2 normalised per bin (n = 1: the
    geometric bin centre). Returns distances and weights, shapes ``(n_bins, n)`` [m], [1].
    """
    x, w = gauss_legendre(n)
    frac = 0.5 * (x + 1.0)
    log_e = np.log(edges)
    r_sub = np.exp(log_e[:-1, None] + frac[None, :] * np.diff(log_e)[:, None])
    weight = w[None, :] * r_sub**2
    return r_sub, weight / np.sum(weight, axis=1, keepdims=True)


def _bin_images(
    edges: FloatArray,
    h_c: float,
    h_o: float,
    elevations: FloatArray,
    half_azimuths: FloatArray,
    *,
    n_el: int,
    n_az: int,
    atmosphere: Atmosphere,
    emission: str,
    nodes: int,
    leg_nodes: int | None,
    core_radius: float,
    sub_distances: int,
    sub_pixels: int,
    supersample: int,
    uplight_exponent: float,
    backend: str = "auto",
) -> FloatArray:
    """Bin-averaged images, shape (n_bins, n_el, len(half_azimuths))."""
    r_sub, w_r = _sub_distances(edges, sub_distances)
    offs = (np.arange(sub_pixels) + 0.5) / sub_pixels - 0.5
    el = elevations[:, None] + offs[None, :] * (90.0 / n_el)  # (e, p)
    w_el = np.cos(np.radians(el))
    w_el = w_el / w_el.sum(axis=1, keepdims=True)
    az = half_azimuths[:, None] + offs[None, :] * (360.0 / n_az)  # (a, q)
    b = sky_luminance_grid(
        el.ravel(),
        az.ravel(),
        r_sub.ravel(),
        source_altitude=h_c,
        observer_altitude=h_o,
        atmosphere=atmosphere,
        emission=emission,
        nodes=nodes,
        leg_nodes=leg_nodes,
        core_radius=core_radius,
        uplight_exponent=uplight_exponent,
        backend=backend,
    ).reshape(el.shape + az.shape + r_sub.shape)  # (e, p, a, q, r, s)
    img = np.einsum("epaqrs,ep,rs->rea", b, w_el, w_r) / sub_pixels
    if supersample > sub_pixels:
        _supersample_source_pixels(
            img,
            *_sub_distances(edges, max(sub_distances, SUPERSAMPLE_DISTANCES)),
            h_c,
            h_o,
            elevations,
            half_azimuths,
            n_el=n_el,
            n_az=n_az,
            supersample=supersample,
            atmosphere=atmosphere,
            kwargs={
                "emission": emission,
                "nodes": nodes,
                "leg_nodes": leg_nodes,
                "core_radius": core_radius,
                "uplight_exponent": uplight_exponent,
                "backend": backend,
            },
        )
    return img


def _supersample_source_pixels(
    img: FloatArray,
    r_sub: FloatArray,
    w_r: FloatArray,
    h_c: float,
    h_o: float,
    elevations: FloatArray,
    half_azimuths: FloatArray,
    *,
    n_el: int,
    n_az: int,
    supersample: int,
    atmosphere: Atmosphere,
    kwargs: dict[str, Any],
) -> None:
    """Average, in place, the pixels next to the source direction over m x m directions.

    The source is seen at relative azimuth 0 and elevation el_s(r); pixels of the first two
    azimuth columns whose centre lies within one pixel height of el_s hold the sharp peak of
    rays grazing the source and are averaged over ``supersample``^2 directions (solid-angle
    weights) instead of sampled at their centre.
    """
    d_el = 90.0 / n_el
    d_az = 360.0 / n_az
    pos, _ = source_frame(
        r_sub, h_c, earth_radius=atmosphere.earth_radius, flat_earth=atmosphere.flat_earth
    )
    el_src = np.degrees(np.arctan2(pos[..., 2] - h_o, np.hypot(pos[..., 0], pos[..., 1])))
    near = np.any(np.abs(elevations[None, :, None] - el_src[:, None, :]) < d_el, axis=-1)
    r_idx, e_idx = np.nonzero(near)
    if r_idx.size == 0:
        return
    cols = np.arange(min(2, half_azimuths.size))
    offs = (np.arange(supersample) + 0.5) / supersample - 0.5
    az = (half_azimuths[cols][:, None] + offs[None, :] * d_az).ravel()  # (a q)
    for e in np.unique(e_idx):  # one grid per pixel row: its bins near the source share rays
        rows = r_idx[e_idx == e]
        el = elevations[e] + offs * d_el  # (p,)
        b = sky_luminance_grid(
            el,
            az,
            r_sub[rows].ravel(),
            source_altitude=h_c,
            observer_altitude=h_o,
            atmosphere=atmosphere,
            **kwargs,
        ).reshape(supersample, cols.size, supersample, rows.size, r_sub.shape[1])
        w_el = np.cos(np.radians(el))
        w_el = w_el / w_el.sum()
        img[rows[:, None], e, cols[None, :]] = (
            np.einsum("paqns,p,ns->na", b, w_el, w_r[rows]) / supersample
        )


@dataclass(frozen=True)
class InterpolatedPair:
    """An (observer, source) altitude pair interpolated between two computed pairs of the
    same height difference h_c - h_o: ``exp((1 - weight) ln b_lower + weight ln b_upper)``."""

    observer: int
    source: int
    lower: tuple[int, int]
    upper: tuple[int, int]
    weight: float


def altitude_pairs(
    observer_altitudes: FloatArray,
    source_altitudes: FloatArray,
    step: int,
    *,
    max_span: float = MAX_INTERPOLATED_SPAN,
) -> tuple[NDArray[np.bool_], list[InterpolatedPair]]:
    """Which (observer, source) altitude pairs to compute and how to fill the others.

    Pairs of equal height difference d = h_c - h_o see the same geometry (the source d above
    the observer); their images differ through the air's density and transmission at the
    observer's altitude, which change smoothly (about exponentially) over the scale heights.
    Along each line of equal d, sorted by h_o, every ``step``-th pair and the last are
    computed, and more where two computed pairs would be more than ``max_span`` apart in h_o
    (the next computed pair is then the farthest within ``max_span``, at least the next pair:
    a grid of a few widely spaced levels is computed in full); a pair between two computed
    ones is interpolated log-linearly in h_o (:func:`interpolate_pairs`; exact for a density
    that is exponential in altitude).

    Parameters
    ----------
    observer_altitudes, source_altitudes
        The kernel's levels [m].
    step
        Spacing of the computed pairs along each line, in pairs; 1 computes every pair [1].
    max_span
        Largest observer-altitude span interpolated across [m].

    Returns
    -------
    computed : numpy.ndarray
        Shape ``(n_o, n_c)``, True where the pair is computed.
    interpolated : list of InterpolatedPair
        The other pairs.

    Examples
    --------
    >>> levels = np.arange(5) * 62.5
    >>> computed, interpolated = altitude_pairs(levels, levels, 2)
    >>> int(computed.sum()), len(interpolated)
    (19, 6)
    >>> computed.diagonal().tolist()  # h_c = h_o: levels 0, 2 and 4 computed
    [True, False, True, False, True]
    >>> three = np.array([0.0, 1000.0, 2000.0])  # 1 km apart: beyond MAX_INTERPOLATED_SPAN
    >>> bool(altitude_pairs(three, three, 15)[0].all())
    True
    """
    h_o = np.asarray(observer_altitudes, dtype=float)
    h_c = np.asarray(source_altitudes, dtype=float)
    computed = np.ones((h_o.size, h_c.size), dtype=bool)
    interpolated: list[InterpolatedPair] = []
    if step <= 1:
        return computed, interpolated
    lines: dict[float, list[tuple[int, int]]] = {}
    for o in range(h_o.size):
        for c in range(h_c.size):
            lines.setdefault(round(float(h_c[c] - h_o[o]), 6), []).append((o, c))
    for pairs in lines.values():
        pairs.sort(key=lambda pair: h_o[pair[0]])
        nodes = [0]
        while nodes[-1] < len(pairs) - 1:
            here = nodes[-1]
            nxt = min(here + step, len(pairs) - 1)
            while nxt > here + 1 and h_o[pairs[nxt][0]] - h_o[pairs[here][0]] > max_span * (
                1 + 1e-9
            ):
                nxt -= 1
            nodes.append(nxt)
        for lower, upper in itertools.pairwise(nodes):
            (o0, c0), (o1, c1) = pairs[lower], pairs[upper]
            for o, c in pairs[lower + 1 : upper]:
                computed[o, c] = False
                weight = (h_o[o] - h_o[o0]) / (h_o[o1] - h_o[o0])
                interpolated.append(InterpolatedPair(o, c, (o0, c0), (o1, c1), float(weight)))
    return computed, interpolated


def interpolate_pairs(
    tables: dict[str, NDArray[np.float32]], interpolated: list[InterpolatedPair]
) -> None:
    """Fill, in place, the interpolated altitude pairs of every table (:func:`altitude_pairs`):
    log-linear where both computed images are positive, linear elsewhere."""
    for table in tables.values():
        for pair in interpolated:
            table[pair.observer, pair.source] = _interpolated(
                table[pair.lower], table[pair.upper], pair.weight
            )


def _interpolated(lower: NDArray[Any], upper: NDArray[Any], w: float) -> FloatArray:
    """exp((1 - w) ln lower + w ln upper) where both are positive, linear elsewhere (both
    forms over every pixel, then chosen: vectorised, no gathered copies)."""
    lower, upper = lower.astype(float), upper.astype(float)
    positive = (lower > 0) & (upper > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        logarithmic = np.log(lower)
        logarithmic *= 1.0 - w
        logarithmic += w * np.log(upper)
        np.exp(logarithmic, out=logarithmic)
    return np.where(positive, logarithmic, (1.0 - w) * lower + w * upper)


def streams(spec: KernelSpec) -> bool:
    """Whether :func:`compute_kernel` streams the tables of this specification through disk
    (one shared basis and no raw tables in the output: see the module docstring)."""
    return spec.shared_bases and not spec.store_tables


def kernel_memory(spec: KernelSpec) -> float:
    """Estimated peak memory of :func:`compute_kernel` [B].

    Streamed (:func:`streams`): the larger of the integration (one observer level's float32
    images, all its source altitudes, distances and emission shapes: m images of p pixels,
    and one pair's float64 images) and the shared basis's randomized range finder
    (:func:`~nightlights.sky.pca.sketched_basis`: the sample of images its search reads, a
    level's read buffer, the sketch, every image's coordinates on it and the error check's
    block), and the output: the basis and every image's coefficients. In memory: the float32 tables
    (observer levels x source levels x distances x elevations x azimuths x emissions, held
    twice: the tables and the dataset's copy), one distance row of float64 images while they
    are integrated, and the PCA of one observer level with the stored bases, coefficients
    and basis spectra of every level. q, the directions kept, is bounded by
    min(m, p, :data:`ESTIMATED_COMPONENTS`).

    Parameters
    ----------
    spec
        The kernel's specification.

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> round(kernel_memory(KernelSpec(store_tables=False)) / 2**20)  # 64 x 64 x 256, streamed
    82
    >>> round(kernel_memory(KernelSpec.exact()) / 2**20)  # the exact path, in memory [MiB]
    43
    """
    n_o, n_c = len(spec.observer_altitudes), len(spec.source_altitudes)
    emissions = len(spec.emissions)
    n_r, pixels = spec.n_distance, spec.n_elevation * spec.n_azimuth
    m = emissions * n_c * n_r
    q = min(m, pixels)
    if streams(spec):
        from nightlights.sky.pca import _BLOCK_ROWS, _SEARCH_ROWS, _SKETCH_ROWS, SKETCH_COLUMNS

        k = min(max(1, q // 4), ESTIMATED_COMPONENTS)
        all_images = n_o * m
        width = min(SKETCH_COLUMNS, all_images, pixels)
        # pass 1: a level's float32 images while its pairs' float64 images are integrated
        integrate = 4.0 * m * pixels + 3 * 8.0 * emissions * n_r * pixels
        # pass 2 (pca.sketched_basis): the sample of images searched for the bases, a level's
        # read buffer, the sketch, every image's coordinates on it, the error check's block
        sketch = (
            4.0 * min(_SEARCH_ROWS, all_images) * pixels
            + 4.0 * min(_SKETCH_ROWS, m) * pixels
            + 8.0 * width * pixels
            + 4.0 * all_images * width
            + 8.0 * _BLOCK_ROWS * pixels
        )
        stored = 8.0 * k * pixels + 4.0 * all_images * k  # the basis and the coefficients
        return max(integrate, sketch) + stored
    tables = 4.0 * emissions * n_o * n_c * n_r * pixels
    images = 2 * 8.0 * n_r * pixels
    k = min(max(1, q // 8), ESTIMATED_COMPONENTS)
    decompositions = 8.0 * n_o * q * q  # every level's eigenvectors, held together
    pca = 8.0 * (2 * m * pixels + 2 * q * q + k * pixels)
    stored = 8.0 * n_o * (2 * k * pixels + 2 * m * k)
    held = 2 * tables if spec.store_tables else tables
    return held + images + decompositions + pca + stored


def compute_kernel(
    spec: KernelSpec | None = None, *, backend: str = "auto", progress: bool = True
) -> xr.Dataset:
    """Precompute a skyglow kernel table and compress it by PCA and FFT.

    A specification with shared bases and without raw tables (:func:`streams`) is built one
    observer level at a time through a temporary folder (the system's temporary directory:
    as many bytes as the float32 tables), so that the memory held does not grow with the
    number of observer levels beyond each level's summary and coefficients; others in memory.

    Parameters
    ----------
    spec
        What to tabulate; default ``KernelSpec()``.
    backend
        Line-of-sight integrator, one of :data:`nightlights.sky.kernel.BACKENDS`; not part of
        the content hash (the backends agree to ~1e-5) but recorded in the attributes.
    progress
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Kernel dataset (layout in the module docstring) [cd m-2 lm-1].

    References
    ----------
    Dobashi et al. 2023, Sec. 3.3-3.4 (precomputation, PCA, FFT).

    Examples
    --------
    >>> spec = KernelSpec(r_min=10.0, r_max=1000.0, n_distance=4, n_elevation=4, n_azimuth=8)
    >>> ds = compute_kernel(spec, progress=False)
    >>> ds["kernel"].shape, ds.attrs["content_hash"] == spec.content_hash
    ((1, 1, 4, 4, 8), True)
    """
    spec = spec if spec is not None else KernelSpec()
    check_memory(
        kernel_memory(spec) + KERNEL_FIXED_BYTES,
        f"the kernel of {len(spec.observer_altitudes)} observer x {len(spec.source_altitudes)} "
        f"source levels x {spec.n_distance} distances x {spec.n_elevation} x {spec.n_azimuth} "
        "pixels",
        option="lower n_distance=, n_elevation= or n_azimuth= (or give fewer altitude levels)",
    )
    if streams(spec):
        with tempfile.TemporaryDirectory(prefix="nightlights-kernel-") as folder:
            levels = _LevelFiles(Path(folder))
            multiple_attrs = _stream_tables(spec, levels, backend=backend, progress=progress)
            ds = _finish_dataset(_stream_compress(spec, levels), spec)
    else:
        tables = kernel_tables(spec, backend=backend, progress=progress)
        _check_tables(tables, spec)
        multiple_attrs = apply_multiple_scattering(tables, spec)
        ds = kernel_dataset(tables, spec)
    ds.attrs.update(multiple_attrs)
    ds.attrs["backend"] = "numpy" if backend == "numpy" or spec.leg_nodes is not None else "numba"
    return ds


#: Memory of a build's first calls besides the arrays :func:`kernel_memory` counts [B]: the
#: compiled line-of-sight integrator's code loaded from numba's cache, its threads and the
#: shipped multiple-scattering tables; 105 MiB measured (``VmHWM`` over the imports) for a
#: kernel of 4 distances x 64 x 256 pixels (``bench_memory_estimates.py``). The memory check
#: adds it to :func:`kernel_memory`.
KERNEL_FIXED_BYTES = 105 * 2**20
#: Most bases assumed by :func:`kernel_memory` before they are chosen [1]; the streamed
#: estimate takes a quarter of a level's rank q up to this, the in-memory one an eighth.
#: Calibrated on ``benchmarks/bench_sky_kernel_defaults.py``: bases chosen 103 of q = 2048
#: (Dobashi's configuration, defaults), 33 and 46 of 512 (reduced grid, defaults and exact).
ESTIMATED_COMPONENTS = 256


class _LevelFiles:
    """The arrays of a streamed build in a temporary folder: ``single`` (pass 1, each
    integrated altitude pair's images of single scattering, ``(emissions, n_r, n_el, n_az)``;
    only the integrated pairs are written) and ``final`` (each observer level, interpolated,
    with multiple scattering, ``(emissions, n_c, n_r, n_el, n_az)``), float32."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def single(self, observer: int, source: int) -> Path:
        return self.folder / f"single-{observer}-{source}.npy"

    def final(self, observer: int) -> Path:
        return self.folder / f"final-{observer}.npy"

    def pair(self, observer: int, source: int) -> NDArray[np.float32]:
        """One integrated pair's images of every emission shape."""
        images: NDArray[np.float32] = np.load(self.single(observer, source))
        return images


class _LevelRows:
    """A level's images as rows ``(m, p)``, read from its file a block of rows at a time
    (what :func:`~nightlights.sky.pca.sketched_basis` slices, using each block before it
    reads the next): a block of consecutive rows by one read into ``buffer``, reused from
    block to block and shared by the levels, so valid until the next read (page faults of a
    memory map or of fresh memory cost several times the copy); other keys through a memory
    map, copied."""

    def __init__(self, path: Path, shape: tuple[int, int], buffer: list[NDArray[Any]]) -> None:
        self.path = path
        self.shape = shape
        self._buffer = buffer  # [array] shared by the levels of a build, or []

    def __getitem__(self, key: Any) -> NDArray[np.float32]:
        if isinstance(key, slice) and key.step in (None, 1):
            lo, hi, _ = key.indices(self.shape[0])
            with open(self.path, "rb") as handle:
                version = np.lib.format.read_magic(handle)
                _, fortran, dtype = (
                    np.lib.format.read_array_header_1_0(handle)
                    if version == (1, 0)
                    else np.lib.format.read_array_header_2_0(handle)
                )
                if not fortran:
                    handle.seek(lo * self.shape[1] * dtype.itemsize, 1)
                    count = max(0, hi - lo) * self.shape[1]
                    if not self._buffer or self._buffer[0].size < count:
                        self._buffer[:] = [np.empty(count, dtype=dtype)]
                    rows = self._buffer[0][:count]
                    if handle.readinto(rows.data.cast("B")) != rows.nbytes:
                        raise OSError(f"{self.path}: short read of rows {lo}-{hi}")
                    return rows.reshape(-1, self.shape[1])
        level = np.load(self.path, mmap_mode="r")
        try:
            return np.array(level.reshape(self.shape)[key])
        finally:
            del level


def _stream_tables(
    spec: KernelSpec, levels: _LevelFiles, *, backend: str, progress: bool
) -> dict[str, str]:
    """Integrate the computed pairs level by level (pass 1), then fill each level's
    interpolated pairs, check it and apply the multiple-scattering factor (pass 2); returns
    the multiple-scattering attributes."""
    h_c = np.asarray(spec.source_altitudes, dtype=float)
    h_o = np.asarray(spec.observer_altitudes, dtype=float)
    emissions = spec.emissions
    n_r_bins = spec.edges.size - 1
    shape = (len(emissions), h_c.size, n_r_bins, spec.n_elevation, spec.n_azimuth)
    r_chunk = _distance_chunk(spec, backend)
    computed, interpolated = altitude_pairs(h_o, h_c, spec.altitude_step)
    start = time.perf_counter()
    with Progress(*_COLUMNS, disable=not progress, transient=True) as bar:
        task = bar.add_task("kernel", total=int(computed.sum()) * len(emissions))
        for o, c in zip(*np.nonzero(computed), strict=True):
            images = np.zeros((shape[0], *shape[2:]), dtype=np.float32)
            for i, emission in enumerate(emissions):
                for lo in range(0, n_r_bins, r_chunk):
                    sl = slice(lo, min(lo + r_chunk, n_r_bins))
                    images[i, sl] = pair_images(spec, o, c, emission, bins=sl, backend=backend)
                bar.advance(task)
            np.save(levels.single(o, c), images)
            del images
    log.info("kernel images computed in %.1f s", time.perf_counter() - start)
    factors, attrs = factor_images(spec)  # the same for every altitude pair
    positive = np.zeros(len(emissions), dtype=bool)
    for o in range(h_o.size):
        level = np.zeros(shape, dtype=np.float32)
        for c in np.flatnonzero(computed[o]).tolist():
            level[:, c] = levels.pair(o, c)
        for pair in (p for p in interpolated if p.observer == o):
            lower = levels.pair(*pair.lower)
            upper = levels.pair(*pair.upper)
            level[:, pair.source] = _interpolated(lower, upper, pair.weight)
        tables = {emission: level[i][None] for i, emission in enumerate(emissions)}
        _check_finite(tables, spec)
        positive |= [bool(np.any(table > 0)) for table in tables.values()]
        for i, emission in enumerate(emissions):
            if emission in factors:
                level[i] *= factors[emission].astype(level.dtype)
        np.save(levels.final(o), level)
        del level, tables
    for o, c in zip(*np.nonzero(computed), strict=True):
        levels.single(o, c).unlink()
    for emission, any_positive in zip(emissions, positive, strict=True):
        if not any_positive:
            _refuse_zero(emission, spec)
    return attrs


def _stream_compress(spec: KernelSpec, levels: _LevelFiles) -> xr.Dataset:
    """The shared PCA of the levels on disk (:func:`~nightlights.sky.pca.sketched_basis`:
    every level read a block of rows at a time to sketch the images, to take their
    coordinates and, with an error target, to check it)."""
    n_o, n_c = len(spec.observer_altitudes), len(spec.source_altitudes)
    n_r, n_el, n_az = spec.n_distance, spec.n_elevation, spec.n_azimuth
    emissions = spec.emissions
    m, p = len(emissions) * n_c * n_r, n_el * n_az
    dtype = np.float32 if spec.precision == "float32" else np.float64
    buffer: list[NDArray[Any]] = []  # one read buffer for every level
    images = [_LevelRows(levels.final(o), (m, p), buffer) for o in range(n_o)]
    basis, coefficients, explained, achieved = sketched_basis(
        images,
        energy=spec.pca_energy,
        n_components=spec.n_components,
        error=spec.pca_error,
        dtype=dtype,
    )
    basis = basis.astype(dtype).astype(float)
    k = basis.shape[0]
    coefs = np.stack(coefficients).astype(dtype).astype(float)
    basis_img = basis.reshape(k, n_el, n_az)
    spectrum = np.fft.rfft(basis_img, axis=-1)
    dims_c = ("observer_altitude", "source_altitude", "distance", "component")
    dims_b = ("observer_altitude", "component", "elevation", "azimuth")
    dims_f = ("observer_altitude", "component", "elevation", "frequency")
    per_level = (n_o, k, n_el)
    data: dict[str, Any] = {
        "basis": (dims_b, np.broadcast_to(basis_img, (*per_level, n_az)), {"units": "1"}),
        "basis_fft_real": (
            dims_f,
            np.broadcast_to(spectrum.real, (*per_level, n_az // 2 + 1)),
            {"units": "1", "transform": "rfft over azimuth"},
        ),
        "basis_fft_imag": (
            dims_f,
            np.broadcast_to(spectrum.imag, (*per_level, n_az // 2 + 1)),
            {"units": "1", "transform": "rfft over azimuth"},
        ),
        "explained_energy": (("observer_altitude",), np.full(n_o, explained), {"units": "1"}),
    }
    for i, emission in enumerate(emissions):
        part = coefs[:, i * n_c * n_r : (i + 1) * n_c * n_r].reshape(n_o, n_c, n_r, k)
        attrs = {"units": "cd m-2 lm-1", "emission": emission.partition(":")[0]}
        data[table_names(emission)[1]] = (dims_c, part, attrs)
    ds = xr.Dataset(data)
    ds.attrs["pca_components"] = k
    if spec.pca_error is not None and spec.n_components is None:
        ds.attrs["pca_mean_error"] = achieved
    return ds.assign_coords(component=np.arange(k), frequency=np.arange(n_az // 2 + 1))


def kernel_dataset(
    tables: dict[str, NDArray[np.float32]],
    spec: KernelSpec,
    *,
    decompositions: list[LevelDecomposition] | None = None,
) -> xr.Dataset:
    """The kernel dataset of a specification's tables: PCA and FFT, coordinates, attributes.

    Parameters
    ----------
    tables
        Emission shape -> images, shape ``(n_o, n_c, n_r, n_el, n_az)`` [cd m-2 lm-1]
        (:func:`kernel_tables`).
    spec
        The specification they were computed from (its compression options apply).
    decompositions
        The observer levels' decompositions of these tables
        (:func:`~nightlights.sky.pca.decompose_levels` of the stacked shapes), to reuse
        between compressions of the same tables; computed when None.

    Returns
    -------
    xarray.Dataset
        Kernel dataset (layout in the module docstring) [cd m-2 lm-1].
    """
    return _finish_dataset(_compress(tables, spec, decompositions), spec)


def _finish_dataset(ds: xr.Dataset, spec: KernelSpec) -> xr.Dataset:
    """The compressed variables with the kernel's coordinates and attributes."""
    h_c = np.asarray(spec.source_altitudes, dtype=float)
    h_o = np.asarray(spec.observer_altitudes, dtype=float)
    elevations, azimuths, edges = spec.elevations, spec.azimuths, spec.edges
    ds = ds.assign_coords(
        observer_altitude=("observer_altitude", h_o, {"units": "m"}),
        source_altitude=("source_altitude", h_c, {"units": "m"}),
        distance=(
            "distance",
            spec.distances,
            {"units": "m", "long_name": "bin centre (geometric)"},
        ),
        elevation=("elevation", elevations, {"units": "deg"}),
        azimuth=("azimuth", azimuths, {"units": "deg", "long_name": "relative to the source"}),
    )
    ds["distance_edges"] = ("distance_edge", edges, {"units": "m"})
    ds.attrs.update(spec.to_attrs())
    ds.attrs["pca_centered"] = 0
    ds.attrs["pca_row_normalised"] = 1
    ds.attrs["units"] = "cd m-2 lm-1"
    ds.attrs["emission"] = (
        "lambertian (kernel); sin^n lobe (kernel_uplight)"
        + ("; Garstang 1986 psi^4 lobe (kernel_garstang_lobe)" if spec.garstang_lobe else "")
        + ("; tabulated_emission (kernel_tabulated)" if spec.tabulated_emission else "")
        + "".join(f"; {name} ({table_names(name)[0]})" for name in spec.emission_shapes)
    )
    ds.attrs["description"] = (
        "Sky luminance per lumen of upward flux of a ground source: single scattering "
        "(nightlights.sky, Dobashi et al. 2023 Sec. 3), times the Monte Carlo "
        f"multiple-scattering factor (multiple_scattering = {spec.multiple_scattering})"
    )
    return ds


def pair_images(
    spec: KernelSpec,
    observer: int,
    source: int,
    emission: str,
    *,
    bins: slice = slice(None),
    nodes: int | None = None,
    backend: str = "auto",
) -> FloatArray:
    """The bin images of one (observer, source) altitude pair, integrated (never interpolated).

    Parameters
    ----------
    spec
        What to tabulate.
    observer, source
        Indices of the observer and source altitudes [1].
    emission
        Emission shape.
    bins
        Distance bins to integrate (default all).
    nodes
        Gauss nodes per panel (default the spec's).
    backend
        Line-of-sight integrator (:func:`compute_kernel`).

    Returns
    -------
    numpy.ndarray
        Shape ``(n_bins, n_el, n_az)`` [cd m-2 lm-1], single scattering, the azimuths past 180
        deg mirrored.
    """
    n_az = spec.n_azimuth
    first, last, _ = bins.indices(spec.edges.size - 1)
    img = _bin_images(
        spec.edges[first : last + 1],
        float(np.asarray(spec.source_altitudes, dtype=float)[source]),
        float(np.asarray(spec.observer_altitudes, dtype=float)[observer]),
        spec.elevations,
        spec.azimuths[: n_az // 2 + 1],
        n_el=spec.n_elevation,
        n_az=n_az,
        atmosphere=spec.atmosphere,
        emission=emission,
        nodes=spec.nodes if nodes is None else nodes,
        leg_nodes=spec.leg_nodes,
        core_radius=spec.core_radius,
        sub_distances=spec.sub_distances,
        sub_pixels=spec.sub_pixels,
        supersample=spec.supersample,
        uplight_exponent=spec.uplight_exponent,
        backend=backend,
    )
    return img[:, :, np.minimum(np.arange(n_az), n_az - np.arange(n_az))]


def kernel_tables(
    spec: KernelSpec, *, backend: str = "auto", progress: bool = True
) -> dict[str, NDArray[np.float32]]:
    """The bin images of every emission shape of a kernel, before compression.

    Parameters
    ----------
    spec
        What to tabulate.
    backend
        Line-of-sight integrator (:func:`compute_kernel`).
    progress
        Show a progress bar.

    Returns
    -------
    dict
        Emission shape -> float32 images, shape ``(n_o, n_c, n_r, n_el, n_az)``
        [cd m-2 lm-1] (single scattering).
    """
    n_el, n_az = spec.n_elevation, spec.n_azimuth
    h_c = np.asarray(spec.source_altitudes, dtype=float)
    h_o = np.asarray(spec.observer_altitudes, dtype=float)
    n_r_bins = spec.edges.size - 1
    emissions = spec.emissions
    shape = (h_o.size, h_c.size, n_r_bins, n_el, n_az)
    tables = {e: np.zeros(shape, dtype=np.float32) for e in emissions}
    r_chunk = _distance_chunk(spec, backend)
    computed, interpolated = altitude_pairs(h_o, h_c, spec.altitude_step)
    steps = [
        (o, c, e, lo)
        for o, c in zip(*np.nonzero(computed), strict=True)
        for e in emissions
        for lo in range(0, n_r_bins, r_chunk)
    ]
    start = time.perf_counter()
    with Progress(*_COLUMNS, disable=not progress, transient=True) as bar:
        task = bar.add_task("kernel", total=len(steps))
        for o, c, e, lo in steps:
            sl = slice(lo, min(lo + r_chunk, n_r_bins))
            tables[e][o, c, sl] = pair_images(spec, o, c, e, bins=sl, backend=backend)
            bar.advance(task)
    log.info("kernel images computed in %.1f s", time.perf_counter() - start)
    interpolate_pairs(tables, interpolated)
    return tables


#: Columns of the precompute's progress bar.
_COLUMNS = (
    TextColumn("kernel"),
    BarColumn(),
    TextColumn("{task.completed}/{task.total}"),
    TimeElapsedColumn(),
    TimeRemainingColumn(),
)


def _distance_chunk(spec: KernelSpec, backend: str) -> int:
    """Distance bins integrated per call: all with the compiled grid (no temporaries), fewer
    with the numpy path (bounding its temporaries) [1]."""
    n_r_bins = spec.edges.size - 1
    if backend == "numpy" or spec.leg_nodes is not None:
        half = spec.n_azimuth // 2 + 1
        pixels = spec.n_elevation * half * spec.sub_pixels**2 * spec.sub_distances
        return min(max(1, int(2_000 // max(1, pixels // 64))), n_r_bins)
    return n_r_bins


def _compress(
    tables: dict[str, np.ndarray],
    spec: KernelSpec,
    decompositions: list[LevelDecomposition] | None = None,
) -> xr.Dataset:
    """PCA of all emission shapes' tables together (shared bases), one variable pair each.

    The Lambertian and uplight tables go through :func:`compress_kernel` as they always did;
    further shapes are stacked after them along the source-altitude axis (the PCA rows are
    then the Lambertian, uplight and further images in that order, as with two tables) and
    their coefficients split off again.
    """
    emissions = list(tables)
    extra = [e for e in emissions if e not in ("lambertian", "uplight")]
    if not extra:
        return compress_kernel(
            tables["lambertian"],
            tables.get("uplight"),
            **_pca_options(spec),
            decompositions=decompositions,
        )
    n_c = tables["lambertian"].shape[1]
    stacked = np.concatenate([tables[e] for e in emissions], axis=1)
    ds = compress_kernel(
        stacked,
        **_pca_options(spec),
        decompositions=decompositions,
    )
    unit = {"units": "cd m-2 lm-1"}
    coefficient = ds["coefficient"]
    images = ds["kernel"] if spec.store_tables else None
    ds = ds.drop_vars([name for name in ("kernel", "coefficient") if name in ds])
    for index, emission in enumerate(emissions):
        image_name, coefficient_name = table_names(emission)
        part = {"source_altitude": slice(index * n_c, (index + 1) * n_c)}
        attrs = unit | {"emission": emission.partition(":")[0]}
        ds[coefficient_name] = (coefficient.dims, coefficient[part].values, attrs)
        if images is not None:
            ds[image_name] = (images.dims, images[part].values, attrs)
    return ds


def _pca_options(spec: KernelSpec) -> dict[str, Any]:
    """The keyword arguments of :func:`compress_kernel` a specification sets."""
    return {
        "pca_energy": spec.pca_energy,
        "n_components": spec.n_components,
        "store_tables": spec.store_tables,
        "pca_error": spec.pca_error,
        "shared_bases": spec.shared_bases,
        "precision": spec.precision,
    }


def _check_tables(tables: dict[str, np.ndarray], spec: KernelSpec) -> None:
    """Refuse a kernel that is zero everywhere or not finite: it would render a black sky
    for any scene."""
    _check_finite(tables, spec)
    for emission, table in tables.items():
        if not np.any(table > 0):
            _refuse_zero(emission, spec)


def _check_finite(tables: dict[str, np.ndarray], spec: KernelSpec) -> None:
    """Refuse tables with non-finite values."""
    for emission, table in tables.items():
        if not np.all(np.isfinite(table)):
            raise InputError(
                f"the {emission[:40]} kernel has non-finite values; check the atmosphere"
            )


def _refuse_zero(emission: str, spec: KernelSpec) -> None:
    """Refuse a shape whose table is zero everywhere."""
    atm = spec.atmosphere
    raise InputError(
        f"the {emission[:40]} kernel is zero everywhere: with turbidity {atm.turbidity:g} "
        f"(aerosol optical depth {atm.aerosol_depth:.3g}) no light reaches the observer "
        f"from {spec.r_min:g}-{spec.r_max:g} m; lower the turbidity or optical depth"
    )
