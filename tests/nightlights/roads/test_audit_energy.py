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
from nightlights.errors import DataQualityWarning
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


def test_luminance_classes_have_a_power_density_from_their_illuminance_field() -> None:
    """An M class is rated on luminance; its D_P comes from the horizontal illuminance field
    laid on its sections too: P / (E_av A), E_av checked against a point-by-point sum."""
    lights, streets = _layers()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(
            lights, streets.assign(lighting_class=["M4"]), energy=roads.EnergyOptions(2024)
        )
    row = result.segments.iloc[0]
    model = result.model
    fields, lum = model.fields, model.luminaires
    xy = fields.illuminance.xy
    assert xy.size and row["average_luminance"] > 0
    from nightlights.roads._geometry import intensities

    tables = [(lambda t: lambda v, h: t.lookup(v, h))(lum.tables[i]) for i in lum.table_index]
    target = np.column_stack([xy, np.zeros(len(xy))])
    candela = intensities(
        target, lum.light_point, lum.rotation, tables, street_azimuth=lum.street_azimuth
    )
    d = np.linalg.norm(target[None] - lum.light_point[:, None], axis=2)
    e = np.sum(candela * lum.light_point[:, 2, None] / d**3, axis=0)
    least = min(e[fields.illuminance.section == s].mean() for s in range(fields.n_sections))
    assert row["average_illuminance"] == pytest.approx(least, rel=5e-3)
    area = row.geometry.length * row["width"]
    assert row["power_density"] == pytest.approx(
        row["power_w"] / (row["average_illuminance"] * area), rel=1e-9
    )
    assert row["energy_density"] > 0
