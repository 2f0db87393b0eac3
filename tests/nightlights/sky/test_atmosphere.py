"""Atmosphere optics: Bodhaine Rayleigh depth, Preetham turbidity, phase functions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from nightlights.errors import InputError
from nightlights.sky.atmosphere import (
    Atmosphere,
    aerosol_optical_depth,
    angstrom_turbidity_coefficient,
    henyey_greenstein_phase,
    isotropic_phase,
    rayleigh_optical_depth,
    rayleigh_phase,
)


def test_rayleigh_optical_depth_bodhaine_values() -> None:
    # Bodhaine et al. 1999, Eq. 30 evaluated by hand at 0.55 um and 0.40 um (tolerance 1e-4
    # relative); between 450 and 650 nm the depth follows roughly lambda^-4.08
    assert rayleigh_optical_depth(550.0) == pytest.approx(0.097065, rel=1e-4)
    assert rayleigh_optical_depth(400.0) == pytest.approx(0.36021, rel=1e-4)
    ratio = rayleigh_optical_depth(450.0) / rayleigh_optical_depth(650.0)
    assert 4.0 < math.log(ratio) / math.log(650 / 450) < 4.2
    with pytest.raises(InputError, match="wavelength"):
        rayleigh_optical_depth(-1.0)


def test_preetham_turbidity_to_aerosol_depth() -> None:
    # Preetham et al. 1999, App. A.3: beta = 0.04608 T - 0.04586; tau = beta lambda^-1.3
    assert angstrom_turbidity_coefficient(2.0) == pytest.approx(0.0463, abs=1e-4)
    assert aerosol_optical_depth(2.0, 550.0) == pytest.approx(0.0463 * 0.55**-1.3, rel=1e-3)
    assert angstrom_turbidity_coefficient(1.0) == pytest.approx(0.0, abs=3e-4)
    with pytest.raises(InputError, match="turbidity"):
        angstrom_turbidity_coefficient(0.5)


def _sphere_integral(phase) -> float:  # type: ignore[no-untyped-def]
    return 2.0 * math.pi * quad(phase, -1.0, 1.0, epsabs=1e-13, epsrel=1e-12, limit=200)[0]


def test_phase_functions_integrate_to_one() -> None:
    # validation (2): normalised over 4 pi sr
    assert _sphere_integral(lambda mu: float(rayleigh_phase(mu))) == pytest.approx(1.0, abs=1e-10)
    assert _sphere_integral(lambda mu: float(isotropic_phase(mu))) == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(-0.9, 0.95))
def test_henyey_greenstein_normalised_with_mean_cosine_g(g: float) -> None:
    assert _sphere_integral(lambda mu: float(henyey_greenstein_phase(mu, g))) == pytest.approx(
        1.0, abs=1e-7
    )
    mean_cos = _sphere_integral(lambda mu: mu * float(henyey_greenstein_phase(mu, g)))
    assert mean_cos == pytest.approx(g, abs=1e-6)


def test_henyey_greenstein_rejects_bad_g() -> None:
    with pytest.raises(InputError, match="asymmetry"):
        henyey_greenstein_phase(0.5, 1.0)


def test_atmosphere_defaults_and_overrides() -> None:
    atm = Atmosphere()
    assert atm.molecular_extinction == pytest.approx(float(rayleigh_optical_depth(550)) / 8000)
    assert atm.aerosol_extinction == pytest.approx(float(aerosol_optical_depth(2.0)) / 1200)
    assert atm.top_altitude == pytest.approx(16 * 8000)
    only_aerosol = Atmosphere(rayleigh_optical_depth=0.0, aerosol_optical_depth=0.2)
    assert only_aerosol.molecular_extinction == 0.0
    assert only_aerosol.top_altitude == pytest.approx(16 * 1200)
    # extinction at sea level sums the species; it falls with altitude
    ext = atm.extinction_coefficient(np.array([0.0, 1000.0, 10000.0]))
    assert ext[0] == pytest.approx(atm.molecular_extinction + atm.aerosol_extinction)
    assert np.all(np.diff(ext) < 0)
    params = atm.parameters()
    assert params["flat_earth"] == 0 and params["aerosol_optical_depth"] == -1.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"turbidity": 0.9}, "turbidity"),
        ({"aerosol_scale_height": 0.0}, "aerosol_scale_height"),
        ({"asymmetry": -1.0}, "asymmetry"),
        ({"aerosol_optical_depth": -0.1}, "aerosol_optical_depth"),
        ({"aerosol_albedo": 1.5}, "aerosol_albedo"),
        ({"molecular_phase": "mie"}, "molecular_phase"),
    ],
)
def test_atmosphere_rejects_bad_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        Atmosphere(**kwargs)
