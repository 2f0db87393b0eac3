"""Tone mapping of night scenes: the dark-adapted eye and the camera.

Linear CIE XYZ luminance [cd m-2] goes in, display sRGB in [0, 1] comes out. Two modes:

``eye`` (Jensen et al. 2001, Larson et al. 1997)
    the rods' scotopic luminance (:func:`scotopic_luminance`), a mesopic weight that blends
    rod and cone vision between about 0.01 and 4 cd m-2 (:func:`mesopic_weight`), the blue
    shift of scotopic vision toward an empirical blue point (:func:`blue_shift`), the loss of
    acuity at low luminance as a Gaussian blur (:func:`visual_acuity`), then a global
    compressive display curve (:func:`reinhard_global`) with a low key.
``photo``
    a camera: white balance (von Kries, :func:`white_balance`), linear exposure, clipping.

Every step is a pure function on arrays; :class:`ToneMapping` holds the parameters.

Length: 600+ lines because each step's numpy form (the published model and the reference) sits
beside the driver of the compiled passes (:mod:`._tonemap_numba`) that must equal it, and the
8-bit code table both share.

References
----------
1. Jensen, H. W., Durand, F., Stark, M. M., Premoze, S., Dorsey, J. & Shirley, P. (2001).
   A physically-based night sky model. Proc. SIGGRAPH 2001, 399-408, Sec. 7 (blue shift,
   mesopic weight s, blue point (0.25, 0.25), scotopic factor 0.4468).
2. Larson, G. W., Rushmeier, H. & Piatko, C. (1997). A visibility matching tone reproduction
   operator for high dynamic range scenes. IEEE TVCG 3(4), 291-306: scotopic luminance from
   XYZ (Eq. 2) and the visual acuity function fitted to Shaler 1937 (Eq. 7).
3. Reinhard, E., Stark, M., Shirley, P. & Ferwerda, J. (2002). Photographic tone reproduction
   for digital images. Proc. SIGGRAPH 2002, Eq. 1-3 (log-average luminance, key, L / (1 + L)).
4. IEC 61966-2-1 (1999): the sRGB transfer function; sRGB matrix via colour-science.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from nightlights.errors import InputError

FloatArray = NDArray[np.float64]

MODES = ("eye", "photo")

#: Blue point of scotopic vision in CIE xy chromaticity (Jensen et al. 2001, Sec. 7,
#: estimated from paintings of night scenes).
BLUE_POINT = (0.25, 0.25)
#: Factor from scotopic luminance to the achromatic luminance shown below the mesopic range
#: [1] (Jensen et al. 2001, Sec. 7).
SCOTOPIC_SCALE = 0.4468
#: log10 of the luminances [cd m-2] where the mesopic weight leaves 0 and reaches 1
#: (Jensen et al. 2001, Sec. 7: s = 0 below 10^-2, s = 1 above 10^0.6 = 3.98 cd m-2).
MESOPIC_LOG_RANGE = (-2.0, 0.6)
#: Key of a low-key scene: the display value of the log-average luminance before compression
#: [1] (Reinhard et al. 2002, Sec. 3.1, which gives 0.18 for normal and 0.045 for dark scenes).
NIGHT_KEY = 0.045


def scotopic_luminance(xyz: ArrayLike) -> FloatArray:
    """Scotopic (rod) luminance from CIE XYZ.

    .. math:: V = Y \\left[1.33\\left(1 + \\frac{Y + Z}{X}\\right) - 1.68\\right]

    Parameters
    ----------
    xyz
        ``(..., 3)`` tristimulus values [cd m-2].

    Returns
    -------
    numpy.ndarray
        ``(...)`` scotopic luminance [scotopic cd m-2]; 0 where X is 0, never negative.

    References
    ----------
    Larson et al. 1997, Eq. 2; Jensen et al. 2001, Sec. 7.

    Examples
    --------
    >>> round(float(scotopic_luminance([0.9505, 1.0, 1.089])), 3)  # D65 white, Y = 1
    2.573
    """
    values = np.asarray(xyz, dtype=float)
    x, y, z = values[..., 0], values[..., 1], values[..., 2]
    ratio = np.divide(y + z, x, out=np.zeros_like(x), where=x > 0)
    scotopic = y * (1.33 * (1.0 + ratio) - 1.68)
    return np.where(x > 0, np.maximum(scotopic, 0.0), 0.0)


def mesopic_weight(
    luminance: ArrayLike, *, log_range: tuple[float, float] = MESOPIC_LOG_RANGE
) -> FloatArray:
    """Weight of cone (photopic) vision: 0 scotopic, 1 photopic, smooth in between.

    .. math::
        t = \\frac{\\log_{10} Y - a}{b - a},\\quad s = 3t^2 - 2t^3 \\text{ for } 0 \\le t \\le 1

    Parameters
    ----------
    luminance
        Photopic luminance Y [cd m-2].
    log_range
        ``(a, b)``: log10 of the luminances [cd m-2] where s leaves 0 and reaches 1.

    Returns
    -------
    numpy.ndarray
        s in [0, 1], non-decreasing in luminance.

    References
    ----------
    Jensen et al. 2001, Sec. 7.

    Examples
    --------
    >>> [round(float(s), 3) for s in mesopic_weight([1e-3, 0.1, 10.0])]
    [0.0, 0.33, 1.0]
    """
    low, high = log_range
    if not high > low:
        raise InputError(f"log_range {log_range}: expected low < high [log10 cd m-2]")
    y = np.asarray(luminance, dtype=float)
    with np.errstate(divide="ignore"):
        t = np.clip((np.log10(np.maximum(y, 0.0)) - low) / (high - low), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def blue_shift(
    xyz: ArrayLike,
    *,
    blue_point: tuple[float, float] = BLUE_POINT,
    scotopic_scale: float = SCOTOPIC_SCALE,
    log_range: tuple[float, float] = MESOPIC_LOG_RANGE,
) -> FloatArray:
    """Night-vision colour: blend of photopic colour and the blue-shifted scotopic grey.

    .. math::
        x' = (1 - s) x_b + s x,\\quad y' = (1 - s) y_b + s y,\\quad
        Y' = 0.4468 (1 - s) V + s Y

    with s the :func:`mesopic_weight` of Y and V the :func:`scotopic_luminance`.

    Parameters
    ----------
    xyz
        ``(..., 3)`` tristimulus values [cd m-2].
    blue_point
        CIE xy chromaticity that scotopic vision tends to [1].
    scotopic_scale
        Factor from scotopic luminance to the luminance shown [1].
    log_range
        Mesopic range, see :func:`mesopic_weight` [log10 cd m-2].

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` perceived XYZ [cd m-2]: unchanged above the mesopic range, of chromaticity
        ``blue_point`` below it.

    References
    ----------
    Jensen et al. 2001, Sec. 7.
    """
    values = np.asarray(xyz, dtype=float)
    y = values[..., 1]
    s = mesopic_weight(y, log_range=log_range)
    total = values.sum(axis=-1)
    safe = total > 0
    x_chrom = np.divide(values[..., 0], total, out=np.full_like(y, blue_point[0]), where=safe)
    y_chrom = np.divide(y, total, out=np.full_like(y, blue_point[1]), where=safe)
    x_new = (1.0 - s) * blue_point[0] + s * x_chrom
    y_new = (1.0 - s) * blue_point[1] + s * y_chrom
    lum = scotopic_scale * (1.0 - s) * scotopic_luminance(values) + s * y
    big_x = x_new * lum / y_new
    big_z = (1.0 - x_new - y_new) * lum / y_new
    return np.stack([big_x, lum, big_z], axis=-1)


def visual_acuity(adaptation_luminance: ArrayLike) -> FloatArray:
    """Highest spatial frequency the eye resolves at an adaptation luminance.

    .. math:: R = 17.25 \\arctan(1.4 \\log_{10} L_a + 0.35) + 25.72

    Parameters
    ----------
    adaptation_luminance
        Adaptation luminance L_a [cd m-2].

    Returns
    -------
    numpy.ndarray
        Resolvable frequency [cycles deg-1], at least 0.5 (the fit is not used below it).

    References
    ----------
    Larson et al. 1997, Eq. 7 (fit to Shaler 1937).

    Examples
    --------
    >>> [round(float(r), 1) for r in visual_acuity([1e-4, 1.0, 100.0])]
    [1.9, 31.5, 47.5]
    """
    la = np.maximum(np.asarray(adaptation_luminance, dtype=float), 1e-12)
    return np.maximum(17.25 * np.arctan(1.4 * np.log10(la) + 0.35) + 25.72, 0.5)


def acuity_blur_sigma(adaptation_luminance: float) -> float:
    """Standard deviation of the Gaussian blur that removes detail the eye cannot resolve [deg].

    A Gaussian's modulation transfer exp(-2 pi^2 sigma^2 f^2) falls to one half at the
    resolvable frequency R of :func:`visual_acuity`: sigma = sqrt(ln 2 / 2) / (pi R).

    Parameters
    ----------
    adaptation_luminance
        Adaptation luminance [cd m-2].

    Returns
    -------
    float
        Blur sigma [deg].
    """
    return float(np.sqrt(np.log(2.0) / 2.0) / (np.pi * visual_acuity(adaptation_luminance)))


def log_average_luminance(luminance: ArrayLike, *, floor: float = 1e-9) -> float:
    """Log-average (geometric mean) luminance of the finite pixels [cd m-2].

    Parameters
    ----------
    luminance
        Luminance [cd m-2]; NaN pixels are skipped.
    floor
        Added inside the logarithm so that black pixels do not give -inf [cd m-2].

    Returns
    -------
    float
        exp(mean(log(floor + L))) [cd m-2].

    References
    ----------
    Reinhard et al. 2002, Eq. 1.
    """
    values = np.asarray(luminance, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return floor
    return float(np.exp(np.mean(np.log(floor + np.maximum(values, 0.0)))))


def reinhard_global(luminance: ArrayLike, scale: float) -> FloatArray:
    """Global compressive display curve L_d = L_s / (1 + L_s) with L_s = scale x L [1].

    Parameters
    ----------
    luminance
        Scene luminance [cd m-2].
    scale
        Exposure: display value per unit luminance before compression [m2 cd-1].

    Returns
    -------
    numpy.ndarray
        Display luminance in [0, 1), strictly increasing in luminance.

    References
    ----------
    Reinhard et al. 2002, Eq. 2-3.
    """
    scaled = scale * np.maximum(np.asarray(luminance, dtype=float), 0.0)
    return scaled / (1.0 + scaled)


def white_balance(xyz: ArrayLike, source_temperature: float) -> FloatArray:
    """Camera white balance: von Kries adaptation (CAT02) from a blackbody white to D65.

    Parameters
    ----------
    xyz
        ``(..., 3)`` tristimulus values [cd m-2].
    source_temperature
        Colour temperature of the light that should look white [K].

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` adapted XYZ [cd m-2]: light of the source colour becomes the sRGB white
        (D65) of the same luminance.
    """
    from ies.spectra import colour_science

    colour = colour_science()

    source = blackbody_white(source_temperature)
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    target = np.array([d65[0] / d65[1], 1.0, (1.0 - d65[0] - d65[1]) / d65[1]])
    return np.asarray(
        colour.adaptation.chromatic_adaptation_VonKries(
            np.asarray(xyz, dtype=float), source, target, transform="CAT02"
        ),
        dtype=float,
    )


#: Colour temperatures of the blackbody chromaticity table [K], log-spaced.
BLACKBODY_TABLE_RANGE = (1000.0, 100000.0)


@functools.cache
def _blackbody_table() -> tuple[FloatArray, FloatArray]:
    """log10 T and the XYZ (Y = 1) of blackbodies, CIE 1931 2-degree observer, 360-830 nm."""
    from ies.spectra import colour_science

    colour = colour_science()

    temperatures = np.geomspace(*BLACKBODY_TABLE_RANGE, 241)
    shape = colour.SpectralShape(360, 830, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    wavelengths = np.asarray(cmfs.wavelengths, dtype=float) * 1e-9  # [m]
    # Planck's law at every temperature, integrated against the CMFs in one product (the
    # sums of colour.sd_to_XYZ's "Integration", whose constant factor Y = 1 removes)
    radiance = np.stack([colour.colorimetry.planck_law(wavelengths, t) for t in temperatures])
    xyz = radiance @ np.asarray(cmfs.values, dtype=float)
    return np.log10(temperatures), xyz / xyz[:, 1:2]


def blackbody_white(temperature: ArrayLike) -> FloatArray:
    """XYZ of a blackbody scaled to luminance 1 (Y = 1) [1].

    Planck's law integrated with the CIE 1931 2-degree colour matching functions (colour-science),
    tabulated at 241 temperatures and interpolated in log T (the chromaticity changes by less
    than 1e-3 between entries).

    Parameters
    ----------
    temperature
        Colour temperature [K], 1000-100000.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` XYZ with Y = 1.

    Examples
    --------
    >>> xyz = blackbody_white(6504.0)
    >>> [round(float(v / xyz.sum()), 3) for v in xyz[:2]]  # near D65 (0.3127, 0.3290)
    [0.313, 0.324]
    """
    t = np.asarray(temperature, dtype=float)
    low, high = BLACKBODY_TABLE_RANGE
    if np.any(~np.isfinite(t)) or np.any((t < low) | (t > high)):
        bad = t[~((t >= low) & (t <= high))].ravel()[0]
        raise InputError(f"colour temperature {bad} K: expected {low:g}-{high:g} K")
    log_t, table = _blackbody_table()
    out = np.stack([np.interp(np.log10(t), log_t, table[:, i]) for i in range(3)], axis=-1)
    return out


def xyz_to_srgb(xyz: ArrayLike) -> FloatArray:
    """Display XYZ (Y = 1 is display white) to gamma-encoded sRGB in [0, 1].

    Colours outside the sRGB gamut are brought in by desaturating them toward the grey of the
    same luminance (the least mixing that puts every channel in [0, 1]), and luminances above 1
    become white, so that the displayed luminance is min(Y, 1) exactly and the mapping keeps
    the order of luminances (per-channel clipping would not: a saturated red channel would
    stop the luminance from rising while the colour still shifts).

    Parameters
    ----------
    xyz
        ``(..., 3)`` display tristimulus values [1].

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` sRGB in [0, 1]; NaN pixels become 0.

    References
    ----------
    IEC 61966-2-1 (1999).
    """
    values = np.nan_to_num(np.asarray(xyz, dtype=float), nan=0.0)
    linear = values @ _srgb_matrix().T
    luminance = np.maximum(values[..., 1], 0.0)
    over = luminance > 1.0
    if np.any(over):
        linear[over] /= luminance[over][:, None]
    grey = np.minimum(luminance, 1.0)[..., None]
    away = linear - grey
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(away > 0, (1.0 - grey) / away, np.where(away < 0, grey / -away, np.inf))
    mix = np.clip(np.min(room, axis=-1, keepdims=True), 0.0, 1.0)
    linear = np.clip(grey + mix * away, 0.0, 1.0)
    # IEC 61966-2-1 transfer function
    return np.where(
        linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055
    )


@functools.cache
def _srgb_matrix() -> FloatArray:
    """XYZ to linear sRGB (D65) matrix of colour-science."""
    from ies.spectra import colour_science

    colour = colour_science()

    return np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB, dtype=float)


@dataclass(frozen=True)
class ToneMapping:
    """Parameters of the tone mapping from linear XYZ [cd m-2] to display sRGB.

    Attributes
    ----------
    mode
        ``eye`` (night vision) or ``photo`` (camera).
    exposure
        Display value per unit luminance [m2 cd-1]. ``eye``: the scale before the compressive
        curve, default ``key`` over the log-average luminance; ``photo``: the linear scale
        before clipping, default 1 over 20 times the log-average luminance.
    key
        ``eye``: the display value of the log-average luminance [1].
    blue_point, scotopic_scale, mesopic_log_range
        Blue shift parameters, see :func:`blue_shift`.
    acuity_blur
        ``eye``: blur by the resolvable frequency at the adaptation luminance.
    adaptation_luminance
        Adaptation luminance [cd m-2]; default the log-average luminance of the image.
    white_temperature
        ``photo``: the light that should look white [K]; None keeps the colours as measured.
    """

    mode: str = "eye"
    exposure: float | None = None
    key: float = NIGHT_KEY
    blue_point: tuple[float, float] = BLUE_POINT
    scotopic_scale: float = SCOTOPIC_SCALE
    mesopic_log_range: tuple[float, float] = MESOPIC_LOG_RANGE
    acuity_blur: bool = True
    adaptation_luminance: float | None = None
    white_temperature: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise InputError(f"tone mapping mode {self.mode!r}; expected one of {MODES}")
        if self.exposure is not None and not self.exposure > 0:
            raise InputError(f"exposure {self.exposure}: expected a positive number [m2 cd-1]")
        if not self.key > 0:
            raise InputError(f"key {self.key}: expected a positive number")


def tone_map(
    xyz: ArrayLike,
    options: ToneMapping | None = None,
    *,
    pixel_size: float | None = None,
    dtype: DTypeLike = np.float64,
) -> NDArray[Any]:
    """Tone-map a linear XYZ image to sRGB.

    Parameters
    ----------
    xyz
        ``(rows, cols, 3)`` tristimulus values [cd m-2]; NaN pixels (no sky) stay black.
    options
        Parameters (default ``ToneMapping()``: the dark-adapted eye).
    pixel_size
        Angular size of a pixel [deg], for the acuity blur; None skips the blur.
    dtype
        ``numpy.float64``: sRGB values in [0, 1]; ``numpy.uint8``: the 8-bit code values
        floor(255 v + 0.5) of an image file, made without the float image.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols, 3)`` sRGB in [0, 1], or its 8-bit code values [0-255].

    Examples
    --------
    >>> xyz = np.full((2, 4, 3), 1e-3) * blackbody_white(6504.0)  # a dark grey sky
    >>> tone_map(xyz, ToneMapping(mode="photo", exposure=100.0), dtype=np.uint8)[0, 0]
    array([91, 88, 91], dtype=uint8)
    """
    return _tone_map(xyz, options, pixel_size, compiled=True, dtype=dtype)


#: Added to the luminance inside the logarithm of the log-average [cd m-2]
#: (:func:`log_average_luminance`'s default).
LOG_AVERAGE_FLOOR = 1e-9
#: Gaussian blurs narrower than this are skipped [pixel]: the kernel truncated at 4 sigma
#: (scipy.ndimage's default) is then three taps whose outer weights are below 0.5 %.
MIN_BLUR_SIGMA = 0.3
#: Half-width of the blur kernel [sigma] (scipy.ndimage's default truncation).
BLUR_TRUNCATE = 4.0


def _tone_map(
    xyz: ArrayLike,
    options: ToneMapping | None,
    pixel_size: float | None,
    *,
    compiled: bool,
    dtype: DTypeLike = np.float64,
) -> NDArray[Any]:
    """:func:`tone_map` compiled (:mod:`._tonemap_numba`) or in numpy (the reference)."""
    options = options if options is not None else ToneMapping()
    kind = np.dtype(dtype)
    if kind not in (np.dtype(np.float64), np.dtype(np.uint8)):
        raise InputError(f"tone map dtype {kind}: expected float64 or uint8")
    codes = kind == np.dtype(np.uint8)
    if options.mode == "eye":
        low, high = options.mesopic_log_range
        if not high > low:
            raise InputError(f"log_range {(low, high)}: expected low < high [log10 cd m-2]")
    values = np.asarray(xyz, dtype=float)
    if compiled:
        return _tone_map_compiled(values, options, pixel_size, codes=codes)
    valid = np.all(np.isfinite(values), axis=-1)
    values = np.where(valid[..., None], np.maximum(values, 0.0), 0.0)
    adaptation = (
        options.adaptation_luminance
        if options.adaptation_luminance is not None
        else log_average_luminance(np.where(valid, values[..., 1], np.nan))
    )
    if options.mode == "photo":
        if options.white_temperature is not None:
            values = white_balance(values, options.white_temperature)
        scale = options.exposure if options.exposure is not None else 1.0 / (20.0 * adaptation)
        display = scale * values
    else:
        values = blue_shift(
            values,
            blue_point=options.blue_point,
            scotopic_scale=options.scotopic_scale,
            log_range=options.mesopic_log_range,
        )
        if options.acuity_blur and pixel_size is not None and pixel_size > 0:
            values = _blur(values, valid, acuity_blur_sigma(adaptation) / pixel_size)
        scale = options.exposure if options.exposure is not None else options.key / adaptation
        lum = values[..., 1]
        compressed = reinhard_global(lum, scale)
        ratio = np.divide(compressed, lum, out=np.zeros_like(lum), where=lum > 0)
        display = values * ratio[..., None]
    rgb = np.where(valid[..., None], xyz_to_srgb(display), 0.0)
    if codes:
        return np.floor(255.0 * rgb + 0.5).astype(np.uint8)
    return rgb


def _tone_map_compiled(
    values: FloatArray, options: ToneMapping, pixel_size: float | None, *, codes: bool
) -> NDArray[Any]:
    """The compiled tone mapping: two parallel passes, no full-size temporaries."""
    from nightlights.nightsky import _tonemap_numba as compiled

    shape = values.shape
    eye = options.mode == "eye"
    low, high = options.mesopic_log_range
    flat, valid, log_sum, count = compiled.perceived_pixels(
        np.ascontiguousarray(values.reshape(-1, 3)),
        LOG_AVERAGE_FLOOR,
        eye and options.white_temperature is None,
        *options.blue_point,
        options.scotopic_scale,
        low,
        high,
    )
    if options.adaptation_luminance is not None:
        adaptation = options.adaptation_luminance
    else:
        adaptation = math.exp(log_sum / count) if count else LOG_AVERAGE_FLOOR
    weights = np.ones(1)
    if not eye:
        if options.white_temperature is not None:
            flat = white_balance(flat, options.white_temperature)
        scale = options.exposure if options.exposure is not None else 1.0 / (20.0 * adaptation)
    else:
        if options.acuity_blur and pixel_size is not None and pixel_size > 0:
            sigma = acuity_blur_sigma(adaptation) / pixel_size
            if sigma >= MIN_BLUR_SIGMA:
                weights = _gaussian_weights(sigma)
        scale = options.exposure if options.exposure is not None else options.key / adaptation
    image = flat.reshape(-1, shape[-2] if len(shape) > 2 else 1, 3)
    mask = valid.reshape(image.shape[:2])
    renormalise = weights.size > 1 and not valid.all()
    arguments = (image, mask, weights, renormalise, float(scale), eye, _srgb_matrix())
    if codes:
        out = compiled.display_codes(*arguments, *_srgb8_table())
    else:
        out = compiled.display_pixels(*arguments)
    return out.reshape(shape)


def _gaussian_weights(sigma: float) -> FloatArray:
    """The 1-D Gaussian kernel of scipy.ndimage.gaussian_filter: taps to 4 sigma, sum 1."""
    radius = int(BLUR_TRUNCATE * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 / (sigma * sigma) * x**2)
    return weights / weights.sum()


#: Entries of the table that starts the search for an 8-bit code [1]: 4096 bins over [0, 1]
#: hold at most two code steps each (the steepest part of the sRGB curve, its linear segment,
#: steps every 1 / (255 x 12.92) = 3.0e-4).
CODE_TABLE_SIZE = 4096


@functools.cache
def _srgb8_table() -> tuple[NDArray[np.uint8], FloatArray]:
    """The code table and the 255 linear values where the 8-bit sRGB code steps up.

    The code is floor(255 encode(v) + 0.5). Code k starts where the encoded value reaches
    (k - 0.5) / 255; the inverse transfer function gives the linear value, then steps of one
    unit in the last place put it on the first double whose code, as the numpy transfer
    function computes it, is k. The table holds the code at each of ``CODE_TABLE_SIZE`` evenly
    spaced linear values.
    """

    def code(linear: FloatArray) -> FloatArray:
        encoded = np.where(
            linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055
        )
        return np.floor(255.0 * encoded + 0.5)

    k = np.arange(1, 256, dtype=float)
    level = (k - 0.5) / 255.0
    start = np.where(level <= 0.04045, level / 12.92, ((level + 0.055) / 1.055) ** 2.4)
    for _ in range(64):
        reached = code(start) >= k
        below = np.nextafter(start, 0.0)
        down = reached & (code(below) >= k)  # the double below is already code k
        if not (down.any() or not reached.all()):
            break
        start = np.where(down, below, np.where(reached, start, np.nextafter(start, 1.0)))
    grid = np.linspace(0.0, 1.0, CODE_TABLE_SIZE)
    table = np.searchsorted(start, grid, side="right").astype(np.uint8)
    return table, start


def _blur(values: FloatArray, valid: NDArray[np.bool_], sigma_pixels: float) -> FloatArray:
    """Gaussian blur of the sky pixels only (normalised so the edge of the sky is not darkened)."""
    from scipy.ndimage import gaussian_filter

    if sigma_pixels < MIN_BLUR_SIGMA:
        return values
    # one pass over the three channels, none across them
    blurred = gaussian_filter(
        values, (sigma_pixels, sigma_pixels, 0.0), mode="nearest", truncate=BLUR_TRUNCATE
    )
    if valid.all():  # nothing to renormalise: the weight is 1 everywhere
        return blurred
    weight = gaussian_filter(
        valid.astype(float), sigma_pixels, mode="nearest", truncate=BLUR_TRUNCATE
    )
    return np.divide(
        blurred, weight[..., None], out=np.zeros_like(blurred), where=weight[..., None] > 0
    )
