"""Garstang's atmosphere (clarity K) and the conversions between atmosphere descriptions.

Sources: Garstang 1986 (PASP 98, 364) and 1991 (PASP 103, 1109) as restated by Cinzano et al.
2000 (MNRAS 318, 641, Eqs. 10-14, A2); Preetham et al. 1999, App. A.3; Koschmieder 1924.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from nightlights.errors import InputError
from nightlights.sky.atmosphere import (
    GARSTANG_AEROSOL_ASYMMETRY,
    Atmosphere,
    aerosol_optical_depth,
    atmosphere_conversion_table,
    garstang_aerosol_inverse_scale_height,
    garstang_aerosol_optical_depth,
    garstang_aerosol_phase,
    garstang_atmosphere,
    garstang_clarity,
    henyey_greenstein_phase,
    horizontal_visibility,
    koschmieder_extinction_coefficient,
    koschmieder_visibility,
    magnitude_optical_depth,
    optical_depth_magnitude,
    preetham_turbidity,
    vertical_extinction,
)


def test_garstang_values_by_hand() -> None:
    # c = 0.104 km-1; N_m0 sigma_R = 2.55e19 cm-3 x 4.6e-27 cm2 = 1.173e-7 cm-1 = 1.173e-5 m-1
    atm = garstang_atmosphere(1.0)
    assert atm.molecular_scale_height == pytest.approx(1e3 / 0.104)
    assert atm.molecular_extinction == pytest.approx(1.173e-5, rel=1e-6)
    assert atm.molecular_optical_depth == pytest.approx(1.173e-5 * 1e3 / 0.104, rel=1e-6)
    # a = 0.657 + 0.059 = 0.716 km-1; aerosol extinction 11.778 x 1.173e-5 m-1
    assert atm.aerosol_scale_height == pytest.approx(1e3 / 0.716)
    assert atm.aerosol_extinction == pytest.approx(11.778 * 1.173e-5, rel=1e-6)
    assert atm.aerosol_depth == pytest.approx(11.778 * 1.173e-5 * 1e3 / 0.716, rel=1e-6)
    # scattering at sea level: aerosols 11.11 K times the molecules (Cinzano 2000, Eq. 12)
    assert atm.aerosol_albedo * atm.aerosol_extinction == pytest.approx(
        11.11 * atm.molecular_extinction, rel=1e-9
    )
    assert garstang_aerosol_inverse_scale_height(3.0) == pytest.approx((0.657 + 3 * 0.059) * 1e-3)


def test_garstang_clear_night_matches_the_quoted_extinction_and_visibility() -> None:
    """K = 1: vertical extinction 0.33 mag and visibility 26 km (the figures Cinzano et al. 2000
    quote for K = 1, recalled, not read): tau = 0.1128 + 0.1930 = 0.3058, 1.0857 tau = 0.332 mag;
    sea-level extinction 12.778 x 1.173e-5 m-1, ln(50) / beta = 26.1 km. With 11.11 K as the
    extinction ratio these would be 0.320 mag and 27.5 km."""
    atm = garstang_atmosphere(1.0)
    assert vertical_extinction(atm) == pytest.approx(0.332, abs=0.001)
    assert horizontal_visibility(atm) == pytest.approx(26_100.0, rel=2e-3)


def test_koschmieder_and_magnitudes() -> None:
    assert koschmieder_visibility(1e-4) == pytest.approx(math.log(50.0) / 1e-4)
    assert koschmieder_visibility(1e-4, contrast=0.05) == pytest.approx(math.log(20.0) / 1e-4)
    assert optical_depth_magnitude(1.0) == pytest.approx(2.5 * math.log10(math.e))
    # 40.7 km at T = 2 (the defaults: Bodhaine molecules over 8 km, Preetham aerosols, 1.2 km)
    beta = 0.097065 / 8000.0 + float(aerosol_optical_depth(2.0)) / 1200.0
    assert horizontal_visibility(Atmosphere(turbidity=2.0)) == pytest.approx(
        math.log(50.0) / beta, rel=2e-4
    )
    assert horizontal_visibility(Atmosphere(rayleigh_optical_depth=0.0, turbidity=1.0)) > 1e6
    with pytest.raises(InputError, match="extinction coefficient"):
        koschmieder_visibility(0.0)
    with pytest.raises(InputError, match="contrast"):
        koschmieder_visibility(1e-4, contrast=1.5)
    with pytest.raises(InputError, match="visibility"):
        koschmieder_extinction_coefficient(-1.0)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 100.0))
def test_clarity_round_trip(clarity: float) -> None:
    tau = garstang_aerosol_optical_depth(clarity)
    assert garstang_clarity(tau) == pytest.approx(clarity, rel=1e-9, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.floats(1.0, 64.0), st.floats(400.0, 900.0))
def test_turbidity_round_trip(turbidity: float, wavelength: float) -> None:
    tau = aerosol_optical_depth(turbidity, wavelength)
    assert preetham_turbidity(tau, wavelength) == pytest.approx(turbidity, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.floats(1.0, 1e6), st.floats(0.0, 5.0))
def test_visibility_and_magnitude_round_trips(visibility: float, magnitude: float) -> None:
    beta = koschmieder_extinction_coefficient(visibility)
    assert koschmieder_visibility(beta) == pytest.approx(visibility, rel=1e-12)
    tau = magnitude_optical_depth(magnitude)
    assert optical_depth_magnitude(tau) == pytest.approx(magnitude, rel=1e-12, abs=1e-15)


def test_monotonic_in_clarity_and_turbidity() -> None:
    clarity = np.linspace(0.0, 20.0, 41)
    tau = garstang_aerosol_optical_depth(clarity)
    assert np.all(np.diff(tau) > 0)
    assert np.all(np.diff(garstang_aerosol_inverse_scale_height(clarity)) > 0)
    garstang = [garstang_atmosphere(k) for k in clarity]
    assert np.all(np.diff([horizontal_visibility(a) for a in garstang]) < 0)
    assert np.all(np.diff([vertical_extinction(a) for a in garstang]) > 0)
    turbidity = np.linspace(1.5, 20.0, 38)
    preetham = [Atmosphere(turbidity=t) for t in turbidity]
    assert np.all(np.diff([a.aerosol_depth for a in preetham]) > 0)
    assert np.all(np.diff([horizontal_visibility(a) for a in preetham]) < 0)
    assert np.all(np.diff([vertical_extinction(a) for a in preetham]) > 0)


def test_clarity_has_a_largest_optical_depth() -> None:
    # the aerosol scale height 1 / (a0 + a1 K) shrinks as K grows: tau -> 11.778 N sigma / a1
    limit = 11.778 * 1.173e-5 / 0.059e-3
    assert garstang_aerosol_optical_depth(1e6) == pytest.approx(limit, rel=1e-4)
    with pytest.raises(InputError, match="Garstang's largest"):
        garstang_clarity(limit)
    with pytest.raises(InputError, match="clarity"):
        garstang_atmosphere(-1.0)
    with pytest.raises(InputError, match="clarity"):
        garstang_aerosol_optical_depth(float("nan"))


def test_no_aerosols_at_zero_clarity() -> None:
    atm = garstang_atmosphere(0.0)
    assert atm.aerosol_depth == 0.0
    assert atm.turbidity == 1.0


def _sphere(function, moment: int = 0) -> float:  # type: ignore[no-untyped-def]
    def integrand(theta: float) -> float:
        mu = math.cos(math.radians(theta))
        return float(function(mu)) * mu**moment * 2.0 * math.pi * math.sin(math.radians(theta))

    total = quad(integrand, 0.0, 180.0, points=[10.0, 124.0], limit=200)[0]
    return total * math.pi / 180.0


def test_garstang_aerosol_phase_normalised_and_continuous() -> None:
    norm = _sphere(garstang_aerosol_phase)
    assert norm == pytest.approx(1.0, abs=5e-3)  # 1.003 as published
    mean_cosine = _sphere(garstang_aerosol_phase, moment=1) / norm
    assert mean_cosine == pytest.approx(GARSTANG_AEROSOL_ASYMMETRY, abs=1e-3)
    for joint, tolerance in ((10.0, 1e-3), (124.0, 0.03)):
        below, above = garstang_aerosol_phase(np.cos(np.radians([joint - 1e-6, joint + 1e-6])))
        assert above == pytest.approx(below, rel=tolerance)


def test_henyey_greenstein_stand_in_for_garstang_phase() -> None:
    """Recorded ratios HG(g = 0.687) / Garstang's function (what the kernel's approximation
    changes): within +3 % to +30 % from 10 to 125 deg, 0.56 at 150 deg, 0.18 forward."""
    angles = np.array([0.0, 10.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0])
    mu = np.cos(np.radians(angles))
    ratio = henyey_greenstein_phase(mu, GARSTANG_AEROSOL_ASYMMETRY) / garstang_aerosol_phase(mu)
    expected = [0.183, 1.097, 1.050, 1.032, 1.190, 1.286, 0.564, 0.259]
    np.testing.assert_allclose(ratio, expected, atol=2e-3)


def test_garstang_atmosphere_survives_the_kernel_parameters() -> None:
    atm = garstang_atmosphere(2.0, flat_earth=True)
    assert Atmosphere.from_parameters(atm.parameters()) == atm


def test_conversion_table() -> None:
    rows = atmosphere_conversion_table()
    depths = [row["aerosol_optical_depth"] for row in rows]
    assert depths == sorted(depths)
    by_name = {row["given"]: row for row in rows}
    # T = 2 is about K = 0.5; K = 1 is about T = 2.9 (equal aerosol optical depth at 550 nm)
    assert by_name["T = 2"]["clarity"] == pytest.approx(0.4996, abs=1e-3)
    assert by_name["K = 1"]["turbidity"] == pytest.approx(2.920, abs=2e-3)
    assert by_name["K = 1"]["visibility_km_garstang"] == pytest.approx(26.1, abs=0.05)
    visibility = [row["visibility_km_preetham"] for row in rows]
    assert visibility == sorted(visibility, reverse=True)
    for row in rows:
        assert row["extinction_mag_garstang"] > row["extinction_mag_preetham"]  # more molecules
    huge = atmosphere_conversion_table(turbidities=(40.0,), clarities=())
    assert huge[0]["clarity"] is None and "visibility_km_garstang" not in huge[0]
