"""The zenith Q map under a cloud deck, against the skyglow panorama's zenith."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.errors import InputError
from nightlights.inverse import inverse_q
from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.clouds import CloudLayer


@pytest.fixture(scope="module")
def scene() -> Scene:
    flux = np.zeros((1, 24, 24))
    flux[0, 10:14, 10:14] = 2e-3  # a 1 km town of 250 m cells [lm m-2]
    flux[0, 4, 19] = 5e-3  # and a village
    raster = Raster(flux, Affine(250, 0, 0, 0, -250, 6000), "EPSG:32635")
    spec = KernelSpec(r_max=9000.0, n_distance=20, n_elevation=8, n_azimuth=32)
    return Scene(raster, kernel=build_kernel(spec, progress=False))


@pytest.mark.parametrize("cover", [1.0, 0.5])
def test_the_cells_add_up_to_the_overcast_zenith(scene: Scene, cover: float) -> None:
    cloudy = scene.replace(clouds=CloudLayer(1000.0, optical_depth=15.0, cover=cover))
    observer = Observer(4125.0, 3125.0, height=0.0)
    q = inverse_q(cloudy, observer, metric="zenith", progress=False)
    expected = float(skyglow(cloudy, observer).panorama.attrs["zenith_luminance_cd_m2"])
    assert q.total == pytest.approx(expected, rel=0.01)
    assert q.panorama_value == pytest.approx(expected, rel=0.01)
    assert q.raster.tags["cloud_cover"] == str(cover)


def test_the_deck_shifts_the_share_towards_near_cells(scene: Scene) -> None:
    # the deck reflects the light of the cells below it: the town, under the observer, gains
    # more than the village 3.6 km away
    observer = Observer(3000.0, 3000.0, height=0.0)
    clear = inverse_q(scene, observer, metric="zenith", progress=False).raster.data[0]
    deck = scene.replace(clouds=CloudLayer(1000.0, optical_depth=15.0))
    overcast = inverse_q(deck, observer, metric="zenith", progress=False).raster.data[0]
    assert overcast[11, 11] / clear[11, 11] > overcast[4, 19] / clear[4, 19]


def test_other_metrics_refuse_a_deck(scene: Scene) -> None:
    deck = scene.replace(clouds=CloudLayer(1000.0))
    with pytest.raises(InputError, match="metric='pca-norm'"):
        inverse_q(deck, Observer(3000.0, 3000.0), progress=False)


def test_zero_cover_leaves_the_clear_values_bitwise(scene: Scene) -> None:
    observer = Observer(3000.0, 3000.0, height=0.0)
    clear = inverse_q(scene, observer, metric="zenith", progress=False).raster.data
    zero = scene.replace(clouds=CloudLayer(1000.0, cover=0.0))
    values = inverse_q(zero, observer, metric="zenith", progress=False).raster.data
    assert np.array_equal(values, clear, equal_nan=True)
