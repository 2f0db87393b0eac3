"""Optical properties of a clear atmosphere: molecules (Rayleigh) and aerosols.

Pure functions, one per published model, and the :class:`Atmosphere` dataclass that holds the
parameters of the two-species exponential atmosphere used by the skyglow kernel.

References
----------
Bodhaine, B. A., Wood, N. B., Dutton, E. G. & Slusser, J. R. 1999, "On Rayleigh optical depth
calculations", J. Atmos. Oceanic Technol. 16, 1854-1861, Eq. 30.
Preetham, A. J., Shirley, P. & Smits, B. 1999, "A practical analytic model for daylight",
SIGGRAPH 99, Appendix A.3 (turbidity to Angstrom coefficient).
Henyey, L. G. & Greenstein, J. L. 1941, "Diffuse radiation in the Galaxy", ApJ 93, 70-83.
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 3.2 (two-species exponential atmosphere, turbidity).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nightlights.errors import InputError

__all__ = [
    "Atmosphere",
    "aerosol_optical_depth",
    "angstrom_turbidity_coefficient",
    "exponential_density",
    "henyey_greenstein_phase",
    "isotropic_phase",
    "rayleigh_optical_depth",
    "rayleigh_phase",
    "scattering_species",
    "smallest_scale_height",
]

#: Density below exp(-TOP_E_FOLDINGS) of its sea-level value is ignored: the top of the
#: model atmosphere is this many of the largest scale heights [1].
TOP_E_FOLDINGS = 16.0

#: Largest turbidity accepted: thin fog (visibility 1-2 km) in McCartney's (1976) table that
#: Preetham et al. (1999) adopt; beyond it the glow of sources past a few hundred metres
#: underflows and the kernel is all but zero [1].
MAX_TURBIDITY = 64.0
#: Largest vertical optical depth accepted (aerosol or molecular), about that of
#: :data:`MAX_TURBIDITY` at 550 nm (6.3) rounded up [1].
MAX_OPTICAL_DEPTH = 10.0
#: Wavelengths accepted: the near ultraviolet to the silicon sensors' near-infrared edge [nm].
WAVELENGTH_RANGE = (300.0, 1100.0)
#: Largest scale height accepted (the model atmosphere's top is 16 of them) [m].
MAX_SCALE_HEIGHT = 100_000.0


def rayleigh_optical_depth(wavelength_nm: ArrayLike = 550.0) -> NDArray[np.float64]:
    """Vertical Rayleigh optical depth of the standard atmosphere at sea level.

    .. math::
        \\tau_R = 0.0021520 \\frac{1.0455996 - 341.29061\\lambda^{-2} - 0.90230850\\lambda^2}
        {1 + 0.0027059889\\lambda^{-2} - 85.968563\\lambda^2}

    with :math:`\\lambda` in micrometres, for 1013.25 hPa, 45 deg latitude, 360 ppm CO2.

    Parameters
    ----------
    wavelength_nm
        Wavelength, 250-1000 [nm].

    Returns
    -------
    numpy.ndarray
        Optical depth [1].

    References
    ----------
    Bodhaine et al. 1999, Eq. 30.

    Examples
    --------
    >>> round(float(rayleigh_optical_depth(550.0)), 4)
    0.0971
    """
    lam = np.asarray(wavelength_nm, dtype=float) / 1000.0
    if np.any(lam <= 0):
        raise InputError(f"wavelength {wavelength_nm!r} nm; expected a positive wavelength")
    inv2 = lam**-2
    sq = lam**2
    # Bodhaine 1999, Eq. 30
    return np.asarray(
        0.0021520
        * (1.0455996 - 341.29061 * inv2 - 0.90230850 * sq)
        / (1.0 + 0.0027059889 * inv2 - 85.968563 * sq)
    )


def angstrom_turbidity_coefficient(turbidity: ArrayLike) -> NDArray[np.float64]:
    """Angstrom turbidity coefficient from Linke-like turbidity.

    .. math:: \\beta = 0.04608 T - 0.04586

    Parameters
    ----------
    turbidity
        Turbidity T, >= 1 (1 is pure air, 2 a clear sky, 10 haze) [1].

    Returns
    -------
    numpy.ndarray
        Angstrom coefficient beta, the aerosol optical depth at 1 um [1].

    References
    ----------
    Preetham, Shirley & Smits 1999, Appendix A.3.
    """
    t = np.asarray(turbidity, dtype=float)
    if np.any(t < 1.0):
        raise InputError(f"turbidity {turbidity!r}; expected >= 1 (1 = pure air)")
    # Preetham 1999, App. A.3; clipped at 0 (T = 1 gives -0.0002, i.e. no aerosol)
    return np.asarray(np.maximum(0.04608 * t - 0.04586, 0.0))


def aerosol_optical_depth(
    turbidity: ArrayLike, wavelength_nm: ArrayLike = 550.0, angstrom_exponent: float = 1.3
) -> NDArray[np.float64]:
    """Vertical aerosol optical depth from turbidity by Angstrom's law.

    .. math:: \\tau_A(\\lambda) = \\beta (\\lambda / 1\\,\\mu m)^{-\\alpha}

    Parameters
    ----------
    turbidity
        Turbidity T, >= 1 [1].
    wavelength_nm
        Wavelength [nm].
    angstrom_exponent
        Angstrom exponent alpha; Preetham uses 1.3 [1].

    Returns
    -------
    numpy.ndarray
        Aerosol optical depth [1].

    References
    ----------
    Preetham, Shirley & Smits 1999, Appendix A.3; Angstrom's law.
    """
    beta = angstrom_turbidity_coefficient(turbidity)
    lam_um = np.asarray(wavelength_nm, dtype=float) / 1000.0
    return np.asarray(beta * lam_um ** (-angstrom_exponent))


def rayleigh_phase(cos_angle: ArrayLike) -> NDArray[np.float64]:
    """Rayleigh phase function, normalised to 1 over the sphere.

    .. math:: p_R(\\Theta) = \\frac{3}{16\\pi}(1 + \\cos^2\\Theta)

    Parameters
    ----------
    cos_angle
        Cosine of the scattering angle [1].

    Returns
    -------
    numpy.ndarray
        Phase function [sr-1].

    References
    ----------
    Chandrasekhar 1950, Radiative Transfer, Sec. 17 (unpolarised Rayleigh phase function).
    """
    mu = np.asarray(cos_angle, dtype=float)
    return 3.0 / (16.0 * math.pi) * (1.0 + mu * mu)


def henyey_greenstein_phase(cos_angle: ArrayLike, asymmetry: float) -> NDArray[np.float64]:
    """Henyey-Greenstein phase function, normalised to 1 over the sphere.

    .. math:: p_{HG}(\\Theta) = \\frac{1 - g^2}{4\\pi (1 + g^2 - 2 g \\cos\\Theta)^{3/2}}

    Parameters
    ----------
    cos_angle
        Cosine of the scattering angle (1 = forward) [1].
    asymmetry
        Asymmetry parameter g in (-1, 1) [1].

    Returns
    -------
    numpy.ndarray
        Phase function [sr-1].

    References
    ----------
    Henyey & Greenstein 1941.
    """
    if not -1.0 < asymmetry < 1.0:
        raise InputError(f"asymmetry {asymmetry!r}; expected -1 < g < 1")
    mu = np.asarray(cos_angle, dtype=float)
    g = asymmetry
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * mu) ** 1.5)


def isotropic_phase(cos_angle: ArrayLike) -> NDArray[np.float64]:
    """Isotropic phase function 1/(4 pi) [sr-1], for validation cases.

    Parameters
    ----------
    cos_angle
        Cosine of the scattering angle [1].

    Returns
    -------
    numpy.ndarray
        Phase function [sr-1].
    """
    return np.full(np.shape(cos_angle), 1.0 / (4.0 * math.pi))


def exponential_density(altitude: ArrayLike, scale_height: float) -> NDArray[np.float64]:
    """Relative number density of an exponential atmosphere, 1 at sea level.

    Parameters
    ----------
    altitude
        Altitude above sea level [m].
    scale_height
        Scale height H [m].

    Returns
    -------
    numpy.ndarray
        exp(-altitude / H) [1].
    """
    return np.exp(-np.asarray(altitude, dtype=float) / scale_height)


@dataclass(frozen=True)
class Atmosphere:
    """Two-species (molecules + aerosols) exponential atmosphere for the skyglow kernel.

    Parameters
    ----------
    turbidity
        Turbidity T setting the aerosol amount (Preetham 1999); ignored when
        ``aerosol_optical_depth`` is given [1].
    wavelength_nm
        Wavelength of the single band [nm].
    molecular_scale_height
        Scale height of air molecules [m].
    aerosol_scale_height
        Scale height of aerosols [m].
    asymmetry
        Henyey-Greenstein asymmetry g of aerosols; 0 gives isotropic aerosol scattering [1].
    earth_radius
        Radius of the spherical Earth [m].
    flat_earth
        Use a flat Earth (Dobashi 2023) instead of a sphere.
    extinction
        Attenuate light on both legs (source to scattering point to observer).
    aerosol_optical_depth
        Vertical aerosol optical depth at ``wavelength_nm``; overrides ``turbidity`` [1].
    rayleigh_optical_depth
        Vertical molecular optical depth; default Bodhaine 1999 at ``wavelength_nm``; 0 removes
        the molecules [1].
    angstrom_exponent
        Angstrom exponent for turbidity to optical depth [1].
    aerosol_albedo
        Single-scattering albedo of aerosols [1].
    molecular_phase
        ``"rayleigh"`` or ``"isotropic"`` (validation).
    """

    turbidity: float = 2.0
    wavelength_nm: float = 550.0
    molecular_scale_height: float = 8000.0
    aerosol_scale_height: float = 1200.0
    asymmetry: float = 0.7
    earth_radius: float = 6.371e6
    flat_earth: bool = False
    extinction: bool = True
    aerosol_optical_depth: float | None = None
    rayleigh_optical_depth: float | None = None
    angstrom_exponent: float = 1.3
    aerosol_albedo: float = 1.0
    molecular_phase: str = "rayleigh"

    def __post_init__(self) -> None:
        if not 1.0 <= self.turbidity <= MAX_TURBIDITY:
            raise InputError(
                f"turbidity {self.turbidity!r}; expected 1 (pure air) to {MAX_TURBIDITY:g} "
                "(thin fog)"
            )
        for name in ("molecular_scale_height", "aerosol_scale_height", "earth_radius"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"{name} {value!r} m; expected a positive length")
        for name in ("molecular_scale_height", "aerosol_scale_height"):
            value = getattr(self, name)
            if value > MAX_SCALE_HEIGHT:
                raise InputError(f"{name} {value!r} m; expected at most {MAX_SCALE_HEIGHT:g} m")
        low, high = WAVELENGTH_RANGE
        if not low <= self.wavelength_nm <= high:
            raise InputError(f"wavelength_nm {self.wavelength_nm!r}; expected {low:g}-{high:g} nm")
        if not (np.isfinite(self.angstrom_exponent) and 0.0 <= self.angstrom_exponent <= 4.0):
            raise InputError(
                f"angstrom_exponent {self.angstrom_exponent!r}; expected 0-4 (1.3 typical)"
            )
        if not -1.0 < self.asymmetry < 1.0:
            raise InputError(f"asymmetry {self.asymmetry!r}; expected -1 < g < 1")
        for name in ("aerosol_optical_depth", "rayleigh_optical_depth"):
            value = getattr(self, name)
            if value is not None and not (0 <= value <= MAX_OPTICAL_DEPTH):
                raise InputError(
                    f"{name} {value!r}; expected an optical depth from 0 to {MAX_OPTICAL_DEPTH:g}"
                )
        if not 0.0 <= self.aerosol_albedo <= 1.0:
            raise InputError(f"aerosol_albedo {self.aerosol_albedo!r}; expected 0..1")
        if self.molecular_phase not in ("rayleigh", "isotropic"):
            raise InputError(
                f"molecular_phase {self.molecular_phase!r}; expected 'rayleigh' or 'isotropic'"
            )

    @property
    def molecular_optical_depth(self) -> float:
        """Vertical molecular optical depth from sea level [1]."""
        if self.rayleigh_optical_depth is not None:
            return float(self.rayleigh_optical_depth)
        return float(rayleigh_optical_depth(self.wavelength_nm))

    @property
    def aerosol_depth(self) -> float:
        """Vertical aerosol optical depth from sea level [1]."""
        if self.aerosol_optical_depth is not None:
            return float(self.aerosol_optical_depth)
        return float(
            aerosol_optical_depth(self.turbidity, self.wavelength_nm, self.angstrom_exponent)
        )

    @property
    def molecular_extinction(self) -> float:
        """Sea-level molecular extinction (= scattering) coefficient [m-1]."""
        return self.molecular_optical_depth / self.molecular_scale_height

    @property
    def aerosol_extinction(self) -> float:
        """Sea-level aerosol extinction coefficient [m-1]."""
        return self.aerosol_depth / self.aerosol_scale_height

    @property
    def top_altitude(self) -> float:
        """Top of the model atmosphere: 16 of the largest active scale heights [m]."""
        heights = [
            h
            for h, beta in (
                (self.molecular_scale_height, self.molecular_extinction),
                (self.aerosol_scale_height, self.aerosol_extinction),
            )
            if beta > 0
        ]
        return TOP_E_FOLDINGS * max(heights) if heights else 0.0

    def extinction_coefficient(self, altitude: ArrayLike) -> NDArray[np.float64]:
        """Total extinction coefficient at an altitude [m-1].

        Parameters
        ----------
        altitude
            Altitude above sea level [m].

        Returns
        -------
        numpy.ndarray
            Extinction coefficient [m-1].
        """
        h = np.asarray(altitude, dtype=float)
        return self.molecular_extinction * exponential_density(
            h, self.molecular_scale_height
        ) + self.aerosol_extinction * exponential_density(h, self.aerosol_scale_height)

    def scattering(self, altitude: ArrayLike, cos_angle: ArrayLike) -> NDArray[np.float64]:
        """Scattering coefficient times phase function, summed over the two species.

        Parameters
        ----------
        altitude
            Altitude of the scattering point above sea level [m].
        cos_angle
            Cosine of the scattering angle [1].

        Returns
        -------
        numpy.ndarray
            sigma_R p_R + sigma_A p_HG [m-1 sr-1].

        References
        ----------
        Dobashi et al. 2023, Sec. 3.2 (single scattering by molecules and aerosols).
        """
        h = np.asarray(altitude, dtype=float)
        out = np.zeros(np.broadcast_shapes(h.shape, np.shape(cos_angle)))
        if self.molecular_extinction > 0:
            phase = (
                rayleigh_phase(cos_angle)
                if self.molecular_phase == "rayleigh"
                else isotropic_phase(cos_angle)
            )
            out = out + self.molecular_extinction * np.exp(-h / self.molecular_scale_height) * phase
        if self.aerosol_extinction > 0 and self.aerosol_albedo > 0:
            out = out + (
                self.aerosol_albedo
                * self.aerosol_extinction
                * np.exp(-h / self.aerosol_scale_height)
                * henyey_greenstein_phase(cos_angle, self.asymmetry)
            )
        return out

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> Atmosphere:
        """The atmosphere described by :meth:`parameters` (or a kernel's attributes).

        Parameters
        ----------
        parameters
            Mapping with the field names of :class:`Atmosphere`; extra keys are ignored, missing
            fields take their defaults, -1 stands for None and integers for booleans.

        Returns
        -------
        Atmosphere
            The atmosphere.

        Examples
        --------
        >>> atm = Atmosphere(aerosol_optical_depth=0.3, flat_earth=True)
        >>> Atmosphere.from_parameters(atm.parameters()) == atm
        True
        """
        values: dict[str, Any] = {}
        for name, spec in cls.__dataclass_fields__.items():
            if name not in parameters:
                continue
            value = parameters[name]
            if isinstance(value, np.generic):
                value = value.item()
            if spec.default is None:  # optional optical depths: -1 stands for None
                value = None if float(value) < 0 else float(value)
            elif isinstance(spec.default, bool):
                value = bool(value)
            elif isinstance(spec.default, float):
                value = float(value)
            else:
                value = str(value)
            values[name] = value
        return cls(**values)

    def parameters(self) -> dict[str, float | int | str]:
        """Every model parameter, as NetCDF-safe attribute values (None -> -1, bool -> int)."""
        out: dict[str, float | int | str] = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if value is None:
                value = -1.0
            elif isinstance(value, bool):
                value = int(value)
            out[name] = value
        out["molecular_optical_depth_used"] = self.molecular_optical_depth
        out["aerosol_optical_depth_used"] = self.aerosol_depth
        return out


def scattering_species(atmosphere: Atmosphere) -> list[tuple[float, float]]:
    """The species that scatter: (sea-level extinction [m-1], scale height [m]) pairs.

    Parameters
    ----------
    atmosphere
        Atmosphere model.

    Returns
    -------
    list of tuple
        Molecules then aerosols, each only when its extinction is positive.
    """
    return [
        (beta, height)
        for beta, height in (
            (atmosphere.molecular_extinction, atmosphere.molecular_scale_height),
            (atmosphere.aerosol_extinction, atmosphere.aerosol_scale_height),
        )
        if beta > 0
    ]


def smallest_scale_height(atmosphere: Atmosphere) -> float:
    """Smallest scale height of the species that scatter (the molecules' when none does) [m].

    Parameters
    ----------
    atmosphere
        Atmosphere model.

    Returns
    -------
    float
        Scale height [m].
    """
    heights = [height for _, height in scattering_species(atmosphere)]
    return min(heights) if heights else atmosphere.molecular_scale_height
