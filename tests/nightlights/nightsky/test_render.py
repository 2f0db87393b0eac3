"""Sky images: projection geometry, flux-conserving star splats, star photometry and colour,
the limiting magnitude, and the brightest point at Sirius in every projection."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from nightlights.errors import InputError
from nightlights.nightsky.astro import star_positions
from nightlights.nightsky.catalog import load_catalog
from nightlights.nightsky.render import (
    PROJECTIONS,
    ZERO_MAGNITUDE_ILLUMINANCE,
    SkyOptions,
    View,
    ballesteros_temperature,
    panorama_lookup,
    render_sky,
    schaefer_limiting_magnitude,
    splat_disc,
    splat_points,
    star_xyz,
    view_pixels,
    zenith_summary,
)

#: Sirius (HR 2491) culminating 37 deg high at 35 N on the Greenwich meridian; Sun 57 deg and
#: Moon 35 deg below the horizon.
SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT = "2026-01-20T22:00:00Z", 0.0, 35.0


def views(width: int, height: int) -> list[View]:
    return [
        View("equirectangular", width, height),
        View("fisheye", height, height),
        View("perspective", width, height, azimuth=150.0, elevation=40.0, field_of_view=100.0),
    ]


def random_stars(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    elevation = np.degrees(np.arcsin(rng.uniform(0.02, 0.98, n)))
    azimuth = rng.uniform(0.0, 360.0, n)
    flux = rng.uniform(0.1, 1.0, (n, 3)) * 1e-6
    return elevation, azimuth, flux


def image_flux(image: np.ndarray, solid_angle: np.ndarray) -> np.ndarray:
    """Sum of luminance x solid angle per channel [lx]."""
    return np.nansum(image * solid_angle[..., None], axis=(0, 1))


def test_equirectangular_and_fisheye_cover_the_hemisphere() -> None:
    pixels = view_pixels(View("equirectangular", 360, 90))
    assert pixels.solid_angle.sum() == pytest.approx(2.0 * math.pi, rel=1e-12)
    fisheye = view_pixels(View("fisheye", 400))
    assert fisheye.solid_angle[fisheye.sky].sum() == pytest.approx(2.0 * math.pi, rel=2e-3)


def test_perspective_solid_angle_of_a_rectangular_pyramid() -> None:
    view = View("perspective", 300, 200, elevation=90.0, field_of_view=80.0)
    pixels = view_pixels(view)
    half_w = math.radians(40.0)
    half_h = math.atan(math.tan(half_w) * 200 / 300)
    # the solid angle of a rectangle seen from its axis: 4 arcsin(sin a sin b)
    expected = 4.0 * math.asin(math.sin(half_w) * math.sin(half_h))
    assert pixels.solid_angle.sum() == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("view", views(64, 48), ids=PROJECTIONS)
def test_locating_pixel_centres_gives_their_indices(view: View) -> None:
    pixels = view_pixels(view)
    rows, cols, inside = pixels.locate(pixels.elevation, pixels.azimuth)
    index_r, index_c = np.indices(view.shape)
    keep = pixels.sky & inside & (pixels.elevation < 89.0)
    np.testing.assert_allclose(rows[keep], index_r[keep], atol=1e-6)
    np.testing.assert_allclose(cols[keep], index_c[keep], atol=1e-6)


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_star_flux_is_independent_of_resolution(projection: str) -> None:
    elevation, azimuth, flux = random_stars(200, seed=1)
    totals = []
    for width, height in ((96, 48), (400, 200), (1000, 500)):
        view = {v.projection: v for v in views(width, height)}[projection]
        pixels = view_pixels(view)
        inside = pixels.locate(elevation, azimuth)[2]
        image = splat_points(pixels, elevation, azimuth, flux)
        np.testing.assert_allclose(
            image_flux(image, pixels.solid_angle), flux[inside].sum(axis=0), rtol=1e-10
        )
        totals.append(image_flux(image, pixels.solid_angle))
    if projection != "perspective":  # a perspective view holds different stars at its edge
        np.testing.assert_allclose(totals[0], totals[-1], rtol=1e-10)


def test_five_magnitudes_carry_one_hundredth_of_the_flux() -> None:
    pixels = view_pixels(View("equirectangular", 720, 180))
    flux = star_xyz(np.array([1.0, 6.0]), np.array([0.3, 0.3]))
    assert flux[1, 1] / flux[0, 1] == pytest.approx(0.01, rel=1e-12)
    image = splat_points(pixels, np.array([30.0, 30.0]), np.array([90.0, 270.0]), flux)
    weighted = image[..., 1] * pixels.solid_angle
    east, west = weighted[:, :360].sum(), weighted[:, 360:].sum()
    assert west / east == pytest.approx(0.01, rel=1e-10)


def test_zero_point_and_colours() -> None:
    # Cinzano 2005: 1.08e5 cd m-2 over one square arcsecond for V = 0
    assert ZERO_MAGNITUDE_ILLUMINANCE == pytest.approx(2.538e-6, rel=1e-3)
    # Ballesteros 2012: the Sun, B-V = 0.65, comes out at its 5778 K
    assert ballesteros_temperature(0.65) == pytest.approx(5778.0, abs=5.0)
    blue, red = star_xyz(np.zeros(2), np.array([-0.2, 1.6]))
    assert blue[2] / blue[0] > 1.0 > red[2] / red[0]
    assert np.allclose(star_xyz(np.zeros(1), np.array([np.nan]))[0], ZERO_MAGNITUDE_ILLUMINANCE)


def test_limiting_magnitude_falls_with_sky_brightness() -> None:
    sky = np.logspace(-4.5, 1.0, 50)
    limit = schaefer_limiting_magnitude(sky)
    assert np.all(np.diff(limit) < 0)
    # the naked-eye limit of about 6.5 mag under a dark 22 mag arcsec-2 (171 ucd m-2) sky
    assert 6.0 < schaefer_limiting_magnitude(171e-6) < 7.0
    assert schaefer_limiting_magnitude(1.7e-4, snellen_ratio=2.0) == pytest.approx(
        schaefer_limiting_magnitude(1.7e-4) + 5.0 * math.log10(2.0)
    )


def test_moon_disc_keeps_its_flux() -> None:
    for width in (128, 1024):
        pixels = view_pixels(View("equirectangular", width, width // 4))
        image = splat_disc(pixels, 40.0, 120.0, 0.26, np.array([1.0, 2.0, 3.0]))
        np.testing.assert_allclose(image_flux(image, pixels.solid_angle), [1, 2, 3], rtol=1e-10)


def test_panorama_lookup_is_periodic() -> None:
    azimuth = (np.arange(8) + 0.5) * 45.0
    elevation = np.array([80.0, 40.0, 5.0])
    values = np.tile(np.cos(np.radians(azimuth)), (3, 1))
    pano = xr.Dataset(
        {"luminance": (("elevation", "azimuth"), values)},
        coords={"elevation": elevation, "azimuth": azimuth},
    )
    near = panorama_lookup(pano, np.array([40.0, 40.0]), np.array([359.0, 1.0]))
    assert near[0, 0] == pytest.approx(near[1, 0])
    assert panorama_lookup(pano, np.array([40.0]), np.array([22.5]))[0, 0] == pytest.approx(
        values[1, 0]
    )


@pytest.fixture(scope="module")
def sirius_images() -> dict[str, tuple]:
    catalog = load_catalog()
    sirius = catalog.select(catalog.hr == 2491)
    az, el = star_positions(sirius, SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT)
    options = SkyOptions(moon=False)
    out = {}
    for view in views(480, 240):
        image = render_sky(SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT, view=view, options=options)
        out[view.projection] = (image, float(el[0]), float(az[0]))
    return out


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_brightest_point_is_sirius(sirius_images: dict, projection: str) -> None:
    image, el, az = sirius_images[projection]
    flux = np.nan_to_num(image.luminance) * image.pixels.solid_angle
    row, col = np.unravel_index(np.argmax(flux), flux.shape)
    expected_row, expected_col, inside = image.pixels.locate(np.array([el]), np.array([az]))
    assert inside[0]
    assert abs(row - expected_row[0]) <= 1.0 and abs(col - expected_col[0]) <= 1.0
    assert image.summary["stars_drawn"] > 100


def test_city_sky_hides_faint_stars_and_reports_the_zenith() -> None:
    view = View("equirectangular", 240, 60)
    azimuth = (np.arange(16) + 0.5) * 22.5
    elevation = np.linspace(85.0, 5.0, 9)
    glow = np.full((9, 16), 5e-3)  # about 18.2 mag arcsec-2: a city sky
    pano = xr.Dataset(
        {"luminance": (("elevation", "azimuth"), glow)},
        coords={"elevation": elevation, "azimuth": azimuth},
    )
    dark = render_sky(SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT, view=view, options=SkyOptions())
    city = render_sky(SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT, view=view, panorama=pano)
    assert city.summary["stars_drawn"] < dark.summary["stars_drawn"] / 3
    assert city.summary["zenith_artificial_cd_m2"] == pytest.approx(5e-3)
    assert city.summary["bortle_class_zenith"] >= 7
    assert dark.summary["zenith_sky_brightness"] == pytest.approx(22.0, abs=0.3)
    only = render_sky(
        SIRIUS_TIME,
        SIRIUS_LON,
        SIRIUS_LAT,
        view=view,
        panorama=pano,
        options=SkyOptions(natural=False),
    )
    np.testing.assert_allclose(only.luminance, 5e-3, rtol=1e-9)


def test_daylight_and_empty_requests_are_refused() -> None:
    with pytest.raises(InputError, match="daylight"):
        render_sky("2026-06-21T12:00:00Z", 0.0, 45.0, view=View("equirectangular", 32, 8))
    with pytest.raises(InputError, match="nothing to draw"):
        render_sky(SIRIUS_TIME, 0.0, 35.0, options=SkyOptions(natural=False, artificial=False))
    with pytest.raises(InputError, match="projection"):
        View("mercator")


def test_zenith_summary_adds_natural_and_artificial() -> None:
    moonless = zenith_summary(0.0)
    assert moonless["zenith_sky_brightness"] == pytest.approx(22.0, abs=1e-9)
    assert moonless["bortle_class_zenith"] == 1
    view = View("equirectangular", 64, 16)
    image = render_sky(SIRIUS_TIME, SIRIUS_LON, SIRIUS_LAT, view=view)
    night = zenith_summary(1e-3, time=SIRIUS_TIME, lon=SIRIUS_LON, lat=SIRIUS_LAT)
    assert night["zenith_natural_cd_m2"] == pytest.approx(image.summary["zenith_natural_cd_m2"])
    total = image.summary["zenith_natural_cd_m2"] + 1e-3
    assert night["zenith_sky_brightness"] == pytest.approx(-2.5 * math.log10(total / 1.08e5))


def test_moon_phase_lit_fraction_and_side() -> None:
    from nightlights.nightsky.moon import moon_state, sun_position

    when, lon, lat = "2026-01-25T20:00:00Z", 24.95, 60.17
    moon = moon_state(when, lon, lat)
    sun_az, sun_el = sun_position(when, lon, lat)
    view = View(
        "perspective", 300, 300, azimuth=moon.azimuth, elevation=moon.elevation, field_of_view=1.2
    )
    pixels = view_pixels(view)
    lit = splat_disc(
        pixels,
        moon.elevation,
        moon.azimuth,
        moon.angular_radius,
        [1.0],
        sun=(sun_az, sun_el),
        phase_angle=moon.phase_angle,
    )[..., 0]
    disc = splat_disc(pixels, moon.elevation, moon.azimuth, moon.angular_radius, [1.0])[..., 0]
    assert (lit * pixels.solid_angle).sum() == pytest.approx(1.0, rel=1e-12)
    area = ((lit > 0) * pixels.solid_angle).sum() / ((disc > 0) * pixels.solid_angle).sum()
    assert area == pytest.approx(moon.illuminated_fraction, abs=0.02)
    # the lit side faces the Sun: its centroid moves toward the Sun's place in the image
    rows, cols = np.indices(view.shape)
    centre = np.array([(lit * rows).sum(), (lit * cols).sum()]) / lit.sum()
    middle = np.array(pixels.locate(np.array([moon.elevation]), np.array([moon.azimuth]))[:2])
    # toward the Sun in the camera frame: its azimuth is larger (right), its elevation lower
    assert sun_az > moon.azimuth and sun_el < moon.elevation
    assert centre[1] > middle[1, 0] and centre[0] > middle[0, 0]


def test_a_file_that_is_not_a_panorama_is_one_line_error(tmp_path) -> None:
    from nightlights.nightsky import sky_render

    fake = tmp_path / "pano.nc"
    fake.write_bytes(b"not a NetCDF file")
    with pytest.raises(InputError, match="not a NetCDF panorama"):
        sky_render(None, time="2026-01-25T20:00:00Z", panorama=fake)


def glow_panorama() -> xr.Dataset:
    """A city glow brightest toward the south-west near the horizon, 16 x 64 pixels."""
    elevation = 90.0 - (np.arange(16) + 0.5) * 90.0 / 16
    azimuth = (np.arange(64) + 0.5) * 360.0 / 64
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    glow = 2e-4 + 3e-3 * np.exp(-el / 15.0) * (1.0 + np.cos(np.radians(az - 225.0))) / 2.0
    return xr.Dataset(
        {"luminance": (("elevation", "azimuth"), glow)},
        coords={"elevation": elevation, "azimuth": azimuth},
    )


@pytest.mark.parametrize("view", views(320, 160), ids=PROJECTIONS)
def test_compiled_render_equals_the_numpy_reference(view: View) -> None:
    from nightlights.nightsky.render import _render_sky

    # a moonlit night (Moon 51 deg up, 68 % lit) with a city glow and every star
    time, lon, lat = "2026-01-27T19:00:00Z", 24.95, 60.17
    args = (time, lon, lat, view, glow_panorama(), SkyOptions(limiting_magnitude=False), None)
    compiled = _render_sky(*args, compiled=True)
    reference = _render_sky(*args, compiled=False)
    assert compiled.summary == reference.summary
    assert "moon_elevation_deg" in compiled.summary and compiled.summary["stars_drawn"] > 1000
    np.testing.assert_array_equal(np.isnan(compiled.xyz), np.isnan(reference.xyz))
    np.testing.assert_allclose(compiled.xyz, reference.xyz, rtol=1e-12, atol=0.0)


def test_sources_drawn_in_place_equal_sources_drawn_alone() -> None:
    for view in views(256, 128):
        pixels = view_pixels(view)
        elevation, azimuth, flux = random_stars(300, 11)
        sky = np.full((*view.shape, 3), 1e-4)
        alone = splat_points(pixels, elevation, azimuth, flux)
        drawn = splat_points(pixels, elevation, azimuth, flux, out=sky.copy())
        np.testing.assert_allclose(drawn, sky + alone, rtol=1e-13)
        disc = splat_disc(pixels, 35.0, 200.0, 4.0, np.array([1.0, 2.0, 3.0]))
        on_sky = splat_disc(pixels, 35.0, 200.0, 4.0, np.array([1.0, 2.0, 3.0]), out=sky.copy())
        np.testing.assert_allclose(on_sky, sky + disc, rtol=1e-13)
    with pytest.raises(InputError, match="splat output"):
        splat_points(pixels, elevation, azimuth, flux, out=np.zeros((3, 3, 3)))


def test_compiled_scatter_add_equals_numpy_add_at() -> None:
    from nightlights.nightsky._render_numba import scatter_add

    rng = np.random.default_rng(4)
    index = rng.integers(0, 50, 2000)  # many repeats
    values = rng.uniform(-1.0, 1.0, 2000)
    expected = np.zeros(50)
    np.add.at(expected, index, values)
    target = np.zeros(50)
    scatter_add(target, index, values)
    np.testing.assert_allclose(target, expected, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("shape", [(1, 1), (3, 5), (257, 130)])
def test_png_bytes_read_back_exactly(shape: tuple[int, int]) -> None:
    import io

    from PIL import Image

    from nightlights.nightsky.stage import png_bytes

    rng = np.random.default_rng(sum(shape))
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    decoded = Image.open(io.BytesIO(png_bytes(image)))
    decoded.load()  # checks the CRCs and the zlib stream's Adler-32
    assert decoded.mode == "RGB"
    np.testing.assert_array_equal(np.asarray(decoded), image)


def test_written_picture_holds_the_image_and_a_legend_strip(tmp_path) -> None:
    from PIL import Image

    from nightlights.nightsky.stage import LEGEND_STRIP, write_png

    rgb = np.linspace(0.0, 1.0, 64 * 128 * 3).reshape(64, 128, 3)
    path = write_png(rgb, tmp_path / "sky.png", "line one\nline two", "equirectangular")
    written = np.asarray(Image.open(path))
    assert written.shape == (64 + LEGEND_STRIP, 128, 3)
    np.testing.assert_array_equal(written[:64], np.floor(255.0 * rgb + 0.5).astype(np.uint8))
    assert written[64:].max() == 255  # white text on the black strip
