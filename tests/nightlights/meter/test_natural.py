"""The natural sky through an instrument: a typical night near 22 mag arcsec-2, the Milky Way's
effect at a given time, and the shared skies of many readings against each reading's own."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.meter.natural import natural_reading, natural_readings
from nightlights.sky.instruments import colour_term, get_instrument


@pytest.mark.parametrize("instrument", ["sqm", "sqm-l", "tess-w"])
def test_typical_night_is_the_zenith_sky_in_the_instruments_band(instrument: str) -> None:
    """A typical moonless night: 22.0 mag arcsec-2 (V) at the zenith plus the colour term; the
    wide SQM reads it brighter (the airglow brightens toward the horizon)."""
    device = get_instrument(instrument)
    magnitude = float(luminance_to_magnitude(natural_reading(device)))
    expected = 22.0 + colour_term(device, "natural_sky")
    if device.fwhm < 30:
        assert magnitude == pytest.approx(expected, abs=0.05)
    else:
        assert expected - 0.5 < magnitude < expected - 0.05


def test_milky_way_overhead_brightens_the_reading() -> None:
    """Deneb (RA 20h41m, Dec +45) culminates near the zenith at latitude 45 N: the Milky Way
    overhead brightens an SQM-L's natural sky against the galactic pole overhead (RA 12h51m,
    Dec +27 at latitude 27 N), by the integrated starlight's contrast."""
    when = pd.Timestamp("2026-09-15T21:00Z")
    from nightlights.nightsky.astro import apparent_sidereal_time, julian_date

    gst = apparent_sidereal_time(julian_date(when))
    plane = natural_reading("sqm-l", when, (310.4 - gst + 180) % 360 - 180, 45.3)
    pole = natural_reading("sqm-l", when, (192.9 - gst + 180) % 360 - 180, 27.1)
    difference = float(luminance_to_magnitude(pole) - luminance_to_magnitude(plane))
    assert 0.05 < difference < 0.8


def test_shared_skies_match_each_readings_own() -> None:
    """200 readings over a night and a region: the shared skies (one per 8 deg of sidereal
    time and 4 deg of latitude) within 0.01 mag arcsec-2 of each reading's own sky."""
    rng = np.random.default_rng(0)
    times = pd.Timestamp("2026-03-20T19:00Z") + pd.to_timedelta(rng.uniform(0, 8, 200), "h")
    lon = rng.uniform(20.0, 28.0, 200)
    lat = rng.uniform(58.0, 64.0, 200)
    shared = natural_readings("sqm-l", times, lon, lat)
    own = np.array(
        [
            natural_reading("sqm-l", t, x, y)
            for t, x, y in zip(times[:40], lon[:40], lat[:40], strict=True)
        ]
    )
    error = luminance_to_magnitude(shared[:40]) - luminance_to_magnitude(own)
    assert np.abs(error).max() < 0.01


def test_time_needs_a_position() -> None:
    with pytest.raises(InputError, match="lon= and lat="):
        natural_reading("sqm", pd.Timestamp("2026-01-18T21:00Z"))
