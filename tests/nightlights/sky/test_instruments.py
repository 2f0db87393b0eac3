"""The instrument models: angular weights on panorama grids, and colour terms."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from ies.spectra import SENSORS, get_sensor, sensor_factor
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import DataQualityWarning, InputError
from nightlights.sky.instruments import (
    INSTRUMENTS,
    NATURAL_SKY,
    ZERO_POINT_SPECTRUM,
    Instrument,
    angular_weights,
    colour_term,
    elevation_weights,
    get_instrument,
    instrument_luminance,
    instrument_magnitude,
)


def _grid(n_el: int, n_az: int) -> tuple[np.ndarray, np.ndarray]:
    elevation = (np.arange(n_el) + 0.5) * 90.0 / n_el
    azimuth = (np.arange(n_az) + 0.5) * 360.0 / n_az
    return elevation, azimuth


@pytest.mark.parametrize("name", list(INSTRUMENTS))
def test_weights_sum_to_one_and_read_a_uniform_sky_exactly(name: str) -> None:
    elevation, azimuth = _grid(90, 180)
    weights = angular_weights(name, elevation, azimuth)
    assert weights.shape == (90, 180)
    assert weights.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all(weights >= 0.0)
    sky = np.full(weights.shape, 3.7e-4)
    assert (weights * sky).sum() == pytest.approx(3.7e-4, rel=1e-12)


def test_response_is_half_at_half_the_fwhm() -> None:
    for instrument in INSTRUMENTS.values():
        values = instrument.response([0.0, instrument.fwhm / 2.0, -instrument.fwhm / 2.0])
        np.testing.assert_allclose(values, [1.0, 0.5, 0.5], rtol=1e-12)
        assert float(instrument.response(95.0)) == 0.0  # behind the instrument


def test_a_point_source_off_axis_is_weighted_as_the_response_says() -> None:
    # two equal-solid-angle pixels, one on the axis and one fwhm/2 off it: weights 1 : 0.5
    instrument = get_instrument("sqm-l")
    elevation, azimuth = _grid(900, 360)
    weights = angular_weights(instrument, elevation, azimuth, pointing=(45.0, 90.0))
    row_on = int(np.argmin(np.abs(elevation - 45.0)))
    row_off = int(np.argmin(np.abs(elevation - (45.0 + instrument.fwhm / 2.0))))
    col = int(np.argmin(np.abs(azimuth - 90.0)))
    band = np.sin(np.radians(elevation + 0.05)) - np.sin(np.radians(elevation - 0.05))
    ratio = (weights[row_off, col] / band[row_off]) / (weights[row_on, col] / band[row_on])
    assert ratio == pytest.approx(0.5, abs=0.01)


def test_a_bright_patch_reads_as_the_response_integral() -> None:
    # the zenith cap within theta0 of a zenith pointing: its share is
    # int_0^theta0 R sin / int_0^90 R sin, computed here by fine quadrature
    instrument = get_instrument("tess-w")
    theta = np.linspace(0.0, 90.0, 200_001)
    integrand = instrument.response(theta) * np.sin(np.radians(theta))
    cap = 10.0
    expected = np.trapezoid(integrand[theta <= cap], theta[theta <= cap]) / np.trapezoid(
        integrand, theta
    )
    elevation, azimuth = _grid(90, 8)  # cap edge at 80 deg falls on a pixel bound
    weights = angular_weights(instrument, elevation, azimuth)
    assert weights[elevation > 90.0 - cap].sum() == pytest.approx(expected, rel=1e-3)


def test_zenith_pointing_is_azimuth_symmetric_and_matches_elevation_weights() -> None:
    elevation, azimuth = _grid(45, 72)
    weights = angular_weights("sqm", elevation, azimuth)
    np.testing.assert_allclose(weights, weights[:, :1] * np.ones((1, 72)), rtol=1e-12)
    np.testing.assert_allclose(weights.sum(axis=1), elevation_weights("sqm", elevation), rtol=1e-12)


def test_weights_converge_as_the_grid_refines() -> None:
    # a sky brightening toward the horizon, L = 1 / sin(e + 5 deg): the SQM's reading on
    # ever finer grids approaches the fine quadrature of int R L dOmega / int R dOmega
    instrument = get_instrument("sqm")
    theta = np.linspace(0.0, 90.0, 400_001)
    elevation_fine = 90.0 - theta
    kernel = instrument.response(theta) * np.sin(np.radians(theta))
    sky_fine = 1.0 / np.sin(np.radians(elevation_fine + 5.0))
    expected = np.trapezoid(kernel * sky_fine, theta) / np.trapezoid(kernel, theta)
    errors = []
    for n in (6, 12, 24, 48, 96, 192):
        elevation, _ = _grid(n, 1)
        weights = elevation_weights(instrument, elevation)
        errors.append(abs((weights * (1.0 / np.sin(np.radians(elevation + 5.0)))).sum() - expected))
    assert errors[-1] < 1e-4 * expected
    assert all(later < earlier for earlier, later in itertools.pairwise(errors))


def test_non_uniform_and_descending_elevations() -> None:
    elevation = np.array([1.0, 3.0, 7.0, 15.0, 30.0, 50.0, 70.0, 85.0, 89.0])
    ascending = elevation_weights("sqm", elevation)
    descending = elevation_weights("sqm", elevation[::-1])
    np.testing.assert_allclose(descending, ascending[::-1], rtol=1e-12)
    assert ascending.sum() == pytest.approx(1.0)
    # the same sky on a fine uniform grid: the cap above 77.5 deg (a bound of both grids)
    fine, _ = _grid(3600, 1)
    fine_weights = elevation_weights("sqm", fine)
    assert ascending[elevation > 77.5].sum() == pytest.approx(
        fine_weights[fine > 77.5].sum(), rel=1e-4
    )


def test_a_narrow_fov_on_a_coarse_grid_sums_to_one_and_warns() -> None:
    elevation, azimuth = _grid(8, 32)
    narrow = get_instrument("tess-w").with_fwhm(2.0)
    with pytest.warns(DataQualityWarning, match="coarser than half"):
        weights = angular_weights(narrow, elevation, azimuth)
    assert weights.sum() == pytest.approx(1.0, abs=1e-12)
    assert weights[-1].sum() == pytest.approx(1.0, abs=1e-9)  # all in the zenith row
    with pytest.warns(DataQualityWarning):
        tilted = angular_weights(narrow, elevation, azimuth, pointing=(30.0, 100.0))
    assert tilted.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.unravel_index(tilted.argmax(), tilted.shape) == (2, 8)


def test_a_fine_grid_does_not_warn() -> None:
    elevation, azimuth = _grid(90, 360)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        angular_weights("tess-w", elevation, azimuth, pointing=(60.0, 10.0))


def test_with_fwhm_and_get_instrument() -> None:
    base = get_instrument("SQM-L")
    wider = base.with_fwhm(30.0)
    assert wider.fwhm == 30.0 and wider.sensor == base.sensor and base.fwhm == 20.0
    assert get_instrument(wider) is wider
    assert float(wider.response(15.0)) == pytest.approx(0.5)
    with pytest.raises(InputError, match="sqm, sqm-l, tess-w, eye"):
        get_instrument("photometer")
    with pytest.raises(InputError, match="fwhm"):
        base.with_fwhm(0.0)
    assert isinstance(wider, Instrument)


def test_wider_response_gives_more_weight_to_low_elevations() -> None:
    elevation, _ = _grid(90, 1)
    low = elevation < 45.0
    shares = [elevation_weights(name, elevation)[low].sum() for name in ("tess-w", "sqm-l")]
    assert shares[0] < shares[1] < elevation_weights("sqm", elevation)[low].sum()


@pytest.mark.parametrize(
    "elevation",
    [np.array([]), np.array([10.0, 10.0]), np.array([-1.0, 45.0]), np.array([[45.0]])],
)
def test_malformed_elevations_are_refused(elevation: np.ndarray) -> None:
    with pytest.raises(InputError, match="elevation"):
        elevation_weights("sqm", elevation)


def test_malformed_azimuth_and_pointing_are_refused() -> None:
    elevation, _ = _grid(10, 1)
    with pytest.raises(InputError, match="azimuth"):
        angular_weights("sqm", elevation, np.array([0.0, 10.0, 30.0]))
    with pytest.raises(InputError, match="pointing"):
        angular_weights("sqm", elevation, np.array([0.0]), pointing=(120.0, 0.0))
    with pytest.raises(InputError, match="sees none"), warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        angular_weights(
            get_instrument("tess-w").with_fwhm(1.0),
            elevation,
            (np.arange(36) + 0.5) * 10.0,
            pointing=(-60.0, 0.0),
        )


# -- spectral side -------------------------------------------------------------------------


def test_the_zero_point_spectrum_has_no_colour_term() -> None:
    for name in INSTRUMENTS:
        assert colour_term(name, ZERO_POINT_SPECTRUM) == pytest.approx(0.0, abs=1e-12)


def test_colour_term_differences_match_sensor_factor_ratios() -> None:
    # the same synthetic photometry through ies.spectra.sensor_factor (k = int S R / 683 int S V):
    # differences of colour terms do not depend on the zero point
    for instrument in ("eye", "sqm", "tess-w"):
        sensor = get_instrument(instrument).sensor
        for first, second in (("LPS", "LED_5000K"), ("mercury", "incandescent")):
            ratios = [
                sensor_factor(spectrum, sensor) / sensor_factor(spectrum, "johnson_v")
                for spectrum in (first, second)
            ]
            expected = -2.5 * np.log10(ratios[0] / ratios[1])
            difference = colour_term(instrument, first) - colour_term(instrument, second)
            assert difference == pytest.approx(expected, abs=1e-9)


def test_sodium_light_reads_fainter_than_white_light_in_the_sqm_band() -> None:
    # the SQM reaches further into the blue than V: relative to V it sees less of sodium's
    # 589 nm light than of a white LED's blue peak (Sanchez de Miguel et al. 2017)
    for name in ("sqm", "sqm-l"):
        low_pressure = colour_term(name, "LPS")
        assert low_pressure > colour_term(name, "LED_4000K") > colour_term(name, "LED_5000K")
    assert colour_term("sqm", "LPS") == colour_term("sqm-l", "LPS")  # one sensor


def test_instrument_luminance_and_magnitude() -> None:
    """A lamp's photopic luminance takes m_X - m_photopic (the eye reads it as it is), a V
    luminance m_X - V."""
    luminance = np.array([1e-4, 2e-4])
    term = colour_term("sqm", "HPS") - colour_term("eye", "HPS")
    np.testing.assert_allclose(
        instrument_luminance(luminance, "sqm", "HPS"), luminance * 10 ** (-0.4 * term)
    )
    np.testing.assert_allclose(
        instrument_luminance(luminance, "sqm", "HPS", band="V"),
        luminance * 10 ** (-0.4 * colour_term("sqm", "HPS")),
    )
    for spectrum in ("HPS", "LPS", "LED_4000K"):
        np.testing.assert_allclose(instrument_luminance(luminance, "eye", spectrum), luminance)
    natural = colour_term("sqm", NATURAL_SKY)
    assert float(instrument_luminance(1.0, "sqm", NATURAL_SKY)) == pytest.approx(
        10 ** (-0.4 * natural)
    )
    with pytest.raises(InputError, match="band='B'"):
        instrument_luminance(luminance, "sqm", "HPS", band="B")
    single = instrument_magnitude({"HPS": 171e-6}, "sqm")
    assert isinstance(single, float)
    assert single == pytest.approx(float(luminance_to_magnitude(171e-6)) + term, abs=1e-12)
    mixed = instrument_magnitude({"HPS": luminance, NATURAL_SKY: 171e-6}, "tess-w")
    assert mixed.shape == (2,)
    expected = luminance_to_magnitude(
        instrument_luminance(luminance, "tess-w", "HPS")
        + instrument_luminance(171e-6, "tess-w", NATURAL_SKY)
    )
    np.testing.assert_allclose(mixed, expected, rtol=1e-12)


def test_unknown_spectrum_and_empty_parts_are_refused() -> None:
    with pytest.raises(InputError, match="spectrum='sodium'"):
        colour_term("sqm", "sodium")
    with pytest.raises(InputError, match="parts"):
        instrument_magnitude({}, "sqm")


def test_sensors_are_registered_in_ies() -> None:
    for sensor in {instrument.sensor for instrument in INSTRUMENTS.values()} | {"johnson_v"}:
        assert sensor in SENSORS
        response = get_sensor(sensor)
        assert response.values.max() == pytest.approx(1.0)
    johnson_v = get_sensor("johnson_v")
    assert johnson_v.wavelengths[np.argmax(johnson_v.values)] == 530.0  # Bessell 1990, Table 2
    assert "reconstruction" in get_sensor("sqm").description
