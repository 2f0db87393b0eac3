"""Emission angular functions of a ground source: the shapes, their registry and a band's mix.

The shapes the skyglow kernel tabulates (:mod:`nightlights.sky.kernel`): Lambertian reflection,
the direct-uplight lobe sin^n, Garstang's (1986) low-angle psi^4 lobe, an isotropic emitter (for
validation) and a tabulated function; each is normalised to 1 lm into the upper hemisphere.
Kept apart from the line-of-sight integral so that its compiled twins
(:mod:`nightlights.sky._kernel_numba`, :mod:`nightlights.sky._montecarlo_numba`) can read the
same constants without importing the integrator.

Every shape is one row of a registry (:class:`EmissionShape`, :func:`register_emission_shape`):
its name, its numpy intensity function, the code of the compiled form both compiled integrators
evaluate it with (:data:`COMPILED_FORMS`), the name of its kernel table and a line of
documentation. The parser of band tags, the validators of the integrators and the kernel
builder read the known names from it, so a shape whose angular function one of the compiled
forms expresses (a cosine, a sine power, isotropic, the psi^4 lobe, or a table interpolated
linearly in the angle) is one registration call.

An emission band's angular function (:class:`EmissionFunction`) is a weighted mix of the
shapes, written in the band tag ``emission_function`` (:data:`EMISSION_FUNCTION_TAG`) by the
stages that make emission rasters (:mod:`nightlights.ground.upward`) and read by the skyglow
stages. A leaf of the package (it imports no other layer), so that the ground stages that write
the tag and the sky stages that read it both import it.

Length: about 900 lines, because the shapes, their compiled forms, the registry that joins them
and the band tag's mixes of them are one vocabulary that the ground stages, the numpy and the
compiled integrators must read alike.

References
----------
1. Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375.
"""

from __future__ import annotations

import functools
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import beta as beta_function

from nightlights._typing import FloatArray
from nightlights.errors import InputError

__all__ = [
    "COMPILED_FORMS",
    "COSINE_FORM",
    "DEFAULT_EMISSION_FUNCTION",
    "EMISSION_FUNCTION_TAG",
    "EMISSION_MODELS",
    "GARSTANG_LOBE_NORM",
    "ISOTROPIC_FORM",
    "PSI4_LOBE_FORM",
    "SAMPLED_FORMS",
    "SINE_POWER_FORM",
    "TABLE_FORM",
    "TABULATED_PREFIX",
    "UPLIGHT_EXPONENT",
    "EmissionFunction",
    "EmissionShape",
    "emission_intensity",
    "emission_shape",
    "emission_shape_names",
    "form_intensity",
    "garstang_weights",
    "kernel_table_names",
    "parse_tabulated_emission",
    "register_emission_shape",
    "sampled_shape",
    "tabulated_emission_intensity",
    "tabulated_norm",
    "unregister_emission_shape",
]

#: The built-in emission angular distributions, each normalised to 1 lm emitted into the upper
#: hemisphere (the registry may hold more: :func:`emission_shape_names`).
EMISSION_MODELS = ("lambertian", "uplight", "isotropic", "garstang_lobe")

# Codes of the compiled angular forms: the branches of both compiled integrators
# (nightlights.sky._kernel_numba._ray, nightlights.sky._montecarlo_numba._emission and
# _sample_emission), which are compiled against these values.
#: I = cos(theta) / pi.
COSINE_FORM = 0
#: I = sin^n(theta) / (pi B(1/2, n/2 + 1)).
SINE_POWER_FORM = 1
#: I = 1 / (2 pi).
ISOTROPIC_FORM = 2
#: I = c theta^4 / (2 pi), c = :data:`GARSTANG_LOBE_NORM`.
PSI4_LOBE_FORM = 3
#: I = t(theta), a table interpolated linearly in theta and normalised to 1 lm.
TABLE_FORM = 4
#: The compiled forms by name.
COMPILED_FORMS = {
    "cosine": COSINE_FORM,
    "sine_power": SINE_POWER_FORM,
    "isotropic": ISOTROPIC_FORM,
    "psi4_lobe": PSI4_LOBE_FORM,
    "table": TABLE_FORM,
}
#: The forms the multiple-scattering Monte Carlo samples (a table it does not).
SAMPLED_FORMS = frozenset({COSINE_FORM, SINE_POWER_FORM, ISOTROPIC_FORM, PSI4_LOBE_FORM})


#: Default exponent n of the direct-uplight lobe sin^n(theta) about the local vertical [1].
UPLIGHT_EXPONENT = 4.0

#: Normalisation c of Garstang's low-angle term c psi^4 / (2 pi): 1 / int_0^{pi/2} psi^4 sin psi
#: dpsi, in closed form 1 / (24 - 12 pi + pi^3 / 2) = 0.55432 (Garstang 1986 rounds it to
#: 0.554) [1].
GARSTANG_LOBE_NORM = 1.0 / (24.0 - 12.0 * math.pi + math.pi**3 / 2.0)

#: Prefix of a tabulated emission function: ``tabulated:{"angles": [...], "intensities":
#: [...]}``, angles from the local vertical [deg], 0 to 90, relative intensities [1].
TABULATED_PREFIX = "tabulated:"


def emission_intensity(
    cos_zenith: ArrayLike, model: str = "lambertian", *, uplight_exponent: float = UPLIGHT_EXPONENT
) -> FloatArray:
    """Luminous intensity per lumen of upward flux, as a function of the emission angle.

    Models (theta = angle from the source's local vertical, 1 lm into the upper hemisphere):

    - ``"lambertian"``: :math:`I = \\cos\\theta / \\pi` (reflection by the ground);
    - ``"uplight"``: :math:`I = \\sin^n\\theta / (\\pi B(1/2, n/2 + 1))`, a lobe peaking at
      the horizon (direct uplight of luminaires, mostly just above the horizontal). For the
      default n = 4 the intensity halves 33 deg above the horizon (sin^4 theta = 1/2 at
      theta = 57 deg), and half the flux leaves within 16 deg of the horizon (see Examples);
    - ``"isotropic"``: :math:`I = 1 / (2\\pi)` (validation);
    - ``"garstang_lobe"``: :math:`I = c\\,\\theta^4 / (2\\pi)`, theta in radians, the
      low-angle term of Garstang's (1986) emission function, with
      :math:`c = 1 / \\int_0^{\\pi/2} \\theta^4 \\sin\\theta\\,d\\theta = 0.5543`
      (:data:`GARSTANG_LOBE_NORM`; Garstang's 0.554). Garstang's full function,
      :math:`(2 G (1 - F) \\cos\\theta + 0.554 F \\theta^4) / (2\\pi)` per lumen of the
      city's output, is the mix of ``"lambertian"`` and this lobe of
      :func:`garstang_weights`.

    Nothing is emitted below the horizontal (cos theta <= 0).

    Parameters
    ----------
    cos_zenith
        Cosine of the angle between the emission direction and the local vertical [1].
    model
        A registered shape (:func:`emission_shape_names`: the built-in
        :data:`EMISSION_MODELS` and any added by :func:`register_emission_shape`), or a
        tabulated function ``tabulated:<json>`` (:func:`parse_tabulated_emission`,
        :func:`tabulated_emission_intensity`).
    uplight_exponent
        Exponent n of the uplight lobe [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1].

    References
    ----------
    .. [1] Normalisation of the sin^n lobe: 2 pi int_0^1 (1 - mu^2)^(n/2) dmu = pi B(1/2, n/2 + 1).
    .. [2] Garstang, R. H. 1986, "Model for artificial night-sky illumination", PASP 98, 364-375,
       the upward emission function (reconstructed from its published form; the normalisation is
       checked in the Examples).

    Examples
    --------
    Every model puts 1 lm into the upper hemisphere; Garstang's c is 0.554:

    >>> from scipy.integrate import quad
    >>> flux = lambda m: 2 * np.pi * quad(lambda mu: float(emission_intensity(mu, m)), 0, 1)[0]
    >>> [round(flux(m), 9) for m in EMISSION_MODELS]
    [1.0, 1.0, 1.0, 1.0]
    >>> round(GARSTANG_LOBE_NORM, 4)
    0.5543

    Half the flux of the sin^4 lobe leaves within 16 deg of the horizon (emission angles
    74-90 deg from the vertical):

    >>> edge = np.sin(np.radians(16.3))
    >>> near = quad(lambda mu: float(emission_intensity(mu, "uplight")), 0, edge)[0]
    >>> round(2 * np.pi * near, 2)
    0.5
    """
    mu = np.asarray(cos_zenith, dtype=float)
    return emission_shape(model).intensity(mu, uplight_exponent)


@functools.lru_cache(maxsize=64)
def parse_tabulated_emission(text: str) -> tuple[str, FloatArray, FloatArray]:
    """The angles and relative intensities of a tabulated emission function.

    Parameters
    ----------
    text
        ``tabulated:{"angles": [...], "intensities": [...]}``: emission angles from the local
        vertical, increasing from 0 (straight up) to 90 (horizontal) [deg], and the relative
        intensity at each (>= 0, not all 0) [1].

    Returns
    -------
    canonical : str
        The text in canonical form (compact JSON, floats).
    angles : numpy.ndarray
        [deg], read-only.
    intensities : numpy.ndarray
        As given (not normalised) [1], read-only.

    Raises
    ------
    InputError
        Not of that form.

    Examples
    --------
    >>> parse_tabulated_emission('tabulated:{"angles": [0, 90], "intensities": [1, 1]}')[0]
    'tabulated:{"angles":[0.0,90.0],"intensities":[1.0,1.0]}'
    """
    body = text[len(TABULATED_PREFIX) :] if text.startswith(TABULATED_PREFIX) else None
    try:
        table: Any = json.loads(body) if body is not None else None
        angles: FloatArray = np.array(table["angles"], dtype=np.float64)
        intensities: FloatArray = np.array(table["intensities"], dtype=np.float64)
    except (ValueError, TypeError, KeyError):
        raise InputError(
            f'emission function {text[:80]!r}; expected tabulated:{{"angles": [deg, 0 to 90], '
            '"intensities": [relative, one per angle]}'
        ) from None
    _check_table(angles, intensities)
    canonical = TABULATED_PREFIX + json.dumps(
        {"angles": angles.tolist(), "intensities": intensities.tolist()}, separators=(",", ":")
    )
    angles.flags.writeable = False
    intensities.flags.writeable = False
    return canonical, angles, intensities


def _check_table(angles: FloatArray, intensities: FloatArray) -> None:
    """Refuse a table that is not >= 2 increasing angles from 0 to 90 deg with finite
    intensities >= 0, not all 0."""
    fine = (
        angles.ndim == 1
        and angles.shape == intensities.shape
        and angles.size >= 2
        and bool(np.all(np.isfinite(angles)) and np.all(np.isfinite(intensities)))
    )
    if not fine or angles[0] != 0.0 or angles[-1] != 90.0 or np.any(np.diff(angles) <= 0):
        raise InputError(
            f"tabulated emission angles {angles.tolist()!r}; expected >= 2 increasing angles "
            "from 0 to 90 deg, one finite intensity each"
        )
    if np.any(intensities < 0) or not np.any(intensities > 0):
        raise InputError(
            f"tabulated emission intensities {intensities.tolist()!r}; expected >= 0, not all 0"
        )


def tabulated_emission_intensity(
    cos_zenith: ArrayLike, angles: ArrayLike, intensities: ArrayLike
) -> FloatArray:
    """Intensity per lumen of upward flux of a tabulated emission function.

    The relative intensity t(theta) is interpolated linearly in the emission angle theta
    between the tabulated angles and scaled to 1 lm into the upper hemisphere,

    .. math::
        I(\\theta) = \\frac{t(\\theta)}{2\\pi \\int_0^{\\pi/2} t(\\theta)
        \\sin\\theta \\, d\\theta},

    the integral exact for the piecewise-linear t: on a segment [a, b] with slope m,
    t_a (cos a - cos b) + m (sin b - sin a - (b - a) cos b).

    Parameters
    ----------
    cos_zenith
        Cosine of the emission direction's angle from the local vertical [1].
    angles
        Tabulated angles from the vertical, 0 to 90, increasing [deg].
    intensities
        Relative intensities at ``angles`` [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1]; 0 below the horizontal.

    Examples
    --------
    A table of cos theta at 1 deg steps is the Lambertian shape, 1 / pi straight up (to
    3e-5, the linear interpolation):

    >>> deg = np.arange(91.0)
    >>> round(float(tabulated_emission_intensity(1.0, deg, np.cos(np.radians(deg)))) * np.pi, 4)
    1.0
    """
    mu = np.asarray(cos_zenith, dtype=float)
    theta = np.degrees(np.arccos(np.clip(mu, 0.0, 1.0)))
    value = np.interp(theta, np.asarray(angles, dtype=float), np.asarray(intensities, dtype=float))
    return np.where(mu > 0, value, 0.0) * tabulated_norm(angles, intensities)


def tabulated_norm(angles: ArrayLike, intensities: ArrayLike) -> float:
    """1 / (2 pi int_0^{pi/2} t(theta) sin theta dtheta) for a piecewise-linear t(theta)
    [cd lm-1 per unit of t] (see :func:`tabulated_emission_intensity`)."""
    a = np.radians(np.asarray(angles, dtype=float))
    t = np.asarray(intensities, dtype=float)
    lo, hi = a[:-1], a[1:]
    slope = np.diff(t) / (hi - lo)
    piece = t[:-1] * (np.cos(lo) - np.cos(hi)) + slope * (
        np.sin(hi) - np.sin(lo) - (hi - lo) * np.cos(hi)
    )
    return 1.0 / (2.0 * math.pi * float(np.sum(piece)))


def garstang_weights(upward_fraction: float, reflectance: float) -> dict[str, float]:
    """Garstang's (1986) emission function as a mix of unit-flux shapes.

    Garstang's intensity per lumen of a city's output,
    :math:`I = (2 G (1 - F) \\cos\\psi + 0.554 F \\psi^4) / (2\\pi)`, sends
    G (1 - F) + F lumens upwards: F directly (the low-angle lobe) and G (1 - F) by reflection
    of the downward flux (Lambertian). Per lumen of upward flux it is

    .. math::
        I = w_L \\frac{\\cos\\psi}{\\pi} + (1 - w_L) \\frac{c \\psi^4}{2\\pi},
        \\quad w_L = \\frac{G (1 - F)}{G (1 - F) + F}.

    Parameters
    ----------
    upward_fraction
        F, the fraction of the luminaires' flux emitted directly upwards, in [0, 1] [1].
    reflectance
        G, the ground's reflectance (albedo) for the downward flux, in [0, 1] [1].

    Returns
    -------
    dict
        Weights of ``"lambertian"`` and ``"garstang_lobe"``, summing to 1 [1].

    References
    ----------
    .. [1] Garstang, R. H. 1986, PASP 98, 364-375 (the upward emission function).

    Examples
    --------
    >>> {k: round(v, 3) for k, v in garstang_weights(0.15, 0.15).items()}
    {'lambertian': 0.459, 'garstang_lobe': 0.541}
    """
    f, g = float(upward_fraction), float(reflectance)
    if not (0.0 <= f <= 1.0 and 0.0 <= g <= 1.0) or g * (1.0 - f) + f <= 0.0:
        raise InputError(
            f"Garstang F={upward_fraction!r}, G={reflectance!r}; expected both in [0, 1] and "
            "some upward flux (F > 0 or G > 0)"
        )
    reflected = g * (1.0 - f)
    lambertian = reflected / (reflected + f)
    return {"lambertian": lambertian, "garstang_lobe": 1.0 - lambertian}


# --- the compiled forms and the registry of shapes ---------------------------------------------


def form_intensity(
    code: int,
    cos_zenith: ArrayLike,
    *,
    exponent: float = UPLIGHT_EXPONENT,
    angles: ArrayLike = (),
    intensities: ArrayLike = (),
) -> FloatArray:
    """The numpy reference of a compiled form: intensity per lumen of upward flux.

    Parameters
    ----------
    code
        One of :data:`COMPILED_FORMS`.
    cos_zenith
        Cosine of the emission direction's angle theta from the local vertical [1].
    exponent
        n of :data:`SINE_POWER_FORM` [1].
    angles, intensities
        The table of :data:`TABLE_FORM`: angles from the vertical, 0 to 90 [deg], and the
        relative intensity at each [1].

    Returns
    -------
    numpy.ndarray
        Intensity [cd lm-1]; 0 below the horizontal (cos theta <= 0).

    Examples
    --------
    >>> round(float(form_intensity(COSINE_FORM, 1.0)) * np.pi, 6)
    1.0
    """
    mu = np.asarray(cos_zenith, dtype=float)
    up = mu > 0
    if code == COSINE_FORM:
        return np.where(up, mu, 0.0) / math.pi
    if code == SINE_POWER_FORM:
        norm = math.pi * float(beta_function(0.5, exponent / 2.0 + 1.0))
        sin2 = np.clip(1.0 - mu * mu, 0.0, 1.0)
        return np.where(up, sin2 ** (exponent / 2.0), 0.0) / norm
    if code == ISOTROPIC_FORM:
        return np.where(up, 1.0 / (2.0 * math.pi), 0.0)
    if code == PSI4_LOBE_FORM:
        psi = np.arccos(np.clip(mu, 0.0, 1.0))
        return np.where(up, GARSTANG_LOBE_NORM * psi**4, 0.0) / (2.0 * math.pi)
    if code == TABLE_FORM:
        return tabulated_emission_intensity(mu, angles, intensities)
    raise InputError(f"compiled form {code!r}; expected one of {sorted(COMPILED_FORMS.values())}")


#: Intensity function of a shape: (cosine of the emission angle [1], the kernel's uplight
#: exponent [1]) -> intensity [cd lm-1], 0 where the cosine is <= 0.
IntensityFunction = Callable[[FloatArray, float], FloatArray]


@dataclass(frozen=True)
class EmissionShape:
    """One row of the registry of emission shapes.

    Attributes
    ----------
    name
        The shape's name: what band tags, kernel options and ``emission=`` arguments say.
    code
        The compiled form both compiled integrators evaluate it with (:data:`COMPILED_FORMS`).
    table
        Stem of its kernel variables: ``""`` for ``kernel``/``coefficient``, else
        ``kernel_<table>``/``coefficient_<table>``; None: no kernel table (validation only).
    doc
        One line on what the shape models (units and source).
    intensity
        The numpy intensity function (:data:`IntensityFunction`), the reference the compiled
        form is tested against.
    exponent
        n of a :data:`SINE_POWER_FORM` shape; None: the kernel's ``uplight_exponent`` [1].
    angles, intensities
        The table of a :data:`TABLE_FORM` shape: angles from the vertical, 0 to 90 [deg],
        and relative intensities [1].
    band_tag
        Whether an emission band's ``emission_function`` tag may name the shape alone.
    """

    name: str
    code: int
    table: str | None
    doc: str
    intensity: IntensityFunction = field(compare=False, repr=False)
    exponent: float | None = None
    angles: tuple[float, ...] = ()
    intensities: tuple[float, ...] = ()
    band_tag: bool = True

    @property
    def table_names(self) -> tuple[str, str] | None:
        """The (image, coefficient) variables of the shape in a kernel; None without a table."""
        if self.table is None:
            return None
        if not self.table:
            return ("kernel", "coefficient")
        return (f"kernel_{self.table}", f"coefficient_{self.table}")

    @property
    def sampled(self) -> bool:
        """Whether the multiple-scattering Monte Carlo samples the shape."""
        return self.code in SAMPLED_FORMS

    def sine_exponent(self, uplight_exponent: float) -> float:
        """n of the sine-power form: the shape's own, else the kernel's [1]."""
        return uplight_exponent if self.exponent is None else self.exponent

    def compiled_table(self) -> FloatArray:
        """Shape (2, m): the table's angles [rad] and normalised intensities [cd lm-1], read
        by the compiled table form; a (2, 2) dummy for the other forms."""
        if self.code != TABLE_FORM:
            return np.zeros((2, 2))
        angles = np.asarray(self.angles, dtype=np.float64)
        intensities = np.asarray(self.intensities, dtype=np.float64)
        norm = tabulated_norm(angles, intensities)
        return np.ascontiguousarray(np.stack([np.radians(angles), intensities * norm]))

    def parameters(self) -> dict[str, Any]:
        """What fixes the compiled numbers (hashed into a kernel's cache key)."""
        return {
            "code": self.code,
            "exponent": self.exponent,
            "angles": list(self.angles),
            "intensities": list(self.intensities),
        }


_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
#: Names of the tag forms with an argument (``garstang:F,G``, ``tabulated:<json>``).
_RESERVED = ("garstang", "tabulated")
_SHAPES: dict[str, EmissionShape] = {}


def register_emission_shape(
    name: str,
    *,
    code: int,
    doc: str,
    table: str | None = None,
    intensity: IntensityFunction | None = None,
    exponent: float | None = None,
    angles: ArrayLike | None = None,
    intensities: ArrayLike | None = None,
    band_tag: bool = True,
    replace: bool = False,
) -> EmissionShape:
    """Add an emission shape to the registry: the one call a new shape on a compiled form needs.

    The shape then works wherever a shape name does: ``emission=`` of
    :func:`~nightlights.sky.kernel.sky_luminance` (numpy and numba), the band tag
    ``emission_function`` (when ``band_tag``), a kernel's ``emission_shapes`` and, for the
    forms in :data:`SAMPLED_FORMS`, the multiple-scattering Monte Carlo.

    Parameters
    ----------
    name
        Lower-case identifier (letters, digits, ``_``), not ``garstang`` or ``tabulated``.
    code
        Compiled form (:data:`COMPILED_FORMS`).
    doc
        One line on what the shape models.
    table
        Stem of its kernel variables; default the name.
    intensity
        numpy intensity function (:data:`IntensityFunction`); default the form's reference,
        :func:`form_intensity` with ``exponent`` or the table. Give one only for a form added
        to the compiled integrators.
    exponent
        n of a :data:`SINE_POWER_FORM` shape; None: the kernel's ``uplight_exponent`` [1].
    angles, intensities
        The table of a :data:`TABLE_FORM` shape: angles from the vertical, increasing from 0
        to 90 [deg], and the relative intensity at each (>= 0, not all 0) [1].
    band_tag
        Whether a band's ``emission_function`` tag may name the shape alone.
    replace
        Replace a registered shape of that name (never a built-in one).

    Returns
    -------
    EmissionShape
        The registered row.

    Raises
    ------
    InputError
        A bad name, form, exponent or table; a name or table stem already taken.

    Examples
    --------
    A sin^2 lobe is the sine-power form with its own exponent; it puts 1 lm into the upper
    hemisphere and equals the uplight lobe of exponent 2:

    >>> from scipy.integrate import quad
    >>> shape = register_emission_shape("sin2_lobe", code=SINE_POWER_FORM, exponent=2.0,
    ...                                 doc="sin^2 lobe about the vertical")
    >>> round(2 * np.pi * quad(lambda mu: float(emission_intensity(mu, "sin2_lobe")), 0, 1)[0], 9)
    1.0
    >>> lobe = emission_intensity(0.5, "sin2_lobe")
    >>> bool(lobe == emission_intensity(0.5, "uplight", uplight_exponent=2.0))
    True
    >>> unregister_emission_shape("sin2_lobe")
    """
    if not (isinstance(name, str) and _NAME.match(name)) or name in _RESERVED:
        raise InputError(
            f"emission shape name {name!r}; expected a lower-case identifier (letters, digits, "
            f"_) other than {' or '.join(_RESERVED)}"
        )
    if name in _SHAPES and (not replace or name in EMISSION_MODELS):
        why = "a built-in shape" if name in EMISSION_MODELS else "registered (replace=True)"
        raise InputError(f"emission shape {name!r} is already {why}")
    if code not in COMPILED_FORMS.values():
        raise InputError(
            f"emission shape {name!r}: compiled form {code!r}; expected one of "
            f"{COMPILED_FORMS} (a new form needs branches in both compiled integrators)"
        )
    stem = name if table is None and name not in EMISSION_MODELS else table
    taken = {s.table: s.name for s in _SHAPES.values() if s.name != name and s.table is not None}
    if stem is not None and (stem in taken or stem == "tabulated" or not _NAME.match(stem or "a")):
        raise InputError(
            f"emission shape {name!r}: kernel table {stem!r}; expected an identifier not taken "
            f"(taken: {', '.join(sorted(taken)) or 'none'}, tabulated)"
        )
    if exponent is not None and not (math.isfinite(exponent) and exponent >= 0):
        raise InputError(f"emission shape {name!r}: exponent {exponent!r}; expected >= 0")
    table_angles: tuple[float, ...] = ()
    table_values: tuple[float, ...] = ()
    if code == TABLE_FORM:
        a = np.asarray(angles if angles is not None else (), dtype=np.float64)
        t = np.asarray(intensities if intensities is not None else (), dtype=np.float64)
        _check_table(a, t)
        table_angles, table_values = tuple(a.tolist()), tuple(t.tolist())
    if intensity is None:
        intensity = functools.partial(_form_reference, code, exponent, table_angles, table_values)
    shape = EmissionShape(
        name, code, stem, doc, intensity, exponent, table_angles, table_values, bool(band_tag)
    )
    _SHAPES[name] = shape
    return shape


def _form_reference(
    code: int,
    exponent: float | None,
    angles: tuple[float, ...],
    intensities: tuple[float, ...],
    cos_zenith: FloatArray,
    uplight_exponent: float,
) -> FloatArray:
    """:func:`form_intensity` with a shape's parameters (the default intensity function)."""
    n = uplight_exponent if exponent is None else exponent
    return form_intensity(code, cos_zenith, exponent=n, angles=angles, intensities=intensities)


def unregister_emission_shape(name: str) -> None:
    """Remove a shape added by :func:`register_emission_shape` (never a built-in one).

    Parameters
    ----------
    name
        The shape's name.

    Raises
    ------
    InputError
        A built-in or unknown shape.
    """
    if name in EMISSION_MODELS or name not in _SHAPES:
        what = "a built-in shape" if name in EMISSION_MODELS else "not registered"
        raise InputError(f"emission shape {name!r} is {what}; cannot unregister it")
    del _SHAPES[name]


def emission_shape_names() -> tuple[str, ...]:
    """Names of the registered shapes, built-in first, in registration order."""
    return tuple(_SHAPES)


@functools.lru_cache(maxsize=64)
def _tabulated_shape(text: str) -> EmissionShape:
    canonical, angles, intensities = parse_tabulated_emission(text)
    a, t = tuple(angles.tolist()), tuple(intensities.tolist())
    reference = functools.partial(_form_reference, TABLE_FORM, None, a, t)
    doc = "tabulated function, interpolated linearly in the emission angle"
    return EmissionShape(canonical, TABLE_FORM, "tabulated", doc, reference, None, a, t)


def emission_shape(name: str) -> EmissionShape:
    """The registry row of a shape name, or of a tabulated function's text.

    Parameters
    ----------
    name
        A registered name (:func:`emission_shape_names`) or ``tabulated:<json>``
        (:func:`parse_tabulated_emission`: a :data:`TABLE_FORM` shape of kernel table
        ``tabulated``, named by its canonical text).

    Returns
    -------
    EmissionShape
        The row.

    Raises
    ------
    InputError
        An unknown name, or a tabulated text of a bad form.

    Examples
    --------
    >>> emission_shape("uplight").code == SINE_POWER_FORM, emission_shape("uplight").table_names
    (True, ('kernel_uplight', 'coefficient_uplight'))
    """
    shape = _SHAPES.get(name) if isinstance(name, str) else None
    if shape is not None:
        return shape
    if isinstance(name, str) and name.startswith(TABULATED_PREFIX):
        return _tabulated_shape(name)
    raise InputError(
        f"emission model {name!r}; expected one of {emission_shape_names()} or "
        f"{TABULATED_PREFIX}<json>"
    )


def sampled_shape(name: str) -> EmissionShape:
    """The row of a shape the multiple-scattering Monte Carlo samples (:data:`SAMPLED_FORMS`).

    Parameters
    ----------
    name
        A registered shape name.

    Returns
    -------
    EmissionShape
        The row.

    Raises
    ------
    InputError
        A shape of another form, or an unknown name.
    """
    sampled = tuple(n for n, s in _SHAPES.items() if s.sampled)
    shape = _SHAPES.get(name) if isinstance(name, str) else None
    if shape is None or not shape.sampled:
        raise InputError(f"emission shape {name!r}; the Monte Carlo samples {', '.join(sampled)}")
    return shape


def kernel_table_names() -> dict[str, tuple[str, str]]:
    """The (image, coefficient) variables of every shape a kernel can tabulate.

    Returns
    -------
    dict
        Shape name -> (image, coefficient), in table order: the built-in shapes, then
        ``tabulated`` (the function in the kernel attribute ``tabulated_emission``), then the
        registered shapes.

    Examples
    --------
    >>> list(kernel_table_names())
    ['lambertian', 'uplight', 'garstang_lobe', 'tabulated']
    """
    names: dict[str, tuple[str, str]] = {}
    for shape in _SHAPES.values():
        if shape.name in EMISSION_MODELS and shape.table_names is not None:
            names[shape.name] = shape.table_names
    names["tabulated"] = ("kernel_tabulated", "coefficient_tabulated")
    for shape in _SHAPES.values():
        if shape.name not in EMISSION_MODELS and shape.table_names is not None:
            names[shape.name] = shape.table_names
    return names


register_emission_shape(
    "lambertian",
    code=COSINE_FORM,
    table="",
    doc="Lambertian reflection by the ground, I = cos(theta) / pi [cd lm-1]",
)
register_emission_shape(
    "uplight",
    code=SINE_POWER_FORM,
    table="uplight",
    doc="direct uplight of luminaires, I = sin^n(theta) / (pi B(1/2, n/2 + 1)), n the "
    "kernel's uplight_exponent [cd lm-1]",
)
register_emission_shape(
    "isotropic",
    code=ISOTROPIC_FORM,
    table=None,
    band_tag=False,
    doc="isotropic emitter, I = 1 / (2 pi) (validation) [cd lm-1]",
)
register_emission_shape(
    "garstang_lobe",
    code=PSI4_LOBE_FORM,
    table="garstang_lobe",
    band_tag=False,
    doc="low-angle term of Garstang's (1986) emission function, I = c theta^4 / (2 pi) [cd lm-1]",
)


#: Band tag naming an emission band's angular function (:meth:`EmissionFunction.parse`).
EMISSION_FUNCTION_TAG = "emission_function"

#: Emission function of a single-band raster without the tag (a satellite night-lights
#: raster, any user raster): Garstang's (1986) function with F = G = 0.15 [1].
DEFAULT_EMISSION_FUNCTION = "garstang:0.15,0.15"


@dataclass(frozen=True)
class EmissionFunction:
    """The angular emission function of one emission band, as a mix of kernel shapes.

    Skyglow is linear in the emission function, so a band whose function is a weighted sum
    of the unit-flux shapes a kernel tabulates (:func:`emission_intensity`) reads the same
    weighted sum of their coefficient tables.

    Attributes
    ----------
    tag
        Canonical text of the band tag ``emission_function``: ``lambertian``, ``uplight``,
        ``garstang:F,G`` or ``tabulated:<json>``.
    weights
        ``(shape, weight)`` pairs: kernel shapes (``lambertian``, ``uplight``,
        ``garstang_lobe``, or the canonical text of a tabulated function, which has its own
        kernel table) and their weights per lumen of the band's upward flux [1].

    Examples
    --------
    >>> f = EmissionFunction.parse("garstang:0.15,0.15")
    >>> f.tag, [(shape, round(w, 3)) for shape, w in f.weights]
    ('garstang:0.15,0.15', [('lambertian', 0.459), ('garstang_lobe', 0.541)])
    >>> EmissionFunction.parse("lambertian").shapes
    ('lambertian',)
    """

    tag: str
    weights: tuple[tuple[str, float], ...]

    @property
    def shapes(self) -> tuple[str, ...]:
        """The kernel shapes the function reads (weight > 0)."""
        return tuple(shape for shape, weight in self.weights if weight > 0)

    def intensity(self, cos_zenith: ArrayLike) -> FloatArray:
        """Intensity per lumen of upward flux: the weighted shapes of
        :func:`emission_intensity`.

        Parameters
        ----------
        cos_zenith
            Cosine of the emission direction's angle from the local vertical [1].

        Returns
        -------
        numpy.ndarray
            Intensity [cd lm-1].

        Examples
        --------
        >>> f = EmissionFunction.parse("garstang:0.15,0.15")
        >>> round(float(f.intensity(1.0)) * np.pi, 3)  # straight up: the Lambertian part
        0.459
        """
        mu = np.asarray(cos_zenith, dtype=float)
        total = np.zeros(mu.shape)
        for shape, weight in self.weights:
            if weight > 0:
                total = total + weight * emission_intensity(mu, shape)
        return total

    @classmethod
    def parse(cls, text: str, *, source: str = "emission_function") -> EmissionFunction:
        """The function a band tag names.

        Parameters
        ----------
        text
            ``lambertian``, ``uplight`` (or another registered shape whose ``band_tag`` is
            set: :func:`register_emission_shape`),
            ``garstang:F,G`` (F the luminaires' direct
            upward fraction, G the ground reflectance, both in [0, 1]) or
            ``tabulated:{"angles": [...], "intensities": [...]}`` (angles from the vertical,
            0 to 90 [deg], relative intensities;
            :func:`parse_tabulated_emission`).
        source
            Where the text came from, for messages.

        Returns
        -------
        EmissionFunction
            The function.

        Raises
        ------
        InputError
            Text of no known form.
        """
        if str(text).strip().startswith(TABULATED_PREFIX):
            try:
                canonical = parse_tabulated_emission(str(text).strip())[0]
            except InputError as exc:
                raise InputError(f"{source}: {exc}") from None
            return cls(canonical, ((canonical, 1.0),))
        name, _, argument = str(text).strip().partition(":")
        name = name.strip().lower()
        if name in _tag_shapes() and not argument:
            return cls(name, ((name, 1.0),))
        if name == "garstang":
            try:
                f, g = (float(x) for x in argument.split(","))
            except ValueError:
                raise InputError(
                    f"{source} {text!r}; expected garstang:F,G with two numbers"
                ) from None
            try:
                weights = garstang_weights(f, g)
            except InputError as exc:
                raise InputError(f"{source} {text!r}: {exc}") from None
            return cls(f"garstang:{f:g},{g:g}", tuple(weights.items()))
        raise InputError(
            f"{source} {text!r}; expected {', '.join(_tag_shapes())}, garstang:F,G or "
            "tabulated:<json>"
        )


def _tag_shapes() -> tuple[str, ...]:
    """The registered shapes a band tag may name alone (``lambertian``, ``uplight``, ...)."""
    return tuple(name for name in emission_shape_names() if emission_shape(name).band_tag)
