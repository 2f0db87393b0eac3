"""Tests of the skyglow runtime: brightness units, polar map, panoramas, stage, failure regimes."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from hypothesis import given
from hypothesis import strategies as st

from nightlights.brightness import bortle_class, luminance_to_magnitude, magnitude_to_luminance
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.io import RasterBand, write_cog
from nightlights.sky import Observer, Scene, skyglow
from nightlights.sky.panorama import (
    kernel_slice,
    panorama_exact,
    panorama_naive,
    panorama_pca,
)
from nightlights.sky.polar import polar_map

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 0, 0, -CELL, 4000)  # 40 x 40 cells over 4 x 4 km
OBSERVER = (2000.0, 2000.0)


# -- brightness (validation 6) ---------------------------------------------------------------


def test_22_mag_is_171_microcandela() -> None:
    """22.0 mag arcsec-2 = 171 ucd m-2 (Cinzano 2005 zero point 1.08e5 cd m-2)."""
    assert magnitude_to_luminance(22.0) == pytest.approx(171e-6, rel=2e-3)
    assert luminance_to_magnitude(171e-6) == pytest.approx(22.0, abs=2e-3)


@given(st.floats(min_value=1e-9, max_value=1e6, allow_nan=False))
def test_magnitude_round_trip(luminance: float) -> None:
    assert magnitude_to_luminance(luminance_to_magnitude(luminance)) == pytest.approx(
        luminance, rel=1e-12
    )


def test_bortle_classes_are_monotone() -> None:
    m = np.array([22.5, 21.95, 21.8, 21.0, 20.0, 19.2, 18.6, 18.2, 17.0])
    assert bortle_class(m).tolist() == list(range(1, 10))


# -- polar map -------------------------------------------------------------------------------


def _scene(bands: int = 1) -> np.ndarray:
    emission = np.zeros((bands, 40, 40))
    emission[0, 5, 30] = 1.0  # one bright cell to the north-east
    emission[0, 20:23, 3:6] = 0.3  # a small block to the west
    if bands == 2:
        emission[1] = 0.1 * emission[0]
    return emission


def test_polar_map_conserves_flux_and_finds_azimuths(small_kernel) -> None:
    edges = np.asarray(small_kernel["distance_edges"].values)
    polar = polar_map(_scene(), TRANSFORM, OBSERVER, distance_edges=edges, n_az=32)
    assert polar.flux.sum() == pytest.approx(polar.total_flux.sum(), rel=1e-12)
    assert polar.total_flux[0] == pytest.approx((1.0 + 9 * 0.3) * CELL**2)
    by_azimuth = polar.flux[0].sum(axis=0)
    # The cell at row 5, col 30 lies at dx = +1050, dy = +1450: azimuth 35.9 deg, which is
    # bin 3 (33.75-45 deg) of 32; the cell spans ~3 deg, inside that bin.
    assert by_azimuth[3] == pytest.approx(CELL**2, rel=1e-9)
    assert by_azimuth[:8].sum() == pytest.approx(CELL**2, rel=1e-9)
    assert by_azimuth[(polar.azimuths > 250) & (polar.azimuths < 290)].sum() == pytest.approx(
        9 * 0.3 * CELL**2, rel=1e-9
    )


def test_observer_inside_a_lit_cell_keeps_its_flux(small_kernel) -> None:
    """Failure regime: the observer's own cell spreads over all azimuths, flux conserved."""
    emission = np.zeros((1, 40, 40))
    emission[0, 20, 20] = 1.0  # cell x 2000-2100, y 1900-2000: the observer stands at its centre
    edges = np.asarray(small_kernel["distance_edges"].values)
    polar = polar_map(emission, TRANSFORM, (2050.0, 1950.0), distance_edges=edges, n_az=32)
    assert polar.flux.sum() == pytest.approx(CELL**2, rel=1e-12)
    assert np.count_nonzero(polar.flux[0].sum(axis=0)) == 32  # light all around
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    luminance = panorama_exact(polar, tables)
    assert np.all(np.isfinite(luminance)) and luminance.min() > 0
    # Nearly symmetric in azimuth: the cell surrounds the observer.
    assert luminance[0].std() / luminance[0].mean() < 0.05


def test_sources_beyond_the_kernel_are_dropped_with_a_warning(small_kernel) -> None:
    emission = np.zeros((1, 10, 300))
    emission[0, 5, 250] = 1.0  # 25 km away: beyond the kernel's 20 km
    emission[0, 5, 5] = 1.0
    transform = Affine(CELL, 0, 0, 0, -CELL, 1000)
    edges = np.asarray(small_kernel["distance_edges"].values)
    with pytest.warns(DataQualityWarning, match="50 % of the emitted flux"):
        polar = polar_map(emission, transform, (500.0, 500.0), distance_edges=edges, n_az=32)
    assert polar.dropped_flux[0] == pytest.approx(CELL**2)


# -- panoramas --------------------------------------------------------------------------------


def test_pca_with_all_bases_equals_exact(small_kernel) -> None:
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    polar = polar_map(
        _scene(2), TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    exact = panorama_exact(polar, tables)
    pca = panorama_pca(polar, tables)
    # The stored bases keep 0.999999 of the energy: agreement to ~1e-3 of the peak.
    assert np.abs(pca - exact).max() < 2e-3 * exact.max()


def test_too_few_bases_degrade_gracefully(small_kernel) -> None:
    """Failure regime: error grows as bases are dropped; one basis is still positive-ish."""
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    polar = polar_map(
        _scene(), TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    exact = panorama_exact(polar, tables)
    bright = exact > 0.01 * exact.max()
    errors = []
    for k in (1, 2, 4, tables.coefficient.shape[-1]):
        pca = panorama_pca(polar, tables, components=k)
        errors.append(np.mean(np.abs(pca[bright] - exact[bright]) / exact[bright]))
    # Mean relative error is not monotone in k for the first few bases (normalised-row PCA
    # optimises the energy, not relative error), but all bases reproduce the exact panorama
    # and one basis is far from it.
    assert errors[0] > 0.05
    assert errors[-1] < 2e-3 and errors[-1] == min(errors)
    with pytest.raises(InputError, match="components=0"):
        panorama_pca(polar, tables, components=0)


def test_single_source_reproduces_the_kernel_image_at_its_azimuth(small_kernel) -> None:
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    n_az = tables.n_az
    polar_flux = np.zeros((1, tables.distance_edges.size - 1, n_az))
    polar_flux[0, 10, 5] = 7.0
    from nightlights.sky.polar import PolarMap

    polar = PolarMap(polar_flux, tables.distance_edges, n_az, np.zeros(1), np.full(1, 7.0))
    image = panorama_exact(polar, tables)
    expected = 7.0 * np.roll(tables.kernel[0, 10], 5, axis=-1)
    np.testing.assert_allclose(image, expected, rtol=1e-9, atol=1e-12 * expected.max())


def test_exact_mode_agrees_with_the_naive_reference(small_kernel) -> None:
    """Binning in distance and azimuth versus direct integration at each cell's position."""
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    scene = _scene()
    polar = polar_map(
        scene, TRANSFORM, OBSERVER, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    exact = panorama_exact(polar, tables)
    naive = panorama_naive(
        scene,
        TRANSFORM,
        OBSERVER,
        elevation=tables.elevation,
        n_az=tables.n_az,
        observer_altitude=0.0,
        multiple_scattering=small_kernel.attrs["multiple_scattering"],
    )
    bright = naive > 0.01 * naive.max()
    # The test kernel is coarse (24 distance bins over 5 m - 20 km, ratio 1.41 per bin; 8 x 32
    # pixels): binning errors of a few per cent; benchmarks/bench_sky_runtime_* chart how the
    # error falls with finer grids.
    assert np.mean(np.abs(exact[bright] - naive[bright]) / naive[bright]) < 0.1
    assert exact[0].mean() == pytest.approx(naive[0].mean(), rel=0.05)  # zenith


def test_bright_near_source_and_dim_far_city_both_visible(small_kernel) -> None:
    """Failure regime (dynamic range): a lamp 150 m away next to a dim town 15 km away."""
    emission = np.zeros((1, 10, 200))
    emission[0, 5, 6] = 50.0  # bright, 150 m east of the observer
    emission[0, 2:8, 145:160] = 0.01  # dim town ~ 15 km east-north-east... same direction
    emission[0, 2:8, 0:2] = 0.0
    transform = Affine(CELL, 0, 0, 0, -CELL, 1000)
    observer = (500.0, 450.0)
    tables = kernel_slice(small_kernel, observer_altitude=0.0)
    polar = polar_map(
        emission, transform, observer, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    near_only = emission.copy()
    near_only[0, :, 100:] = 0
    polar_near = polar_map(
        near_only, transform, observer, distance_edges=tables.distance_edges, n_az=tables.n_az
    )
    both = panorama_exact(polar, tables)
    near = panorama_exact(polar_near, tables)
    town = both - near
    # The town adds light that is many orders of magnitude below the lamp's peak but still
    # resolved (linearity in float64 keeps it).
    assert town.max() > 0 and town.max() < 1e-3 * near.max()
    assert np.all(town >= -1e-12 * near.max())


# -- stage --------------------------------------------------------------------------------------


def _write_scene(path, bands: int = 2) -> None:
    scene = _scene(bands)
    write_cog(
        path,
        [
            RasterBand(scene[b].astype(np.float32), ("reflected", "uplight")[b], "lm m-2")
            for b in range(bands)
        ],
        transform=Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000),
        crs="EPSG:32635",
    )


def test_stage_writes_panorama_contract(tmp_path, small_kernel) -> None:
    src = tmp_path / "emission.tif"
    _write_scene(src)
    out = tmp_path / "pano.nc"
    png = tmp_path / "pano.png"
    polar_nc = tmp_path / "polar.nc"
    result = skyglow(
        Scene(src, kernel=small_kernel),
        Observer(502_000.0, 6_698_000.0, height=0.0),
        out,
        png=png,
        projection="fisheye",
        polar_output=polar_nc,
    )
    pano = xr.open_dataset(out, engine="h5netcdf")
    assert pano["luminance"].dims == ("elevation", "azimuth")
    assert pano["luminance"].attrs["units"] == "cd m-2"
    assert pano["sky_brightness"].attrs["units"] == "mag arcsec-2"
    assert pano["elevation"].values[0] > pano["elevation"].values[-1]  # zenith first
    assert pano["azimuth"].values[0] == pytest.approx(360 / 64)
    assert pano.attrs["kernel_hash"] == small_kernel.attrs["content_hash"]
    assert np.allclose(pano["sky_brightness"], luminance_to_magnitude(pano["luminance"]))
    assert 1 <= result.bortle <= 9 and png.stat().st_size > 5000
    polar = xr.open_dataset(polar_nc, engine="h5netcdf")
    assert float(polar["flux"].sum()) == pytest.approx((1.0 + 2.7) * 1.1 * CELL**2, rel=1e-6)
    pano.close()
    polar.close()


def test_stage_observer_in_another_crs(tmp_path, small_kernel) -> None:
    src = tmp_path / "emission.tif"
    _write_scene(src, bands=1)
    from pyproj import Transformer

    lon, lat = Transformer.from_crs("EPSG:32635", "EPSG:4326", always_xy=True).transform(
        502_000.0, 6_698_000.0
    )
    scene = Scene(src, kernel=small_kernel)
    a = skyglow(scene, Observer(502_000.0, 6_698_000.0, height=0.0), tmp_path / "a.nc")
    b = skyglow(scene, Observer(lon, lat, crs="EPSG:4326", height=0.0), tmp_path / "b.nc")
    np.testing.assert_allclose(a.panorama["luminance"], b.panorama["luminance"], rtol=1e-6)


def test_stage_bad_inputs(tmp_path, small_kernel) -> None:
    src = tmp_path / "emission.tif"
    _write_scene(src)
    out = tmp_path / "pano.nc"
    site = Observer(502_000.0, 6_698_000.0)
    with pytest.raises(InputError, match="mode 'fast'"):
        skyglow(Scene(src, kernel=small_kernel), site, out, mode="fast")
    one_band_kernel = small_kernel.drop_vars(["kernel_uplight", "coefficient_uplight"])
    with pytest.raises(InputError, match="no uplight table"):
        skyglow(Scene(src, kernel=one_band_kernel), site.replace(height=0.0), out)
    with pytest.raises(InputError, match="turbidity 5"):
        skyglow(Scene(src, kernel=small_kernel, turbidity=5), site, out)
    geographic = tmp_path / "geo.tif"
    write_cog(
        geographic,
        [RasterBand(np.ones((4, 4), np.float32), "e", "lm m-2")],
        transform=Affine(0.01, 0, 24, 0, -0.01, 60),
        crs="EPSG:4326",
    )
    with pytest.raises(CRSError, match="projected CRS"):
        skyglow(Scene(geographic, kernel=small_kernel), Observer(24.01, 59.99), out)
    assert not out.exists()


def test_observer_altitude_outside_kernel_warns(small_kernel) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kernel_slice(small_kernel, observer_altitude=500.0)
    assert any("outside the kernel's levels" in str(w.message) for w in caught)


def test_rgb_bands_orange_and_blue_white_lights_colour_the_sky(tmp_path) -> None:
    """Dobashi 2023 Fig. 10: sodium light gives a redder sky than 4000 K LED light; the
    shorter wavelengths scatter more (Rayleigh), so the Z band falls faster with distance."""
    src = tmp_path / "emission.tif"
    _write_scene(src, bands=1)
    cache = tmp_path / "cache"
    results = {}
    for spectrum in ("HPS", "LED_4000K"):
        out = tmp_path / f"{spectrum}.nc"
        skyglow(
            Scene(src, n_elevation=8, n_azimuth=32, n_distance=16, cache_dir=cache),
            Observer(502_000.0, 6_698_000.0),
            out,
            bands="RGB",
            spectrum=spectrum,
            progress=False,
            png=tmp_path / f"{spectrum}.png",
        )
        pano = xr.open_dataset(out, engine="h5netcdf")
        results[spectrum] = {band: pano[band].values.copy() for band in ("X", "Y", "Z")}
        np.testing.assert_allclose(pano["luminance"].values, pano["Y"].values)
        pano.close()
    zenith_ratio = {s: r["X"][0].mean() / r["Z"][0].mean() for s, r in results.items()}
    assert zenith_ratio["HPS"] > 3 * zenith_ratio["LED_4000K"]
    assert (tmp_path / "HPS.png").stat().st_size > 5000
    with pytest.raises(InputError, match="RGB"):
        skyglow(
            Scene(src, cache_dir=cache),
            Observer(502_000.0, 6_698_000.0),
            tmp_path / "x.nc",
            bands="RGB",
            mode="naive",
        )
