"""What a skyglow kernel is: :class:`KernelSpec` and the axes it spans.

A kernel table holds, for each observer altitude h_o, source altitude h_c and distance bin r,
the panorama b(elevation, relative azimuth) [cd m-2 lm-1] of sky luminance per lumen emitted
upwards by a ground source in that bin (Dobashi et al. 2023, Sec. 3.4.1). Its specification
holds every parameter that changes the numbers: the axes, the atmosphere, the emission
components, the quadrature and the compression. The content hash of the specification keys the
kernel cache; :meth:`KernelSpec.to_attrs` and :meth:`KernelSpec.from_attrs` carry it through the
NetCDF attributes.

Each band of an emission raster carries its angular emission function
(:class:`~nightlights.emission_functions.EmissionFunction`, the band tag ``emission_function``,
both from the leaf :mod:`nightlights.emission_functions` and handed on here); it names the mix
of the kernel's tabulated shapes that band reads.

Defaults: the measured-best build (:data:`DEFAULT_NODES`, :data:`DEFAULT_ALTITUDE_STEP`,
:data:`DEFAULT_PCA_ERROR`, shared bases, float32 storage; each constant cites the benchmark that
set it; the whole is charted by ``benchmarks/bench_sky_kernel_defaults.py``). The reference
build, every altitude pair integrated at 12 nodes and compressed per observer altitude to an
explained energy in float64, is :meth:`KernelSpec.exact` (:data:`EXACT_SETTINGS`); its
content hash is the one earlier versions gave the same parameters.

Length: about 800 lines, because the specification and its axes are one description of what a
kernel holds, and the scene-sized specification is made from them.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from nightlights._resources import check_memory
from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    DEFAULT_EMISSION_FUNCTION,
    EMISSION_FUNCTION_TAG,
    EMISSION_MODELS,
    EmissionFunction,
    emission_shape,
)
from nightlights.errors import InputError
from nightlights.io.raster import LitCells, Raster
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.kernel import UPLIGHT_EXPONENT, parse_tabulated_emission

__all__ = [
    "DEFAULT_ALTITUDE_STEP",
    "DEFAULT_EMISSION_FUNCTION",
    "DEFAULT_NODES",
    "DEFAULT_PCA_ERROR",
    "EMISSION_FUNCTION_TAG",
    "EXACT_SETTINGS",
    "KERNEL_FORMAT_VERSION",
    "MAX_KERNEL_RANGE",
    "MAX_SOURCE_LEVELS",
    "SOURCE_LEVEL_SPACING",
    "EmissionFunction",
    "KernelSpec",
    "distance_grid",
    "panorama_elevations",
    "relative_azimuths",
    "scene_kernel_spec",
    "source_levels",
]

#: Bumped whenever the physics or the file layout changes, so that caches are rebuilt.
KERNEL_FORMAT_VERSION = 2

#: Gauss-Legendre nodes per line-of-sight panel of the default build [1]. From
#: ``benchmarks/bench_sky_kernel_nodes.py``: the bin images (what a kernel stores) against 32
#: nodes, mean relative error over the pixels above 1 % of their image's maximum, are 0.009 %
#: off at 6 nodes on Dobashi's configuration (0.003 % at 8; 99th percentile of the pixels
#: 0.04 %) and 0.022 % on a kernel reaching 300 km (0.009 % at 8; 99th percentile 0.26 %), at
#: 3/4 of the integration time of 8 nodes: 1/20 of the default build's 0.5 % budget, below the
#: PCA's share of it (0.3 %, whose pixel tails reach several per cent). Single rays converge
#: more slowly (``bench_sky_kernel_quadrature.py``: 99th percentile 2.2 % at 6 nodes, 0.32 % at
#: 8); the exact path keeps 12.
DEFAULT_NODES = 6

#: Spacing of the integrated altitude pairs along each line of equal h_c - h_o in the default
#: build [1]: ``benchmarks/bench_sky_kernel_altitudes.py`` (Dobashi's 16 x 16 levels, 62.5 m
#: apart) measured 0.07 % mean error (0.26 % for the worst pair) at 0.25 of the time with 15;
#: the interpolated span is capped at
#: :data:`~nightlights.sky.build.MAX_INTERPOLATED_SPAN` whatever the grid.
DEFAULT_ALTITUDE_STEP = 15

#: PCA error target of the default build (mean relative error over the pixels above 1 % of their
#: image's maximum) [1]. The default build is to stay within 0.5 % of the exact path; the
#: interpolated altitude pairs take 0.14 % of it (``bench_sky_kernel_fast_precompute.py``), so
#: the PCA gets 0.3 %: ``benchmarks/bench_sky_kernel_storage.py`` (Dobashi's configuration, one
#: float32 basis shared by the observer altitudes) measured 0.36 % at 96 bases and 0.14 % at 128
#: (11.8 MB at 76 bases for a 0.5 % target; the 1 % target leaves a 15 % 99th percentile of the
#: pixel errors). Checked end to end in ``bench_sky_kernel_defaults.py``.
DEFAULT_PCA_ERROR = 0.003

#: The reference build restored by :meth:`KernelSpec.exact`: every altitude pair integrated at
#: 12 nodes (the default of kernel format 2: maximum ray error 0.16 %, median 4e-7 in
#: ``bench_sky_kernel_quadrature.py``), one PCA per observer altitude chosen by explained
#: energy, float64 storage.
EXACT_SETTINGS: dict[str, Any] = {
    "nodes": 12,
    "pca_error": None,
    "shared_bases": False,
    "precision": "float64",
    "altitude_step": 1,
}


def _registered_shapes(names: Sequence[str]) -> tuple[str, ...]:
    """The registered shapes a kernel tabulates besides its built-in and tabulated ones."""
    shapes = (names,) if isinstance(names, str) else tuple(names)
    for name in shapes:
        row = emission_shape(name)  # refuses an unknown name
        if name in EMISSION_MODELS or row.table is None or row.table == "tabulated":
            raise InputError(
                f"emission_shapes {name[:40]!r}; expected a registered shape with its own "
                "kernel table (uplight, garstang_lobe and tabulated functions have their options)"
            )
    if len(set(shapes)) != len(shapes):
        raise InputError(f"emission_shapes {list(shapes)!r}; expected each shape once")
    return tuple(str(name) for name in shapes)


def panorama_elevations(n_elevation: int) -> FloatArray:
    """Elevation pixel centres of the panorama, zenith first: 90 - (i + 0.5) 90 / n [deg].

    Parameters
    ----------
    n_elevation
        Number of elevation rows [1].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_elevation,)`` [deg].

    Examples
    --------
    >>> panorama_elevations(3).tolist()
    [75.0, 45.0, 15.0]
    """
    return 90.0 - (np.arange(n_elevation) + 0.5) * 90.0 / n_elevation


def relative_azimuths(n_azimuth: int) -> FloatArray:
    """Kernel azimuths relative to the source direction, k 360 / n [deg].

    Parameters
    ----------
    n_azimuth
        Number of azimuth columns [1].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_azimuth,)`` [deg].
    """
    return np.arange(n_azimuth) * 360.0 / n_azimuth


#: Significant digits kept of the atmosphere's derived optical depths in the content hash: they
#: are integrals whose last bits change with the numerical libraries' versions, and a kernel
#: must keep its hash (and its cache) when only those change.
HASH_DIGITS = 10
#: Significant digits kept of the distance edges in the content hash: ``np.geomspace`` runs
#: through the CPU's vectorised log and exp, whose last bit differs between processors, and a
#: kernel must keep its hash on another machine.
EDGE_DIGITS = 12


def _derived_rounded(parameters: dict[str, Any]) -> dict[str, Any]:
    """The atmosphere's parameters with its derived optical depths (``*_used``) rounded to
    :data:`HASH_DIGITS` significant digits, for :meth:`KernelSpec.parameters`."""
    return {
        key: float(f"{value:.{HASH_DIGITS}g}") if key.endswith("_used") else value
        for key, value in parameters.items()
    }


#: Largest source distance any kernel covers [m], the outer edge of a scene-sized kernel and
#: the bound of ``r_max`` (spherical Earth; beyond it sources sit well below the observer's
#: horizon and contribute little, and the tables are not validated there).
MAX_KERNEL_RANGE = 300_000.0


def distance_grid(r_min: float, r_max: float, n_distance: int) -> FloatArray:
    """Log-spaced distance bin edges.

    Parameters
    ----------
    r_min
        Inner edge of the first bin, > 0 [m].
    r_max
        Outer edge of the last bin [m].
    n_distance
        Number of bins [1].

    Returns
    -------
    numpy.ndarray
        Shape ``(n_distance + 1,)`` [m].

    Examples
    --------
    >>> distance_grid(10.0, 1000.0, 2).tolist()
    [10.0, 100.0, 1000.0]
    """
    if not (0 < r_min < r_max < np.inf) or n_distance < 1:
        raise InputError(
            f"distance grid r_min={r_min!r} m, r_max={r_max!r} m, n_distance={n_distance!r}; "
            "expected 0 < r_min < r_max and n_distance >= 1"
        )
    return np.geomspace(r_min, r_max, n_distance + 1)


def _check_edges(edges: ArrayLike) -> FloatArray:
    e = np.asarray(edges, dtype=float).ravel()
    if e.size < 2 or e[0] <= 0 or np.any(np.diff(e) <= 0) or not np.all(np.isfinite(e)):
        shown = e.tolist() if e.size <= 8 else [*e[:3].tolist(), "...", *e[-3:].tolist()]
        raise InputError(
            f"distance_edges {shown!r} ({e.size} values); expected >= 2 increasing finite "
            "values > 0 m"
        )
    return e


def _levels(values: ArrayLike, name: str) -> tuple[float, ...]:
    levels = np.sort(np.asarray(values, dtype=float).ravel())
    if levels.size == 0:
        raise InputError(f"{name}: expected at least one altitude")
    if np.any(np.diff(levels) <= 0) or not np.all(np.isfinite(levels)):
        raise InputError(f"{name} {levels.tolist()!r} m; expected distinct finite altitudes")
    return tuple(float(x) for x in levels)


@dataclass(frozen=True)
class KernelSpec:
    """Every parameter of a skyglow kernel: axes, atmosphere, emission, quadrature, compression.

    Parameters
    ----------
    distance_edges
        Distance bin edges, increasing, > 0; default log-spaced from ``r_min`` to ``r_max`` in
        ``n_distance`` bins (then ``r_min``, ``r_max`` and ``n_distance`` are set from the
        edges) [m].
    r_min
        Inner edge of the default distance grid [m].
    r_max
        Outer edge of the default distance grid, at most :data:`MAX_KERNEL_RANGE` (so is the
        last of ``distance_edges``) [m].
    n_distance
        Number of distance bins of the default grid [1].
    source_altitudes
        Source altitudes h_c above sea level, sorted on creation [m].
    observer_altitudes
        Observer altitudes h_o above sea level, sorted on creation [m].
    n_elevation
        Panorama rows, elevation 0-90 deg [1].
    n_azimuth
        Panorama columns (even), azimuth 0-360 deg [1].
    atmosphere
        Atmosphere model; default :class:`~nightlights.sky.atmosphere.Atmosphere`.
    uplight
        Also tabulate ``kernel_uplight`` for the low-angle direct-uplight lobe.
    garstang_lobe
        Also tabulate ``kernel_garstang_lobe`` for the low-angle term of Garstang's (1986)
        emission function; with ``kernel`` it serves every Garstang mix
        (:func:`~nightlights.sky.kernel.garstang_weights`).
    tabulated_emission
        Also tabulate ``kernel_tabulated`` for this tabulated emission function
        (``tabulated:<json>``, stored in canonical form; one per kernel).
    uplight_exponent
        Exponent n of the uplight lobe sin^n [1].
    nodes
        Gauss-Legendre nodes on each side of the closest approach; default
        :data:`DEFAULT_NODES` (12 in :meth:`exact`) [1].
    leg_nodes
        None: closed-form leg optical depths; an integer: Gauss nodes per leg [1].
    core_radius
        Softening radius of the point source [m].
    sub_distances
        Gauss-Legendre distances in ln r averaged per bin (area weighted); 1 = the geometric
        bin centre (within 0.4 % of the converged bin mean at 64-128 bins, 2: 0.07 %); the
        pixels next to the source direction always average at least 4 [1].
    sub_pixels
        Directions per pixel side averaged (solid-angle weighted) [1].
    supersample
        Directions per pixel side averaged in the pixels next to the source direction, where
        rays graze the source (observer next to a lit cell, sources above the observer) [1].
    pca_energy
        Explained-energy target choosing the number of components [1].
    n_components
        Number of components (overrides ``pca_energy``) [1].
    store_tables
        Keep the raw images (``kernel``, ``kernel_uplight``) next to the PCA bases; they are
        needed only by ``exact`` mode and are most of the file (2.2 of 2.9 GB for Dobashi's
        configuration).
    pca_error
        Error target choosing the number of components (overrides ``pca_energy``; ignored
        when ``n_components`` is given): the smallest number whose reconstruction has at most
        this mean relative error over pixels brighter than 1 % of their image's maximum
        (:func:`~nightlights.sky.pca.bright_relative_error`); default
        :data:`DEFAULT_PCA_ERROR`; None chooses by ``pca_energy`` (:meth:`exact`) [1].
    shared_bases
        One PCA basis for every observer altitude instead of one per altitude (the
        coefficients stay per level; default; see :mod:`nightlights.sky.pca`); False in
        :meth:`exact`.
    precision
        Storage precision of the bases and coefficients, ``"float64"`` or ``"float32"``
        (rounded on building, so that a file written in float32 reads back unchanged);
        default ``"float32"`` (``bench_sky_kernel_storage.py``: the mean error of Dobashi's
        configuration moves from 4.2130e-5 to 4.2134e-5, the file halves); ``"float64"`` in
        :meth:`exact`.
    multiple_scattering
        ``"monte-carlo"``: every table is multiplied by the multiple-scattering factor
        f(elevation, azimuth, distance) of :mod:`nightlights.sky.multiple` (all scattering
        orders, measured by Monte Carlo; shipped for turbidity 2 and Garstang's K = 1 at 550
        nm, measured on the first build for other atmospheres); ``"single"``: single
        scattering only, the kernel of Dobashi et al. (2023) and of earlier versions.
    altitude_step
        Precompute every ``altitude_step``-th (observer, source) altitude pair along each line
        of equal height difference h_c - h_o (and both ends) and interpolate the others
        log-linearly in the observer altitude (:mod:`nightlights.sky.build`), never across
        more than :data:`~nightlights.sky.build.MAX_INTERPOLATED_SPAN` of observer altitude
        (more pairs are integrated where the levels are farther apart, so that a grid of a
        few levels is integrated in full); default :data:`DEFAULT_ALTITUDE_STEP`; 1 computes
        every pair (:meth:`exact`) [1].
    emission_shapes
        Also tabulate these registered shapes
        (:func:`~nightlights.emission_functions.register_emission_shape`), each in its own
        table ``kernel_<table>``; their definitions go into the content hash.

    Examples
    --------
    >>> spec = KernelSpec(r_min=10.0, r_max=1000.0, n_distance=2, n_elevation=8, n_azimuth=16)
    >>> spec.distance_edges
    (10.0, 100.0, 1000.0)
    >>> KernelSpec.from_attrs(spec.to_attrs()) == spec
    True
    >>> len(spec.content_hash)
    64
    >>> exact = KernelSpec.exact(n_elevation=8, n_azimuth=16)
    >>> (exact.nodes, exact.pca_error, exact.shared_bases, exact.precision, exact.altitude_step)
    (12, None, False, 'float64', 1)
    """

    distance_edges: Sequence[float] | None = None
    r_min: float = 10.0
    r_max: float = 100_000.0
    n_distance: int = 64
    source_altitudes: Sequence[float] = (0.0,)
    observer_altitudes: Sequence[float] = (0.0,)
    n_elevation: int = 64
    n_azimuth: int = 256
    atmosphere: Atmosphere = field(default_factory=Atmosphere)
    uplight: bool = False
    uplight_exponent: float = UPLIGHT_EXPONENT
    garstang_lobe: bool = False
    tabulated_emission: str | None = None
    nodes: int = DEFAULT_NODES
    leg_nodes: int | None = None
    core_radius: float = 1.0
    sub_distances: int = 1
    sub_pixels: int = 1
    supersample: int = 8
    pca_energy: float = 0.999999
    n_components: int | None = None
    store_tables: bool = True
    pca_error: float | None = DEFAULT_PCA_ERROR
    shared_bases: bool = True
    precision: str = "float32"
    altitude_step: int = DEFAULT_ALTITUDE_STEP
    multiple_scattering: str = "monte-carlo"
    emission_shapes: Sequence[str] = ()

    def __post_init__(self) -> None:
        self._check_size()
        edges = _check_edges(
            distance_grid(self.r_min, self.r_max, self.n_distance)
            if self.distance_edges is None
            else self.distance_edges
        )
        if edges[-1] > MAX_KERNEL_RANGE:
            given = (
                f"r_max={self.r_max!r} m"
                if self.distance_edges is None
                else f"distance_edges ending at {edges[-1]:g} m"
            )
            raise InputError(
                f"{given}; expected at most {MAX_KERNEL_RANGE:g} m (MAX_KERNEL_RANGE: the "
                "kernel's supported range; farther sources sit below the observer's horizon)"
            )
        setattr_ = object.__setattr__
        setattr_(self, "distance_edges", tuple(float(x) for x in edges))
        setattr_(self, "r_min", float(edges[0]))
        setattr_(self, "r_max", float(edges[-1]))
        setattr_(self, "n_distance", int(edges.size - 1))
        setattr_(self, "source_altitudes", _levels(self.source_altitudes, "source_altitudes"))
        setattr_(self, "observer_altitudes", _levels(self.observer_altitudes, "observer_altitudes"))
        if not isinstance(self.atmosphere, Atmosphere):
            raise InputError(
                f"atmosphere of type {type(self.atmosphere).__name__}; expected an Atmosphere"
            )
        if self.n_elevation < 1 or self.n_azimuth < 2 or self.n_azimuth % 2:
            raise InputError(
                f"n_elevation={self.n_elevation!r}, n_azimuth={self.n_azimuth!r}; expected "
                "n_elevation >= 1 and an even n_azimuth >= 2"
            )
        if self.sub_distances < 1 or self.sub_pixels < 1:
            raise InputError(
                f"sub_distances={self.sub_distances!r}, sub_pixels={self.sub_pixels!r}; "
                "expected >= 1"
            )
        if (
            self.nodes < 1
            or self.supersample < 1
            or (self.leg_nodes is not None and self.leg_nodes < 1)
        ):
            raise InputError(
                f"nodes={self.nodes!r}, supersample={self.supersample!r}, "
                f"leg_nodes={self.leg_nodes!r}; expected >= 1"
            )
        if not (np.isfinite(self.core_radius) and self.core_radius > 0):
            raise InputError(f"core_radius {self.core_radius!r} m; expected a positive length")
        if not (np.isfinite(self.uplight_exponent) and self.uplight_exponent >= 0):
            raise InputError(f"uplight_exponent {self.uplight_exponent!r}; expected >= 0")
        if self.tabulated_emission is not None:
            setattr_(
                self, "tabulated_emission", parse_tabulated_emission(self.tabulated_emission)[0]
            )
        setattr_(self, "emission_shapes", _registered_shapes(self.emission_shapes))
        if self.n_components is None and not 0 < self.pca_energy <= 1:
            raise InputError(f"pca_energy {self.pca_energy!r}; expected 0 < energy <= 1")
        if self.n_components is not None and self.n_components < 1:
            raise InputError(f"n_components {self.n_components!r}; expected >= 1")
        if self.pca_error is not None and not 0 < self.pca_error < 1:
            raise InputError(f"pca_error {self.pca_error!r}; expected 0 < error < 1")
        if self.multiple_scattering not in ("monte-carlo", "single"):
            raise InputError(
                f"multiple_scattering {self.multiple_scattering!r}; expected 'monte-carlo' or "
                "'single'"
            )
        if self.precision not in ("float64", "float32"):
            raise InputError(f"precision {self.precision!r}; expected 'float64' or 'float32'")
        if not (isinstance(self.altitude_step, (int, np.integer)) and self.altitude_step >= 1):
            raise InputError(f"altitude_step {self.altitude_step!r}; expected an integer >= 1")
        for name in ("n_elevation", "n_azimuth", "nodes", "sub_distances", "sub_pixels"):
            setattr_(self, name, int(getattr(self, name)))
        setattr_(self, "supersample", int(self.supersample))
        for name in ("uplight", "garstang_lobe", "store_tables", "shared_bases"):
            setattr_(self, name, bool(getattr(self, name)))
        setattr_(self, "altitude_step", int(self.altitude_step))
        if self.pca_error is not None:
            setattr_(self, "pca_error", float(self.pca_error))
        for name in ("uplight_exponent", "core_radius", "pca_energy"):
            setattr_(self, name, float(getattr(self, name)))
        for name in ("leg_nodes", "n_components"):
            value = getattr(self, name)
            setattr_(self, name, None if value is None else int(value))

    @classmethod
    def exact(cls, **fields: Any) -> KernelSpec:
        """The reference build: :data:`EXACT_SETTINGS` (every altitude pair integrated at 12
        nodes, per-level bases chosen by explained energy, float64), other fields as given.

        Parameters
        ----------
        **fields
            Further fields (one of :data:`EXACT_SETTINGS` given here overrides it).

        Returns
        -------
        KernelSpec
            The specification; its content hash is the one kernel format 2 gave these
            parameters before the faster defaults.
        """
        return cls(**(EXACT_SETTINGS | fields))

    @property
    def is_exact(self) -> bool:
        """Whether the build settings are those of :meth:`exact`."""
        return all(getattr(self, key) == value for key, value in EXACT_SETTINGS.items())

    def _check_size(self) -> None:
        """Refuse a grid whose tables alone exceed the memory limit, before its axes (and
        their hash) are made: the full estimate is :func:`~nightlights.sky.build.kernel_memory`.
        """
        n_r = len(self.distance_edges) - 1 if self.distance_edges is not None else self.n_distance
        sizes = (n_r, self.n_elevation, self.n_azimuth)
        if not all(isinstance(n, (int, np.integer)) and n > 0 for n in sizes):
            return  # the checks below name the bad value
        levels = len(np.ravel(self.source_altitudes)) * len(np.ravel(self.observer_altitudes))
        emissions = 1 + sum(
            bool(x) for x in (self.uplight, self.garstang_lobe, self.tabulated_emission)
        )
        shapes = self.emission_shapes
        emissions += 1 if isinstance(shapes, str) else len(tuple(shapes))
        check_memory(
            2 * 4.0 * emissions * levels * float(np.prod(sizes, dtype=float)),
            f"the kernel of {n_r} distances x {self.n_elevation} x {self.n_azimuth} pixels",
            option="lower n_distance=, n_elevation= or n_azimuth=",
        )

    # -- derived axes --------------------------------------------------------------------

    @property
    def edges(self) -> FloatArray:
        """Distance bin edges as an array, shape ``(n_distance + 1,)`` [m]."""
        return np.asarray(self.distance_edges, dtype=float)

    @property
    def distances(self) -> FloatArray:
        """Geometric bin centres, shape ``(n_distance,)`` [m]."""
        e = self.edges
        return np.sqrt(e[:-1] * e[1:])

    @property
    def elevations(self) -> FloatArray:
        """Elevation pixel centres, zenith first, shape ``(n_elevation,)`` [deg]."""
        return panorama_elevations(self.n_elevation)

    @property
    def azimuths(self) -> FloatArray:
        """Azimuths relative to the source, shape ``(n_azimuth,)`` [deg]."""
        return relative_azimuths(self.n_azimuth)

    @property
    def emissions(self) -> tuple[str, ...]:
        """The emission shapes tabulated, in table order: ``lambertian`` (then ``uplight``,
        ``garstang_lobe``, the tabulated function's text, the registered
        ``emission_shapes``)."""
        optional = (("uplight", self.uplight), ("garstang_lobe", self.garstang_lobe))
        tabulated = (self.tabulated_emission,) if self.tabulated_emission else ()
        return (
            "lambertian",
            *(name for name, wanted in optional if wanted),
            *tabulated,
            *self.emission_shapes,
        )

    # -- identity ------------------------------------------------------------------------

    def parameters(self) -> dict[str, Any]:
        """Normalised, JSON-serialisable description hashed into :attr:`content_hash`.

        Returns
        -------
        dict
            Every parameter and grid (the key names are those of kernel format 2, so that
            cached kernels keep their hash; the optional tables and the storage and precompute
            levers add a key only when not at their kernel-format-2 value, the one of
            :data:`EXACT_SETTINGS`: exact-path kernels keep their hash, default ones differ).
        """
        optional: dict[str, Any] = {"garstang_lobe": True} if self.garstang_lobe else {}
        if self.tabulated_emission:
            optional["tabulated_emission"] = self.tabulated_emission
        if self.pca_error is not None:
            optional["pca_error"] = self.pca_error
        if self.shared_bases:
            optional["shared_bases"] = True
        if self.precision != "float64":
            optional["precision"] = self.precision
        if self.altitude_step != 1:
            optional["altitude_step"] = self.altitude_step
        if self.emission_shapes:
            optional["emission_shapes"] = [
                {"name": name, **emission_shape(name).parameters()} for name in self.emission_shapes
            ]
        if self.multiple_scattering != "single":
            from nightlights.sky.multiple import tables_digest

            optional["multiple_scattering"] = self.multiple_scattering
            # the factor tables' content: a kernel cached with other tables is stale
            optional["multiple_scattering_tables"] = tables_digest(
                self.atmosphere, self.emissions, self.uplight_exponent
            )
        return optional | {
            "kernel_format_version": KERNEL_FORMAT_VERSION,
            "distance_edges": [float(f"{e:.{EDGE_DIGITS}g}") for e in self.distance_edges or ()],
            "source_altitudes": list(self.source_altitudes),
            "observer_altitudes": list(self.observer_altitudes),
            "n_el": self.n_elevation,
            "n_az": self.n_azimuth,
            "atmosphere": _derived_rounded(self.atmosphere.parameters()),
            "nodes": self.nodes,
            "leg_nodes": self.leg_nodes,
            "core_radius": self.core_radius,
            "sub_distances": self.sub_distances,
            "sub_pixels": self.sub_pixels,
            "supersample": self.supersample,
            "uplight": self.uplight,
            "uplight_exponent": self.uplight_exponent,
            "pca_energy": self.pca_energy,
            "n_components": self.n_components,
            "store_tables": self.store_tables,
        }

    @cached_property
    def content_hash(self) -> str:
        """sha256 (hex) of :meth:`parameters`: equal specifications, equal kernels."""
        text = json.dumps(self.parameters(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def to_attrs(self) -> dict[str, Any]:
        """NetCDF-safe attributes describing the kernel (None -> -1, bool -> int).

        Returns
        -------
        dict
            The atmosphere's parameters, the axes, the knobs and ``content_hash``.
        """
        attrs: dict[str, Any] = dict(self.atmosphere.parameters())
        attrs["distance_edges"] = np.asarray(self.distance_edges, dtype=float)
        attrs["source_altitudes"] = np.asarray(self.source_altitudes, dtype=float)
        attrs["observer_altitudes"] = np.asarray(self.observer_altitudes, dtype=float)
        attrs["n_elevation"] = self.n_elevation
        attrs["n_azimuth"] = self.n_azimuth
        attrs["leg_nodes"] = -1 if self.leg_nodes is None else self.leg_nodes
        for key in (
            "nodes",
            "core_radius",
            "sub_distances",
            "sub_pixels",
            "supersample",
            "uplight_exponent",
            "pca_energy",
        ):
            attrs[key] = getattr(self, key)
        attrs["kernel_format_version"] = KERNEL_FORMAT_VERSION
        attrs["content_hash"] = self.content_hash
        attrs["uplight"] = int(self.uplight)
        attrs["garstang_lobe"] = int(self.garstang_lobe)
        attrs["tabulated_emission"] = self.tabulated_emission or ""
        attrs["store_tables"] = int(self.store_tables)
        attrs["n_components_requested"] = -1 if self.n_components is None else self.n_components
        attrs["pca_error"] = -1.0 if self.pca_error is None else self.pca_error
        attrs["shared_bases"] = int(self.shared_bases)
        attrs["precision"] = self.precision
        attrs["altitude_step"] = self.altitude_step
        attrs["multiple_scattering"] = self.multiple_scattering
        if self.emission_shapes:
            attrs["emission_shapes"] = ",".join(self.emission_shapes)
        return attrs

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, Any]) -> KernelSpec:
        """The specification written by :meth:`to_attrs`.

        Parameters
        ----------
        attrs
            A kernel's attributes.

        Returns
        -------
        KernelSpec
            The specification.

        Raises
        ------
        InputError
            The attributes lack the axes (kernels written before they were recorded: use
            :meth:`from_kernel`) or another parameter.
        """
        missing = [
            key
            for key in ("distance_edges", "source_altitudes", "observer_altitudes", "n_elevation")
            if key not in attrs
        ]
        if missing:
            raise InputError(
                f"kernel attributes lack {missing}; read the axes from the dataset with "
                "KernelSpec.from_kernel"
            )

        def number(key: str) -> Any:
            if key not in attrs:
                raise InputError(f"kernel attributes lack {key!r}")
            value = attrs[key]
            return value.item() if isinstance(value, np.generic) else value

        def optional(key: str) -> int | None:
            value = int(number(key))
            return None if value < 0 else value

        error = float(attrs.get("pca_error", -1.0))

        return cls(
            distance_edges=np.atleast_1d(attrs["distance_edges"]).tolist(),
            source_altitudes=np.atleast_1d(attrs["source_altitudes"]).tolist(),
            observer_altitudes=np.atleast_1d(attrs["observer_altitudes"]).tolist(),
            n_elevation=int(number("n_elevation")),
            n_azimuth=int(number("n_azimuth")),
            atmosphere=Atmosphere.from_parameters(attrs),
            uplight=bool(number("uplight")),
            uplight_exponent=float(number("uplight_exponent")),
            garstang_lobe=bool(int(attrs.get("garstang_lobe", 0))),
            tabulated_emission=str(attrs.get("tabulated_emission", "")) or None,
            nodes=int(number("nodes")),
            leg_nodes=optional("leg_nodes"),
            core_radius=float(number("core_radius")),
            sub_distances=int(number("sub_distances")),
            sub_pixels=int(number("sub_pixels")),
            supersample=int(number("supersample")),
            pca_energy=float(number("pca_energy")),
            n_components=optional("n_components_requested"),
            store_tables=bool(number("store_tables")),
            pca_error=None if error < 0 else error,
            shared_bases=bool(int(attrs.get("shared_bases", 0))),
            multiple_scattering=str(attrs.get("multiple_scattering", "single")),
            precision=str(attrs.get("precision", "float64")),
            altitude_step=int(attrs.get("altitude_step", 1)),
            emission_shapes=tuple(filter(None, str(attrs.get("emission_shapes", "")).split(","))),
        )

    @classmethod
    def from_kernel(cls, kernel: xr.Dataset) -> KernelSpec:
        """The specification of a kernel dataset, its axes read from its coordinates.

        Parameters
        ----------
        kernel
            A kernel dataset (:func:`~nightlights.sky.build.compute_kernel`), also one written
            before the axes were recorded in the attributes.

        Returns
        -------
        KernelSpec
            The specification; its :attr:`content_hash` equals the kernel's when the kernel
            was built from it.
        """
        attrs = dict(kernel.attrs)
        attrs.setdefault("distance_edges", np.asarray(kernel["distance_edges"].values))
        attrs.setdefault("source_altitudes", np.asarray(kernel["source_altitude"].values))
        attrs.setdefault("observer_altitudes", np.asarray(kernel["observer_altitude"].values))
        attrs.setdefault("n_elevation", int(kernel.sizes["elevation"]))
        n_frequency = int(kernel.sizes["frequency"])
        attrs.setdefault("n_azimuth", int(kernel.sizes.get("azimuth", 2 * (n_frequency - 1))))
        return cls.from_attrs(attrs)


#: Largest spacing of the source-altitude levels of a scene kernel over terrain [m] (Dobashi
#: et al. 2023 use 62.5 m); at most :data:`MAX_SOURCE_LEVELS` levels span the lit cells.
SOURCE_LEVEL_SPACING = 50.0
MAX_SOURCE_LEVELS = 16


def source_levels(
    heights: ArrayLike,
    *,
    spacing: float = SOURCE_LEVEL_SPACING,
    max_levels: int = MAX_SOURCE_LEVELS,
) -> FloatArray:
    """Source-altitude levels of a scene kernel spanning the altitudes of the lit cells.

    Parameters
    ----------
    heights
        Altitudes of the lit cells (NaN ignored) [m].
    spacing
        Largest spacing between levels [m].
    max_levels
        Most levels (the spacing grows beyond it) [1].

    Returns
    -------
    numpy.ndarray
        Increasing levels from the lowest to the highest lit cell; one level when they all
        stand within 1 m [m].

    Examples
    --------
    >>> source_levels([20.0, 120.0]).tolist()
    [20.0, 70.0, 120.0]
    """
    h = np.asarray(heights, dtype=float)
    h = h[np.isfinite(h)]
    if h.size == 0:
        return np.zeros(1)
    low, high = float(h.min()), float(h.max())
    if high - low < 1.0:
        return np.array([0.5 * (low + high)])
    count = int(np.clip(np.ceil((high - low) / spacing) + 1, 2, max_levels))
    return np.linspace(low, high, count)


def scene_kernel_spec(
    raster: Raster | LitCells,
    observer: tuple[float, float],
    *,
    observer_altitude: float,
    turbidity: float,
    n_elevation: int,
    n_azimuth: int,
    n_distance: int,
    uplight: bool,
    source_altitudes: ArrayLike = (0.0,),
    garstang_lobe: bool = False,
    tabulated_emission: str | None = None,
    emission_shapes: Sequence[str] = (),
) -> KernelSpec:
    """Kernel sized to the scene: distances from 10 m to the farthest corner of the emission
    (at most :data:`MAX_KERNEL_RANGE`), the observer's altitude and the source-altitude levels.

    Parameters
    ----------
    raster
        Emission raster (its grid sets the range), or its lit cells (their extent sets it).
    observer
        Observer (x, y) in the raster's CRS [m].
    observer_altitude
        Observer altitude above sea level [m].
    turbidity
        Atmospheric turbidity [1].
    n_elevation, n_azimuth, n_distance
        Panorama rows and columns and distance bins [1].
    uplight
        Tabulate the uplight lobe too.
    source_altitudes
        Source-altitude levels [m].
    garstang_lobe
        Tabulate Garstang's low-angle lobe too.
    tabulated_emission
        A tabulated emission function to tabulate too (``tabulated:<json>``).
    emission_shapes
        Registered shapes to tabulate too (:attr:`KernelSpec.emission_shapes`).

    Returns
    -------
    KernelSpec
        The specification.
    """
    bounds = raster.lit_bounds() if isinstance(raster, LitCells) else None
    left, bottom, right, top = bounds if bounds is not None else raster.bounds
    far = max(
        np.hypot(x - observer[0], y - observer[1]) for x in (left, right) for y in (bottom, top)
    )
    r_max = float(min(MAX_KERNEL_RANGE, max(far * 1.01, 100.0)))
    return KernelSpec(
        r_min=10.0,
        r_max=r_max,
        n_distance=n_distance,
        n_elevation=n_elevation,
        n_azimuth=n_azimuth,
        observer_altitudes=(float(observer_altitude),),
        source_altitudes=tuple(float(h) for h in np.ravel(source_altitudes)),
        atmosphere=Atmosphere(turbidity=turbidity),
        uplight=uplight,
        garstang_lobe=garstang_lobe,
        tabulated_emission=tabulated_emission,
        emission_shapes=emission_shapes,
    )
