"""Precomputed skyglow kernels: tables over distance and altitudes, PCA, FFT, cache.

A kernel table holds, for each observer altitude h_o, source altitude h_c and distance bin r,
the panorama b(elevation, relative azimuth) [cd m-2 lm-1] of sky luminance per lumen emitted
upwards by a ground source in that bin (Dobashi et al. 2023, Sec. 3.4.1). Each bin image is the
area-weighted average of :func:`nightlights.sky.kernel.sky_luminance` over ``sub_distances``
Gauss-Legendre nodes in ln r inside the bin (weights r^2 d ln r, i.e. flux spread evenly over
the annulus; 1 = the geometric bin centre), optionally averaged over ``sub_pixels`` x
``sub_pixels`` directions inside each pixel (solid-angle weights). Pixels next to the source
direction, where rays graze the source, are always averaged over ``supersample`` x
``supersample`` directions and at least 4 distances. Relative azimuths are
symmetric: only 0-180 deg are computed and mirrored.

Compression (Dobashi 2023, Eq. 4): per observer altitude, the images (rows) are normalised to
unit norm and decomposed by a truncated SVD (eigen-decomposition of the smaller Gram matrix);
the number of components is the smallest reaching the explained-energy target (the largest over
observer altitudes), or given. Normalising rows lets faint, distant images weigh as much as
bright, nearby ones; the basis is orthonormal and coefficients are projections of the raw
images, so kernel ~= sum_k coefficient_k basis_k (no mean is subtracted: ``pca_centered = 0``).
Basis images are Fourier-transformed over azimuth (rfft) for the runtime (Dobashi 2023, Eq. 9).

Dataset layout (shared with the runtime, issue 4): coordinates ``observer_altitude``,
``source_altitude``, ``distance`` (bin centres; edges in ``distance_edges``), ``elevation``
(pixel centres 90 - (i + 0.5) 90 / n_el), ``azimuth`` (relative to the source, k 360 / n_az),
``component``, ``frequency``; variables ``kernel`` (+ ``kernel_uplight``), ``basis``,
``coefficient`` (+ ``coefficient_uplight``), ``basis_fft_real``, ``basis_fft_imag``,
``explained_energy``; attributes with every model parameter and ``content_hash``.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from nightlights.errors import InputError
from nightlights.io.atomic import atomic_output
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.geometry import source_frame
from nightlights.sky.kernel import UPLIGHT_EXPONENT, sky_luminance_grid
from nightlights.sky.quadrature import gauss_legendre

__all__ = [
    "KERNEL_FORMAT_VERSION",
    "build_kernel",
    "default_cache_dir",
    "distance_grid",
    "get_or_build_kernel",
    "kernel_build_stage",
    "kernel_cache_path",
    "kernel_parameters",
    "panorama_elevations",
    "pca_compress",
    "read_kernel",
    "relative_azimuths",
    "write_kernel",
]

log = logging.getLogger(__name__)

#: Bumped whenever the physics or the file layout changes, so that caches are rebuilt.
KERNEL_FORMAT_VERSION = 2

FloatArray = NDArray[np.float64]

_REQUIRED_VARIABLES = (
    "basis",
    "coefficient",
    "basis_fft_real",
    "basis_fft_imag",
    "distance_edges",
)


def panorama_elevations(n_el: int) -> FloatArray:
    """Elevation pixel centres of the panorama, zenith first: 90 - (i + 0.5) 90 / n_el [deg].

    Parameters
    ----------
    n_el
        Number of elevation rows [-].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_el,)`` [deg].
    """
    return 90.0 - (np.arange(n_el) + 0.5) * 90.0 / n_el


def relative_azimuths(n_az: int) -> FloatArray:
    """Kernel azimuths relative to the source direction, k 360 / n_az [deg].

    Parameters
    ----------
    n_az
        Number of azimuth columns [-].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_az,)`` [deg].
    """
    return np.arange(n_az) * 360.0 / n_az


def distance_grid(r_min: float, r_max: float, n_r: int) -> FloatArray:
    """Log-spaced distance bin edges.

    Parameters
    ----------
    r_min
        Inner edge of the first bin, > 0 [m].
    r_max
        Outer edge of the last bin [m].
    n_r
        Number of bins [-].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_r + 1,)`` [m].
    """
    if not (0 < r_min < r_max) or n_r < 1:
        raise InputError(
            f"distance grid r_min={r_min!r} m, r_max={r_max!r} m, n_r={n_r!r}; "
            "expected 0 < r_min < r_max and n_r >= 1"
        )
    return np.geomspace(r_min, r_max, n_r + 1)


def _check_edges(edges: ArrayLike) -> FloatArray:
    e = np.asarray(edges, dtype=float).ravel()
    if e.size < 2 or e[0] <= 0 or np.any(np.diff(e) <= 0) or not np.all(np.isfinite(e)):
        raise InputError(
            f"distance_edges {e.tolist()!r}; expected >= 2 increasing finite values > 0 m"
        )
    return e


def kernel_parameters(
    *,
    distance_edges: ArrayLike | None = None,
    r_min: float = 10.0,
    r_max: float = 100_000.0,
    n_r: int = 64,
    source_altitudes: Sequence[float] = (0.0,),
    observer_altitudes: Sequence[float] = (0.0,),
    n_el: int = 32,
    n_az: int = 128,
    atmosphere: Atmosphere | None = None,
    nodes: int = 12,
    leg_nodes: int | None = None,
    core_radius: float = 1.0,
    sub_distances: int = 1,
    sub_pixels: int = 1,
    supersample: int = 8,
    uplight: bool = False,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    pca_energy: float = 0.999999,
    n_components: int | None = None,
    store_tables: bool = True,
) -> dict[str, Any]:
    """Normalised, JSON-serialisable description of a kernel, hashed into its content hash.

    Parameters are those of :func:`build_kernel` (without ``progress``).

    Returns
    -------
    dict
        Every parameter and grid, with ``content_hash`` (sha256 of the rest).
    """
    atm = atmosphere if atmosphere is not None else Atmosphere()
    edges = _check_edges(
        distance_grid(r_min, r_max, n_r) if distance_edges is None else distance_edges
    )
    h_c = np.sort(np.asarray(source_altitudes, dtype=float).ravel())
    h_o = np.sort(np.asarray(observer_altitudes, dtype=float).ravel())
    if h_c.size == 0 or h_o.size == 0:
        raise InputError(
            "source_altitudes and observer_altitudes; expected at least one value each"
        )
    for name, levels in (("source_altitudes", h_c), ("observer_altitudes", h_o)):
        if np.any(np.diff(levels) <= 0) or not np.all(np.isfinite(levels)):
            raise InputError(f"{name} {levels.tolist()!r} m; expected distinct finite altitudes")
    if n_el < 1 or n_az < 2 or n_az % 2:
        raise InputError(f"n_el={n_el!r}, n_az={n_az!r}; expected n_el >= 1 and an even n_az >= 2")
    if sub_distances < 1 or sub_pixels < 1:
        raise InputError(
            f"sub_distances={sub_distances!r}, sub_pixels={sub_pixels!r}; expected >= 1"
        )
    if n_components is None and not 0 < pca_energy <= 1:
        raise InputError(f"pca_energy {pca_energy!r}; expected 0 < energy <= 1")
    if n_components is not None and n_components < 1:
        raise InputError(f"n_components {n_components!r}; expected >= 1")
    params: dict[str, Any] = {
        "kernel_format_version": KERNEL_FORMAT_VERSION,
        "distance_edges": [float(x) for x in edges],
        "source_altitudes": [float(x) for x in h_c],
        "observer_altitudes": [float(x) for x in h_o],
        "n_el": int(n_el),
        "n_az": int(n_az),
        "atmosphere": atm.parameters(),
        "nodes": int(nodes),
        "leg_nodes": None if leg_nodes is None else int(leg_nodes),
        "core_radius": float(core_radius),
        "sub_distances": int(sub_distances),
        "sub_pixels": int(sub_pixels),
        "supersample": int(supersample),
        "uplight": bool(uplight),
        "uplight_exponent": float(uplight_exponent),
        "pca_energy": float(pca_energy),
        "n_components": None if n_components is None else int(n_components),
        "store_tables": bool(store_tables),
    }
    text = json.dumps(params, sort_keys=True, separators=(",", ":"))
    params["content_hash"] = hashlib.sha256(text.encode()).hexdigest()
    return params


#: Distances per bin (Gauss-Legendre in ln r) averaged in the supersampled pixels next to the
#: source direction, at least: there the image changes fastest with distance (the source moves
#: across the pixel within one bin).
SUPERSAMPLE_DISTANCES = 4


def _sub_distances(edges: FloatArray, n: int) -> tuple[FloatArray, FloatArray]:
    """Gauss-Legendre nodes in ln r inside each bin and their area weights.

    The bin image is the mean over the annulus, int b r^2 d ln r / int r^2 d ln r; with n
    Gauss-Legendre nodes x_i in ln r the weights are w_i r_i^2 normalised per bin (n = 1: the
    geometric bin centre). Returns distances and weights, shapes ``(n_bins, n)`` [m], [-].
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


def pca_compress(
    images: FloatArray, *, energy: float = 0.999999, n_components: int | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Truncated SVD of a stack of images with unit-normalised rows.

    Parameters
    ----------
    images
        Shape ``(m, p)``: m images of p pixels [cd m-2 lm-1].
    energy
        Explained-energy target of the normalised images, used when ``n_components`` is None [-].
    n_components
        Number of components to keep [-].

    Returns
    -------
    basis : numpy.ndarray
        Shape ``(k, p)``, orthonormal rows [-].
    coefficient : numpy.ndarray
        Shape ``(m, k)``: projections of the images on the basis [cd m-2 lm-1].
    explained : numpy.ndarray
        Cumulative explained energy of the normalised images, shape ``(min(m, p),)`` [-].

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


def build_kernel(
    *,
    distance_edges: ArrayLike | None = None,
    r_min: float = 10.0,
    r_max: float = 100_000.0,
    n_r: int = 64,
    source_altitudes: Sequence[float] = (0.0,),
    observer_altitudes: Sequence[float] = (0.0,),
    n_el: int = 32,
    n_az: int = 128,
    atmosphere: Atmosphere | None = None,
    nodes: int = 12,
    leg_nodes: int | None = None,
    core_radius: float = 1.0,
    sub_distances: int = 1,
    sub_pixels: int = 1,
    supersample: int = 8,
    uplight: bool = False,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    pca_energy: float = 0.999999,
    n_components: int | None = None,
    progress: bool = True,
    backend: str = "auto",
    store_tables: bool = True,
) -> xr.Dataset:
    """Precompute a skyglow kernel table, compress it by PCA and FFT.

    Parameters
    ----------
    distance_edges
        Distance bin edges, increasing, > 0; default log-spaced from ``r_min``, ``r_max``,
        ``n_r`` [m].
    r_min, r_max
        Range of the default distance grid [m].
    n_r
        Number of distance bins of the default grid [-].
    source_altitudes
        Source altitudes h_c above sea level [m].
    observer_altitudes
        Observer altitudes h_o above sea level [m].
    n_el, n_az
        Panorama rows (elevation, 0-90 deg) and columns (even; azimuth, 0-360 deg) [-].
    atmosphere
        Atmosphere model; default :class:`~nightlights.sky.atmosphere.Atmosphere` [-].
    nodes
        Gauss-Legendre nodes on each side of the closest approach [-].
    leg_nodes
        None: closed-form leg optical depths; an integer: Gauss nodes per leg [-].
    core_radius
        Softening radius of the point source [m].
    sub_distances
        Gauss-Legendre distances in ln r averaged per bin (area weighted); 1 = the geometric
        bin centre (within 0.4 % of the converged bin mean at 64-128 bins, 2: 0.07 %); the
        pixels next to the source direction always average at least 4 [-].
    sub_pixels
        Directions per pixel side averaged (solid-angle weighted) [-].
    supersample
        Directions per pixel side averaged in the pixels next to the source direction, where
        rays graze the source (observer next to a lit cell, sources above the observer) [-].
    uplight
        Also compute ``kernel_uplight`` for the low-angle direct-uplight lobe [-].
    uplight_exponent
        Exponent n of the uplight lobe sin^n [-].
    pca_energy
        Explained-energy target choosing the number of components [-].
    n_components
        Number of components (overrides ``pca_energy``) [-].
    progress
        Show a progress bar [-].
    backend
        Line-of-sight integrator, one of :data:`nightlights.sky.kernel.BACKENDS`; not part of
        the content hash (the backends agree to ~1e-5) but recorded in the attributes [-].
    store_tables
        Keep the raw images (``kernel``, ``kernel_uplight``) next to the PCA bases; they are
        needed only by ``exact`` mode and are most of the file (2.2 of 2.9 GB for Dobashi's
        configuration) [-].

    Returns
    -------
    xarray.Dataset
        Kernel dataset in the skyglow contract format [cd m-2 lm-1].

    References
    ----------
    Dobashi et al. 2023, Sec. 3.3-3.4 (precomputation, PCA, FFT).
    """
    params = kernel_parameters(
        distance_edges=distance_edges,
        r_min=r_min,
        r_max=r_max,
        n_r=n_r,
        source_altitudes=source_altitudes,
        observer_altitudes=observer_altitudes,
        n_el=n_el,
        n_az=n_az,
        atmosphere=atmosphere,
        nodes=nodes,
        leg_nodes=leg_nodes,
        core_radius=core_radius,
        sub_distances=sub_distances,
        sub_pixels=sub_pixels,
        supersample=supersample,
        uplight=uplight,
        uplight_exponent=uplight_exponent,
        pca_energy=pca_energy,
        n_components=n_components,
        store_tables=store_tables,
    )
    atm = atmosphere if atmosphere is not None else Atmosphere()
    edges = np.asarray(params["distance_edges"])
    h_c = np.asarray(params["source_altitudes"])
    h_o = np.asarray(params["observer_altitudes"])
    n_r_bins = edges.size - 1
    centres = np.sqrt(edges[:-1] * edges[1:])
    elevations = panorama_elevations(n_el)
    azimuths = relative_azimuths(n_az)
    half = azimuths[: n_az // 2 + 1]
    mirror = np.minimum(np.arange(n_az), n_az - np.arange(n_az))
    emissions = ("lambertian", "uplight") if uplight else ("lambertian",)
    shape = (h_o.size, h_c.size, n_r_bins, n_el, n_az)
    tables = {e: np.zeros(shape, dtype=np.float32) for e in emissions}
    if backend == "numpy" or leg_nodes is not None:  # bound the numpy path's temporaries
        pixels = n_el * half.size * sub_pixels**2 * sub_distances
        r_chunk = min(max(1, int(2_000 // max(1, pixels // 64))), n_r_bins)
    else:  # the compiled grid makes no temporaries: all bins at once (one table per row)
        r_chunk = n_r_bins
    steps = [
        (o, c, e, lo)
        for o in range(h_o.size)
        for c in range(h_c.size)
        for e in emissions
        for lo in range(0, n_r_bins, r_chunk)
    ]
    start = time.perf_counter()
    columns = (
        TextColumn("kernel"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
    )
    with Progress(*columns, disable=not progress, transient=True) as bar:
        task = bar.add_task("kernel", total=len(steps))
        for o, c, e, lo in steps:
            sl = slice(lo, min(lo + r_chunk, n_r_bins))
            img = _bin_images(
                edges[sl.start : sl.stop + 1],
                float(h_c[c]),
                float(h_o[o]),
                elevations,
                half,
                n_el=n_el,
                n_az=n_az,
                atmosphere=atm,
                emission=e,
                nodes=nodes,
                leg_nodes=leg_nodes,
                core_radius=core_radius,
                sub_distances=sub_distances,
                sub_pixels=sub_pixels,
                supersample=supersample,
                uplight_exponent=uplight_exponent,
                backend=backend,
            )
            tables[e][o, c, sl] = img[:, :, mirror]
            bar.advance(task)
    log.info("kernel images computed in %.1f s", time.perf_counter() - start)
    ds = compress_kernel(
        tables["lambertian"],
        tables.get("uplight"),
        pca_energy=pca_energy,
        n_components=n_components,
        store_tables=store_tables,
    )
    ds = ds.assign_coords(
        observer_altitude=("observer_altitude", h_o, {"units": "m"}),
        source_altitude=("source_altitude", h_c, {"units": "m"}),
        distance=("distance", centres, {"units": "m", "long_name": "bin centre (geometric)"}),
        elevation=("elevation", elevations, {"units": "deg"}),
        azimuth=("azimuth", azimuths, {"units": "deg", "long_name": "relative to the source"}),
    )
    ds["distance_edges"] = ("distance_edge", edges, {"units": "m"})
    ds.attrs.update(_attributes(params))
    ds.attrs["backend"] = "numpy" if backend == "numpy" or leg_nodes is not None else "numba"
    return ds


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
        Explained-energy target [-].
    n_components
        Number of components (overrides ``pca_energy``) [-].
    store_tables
        Include the raw images ``kernel`` (and ``kernel_uplight``) [-].

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


def _attributes(params: dict[str, Any]) -> dict[str, Any]:
    attrs: dict[str, Any] = {}
    for key, value in params["atmosphere"].items():
        attrs[key] = value
    attrs["leg_nodes"] = -1 if params["leg_nodes"] is None else params["leg_nodes"]
    for key in (
        "nodes",
        "core_radius",
        "sub_distances",
        "sub_pixels",
        "supersample",
        "uplight_exponent",
        "pca_energy",
        "kernel_format_version",
        "content_hash",
    ):
        attrs[key] = params[key]
    attrs["uplight"] = int(params["uplight"])
    attrs["store_tables"] = int(params["store_tables"])
    attrs["n_components_requested"] = (
        -1 if params["n_components"] is None else params["n_components"]
    )
    attrs["pca_centered"] = 0
    attrs["pca_row_normalised"] = 1
    attrs["units"] = "cd m-2 lm-1"
    attrs["emission"] = "lambertian (kernel); sin^n lobe (kernel_uplight)"
    attrs["description"] = (
        "Single-scattering sky luminance per lumen of upward flux of a ground source "
        "(nightlights.sky, Dobashi et al. 2023 Sec. 3)"
    )
    return attrs


def write_kernel(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a kernel dataset to NetCDF (h5netcdf) atomically.

    Parameters
    ----------
    ds
        Kernel dataset [-].
    path
        Output path [-].

    Returns
    -------
    pathlib.Path
        The written path.
    """
    target = Path(path)
    with atomic_output(target) as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf")
    return target


def read_kernel(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a kernel dataset written by :func:`write_kernel`, loaded into memory.

    Parameters
    ----------
    path
        NetCDF file [-].

    Returns
    -------
    xarray.Dataset
        Kernel dataset [-].
    """
    source = Path(path)
    if not source.is_file():
        raise InputError(f"{source}: kernel file does not exist")
    try:
        ds = xr.load_dataset(source, engine="h5netcdf")
    except (OSError, ValueError) as exc:
        raise InputError(f"{source}: not a readable NetCDF kernel ({exc})") from exc
    missing = [name for name in _REQUIRED_VARIABLES if name not in ds]
    if missing or "content_hash" not in ds.attrs:
        raise InputError(
            f"{source}: not a skyglow kernel; missing {missing or ['content_hash attribute']}"
        )
    return ds


def default_cache_dir() -> Path:
    """Kernel cache folder: ``$NIGHTLIGHTS_CACHE/sky`` or ``~/.cache/nightlights/sky``.

    Returns
    -------
    pathlib.Path
        Folder (not created) [-].
    """
    root = os.environ.get("NIGHTLIGHTS_CACHE")
    base = Path(root) if root else Path.home() / ".cache" / "nightlights"
    return base / "sky"


def kernel_cache_path(
    params: dict[str, Any] | str, cache_dir: str | os.PathLike[str] | None = None
) -> Path:
    """Cache file of a kernel, keyed by its content hash.

    Parameters
    ----------
    params
        Output of :func:`kernel_parameters`, or a content hash [-].
    cache_dir
        Cache folder; default :func:`default_cache_dir` [-].

    Returns
    -------
    pathlib.Path
        ``<cache_dir>/kernel-<hash[:24]>.nc`` [-].
    """
    digest = params if isinstance(params, str) else str(params["content_hash"])
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    return folder / f"kernel-{digest[:24]}.nc"


def get_or_build_kernel(
    *, cache_dir: str | os.PathLike[str] | None = None, progress: bool = True, **kwargs: Any
) -> xr.Dataset:
    """Return a cached kernel whose content hash matches the parameters, or build and cache it.

    Parameters
    ----------
    cache_dir
        Cache folder; default :func:`default_cache_dir` [-].
    progress
        Show a progress bar while building [-].
    **kwargs
        Parameters of :func:`build_kernel` [-].

    Returns
    -------
    xarray.Dataset
        Kernel dataset [-].
    """
    params = kernel_parameters(**{k: v for k, v in kwargs.items() if k != "backend"})
    path = kernel_cache_path(params, cache_dir)
    if path.is_file():
        try:
            ds = read_kernel(path)
        except InputError:
            log.warning("cached kernel %s is unreadable; rebuilding", path)
        else:
            if ds.attrs.get("content_hash") == params["content_hash"]:
                log.info("reusing cached kernel %s", path)
                return ds
            log.warning("cached kernel %s has another content hash; rebuilding", path)
    ds = build_kernel(progress=progress, **kwargs)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_kernel(ds, path)
    log.info("kernel cached at %s", path)
    return ds


def kernel_build_stage(
    dst: str | os.PathLike[str], *, progress: bool = True, **kwargs: Any
) -> xr.Dataset:
    """Stage: build a kernel and write it to ``dst`` (NetCDF, atomic).

    Parameters
    ----------
    dst
        Output NetCDF path [-].
    progress
        Show a progress bar [-].
    **kwargs
        Parameters of :func:`build_kernel` [-].

    Returns
    -------
    xarray.Dataset
        The kernel written [-].
    """
    target = Path(dst)
    if not target.parent.is_dir():
        raise InputError(f"{target}: output folder {target.parent} does not exist")
    ds = build_kernel(progress=progress, **kwargs)
    write_kernel(ds, target)
    return ds
