"""RP-8's figures against loops over the field points written here."""

from __future__ import annotations

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.roads import (
    illuminance_average_to_minimum,
    luminance_average_to_minimum,
    luminance_maximum_to_minimum,
    veiling_luminance_ratio,
)


def test_luminance_ratios_per_observer_by_loops() -> None:
    rng = np.random.default_rng(7)
    field = rng.uniform(0.2, 2.0, size=(3, 10, 6))  # 3 observers
    for k in range(3):
        values = [field[k, i, j] for i in range(10) for j in range(6)]
        low = min(values)
        assert luminance_average_to_minimum(field)[k] == pytest.approx(
            sum(values) / len(values) / low, rel=1e-12
        )
        assert luminance_maximum_to_minimum(field)[k] == pytest.approx(max(values) / low)


def test_illuminance_and_veiling_ratios_by_hand() -> None:
    assert illuminance_average_to_minimum([[2.0, 6.0, 4.0], [4.0, 4.0, 4.0]]) == 2.0
    assert veiling_luminance_ratio([0.05, 0.12], 0.8) == pytest.approx(0.15)


def test_a_dark_point_gives_an_infinite_ratio_and_a_dark_field_an_error() -> None:
    assert luminance_maximum_to_minimum([[0.0, 1.0], [2.0, 1.0]]) == np.inf
    assert illuminance_average_to_minimum([[0.0, 1.0], [2.0, 1.0]]) == np.inf
    with pytest.raises(InputError, match="dark everywhere"):
        luminance_average_to_minimum(np.zeros((2, 3)))
    with pytest.raises(InputError, match=r"average=0\.0"):
        veiling_luminance_ratio([0.1], 0.0)
    with pytest.raises(InputError, match="expected a field"):
        luminance_average_to_minimum([1.0, 2.0])
