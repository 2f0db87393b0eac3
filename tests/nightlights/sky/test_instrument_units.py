"""What an instrument reads of the modelled sky in the zenith summaries of ``skyglow`` and
``observers``: the panorama read with the instrument's angular weights and colour term, with
the natural sky; the defaults unchanged without an instrument."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine

from nightlights.brightness import NATURAL_ZENITH_LUMINANCE, luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.forward import _colour_spectrum
from nightlights.sky.instrument_units import (
    DEFAULT_SPECTRUM,
    emission_spectrum,
    instrument_sky,
)
from nightlights.sky.instruments import angular_weights, instrument_luminance
from nightlights.sky.observers import INSTRUMENT_FIELDS, SUMMARY_FIELDS, observers

CELL = 100.0
CRS = "EPSG:32635"
TRANSFORM = Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000)
#: Observers in, beside and outside the town [m].
POINTS = [(502_000.0, 6_698_000.0), (500_350.0, 6_697_850.0), (503_500.0, 6_696_500.0)]
#: Float rounding only: the same panorama summed in another order.
RTOL = 1e-12


@pytest.fixture(scope="module")
def fine_kernel() -> xr.Dataset:
    """As the shared ``small_kernel`` with 24 rows of 3.75 deg: fine enough for the 17-20 deg
    responses of the lensed instruments and the eye."""
    spec = KernelSpec(
        r_min=5.0, r_max=20_000.0, n_distance=24, n_elevation=24, n_azimuth=32, uplight=True
    )
    return build_kernel(spec, progress=False).kernel


def town(tags: dict[str, str] | None = None) -> Raster:
    """A bright block, a lit street and a lamp; Lambertian + 1/8 uplight."""
    flux = np.zeros((2, 40, 40))
    flux[0, 5, 30] = 1.0
    flux[0, 20:23, 3:6] = 0.25
    flux[0, 30, 12:30] = 0.1
    flux[1] = 0.125 * flux[0]
    return Raster(flux, TRANSFORM, CRS, ("reflected", "uplight"), ("lm m-2",) * 2, tags or {})


def ridge() -> Raster:
    """A 200 m ridge between the first observer and the block to the west [m]."""
    heights = np.zeros((1, 40, 40))
    heights[0, :, 10:12] = 200.0
    return Raster(heights, TRANSFORM, CRS, ("height",), ("m",))


def read(panorama: xr.Dataset, instrument: str, spectrum: str = DEFAULT_SPECTRUM) -> float:
    """The panorama read with the instrument's angular weights and colour term [cd m-2];
    pixels the terrain hides add nothing."""
    weights = angular_weights(instrument, panorama["elevation"].values, panorama["azimuth"].values)
    reading = float(np.sum(weights * np.nan_to_num(panorama["luminance"].values)))
    return float(instrument_luminance(reading, instrument, spectrum))


def natural(instrument: str) -> float:
    """The default natural sky in the instrument's units [cd m-2]."""
    return float(
        instrument_luminance(NATURAL_ZENITH_LUMINANCE, instrument, "natural_sky", band="V")
    )


# --- skyglow ---------------------------------------------------------------------------------


def test_skyglow_reports_the_panorama_read_by_the_instrument(small_kernel: xr.Dataset) -> None:
    scene = Scene(town(), kernel=small_kernel)
    observer = Observer(*POINTS[0], height=0.0)
    plain = skyglow(scene, observer)
    result = skyglow(scene, observer, instrument="sqm")
    # the panorama and the zenith figures are the same; the instrument's are added
    xr.testing.assert_identical(result.panorama["luminance"], plain.panorama["luminance"])
    assert result.zenith_luminance == plain.zenith_luminance
    assert plain.instrument is plain.instrument_luminance is plain.instrument_magnitude is None
    assert not any(key.startswith("instrument") for key in plain.panorama.attrs)
    expected = read(plain.panorama, "sqm")
    assert result.instrument == "sqm"
    assert result.instrument_luminance == pytest.approx(expected, rel=RTOL)
    magnitude = float(luminance_to_magnitude(expected + natural("sqm")))
    assert result.instrument_magnitude == pytest.approx(magnitude, rel=RTOL)
    attrs = result.panorama.attrs
    assert attrs["instrument_luminance_cd_m2"] == result.instrument_luminance
    assert attrs["instrument_sky_brightness"] == result.instrument_magnitude
    assert (attrs["instrument_spectrum"], attrs["instrument_spectrum_source"]) == (
        DEFAULT_SPECTRUM,
        "default",
    )


def test_the_wide_sqm_reads_more_of_the_low_sky_than_the_lensed_one(
    fine_kernel: xr.Dataset,
) -> None:
    """An observer 2 km from the lights: the glow rises towards the town's horizon, so the
    84 deg SQM takes in more of it than the 20 deg SQM-L, whose reading stays near the
    zenith's (both have the SQM's band: one colour term)."""
    scene = Scene(town(), kernel=fine_kernel)
    observer = Observer(*POINTS[2], height=0.0)
    wide = skyglow(scene, observer, instrument="sqm")
    narrow = skyglow(scene, observer, instrument="sqm-l")
    factor = float(instrument_luminance(1.0, "sqm", DEFAULT_SPECTRUM))
    assert wide.instrument_luminance is not None and narrow.instrument_luminance is not None
    assert wide.instrument_luminance / factor > 1.2 * wide.zenith_luminance
    assert narrow.instrument_luminance / factor == pytest.approx(wide.zenith_luminance, rel=0.1)


def test_terrain_hides_its_share_of_the_artificial_sky(small_kernel: xr.Dataset) -> None:
    scene = Scene(town(), kernel=small_kernel, dem=ridge())
    result = skyglow(scene, Observer(*POINTS[0], height=1.7), instrument="sqm")
    luminance = result.panorama["luminance"].values
    assert np.isnan(luminance).any()  # the ridge hides the low sky to the west
    assert result.instrument_luminance == pytest.approx(read(result.panorama, "sqm"), rel=RTOL)


def test_the_spectrum_is_given_else_the_emissions_tag_else_the_default(
    fine_kernel: xr.Dataset,
) -> None:
    observer = Observer(*POINTS[0], height=0.0)
    by_tag = skyglow(Scene(town({"spectrum": "HPS"}), kernel=fine_kernel), observer,
                     instrument="tess-w")  # fmt: skip
    assert by_tag.panorama.attrs["instrument_spectrum"] == "HPS"
    assert by_tag.instrument_luminance == pytest.approx(
        read(by_tag.panorama, "tess-w", "HPS"), rel=RTOL
    )
    given = skyglow(Scene(town({"spectrum": "HPS"}), kernel=fine_kernel), observer,
                    instrument="tess-w", spectrum="LED_3000K")  # fmt: skip
    assert given.panorama.attrs["instrument_spectrum_source"] == "spectrum="
    assert given.instrument_luminance == pytest.approx(
        read(given.panorama, "tess-w", "LED_3000K"), rel=RTOL
    )
    # an RGB panorama takes its colours from the same spectrum; a V one opens nothing for it
    assert _colour_spectrum("RGB", Scene(town({"spectrum": "HPS"}))) == "HPS"
    assert _colour_spectrum("RGB", Scene(town())) == DEFAULT_SPECTRUM


def test_a_given_natural_sky_is_added_as_it_is(fine_kernel: xr.Dataset) -> None:
    scene = Scene(town(), kernel=fine_kernel)
    result = skyglow(scene, Observer(*POINTS[2], height=0.0), instrument="eye",
                     natural_luminance=3e-4)  # fmt: skip
    assert result.instrument_luminance is not None
    expected = float(luminance_to_magnitude(result.instrument_luminance + 3e-4))
    assert result.instrument_magnitude == pytest.approx(expected, rel=RTOL)
    assert result.panorama.attrs["instrument_natural_source"] == "natural_luminance="


# --- observers -----------------------------------------------------------------------------


def test_every_observer_reads_what_skyglow_reads(fine_kernel: xr.Dataset, tmp_path: Path) -> None:
    scene = Scene(town({"spectrum": "HPS"}), kernel=fine_kernel)
    sites = [Observer(x, y, height=0.0) for x, y in POINTS]
    folder = tmp_path / "skies"
    folder.mkdir()
    result = observers(scene, sites, tmp_path / "s.gpkg", panoramas=folder, top_cells=1,
                       scheduler="synchronous", instrument="sqm-l", progress=False)  # fmt: skip
    fields = [*SUMMARY_FIELDS, *INSTRUMENT_FIELDS]
    assert list(result.summary.columns[: len(fields)]) == fields
    for row, site in zip(result.summary.itertuples(), sites, strict=True):
        alone = skyglow(scene, site, instrument="sqm-l")
        assert row.instrument_luminance == pytest.approx(alone.instrument_luminance, rel=RTOL)
        assert row.instrument_sky_brightness == pytest.approx(alone.instrument_magnitude, rel=RTOL)
        written = xr.load_dataset(folder / f"{row.name}.nc", engine="h5netcdf")
        assert written.attrs["instrument"] == "sqm-l"
        assert written.attrs["instrument_spectrum"] == "HPS"
    plain = observers(scene, sites, top_cells=1, scheduler="synchronous", progress=False)
    assert not set(INSTRUMENT_FIELDS) & set(plain.summary.columns)
    np.testing.assert_array_equal(
        plain.summary["zenith_artificial"], result.summary["zenith_artificial"]
    )


def test_observers_on_terrain_read_what_skyglow_reads(fine_kernel: xr.Dataset) -> None:
    scene = Scene(town(), kernel=fine_kernel, dem=ridge())
    sites = [Observer(x, y, height=1.7) for x, y in POINTS]
    result = observers(scene, sites, top_cells=0, scheduler="synchronous", instrument="sqm",
                       progress=False)  # fmt: skip
    for row, site in zip(result.summary.itertuples(), sites, strict=True):
        alone = skyglow(scene, site, instrument="sqm")
        assert row.instrument_luminance == pytest.approx(alone.instrument_luminance, rel=RTOL)


def test_the_instrument_columns_take_from_the_top_cells_limit(
    small_kernel: xr.Dataset, tmp_path: Path
) -> None:
    scene = Scene(town(), kernel=small_kernel)
    sites = [Observer(*POINTS[0], height=0.0)]
    with pytest.raises(InputError, match=r"top_cells=662: .* at most 661 top cells"):
        observers(scene, sites, tmp_path / "s.gpkg", top_cells=662, instrument="sqm",
                  progress=False)  # fmt: skip


# --- the shared part --------------------------------------------------------------------------


def test_without_an_instrument_nothing_is_read() -> None:
    assert instrument_sky(None, spectrum="no such", natural_luminance=-1.0) is None


def test_the_default_natural_sky_is_a_uniform_moonless_sky_in_the_instruments_band() -> None:
    for name in ("sqm", "sqm-l", "tess-w", "eye"):
        reader = instrument_sky(name)
        assert reader is not None
        assert reader.natural == pytest.approx(natural(name), rel=RTOL)
        # a uniform sky of that luminance is read as it is by every angular response
        elevation = 90.0 - (np.arange(32) + 0.5) * 90.0 / 32
        azimuth = (np.arange(16) + 0.5) * 22.5
        uniform = np.full((32, 16), NATURAL_ZENITH_LUMINANCE)
        weights = reader.panorama_weights(elevation, azimuth)
        assert float(np.sum(weights * uniform)) == pytest.approx(
            NATURAL_ZENITH_LUMINANCE, rel=1e-12
        )


def test_weights_come_back_in_the_kernels_row_order() -> None:
    reader = instrument_sky("sqm-l")
    assert reader is not None
    descending = 90.0 - (np.arange(16) + 0.5) * 90.0 / 16
    down = reader.elevation_weights(descending)
    up = reader.elevation_weights(descending[::-1])
    np.testing.assert_allclose(down, up[::-1], rtol=1e-12)
    assert down[0] > down[-1]  # the zenith row first
    panorama = reader.panorama_weights(descending, (np.arange(8) + 0.5) * 45.0)
    np.testing.assert_allclose(panorama.sum(axis=1), down, rtol=1e-12)


def test_the_spectrum_tag_of_every_emission_input(tmp_path: Path) -> None:
    raster = town({"spectrum": "LPS"})
    assert emission_spectrum(raster) == "LPS"
    assert emission_spectrum(raster.lit_cells()) is None
    assert emission_spectrum(None) is None
    path = tmp_path / "emission.tif"
    raster.write(path)
    assert emission_spectrum(path) == "LPS"
    assert emission_spectrum(xr.DataArray(np.zeros((2, 2)), attrs={"spectrum": "HPS"})) == "HPS"
