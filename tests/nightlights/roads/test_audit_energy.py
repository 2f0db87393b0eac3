"""Energy in the audit: one segment against a hand computation of P, W, D_P, D_E and CO2."""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
from pyproj import Transformer
from shapely import LineString, Point

from nightlights import roads
from nightlights.errors import DataQualityWarning, InputError
from nightlights.streets import place

#: Helsinki in ETRS-TM35FIN [m].
X0, Y0 = 385_000.0, 6_672_000.0
LENGTH, WIDTH = 200.0, 6.0


def _layers() -> tuple[gpd.GeoDataFrame, gpd.GeoDataFrame]:
    streets = gpd.GeoDataFrame(
        {
            "source_id": ["a"],
            "width": [WIDTH],
            "lanes": [2],
            "lit": [True],
            "arrangement": ["single_sided"],
            "spacing": [25.0],
            "mounting_height": [6.0],
            "system_id": ["street_led_small"],
            "lighting_class": ["P3"],
        },
        geometry=[LineString([(X0, Y0), (X0 + LENGTH, Y0)])],
        crs="EPSG:3067",
    )
    lights = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0).lights
    lights["power"] = 40.0 + np.arange(len(lights), dtype=float)  # [W]
    extra = gpd.GeoDataFrame(
        {
            "light_id": [900, 901],
            "street_id": [None, None],
            "system_id": ["street_led_small"] * 2,
            "heading": [0.0, 0.0],
            "power": [30.0, 1000.0],
        },
        geometry=[Point(X0 + 50, Y0 + 20), Point(X0 + 50, Y0 + 300)],  # 20 m and 300 m away
        crs="EPSG:3067",
    )
    return gpd.GeoDataFrame(pd.concat([lights, extra], ignore_index=True), crs="EPSG:3067"), streets


def _hand(lights: gpd.GeoDataFrame) -> tuple[float, float]:
    """Power of the lights that belong to the segment [W] and the burning hours of 2024 [h]."""
    power = float(lights["power"].iloc[:-1].sum())  # all but the light 300 m away
    lon, lat = Transformer.from_crs(3067, 4326, always_xy=True).transform(X0 + LENGTH / 2, Y0)
    return power, roads.annual_burning_hours(lon, lat, 2024)


def test_one_segment_against_hand_computation() -> None:
    lights, streets = _layers()
    options = roads.EnergyOptions(2024, grid_factor=0.4)
    with pytest.warns(DataQualityWarning, match="farther than 50 m"):
        result = roads.audit(lights, streets, energy=options)
    row = result.segments.iloc[0]
    power, hours = _hand(lights)
    area = LENGTH * WIDTH
    assert row["power_w"] == pytest.approx(power, rel=1e-9)
    assert row["energy_kwh"] == pytest.approx(power * hours / 1000, rel=1e-3)
    assert row["energy_density"] == pytest.approx(power * hours / area, rel=1e-3)
    assert row["power_density"] == pytest.approx(
        power / (row["average_illuminance"] * area), rel=1e-3
    )
    assert row["co2_kg"] == pytest.approx(power * hours / 1000 * 0.4, rel=1e-3)
    totals = result.summary.to_dict()["energy"]
    assert totals["energy_kwh"] == pytest.approx(power * hours / 1000, rel=1e-3)
    assert totals["energy_density"] == pytest.approx(power * hours / area, rel=1e-3)
    assert totals["co2_kg"] == pytest.approx(power * hours * 0.4 / 1000, rel=1e-3)
    assert totals["unassigned_lights"] == 1


def test_schedule_and_dimming_scale_the_energy() -> None:
    lights, streets = _layers()
    _, hours = _hand(lights)
    lights = lights.iloc[:-1].assign(level=0.5)  # the light 300 m away dropped
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        half = roads.audit(
            lights, streets, energy=roads.EnergyOptions(2024, schedule="12:00=0.5", zone="UTC")
        )
        dimmed = roads.audit(lights, streets, dimming="level", energy=roads.EnergyOptions(2024))
    power = float(lights["power"].sum())
    assert half.segments["energy_kwh"].iloc[0] == pytest.approx(power * hours / 2000, rel=1e-3)
    assert dimmed.segments["power_w"].iloc[0] == pytest.approx(power / 2, rel=1e-9)
    assert dimmed.summary.energy is not None and half.summary.energy["co2_kg"] is None


def test_luminance_classes_have_no_power_density() -> None:
    lights, streets = _layers()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(
            lights, streets.assign(lighting_class=["M4"]), energy=roads.EnergyOptions(2024)
        )
    row = result.segments.iloc[0]
    assert np.isnan(row["power_density"]) and row["energy_density"] > 0


def test_bad_energy_options_write_nothing(tmp_path) -> None:
    lights, streets = _layers()
    out, summary = tmp_path / "a.gpkg", tmp_path / "a.json"
    for options, match in [
        (roads.EnergyOptions(2024, grid_factor=-1.0), "grid_factor"),
        (roads.EnergyOptions(2024, schedule="22:00=2"), "schedule|level"),
        (roads.EnergyOptions(1800), "year=1800"),
    ]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DataQualityWarning)
            with pytest.raises(InputError, match=match):
                roads.audit(lights, streets, out, energy=options, summary_json=summary)
        assert not out.exists() and not summary.exists()
    lights = lights.assign(power=np.nan, system_id="no_such_system")
    with pytest.raises(InputError):
        roads.audit(lights, streets, out, energy=roads.EnergyOptions(2024))
    assert not out.exists()
