"""Sky brightness units and the zenith summary: the leaf agrees with the night sky's model to
the last bit, and the sky package's earlier path hands on the same objects."""

from __future__ import annotations

import math

import pytest

import nightlights.sky.brightness as sky_brightness
from nightlights import brightness
from nightlights.errors import InputError
from nightlights.nightsky.background import NaturalSky, natural_sky_luminance
from nightlights.nightsky.render import zenith_summary as night_zenith_summary

#: Artificial zenith luminances from a dark site to a city centre [cd m-2].
ARTIFICIAL = (0.0, 1e-6, 171e-6, 3.65e-3, 0.05)


def test_natural_zenith_is_the_night_skys_moonless_zenith() -> None:
    # exact: the skyglow stages' natural sky and the night sky's default must not differ
    zenith = float(natural_sky_luminance([90.0])["total"][0])
    assert brightness.NATURAL_ZENITH_LUMINANCE == zenith
    assert NaturalSky().zenith_magnitude == brightness.NATURAL_ZENITH_MAGNITUDE
    assert brightness.NATURAL_ZENITH_LUMINANCE * 1e6 == pytest.approx(171.17, abs=0.01)


@pytest.mark.parametrize("artificial", ARTIFICIAL)
def test_zenith_summary_equals_the_night_skys(artificial: float) -> None:
    leaf = brightness.zenith_summary(artificial)
    night = night_zenith_summary(artificial)
    assert leaf == night
    assert list(leaf) == list(night)


def test_zenith_summary_adds_a_given_natural_sky() -> None:
    natural = float(brightness.magnitude_to_luminance(21.0))
    summary = brightness.zenith_summary(natural, natural_luminance=natural)
    # twice the light is 2.5 log10(2) = 0.753 mag brighter
    assert summary["zenith_natural_sky_brightness"] == pytest.approx(21.0, abs=1e-12)
    assert summary["zenith_sky_brightness"] == pytest.approx(21.0 - 2.5 * math.log10(2.0))
    assert summary["bortle_class_zenith"] == 5  # 20.25: between 20.49 and 19.50


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        (-1e-9, "expected >= 0"),
        (math.nan, "not a finite number .* no Bortle class"),
        (math.inf, "not a finite number .* no Bortle class"),
    ],
)
@pytest.mark.parametrize("summary", [brightness.zenith_summary, night_zenith_summary])
def test_zenith_summary_rejects_negative_or_non_finite_light(
    summary: object, bad: float, message: str
) -> None:
    with pytest.raises(InputError, match=message):
        summary(bad)  # type: ignore[operator]


def test_the_sky_packages_path_hands_on_the_same_objects() -> None:
    for name in sky_brightness.__all__:
        assert getattr(sky_brightness, name) is getattr(brightness, name), name


#: (zenith magnitude [mag arcsec-2], Bortle class or None for a sky that is not finite)
BORTLE_CASES = [
    (22.5, 1),
    (math.inf, 1),  # zero luminance: no light at all, the darkest class
    (21.0, 4),
    (17.9, 9),
    (math.nan, None),  # NaN luminance
    (-math.inf, None),  # infinite luminance
]


@pytest.mark.parametrize(("magnitude", "expected"), BORTLE_CASES)
def test_a_sky_that_is_not_finite_has_no_bortle_class(
    magnitude: float, expected: int | None
) -> None:
    if expected is None:
        with pytest.raises(InputError, match=r"not a finite number .* no Bortle class"):
            brightness.bortle_class(magnitude)
        with pytest.raises(InputError, match="1 of 3 values"):
            brightness.bortle_class([20.0, magnitude, 21.0])
        assert brightness.bortle_class_or_reason(magnitude) == (None, brightness.NON_FINITE_SKY)
    else:
        assert int(brightness.bortle_class(magnitude)) == expected
        assert brightness.bortle_class_or_reason(magnitude) == (expected, None)
