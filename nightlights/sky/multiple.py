"""Multiple scattering in the kernel: a factor f(elevation, azimuth, distance) from Monte Carlo.

The kernel integrates light scattered once (:mod:`nightlights.sky.kernel`). Light scattered
two or more times multiplies it by 1.2 (1 km) to 2-3 (50 km) and more far away
(:mod:`nightlights.sky.montecarlo`, docs/physics/multiple_scattering.md). Because skyglow is
linear in the source, the correction is a factor per kernel image:

.. math:: b(\\varepsilon, \\alpha, r) = f(\\varepsilon, \\alpha, r)\\,
   b_1(\\varepsilon, \\alpha, r), \\quad f = \\frac{\\sum_{k \\ge 1} b_k}{b_1}

with b_1 the single-scattering luminance and b_k the luminance of light scattered exactly k
times, for one emission shape and one atmosphere. The kernel build multiplies each table by f
before its PCA compression, so the run time of a panorama does not change.

Modelling choices:

- f is measured by the Monte Carlo of :func:`~nightlights.sky.montecarlo.monte_carlo_luminance`
  (all orders, next-event estimation) on a coarse grid: 4 elevations (90, 45, 20, 8 deg) x 3
  relative azimuths (0 = towards the source, 90, 180) x 12 distances (100 m to 300 km, even in
  ln r), one photon run serving every ray. ln f is interpolated linearly in elevation and
  azimuth and by a monotone cubic Hermite (Fritsch-Carlson) through the nodes in ln r, and
  held constant outside the grid (below 8 deg elevation, nearer than 100 m, farther than
  300 km). The grid is coarse because f is smooth: the benchmark's directions differ by
  20-60 % at 10-300 km, not by orders of magnitude. In ln r, f of a Lambertian source bends
  upwards beyond 50 km (a factor 2 in f from 70 to 145 km): linear interpolation overshot an
  independent Monte Carlo at the midpoints 49 and 101 km by up to 4 and 10 %, the cubic by up
  to 2 and 5 %.
- f is computed for a source and an observer at sea level and applied at every source and
  observer altitude of the kernel (the altitudes of a city, up to a few hundred metres, are
  small against the scale heights that set f).
- Noise: the Monte Carlo's standard error of each grid value is kept
  (:attr:`MultipleScatteringTable.standard_error`); the values are used as measured. Smoothing
  in distance (weighted three-point averages, local linear fits, cubic and quartic fits in
  ln r, a monotone fit) was tried against the independent 300,000-photon reference of
  ``bench_sky_multiple_scattering.py`` and none beat the raw values at every distance, so
  none is applied: the error left is the tables' own noise, which falls as 1 / sqrt(photons).
- The tables for the default atmospheres (turbidity 2 and Garstang's K = 1 at 550 nm, ground
  levels, each emission shape) are shipped, measured by
  ``benchmarks/bench_sky_multiple_scattering_tables.py`` (seeds from :data:`SEED`; each
  table's runs, photons and estimator are recorded in the file): at turbidity 2, 120,000
  photons for the Lambertian and uplight shapes and 60,000 with azimuthal splitting for
  Garstang's psi^4 lobe; at K = 1, 40,000 per shape. Any other atmosphere is measured when its
  first kernel is built (:data:`BUILD_PHOTONS` photons with azimuthal splitting, cached for
  the process).
- Azimuthal splitting (:func:`~nightlights.sky.montecarlo.monte_carlo_luminance`,
  ``split_window`` = :data:`SPLIT_WINDOW`): an event whose circle about the source's vertical
  passes near a view ray is replaced by an importance-sampled average over the arc near the
  ray (unbiased, same histories). It removes most of the heavy tail that the few events
  passing near a distant observer's rays give the plain estimator.
- A tabulated (user) emission function cannot be sampled by the Monte Carlo; its table gets the
  factor of the kernel shape nearest to it in the share of flux below 30 deg elevation
  (:func:`nearest_shape`), and the kernel's attributes say so.

References
----------
.. [1] Garstang, R. H. 1986, PASP 98, 364 (double scattering raises the glow by a factor of
   about 1.6-2.5 at 10-150 km for K = 1).
.. [2] Marchuk, G. I. et al. 1980, The Monte Carlo Methods in Atmospheric Optics (Springer).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    UPLIGHT_EXPONENT,
    emission_shape,
    sampled_shape,
)
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere, garstang_atmosphere

__all__ = [
    "BUILD_PHOTONS",
    "FACTOR_AZIMUTHS",
    "FACTOR_DISTANCES",
    "FACTOR_ELEVATIONS",
    "MULTIPLE_SCATTERING_MODELS",
    "MultipleScatteringTable",
    "multiple_scattering_factor",
    "multiple_scattering_table",
    "nearest_shape",
]

#: Choices of :attr:`nightlights.sky.spec.KernelSpec.multiple_scattering`: ``monte-carlo``
#: (single scattering times the Monte Carlo factor of this module) or ``single``.
MULTIPLE_SCATTERING_MODELS = ("monte-carlo", "single")
#: Elevations of the factor grid [deg].
FACTOR_ELEVATIONS = (8.0, 20.0, 45.0, 90.0)
#: Relative azimuths of the factor grid (0 = towards the source) [deg].
FACTOR_AZIMUTHS = (0.0, 90.0, 180.0)
#: Distances of the factor grid, 100 m to 300 km even in ln r [m].
FACTOR_DISTANCES = tuple(float(r) for r in np.geomspace(100.0, 300e3, 12))
#: Photons of the shipped tables [1].
SHIPPED_PHOTONS = 40_000
#: Photons of a table measured at kernel build time [1].
BUILD_PHOTONS = 5_000
#: Scattering orders followed (the benchmark finds no flux left in flight at 50) [1].
MAX_ORDER = 50
#: Seed of the factor tables' photon streams.
SEED = 20_231_219
#: Azimuthal splitting of the table's Monte Carlo
#: (:func:`~nightlights.sky.montecarlo.monte_carlo_luminance`): window as a fraction of the
#: observer distance [1], and rotations per split event [1].
SPLIT_WINDOW = 0.25
SPLIT_POINTS = 16
#: Elevation below which a shape's share of flux decides :func:`nearest_shape` [deg].
LOW_ANGLE = 30.0

_SHIPPED = "multiple_scattering.json"


@dataclass(frozen=True)
class MultipleScatteringTable:
    """The factor f = (all orders) / (single scattering) on the coarse grid.

    Attributes
    ----------
    emission
        Emission shape (a registered shape the Monte Carlo samples).
    factor
        Shape ``(4, 3, 12)`` over :data:`FACTOR_ELEVATIONS`, :data:`FACTOR_AZIMUTHS`,
        :data:`FACTOR_DISTANCES` [1].
    standard_error
        Same shape: the Monte Carlo's standard error of the raw factor [1].
    photons
        Photon histories [1].
    source
        ``shipped`` or ``measured``.
    """

    emission: str
    factor: FloatArray
    standard_error: FloatArray
    photons: int
    source: str

    def __call__(self, elevation: ArrayLike, azimuth: ArrayLike, distance: ArrayLike) -> FloatArray:
        """The interpolated factor (see :func:`multiple_scattering_factor`)."""
        return _interpolate(self.factor, elevation, azimuth, distance)


def _atmosphere_key(atmosphere: Atmosphere) -> str:
    """The atmosphere's parameters as canonical JSON (numbers as floats, 6 significant digits)."""
    params = {
        k: float(f"{v:.6g}") if isinstance(v, int | float) else v
        for k, v in atmosphere.parameters().items()
    }
    return json.dumps(params, sort_keys=True)


def _measure(
    atmosphere: Atmosphere,
    emission: str,
    photons: int,
    uplight_exponent: float,
    seed: int = SEED,
    split_window: float = SPLIT_WINDOW,
) -> tuple[FloatArray, FloatArray]:
    """Factor and its standard error on the grid, shape ``(4, 3, 12)`` (the zenith is
    measured once and shared by the three azimuths)."""
    from nightlights.sky.montecarlo import monte_carlo_luminance

    low = np.asarray(FACTOR_ELEVATIONS[:-1])
    el, az, r = np.meshgrid(low, FACTOR_AZIMUTHS, FACTOR_DISTANCES, indexing="ij")
    zenith = np.asarray(FACTOR_DISTANCES)
    mc = monte_carlo_luminance(
        np.concatenate([el.ravel(), np.full(zenith.size, 90.0)]),
        np.concatenate([az.ravel(), np.zeros(zenith.size)]),
        np.concatenate([r.ravel(), zenith]),
        atmosphere=atmosphere,
        emission=emission,
        photons=photons,
        max_order=MAX_ORDER,
        seed=seed,
        uplight_exponent=uplight_exponent,
        split_window=split_window,
        split_points=SPLIT_POINTS,
    )
    shape = (len(FACTOR_ELEVATIONS), len(FACTOR_AZIMUTHS), zenith.size)
    factor = np.empty(shape)
    error = np.empty(shape)
    for out, values in ((factor, mc.ratio), (error, mc.ratio_standard_error)):
        out[:-1] = values[: el.size].reshape(el.shape)
        out[-1] = values[el.size :]
    return factor, error


@functools.cache
def _shipped() -> dict[str, Any]:
    path = resources.files("nightlights.sky") / "data" / _SHIPPED
    if not path.is_file():
        return {}
    data: dict[str, Any] = json.loads(path.read_text())
    return data


@functools.cache
def _table(
    atmosphere: Atmosphere, emission: str, photons: int, uplight_exponent: float, definition: str
) -> tuple[FloatArray, FloatArray]:
    """Cached measurement (one per atmosphere, shape, its definition and photon count in a
    process)."""
    return _measure(atmosphere, emission, photons, uplight_exponent)


def multiple_scattering_table(
    atmosphere: Atmosphere,
    emission: str = "lambertian",
    *,
    photons: int | None = None,
    uplight_exponent: float = UPLIGHT_EXPONENT,
) -> MultipleScatteringTable:
    """The multiple-scattering factor of an atmosphere and emission shape on the coarse grid.

    Parameters
    ----------
    atmosphere
        Atmosphere model; ``extinction`` must be on.
    emission
        Emission shape: a registered shape the Monte Carlo samples
        (:func:`~nightlights.emission_functions.sampled_shape`).
    photons
        Photon histories; None: the shipped table when there is one for this atmosphere and
        shape, else :data:`BUILD_PHOTONS` [1].
    uplight_exponent
        Exponent of the uplight lobe [1].

    Returns
    -------
    MultipleScatteringTable
        The factor and its standard error.

    Raises
    ------
    InputError
        Unknown shape, or an atmosphere without extinction.

    Examples
    --------
    >>> from nightlights.sky.atmosphere import Atmosphere
    >>> t = multiple_scattering_table(Atmosphere(turbidity=2.0))  # shipped
    >>> t.source, round(float(t(90.0, 0.0, 10e3)), 1)
    ('shipped', 1.6)
    """
    shape = sampled_shape(emission)
    if not atmosphere.extinction:
        raise InputError("multiple scattering needs extinction on (Atmosphere(extinction=True))")
    key = _atmosphere_key(atmosphere)
    exponent = float(uplight_exponent)
    shipped = _shipped().get(f"{emission}|{exponent:g}|{key}")
    if photons is None and shipped is not None:
        raw = np.asarray(shipped["factor"], dtype=float)
        error = np.asarray(shipped["standard_error"], dtype=float)
        return MultipleScatteringTable(emission, raw, error, int(shipped["photons"]), "shipped")
    n = BUILD_PHOTONS if photons is None else int(photons)
    raw, error = _table(atmosphere, emission, n, exponent, json.dumps(shape.parameters()))
    return MultipleScatteringTable(emission, raw, error, n, "measured")


def _pchip_slopes(y: FloatArray, h: float) -> FloatArray:
    """Fritsch-Carlson (monotone) node slopes of y on a uniform grid of step h, along the last
    axis (three-point end formula, limited)."""
    d = np.diff(y, axis=-1) / h
    m = np.zeros(y.shape)
    a, b = d[..., :-1], d[..., 1:]
    same = a * b > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        m[..., 1:-1] = np.where(
            same, 2.0 / (1.0 / np.where(same, a, 1.0) + 1.0 / np.where(same, b, 1.0)), 0.0
        )
    for end, d0, d1 in ((0, d[..., 0], d[..., 1]), (-1, d[..., -1], d[..., -2])):
        e = (3.0 * d0 - d1) / 2.0
        e = np.where(e * d0 <= 0, 0.0, e)
        e = np.where((d0 * d1 < 0) & (np.abs(e) > 3.0 * np.abs(d0)), 3.0 * d0, e)
        m[..., end] = e
    return m


def _interpolate(
    factor: FloatArray, elevation: ArrayLike, azimuth: ArrayLike, distance: ArrayLike
) -> FloatArray:
    el, az, r = np.broadcast_arrays(
        np.asarray(elevation, dtype=float),
        np.asarray(azimuth, dtype=float),
        np.asarray(distance, dtype=float),
    )
    az = np.abs((az + 180.0) % 360.0 - 180.0)  # relative azimuth folded to 0-180
    grid = (
        np.asarray(FACTOR_ELEVATIONS),
        np.asarray(FACTOR_AZIMUTHS),
        np.log(np.asarray(FACTOR_DISTANCES)),
    )
    points = (el, az, np.log(np.maximum(r, 1e-9)))
    log_f = np.log(factor)
    index = []
    frac = []
    for axis, p in zip(grid, points, strict=True):
        p = np.clip(p, axis[0], axis[-1])
        i = np.clip(np.searchsorted(axis, p, side="right") - 1, 0, axis.size - 2)
        index.append(i)
        frac.append((p - axis[i]) / (axis[i + 1] - axis[i]))
    # in ln r: monotone cubic Hermite (Fritsch-Carlson) on ln f through the nodes
    step = float(grid[2][1] - grid[2][0])
    slopes = _pchip_slopes(log_f, step)
    t = frac[2]
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    # linear in elevation and azimuth
    out = np.zeros(el.shape)
    k = index[2]
    for de in (0, 1):
        we = frac[0] if de else 1.0 - frac[0]
        for da in (0, 1):
            wa = frac[1] if da else 1.0 - frac[1]
            ie, ia = index[0] + de, index[1] + da
            value = (
                h00 * log_f[ie, ia, k]
                + h10 * step * slopes[ie, ia, k]
                + h01 * log_f[ie, ia, k + 1]
                + h11 * step * slopes[ie, ia, k + 1]
            )
            out += we * wa * value
    return np.asarray(np.exp(out))


def multiple_scattering_factor(
    atmosphere: Atmosphere,
    emission: str,
    elevation: ArrayLike,
    azimuth: ArrayLike,
    distance: ArrayLike,
) -> FloatArray:
    """Multiple-scattering factor f: all orders over single scattering.

    Parameters
    ----------
    atmosphere
        Atmosphere model.
    emission
        Emission shape: a registered shape the Monte Carlo samples
        (:func:`~nightlights.emission_functions.sampled_shape`).
    elevation
        Elevation of the view [deg].
    azimuth
        Azimuth of the view relative to the source [deg].
    distance
        Ground distance of the source [m].

    Returns
    -------
    numpy.ndarray
        f >= 1, the broadcast shape of the inputs [1].

    Examples
    --------
    >>> from nightlights.sky.atmosphere import Atmosphere
    >>> f = multiple_scattering_factor(Atmosphere(), "lambertian", 90.0, 0.0, [1e3, 50e3])
    >>> bool(1.0 < f[0] < f[1])
    True
    """
    return multiple_scattering_table(atmosphere, emission)(elevation, azimuth, distance)


def nearest_shape(tabulated: str) -> str:
    """The kernel shape whose share of flux below :data:`LOW_ANGLE` elevation is nearest to a
    tabulated emission function's (its multiple-scattering factor stands in for the function's).

    Parameters
    ----------
    tabulated
        The function's text (``tabulated:{...}``), or a registered shape the Monte Carlo does
        not sample (one of the table form,
        :data:`~nightlights.emission_functions.TABLE_FORM`).

    Returns
    -------
    str
        ``lambertian``, ``uplight`` or ``garstang_lobe``.
    """
    from nightlights.emission_functions import emission_intensity

    if emission_shape(tabulated).sampled:
        raise InputError(f"{tabulated[:40]!r} is not a tabulated emission function")
    mu = np.linspace(0.0, 1.0, 2001)  # cosine of the zenith angle
    low = mu <= np.sin(np.radians(LOW_ANGLE))

    def share(shape: str) -> float:
        flux = np.asarray(emission_intensity(mu, shape), dtype=float) * mu
        return float(np.trapezoid(flux[low], mu[low]) / np.trapezoid(flux, mu))

    target = share(tabulated)
    shapes = ("lambertian", "uplight", "garstang_lobe")
    return min(shapes, key=lambda s: abs(share(s) - target))


def garstang_clear_night() -> Atmosphere:
    """Garstang's clear night, K = 1 at 550 nm: the second shipped atmosphere."""
    return garstang_atmosphere(1.0)


def shape_table(
    atmosphere: Atmosphere, emission: str, uplight_exponent: float = UPLIGHT_EXPONENT
) -> MultipleScatteringTable:
    """The factor table of a kernel emission shape, or, for a tabulated function (a shape the
    Monte Carlo does not sample), of the shape that stands in for it (:func:`nearest_shape`)."""
    shape = _stand_in(emission)
    return multiple_scattering_table(atmosphere, shape, uplight_exponent=uplight_exponent)


def _stand_in(emission: str) -> str:
    """The shape whose factor table a kernel shape uses: itself, or for a shape the Monte Carlo
    does not sample (a table-form shape) :func:`nearest_shape`."""
    return emission if emission_shape(emission).sampled else nearest_shape(emission)


def tables_digest(atmosphere: Atmosphere, shapes: tuple[str, ...], uplight_exponent: float) -> str:
    """A short hash of the factor tables a kernel of these shapes would use, for its cache key.

    Parameters
    ----------
    atmosphere
        The kernel's atmosphere.
    shapes
        Its emission shapes (tabulated functions: the text, their stand-in shape is used).
    uplight_exponent
        Exponent of the uplight lobe [1].

    Returns
    -------
    str
        16 hexadecimal digits: the shipped tables' values where they exist, else the
        parameters of the build-time measurement (photons, seed, orders, splitting).
    """
    import hashlib

    key = _atmosphere_key(atmosphere)
    parts: list[Any] = []
    for emission in shapes:
        shape = _stand_in(emission)
        entry = _shipped().get(f"{shape}|{float(uplight_exponent):g}|{key}")
        if entry is not None:
            parts.append([shape, entry["photons"], entry["factor"]])
        else:
            measured = [BUILD_PHOTONS, SEED, MAX_ORDER, SPLIT_WINDOW, SPLIT_POINTS]
            parts.append([shape, "measured", *measured])
    text = json.dumps(parts, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def apply_multiple_scattering(tables: dict[str, Any], spec: Any) -> dict[str, str]:
    """Multiply a kernel's single-scattering tables by the factor, in place.

    Parameters
    ----------
    tables
        Emission shape (or tabulated function text) -> array of shape ``(n_observer,
        n_source, n_distance, n_elevation, n_azimuth)`` [cd m-2 lm-1].
    spec
        The kernel's :class:`~nightlights.sky.spec.KernelSpec`.

    Returns
    -------
    dict
        Attributes to record: ``multiple_scattering_tables`` (per shape: the table used,
        ``shipped`` or ``measured``, its photons, and for a tabulated function the shape
        whose factor stands in) ; empty when ``spec.multiple_scattering`` is ``single``.
    """
    factors, attrs = factor_images(spec, tuple(tables))
    for emission, table in tables.items():
        if emission in factors:
            table *= factors[emission].astype(table.dtype)
    return attrs


def factor_images(
    spec: Any, emissions: tuple[str, ...] | None = None
) -> tuple[dict[str, FloatArray], dict[str, str]]:
    """The multiple-scattering factor of every pixel of a kernel's images, per emission shape,
    for :func:`apply_multiple_scattering` (computed once for every altitude pair).

    Parameters
    ----------
    spec
        The kernel's :class:`~nightlights.sky.spec.KernelSpec`.
    emissions
        The shapes (default ``spec.emissions``).

    Returns
    -------
    factors : dict
        Emission shape -> array, shape ``(n_distance, n_elevation, n_azimuth)`` [1];
        empty when there is no factor (single scattering, or no extinction).
    attrs : dict
        As :func:`apply_multiple_scattering`.
    """
    if spec.multiple_scattering == "single":
        return {}, {}
    if not spec.atmosphere.extinction:  # nothing is scattered out of the beam: no factor
        return {}, {"multiple_scattering_tables": "none: extinction is off (single scattering)"}
    el = np.asarray(spec.elevations, dtype=float)[:, None]
    az = np.asarray(spec.azimuths, dtype=float)[None, :]
    notes = []
    images = {}
    for emission in spec.emissions if emissions is None else emissions:
        factors = shape_table(spec.atmosphere, emission, spec.uplight_exponent)
        images[emission] = np.stack(
            [factors(el, az, r) for r in np.asarray(spec.distances, dtype=float)]
        )
        shape = factors.emission
        name = "tabulated" if emission_shape(emission).table == "tabulated" else emission
        stand_in = f" (factor of {shape})" if shape != emission else ""
        notes.append(f"{name}: {factors.source}, {factors.photons} photons{stand_in}")
    return images, {"multiple_scattering_tables": "; ".join(notes)}


def scattering_note(kernel_attrs: Any) -> str:
    """What a kernel's luminance counts, for the notes of the products made with it.

    Parameters
    ----------
    kernel_attrs
        The kernel dataset's attributes.

    Returns
    -------
    str
        ``all scattering orders (...)`` or ``single scattering``.
    """
    if str(kernel_attrs.get("multiple_scattering", "single")) == "single":
        return "single scattering"
    return "all scattering orders (single scattering x the Monte Carlo multiple-scattering factor)"
