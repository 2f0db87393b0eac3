"""Extending the toolkit through its registries alone (docs/extending.md).

A toy emission shape, a toy sky-region kind and a toy raster style are each added by one
registration call, used in a real computation or write, checked against what the built-in
machinery gives for the same thing, and removed again.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
import xarray as xr
from affine import Affine
from numpy.typing import ArrayLike
from pyproj import CRS

from nightlights.emission_functions import (
    SINE_POWER_FORM,
    TABLE_FORM,
    emission_intensity,
    emission_shape_names,
    register_emission_shape,
    unregister_emission_shape,
)
from nightlights.errors import InputError
from nightlights.inverse import (
    SkyRegion,
    inverse_s,
    region_kinds,
    region_numbers,
    register_region_kind,
    unregister_region_kind,
)
from nightlights.io import Raster
from nightlights.io.styles import (
    PRODUCT_TAG,
    raster_styles,
    register_raster_style,
    sidecar_path,
    unregister_raster_style,
)
from nightlights.sky import KernelSpec, Observer, Scene, build_kernel, skyglow
from nightlights.sky.kernel import sky_luminance, sky_luminance_grid
from nightlights.sky.montecarlo import monte_carlo_luminance

#: The toy shape: a cos^2 lobe about the vertical, tabulated every degree.
ANGLES = np.arange(91.0)
COS2 = np.cos(np.radians(ANGLES)) ** 2
#: The same table as a built-in tabulated emission function.
COS2_TEXT = "tabulated:" + json.dumps({"angles": ANGLES.tolist(), "intensities": COS2.tolist()})
TINY: dict[str, Any] = {"r_max": 3000.0, "n_distance": 8, "n_elevation": 8, "n_azimuth": 16}


@pytest.fixture
def toy_shapes() -> Iterator[None]:
    """``cos2_lobe`` (the table form) and ``sin4_twin`` (the sine power of ``uplight``)."""
    register_emission_shape(
        "cos2_lobe",
        code=TABLE_FORM,
        angles=ANGLES,
        intensities=COS2,
        doc="cos^2 lobe about the vertical, tabulated every degree",
    )
    register_emission_shape(
        "sin4_twin", code=SINE_POWER_FORM, exponent=4.0, doc="the uplight lobe, n = 4"
    )
    try:
        yield
    finally:
        unregister_emission_shape("cos2_lobe")
        unregister_emission_shape("sin4_twin")
    assert "cos2_lobe" not in emission_shape_names()


def _above(argument: str, text: str) -> SkyRegion:
    return SkyRegion("above", text, parameters=tuple(region_numbers(argument, 1, text, "above:EL")))


def _above_mask(region: SkyRegion, elevation: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    return np.asarray(elevation >= region.parameters[0])


@pytest.fixture
def toy_region_kind() -> Iterator[None]:
    """``above:EL``: every direction at or above elevation EL."""
    register_region_kind(
        "above",
        form="above:EL",
        parse=_above,
        mask=_above_mask,
        doc="every direction at or above elevation EL [deg]",
    )
    try:
        yield
    finally:
        unregister_region_kind("above")
    assert "above" not in region_kinds()


def _toy_style(
    descriptions: Sequence[str],
    units: Sequence[str],
    bands: Sequence[ArrayLike],
    tags: Mapping[str, str],
) -> str:
    peak = float(np.nanmax(np.asarray(bands[0], dtype=float)))
    return f"<!-- toy style of {descriptions[0]} [{units[0]}], peak {peak:g} -->\n"


@pytest.fixture
def toy_style() -> Iterator[None]:
    register_raster_style("toy_product", _toy_style)
    try:
        yield
    finally:
        unregister_raster_style("toy_product")
    assert "toy_product" not in raster_styles()


def _emission(tag: str) -> Raster:
    flux = np.zeros((1, 20, 20))
    flux[0, 5, 15] = flux[0, 12, 3] = 1.0  # [lm m-2]
    return Raster(
        flux,
        Affine(100, 0, 0, 0, -100, 2000),
        CRS("EPSG:32635"),
        ("upward",),
        ("lm m-2",),
        band_tags=({"emission_function": tag},),
    )


@pytest.mark.usefixtures("toy_shapes")
def test_a_toy_shape_equals_the_builtin_it_copies() -> None:
    mu = np.linspace(-0.1, 1.0, 23)
    # one registration: the intensity is the table form's, normalised to 1 lm
    np.testing.assert_array_equal(
        emission_intensity(mu, "cos2_lobe"), emission_intensity(mu, COS2_TEXT)
    )
    elevation, azimuth, distance = np.linspace(2.0, 88.0, 5), np.linspace(0, 180, 7), [80.0, 2e3]
    toy = sky_luminance_grid(elevation, azimuth, distance, emission="cos2_lobe")
    builtin = sky_luminance_grid(elevation, azimuth, distance, emission=COS2_TEXT)
    np.testing.assert_array_equal(toy, builtin)
    # the numpy reference and the compiled form agree on the toy as on every shape
    rays = (elevation[:, None, None], azimuth[None, :, None], np.asarray(distance))
    reference = sky_luminance(*rays, emission="cos2_lobe", backend="numpy")
    np.testing.assert_allclose(sky_luminance(*rays, emission="cos2_lobe"), reference, rtol=1e-6)
    # a sine power of its own exponent: the uplight lobe, in both integrators
    np.testing.assert_array_equal(
        sky_luminance(*rays, emission="sin4_twin"), sky_luminance(*rays, emission="uplight")
    )
    twin, uplight = (
        monte_carlo_luminance(60.0, 0.0, 2e3, emission=e, photons=200, max_order=2, seed=5)
        for e in ("sin4_twin", "uplight")
    )
    np.testing.assert_array_equal(twin.luminance, uplight.luminance)


@pytest.mark.usefixtures("toy_shapes")
def test_a_toy_shape_gets_its_kernel_table_and_band_tag() -> None:
    single: dict[str, Any] = {**TINY, "multiple_scattering": "single"}
    toy_kernel = build_kernel(KernelSpec(**single, emission_shapes=("cos2_lobe",)), progress=False)
    tab_kernel = build_kernel(KernelSpec(**single, tabulated_emission=COS2_TEXT), progress=False)
    toy, tab = toy_kernel.kernel, tab_kernel.kernel
    np.testing.assert_array_equal(toy["kernel_cos2_lobe"].values, tab["kernel_tabulated"].values)
    np.testing.assert_array_equal(
        toy["coefficient_cos2_lobe"].values, tab["coefficient_tabulated"].values
    )
    # a band tagged with the toy shape reads its table: the panorama of the same function
    observer = Observer(1000.0, 950.0, height=0.0)
    toy_sky = skyglow(Scene(_emission("cos2_lobe"), kernel=toy), observer).panorama
    tab_sky = skyglow(Scene(_emission(COS2_TEXT), kernel=tab), observer).panorama
    assert float(toy_sky["luminance"].max()) > 0
    xr.testing.assert_equal(toy_sky["luminance"], tab_sky["luminance"])
    # the Monte Carlo cannot sample a table: the multiple-scattering factor borrows a shape's
    with pytest.raises(InputError, match="Monte Carlo samples"):
        monte_carlo_luminance(60.0, 0.0, 2e3, emission="cos2_lobe", photons=10)


def test_an_unregistered_shape_is_refused() -> None:
    with pytest.raises(InputError, match="emission model 'cos2_lobe'"):
        sky_luminance(45.0, 0.0, 1e3, emission="cos2_lobe")
    with pytest.raises(InputError, match="already a built-in shape"):
        register_emission_shape("uplight", code=SINE_POWER_FORM, doc="a second uplight")
    with pytest.raises(InputError, match="compiled form 9"):
        register_emission_shape("new_form", code=9, doc="needs compiled branches first")


@pytest.mark.usefixtures("toy_region_kind")
def test_a_toy_region_kind_masks_and_drives_inverse_s() -> None:
    elevation, azimuth = np.array([80.0, 45.0, 20.0]), np.array([10.0, 200.0])
    region = SkyRegion.parse("above:30")
    assert (region.kind, region.parameters) == ("above", (30.0,))
    assert region.mask(elevation, azimuth).tolist() == [[True, True], [True, True], [False, False]]
    with pytest.raises(InputError, match="above:EL"):
        SkyRegion.parse("above:x")
    # "above:30" is the zenith cap of radius 60: S_i over it is the built-in kind's, exactly
    kernel = build_kernel(KernelSpec(**TINY), progress=False).kernel
    scene, observer = Scene(_emission("lambertian"), kernel=kernel), Observer(1000.0, 950.0)
    toy = inverse_s(scene, observer, region="above:30").raster.data
    builtin = inverse_s(scene, observer, region="zenith:60").raster.data
    assert np.nansum(toy) > 0
    np.testing.assert_array_equal(toy, builtin)


def test_an_unregistered_region_kind_is_refused() -> None:
    with pytest.raises(InputError, match="unknown shortcut 'above'"):
        SkyRegion.parse("above:30")
    with pytest.raises(InputError, match="built-in kind"):
        unregister_region_kind("zenith")


@pytest.mark.usefixtures("toy_style")
def test_a_toy_style_is_written_beside_its_raster(tmp_path: Path) -> None:
    data = np.arange(12.0).reshape(1, 3, 4)
    tags = {PRODUCT_TAG: "toy_product"}
    transform = Affine(10, 0, 0, 0, -10, 30)
    raster = Raster(data, transform, CRS("EPSG:32635"), ("toy",), ("cd m-2",), tags)
    path = raster.write(tmp_path / "toy.tif")
    style = sidecar_path(path).read_text(encoding="utf-8")
    assert style == "<!-- toy style of toy [cd m-2], peak 11 -->\n"
    with rasterio.open(path) as dataset:
        assert dataset.tags()[PRODUCT_TAG] == "toy_product"


def test_the_extending_page_runs_as_printed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The code blocks of docs/extending.md, in order, as one script; it removes what it adds."""
    page = Path(__file__).resolve().parents[2] / "docs" / "extending.md"
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.DOTALL)
    assert len(blocks) >= 5
    before = (emission_shape_names(), region_kinds(), raster_styles())
    monkeypatch.chdir(tmp_path)
    exec(compile("\n".join(blocks), str(page), "exec"), {"__name__": "extending_page"})
    printed = capsys.readouterr().out
    assert "flux 1.0000 lm" in printed
    assert "['coefficient', 'coefficient_cos2_lobe']" in printed
    assert "above (30.0,)" in printed and "glow_share.qml written beside glow_share.tif" in printed
    assert (emission_shape_names(), region_kinds(), raster_styles()) == before
    assert list(tmp_path.iterdir()) == []
