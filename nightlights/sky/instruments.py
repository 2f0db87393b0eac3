"""Sky-brightness instruments: their angular and spectral responses, and what they read.

An instrument pointing at (elevation e_p, azimuth a_p) reads the sky luminance L weighted by its
angular response R(theta), theta the angle off its axis, over the upper hemisphere:

.. math::

    L_\\mathrm{read} = \\frac{\\int R(\\theta) L\\, d\\Omega}{\\int R(\\theta)\\, d\\Omega},
    \\qquad \\cos\\theta = \\sin e \\sin e_p + \\cos e \\cos e_p \\cos(a - a_p).

On a panorama grid the integral becomes a weighted sum (:func:`angular_weights`): each pixel's
weight is the response integrated over the pixel's solid angle (bounded by the midpoints
between elevation centres, 0 and 90 deg at the ends, and the uniform azimuth columns),
normalised to sum to 1, so a uniform sky is read exactly and a narrow response on a coarse
grid still integrates correctly. The response of every instrument is modelled as a Gaussian
in the off-axis angle with the instrument's full width at half maximum, zero behind the
instrument (theta > 90 deg):

.. math:: R(\\theta) = 2^{-(2\\theta / \\mathrm{FWHM})^2}.

Sources of the angular widths: the lensed SQM-L / -LE / -LU, about 20 deg FWHM, as the
manufacturer declares it [2, 5]; the wide-angle SQM, about 84 deg FWHM (42 deg HWHM) [1, 2],
which Cinzano measured on a rotation table [1]; the TESS-W, about 17 deg FWHM [3]. The
Gaussian is a model for all of them: Cinzano's measured SQM response is reported to fall
faster in the wings than a Gaussian of the same FWHM (a secondary account of [1] gives a
factor-10 attenuation near 55 deg, where the Gaussian still gives 0.30), so the Gaussian
over-weights the SQM's low sky; lensed units measured in the laboratory showed wider
responses than declared, with double peaks [5]. A file that states another FOV gives its
instrument :meth:`Instrument.with_fwhm`.

The spectral side: an instrument reports a magnitude in its own band. For light of spectral
power distribution S the colour term (:func:`colour_term`) is the synthetic-photometry
difference between the instrument's magnitude and Johnson V, as Cinzano (2005) relates the
SQM to Johnson V,

.. math::

    m_X - V = -2.5 \\log_{10}
        \\frac{\\int S R_X\\, d\\lambda / \\int S_0 R_X\\, d\\lambda}
              {\\int S R_V\\, d\\lambda / \\int S_0 R_V\\, d\\lambda},

energy-weighted over :data:`ies.spectra.WAVELENGTHS` (360-950 nm), with R_V the Johnson V
passband of Bessell (1990, Table 2; sensor ``"johnson_v"``) and S_0 the spectrum at which the
instrument's zero point makes m_X = V: Vega, approximated by a blackbody at Vega's effective
temperature (:data:`ZERO_POINT_SPECTRUM`; Unihedron's manuals give Vega as the reference of
the SQM's magnitudes). The responses R_X are the sensors ``"sqm"`` and ``"tess_w"`` of
:mod:`ies.spectra`, **reconstructions from the published components** (a TSL237 photodiode
behind a HOYA CM-500 glass, or behind a 740 nm dichroic; see
``ies/data/build_photometer_response.py``), not measured curves; the eye uses the CIE 1924
photopic V(lambda) (sensor ``"photopic"``), so its colour term is photopic minus Johnson V.
Cinzano's (2005) and Sánchez de Miguel et al.'s (2017) tables of SQM - V could not be read
for this module, so the colour terms are not validated against them: treat them as uncertain
by a few tenths of a magnitude (see the tests). :func:`instrument_luminance` converts the
luminance of light of a spectrum into the V-equivalent luminance that the instrument's
magnitude stands for, and :func:`instrument_magnitude` sums several spectra.

Length: one registry (:data:`INSTRUMENTS`) ties each instrument's angular response to its band;
the two halves share it and are read together.

References
----------
1. Cinzano, P. (2005). Night sky photometry with Sky Quality Meter. ISTIL Internal Report 9,
   v1.4: the SQM (TAOS TSL237 behind a HOYA CM-500 filter), its measured angular sensitivity
   and its synthetic photometry against Johnson B and V and the CIE photopic and scotopic
   responses.
2. Unihedron. Sky Quality Meter operator's manuals (SQM-L, SQM-LE, SQM-LU): a lensed field of
   about 20 deg FWHM (10 deg HWHM); the wide-angle SQM about 84 deg FWHM; Vega as the
   reference point of the magnitudes.
3. Zamorano, J. et al. (2016). Testing sky brightness models against radial dependency: a dense
   two dimensional survey around the city of Madrid. J. Quant. Spectrosc. Radiat. Transf. 181,
   52-66: the TESS photometer (TSL237 behind a dichroic filter), about 17 deg FWHM.
4. Sánchez de Miguel, A. et al. (2017). Sky Quality Meter measurements in a colour changing
   world. MNRAS 467, 2966-2979.
5. Verification of angular response of Sky Quality Meter with quasi-punctual light sources.
   Sensors 21(22), 7544 (2021): the manufacturer's declared 20 deg FWHM for the SQM-LE and
   measured responses wider than declared.
6. Bessell, M. S. (1990). UBVRI passbands. PASP 102, 1181-1199, Table 2.
7. Castelli, F. & Kurucz, R. L. (1994). Model atmospheres for Vega. A&A 281, 817-832
   (T_eff = 9550 K).
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import DataQualityWarning, InputError

__all__ = [
    "INSTRUMENTS",
    "LUMINANCE_BANDS",
    "Instrument",
    "angular_weights",
    "colour_term",
    "elevation_weights",
    "get_instrument",
    "instrument_luminance",
    "instrument_magnitude",
]

#: Sub-pixels per FWHM used to integrate the response over a pixel [1]: each pixel is split
#: into equal parts no wider than about FWHM / 8, each integrated by Gauss-Legendre
#: quadrature of :data:`GAUSS_NODES` nodes per dimension (the tests show the convergence).
SUBSAMPLES_PER_FWHM = 8
#: Gauss-Legendre nodes per sub-pixel and dimension [1].
GAUSS_NODES = 3
#: Most sub-samples per pixel side [1] (bounds the work for a tiny FWHM on a coarse grid).
MAX_SUBSAMPLES = 64
#: Name of the Johnson V passband in :data:`ies.spectra.SENSORS` (Bessell 1990, Table 2).
JOHNSON_V = "johnson_v"
#: Pixels at the pointing coarser than FWHM / RESOLUTION_FACTOR draw a warning [1]: the
#: luminance is then taken as uniform over a pixel as wide as the response's core.
RESOLUTION_FACTOR = 2.0


def _gaussian_response(off_axis: FloatArray, fwhm: float) -> FloatArray:
    """2^-(2 theta / FWHM)^2, zero behind the instrument (theta > 90 deg)."""
    response = np.exp2(-((2.0 * off_axis / fwhm) ** 2))
    return np.where(off_axis <= 90.0, response, 0.0)


@dataclass(frozen=True)
class Instrument:
    """A sky-brightness instrument: its angular and spectral response.

    Attributes
    ----------
    name : str
        Key in :data:`INSTRUMENTS` (``"sqm"``, ``"sqm-l"``, ``"tess-w"``, ``"eye"``).
    description : str
        What it is and where its numbers come from.
    fwhm : float
        Full width at half maximum of the angular response [deg].
    sensor : str
        Its spectral response, a name in :data:`ies.spectra.SENSORS`.
    """

    name: str
    description: str
    fwhm: float
    sensor: str

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fwhm) and 0.0 < self.fwhm <= 360.0):
            raise InputError(
                f"fwhm={self.fwhm!r} for instrument {self.name!r}; expected a full width at "
                "half maximum in (0, 360] deg"
            )

    def response(self, off_axis: ArrayLike) -> FloatArray:
        """Relative angular response, 1 on the axis.

        A Gaussian in the off-axis angle with this instrument's FWHM (module docstring), zero
        behind the instrument.

        Parameters
        ----------
        off_axis
            Angle from the instrument's axis [deg], any shape.

        Returns
        -------
        numpy.ndarray
            Response, same shape [1].

        Examples
        --------
        >>> sqm_l = get_instrument("sqm-l")
        >>> [round(float(r), 3) for r in sqm_l.response([0.0, sqm_l.fwhm / 2])]
        [1.0, 0.5]
        """
        theta = np.abs(np.asarray(off_axis, dtype=float))
        return _gaussian_response(theta, self.fwhm)

    def with_fwhm(self, fwhm: float) -> Instrument:
        """The same instrument with another angular width (a file that states its FOV).

        Parameters
        ----------
        fwhm
            Full width at half maximum of the angular response [deg].

        Returns
        -------
        Instrument
            A copy with ``fwhm`` replaced.

        Examples
        --------
        >>> get_instrument("sqm-l").with_fwhm(15.0).fwhm
        15.0
        """
        return replace(self, fwhm=float(fwhm))


#: The instruments by name. Angular widths: Unihedron's data sheets (SQM about 84 deg, the
#: lensed SQM-L / -LE / -LU about 20 deg FWHM), Zamorano et al. (2016) for the TESS-W
#: (about 17 deg FWHM). The eye's width is a modelling choice (see its description).
INSTRUMENTS: dict[str, Instrument] = {
    "sqm": Instrument(
        "sqm",
        "Unihedron Sky Quality Meter without lens (SQM): TSL237 behind a HOYA CM-500 filter; "
        "angular response about 84 deg FWHM (Unihedron; Cinzano 2005 measured it)",
        84.0,
        "sqm",
    ),
    "sqm-l": Instrument(
        "sqm-l",
        "Unihedron Sky Quality Meter with lens (SQM-L, SQM-LE, SQM-LU): the SQM's detector "
        "and filter behind a lens; angular response about 20 deg FWHM (Unihedron data sheet)",
        20.0,
        "sqm",
    ),
    "tess-w": Instrument(
        "tess-w",
        "STARS4ALL TESS-W photometer: TSL237 behind a dichroic filter cutting near 740 nm; "
        "field of view about 17 deg FWHM (Zamorano et al. 2016)",
        17.0,
        "tess_w",
    ),
    "eye": Instrument(
        "eye",
        "naked eye (Globe at Night limiting magnitudes converted to V sky brightness): "
        "photopic V(lambda); the 20 deg width is a modelling choice (the patch of sky around "
        "the chart's constellation), not a measured response",
        20.0,
        "photopic",
    ),
}


def get_instrument(name: str | Instrument) -> Instrument:
    """An instrument by name (or the instrument itself).

    Parameters
    ----------
    name
        A key of :data:`INSTRUMENTS` (case-insensitive), or an :class:`Instrument`.

    Returns
    -------
    Instrument

    Raises
    ------
    InputError
        For an unknown name; the message lists the known ones.

    Examples
    --------
    >>> get_instrument("SQM-L").fwhm
    20.0
    """
    if isinstance(name, Instrument):
        return name
    key = str(name).strip().lower()
    if key not in INSTRUMENTS:
        raise InputError(f"instrument={name!r}; expected one of {', '.join(INSTRUMENTS)}")
    return INSTRUMENTS[key]


def _elevation_bounds(elevation: FloatArray) -> FloatArray:
    """Pixel bounds of ascending centres: the midpoints, 0 and 90 deg at the ends [deg]."""
    if elevation.ndim != 1 or elevation.size == 0:
        raise InputError(
            f"elevation of shape {elevation.shape}; expected a non-empty 1-D array of pixel "
            "centres [deg]"
        )
    if not np.all(np.isfinite(elevation)) or elevation.min() < 0.0 or elevation.max() > 90.0:
        raise InputError(
            f"elevation from {elevation.min()!r} to {elevation.max()!r}; expected pixel "
            "centres within [0, 90] deg"
        )
    if np.any(np.diff(elevation) <= 0.0):
        raise InputError("elevation is not strictly ascending; expected pixel centres [deg]")
    return np.concatenate(([0.0], 0.5 * (elevation[1:] + elevation[:-1]), [90.0]))


def _ordered(elevation: ArrayLike) -> tuple[FloatArray, bool]:
    """The elevations ascending, and whether they came descending (zenith first)."""
    values = np.asarray(elevation, dtype=float)
    descending = values.ndim == 1 and values.size > 1 and bool(values[0] > values[-1])
    return (values[::-1] if descending else values), descending


def _azimuth_step(azimuth: FloatArray) -> float:
    """The uniform azimuth spacing of a full circle of columns [deg]."""
    if azimuth.ndim != 1 or azimuth.size == 0 or not np.all(np.isfinite(azimuth)):
        raise InputError(
            f"azimuth of shape {azimuth.shape}; expected a non-empty 1-D array of column "
            "centres [deg]"
        )
    step = 360.0 / azimuth.size
    if azimuth.size > 1 and not np.allclose(np.diff(azimuth), step, rtol=0.0, atol=1e-6 * step):
        raise InputError(
            f"azimuth of {azimuth.size} columns is not uniform over 360 deg; expected a step "
            f"of {step:g} deg"
        )
    return step


def _subdivisions(width: float, fwhm: float) -> int:
    return int(min(MAX_SUBSAMPLES, max(1, math.ceil(width * SUBSAMPLES_PER_FWHM / fwhm))))


def _check_resolution(
    instrument: Instrument,
    edges: FloatArray,
    azimuth_step: float,
    pointing_elevation: float,
) -> None:
    """Warn when the pixel at the pointing is coarser than FWHM / RESOLUTION_FACTOR."""
    row = int(np.clip(np.searchsorted(edges, pointing_elevation) - 1, 0, edges.size - 2))
    height = float(edges[row + 1] - edges[row])
    arc = azimuth_step * math.cos(math.radians(min(90.0, max(0.0, pointing_elevation))))
    size = max(height, arc if pointing_elevation < 90.0 - 1e-9 else 0.0)
    limit = instrument.fwhm / RESOLUTION_FACTOR
    if size > limit:
        warnings.warn(
            f"the grid's pixel at the pointing spans {size:.3g} deg, coarser than half the "
            f"{instrument.name!r} response's FWHM ({instrument.fwhm:g} deg): the luminance is "
            "taken as uniform over it; use a finer panorama for this instrument",
            DataQualityWarning,
            stacklevel=3,
        )


def _pointing(pointing: tuple[float, float]) -> tuple[float, float]:
    elevation, azimuth = (float(v) for v in pointing)
    if not (math.isfinite(elevation) and -90.0 <= elevation <= 90.0 and math.isfinite(azimuth)):
        raise InputError(
            f"pointing={pointing!r}; expected (elevation [deg] in [-90, 90], azimuth [deg])"
        )
    return elevation, azimuth


def angular_weights(
    instrument: str | Instrument,
    elevation: ArrayLike,
    azimuth: ArrayLike,
    *,
    pointing: tuple[float, float] = (90.0, 0.0),
) -> FloatArray:
    """Weights of a panorama's pixels in an instrument's reading, summing to 1.

    Each pixel's weight is the angular response integrated over its solid angle (by
    Gauss-Legendre quadrature on sub-pixels no wider than about FWHM / 8), normalised over
    the upper hemisphere, so that the reading of a panorama L is ``(weights * L).sum()`` and
    a uniform sky is read exactly. The pixel bounds are the midpoints between elevation
    centres (0 and 90 deg at the ends) and the uniform azimuth columns centred on the given
    azimuths.

    Parameters
    ----------
    instrument
        A name of :data:`INSTRUMENTS` or an :class:`Instrument`.
    elevation
        Pixel-centre elevations, ``(n_el,)``, strictly monotonic (ascending; a zenith-first
        descending grid is accepted and its weights come back in its order), within
        [0, 90] [deg]; need not be uniform.
    azimuth
        Column-centre azimuths, ``(n_az,)``, uniform over 360 deg, clockwise from north [deg].
    pointing
        (elevation, azimuth) of the instrument's axis [deg]; the zenith by default.

    Returns
    -------
    numpy.ndarray
        ``(n_el, n_az)`` weights [1], summing to 1.

    Raises
    ------
    InputError
        For a malformed grid, or a pointing whose response misses the upper hemisphere.

    Warns
    -----
    DataQualityWarning
        When the pixel at the pointing is wider than half the FWHM: the weights still sum to
        1 and integrate the response exactly, but the luminance within the response's core is
        taken as one pixel's value.

    Examples
    --------
    >>> el = np.arange(0.5, 90.0, 1.0)
    >>> az = np.arange(0.5, 360.0, 1.0)
    >>> w = angular_weights("sqm-l", el, az)
    >>> round(float(w.sum()), 12), w.shape
    (1.0, (90, 360))
    """
    device = get_instrument(instrument)
    ordered, descending = _ordered(elevation)
    edges = _elevation_bounds(ordered)
    columns = np.asarray(azimuth, dtype=float)
    step = _azimuth_step(columns)
    pointing_elevation, pointing_azimuth = _pointing(pointing)
    _check_resolution(device, edges, step, pointing_elevation)

    # sub-pixels: each elevation pixel split in m_el equal parts of sin(elevation) (equal
    # solid angle), each column in m_az; Gauss-Legendre nodes within each sub-pixel
    m_el = _subdivisions(float(np.max(np.diff(edges))), device.fwhm)
    zenith = pointing_elevation >= 90.0 - 1e-12
    m_az = 1 if zenith else _subdivisions(step, device.fwhm)
    nodes, node_weights = np.polynomial.legendre.leggauss(GAUSS_NODES)
    mu_edges = np.sin(np.radians(edges))
    mu_width = np.diff(mu_edges) / m_el  # (n_el,)
    parts = (np.arange(m_el)[:, None] + 0.5 * (nodes + 1.0)[None, :]).ravel() / m_el
    mu = mu_edges[:-1, None] + np.diff(mu_edges)[:, None] * parts  # (n_el, m_el * q)
    dmu = mu_width[:, None] * np.tile(0.5 * node_weights, m_el)[None, :]
    az_parts = (np.arange(m_az)[:, None] + 0.5 * (nodes + 1.0)[None, :]).ravel() / m_az - 0.5
    daz = np.tile(0.5 * node_weights, m_az) / m_az  # fractions of a column, sum 1
    relative = np.radians(columns[:, None] + az_parts * step - pointing_azimuth)
    sin_e = mu[:, :, None, None]
    cos_e = np.sqrt(np.clip(1.0 - sin_e**2, 0.0, None))
    p_el = math.radians(pointing_elevation)
    cos_theta = sin_e * math.sin(p_el) + cos_e * math.cos(p_el) * np.cos(relative)[None, None]
    off_axis = np.degrees(np.arccos(np.clip(cos_theta, -1.0, 1.0)))
    response = device.response(off_axis)  # (n_el, m_el * q, n_az, m_az * q)
    weights = np.einsum("iajb,ia,b->ij", response, dmu, daz)
    total = float(weights.sum())
    if not total > 0.0:
        raise InputError(
            f"pointing={pointing!r}: the {device.name!r} response (FWHM {device.fwhm:g} deg) "
            "sees none of the upper hemisphere on this grid"
        )
    weights = weights / total
    return weights[::-1] if descending else weights


def elevation_weights(instrument: str | Instrument, elevation: ArrayLike) -> FloatArray:
    """Weights of a panorama's elevation rows for a zenith-pointing instrument, summing to 1.

    :func:`angular_weights` with the default zenith pointing, summed over azimuth (the
    response of a zenith-pointing instrument does not depend on azimuth): the reading of an
    azimuth-averaged panorama is ``(weights * row_means).sum()``.

    Parameters
    ----------
    instrument
        A name of :data:`INSTRUMENTS` or an :class:`Instrument`.
    elevation
        Pixel-centre elevations, ``(n_el,)``, strictly monotonic, within [0, 90] [deg].

    Returns
    -------
    numpy.ndarray
        ``(n_el,)`` weights [1], summing to 1, in the order of ``elevation``.

    Examples
    --------
    >>> elevation = np.arange(0.5, 90.0, 1.0)
    >>> [round(float(elevation_weights(name, elevation)[elevation > 45].sum()), 2)
    ...  for name in ("sqm", "sqm-l", "tess-w")]
    [0.61, 1.0, 1.0]
    """
    return angular_weights(instrument, elevation, np.array([180.0]))[:, 0]


#: Effective temperature of Vega [K], the Castelli & Kurucz (1994) model atmosphere; its
#: blackbody stands for Vega's spectrum in the zero point (:data:`ZERO_POINT_SPECTRUM`).
VEGA_TEMPERATURE = 9550.0
#: The spectrum at which every instrument's magnitude equals V: Vega, approximated by a
#: blackbody at :data:`VEGA_TEMPERATURE`. Unihedron's SQM manuals give Vega as the reference
#: point of the SQM's magnitudes; the same convention is assumed for the TESS-W and the eye.
ZERO_POINT_SPECTRUM = "vega_blackbody"
#: The natural night sky's spectrum: sunlight, a blackbody at the Sun's nominal effective
#: temperature (IAU 2015 Resolution B3, 5772 K), as :mod:`nightlights.nightsky.background`
#: colours it (zodiacal light is scattered sunlight, integrated starlight is dominated by
#: Sun-like stars). The airglow's emission lines (O I 557.7 and 630 nm, Na 589 nm, the OH
#: bands in the red) are not modelled.
NATURAL_SKY = "natural_sky"
#: The eye's photopic response in :data:`ies.spectra.SENSORS`: the band of a luminance in
#: candela.
PHOTOPIC = "photopic"
#: Sun's nominal effective temperature [K] (IAU 2015 Resolution B3; Mamajek et al. 2015).
SUN_TEMPERATURE = 5772.0


def _planck(wavelength_nm: FloatArray, temperature: float) -> FloatArray:
    """Relative blackbody spectral radiance per unit wavelength at ``temperature`` [K]."""
    c2 = 1.438776877e7  # second radiation constant [nm K] (CODATA 2018)
    x = c2 / (wavelength_nm * temperature)
    return np.asarray(wavelength_nm**-5.0 / np.expm1(x), dtype=float)


def _source(spectrum: str) -> FloatArray:
    """A named source spectrum on :data:`ies.spectra.WAVELENGTHS` (relative power)."""
    from ies.errors import PhotometryError
    from ies.spectra import SPDS, WAVELENGTHS, get_spd

    if spectrum == NATURAL_SKY:
        return _planck(WAVELENGTHS, SUN_TEMPERATURE)
    if spectrum == ZERO_POINT_SPECTRUM:
        return _planck(WAVELENGTHS, VEGA_TEMPERATURE)
    try:
        return get_spd(spectrum).on(WAVELENGTHS)
    except PhotometryError:
        raise InputError(
            f"spectrum={spectrum!r}; expected one of {', '.join((*SPDS, NATURAL_SKY))}"
        ) from None


def _band_signal(spectrum: str, sensor: str) -> float:
    """Energy-integrated signal of a relative source spectrum in a sensor's band [1]."""
    from ies.spectra import WAVELENGTHS, get_sensor

    response = get_sensor(sensor).on(WAVELENGTHS)
    return float(np.trapezoid(_source(spectrum) * response, WAVELENGTHS))


@functools.cache
def _colour_term(sensor: str, spectrum: str) -> float:
    ratio = _band_signal(spectrum, sensor) / _band_signal(spectrum, JOHNSON_V)
    zero = _band_signal(ZERO_POINT_SPECTRUM, sensor) / _band_signal(ZERO_POINT_SPECTRUM, JOHNSON_V)
    if not (ratio > 0.0 and math.isfinite(ratio)):
        raise InputError(
            f"spectrum={spectrum!r} gives no signal in the {sensor!r} or V band; "
            "its colour term is undefined"
        )
    return -2.5 * math.log10(ratio / zero)


def colour_term(instrument: str | Instrument, spectrum: str) -> float:
    """m_instrument - V [mag] for light of a spectrum, by synthetic photometry (Cinzano 2005).

    .. math::

        m_X - V = -2.5 \\log_{10} \\frac{\\int S R_X / \\int S R_V}
                                         {\\int S_0 R_X / \\int S_0 R_V}

    with the energy-weighted integrals over :data:`ies.spectra.WAVELENGTHS`, R_X the
    instrument's sensor response, R_V Bessell's (1990) Johnson V, and S_0 the zero-point
    spectrum (Vega as a blackbody, :data:`ZERO_POINT_SPECTRUM`). Positive: the instrument
    reads the light fainter than V.

    Parameters
    ----------
    instrument
        A name of :data:`INSTRUMENTS` or an :class:`Instrument`.
    spectrum
        A name of :data:`ies.spectra.SPDS`, ``"natural_sky"`` (:data:`NATURAL_SKY`) or
        ``"vega_blackbody"`` (the zero point, whose colour term is 0 by definition).

    Returns
    -------
    float
        Colour term [mag].

    Raises
    ------
    InputError
        For an unknown spectrum.

    Examples
    --------
    >>> abs(colour_term("sqm", "vega_blackbody")) < 1e-12
    True
    >>> colour_term("sqm", "LPS") > colour_term("sqm", "LED_4000K")
    True
    """
    return _colour_term(get_instrument(instrument).sensor, str(spectrum))


#: The bands a luminance may stand in: ``"photopic"`` (candela from lumens: the modelled
#: artificial sky) or ``"V"`` (the luminance of a Johnson V surface brightness by the
#: 1.08e5 cd m-2 zero point: the natural sky's 22.0 mag arcsec-2).
LUMINANCE_BANDS = ("photopic", "V")


def instrument_luminance(
    luminance: ArrayLike,
    instrument: str | Instrument,
    spectrum: str,
    *,
    band: str | None = None,
) -> FloatArray:
    """The V-equivalent luminance an instrument's magnitude stands for: L 10^(-0.4 c).

    A photopic luminance (the model's artificial sky, candela from lumens) is carried into the
    instrument's band by ``c = (m_X - V) - (m_photopic - V)`` of its spectrum, the difference
    of the instrument's and the eye's colour terms: an instrument with the eye's photopic
    response reads a photopic luminance as it is. A luminance that stands for a V magnitude
    (the natural sky's 22.0 mag arcsec-2) takes ``c = m_X - V``.

    Parameters
    ----------
    luminance
        Luminance of light of ``spectrum`` [cd m-2], any shape.
    instrument
        A name of :data:`INSTRUMENTS` or an :class:`Instrument`.
    spectrum
        A name of :data:`ies.spectra.SPDS` or ``"natural_sky"``.
    band
        What the luminance is measured in (:data:`LUMINANCE_BANDS`); None: ``"V"`` for the
        natural sky, ``"photopic"`` for a lamp spectrum.

    Returns
    -------
    numpy.ndarray
        Luminance [cd m-2] whose :func:`~nightlights.brightness.luminance_to_magnitude` is the
        instrument's magnitude.

    Examples
    --------
    >>> float(instrument_luminance(1e-3, "eye", "HPS"))  # the eye reads photopic light as is
    0.001
    """
    if band is None:
        band = "V" if spectrum == NATURAL_SKY else "photopic"
    if band not in LUMINANCE_BANDS:
        raise InputError(f"band={band!r}; expected one of {', '.join(LUMINANCE_BANDS)}")
    term = colour_term(instrument, spectrum)
    if band == "photopic":
        term -= _colour_term(PHOTOPIC, str(spectrum))
    return np.asarray(luminance, dtype=float) * 10.0 ** (-0.4 * term)


def instrument_magnitude(
    parts: Mapping[str, ArrayLike], instrument: str | Instrument
) -> float | FloatArray:
    """What an instrument reads for light made of parts of several spectra [mag arcsec-2].

    .. math:: m_X = -2.5 \\log_{10}\\Big(\\sum_s L_s 10^{-0.4 c_s} / 1.08\\times10^5\\Big)

    with each part's colour term as :func:`instrument_luminance` takes it (a lamp's photopic
    luminance, the natural sky's V luminance).

    Parameters
    ----------
    parts
        Luminance of each part [cd m-2] (scalars or arrays of one shape), keyed by its spectrum
        (a name of :data:`ies.spectra.SPDS`, photopic, or ``"natural_sky"``, V).
    instrument
        A name of :data:`INSTRUMENTS` or an :class:`Instrument`.

    Returns
    -------
    float or numpy.ndarray
        The instrument's magnitude [mag arcsec-2]: a float when every part is a scalar.
    """
    if not parts:
        raise InputError("parts={}; expected at least one spectrum with its luminance")
    total = sum(
        (instrument_luminance(value, instrument, name) for name, value in parts.items()),
        start=np.zeros(()),
    )
    magnitude = luminance_to_magnitude(total)
    return float(magnitude) if magnitude.ndim == 0 else magnitude
