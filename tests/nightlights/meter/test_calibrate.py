"""The calibration's fit on synthetic stations: recovery of a known scale and turbidity, the
held-out RMS against the injected noise, robustness, and its refusals and warnings."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nightlights.errors import DataQualityWarning, InputError
from nightlights.meter.calibrate import Model, fit, residual_statistics

NATURAL = 1.7e-4  # 22.0 mag arcsec-2 [cd m-2]


def stations(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Artificial readings spanning a dark site to a city (1e-5 to 3e-2 cd m-2), and their
    distances [km], the stand-in for what a turbidity changes."""
    rng = np.random.default_rng(seed)
    distance = rng.uniform(1.0, 40.0, n)
    artificial = 3e-2 * distance**-1.8
    return artificial, distance


def turbid(artificial: np.ndarray, distance: np.ndarray, turbidity: float) -> np.ndarray:
    """A turbidity's effect that a scale cannot mimic: more light near, less far (extinction)."""
    return artificial * np.exp(-(turbidity - 2.0) * (distance / 20.0 - 0.5))


def test_scale_recovered_exactly_without_noise() -> None:
    artificial, _ = stations(30)
    natural = np.full(30, NATURAL)
    measured = Model(np.zeros(30), artificial, natural).predict(scale=1.7)
    calibration = fit(Model(measured, artificial, natural))
    assert calibration.parameters["scale"] == pytest.approx(1.7, rel=1e-6)
    assert calibration.held_out["rms"] < 1e-6
    assert calibration.folds == "station"
    assert len(calibration.fold_parameters["scale"]) == 30


@pytest.mark.parametrize("folds", ["station", 5])
def test_scale_and_noise_recovered(folds: str | int) -> None:
    """400 stations with 0.1 mag of noise: the scale within 2 %, the held-out RMS equals the
    noise within 10 %, and in-sample and held-out agree (one parameter barely overfits)."""
    n, noise = 400, 0.1
    artificial, _ = stations(n)
    natural = np.full(n, NATURAL)
    rng = np.random.default_rng(7)
    measured = Model(np.zeros(n), artificial, natural).predict(scale=0.6)
    measured = measured + rng.normal(0.0, noise, n)
    calibration = fit(Model(measured, artificial, natural), folds=folds)
    assert calibration.parameters["scale"] == pytest.approx(0.6, rel=0.02)
    assert calibration.held_out["rms"] == pytest.approx(noise, rel=0.10)
    assert abs(calibration.held_out["bias"]) < 0.02
    assert calibration.in_sample["rms"] <= calibration.held_out["rms"]
    # the standard error is what the scatter of a 400-station fit says (about 1 %)
    assert 0.001 < calibration.uncertainties["scale"] / 0.6 < 0.03


def test_turbidity_and_scale_recovered() -> None:
    """A turbidity grid tabulated at 1-5: scale within 2 %, turbidity within 0.1."""
    n, noise = 300, 0.1
    artificial, distance = stations(n, seed=3)
    grid = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    table = np.stack([turbid(artificial, distance, t) for t in grid])
    natural = np.full(n, NATURAL)
    truth = Model(np.zeros(n), turbid(artificial, distance, 2.7), natural).predict(scale=1.3)
    measured = truth + np.random.default_rng(11).normal(0.0, noise, n)
    model = Model(measured, table, natural, grid, turbidity=2.0)
    calibration = fit(model, ("scale", "turbidity"), folds=10)
    assert calibration.parameters["scale"] == pytest.approx(1.3, rel=0.02)
    assert calibration.parameters["turbidity"] == pytest.approx(2.7, abs=0.1)
    assert calibration.held_out["rms"] == pytest.approx(noise, rel=0.10)


def test_outlying_stations_do_not_drag_the_fit() -> None:
    """Five stations 2 mag off (a wrong position, a cloudy season): the robust loss keeps the
    scale within 3 % where plain least squares is off by more than 10 %."""
    from scipy.optimize import least_squares

    n = 100
    artificial, _ = stations(n, seed=5)
    natural = np.full(n, NATURAL)
    measured = Model(np.zeros(n), artificial, natural).predict(scale=1.0)
    measured = measured + np.random.default_rng(2).normal(0.0, 0.05, n)
    measured[:5] -= 2.0  # much brighter than the model
    model = Model(measured, artificial, natural)
    calibration = fit(model)
    assert calibration.parameters["scale"] == pytest.approx(1.0, rel=0.03)
    plain = least_squares(lambda p: measured - model.predict(np.exp(p[0])), [0.0])
    assert abs(np.exp(plain.x[0]) - 1.0) > 0.10


def test_fewer_stations_than_parameters_refused() -> None:
    grid = np.array([2.0, 3.0])
    model = Model(np.array([20.0, 19.0]), np.ones((2, 2)) * 1e-3, np.full(2, NATURAL), grid, 2.0)
    with pytest.raises(InputError, match="2 stations for 2 parameters"):
        fit(model, ("scale", "turbidity"))
    with pytest.raises(InputError, match="1 station for 1 parameter"):
        fit(Model(np.array([20.0]), np.array([1e-3]), np.array([NATURAL])))


@pytest.mark.parametrize(
    ("parameters", "message"),
    [(("turbidity",), "expected 'scale'"), (("scale", "colour"), "expected 'scale'")],
)
def test_unknown_parameters_refused(parameters: tuple[str, ...], message: str) -> None:
    artificial, _ = stations(5)
    with pytest.raises(InputError, match=message):
        fit(Model(np.full(5, 20.0), artificial, np.full(5, NATURAL)), parameters)


def test_turbidity_without_a_grid_refused() -> None:
    artificial, _ = stations(5)
    with pytest.raises(InputError, match="two turbidities"):
        fit(Model(np.full(5, 20.0), artificial, np.full(5, NATURAL)), ("scale", "turbidity"))


@pytest.mark.parametrize("folds", [1, 0, "half", 99, True])
def test_bad_folds_refused(folds: object) -> None:
    artificial, _ = stations(6)
    with pytest.raises(InputError, match="folds="):
        fit(Model(np.full(6, 20.0), artificial, np.full(6, NATURAL)), folds=folds)  # type: ignore[arg-type]


def test_dark_stations_warn_that_the_scale_is_unconstrained() -> None:
    artificial = np.full(8, NATURAL / 50)  # every station 2 % artificial
    measured = Model(np.zeros(8), artificial, np.full(8, NATURAL)).predict(scale=1.0)
    with pytest.warns(DataQualityWarning, match="poorly constrained"):
        fit(Model(measured, artificial, np.full(8, NATURAL)))


def test_narrow_brightness_span_warns_for_turbidity() -> None:
    artificial = np.linspace(1e-3, 1.2e-3, 8)
    grid = np.array([2.0, 3.0])
    table = np.stack([artificial, artificial * 1.1])
    measured = Model(np.zeros(8), artificial, np.full(8, NATURAL)).predict(scale=1.0)
    with pytest.warns(DataQualityWarning, match="span"):
        fit(Model(measured, table, np.full(8, NATURAL), grid, 2.0), ("scale", "turbidity"))


def test_a_well_spread_set_fits_without_warnings() -> None:
    artificial, _ = stations(50)
    measured = Model(np.zeros(50), artificial, np.full(50, NATURAL)).predict(scale=2.0)
    measured = measured + np.random.default_rng(0).normal(0.0, 0.05, 50)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        fit(Model(measured, artificial, np.full(50, NATURAL)))


def test_residual_statistics() -> None:
    stats = residual_statistics([0.3, -0.1, 0.1, np.nan])
    assert stats == {"n": 3, "bias": 0.1, "rms": pytest.approx(0.19149, abs=1e-5), "mad": 0.2}
    assert residual_statistics([])["n"] == 0


def test_low_angle_share_recovered() -> None:
    """The low-angle band lights far stations more than near ones: a share of 0.3 against the
    emission's 0.1 is recovered within 0.03 with the scale within 2 %, 0.05 mag of noise."""
    n = 300
    artificial, distance = stations(n, seed=6)
    low_part = 0.1 * artificial * (distance / 10.0) ** 0.8  # reaches farther
    total = artificial + low_part
    natural = np.full(n, NATURAL)
    model = Model(np.zeros(n), total, natural, low_angle=low_part, share=0.1)
    truth = model.predict(scale=0.8, share=0.3)
    measured = truth + np.random.default_rng(9).normal(0.0, 0.05, n)
    calibration = fit(
        Model(measured, total, natural, low_angle=low_part, share=0.1), ("scale", "share"), folds=5
    )
    assert calibration.parameters["share"] == pytest.approx(0.3, abs=0.03)
    assert calibration.parameters["scale"] == pytest.approx(0.8, rel=0.02)
    assert calibration.held_out["rms"] == pytest.approx(0.05, rel=0.10)


def test_share_without_a_low_angle_band_refused() -> None:
    artificial, _ = stations(6)
    with pytest.raises(InputError, match="two bands"):
        fit(Model(np.full(6, 20.0), artificial, np.full(6, NATURAL)), ("scale", "share"))


def test_share_keeps_the_emission_when_unchanged() -> None:
    """At the emission's own share the two-band model is the one-band model."""
    artificial, distance = stations(10)
    low = 0.2 * artificial * distance / 20.0
    model = Model(np.zeros(10), artificial + low, np.full(10, NATURAL), low_angle=low, share=0.25)
    np.testing.assert_allclose(model.predict(1.3, share=0.25), model.predict(1.3), rtol=1e-12)
