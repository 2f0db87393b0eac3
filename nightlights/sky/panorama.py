"""Panoramas of skyglow from a polar map and a precomputed kernel (Dobashi et al. 2023, Sec. 3.3).

Skyglow is linear in the emission and, for sources on a common altitude, the kernel only
depends on the azimuth relative to the source. The panorama is therefore a circular
convolution in azimuth of the polar flux map with the kernel images, done with FFTs:

- ``exact``: ``L = irfft( sum_d rfft(F_d) rfft(b_d) )`` over distance bins d;
- ``pca``: with ``b_d ~ sum_k c_dk B_k`` (Dobashi Eq. 4), ``H_k = sum_d F_d c_dk`` (Eq. 7),
  ``L = irfft( sum_k rfft(H_k) rfft(B_k) )`` (Eqs. 8-9): one inverse FFT per elevation row;
- ``naive``: the reference, direct integration of the kernel for every lit cell at its own
  position (Dobashi's baseline), with no binning and no PCA.

A kernel slice's rows are the emission shapes the kernel tabulates (``lambertian``, then
``uplight``, ``garstang_lobe`` when present); :func:`band_slice` turns them into one row per
emission band, each the mix of shapes of the band's
:class:`~nightlights.emission_functions.EmissionFunction`. Without it, band 0 reads the
Lambertian row and band 1 the uplight row.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import xarray as xr
from affine import Affine
from numpy.typing import NDArray

from nightlights._typing import FloatArray
from nightlights.emission_functions import EmissionFunction, kernel_table_names
from nightlights.errors import DataQualityWarning, InputError
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.kernel import UPLIGHT_EXPONENT
from nightlights.sky.polar import PolarMap

MODES = ("pca", "exact", "naive")


@dataclass(frozen=True)
class KernelSlice:
    """The kernel tables for one observer and source altitude.

    Attributes
    ----------
    kernel
        ``(rows, n_r, n_el, n_az)`` images [cd m-2 lm-1], one row per entry of ``emissions``.
    coefficient
        ``(rows, n_r, n_components)`` PCA coefficients [cd m-2 lm-1].
    basis_fft
        ``(n_components, n_el, n_freq)`` complex rfft of the bases over azimuth [1].
    distance_edges
        ``(n_r + 1,)`` [m].
    elevation
        ``(n_el,)`` pixel centres [deg].
    observer_altitude
        The observer altitude the slice is for [m].
    observer_weights
        Weights of the observer levels whose components are interleaved (one level: ``(1,)``;
        between two: ``(1 - w, w)``) [1].
    emissions
        What each row is: the kernel's shapes (``lambertian``, ``uplight``, ...), or, after
        :func:`band_slice`, the emission bands' function tags.
    per_band
        Whether the rows are emission bands (:func:`band_slice`) rather than kernel shapes.
    """

    kernel: FloatArray
    coefficient: FloatArray
    basis_fft: NDArray[np.complex128]
    distance_edges: FloatArray
    elevation: FloatArray
    observer_altitude: float = float("nan")
    observer_weights: tuple[float, ...] = (1.0,)
    emissions: tuple[str, ...] = ("lambertian", "uplight")
    per_band: bool = False

    @cached_property
    def basis_fft_by_frequency(self) -> NDArray[np.complex128]:
        """``basis_fft`` as ``(n_freq, n_el, n_components)``, contiguous: the layout in which
        Eq. 9's sum over components is one batched matrix product (6x faster than einsum)."""
        return np.ascontiguousarray(np.moveaxis(self.basis_fft, 0, -1).transpose(1, 0, 2))

    @property
    def n_az(self) -> int:
        """Azimuth columns (even), from the stored rfft of the bases."""
        return 2 * (int(self.basis_fft.shape[-1]) - 1)

    @property
    def has_tables(self) -> bool:
        """Whether the raw kernel images are there (``exact`` mode needs them)."""
        return int(self.kernel.shape[-1]) > 0


def _clamp_level(levels: FloatArray, value: float, name: str) -> float:
    """``value`` or, outside the levels' range, the nearest level (with a warning if far)."""
    if value < levels.min() - 1e-6 or value > levels.max() + 1e-6:
        nearest = float(levels[np.argmin(np.abs(levels - value))])
        if abs(nearest - value) > 5.0:
            warnings.warn(
                f"{name} {value:g} m is outside the kernel's levels "
                f"{levels.min():g}-{levels.max():g} m; using {nearest:g} m",
                DataQualityWarning,
                stacklevel=3,
            )
        return nearest
    return value


def kernel_slice(
    kernel: xr.Dataset, *, observer_altitude: float, source_altitude: float = 0.0
) -> KernelSlice:
    """Interpolate a kernel dataset linearly to one observer and one source altitude.

    In the source altitude only the kernel tables and the PCA coefficients are interpolated
    (the bases are shared by all source altitudes of an observer level). Bases of two
    observer levels come from separate SVDs and cannot be averaged (their signs and
    rotations within the PCA subspace are arbitrary), so an observer altitude between two
    levels h_0 < h < h_1 with weight w = (h - h_0) / (h_1 - h_0) keeps BOTH levels' bases,
    interleaved (level 0 component 0, level 1 component 0, level 0 component 1, ...), with
    coefficients scaled by 1 - w and w: sum_k c_k B_k is then exactly the linearly
    interpolated kernel. Such a slice has twice the stored components (and costs twice as
    much in :func:`panorama_pca`).

    Parameters
    ----------
    kernel
        Dataset in the format of :func:`nightlights.sky.precompute.build_kernel`.
    observer_altitude
        Observer altitude [m]; outside the kernel's range the nearest level is used with a
        warning.
    source_altitude
        Altitude of the light sources [m]; same rule.
    """
    h_o = np.asarray(kernel["observer_altitude"].values, dtype=float)
    h_o_value = _clamp_level(h_o, float(observer_altitude), "observer_altitude")
    h_c = np.asarray(kernel["source_altitude"].values, dtype=float)
    h_c_value = _clamp_level(h_c, float(source_altitude), "source_altitude")
    pieces = [
        (weight, _level_arrays(kernel, index, h_c_value, tables=True))
        for index, weight in _observer_pieces(h_o, h_o_value)
    ]
    return _compose(kernel, pieces, h_o_value)


def _observer_pieces(h_o: FloatArray, value: float) -> list[tuple[int, float]]:
    """The (level index, weight) of the one or two observer levels around ``value``."""
    order = np.argsort(h_o)
    exact = np.nonzero(np.abs(h_o - value) <= 1e-6)[0]
    if exact.size:
        return [(int(exact[0]), 1.0)]
    upper = int(np.searchsorted(h_o[order], value))
    lo, hi = int(order[upper - 1]), int(order[upper])
    w = (value - h_o[lo]) / (h_o[hi] - h_o[lo])
    return [(lo, 1.0 - w), (hi, w)]


@dataclass(frozen=True)
class _LevelArrays:
    """One observer level's tables at one source altitude, as numpy arrays."""

    kernel: FloatArray  # (rows, n_r, n_el, n_az), or n_az = 0 without raw images
    coefficient: FloatArray  # (rows, n_r, n_components)
    spectrum: NDArray[np.complex128]  # (n_components, n_el, n_freq)
    emissions: tuple[str, ...]  # the shape of each row


def _level_arrays(
    kernel: xr.Dataset, index: int, source_altitude: float, *, tables: bool
) -> _LevelArrays:
    level = kernel.isel(observer_altitude=index)
    if kernel.sizes["source_altitude"] == 1:
        level = level.isel(source_altitude=0)
    else:
        level = level.interp(source_altitude=source_altitude)
    variables = kernel_table_names()
    present = [e for e, (_, coef) in variables.items() if coef in level]
    names = [variables[e][0] for e in present]
    coefficient_names = [variables[e][1] for e in present]
    # a tabulated function's row is named by its text, which the bands' tags match
    tabulated = str(kernel.attrs.get("tabulated_emission", ""))
    emissions = tuple(tabulated if e == "tabulated" else e for e in present)
    if "kernel" in level and tables:
        images = np.stack([level[n].values.astype(float) for n in names])
    else:  # a PCA-only kernel (built with store_tables=False), or the images not wanted
        n_r, n_el = level.sizes["distance"], level.sizes["elevation"]
        images = np.zeros((len(coefficient_names), n_r, n_el, 0))
    return _LevelArrays(
        kernel=images,
        coefficient=np.stack([level[n].values.astype(float) for n in coefficient_names]),
        spectrum=level["basis_fft_real"].values + 1j * level["basis_fft_imag"].values,
        emissions=emissions,
    )


def _compose(
    kernel: xr.Dataset, pieces: list[tuple[float, _LevelArrays]], observer_altitude: float
) -> KernelSlice:
    """The slice of one or two weighted observer levels, their components interleaved."""
    if len(pieces) == 1 and pieces[0][0] == 1.0:
        images, coefficient = pieces[0][1].kernel, pieces[0][1].coefficient[..., None]
    else:
        images = np.sum([weight * p.kernel for weight, p in pieces], axis=0)
        coefficient = np.stack([weight * p.coefficient for weight, p in pieces], axis=-1)
    # Interleave the components of the (one or two) observer levels.
    coefficient = coefficient.reshape(*coefficient.shape[:-2], -1)
    basis_fft = np.stack([p.spectrum for _, p in pieces], axis=1)
    basis_fft = basis_fft.reshape(-1, *basis_fft.shape[2:])
    return KernelSlice(
        kernel=images,
        coefficient=coefficient,
        basis_fft=basis_fft,
        distance_edges=np.asarray(kernel["distance_edges"].values, dtype=float),
        elevation=np.asarray(kernel["elevation"].values, dtype=float),
        observer_altitude=observer_altitude,
        observer_weights=tuple(float(weight) for weight, _ in pieces),
        emissions=pieces[0][1].emissions,
    )


def band_slice(tables: KernelSlice, functions: Sequence[EmissionFunction]) -> KernelSlice:
    """The slice with one row per emission band: each band's mix of the kernel's shapes.

    Skyglow is linear in the emission function, so a band whose function is
    sum_e w_e (shape e) reads sum_e w_e (coefficients of shape e), and the same mix of the
    raw images.

    Parameters
    ----------
    tables
        A slice whose rows are the kernel's shapes (:func:`kernel_slice`,
        :class:`KernelLevels`).
    functions
        One emission function per band.

    Returns
    -------
    KernelSlice
        Rows = bands; ``emissions`` holds the bands' function tags.

    Raises
    ------
    InputError
        A band reads a shape the kernel did not tabulate.
    """
    if tables.per_band:
        raise InputError("the kernel slice already has one row per emission band")
    rows = {name: index for index, name in enumerate(tables.emissions)}
    mix = np.zeros((len(functions), len(tables.emissions)))
    for band, function in enumerate(functions):
        for shape in function.shapes:
            if shape not in rows:
                raise InputError(
                    f"emission band {band + 1} ({function.tag}) reads the {shape} shape but the "
                    f"kernel has no {shape} table (only {', '.join(tables.emissions)}); build it "
                    f"with {shape}"
                )
        for shape, weight in function.weights:
            if weight > 0:
                mix[band, rows[shape]] = weight
    images = tables.kernel
    if tables.has_tables:
        images = np.einsum("be,e...->b...", mix, images)
    else:
        images = np.zeros((len(functions), *images.shape[1:]))
    return dataclasses.replace(
        tables,
        kernel=images,
        coefficient=np.einsum("be,e...->b...", mix, tables.coefficient),
        emissions=tuple(function.tag for function in functions),
        per_band=True,
    )


def kernel_levels(kernel: xr.Dataset, *, observer_altitude: float) -> list[KernelSlice]:
    """One kernel slice per stored source-altitude level, for :func:`polar_map_levels` maps.

    Parameters
    ----------
    kernel
        Kernel dataset.
    observer_altitude
        Observer altitude [m] (interpolated between observer levels as in
        :func:`kernel_slice`).

    Returns
    -------
    list of KernelSlice
        In increasing source altitude; all share the same bases.
    """
    return KernelLevels(kernel).at(observer_altitude)


class KernelLevels:
    """A kernel's source-level slices at any observer altitude, its tables read once.

    :func:`kernel_levels` for a moving observer: the per-level arrays are taken out of the
    dataset on first use and kept, so a new observer altitude costs only the weighting of
    one or two observer levels (what :func:`kernel_slice` does each time from the dataset).

    Parameters
    ----------
    kernel
        Kernel dataset.
    tables
        Keep the raw kernel images (``exact`` mode needs them; ``pca`` does not).

    Examples
    --------
    >>> from nightlights.sky import KernelSpec, build_kernel
    >>> table = build_kernel(
    ...     KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
    ... ).kernel
    >>> [s.observer_altitude for s in KernelLevels(table).at(0.0)]
    [0.0]
    """

    def __init__(self, kernel: xr.Dataset, *, tables: bool = True) -> None:
        self._kernel = kernel
        self._tables = tables
        self._h_o = np.asarray(kernel["observer_altitude"].values, dtype=float)
        self.levels = np.sort(np.asarray(kernel["source_altitude"].values, dtype=float))
        self._arrays: dict[tuple[int, float], _LevelArrays] = {}

    def at(self, observer_altitude: float) -> list[KernelSlice]:
        """One slice per source level, in increasing source altitude.

        Parameters
        ----------
        observer_altitude
            Observer altitude [m] (clamped to the kernel's levels with a warning when far
            outside).

        Returns
        -------
        list of KernelSlice
            As :func:`kernel_levels`.
        """
        value = _clamp_level(self._h_o, float(observer_altitude), "observer_altitude")
        pieces = _observer_pieces(self._h_o, value)
        return [
            _compose(self._kernel, [(w, self._level(i, float(h))) for i, w in pieces], value)
            for h in self.levels
        ]

    def _level(self, index: int, source_altitude: float) -> _LevelArrays:
        key = (index, source_altitude)
        if key not in self._arrays:
            self._arrays[key] = _level_arrays(
                self._kernel, index, source_altitude, tables=self._tables
            )
        return self._arrays[key]


def _pairs(
    polar: PolarMap | Sequence[PolarMap], tables: KernelSlice | Sequence[KernelSlice]
) -> tuple[list[PolarMap], list[KernelSlice]]:
    """Polar maps and kernel slices level by level (one of each for a single altitude)."""
    polars = [polar] if isinstance(polar, PolarMap) else list(polar)
    slices = [tables] if isinstance(tables, KernelSlice) else list(tables)
    if len(polars) != len(slices) or not polars:
        raise InputError(
            f"{len(polars)} polar maps for {len(slices)} kernel source levels; expected one "
            "polar map per level"
        )
    shape = slices[0].basis_fft.shape
    altitudes = np.array([t.observer_altitude for t in slices])
    if any(t.basis_fft.shape != shape for t in slices) or np.ptp(altitudes) > 0:
        raise InputError(
            "kernel slices of different observer altitudes cannot be combined (their bases differ)"
        )
    for p, t in zip(polars, slices, strict=True):
        _check_bands(p, t)
    return polars, slices


def _check_bands(polar: PolarMap, tables: KernelSlice) -> None:
    bands = polar.flux.shape[0]
    if tables.per_band and bands != len(tables.emissions):
        raise InputError(
            f"the emission has {bands} bands but the kernel slice was made for "
            f"{len(tables.emissions)} ({', '.join(tables.emissions)})"
        )
    if not tables.per_band and tables.emissions[:bands] != ("lambertian", "uplight")[:bands]:
        raise InputError(
            f"the emission has {bands} bands (Lambertian + uplight) but the kernel has no "
            "uplight table; build it with uplight"
        )
    if polar.n_az != tables.n_az or polar.flux.shape[1] != tables.coefficient.shape[1]:
        raise InputError(
            f"polar map {polar.flux.shape[1:]} (distance x azimuth) does not match the kernel "
            f"{tables.coefficient.shape[1]} x {tables.n_az}"
        )


def panorama_pca(
    polar: PolarMap | Sequence[PolarMap],
    tables: KernelSlice | Sequence[KernelSlice],
    *,
    components: int | None = None,
) -> FloatArray:
    """Panorama by PCA and FFT (Dobashi 2023, Eqs. 7-9).

    Parameters
    ----------
    polar
        Polar flux map [lm], bins matching the kernel; or one map per source-altitude level
        (:func:`nightlights.sky.polar.polar_map_levels`), whose H_k add up before the FFT
        (each cell read with c_k at its own altitude, Dobashi 2023 Sec. 3.4.2).
    tables
        Kernel slice, or one per level (:func:`kernel_levels`).
    components
        Use only the first ``components`` bases (default: all stored) [1].

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` luminance [cd m-2].
    """
    polars, slices = _pairs(polar, tables)
    stored = slices[0].coefficient.shape[-1]
    k = stored if components is None else int(components)
    if not 1 <= k <= stored:
        raise InputError(f"components={components}; the kernel stores 1-{stored}")
    # Eq. 7: H_k(azimuth) = sum over distance of flux x c_k, summed over emission bands (and
    # source-altitude levels).
    h = sum(
        np.einsum("bda,bdk->ka", p.flux, t.coefficient[: p.flux.shape[0], :, :k])
        for p, t in zip(polars, slices, strict=True)
    )
    # Eq. 9: sum_k F[H_k] F[B_k], one (n_el x k) @ (k) product per frequency
    h_fft = np.fft.rfft(h, axis=-1)  # (k, n_freq)
    basis = slices[0].basis_fft_by_frequency[:, :, :k]  # (n_freq, n_el, k)
    spectrum = np.matmul(basis, h_fft.T[:, :, None])[..., 0].T  # (n_el, n_freq)
    return np.fft.irfft(spectrum, n=polars[0].n_az, axis=-1)


def panorama_exact(
    polar: PolarMap | Sequence[PolarMap], tables: KernelSlice | Sequence[KernelSlice]
) -> FloatArray:
    """Panorama without PCA: per distance bin, FFT convolution of flux and kernel images.

    Parameters
    ----------
    polar, tables
        As :func:`panorama_pca` (one of each, or one per source-altitude level).

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` luminance [cd m-2].
    """
    polars, slices = _pairs(polar, tables)
    if not slices[0].has_tables:
        raise InputError(
            "the kernel stores no raw images (built with store_tables=False); use mode='pca'"
        )
    spectrum = 0.0
    for p, t in zip(polars, slices, strict=True):
        bands = p.flux.shape[0]
        flux_fft = np.fft.rfft(p.flux, axis=-1)  # (bands, n_r, n_freq)
        kernel_fft = np.fft.rfft(t.kernel[:bands], axis=-1)  # (bands, n_r, n_el, n_freq)
        spectrum = spectrum + np.einsum("bdf,bdef->ef", flux_fft, kernel_fft)
    return np.fft.irfft(spectrum, n=polars[0].n_az, axis=-1)


def panorama_naive(
    emission: FloatArray,
    transform: Affine,
    observer: tuple[float, float],
    *,
    elevation: FloatArray,
    n_az: int,
    observer_altitude: float,
    source_altitude: float | FloatArray = 0.0,
    atmosphere: Atmosphere | None = None,
    nodes: int = 24,
    uplight_exponent: float = UPLIGHT_EXPONENT,
    functions: Sequence[EmissionFunction] | None = None,
    multiple_scattering: str = "single",
) -> FloatArray:
    """Reference panorama: the kernel integrated directly for each lit cell at its centre.

    Parameters
    ----------
    emission
        ``(bands, rows, cols)`` upward flux density [lm m-2] (band 0 Lambertian, 1 uplight).
    transform
        Raster transform [m].
    observer
        Observer (x, y) [m].
    elevation
        Panorama elevation pixel centres [deg].
    n_az
        Azimuth columns [1].
    observer_altitude
        [m].
    source_altitude
        One altitude for all sources, or one per cell, shape ``(rows, cols)`` [m].
    atmosphere
        :class:`nightlights.sky.atmosphere.Atmosphere` (default: its defaults).
    nodes
        Gauss-Legendre nodes per ray half [1].
    uplight_exponent
        Exponent n of the uplight lobe sin^n [1].
    functions
        Emission function of each band; default band 0 Lambertian, band 1 uplight.
    multiple_scattering
        ``single``, or ``monte-carlo``: each cell's single scattering times the Monte Carlo
        factor at its own distance and direction (:mod:`nightlights.sky.multiple`), the model
        of a default kernel.

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` luminance [cd m-2].
    """
    from nightlights.sky.kernel import sky_luminance
    from nightlights.sky.multiple import shape_table

    atmosphere = atmosphere if atmosphere is not None else Atmosphere()
    data = np.nan_to_num(np.asarray(emission, dtype=float), nan=0.0)
    if data.ndim == 2:
        data = data[None]
    cell = abs(transform.a)
    heights = np.broadcast_to(np.asarray(source_altitude, dtype=float), data.shape[1:])
    azimuth = (np.arange(n_az) + 0.5) * 360.0 / n_az
    result = np.zeros((elevation.size, n_az))
    if functions is None:
        functions = [EmissionFunction.parse(kind) for kind in ("lambertian", "uplight")]
    if len(functions) < data.shape[0]:
        raise InputError(f"{data.shape[0]} emission bands but {len(functions)} functions")
    for band, function in zip(range(data.shape[0]), functions, strict=False):
        rows, cols = np.nonzero(data[band])
        cx = transform.c + transform.a * (cols + 0.5) + transform.b * (rows + 0.5)
        cy = transform.f + transform.d * (cols + 0.5) + transform.e * (rows + 0.5)
        dx, dy = cx - observer[0], cy - observer[1]
        r = np.hypot(dx, dy)
        source_azimuth = np.degrees(np.arctan2(dx, dy)) % 360.0
        flux = data[band, rows, cols] * cell * cell
        for i in range(r.size):
            relative = (azimuth[None, :] - source_azimuth[i]) % 360.0
            for shape, weight in function.weights:
                if weight <= 0:
                    continue
                factor: FloatArray | float = 1.0
                if multiple_scattering != "single" and atmosphere.extinction:
                    factor = shape_table(atmosphere, shape, uplight_exponent)(
                        elevation[:, None], relative, r[i]
                    )
                result += (
                    (weight * flux[i])
                    * factor
                    * sky_luminance(
                        elevation[:, None],
                        relative,
                        r[i],
                        source_altitude=heights[rows[i], cols[i]],
                        observer_altitude=observer_altitude,
                        atmosphere=atmosphere,
                        emission=shape,
                        nodes=nodes,
                        uplight_exponent=uplight_exponent,
                    )
                )
    return result
