"""Scene(clouds=...): the skyglow stage under a cloud deck."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from nightlights.io import Raster
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.clouds import CloudLayer, cloud_luminance


@pytest.fixture(scope="module")
def scene() -> Scene:
    flux = np.zeros((1, 40, 40))
    flux[0, 19, 31] = 1e-3  # one lit 250 m cell, 62.5 lm [lm m-2]
    raster = Raster(flux, Affine(250, 0, 0, 0, -250, 10000), "EPSG:32635")
    spec = KernelSpec(r_max=12000.0, n_distance=24, n_elevation=8, n_azimuth=32)
    return Scene(raster, kernel=build_kernel(spec, progress=False))


def test_no_deck_and_zero_cover_leave_the_clear_sky_bitwise(scene: Scene) -> None:
    observer = Observer(5000.0, 5000.0, height=0.0)
    clear = skyglow(scene, observer).panorama
    none = skyglow(scene.replace(clouds=None), observer).panorama
    zero = skyglow(scene.replace(clouds=CloudLayer(1000.0, cover=0.0)), observer).panorama
    assert np.array_equal(clear["luminance"].values, none["luminance"].values)
    assert np.array_equal(clear["luminance"].values, zero["luminance"].values)
    assert "cloud_cover" not in clear.attrs


def test_overcast_zenith_is_the_point_source_model(scene: Scene) -> None:
    # the lit cell's centre lies 2,875 m east of the observer and 125 m south
    observer = Observer(5000.0, 5000.0, height=0.0)
    deck = CloudLayer(1000.0, optical_depth=15.0)
    pano = skyglow(scene.replace(clouds=deck), observer).panorama
    top = float(pano["elevation"].values.max())
    distance = float(np.hypot(2875.0, 125.0))
    flux = 1e-3 * 250.0 * 250.0  # [lm]
    atmosphere = Atmosphere.from_parameters(scene.kernel_dataset().attrs)  # type: ignore[union-attr]
    expected = flux * float(
        np.mean(cloud_luminance(top, np.arange(32) * 11.25, distance, deck, atmosphere))
    )
    assert float(pano.attrs["zenith_luminance_cd_m2"]) == pytest.approx(expected, rel=0.1)
    assert pano.attrs["natural_sky_factor"] == pytest.approx(deck.transmittance)
    assert pano.attrs["stars_factor"] == 0.0


def test_the_scene_refuses_what_is_no_deck(scene: Scene) -> None:
    from nightlights.errors import InputError

    with pytest.raises(InputError, match="clouds"):
        scene.replace(clouds=1000.0)


def test_stages_without_a_cloud_model_refuse_a_deck(scene: Scene) -> None:
    from nightlights.errors import InputError
    from nightlights.sky.observers import observers

    cloudy = scene.replace(clouds=CloudLayer(1000.0))
    with pytest.raises(InputError, match="clear sky only"):
        observers(cloudy, [Observer(5000.0, 5000.0, height=0.0)], progress=False)
