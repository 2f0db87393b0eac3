"""Emission functions of the skyglow kernel: Garstang's (1986) low-angle lobe and its mixes.

Sources: Garstang, R. H. 1986, PASP 98, 364-375 (the emission function
(2 G (1 - F) cos psi + 0.554 F psi^4) / (2 pi) per lumen of a city's output).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from scipy.integrate import quad

from nightlights.emission_functions import (
    DEFAULT_EMISSION_FUNCTION,
    EMISSION_FUNCTION_TAG,
    EmissionFunction,
)
from nightlights.errors import InputError
from nightlights.ground.upward import (
    emission_from_viirs,
    flux_density_to_viirs_radiance,
    viirs_radiance_to_flux_density,
)
from nightlights.io import Raster
from nightlights.sky import Observer, Scene, _kernel_numba
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.build import compute_kernel
from nightlights.sky.forward import skyglow_panorama
from nightlights.sky.kernel import (
    GARSTANG_LOBE_NORM,
    emission_intensity,
    garstang_weights,
    parse_tabulated_emission,
    sky_luminance,
)
from nightlights.sky.panorama import (
    band_slice,
    kernel_slice,
    panorama_exact,
    panorama_naive,
    panorama_pca,
)
from nightlights.sky.polar import polar_map
from nightlights.sky.setup import band_emission_functions
from nightlights.sky.spec import KernelSpec


def test_garstang_lobe_normalisation_is_garstangs_0554() -> None:
    """c = 1 / int_0^{pi/2} psi^4 sin psi dpsi, by quadrature and in closed form; Garstang
    (1986) prints 0.554."""
    integral = quad(lambda psi: psi**4 * math.sin(psi), 0.0, math.pi / 2)[0]
    assert GARSTANG_LOBE_NORM == pytest.approx(1.0 / integral, rel=1e-12)
    assert round(GARSTANG_LOBE_NORM, 3) == 0.554
    flux = quad(
        lambda psi: (
            2 * math.pi * math.sin(psi) * float(emission_intensity(math.cos(psi), "garstang_lobe"))
        ),
        0.0,
        math.pi / 2,
    )[0]
    assert flux == pytest.approx(1.0, rel=1e-10)


def test_garstang_lobe_shape() -> None:
    """Zero at the zenith, growing as psi^4 towards the horizon, nothing below it."""
    psi = np.radians([0.0, 30.0, 60.0, 90.0])
    intensity = emission_intensity(np.cos(psi), "garstang_lobe")
    assert intensity[0] == 0.0
    np.testing.assert_allclose(
        intensity[1:], GARSTANG_LOBE_NORM * psi[1:] ** 4 / (2 * math.pi), rtol=1e-12
    )
    assert float(emission_intensity(-0.2, "garstang_lobe")) == 0.0


def test_sin4_lobe_half_flux_and_half_intensity() -> None:
    """The sin^4 lobe: half its flux within 16.3 deg of the horizon; its intensity halves
    32.8 deg above it (sin^4 theta = 1/2)."""

    def fraction(elevation_deg: float) -> float:
        edge = math.sin(math.radians(elevation_deg))
        return 2 * math.pi * quad(lambda mu: float(emission_intensity(mu, "uplight")), 0, edge)[0]

    assert fraction(16.3) == pytest.approx(0.5, abs=2e-3)
    half = 90.0 - math.degrees(math.asin(0.5**0.25))
    assert half == pytest.approx(32.8, abs=0.05)
    mu = math.cos(math.radians(90.0 - half))
    assert float(emission_intensity(mu, "uplight")) == pytest.approx(
        0.5 * float(emission_intensity(1e-12, "uplight")), rel=1e-12
    )


def test_garstang_weights() -> None:
    """F = G = 0.15: 0.459 Lambertian + 0.541 lobe; the mix is Garstang's function per
    upward lumen."""
    w = garstang_weights(0.15, 0.15)
    assert w["lambertian"] == pytest.approx(0.459, abs=5e-4)
    assert w["garstang_lobe"] == pytest.approx(0.541, abs=5e-4)
    f, g = 0.1, 0.2
    w = garstang_weights(f, g)
    mu = np.linspace(0.01, 1.0, 50)
    mix = w["lambertian"] * emission_intensity(mu, "lambertian") + w[
        "garstang_lobe"
    ] * emission_intensity(mu, "garstang_lobe")
    psi = np.arccos(mu)
    garstang = (2 * g * (1 - f) * mu + GARSTANG_LOBE_NORM * f * psi**4) / (2 * math.pi)
    np.testing.assert_allclose(mix, garstang / (g * (1 - f) + f), rtol=1e-12)
    assert garstang_weights(0.0, 0.3) == {"lambertian": 1.0, "garstang_lobe": 0.0}
    for bad in ((-0.1, 0.1), (0.1, 1.5), (0.0, 0.0), (float("nan"), 0.1)):
        with pytest.raises(InputError, match="Garstang"):
            garstang_weights(*bad)


#: A tabulated emission function peaking 10 deg above the horizon.
PEAKED = 'tabulated:{"angles": [0, 30, 60, 80, 90], "intensities": [0.2, 0.3, 1.0, 2.0, 0.5]}'


@pytest.mark.parametrize("emission", ["garstang_lobe", PEAKED])
@pytest.mark.parametrize(
    "atmosphere", [Atmosphere(), Atmosphere(flat_earth=True), Atmosphere(extinction=False)]
)
def test_new_shapes_numba_match_numpy(emission: str, atmosphere: Atmosphere) -> None:
    """The compiled lobe and tabulated branch against the numpy reference, per ray and on
    the grid form."""
    rng = np.random.default_rng(3)
    n = 800
    el = rng.uniform(0.5, 90.0, n)
    az = rng.uniform(0.0, 360.0, n)
    r = np.exp(rng.uniform(np.log(5.0), np.log(3e5), n))
    h_c = rng.choice([0.0, 400.0], n)
    h_o = rng.choice([0.0, 1000.0], n)
    kw = {"atmosphere": atmosphere, "emission": emission, "nodes": 12}
    ref = sky_luminance(
        el, az, r, source_altitude=h_c, observer_altitude=h_o, backend="numpy", **kw
    )
    fast = sky_luminance(
        el, az, r, source_altitude=h_c, observer_altitude=h_o, backend="numba", **kw
    )
    assert np.array_equal(ref > 0, fast > 0) and (ref > 0).mean() > 0.5
    np.testing.assert_allclose(fast, ref, rtol=1e-6)
    e, a, d = np.array([5.0, 30.0, 80.0]), np.linspace(0, 180, 7), np.geomspace(50, 2e5, 6)
    grid = _kernel_numba.luminance_grid(
        e,
        a,
        d,
        source_altitude=0.0,
        observer_altitude=0.0,
        core_radius=1.0,
        uplight_exponent=4.0,
        **kw,
    )
    rays = sky_luminance(
        e[:, None, None], a[None, :, None], d[None, None, :], backend="numpy", **kw
    )
    np.testing.assert_allclose(grid, rays, rtol=5e-5, atol=1e-30)


# -- validation 2: far-field slopes over a flat Earth without extinction -------------------

FLAT_CLEAR = Atmosphere(flat_earth=True, extinction=False)
FAR_FIELD = (3e5, 5.5e5, 1e6)  # [m]


def _zenith_reference(distance: float, emission: str) -> float:
    """Zenith luminance per lumen by adaptive 1-D quadrature in the scattering height z
    (flat Earth, no extinction: s^2 = D^2 + z^2, cos(emission) = z / s, cos(scattering) =
    -z / s), independent of the kernel's panels and substitution [cd m-2 lm-1]."""

    def integrand(z: float) -> float:
        s = math.hypot(distance, z)
        value = FLAT_CLEAR.scattering(z, -z / s) * emission_intensity(z / s, emission)
        return float(value) / (s * s + 1.0)  # core radius 1 m, as sky_luminance

    top = FLAT_CLEAR.top_altitude
    return quad(integrand, 0.0, top, limit=400, points=[1e3, 5e3, 2e4], epsrel=1e-11)[0]


def _local_slope(distance: float, emission: str, **kwargs: float) -> float:
    """d ln L / d ln D of the zenith luminance by a central difference (+-2 %)."""
    step = 1.02
    near, far = (
        float(
            sky_luminance(
                90.0, 0.0, distance * f, atmosphere=FLAT_CLEAR, emission=emission, **kwargs
            )
        )
        for f in (1.0 / step, step)
    )
    return math.log(far / near) / (2.0 * math.log(step))


@pytest.mark.parametrize("emission", ["lambertian", "uplight", "garstang_lobe"])
def test_far_field_zenith_matches_a_one_dimensional_quadrature(emission: str) -> None:
    """The kernel's zenith luminance 300-1000 km away equals the 1-D reference (measured
    agreement 1e-8)."""
    for distance in FAR_FIELD:
        b = float(sky_luminance(90.0, 0.0, distance, atmosphere=FLAT_CLEAR, emission=emission))
        assert b == pytest.approx(_zenith_reference(distance, emission), rel=1e-6)


@pytest.mark.parametrize(
    ("emission", "exponent", "slope"),
    [
        ("lambertian", 4.0, -3.0),
        ("uplight", 2.0, -2.0),
        ("uplight", 4.0, -2.0),
        ("uplight", 8.0, -2.0),
    ],
)
def test_far_field_slopes_lambertian_and_sin_n(
    emission: str, exponent: float, slope: float
) -> None:
    """Far field D >> H: Lambertian I ~ cos = z / D gives D^-3, a sin^n lobe (I -> its
    horizontal value, to second order in z / D) D^-2. Local slopes 300-1000 km within 0.02
    (measured: -2.995 to -2.999; n = 4: -1.994 to -1.999)."""
    for distance in FAR_FIELD:
        measured = _local_slope(distance, emission, uplight_exponent=exponent)
        assert measured == pytest.approx(slope, abs=0.02)


def test_far_field_slope_of_the_garstang_lobe() -> None:
    """psi^4 has a non-zero slope at the horizon: with psi = pi/2 - z/D + O((z/D)^3),
    I ~ (pi/2)^4 (1 - (8/pi) z / D), so L ~ D^-2 (1 - (8/pi) <z> / D) and the local slope is
    -2 + (8/pi) <z> / D, <z> the scattering-weighted mean height at 90 deg (6.1 km here):
    -1.949 at 300 km, -1.984 at 1000 km (first-order prediction within 0.001). The slope
    tends to -2 but is within 0.02 of it only beyond ~800 km."""

    def weight(z: float) -> float:
        return float(FLAT_CLEAR.scattering(z, 0.0))

    top = FLAT_CLEAR.top_altitude
    mean_height = (
        quad(lambda z: z * weight(z), 0, top, limit=200)[0] / quad(weight, 0, top, limit=200)[0]
    )
    assert 5e3 < mean_height < 7e3
    slopes = [_local_slope(d, "garstang_lobe") for d in FAR_FIELD]
    for distance, measured in zip(FAR_FIELD, slopes, strict=True):
        assert measured == pytest.approx(-2.0 + 8.0 / math.pi * mean_height / distance, abs=0.003)
    assert slopes[-1] == pytest.approx(-2.0, abs=0.02)
    assert -1.9 > slopes[0] > slopes[1] > slopes[2] > -2.0


# -- kernel tables of the lobe and band mixes -----------------------------------------------

SMALL = {"r_min": 5.0, "r_max": 20_000.0, "n_distance": 16, "n_elevation": 8, "n_azimuth": 32}


@pytest.fixture(scope="module")
def lobe_kernel() -> xr.Dataset:
    """Lambertian, uplight and Garstang-lobe tables with shared bases (~1 s)."""
    spec = KernelSpec(**SMALL, uplight=True, garstang_lobe=True, source_altitudes=(0.0, 100.0))
    return compute_kernel(spec, progress=False)


def test_lobe_table_shares_the_bases(lobe_kernel: xr.Dataset) -> None:
    """One basis for every shape; each shape's images are its coefficients times the bases
    (to the PCA energy target), and the Lambertian and uplight images are those of a kernel
    without the lobe."""
    k = lobe_kernel.sizes["component"]
    basis = lobe_kernel["basis"].values.reshape(1, k, -1)
    for image, coefficient in (
        ("kernel", "coefficient"),
        ("kernel_uplight", "coefficient_uplight"),
        ("kernel_garstang_lobe", "coefficient_garstang_lobe"),
    ):
        table = lobe_kernel[image].values
        rebuilt = np.einsum("ocrk,okp->ocrp", lobe_kernel[coefficient].values, basis)
        error = np.abs(rebuilt - table.reshape(rebuilt.shape)).max() / table.max()
        assert error < 2e-3, image
    spec = KernelSpec(**SMALL, uplight=True, source_altitudes=(0.0, 100.0))
    plain = compute_kernel(spec, progress=False)
    np.testing.assert_array_equal(plain["kernel"].values, lobe_kernel["kernel"].values)
    np.testing.assert_array_equal(
        plain["kernel_uplight"].values, lobe_kernel["kernel_uplight"].values
    )
    assert lobe_kernel.attrs["garstang_lobe"] == 1 and plain.attrs["garstang_lobe"] == 0


def test_spec_round_trip_and_hash_of_kernels_without_the_lobe() -> None:
    """The lobe changes the hash only when tabulated: cached kernels keep theirs."""
    plain, lobe = KernelSpec(**SMALL), KernelSpec(**SMALL, garstang_lobe=True)
    assert "garstang_lobe" not in plain.parameters()
    assert plain.content_hash != lobe.content_hash
    assert KernelSpec.from_attrs(lobe.to_attrs()) == lobe
    legacy = {k: v for k, v in plain.to_attrs().items() if k != "garstang_lobe"}
    assert KernelSpec.from_attrs(legacy) == plain
    assert lobe.emissions == ("lambertian", "garstang_lobe")


def test_emission_function_tags() -> None:
    assert EmissionFunction.parse("lambertian").weights == (("lambertian", 1.0),)
    assert EmissionFunction.parse(" Uplight ").tag == "uplight"
    f = EmissionFunction.parse("garstang:0.1,0.2")
    assert f.tag == "garstang:0.1,0.2"
    assert dict(f.weights) == pytest.approx(garstang_weights(0.1, 0.2))
    for bad in ("cosine", "garstang:0.1", "garstang:a,b", "garstang:2,0.1", "lambertian:1"):
        with pytest.raises(InputError, match="emission_function"):
            EmissionFunction.parse(bad)


def _one_band_scene() -> tuple[np.ndarray, Affine]:
    emission = np.zeros((1, 40, 40))
    emission[0, 5:9, 30:34] = 2.0
    emission[0, 25, 3] = 40.0
    emission[0, 20, 21] = 5.0  # next to the observer
    return emission, Affine(100.0, 0.0, 0.0, 0.0, -100.0, 4000.0)


def test_a_band_mix_reads_the_mix_of_coefficient_tables(lobe_kernel: xr.Dataset) -> None:
    """garstang:F,G on one band = w_L x (Lambertian panorama) + (1 - w_L) x (lobe
    panorama), in pca and exact mode, and agrees with the direct integration."""
    emission, transform = _one_band_scene()
    observer = (2000.0, 2000.0)
    raw = kernel_slice(lobe_kernel, observer_altitude=0.0)
    assert raw.emissions == ("lambertian", "uplight", "garstang_lobe")
    polar = polar_map(
        emission, transform, observer, distance_edges=raw.distance_edges, n_az=raw.n_az
    )
    garstang = EmissionFunction.parse("garstang:0.15,0.15")
    parts = {
        name: panorama_pca(polar, band_slice(raw, [EmissionFunction.parse(name)]))
        for name in ("lambertian",)
    }
    lobe_only = EmissionFunction("garstang_lobe", (("garstang_lobe", 1.0),))
    parts["garstang_lobe"] = panorama_pca(polar, band_slice(raw, [lobe_only]))
    mixed = band_slice(raw, [garstang])
    assert mixed.per_band and mixed.emissions == ("garstang:0.15,0.15",)
    w = dict(garstang.weights)
    expected = w["lambertian"] * parts["lambertian"] + w["garstang_lobe"] * parts["garstang_lobe"]
    np.testing.assert_allclose(panorama_pca(polar, mixed), expected, rtol=1e-10, atol=0)
    exact = panorama_exact(polar, mixed)
    naive = panorama_naive(
        emission,
        transform,
        observer,
        elevation=raw.elevation,
        n_az=raw.n_az,
        observer_altitude=0.0,
        functions=[garstang],
        multiple_scattering="monte-carlo",  # the model of the default kernel
    )
    bright = naive > 0.01 * naive.max()
    assert np.mean(np.abs(exact[bright] - naive[bright]) / naive[bright]) < 0.1
    assert exact[0].mean() == pytest.approx(naive[0].mean(), rel=0.05)
    # the lobe sends more light to the far sky than the Lambertian shape: the mix lies between
    zenith = {name: image[0].mean() for name, image in parts.items()}
    assert min(zenith.values()) < exact[0].mean() < max(zenith.values())


def test_a_band_mix_needs_the_shapes_in_the_kernel() -> None:
    kernel = compute_kernel(KernelSpec(**SMALL, uplight=True), progress=False)
    raw = kernel_slice(kernel, observer_altitude=0.0)
    with pytest.raises(InputError, match="no garstang_lobe table"):
        band_slice(raw, [EmissionFunction.parse("garstang:0.15,0.15")])
    two = band_slice(raw, [EmissionFunction.parse("uplight"), EmissionFunction.parse("lambertian")])
    np.testing.assert_array_equal(two.coefficient[0], raw.coefficient[1])
    np.testing.assert_array_equal(two.coefficient[1], raw.coefficient[0])
    with pytest.raises(InputError, match="already"):
        band_slice(two, [EmissionFunction.parse("lambertian")])


# -- the band tag emission_function ----------------------------------------------------------

CITY_TRANSFORM = Affine(100.0, 0.0, 500_000.0, 0.0, -100.0, 6_702_000.0)
CITY_OBSERVER = Observer(501_000.0, 6_701_000.0)
SCENE_GRID = {"n_elevation": 8, "n_azimuth": 32, "n_distance": 12}


def _city(tags: tuple[dict[str, str], ...] = ({},)) -> Raster:
    data = np.zeros((len(tags), 20, 20))
    data[:, 3:7, 12:16] = 2.0
    data[:, 15, 4] = 30.0
    return Raster(data, CITY_TRANSFORM, "EPSG:32635", band_tags=tags)


def test_band_functions_from_tags_and_defaults(tmp_path: Path) -> None:
    """Tags of a Raster, a DataArray and a file; untagged: one band garstang:0.15,0.15, two
    bands lambertian + uplight."""
    functions, notes = band_emission_functions(_city(), 1)
    assert [f.tag for f in functions] == [DEFAULT_EMISSION_FUNCTION] and notes == ("default",)
    functions, notes = band_emission_functions(_city(({}, {})), 2)
    assert [f.tag for f in functions] == ["lambertian", "uplight"]
    tagged = _city(({EMISSION_FUNCTION_TAG: "garstang:0.1,0.2"}, {}))
    functions, notes = band_emission_functions(tagged, 2)
    assert [f.tag for f in functions] == ["garstang:0.1,0.2", "uplight"]
    assert notes == ("tag", "default")
    path = tagged.write(tmp_path / "tagged.tif")
    assert band_emission_functions(path, 2)[0] == functions
    array = _city().to_xarray().assign_attrs({EMISSION_FUNCTION_TAG: "uplight"})
    assert band_emission_functions(array, 1)[0][0].tag == "uplight"
    assert band_emission_functions(_city().lit_cells(), 1)[1] == ("default",)
    with pytest.raises(InputError, match="band 1 tag emission_function 'cos'"):
        band_emission_functions(_city(({EMISSION_FUNCTION_TAG: "cos"},)), 1)


def test_untagged_single_band_reads_garstang_with_a_scene_kernel(tmp_path: Path) -> None:
    """The scene kernel gets the lobe table; the panorama equals the tagged garstang band's
    and its attributes say which function the band was given."""
    untagged = skyglow_panorama(
        Scene(_city(), cache_dir=tmp_path, **SCENE_GRID), CITY_OBSERVER, progress=False
    ).panorama
    assert untagged.attrs["emission_functions"] == "garstang:0.15,0.15"
    assert untagged.attrs["emission_function_sources"] == "default"
    tagged = skyglow_panorama(
        Scene(
            _city(({EMISSION_FUNCTION_TAG: "garstang:0.15,0.15"},)),
            cache_dir=tmp_path,
            **SCENE_GRID,
        ),
        CITY_OBSERVER,
        progress=False,
    ).panorama
    assert tagged.attrs["emission_function_sources"] == "tag"
    np.testing.assert_array_equal(untagged["luminance"], tagged["luminance"])
    lambertian = skyglow_panorama(
        Scene(_city(({EMISSION_FUNCTION_TAG: "lambertian"},)), cache_dir=tmp_path, **SCENE_GRID),
        CITY_OBSERVER,
        progress=False,
    ).panorama
    assert lambertian.attrs["emission_functions"] == "lambertian"
    # the low-angle lobe lights the sky near the horizon more than a Lambertian ground
    low = untagged["luminance"].values[-1].mean() / lambertian["luminance"].values[-1].mean()
    assert low > 1.0


def test_untagged_band_with_a_given_kernel_without_the_lobe(small_kernel: xr.Dataset) -> None:
    """Read as Lambertian, as before the default, and said so; a tagged Garstang band needs
    the lobe table."""
    eye = CITY_OBSERVER.replace(height=0.0)
    untagged = skyglow_panorama(Scene(_city(), kernel=small_kernel), eye).panorama
    assert untagged.attrs["emission_functions"] == "lambertian"
    assert "needs the kernel's garstang_lobe table" in untagged.attrs["emission_function_sources"]
    lambertian = skyglow_panorama(
        Scene(_city(({EMISSION_FUNCTION_TAG: "lambertian"},)), kernel=small_kernel), eye
    ).panorama
    np.testing.assert_array_equal(untagged["luminance"], lambertian["luminance"])
    with pytest.raises(InputError, match="no garstang_lobe table"):
        skyglow_panorama(
            Scene(_city(({EMISSION_FUNCTION_TAG: "garstang:0.15,0.15"},)), kernel=small_kernel),
            eye,
        )


def test_tagged_bands_pca_against_naive(lobe_kernel: xr.Dataset) -> None:
    """Two bands with their own functions (uplight, garstang) in pca mode against the direct
    integration of each band's mix."""
    city = _city(({EMISSION_FUNCTION_TAG: "uplight"}, {EMISSION_FUNCTION_TAG: "garstang:0.2,0.1"}))
    observer = Observer(501_000.0, 6_700_500.0, height=0.0)
    scene = Scene(city, kernel=lobe_kernel)
    pca = skyglow_panorama(scene, observer).panorama
    naive = skyglow_panorama(scene, observer, mode="naive").panorama
    assert pca.attrs["emission_functions"] == "uplight; garstang:0.2,0.1"
    a, b = pca["luminance"].values, naive["luminance"].values
    bright = b > 0.01 * b.max()
    assert np.mean(np.abs(a[bright] - b[bright]) / b[bright]) < 0.1
    assert a[0].mean() == pytest.approx(b[0].mean(), rel=0.05)


def test_emission_stages_write_the_tag() -> None:
    """The VIIRS stage tags its band and scales the flux by 1 / (pi I_1(0)): Garstang's
    F = G = 0.15 gives 1 / 0.459 = 2.18 times the Lambertian flux."""
    dnb = Raster(
        np.full((1, 4, 4), 20.0),
        Affine(450, 0, 500_000, 0, -450, 6_700_000),
        "EPSG:32635",
        ("radiance",),
        ("nW cm-2 sr-1",),
    )
    plain = emission_from_viirs(dnb, spectrum="LED_4000K")
    assert plain.raster.band_tags[0][EMISSION_FUNCTION_TAG] == "lambertian"
    garstang = emission_from_viirs(
        dnb, spectrum="LED_4000K", emission_function="garstang:0.15,0.15"
    )
    assert garstang.raster.band_tags[0][EMISSION_FUNCTION_TAG] == "garstang:0.15,0.15"
    ratio = garstang.total_flux["upward"] / plain.total_flux["upward"]
    assert ratio == pytest.approx(1.0 / garstang_weights(0.15, 0.15)["lambertian"], rel=1e-6)
    assert ratio == pytest.approx(2.18, abs=0.005)
    with pytest.raises(InputError, match="no light straight up"):
        emission_from_viirs(dnb, spectrum="LED_4000K", emission_function="uplight")
    radiance = flux_density_to_viirs_radiance(
        viirs_radiance_to_flux_density(20.0, 300.0, zenith_intensity=0.1),
        300.0,
        zenith_intensity=0.1,
    )
    assert float(radiance) == pytest.approx(20.0, rel=1e-12)


# -- tabulated emission functions -----------------------------------------------------------


def _cosine_table(step: float = 1.0) -> str:
    angles = np.arange(0.0, 90.0 + step / 2, step)
    table = {"angles": angles.tolist(), "intensities": np.cos(np.radians(angles)).tolist()}
    return "tabulated:" + json.dumps(table)


def test_tabulated_function_parse_and_normalisation() -> None:
    canonical = parse_tabulated_emission(PEAKED)[0]
    assert canonical.startswith('tabulated:{"angles":[0.0,30.0') and " " not in canonical
    assert EmissionFunction.parse(PEAKED).tag == canonical
    flux = 2 * math.pi * quad(lambda mu: float(emission_intensity(mu, PEAKED)), 0, 1, limit=200)[0]
    assert flux == pytest.approx(1.0, rel=1e-8)
    # linear in the angle between the nodes; 0 below the horizon
    mid = float(emission_intensity(math.cos(math.radians(70.0)), PEAKED))
    assert mid == pytest.approx(
        1.5 * float(emission_intensity(math.cos(math.radians(60.0)), PEAKED))
    )
    assert float(emission_intensity(-0.1, PEAKED)) == 0.0
    # cos theta at 1 deg steps is the Lambertian shape within the interpolation error
    mu = np.linspace(0.05, 1.0, 20)
    np.testing.assert_allclose(
        emission_intensity(mu, _cosine_table()), emission_intensity(mu, "lambertian"), rtol=2e-4
    )
    bad = (
        "tabulated:[1, 2]",
        'tabulated:{"angles": [0, 45], "intensities": [1, 1]}',
        'tabulated:{"angles": [0, 90, 60], "intensities": [1, 1, 1]}',
        'tabulated:{"angles": [0, 90], "intensities": [0, 0]}',
        'tabulated:{"angles": [0, 90], "intensities": [1, -1]}',
        'tabulated:{"angles": [0, 90], "intensities": [1]}',
    )
    for text in bad:
        with pytest.raises(InputError, match="tabulated"):
            EmissionFunction.parse(text)


def test_tabulated_kernel_table_and_band(tmp_path: Path) -> None:
    """A tabulated band gets its own table in the scene kernel; a cosine table reproduces the
    Lambertian band's panorama."""
    cosine = _cosine_table(0.5)
    spec = KernelSpec(**SMALL, tabulated_emission=cosine)
    assert spec.emissions == ("lambertian", parse_tabulated_emission(cosine)[0])
    assert KernelSpec.from_attrs(spec.to_attrs()) == spec
    assert spec.content_hash != KernelSpec(**SMALL).content_hash
    kernel = compute_kernel(spec, progress=False)
    np.testing.assert_allclose(
        kernel["kernel_tabulated"].values, kernel["kernel"].values, rtol=1e-4, atol=0
    )
    tabulated = skyglow_panorama(
        Scene(_city(({EMISSION_FUNCTION_TAG: cosine},)), cache_dir=tmp_path, **SCENE_GRID),
        CITY_OBSERVER,
        progress=False,
    ).panorama
    assert tabulated.attrs["emission_functions"] == parse_tabulated_emission(cosine)[0]
    lambertian = skyglow_panorama(
        Scene(_city(({EMISSION_FUNCTION_TAG: "lambertian"},)), cache_dir=tmp_path, **SCENE_GRID),
        CITY_OBSERVER,
        progress=False,
    ).panorama
    np.testing.assert_allclose(tabulated["luminance"], lambertian["luminance"], rtol=1e-3)
    with pytest.raises(InputError, match="2 different tabulated"):
        skyglow_panorama(
            Scene(
                _city(({EMISSION_FUNCTION_TAG: cosine}, {EMISSION_FUNCTION_TAG: PEAKED})),
                cache_dir=tmp_path,
                **SCENE_GRID,
            ),
            CITY_OBSERVER,
            progress=False,
        )
