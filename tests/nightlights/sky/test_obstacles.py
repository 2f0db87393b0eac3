"""Obstacles in a scene: the obstructed emission's flux, nothing changed without obstacles
(bitwise), the sky dimmed more far away than overhead, bad input refused."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from scipy.integrate import quad

from nightlights.emission_functions import EmissionFunction
from nightlights.errors import InputError
from nightlights.ground.obstacles import ObstacleProperties, blocked_intensity
from nightlights.io import Raster
from nightlights.io.raster import as_lit_cells
from nightlights.sky import Observer, Scene, darkness, skyglow
from nightlights.sky.obstacles import obstructed_emission

CELL = 100.0
TRANSFORM = Affine(CELL, 0, 500_000, 0, -CELL, 6_700_000)
CRS = "EPSG:32635"


def _town(tags: tuple[str, ...] = ("lambertian", "uplight")) -> Raster:
    data = np.zeros((len(tags), 40, 40))
    data[:, 18:22, 18:22] = 1.0
    if len(tags) > 1:
        data[-1] *= 0.25  # the uplight band
    return Raster(
        data,
        TRANSFORM,
        CRS,
        tuple(f"band{i}" for i in range(len(tags))),
        ("lm m-2",) * len(tags),
        band_tags=tuple({"emission_function": t} for t in tags),
    )


def _flux_through(shape: str, props: ObstacleProperties) -> float:
    """Escaping fraction by adaptive quadrature of the transmitted intensity."""
    kink = math.sin(math.radians(props.angle))
    return (
        2
        * math.pi
        * quad(
            lambda mu: float(
                blocked_intensity(mu, shape, props.height, props.spacing, props.filling)
            ),
            0.0,
            1.0,
            points=[kink],
            limit=200,
        )[0]
    )


def test_lambertian_floor_of_full_canyons_keeps_its_sky_view_factor() -> None:
    props = ObstacleProperties(10.0, 10.0, 1.0)
    out = obstructed_emission(_town(("lambertian",)), props)
    assert out is not None and out.count == 1
    np.testing.assert_allclose(out.data[0, 19, 19], math.cos(math.atan(2.0)), rtol=1e-9)
    assert out.data[0, 0, 0] == 0.0


def test_garstang_band_is_split_into_its_shapes_with_the_escaping_flux() -> None:
    props = ObstacleProperties(17.5, 12.7, 0.55)
    out = obstructed_emission(_town(("garstang:0.15,0.15",)), props)
    assert out is not None and out.count == 2
    assert [t["emission_function"] for t in out.band_tags] == ["lambertian", "garstang:1,0"]
    weights = dict(EmissionFunction.parse("garstang:0.15,0.15").weights)
    # The lobe through the gaps keeps its shape; everything else is carried as Lambertian.
    assert out.data[1, 19, 19] == pytest.approx((1 - 0.55) * weights["garstang_lobe"])
    total = sum(w * _flux_through(s, props) for s, w in weights.items())
    assert out.data[:, 19, 19].sum() == pytest.approx(total, rel=1e-6)


def test_zero_height_obstacles_change_nothing_bitwise(small_kernel: xr.Dataset) -> None:
    town = _town()
    eye = Observer(502_500.0, 6_697_500.0, height=0.0)
    plain = Scene(town, kernel=small_kernel)
    flat = np.zeros((3, 40, 40))
    flat[1] = 20.0
    flat[2] = 1.0
    flat[0, :5, :5] = np.nan  # nodata: no obstacle
    zero = Raster(flat, TRANSFORM, CRS, ("height", "spacing", "filling"))
    for obstacles in (ObstacleProperties(0.0, 20.0, 1.0), ObstacleProperties(9.0, 20.0, 0.0), zero):
        scene = Scene(town, kernel=small_kernel, obstacles=obstacles)
        assert scene.emission is town
        a = skyglow(plain, eye, progress=False).panorama["luminance"].values
        b = skyglow(scene, eye, progress=False).panorama["luminance"].values
        np.testing.assert_array_equal(a, b)
    a = darkness(plain, progress=False).raster.data
    b = darkness(Scene(town, kernel=small_kernel, obstacles=zero), progress=False).raster.data
    np.testing.assert_array_equal(a, b)


def test_obstacles_dim_the_distant_sky_more_than_the_sky_overhead(
    small_kernel: xr.Dataset,
) -> None:
    town = _town()
    props = ObstacleProperties(15.0, 10.0, 1.0)
    plain = Scene(town, kernel=small_kernel)
    blocked = Scene(town, kernel=small_kernel, obstacles=props)
    ratios = []
    for dx in (0.0, 1_500.0):
        eye = Observer(502_000.0 + dx, 6_698_000.0, height=0.0)
        ratios.append(
            skyglow(blocked, eye, progress=False).zenith_luminance
            / skyglow(plain, eye, progress=False).zenith_luminance
        )
    # The sky can lose no more than the flux does (total escaping fraction of the bands) ...
    kept = (_flux_through("lambertian", props) + 0.25 * _flux_through("uplight", props)) / 1.25
    assert ratios[1] < ratios[0] < 1.0
    assert ratios[1] < kept
    # ... and the darkness map sees the same obstructed emission.
    dark = darkness(blocked, progress=False).raster.data[0]
    assert dark.max() < darkness(plain, progress=False).raster.data[0].max()


def test_replace_and_records_keep_the_obstacles_once(tmp_path: Path) -> None:
    town = _town()
    path = tmp_path / "obstacles.tif"
    Raster(
        np.stack([np.full((40, 40), 12.0), np.full((40, 40), 10.0), np.full((40, 40), 0.5)]),
        TRANSFORM,
        CRS,
        ("height", "spacing", "filling"),
    ).write(path)
    scene = Scene(town, obstacles=path)
    again = scene.replace(turbidity=3.0)
    np.testing.assert_array_equal(again.emission.data, scene.emission.data)
    assert scene.inputs["emission"] is town and scene.inputs["obstacles"] == path
    tags = scene.record(xr.Dataset(coords={"elevation": [1], "distance": [1], "azimuth": [1]}))
    assert Scene(town).recorded(tags).obstacles == path


def test_bad_obstacles_are_refused(tmp_path: Path) -> None:
    town = _town()
    wrong = Raster(np.ones((3, 10, 10)), TRANSFORM, CRS)
    with pytest.raises(InputError, match="expected the emission's grid"):
        Scene(town, obstacles=wrong)
    two = Raster(np.ones((2, 40, 40)), TRANSFORM, CRS)
    with pytest.raises(InputError, match="2 bands; expected 3"):
        Scene(town, obstacles=two)
    negative = np.ones((3, 40, 40))
    negative[0, 3, 4] = -2.0
    with pytest.raises(InputError, match=r"obstacle height=-2.0 m at index \(3, 4\)"):
        Scene(town, obstacles=Raster(negative, TRANSFORM, CRS))
    with pytest.raises(InputError, match="not its lit cells"):
        Scene(as_lit_cells(town), obstacles=ObstacleProperties(5.0, 10.0, 0.5))
    with pytest.raises(InputError, match="obstacles of type float"):
        Scene(town, obstacles=3.0)  # type: ignore[arg-type]
