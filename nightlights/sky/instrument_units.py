"""The modelled sky in an instrument's units: what a photometer reads of the artificial skyglow.

A sky-brightness meter reads the sky through its angular response and in its own band. Over a
panorama of artificial luminance :math:`L_{ij}` (elevation rows i, azimuth columns j) the
reading is the response-weighted mean (:func:`~nightlights.sky.instruments.angular_weights`,
weights :math:`A_{ij}` summing to 1), and the V-equivalent luminance the instrument's magnitude
stands for scales it by the colour term :math:`C = m_\\mathrm{instrument} - m_\\mathrm{photopic}`
of the light's spectrum (the model's luminance is photopic;
:func:`~nightlights.sky.instruments.instrument_luminance`, synthetic photometry as in Cinzano
2005):

.. math::

    L_\\mathrm{art} = 10^{-0.4\\, C(S)} \\sum_{ij} A_{ij} L_{ij}, \\qquad
    m = -2.5 \\log_{10}\\frac{L_\\mathrm{art} + L_\\mathrm{nat}}{1.08 \\times 10^5}
    \\quad [\\mathrm{mag\\,arcsec^{-2}}],

with :math:`L_\\mathrm{nat}` the natural sky's reading in the same units. The natural sky is
taken by default as a uniform sky of :data:`~nightlights.brightness.NATURAL_ZENITH_LUMINANCE`
(22.0 mag arcsec-2 in V, a typical moonless night) with the natural sky's colour term
:math:`m_\\mathrm{instrument} - V`: a uniform
approximation (the real natural sky brightens towards the horizon by van Rhijn's law, so a
wide-field meter reads it somewhat brighter); the meter layer computes the natural sky of a
given date and time. Pixels that the terrain hides add no artificial light (the ground is
taken as dark), while the natural sky is counted over the whole response.

:func:`instrument_sky` gathers what the darkness map, the skyglow panorama and the
many-observer summary share: the instrument, the spectrum of the artificial light (given, else
the emission raster's ``spectrum`` tag, else :data:`DEFAULT_SPECTRUM`) and the natural sky.

References
----------
1. Cinzano, P. 2005, "Night sky photometry with Sky Quality Meter", ISTIL Internal Report 9
   (colour terms by synthetic photometry; m = -2.5 log10(L / 1.08e5)).
2. Garstang, R. H. 1989, "Night-sky brightness at observatories and sites", PASP 101, 306
   (the natural sky's van Rhijn brightening towards the horizon).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from ies.spectra import SPDS
from nightlights._typing import FloatArray
from nightlights.brightness import NATURAL_ZENITH_LUMINANCE, luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.io.raster import LitCells
from nightlights.sky.instruments import (
    NATURAL_SKY,
    Instrument,
    angular_weights,
    elevation_weights,
    get_instrument,
    instrument_luminance,
)

__all__ = [
    "DEFAULT_SPECTRUM",
    "NATURAL_SKY_SPECTRUM",
    "SPECTRUM_TAG",
    "InstrumentSky",
    "emission_spectrum",
    "instrument_sky",
]

#: Spectrum of the artificial light when neither ``spectrum=`` nor the emission raster's
#: ``spectrum`` tag names one: a 4000 K phosphor LED (CIE 15:2018 illuminant LED-B3). It is the
#: spectrum the toolkit already assumes wherever one is needed without being given (the VIIRS
#: conversion's default, :data:`~nightlights.ground.upward.DEFAULT_VIIRS_SPECTRUM`, and the
#: colours of the skyglow panorama), so the colour term matches the light the flux was derived
#: for; and white LEDs of 3000-4000 K are what street lighting is being converted to.
DEFAULT_SPECTRUM = "LED_4000K"
#: The spectrum name of the natural night sky for the colour term
#: (:func:`~nightlights.sky.instruments.colour_term`).
NATURAL_SKY_SPECTRUM = NATURAL_SKY
#: Dataset tag of an emission raster naming its light's spectrum (written by
#: :func:`~nightlights.ground.upward.emission_from_viirs`).
SPECTRUM_TAG = "spectrum"


@dataclass(frozen=True)
class InstrumentSky:
    """An instrument, the spectrum of the artificial light and the natural sky it reads.

    Attributes
    ----------
    instrument
        The instrument (:class:`~nightlights.sky.instruments.Instrument`).
    spectrum
        The artificial light's spectrum, a name of :data:`ies.spectra.SPDS`.
    spectrum_source
        Where the spectrum came from: ``spectrum=``, ``emission tag`` or ``default``.
    natural
        The natural sky's reading: the V-equivalent luminance the instrument's reading of it
        stands for, colour term included [cd m-2].
    natural_source
        Where the natural sky came from: ``natural_luminance=`` or the default's description.
    """

    instrument: Instrument
    spectrum: str
    spectrum_source: str
    natural: float
    natural_source: str

    def artificial(self, reading: ArrayLike) -> FloatArray:
        """The V-equivalent luminance of an angular-weighted artificial luminance [cd m-2].

        Parameters
        ----------
        reading
            Luminance weighted by the instrument's angular response [cd m-2].
        """
        return np.asarray(
            instrument_luminance(reading, self.instrument, self.spectrum), dtype=float
        )

    def magnitude(self, artificial: ArrayLike) -> FloatArray:
        """The instrument's sky brightness of artificial + natural [mag arcsec-2].

        Parameters
        ----------
        artificial
            The artificial sky's V-equivalent reading (:meth:`artificial`) [cd m-2].
        """
        return luminance_to_magnitude(np.asarray(artificial, dtype=float) + self.natural)

    def elevation_weights(self, elevation: ArrayLike) -> FloatArray:
        """The instrument's elevation weights of a kernel's rows, in their order [1].

        Parameters
        ----------
        elevation
            Pixel centres of the rows, zenith first (the kernel's order) or ascending [deg].
        """
        el = np.asarray(elevation, dtype=float)
        order = np.argsort(el, kind="stable")  # the API's grid ascends in elevation
        weights = np.empty(el.shape)
        weights[order] = elevation_weights(self.instrument, el[order])
        return weights

    def panorama_weights(
        self,
        elevation: ArrayLike,
        azimuth: ArrayLike,
        *,
        pointing: tuple[float, float] = (90.0, 0.0),
    ) -> FloatArray:
        """``(n_el, n_az)`` angular weights over a panorama's pixels, in its row order [1].

        Parameters
        ----------
        elevation
            Row pixel centres, zenith first (the panorama's order) or ascending [deg].
        azimuth
            Column pixel centres, uniform [deg].
        pointing
            Elevation and azimuth the instrument points at [deg].
        """
        el = np.asarray(elevation, dtype=float)
        order = np.argsort(el, kind="stable")
        weights = np.empty((el.size, np.size(azimuth)))
        weights[order] = angular_weights(
            self.instrument, el[order], np.asarray(azimuth, dtype=float), pointing=pointing
        )
        return weights

    def read(self, luminance: ArrayLike, weights: FloatArray) -> float:
        """The V-equivalent reading of a panorama's artificial sky [cd m-2].

        Parameters
        ----------
        luminance
            ``(n_el, n_az)`` artificial luminance, NaN where the terrain hides the sky
            (counted as dark) [cd m-2].
        weights
            The panorama's angular weights (:meth:`panorama_weights`) [1].
        """
        values = np.asarray(luminance, dtype=float)
        hidden = np.isnan(values)
        return float(self.artificial(float(np.sum(weights * np.where(hidden, 0.0, values)))))

    def summary(self, artificial: float) -> dict[str, Any]:
        """The instrument figures of a zenith summary (the panorama's attributes).

        Parameters
        ----------
        artificial
            The artificial sky's V-equivalent reading [cd m-2].

        Returns
        -------
        dict
            ``instrument``, ``instrument_spectrum``, ``instrument_luminance_cd_m2``
            (artificial), ``instrument_natural_cd_m2`` and ``instrument_sky_brightness``
            [mag arcsec-2] (artificial + natural).
        """
        return {
            **self.tags(),
            "instrument_luminance_cd_m2": float(artificial),
            "instrument_sky_brightness": float(self.magnitude(artificial)),
        }

    def tags(self) -> dict[str, Any]:
        """What the outputs record of the instrument, spectrum and natural sky."""
        return {
            "instrument": self.instrument.name,
            "instrument_fwhm_deg": float(self.instrument.fwhm),
            "instrument_spectrum": self.spectrum,
            "instrument_spectrum_source": self.spectrum_source,
            "instrument_natural_cd_m2": float(self.natural),
            "instrument_natural_source": self.natural_source,
        }


def instrument_sky(
    instrument: str | Instrument | None,
    *,
    spectrum: str | None = None,
    natural_luminance: float | None = None,
    emission: Any = None,
    label: str = "emission raster",
) -> InstrumentSky | None:
    """The instrument, the artificial light's spectrum and the natural sky of a stage call.

    Parameters
    ----------
    instrument
        A key of :data:`~nightlights.sky.instruments.INSTRUMENTS` or an
        :class:`~nightlights.sky.instruments.Instrument`; None: no instrument units.
    spectrum
        The artificial light's spectrum, a name of :data:`ies.spectra.SPDS`; None: the
        emission raster's ``spectrum`` tag (:func:`emission_spectrum`), else
        :data:`DEFAULT_SPECTRUM`.
    natural_luminance
        The natural sky's reading, V-equivalent with the instrument's natural-sky colour term
        included [cd m-2]; None: a uniform moonless sky of
        :data:`~nightlights.brightness.NATURAL_ZENITH_LUMINANCE` seen by the instrument.
    emission
        The emission input (a :class:`~nightlights.io.Raster`, a DataArray, a path or
        :class:`~nightlights.io.raster.LitCells`), for its ``spectrum`` tag.
    label
        How the emission is named in messages.

    Returns
    -------
    InstrumentSky or None
        None without an instrument.

    Raises
    ------
    InputError
        An unknown instrument or spectrum (given or tagged), or a natural luminance that is
        negative or not finite.
    """
    if instrument is None:
        return None
    chosen = get_instrument(instrument)
    if spectrum is not None:
        source = "spectrum="
        _check_spectrum(spectrum, f"spectrum={spectrum!r}:", "")
    else:
        tagged = emission_spectrum(emission)
        if tagged is not None:
            _check_spectrum(
                tagged, f"{label}: {SPECTRUM_TAG} tag {tagged!r}", "; or give spectrum="
            )
            spectrum, source = tagged, "emission tag"
        else:
            spectrum, source = DEFAULT_SPECTRUM, "default"
    if natural_luminance is None:
        natural = float(
            instrument_luminance(NATURAL_ZENITH_LUMINANCE, chosen, NATURAL_SKY_SPECTRUM, band="V")
        )
        natural_source = (
            f"uniform moonless sky of {NATURAL_ZENITH_LUMINANCE:.4g} cd m-2 (V) with the "
            "natural-sky colour term"
        )
    else:
        natural = float(natural_luminance)
        if not (math.isfinite(natural) and natural >= 0):
            raise InputError(
                f"natural_luminance={natural_luminance!r}; expected a finite luminance >= 0 "
                "[cd m-2]"
            )
        natural_source = "natural_luminance="
    return InstrumentSky(chosen, spectrum, source, natural, natural_source)


def emission_spectrum(emission: Any) -> str | None:
    """The ``spectrum`` tag of an emission input, or None where it has none.

    Parameters
    ----------
    emission
        A :class:`~nightlights.io.Raster` (its tags), a DataArray (its attributes), a path
        (the file's dataset tags) or :class:`~nightlights.io.raster.LitCells` (no tags).

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> raster = Raster(np.ones((1, 2, 2)), Affine(10, 0, 0, 0, -10, 20), "EPSG:32635",
    ...                 tags={"spectrum": "HPS"})
    >>> emission_spectrum(raster)
    'HPS'
    """
    if emission is None or isinstance(emission, LitCells):
        return None
    if isinstance(emission, Raster):
        value = emission.tags.get(SPECTRUM_TAG)
    elif isinstance(emission, xr.DataArray):
        value = emission.attrs.get(SPECTRUM_TAG)
    else:
        import rasterio

        with rasterio.open(emission) as dataset:
            value = dataset.tags().get(SPECTRUM_TAG)
    return str(value) if value else None


def _check_spectrum(name: str, what: str, hint: str) -> None:
    """Refuse a spectrum that :data:`ies.spectra.SPDS` does not hold."""
    if name not in SPDS:
        raise InputError(f"{what} not a known spectrum; expected one of {', '.join(SPDS)}{hint}")
