"""Spectra and sensors: the photopic identity, S/P ratios against published ranges."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ies.errors import PhotometryError
from ies.spectra import (
    SENSORS,
    SPDS,
    get_sensor,
    get_spd,
    scotopic_photopic_ratio,
    sensor_factor,
)


@pytest.mark.parametrize("spd", SPDS)
def test_photopic_sensor_gives_exactly_one_over_683(spd):
    # one lux is 1/683 W m-2 of V-weighted irradiance (definition of the lumen, K_m = 683)
    assert sensor_factor(spd, "photopic") == pytest.approx(1 / 683, rel=1e-12)


def test_every_sensor_loads_peak_normalised():
    assert {"cie_x", "cie_y", "cie_z"} <= set(SENSORS)  # CMFs keep their CIE scale
    for name in ("photopic", "scotopic", "melanopic", "nvis_class_a", "nvis_class_b"):
        sensor = get_sensor(name)
        assert np.all(np.diff(sensor.wavelengths) > 0)
        assert sensor.values.max() == pytest.approx(1.0, abs=0.03), name
        assert sensor.values.min() >= 0.0


def test_named_responses_peak_where_published():
    peaks = {"photopic": 555, "scotopic": 507, "melanopic": 490}  # CIE 1924, 1951, S 026
    for name, peak in peaks.items():
        sensor = get_sensor(name)
        assert sensor.wavelengths[np.argmax(sensor.values)] == pytest.approx(peak, abs=2)


def test_scotopic_photopic_ratios_fall_in_published_ranges():
    # Published S/P ratios (e.g. Berman 1992, J. Illum. Eng. Soc. 21(1); IES TM-12-12):
    # HPS about 0.6-0.65, LPS about 0.25, incandescent 1.41, 4000 K white LED about 1.5-1.8.
    assert 0.55 <= scotopic_photopic_ratio("HPS") <= 0.70
    assert scotopic_photopic_ratio("LPS") < 0.35
    assert scotopic_photopic_ratio("incandescent") == pytest.approx(1.41, abs=0.03)
    assert 1.5 <= scotopic_photopic_ratio("LED_4000K") <= 2.0
    assert scotopic_photopic_ratio("LED_3000K") < scotopic_photopic_ratio("LED_4000K")


def test_narrowband_source_at_555_nm():
    wavelengths = np.array([553.0, 554.0, 555.0, 556.0, 557.0])
    line = (wavelengths, np.array([0.0, 0.0, 1.0, 0.0, 0.0]))
    v_prime_555 = float(get_sensor("scotopic").on(np.array([555.0]))[0])
    assert sensor_factor(line, "scotopic") == pytest.approx(v_prime_555 / 683, rel=1e-3)


def test_nvis_goggles_see_red_rich_sources_more():
    # NVIS class A passes light above 625 nm: incandescent light (red-rich) excites it far more
    # per lux than a white LED; the class B filter (665 nm) passes less of every source.
    # (The shipped SPDs end at 780 nm, so near-infrared lines such as Na 819 nm are missing.)
    assert sensor_factor("incandescent", "nvis_class_a") > 3 * sensor_factor(
        "LED_4000K", "nvis_class_a"
    )
    for spd in ("HPS", "LED_4000K", "incandescent"):
        assert sensor_factor(spd, "nvis_class_b") < sensor_factor(spd, "nvis_class_a")


def test_melanopic_factor_grows_with_cct():
    values = [sensor_factor(f"LED_{k}K", "melanopic") for k in (2700, 3000, 4000, 5000)]
    assert values == sorted(values)


def test_xyz_sensors_give_chromaticity_of_illuminant_a():
    x = sensor_factor("incandescent", "cie_x")
    y = sensor_factor("incandescent", "cie_y")
    z = sensor_factor("incandescent", "cie_z")
    # CIE illuminant A: x = 0.4476, y = 0.4074 (CIE 15:2018, Table 1)
    assert x / (x + y + z) == pytest.approx(0.4476, abs=2e-3)
    assert y / (x + y + z) == pytest.approx(0.4074, abs=2e-3)


def test_unknown_names_and_bad_spectra():
    with pytest.raises(PhotometryError, match="known"):
        get_spd("candle")
    with pytest.raises(PhotometryError, match="known"):
        get_sensor("eagle")
    with pytest.raises(PhotometryError, match="ascending"):
        sensor_factor(([500.0, 400.0], [1.0, 1.0]), "photopic")
    with pytest.raises(PhotometryError, match="photopic content"):
        sensor_factor(([900.0, 910.0], [1.0, 1.0]), "photopic")


def test_colour_science_loads_without_pyplot_and_keeps_numpy_printing():
    """colour-science imports ``matplotlib.pyplot`` and sets NumPy's legacy print style on
    its own import; through :func:`ies.spectra.colour_science` neither happens, and its
    plotting subpackage still loads when used."""
    code = """
import sys, warnings
import numpy as np
from ies.spectra import colour_science

options, filters = np.get_printoptions(), list(warnings.filters)
colour = colour_science()
assert colour_science() is colour
print(np.get_printoptions() == options, warnings.filters == filters)
print("matplotlib.pyplot" in sys.modules)
print(callable(colour.plotting.plot_single_sd), "matplotlib.pyplot" in sys.modules)
import colour.plotting
print(colour.plotting.plot_single_sd is sys.modules["colour.plotting"].plot_single_sd)
"""
    root = Path(__file__).resolve().parents[2]
    path = os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")]))
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "svg", "PYTHONPATH": path},
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert done.stdout.split("\n")[:4] == ["True True", "False", "True True", "True"]
