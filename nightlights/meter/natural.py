"""The natural sky as an instrument reads it: at a reading's time and place, or a typical night.

The moonless natural sky (:func:`~nightlights.nightsky.background.natural_sky_luminance`:
airglow brightening toward the horizon, zodiacal light, integrated starlight following the
smoothed density of the catalogue's faint stars at that instant) is evaluated on a grid of
directions and read with the instrument's angular response
(:func:`~nightlights.sky.instruments.angular_weights`) in its band (the colour term of the
natural sky's spectrum, :func:`~nightlights.sky.instruments.colour_term`):

.. math::

    N = 10^{-0.4\\, c_{\\mathrm{nat}}} \\sum_{ij} w_{ij}\\, L_{\\mathrm{nat}}(\\theta_i, \\phi_j)
    \\quad [\\mathrm{cd\\,m^{-2}}].

Without a time the integrated starlight takes its all-sky mean (a "typical moonless night":
22.0 mag arcsec-2 in V at the zenith), so the reading depends on the
instrument's field alone.

References
----------
1. Krisciunas, K. & Schaefer, B. E. 1991, PASP 103, 1033, Eq. 2 (the dark sky's van Rhijn
   brightening); Schaefer 1998 (VISLIMIT) for the 60 % airglow share, as in
   :mod:`nightlights.nightsky.background`.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from nightlights._typing import FloatArray
from nightlights.nightsky.background import (
    STARLIGHT_FAINT_LIMIT,
    STARLIGHT_SMOOTHING,
    NaturalSky,
    natural_sky_luminance,
    starlight_density,
)
from nightlights.sky.instruments import (
    NATURAL_SKY,
    Instrument,
    angular_weights,
    get_instrument,
    instrument_luminance,
)

__all__ = [
    "LATITUDE_STEP",
    "NATURAL_SPECTRUM",
    "SIDEREAL_STEP",
    "SKY_GRID_STEP",
    "STARLIGHT_GRID_STEP",
    "natural_reading",
    "natural_readings",
]

#: The spectrum whose colour term the natural sky takes (see
#: :func:`~nightlights.sky.instruments.colour_term`).
NATURAL_SPECTRUM = NATURAL_SKY
#: Spacing of the grid of directions the natural sky is read on [deg]: the narrowest field
#: (TESS-W, 17 deg FWHM) spans eight pixels across, and the natural sky varies on scales of
#: tens of degrees (the airglow's van Rhijn brightening, the Milky Way smoothed by 8 deg).
SKY_GRID_STEP = 2.0
#: Spacing of the nodes the starlight density is evaluated on [deg]: three quarters of its
#: smoothing (8 deg), a quarter of the cost of the renderer's 4 deg nodes.
STARLIGHT_GRID_STEP = 6.0
#: Many readings share one natural sky when their local sidereal times fall in one step of this
#: width [deg] (32 minutes of time) and their latitudes in one of :data:`LATITUDE_STEP`: the
#: moonless natural sky depends on the place and time only through the sidereal time and the
#: latitude (the Milky Way's position), smoothed by the starlight's 8 deg. Chosen by
#: ``benchmarks/bench_meter_natural.py``: against each reading's own sky on a 0.5 deg grid, 200
#: readings of a March night over 20-28 E, 58-64 N are within 0.0034 mag arcsec-2 (SQM-L) and
#: 0.0023 (SQM) at 8 deg, 5 times faster than at 2 deg (0.0009), far below a meter's 0.05-0.1.
SIDEREAL_STEP = 8.0
#: See :data:`SIDEREAL_STEP` [deg].
LATITUDE_STEP = 4.0


@functools.cache
def _grid() -> tuple[FloatArray, FloatArray]:
    elevation = np.arange(SKY_GRID_STEP / 2, 90.0, SKY_GRID_STEP)
    azimuth = np.arange(SKY_GRID_STEP / 2, 360.0, SKY_GRID_STEP)
    return elevation, azimuth


@functools.cache
def _faint_catalog() -> Any:
    from nightlights.nightsky.catalog import load_catalog

    stars = load_catalog()
    return stars.select(stars.vmag >= STARLIGHT_FAINT_LIMIT)


def natural_reading(
    instrument: str | Instrument,
    time: Any = None,
    lon: float | None = None,
    lat: float | None = None,
    *,
    pointing: tuple[float, float] = (90.0, 0.0),
    sky: NaturalSky | None = None,
) -> float:
    """The natural sky's reading by an instrument [cd m-2, V-equivalent in its band].

    Parameters
    ----------
    instrument
        A name of :data:`~nightlights.sky.instruments.INSTRUMENTS` or an instrument.
    time
        UTC instant (datetime, string, numpy.datetime64 or pandas Timestamp); None: a typical
        moonless night (the integrated starlight at its all-sky mean).
    lon, lat
        The station [deg], with ``time``.
    pointing
        Elevation and azimuth the instrument points at [deg].
    sky
        The natural sky's parameters (default :class:`~nightlights.nightsky.background.NaturalSky`).

    Returns
    -------
    float
        The V-equivalent luminance whose magnitude the instrument reports [cd m-2].

    Examples
    --------
    >>> from nightlights.brightness import luminance_to_magnitude
    >>> typical = natural_reading("sqm-l")
    >>> 21.0 < float(luminance_to_magnitude(typical)) < 23.0
    True
    """
    device = get_instrument(instrument)
    elevation, azimuth = _grid()
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    starlight: Any = 1.0
    if time is not None:
        if lon is None or lat is None:
            from nightlights.errors import InputError

            raise InputError("time= needs lon= and lat= (the station's position)")
        from nightlights.nightsky.astro import star_positions

        star_az, star_el = star_positions(_faint_catalog(), _utc(time), lon, lat)
        starlight = starlight_density(
            star_el,
            star_az,
            el,
            az,
            smoothing=STARLIGHT_SMOOTHING,
            grid_step=STARLIGHT_GRID_STEP,
        )
    luminance = natural_sky_luminance(el, starlight=starlight, sky=sky)["total"]
    weights = angular_weights(device, elevation, azimuth, pointing=pointing)
    reading = float(np.sum(weights * luminance))
    return float(instrument_luminance(reading, device, NATURAL_SPECTRUM, band="V"))


def natural_readings(
    instrument: str | Instrument,
    times: Any,
    lon: Any,
    lat: Any,
    *,
    pointing: tuple[float, float] = (90.0, 0.0),
    sky: NaturalSky | None = None,
) -> FloatArray:
    """The natural sky's readings at many instants and places, shared where they coincide.

    Each reading takes the sky of the centre of its cell of local sidereal time
    (:data:`SIDEREAL_STEP`) and latitude (:data:`LATITUDE_STEP`), computed once per cell by
    :func:`natural_reading`.

    Parameters
    ----------
    instrument
        A name of :data:`~nightlights.sky.instruments.INSTRUMENTS` or an instrument.
    times
        UTC instants (pandas timestamps with a zone, or numpy datetime64 in UTC).
    lon, lat
        The stations [deg], one per instant.
    pointing
        Elevation and azimuth the instrument points at [deg].
    sky
        The natural sky's parameters.

    Returns
    -------
    numpy.ndarray
        The V-equivalent luminances [cd m-2], one per instant.
    """
    from nightlights.nightsky.astro import apparent_sidereal_time, julian_date

    stamps = [_utc(t) for t in list(times)]
    lons = np.asarray(lon, dtype=float).ravel()
    lats = np.asarray(lat, dtype=float).ravel()
    out = np.empty(len(stamps))
    shared: dict[tuple[int, int], float] = {}
    for i, stamp in enumerate(stamps):
        local = (apparent_sidereal_time(julian_date(stamp)) + lons[i]) % 360.0
        key = (round(local / SIDEREAL_STEP), round(float(lats[i]) / LATITUDE_STEP))
        if key not in shared:
            # the cell's centre: the same instant seen from the longitude that puts its
            # sidereal time there, at the cell's latitude
            centre = key[0] * SIDEREAL_STEP
            shared[key] = natural_reading(
                instrument,
                stamp,
                float((lons[i] + centre - local + 180.0) % 360.0 - 180.0),
                float(np.clip(key[1] * LATITUDE_STEP, -90.0, 90.0)),
                pointing=pointing,
                sky=sky,
            )
        out[i] = shared[key]
    return out


def _utc(time: Any) -> Any:
    """A UTC instant the ephemerides take (pandas Timestamps become numpy datetime64)."""
    if hasattr(time, "tz_convert"):
        stamp = time.tz_convert("UTC") if time.tzinfo is not None else time
        return np.datetime64(stamp.tz_localize(None), "ns")
    return time
