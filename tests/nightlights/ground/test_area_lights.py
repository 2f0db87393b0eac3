"""Area sources as Voronoi pseudo-lights (Chuang 2011, Sec. 5.2)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from nightlights.errors import InputError
from nightlights.ground import (
    AreaLightOptions,
    InfluenceThreshold,
    area_luminaires,
    compute_irradiance,
    flux_profile,
    grid_from_bounds,
    irradiance,
    lambertian_panel_table,
    pseudo_lights,
    read_area_lights,
    rectangle_illuminance,
)

CRS = "EPSG:32633"


@settings(max_examples=25, deadline=None)
@given(st.floats(1.0, 80.0), st.floats(1.0, 80.0), st.floats(0.5, 30.0), st.floats(0, 500))
def test_pseudo_lights_carry_the_whole_flux(
    width: float, depth: float, spacing: float, exitance: float
) -> None:
    polygon = shapely.Polygon([(0, 0), (width, 0), (width, depth), (0.3 * width, 1.5 * depth)])
    lights = pseudo_lights([polygon], [exitance], spacing=spacing)
    assert lights.flux.sum() == pytest.approx(exitance * polygon.area, rel=1e-9, abs=1e-9)
    assert np.all(shapely.contains_xy(polygon.buffer(1e-9), lights.x, lights.y))
    assert len(lights.x) >= 1


def test_holes_and_multipolygons() -> None:
    ring = shapely.box(0, 0, 30, 30).difference(shapely.box(10, 10, 20, 20))
    multi = shapely.MultiPolygon([shapely.box(100, 0, 104, 4), shapely.box(110, 0, 111, 1)])
    lights = pseudo_lights([ring, multi, shapely.Polygon()], [2.0, 3.0, 5.0], spacing=3.0)
    assert lights.flux[lights.source == 0].sum() == pytest.approx(2.0 * 800)
    assert lights.flux[lights.source == 1].sum() == pytest.approx(3.0 * 17)
    assert not np.any(lights.source == 2)
    assert not np.any(shapely.contains_xy(shapely.box(10, 10, 20, 20), lights.x, lights.y))


def test_panel_table_emits_one_lumen_downwards() -> None:
    profile = flux_profile(lambertian_panel_table())
    assert profile.downward_flux == pytest.approx(1.0, rel=1e-4)  # midpoint rule, 0.5 deg
    assert profile.upward_flux == pytest.approx(0.0, abs=1e-12)


def test_rectangle_reference_is_the_infinite_plane_limit() -> None:
    """Under a huge uniform Lambertian plane E = M (view factor 1)."""
    value = rectangle_illuminance(0.0, 0.0, (-1e5, -1e5, 1e5, 1e5), exitance=50.0, height=10.0)
    assert value == pytest.approx(50.0, rel=1e-3)
    # Symmetry: the four corners of a rectangle see the same.
    corners = rectangle_illuminance(
        [0, 40, 0, 40], [0, 0, 20, 20], (0, 0, 40, 20), exitance=1.0, height=8.0
    )
    np.testing.assert_allclose(corners, corners[0], rtol=1e-12)


def test_pseudo_lights_converge_to_the_exact_panel() -> None:
    """Spacing = height / 2 (the default) stays within 2 % of the peak (Howell B-3 exact)."""
    grid = grid_from_bounds((-30, -30, 70, 50), 1.0)
    x = grid.x_min + np.arange(grid.cols) + 0.5
    y = grid.y_max - np.arange(grid.rows) - 0.5
    exact = rectangle_illuminance(x[None, :], y[:, None], (0, 0, 40, 20), exitance=100, height=8.0)
    errors = []
    for spacing in (16.0, 4.0, 1.0):
        lights = pseudo_lights([shapely.box(0, 0, 40, 20)], [100.0], spacing=spacing)
        luminaires = area_luminaires(lights, height=8.0)
        result = compute_irradiance(
            grid,
            luminaires,
            luminaires.intensity_scale[:, None],
            np.full(len(lights.x), 1e4),
            progress=False,
        )
        errors.append(np.abs(result.bands[0] - exact).max() / exact.max())
    assert errors[0] > errors[1] > errors[2]
    assert errors[1] < 0.02


def write_areas(path: Path, exitance: list, crs: str | None = CRS) -> Path:
    frame = gpd.GeoDataFrame(
        {"lux_out": exitance},
        geometry=[shapely.box(10 * i, 0, 10 * i + 8, 8) for i in range(len(exitance))],
        crs=crs,
    )
    frame.to_file(path, driver="GPKG")
    return path


def test_read_area_lights_validates(tmp_path: Path) -> None:
    good = write_areas(tmp_path / "a.gpkg", [10.0, 20.0])
    lum = read_area_lights(good, exitance_field="lux_out", crs=CRS, options=AreaLightOptions())
    assert lum.intensity_scale.sum() == pytest.approx(64 * 30)
    with pytest.raises(InputError, match="no field 'exitance'"):
        read_area_lights(good, exitance_field="exitance", crs=CRS, options=AreaLightOptions())
    bad = write_areas(tmp_path / "b.gpkg", [10.0, -1.0])
    with pytest.raises(InputError, match=r"features \[1\]"):
        read_area_lights(bad, exitance_field="lux_out", crs=CRS, options=AreaLightOptions())
    with pytest.raises(InputError, match="height"):
        AreaLightOptions(height=0.0)


def test_stage_with_area_sources_only(tmp_path: Path) -> None:
    areas = write_areas(tmp_path / "a.gpkg", [100.0])
    lights = tmp_path / "none.gpkg"
    gpd.GeoDataFrame(
        {"light_id": [], "system_id": [], "heading": []}, geometry=[], crs=CRS
    ).to_file(lights, driver="GPKG")
    out = tmp_path / "e.tif"
    fluxes = []
    for threshold in (InfluenceThreshold("energy", 0.005), InfluenceThreshold()):
        irradiance(
            lights,
            out,
            resolution=1.0,
            bounds=(-300, -300, 300, 300),
            area_sources=areas,
            exitance_field="lux_out",
            progress=False,
            threshold=threshold,
            database=object(),  # type: ignore[arg-type]
        )
        with rasterio.open(out) as dataset:
            fluxes.append(dataset.read(1).astype(float).sum())
    # 100 lm/m2 x 64 m2 = 6400 lm lands on the ground; the 600 m raster holds > 99 %.
    assert fluxes[0] == pytest.approx(6400, rel=0.01)
    # The default floor (0.01 lx) cuts this broad Lambertian source where E = 0.01 lx:
    # (6400/pi) cos^4(t) / 8^2 = 0.01 gives cos^2(t) = 1.77 %, the flux fraction beyond
    # (analytic, Lambertian point source); a few pixels more are lost at the disc edge.
    assert fluxes[1] == pytest.approx(6400 * (1 - 0.0177), rel=0.005)


def test_area_sources_need_a_spectrum_for_sensor_bands(tmp_path: Path) -> None:
    areas = write_areas(tmp_path / "a.gpkg", [100.0])
    lights = tmp_path / "none.gpkg"
    gpd.GeoDataFrame(
        {"light_id": [], "system_id": [], "heading": []}, geometry=[], crs=CRS
    ).to_file(lights, driver="GPKG")
    kwargs = {
        "resolution": 2.0,
        "sensors": ("photopic", "scotopic"),
        "area_sources": areas,
        "exitance_field": "lux_out",
        "progress": False,
    }
    with pytest.raises(InputError, match=r"area_source has none.*area_options\.spectrum="):
        irradiance(lights, tmp_path / "e.tif", **kwargs)
    irradiance(
        lights, tmp_path / "e.tif", area_options=AreaLightOptions(spectrum="LED_4000K"), **kwargs
    )
    with rasterio.open(tmp_path / "e.tif") as dataset:
        photopic, scotopic = dataset.read().astype(float)
    from ies.spectra import sensor_factor

    lit = photopic > 1
    np.testing.assert_allclose(
        scotopic[lit] / photopic[lit], sensor_factor("LED_4000K", "scotopic"), rtol=1e-5
    )
