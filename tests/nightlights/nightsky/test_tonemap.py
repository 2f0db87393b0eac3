"""Night-vision tone mapping: Jensen et al. 2001 blue shift, Larson et al. 1997 scotopic
luminance and acuity, the display curve, the camera mode."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.nightsky.background import rayleigh_sunlight_xyz
from nightlights.nightsky.tonemap import (
    BLUE_POINT,
    ToneMapping,
    acuity_blur_sigma,
    blackbody_white,
    blue_shift,
    mesopic_weight,
    scotopic_luminance,
    tone_map,
    visual_acuity,
)

#: Chromaticities of night light: sodium-like, warm LED, daylight, hot star, scattered sunlight.
LIGHTS = [
    blackbody_white(2000.0),
    blackbody_white(3000.0),
    blackbody_white(6504.0),
    blackbody_white(20000.0),
    rayleigh_sunlight_xyz(),
]


def chromaticity(xyz: np.ndarray) -> np.ndarray:
    return xyz[..., :2] / xyz.sum(axis=-1, keepdims=True)


def test_scotopic_luminance_of_equal_energy_white() -> None:
    # Larson et al. 1997, Eq. 2 with X = Y = Z = 1: 1.33 x 3 - 1.68 = 2.31 (exact)
    assert scotopic_luminance([1.0, 1.0, 1.0]) == pytest.approx(2.31, rel=1e-12)
    assert scotopic_luminance([0.0, 1.0, 1.0]) == 0.0  # no X: no defined ratio, no light


def test_mesopic_weight_limits_and_monotonic() -> None:
    y = np.logspace(-6, 3, 400)
    s = mesopic_weight(y)
    assert np.all(np.diff(s) >= 0)
    assert np.all(s[y <= 1e-2] == 0.0)
    assert np.all(s[y >= 10**0.6] == 1.0)
    # smoothstep midpoint: log10 Y = -2 + 1.3 gives s = 0.5 exactly
    assert mesopic_weight(10.0**-0.7) == pytest.approx(0.5, abs=1e-12)


@pytest.mark.parametrize("light", LIGHTS)
def test_photopic_colours_kept_above_the_mesopic_range(light: np.ndarray) -> None:
    xyz = light * np.array([4.0, 10.0, 1000.0])[:, None]
    np.testing.assert_allclose(blue_shift(xyz), xyz, rtol=1e-12)


@pytest.mark.parametrize("light", LIGHTS)
def test_blue_shift_converges_to_the_blue_point_far_below(light: np.ndarray) -> None:
    xyz = light * np.array([1e-2, 1e-4, 1e-7])[:, None]
    shifted = blue_shift(xyz)
    np.testing.assert_allclose(chromaticity(shifted), [BLUE_POINT] * 3, atol=1e-12)
    # the luminance shown is 0.4468 of the scotopic luminance (Jensen et al. 2001, Sec. 7)
    np.testing.assert_allclose(shifted[:, 1], 0.4468 * scotopic_luminance(xyz), rtol=1e-12)


@pytest.mark.parametrize("light", LIGHTS)
def test_tone_map_is_monotonic_in_luminance(light: np.ndarray) -> None:
    luminance = np.logspace(-7, 4, 600)
    image = (luminance[:, None] * light)[:, None, :]
    for mode in ("eye", "photo"):
        rgb = tone_map(image, ToneMapping(mode=mode, exposure=30.0))[:, 0, :]
        shown = colour.sRGB_to_XYZ(rgb)[:, 1]  # the displayed luminance
        assert np.all(np.diff(shown) >= -1e-12), mode
        assert shown[-1] > shown[0]


def test_tone_map_keeps_photopic_chromaticity_and_shows_blue_far_below() -> None:
    light = blackbody_white(3000.0)
    bright = (10.0 * light)[None, None, :]
    dark = (1e-5 * light)[None, None, :]
    for xyz, expected in ((bright, chromaticity(light)), (dark, np.array(BLUE_POINT))):
        # exposure chosen so that the display value stays inside the sRGB cube
        rgb = tone_map(xyz, ToneMapping(exposure=0.2 / xyz[0, 0, 1], acuity_blur=False))
        back = colour.sRGB_to_XYZ(rgb[0, 0])
        np.testing.assert_allclose(chromaticity(back), expected, atol=2e-3)


def test_visual_acuity_follows_larson_and_blur_grows_in_the_dark() -> None:
    # Larson et al. 1997, Eq. 7 at L_a = 1 cd m-2: 17.25 atan(0.35) + 25.72
    assert visual_acuity(1.0) == pytest.approx(17.25 * np.arctan(0.35) + 25.72, rel=1e-12)
    sigmas = [acuity_blur_sigma(la) for la in (1e-5, 1e-3, 1.0, 100.0)]
    assert sigmas == sorted(sigmas, reverse=True)


def test_blur_keeps_a_uniform_sky_and_black_outside() -> None:
    xyz = np.full((40, 40, 3), 1e-4) * blackbody_white(6504.0)
    xyz[:5] = np.nan
    rgb = tone_map(xyz, ToneMapping(exposure=300.0), pixel_size=1.0)
    assert np.all(rgb[:5] == 0.0)
    np.testing.assert_allclose(rgb[5:], np.broadcast_to(rgb[20, 20], rgb[5:].shape), atol=1e-9)


def test_photo_white_balance_makes_the_light_neutral() -> None:
    xyz = (0.05 * blackbody_white(3000.0))[None, None, :]
    rgb = tone_map(xyz, ToneMapping(mode="photo", exposure=10.0, white_temperature=3000.0))
    assert np.ptp(rgb) < 2e-3
    raw = tone_map(xyz, ToneMapping(mode="photo", exposure=10.0))
    assert raw[0, 0, 0] > raw[0, 0, 2]  # without balance, 3000 K light is orange


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(InputError, match="mode"):
        ToneMapping(mode="film")
    with pytest.raises(InputError, match="exposure"):
        ToneMapping(exposure=0.0)
    with pytest.raises(InputError, match="colour temperature"):
        blackbody_white(500.0)
    with pytest.raises(InputError, match="log_range"):
        mesopic_weight(1.0, log_range=(1.0, -1.0))


def night_sky_sample() -> np.ndarray:
    """A sky from far below the mesopic range to above it, every light colour, some pixels
    with no sky (NaN), some black, and luminances above the display white."""
    rng = np.random.default_rng(5)
    luminance = 10.0 ** rng.uniform(-7.0, 3.0, (40, 60))
    lights = np.array(LIGHTS)[rng.integers(0, len(LIGHTS), (40, 60))]
    xyz = lights / lights[..., 1:2] * luminance[..., None]
    xyz[:3] = np.nan
    xyz[5, :10] = 0.0
    return xyz


TONE_MAPPINGS = [
    ToneMapping(),
    ToneMapping(acuity_blur=False, exposure=3e4),
    ToneMapping(mode="photo"),
    ToneMapping(mode="photo", white_temperature=4000.0, exposure=2e3),
]


@pytest.mark.parametrize("options", TONE_MAPPINGS)
@pytest.mark.parametrize("pixel_size", [0.05, 1.0])
def test_compiled_tone_map_equals_the_numpy_reference(
    options: ToneMapping, pixel_size: float
) -> None:
    from nightlights.nightsky.tonemap import _tone_map

    xyz = night_sky_sample()
    compiled = _tone_map(xyz, options, pixel_size, compiled=True)
    reference = _tone_map(xyz, options, pixel_size, compiled=False)
    np.testing.assert_allclose(compiled, reference, rtol=0, atol=1e-12)
    assert np.all(compiled[:3] == 0.0)


def test_compiled_blur_equals_scipy_with_and_without_sky_edges() -> None:
    from nightlights.nightsky.tonemap import _tone_map, acuity_blur_sigma

    # a dark sky (adaptation 1e-5 cd m-2) blurs by several pixels at 0.05 deg per pixel
    rng = np.random.default_rng(9)
    xyz = 1e-5 * 10.0 ** rng.uniform(-1.0, 1.0, (30, 50))[..., None] * blackbody_white(4000.0)
    assert acuity_blur_sigma(1e-5) / 0.05 > 3.0
    for edge in (False, True):
        if edge:
            xyz[:, :4] = np.nan  # sky edge: the blur is renormalised by the sky's share
        compiled = _tone_map(xyz, ToneMapping(), 0.05, compiled=True)
        reference = _tone_map(xyz, ToneMapping(), 0.05, compiled=False)
        np.testing.assert_allclose(compiled, reference, rtol=0, atol=1e-12)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1, written out here independently of the module."""
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)


@pytest.mark.parametrize("options", TONE_MAPPINGS)
def test_eight_bit_codes_are_the_rounded_reference(options: ToneMapping) -> None:
    from nightlights.nightsky.tonemap import _tone_map

    xyz = night_sky_sample()
    codes = tone_map(xyz, options, pixel_size=0.05, dtype=np.uint8)
    reference = _tone_map(xyz, options, 0.05, compiled=False)
    assert codes.dtype == np.uint8 and codes.shape == xyz.shape
    expected = np.floor(255.0 * reference + 0.5)
    # the compiled and numpy paths differ by rounding (1e-14): a value that close to a code
    # boundary may round either way; every other value gets exactly the rounded code
    near_boundary = np.abs(255.0 * reference + 0.5 - np.round(255.0 * reference + 0.5)) < 1e-9
    assert np.all((codes == expected) | near_boundary)
    assert np.all(np.abs(codes - expected) <= 1)
    assert np.all(codes[:3] == 0)


def test_eight_bit_code_steps_sit_on_the_srgb_boundaries() -> None:
    from nightlights.nightsky._tonemap_numba import display_codes
    from nightlights.nightsky.tonemap import _srgb8_table

    table, steps = _srgb8_table()
    assert steps.size == 255 and np.all(np.diff(steps) > 0)
    codes = np.floor(255.0 * srgb_encode(steps) + 0.5)
    below = np.floor(255.0 * srgb_encode(np.nextafter(steps, 0.0)) + 0.5)
    np.testing.assert_array_equal(codes, np.arange(1, 256))
    np.testing.assert_array_equal(below, np.arange(0, 255))
    # grey pixels (X, Y, Z of D65 white) at every boundary, a hair below and at it: through
    # the compiled lookup each gets the code of its linear value
    d65 = np.array([0.95047, 1.0, 1.08883])
    linear = np.concatenate([np.nextafter(steps, 0.0), steps, np.linspace(0.0, 1.0, 1001)])
    # identity display (photo mode, exposure 1): XYZ -> sRGB of a grey returns its Y
    xyz = linear[:, None] * d65 / d65[1]
    matrix = np.linalg.inv(
        np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    )
    out = display_codes(
        xyz[None],
        np.ones((1, linear.size), bool),
        np.ones(1),
        False,
        1.0,
        False,
        matrix,
        table,
        steps,
    )[0]
    grey = np.clip(xyz @ matrix.T, 0.0, 1.0)
    np.testing.assert_array_equal(out, np.searchsorted(steps, grey, side="right"))


def test_blackbody_table_equals_colour_science_integration() -> None:
    from nightlights.nightsky.tonemap import _blackbody_table

    log_t, table = _blackbody_table()
    shape = colour.SpectralShape(360, 830, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    for index in (0, 60, 120, 240):
        sd = colour.sd_blackbody(float(10.0 ** log_t[index]), shape)
        xyz = np.asarray(colour.sd_to_XYZ(sd, cmfs, method="Integration"), dtype=float)
        np.testing.assert_allclose(table[index], xyz / xyz[1], rtol=1e-12)
