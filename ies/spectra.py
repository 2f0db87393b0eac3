"""Spectral power distributions of light sources, sensor responses and the lux-to-sensor factor.

A sensor with relative spectral response R sees, for a source of spectral power
distribution S that produces an illuminance E_v [lx],

.. math::

    E_R = k\\, E_v, \\qquad k = \\frac{\\int S(\\lambda) R(\\lambda)\\, d\\lambda}
                                 {683 \\int S(\\lambda) V(\\lambda)\\, d\\lambda}

in W m-2 (R-weighted irradiance) per lux (Chuang 2011, Sec. 5.1, Eq. 10; K_m = 683 lm/W).
For R = V the factor is exactly 1/683 W m-2 per lx: one lux is 1/683 W m-2 of
V-weighted irradiance, the definition of the lumen.

Named spectra come from colour-science's shipped datasets (CIE 15:2018 illuminants HP1-HP5
and LED-B1..B5, the light-source library of Ohno/NIST), the CIE 1924 photopic and CIE 1951
scotopic luminous efficiency functions and the CIE 1931 2 degree colour-matching functions.
Responses shipped as CSV in ``ies/data`` (see ``ies/data/README.md``): the CIE S 026
melanopic action spectrum, a MIL-STD-3009-style NVIS goggle model (class A and B), the
Johnson V passband of Bessell (1990, Table 2), and the Sky Quality Meter and TESS-W
photometer responses, reconstructed from their published components (a TSL237 photodiode
behind a HOYA CM-500 glass or a 740 nm dichroic), not measured curves.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from importlib import resources
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ies.errors import PhotometryError

#: Maximum luminous efficacy of photopic vision [lm W-1] (CIE, SI definition of the lumen).
K_PHOTOPIC = 683.0
#: Maximum luminous efficacy of scotopic vision [lm W-1] (CIE 1951; 1700 lm/W).
K_SCOTOPIC = 1700.0
#: Common integration grid [nm].
WAVELENGTHS = np.arange(360.0, 951.0, 1.0)


@dataclass(frozen=True, eq=False)
class Spectrum:
    """A sampled spectral curve.

    Attributes
    ----------
    name : str
        Identifier.
    wavelengths : ndarray
        Ascending wavelengths [nm].
    values : ndarray
        Spectral power (relative) or sensor response (peak-normalised).
    description : str
        Provenance.
    """

    name: str
    wavelengths: NDArray[np.float64]
    values: NDArray[np.float64]
    description: str = ""

    def on(self, wavelengths: NDArray[np.float64]) -> NDArray[np.float64]:
        """Linear interpolation onto ``wavelengths``, zero outside the sampled range."""
        return np.interp(wavelengths, self.wavelengths, self.values, left=0.0, right=0.0)


#: colour-science's plotting subpackage, which imports ``matplotlib.pyplot``.
_COLOUR_PLOTTING = "colour.plotting"


class _DeferredColourPlotting(ModuleType):
    """Stands in for ``colour.plotting`` and imports the real subpackage on first use."""

    def __getattr__(self, name: str) -> Any:
        if sys.modules.get(_COLOUR_PLOTTING) is self:  # colour-science is still loading
            raise AttributeError(f"{_COLOUR_PLOTTING} is not loaded yet; no {name!r}")
        return getattr(importlib.import_module(_COLOUR_PLOTTING), name)


def colour_science() -> Any:
    """The ``colour`` package (colour-science), imported without changing the process.

    Importing colour-science sets NumPy's print options to the 1.13 legacy style, adds a
    warnings filter, and imports its plotting subpackage and with it ``matplotlib.pyplot``.
    Here the import is silent, the caller's print options and warnings filters are the same
    afterwards, and ``colour.plotting`` is a stand-in that imports the real subpackage (and
    pyplot) when first used. Import colour-science through this function only: a plain
    ``import colour`` that runs first makes those changes for good.

    Returns
    -------
    colour
        The package, as colour-science registers it in ``sys.modules``.
    """
    loaded = sys.modules.get("colour")
    if loaded is not None:
        return loaded
    deferred = _DeferredColourPlotting(_COLOUR_PLOTTING)
    sys.modules[_COLOUR_PLOTTING] = deferred
    try:
        with warnings.catch_warnings(), np.printoptions():
            warnings.simplefilter("ignore")
            import colour
    finally:
        if sys.modules.get(_COLOUR_PLOTTING) is deferred:
            del sys.modules[_COLOUR_PLOTTING]
    return colour


def _from_colour_sd(name: str, sd: Any, description: str) -> Spectrum:
    return Spectrum(
        name,
        np.asarray(sd.wavelengths, dtype=np.float64),
        np.asarray(sd.values, dtype=np.float64),
        description,
    )


def _illuminant(key: str) -> Callable[[], object]:
    return lambda: colour_science().SDS_ILLUMINANTS[key]


def _light_source(key: str) -> Callable[[], object]:
    return lambda: colour_science().SDS_LIGHT_SOURCES[key]


#: Named SPDs: name -> (loader, provenance).
_SPD_SOURCES: dict[str, tuple[Callable[[], object], str]] = {
    "HPS": (
        _light_source("HPS"),
        "high-pressure sodium, colour-science light-source library (NIST measurements)",
    ),
    "HPS_CIE_HP1": (
        _illuminant("HP1"),
        "CIE 15:2018 illuminant HP1, standard high-pressure sodium",
    ),
    "HPS_colour_enhanced": (
        _illuminant("HP2"),
        "CIE 15:2018 illuminant HP2, colour-enhanced high-pressure sodium",
    ),
    "LPS": (_light_source("LPS"), "low-pressure sodium, colour-science light-source library"),
    "mercury": (_light_source("Mercury"), "mercury vapour, colour-science light-source library"),
    "metal_halide_3000K": (_illuminant("HP3"), "CIE 15:2018 illuminant HP3, metal halide"),
    "metal_halide_4000K": (_illuminant("HP4"), "CIE 15:2018 illuminant HP4, metal halide"),
    "LED_2700K": (_illuminant("LED-B1"), "CIE 15:2018 illuminant LED-B1, phosphor LED 2733 K"),
    "LED_3000K": (_illuminant("LED-B2"), "CIE 15:2018 illuminant LED-B2, phosphor LED 2998 K"),
    "LED_4000K": (_illuminant("LED-B3"), "CIE 15:2018 illuminant LED-B3, phosphor LED 4103 K"),
    "LED_5000K": (_illuminant("LED-B4"), "CIE 15:2018 illuminant LED-B4, phosphor LED 5109 K"),
    "incandescent": (_illuminant("A"), "CIE standard illuminant A, 2856 K"),
}

SPDS: tuple[str, ...] = tuple(_SPD_SOURCES)


def _lef(key: str) -> Callable[[], object]:
    return lambda: colour_science().colorimetry.SDS_LEFS[key]


def _cmf(index: int) -> Callable[[], object]:
    def load() -> object:
        cmfs = colour_science().MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        return cmfs.signals[cmfs.labels[index]]

    return load


def _csv(file_name: str, column: str) -> Callable[[], tuple[NDArray, NDArray]]:
    def load() -> tuple[NDArray, NDArray]:
        text = resources.files("ies").joinpath("data", file_name).read_text()
        rows = [line for line in text.splitlines() if line and not line.startswith("#")]
        header = rows[0].split(",")
        data = np.array([[float(x) for x in row.split(",")] for row in rows[1:]])
        return data[:, 0], data[:, header.index(column)]

    return load


_SENSOR_SOURCES: dict[str, tuple[Callable[[], object], str]] = {
    "photopic": (
        _lef("CIE 1924 Photopic Standard Observer"),
        "CIE 1924 photopic luminous efficiency V(lambda)",
    ),
    "scotopic": (
        _lef("CIE 1951 Scotopic Standard Observer"),
        "CIE 1951 scotopic luminous efficiency V'(lambda)",
    ),
    "cie_x": (_cmf(0), "CIE 1931 2 degree colour-matching function x-bar"),
    "cie_y": (_cmf(1), "CIE 1931 2 degree colour-matching function y-bar"),
    "cie_z": (_cmf(2), "CIE 1931 2 degree colour-matching function z-bar"),
    "melanopic": (
        _csv("cie_s026_melanopic.csv", "melanopic"),
        "CIE S 026/E:2018 melanopic action spectrum (ies/data)",
    ),
    "nvis_class_a": (
        _csv("nvis_response.csv", "nvis_class_a"),
        "NVIS class A goggle response, MIL-STD-3009-style model (ies/data)",
    ),
    "nvis_class_b": (
        _csv("nvis_response.csv", "nvis_class_b"),
        "NVIS class B goggle response, MIL-STD-3009-style model (ies/data)",
    ),
    "johnson_v": (
        _csv("johnson_v.csv", "johnson_v"),
        "Johnson V passband, Bessell (1990) PASP 102, 1181, Table 2 (ies/data)",
    ),
    "sqm": (
        _csv("photometer_response.csv", "sqm"),
        "Sky Quality Meter (TAOS TSL237 behind a HOYA CM-500 filter, Cinzano 2005): a "
        "reconstruction from the published components, not a measurement (ies/data)",
    ),
    "tess_w": (
        _csv("photometer_response.csv", "tess_w"),
        "TESS-W photometer (TSL237 behind a dichroic filter cutting near 740 nm, Zamorano "
        "et al. 2016): a reconstruction from the published components, not a measurement "
        "(ies/data)",
    ),
}

#: Names of the built-in sensor responses.
SENSORS: tuple[str, ...] = tuple(_SENSOR_SOURCES)


def _build(name: str, table: dict[str, tuple[Callable[[], object], str]], kind: str) -> Spectrum:
    if name not in table:
        raise PhotometryError(f"unknown {kind} {name!r}; known: {', '.join(table)}")
    loader, description = table[name]
    loaded = loader()
    if isinstance(loaded, tuple):
        wavelengths, values = loaded
        return Spectrum(
            name, np.asarray(wavelengths, float), np.asarray(values, float), description
        )
    return _from_colour_sd(name, loaded, description)


@cache
def get_spd(name: str) -> Spectrum:
    """A named light-source spectral power distribution (see :data:`SPDS`).

    Parameters
    ----------
    name : str
        E.g. ``"HPS"``, ``"LED_4000K"``.

    Returns
    -------
    Spectrum
        Relative spectral power.
    """
    return _build(name, _SPD_SOURCES, "SPD")


@cache
def get_sensor(name: str) -> Spectrum:
    """A named sensor response (see :data:`SENSORS`), peak-normalised.

    Parameters
    ----------
    name : str
        E.g. ``"photopic"``, ``"scotopic"``, ``"melanopic"``, ``"nvis_class_a"``.

    Returns
    -------
    Spectrum
        Relative spectral response.
    """
    return _build(name, _SENSOR_SOURCES, "sensor")


SpectrumLike = Spectrum | str | tuple[ArrayLike, ArrayLike]


def _as_spectrum(value: SpectrumLike, getter: Callable[[str], Spectrum]) -> Spectrum:
    if isinstance(value, Spectrum):
        return value
    if isinstance(value, str):
        return getter(value)
    wavelengths, values = value
    w = np.asarray(wavelengths, float)
    v = np.asarray(values, float)
    if w.ndim != 1 or w.shape != v.shape or np.any(np.diff(w) <= 0):
        raise PhotometryError(
            "a spectrum needs ascending wavelengths [nm] and values of the same length"
        )
    if np.any(v < 0) or not np.all(np.isfinite(v)):
        raise PhotometryError("spectral values must be finite and >= 0")
    return Spectrum("custom", w, v)


def sensor_factor(spd: SpectrumLike, sensor: SpectrumLike) -> float:
    """Sensor-weighted irradiance per lux for a source spectrum.

    Parameters
    ----------
    spd : Spectrum, str or (wavelengths, values)
        Source spectral power distribution (any scale) [nm, -].
    sensor : Spectrum, str or (wavelengths, values)
        Sensor relative spectral response [nm, -].

    Returns
    -------
    float
        :math:`k = \\int S R\\, d\\lambda / (683 \\int S V\\, d\\lambda)`
        [W m-2 per lx] (sensor-weighted irradiance per unit illuminance).

    References
    ----------
    Chuang 2011, Sec. 5.1, Eq. 10; CIE 1924 V(lambda), K_m = 683 lm/W.

    Examples
    --------
    >>> round(sensor_factor("HPS", "photopic") * 683, 12)
    1.0
    """
    source = _as_spectrum(spd, get_spd)
    response = _as_spectrum(sensor, get_sensor)
    photopic = get_sensor("photopic")
    s = source.on(WAVELENGTHS)
    numerator = np.trapezoid(s * response.on(WAVELENGTHS), WAVELENGTHS)
    denominator = K_PHOTOPIC * np.trapezoid(s * photopic.on(WAVELENGTHS), WAVELENGTHS)
    if denominator <= 0:
        raise PhotometryError(f"spectrum {source.name!r} has no photopic content; lux are 0")
    return float(numerator / denominator)


def scotopic_photopic_ratio(spd: SpectrumLike) -> float:
    """S/P ratio: scotopic over photopic luminous flux of a source.

    Parameters
    ----------
    spd : Spectrum, str or (wavelengths, values)
        Source spectral power distribution [nm, -].

    Returns
    -------
    float
        :math:`1700 \\int S V' / (683 \\int S V)`.

    References
    ----------
    CIE 1951 scotopic luminous efficiency; K'_m = 1700 lm/W.
    """
    return K_SCOTOPIC * sensor_factor(spd, "scotopic")
