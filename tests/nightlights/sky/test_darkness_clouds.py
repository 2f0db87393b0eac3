"""The darkness map under a cloud deck, against the skyglow panorama at single cells."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, darkness, skyglow
from nightlights.sky.clouds import CloudLayer


@pytest.fixture(scope="module")
def scene() -> Scene:
    flux = np.zeros((1, 24, 24))
    flux[0, 10:14, 10:14] = 2e-3  # a 1 km town of 250 m cells [lm m-2]
    flux[0, 4, 19] = 5e-3  # and a village
    raster = Raster(flux, Affine(250, 0, 0, 0, -250, 6000), "EPSG:32635")
    spec = KernelSpec(r_max=9000.0, n_distance=20, n_elevation=8, n_azimuth=32)
    return Scene(raster, kernel=build_kernel(spec, progress=False))


def _centre(row: int, col: int) -> Observer:
    return Observer(250.0 * col + 125.0, 6000.0 - 250.0 * row - 125.0, height=0.0)


def test_overcast_map_matches_the_panorama_zenith_at_cells(scene: Scene) -> None:
    deck = CloudLayer(1000.0, optical_depth=15.0, cover=0.7)
    cloudy = scene.replace(clouds=deck)
    zenith = darkness(cloudy, height=0.0, progress=False).raster.data[0]
    for row, col in [(11, 11), (12, 16), (4, 19), (20, 3)]:
        pano = skyglow(cloudy, _centre(row, col)).panorama
        expected = float(pano.attrs["zenith_luminance_cd_m2"])
        assert zenith[row, col] == pytest.approx(expected, rel=2e-3)


def test_zero_cover_and_no_deck_give_the_clear_map_bitwise(scene: Scene) -> None:
    clear = darkness(scene, height=0.0, progress=False).raster
    zero = darkness(
        scene.replace(clouds=CloudLayer(1000.0, cover=0.0)), height=0.0, progress=False
    ).raster
    assert np.array_equal(clear.data, zero.data)
    assert "cloud_cover" not in clear.tags and zero.tags["cloud_cover"] == "0.0"


def test_overcast_brightens_the_town_more_than_far_away(scene: Scene) -> None:
    clear = darkness(scene, height=0.0, progress=False).raster.data[0]
    deck = CloudLayer(1000.0, optical_depth=15.0)
    overcast = darkness(scene.replace(clouds=deck), height=0.0, progress=False).raster.data[0]
    gain = overcast / clear
    assert gain[11, 11] > 2.0  # under a 1 km deck of R = 0.53 the town's zenith is amplified
    assert gain[11, 11] > gain[23, 0]  # and the gain falls away from it


def test_an_instrument_reads_the_overcast_rows_and_a_dimmed_natural_sky(scene: Scene) -> None:
    deck = CloudLayer(1000.0, optical_depth=15.0, cover=0.8)
    cloudy = scene.replace(clouds=deck)
    clear = darkness(scene, height=0.0, instrument="sqm", progress=False).raster
    mapped = darkness(cloudy, height=0.0, instrument="sqm", progress=False).raster
    for row, col in [(11, 11), (20, 3)]:
        pano = skyglow(cloudy, _centre(row, col), instrument="sqm").panorama
        expected = float(pano.attrs["instrument_luminance_cd_m2"])
        assert mapped.data[0][row, col] == pytest.approx(expected, rel=2e-3)
    # the deck passes T = 1 - R of the diffuse natural sky, under the cover's share
    factor = 1.0 - 0.8 * deck.reflectance
    natural = float(clear.tags["instrument_natural_cd_m2"])
    assert float(mapped.tags["instrument_natural_cd_m2"]) == pytest.approx(natural * factor)


def test_what_the_map_cannot_carry_is_refused(scene: Scene) -> None:
    deck = CloudLayer(1000.0)
    flat = Raster(np.zeros((1, 24, 24)), Affine(250, 0, 0, 0, -250, 6000), "EPSG:32635")
    with pytest.raises(InputError, match="DEM"):
        darkness(scene.replace(clouds=deck, dem=flat), progress=False)
