"""The catalogue network chosen from where a street layer lies."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely

from nightlights.errors import DataQualityWarning, InputError
from nightlights.streets._location import (
    FALLBACK_NETWORK,
    REGION_BOXES,
    layer_location,
    network_for_location,
)
from nightlights.streets._sample import network_by_location, sample
from tests.nightlights.streets.conftest import normalized_layer, write_normalized

ROWS: list[dict] = [{"street_class": "local", "lanes": 2}, {"street_class": "arterial"}, {}]


def layer_at(longitude: float, latitude: float, crs: str) -> gpd.GeoDataFrame:
    """Normalised streets about 100 m long near (longitude, latitude) [deg], in ``crs``."""
    layer = normalized_layer(ROWS)
    lines = [
        shapely.LineString(
            [(longitude + 0.001 * i, latitude), (longitude + 0.001 * i, latitude + 0.001)]
        )
        for i in range(len(layer))
    ]
    frame = gpd.GeoDataFrame(layer.drop(columns="geometry"), geometry=lines, crs="EPSG:4326")
    return frame.to_crs(crs)


# (place, longitude [deg], latitude [deg], CRS, expected network)
PLACES = [
    ("Paris", 2.35, 48.86, "EPSG:32631", "europe"),  # UTM 31N
    ("Helsinki", 24.94, 60.17, "EPSG:3067", "europe"),  # ETRS-TM35FIN
    ("Madrid", -3.70, 40.42, "EPSG:25830", "europe"),  # ETRS89 / UTM 30N
    ("Berlin", 13.40, 52.52, "EPSG:4326", "europe"),  # geographic
    ("Chicago", -87.63, 41.88, "EPSG:32616", "north_america"),  # UTM 16N
    ("Vancouver", -123.12, 49.28, "EPSG:32610", "north_america"),  # UTM 10N
    ("New York", -74.01, 40.71, "EPSG:3857", "north_america"),  # web Mercator
    ("Honolulu", -157.86, 21.31, "EPSG:32604", "north_america"),  # UTM 4N
    ("Tokyo", 139.69, 35.69, "EPSG:6677", "east_asia"),  # JGD2011 / Japan plane IX
    ("Tokyo", 139.69, 35.69, "EPSG:32654", "east_asia"),  # UTM 54N
    ("Tokyo", 139.69, 35.69, "EPSG:4326", "east_asia"),  # geographic
    ("Sapporo", 141.35, 43.06, "EPSG:3857", "east_asia"),  # web Mercator
    ("Shanghai", 121.47, 31.23, "EPSG:32651", "east_asia"),  # UTM 51N
    ("Shanghai", 121.47, 31.23, "EPSG:4490", "east_asia"),  # CGCS2000, geographic
    ("Beijing", 116.40, 39.90, "EPSG:3857", "east_asia"),  # web Mercator
    ("Hong Kong", 114.17, 22.30, "EPSG:2326", "east_asia"),  # Hong Kong 1980 Grid
    ("Chengdu", 104.07, 30.67, "EPSG:32648", "east_asia"),  # UTM 48N
    ("Harbin", 126.63, 45.75, "EPSG:32652", "east_asia"),  # UTM 52N
    ("Seoul", 126.98, 37.57, "EPSG:5186", "east_asia"),  # Korea 2000 / Central Belt 2010
    ("Seoul", 126.98, 37.57, "EPSG:3857", "east_asia"),  # web Mercator
    ("Taipei", 121.56, 25.03, "EPSG:3826", "east_asia"),  # TWD97 / TM2 zone 121
    ("Taipei", 121.56, 25.03, "EPSG:4326", "east_asia"),  # geographic
    ("Sydney", 151.21, -33.87, "EPSG:28356", "generic"),  # GDA94 / MGA 56
    ("Sao Paulo", -46.63, -23.55, "EPSG:31983", "generic"),  # SIRGAS 2000 / UTM 23S
    ("Mumbai", 72.88, 19.08, "EPSG:32643", "generic"),  # UTM 43N
    ("Hanoi", 105.85, 21.03, "EPSG:32648", "generic"),  # UTM 48N
    ("Bangkok", 100.50, 13.75, "EPSG:32647", "generic"),  # UTM 47N
    ("Manila", 120.98, 14.60, "EPSG:3857", "generic"),  # web Mercator
    ("Ulaanbaatar", 106.91, 47.92, "EPSG:4326", "generic"),  # geographic
    ("Vladivostok", 131.89, 43.12, "EPSG:32652", "generic"),  # UTM 52N
]


@pytest.mark.parametrize(("place", "lon", "lat", "crs", "expected"), PLACES)
def test_network_from_layer_location(
    place: str, lon: float, lat: float, crs: str, expected: str
) -> None:
    layer = layer_at(lon, lat, crs)
    longitude, latitude = layer_location(layer)
    assert longitude == pytest.approx(lon + 0.001, abs=0.01), place  # centre of the extent
    assert latitude == pytest.approx(lat + 0.0005, abs=0.01), place
    assert network_for_location(longitude, latitude) == expected, place
    if expected == FALLBACK_NETWORK:
        with pytest.warns(DataQualityWarning, match=r"'generic' network.*network="):
            assert network_by_location(layer, source=place)[0] == expected
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DataQualityWarning)
            assert network_by_location(layer, source=place)[0] == expected


def test_boxes_edges_and_wrapping() -> None:
    west, south, east, north = REGION_BOXES["europe"][0]
    assert network_for_location(west, south) == "europe"  # edges belong to the box
    assert network_for_location(east + 0.01, north) == FALLBACK_NETWORK
    assert network_for_location(-87.63 + 360.0, 41.88) == "north_america"  # wrapped
    assert network_for_location(math.nan, 50.0) == FALLBACK_NETWORK
    assert set(REGION_BOXES) == {"europe", "north_america", "east_asia"}
    boxes = [box for region in REGION_BOXES.values() for box in region]
    for west, south, east, north in boxes:
        assert -180 <= west < east <= 180 and -90 <= south < north <= 90
    # no two boxes overlap (shared edges allowed): the order of the regions does not matter
    for i, (w1, s1, e1, n1) in enumerate(boxes):
        for w2, s2, e2, n2 in boxes[i + 1 :]:
            assert min(e1, e2) <= max(w1, w2) or min(n1, n2) <= max(s1, s2)


@pytest.mark.parametrize(
    ("place", "lon", "lat", "expected"),
    [
        ("Naha", 127.68, 26.21, "east_asia"),  # Ryukyu Islands
        ("Fukuoka", 130.40, 33.59, "east_asia"),
        ("Hiroshima", 132.46, 34.39, "east_asia"),
        ("Busan", 129.08, 35.18, "east_asia"),
        ("Kunming", 102.71, 25.04, "east_asia"),
        ("Lanzhou", 103.83, 36.06, "east_asia"),
        ("Haikou", 110.33, 20.04, "east_asia"),  # Hainan
        ("Kaohsiung", 120.30, 22.63, "east_asia"),
        ("Istanbul", 28.98, 41.01, "europe"),
        ("Anchorage", -149.90, 61.22, "north_america"),
        ("Lhasa", 91.11, 29.65, "generic"),  # Tibet: left to generic
        ("Urumqi", 87.62, 43.83, "generic"),  # Xinjiang
        ("Yangon", 96.16, 16.84, "generic"),
        ("Vientiane", 102.63, 17.97, "generic"),
        ("Delhi", 77.21, 28.61, "generic"),
        ("Singapore", 103.82, 1.35, "generic"),
        ("Khabarovsk", 135.07, 48.48, "generic"),
        ("Yuzhno-Sakhalinsk", 142.74, 46.96, "generic"),
    ],
)
def test_east_asia_boxes(place: str, lon: float, lat: float, expected: str) -> None:
    assert network_for_location(lon, lat) == expected, place


def test_sample_records_the_network_chosen_by_location(tmp_path: Path) -> None:
    src, dst = tmp_path / "sydney.gpkg", tmp_path / "lit.gpkg"
    write_normalized(layer_at(151.21, -33.87, "EPSG:28356"), src)
    with pytest.warns(DataQualityWarning, match=r"sydney\.gpkg.*151\.21, -33\.87.*network="):
        result = sample(src, dst, seed=1)
    assert result.network == "generic"
    assert result.location == pytest.approx((151.211, -33.8695), abs=0.01)
    assert set(result.streets["network"]) == {"generic"}
    assert set(gpd.read_file(dst)["network"]) == {"generic"}  # provenance in the output
    src = tmp_path / "chicago.gpkg"
    write_normalized(layer_at(-87.63, 41.88, "EPSG:32616"), src)
    chicago = sample(src, seed=1)
    assert chicago.network == "north_america" and set(chicago.streets["network"]) == {
        "north_america"
    }
    src = tmp_path / "tokyo.gpkg"
    write_normalized(layer_at(139.69, 35.69, "EPSG:6677"), src)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        tokyo = sample(src, tmp_path / "tokyo_lit.gpkg", seed=1)
    assert tokyo.network == "east_asia"
    assert set(gpd.read_file(tmp_path / "tokyo_lit.gpkg", layer="streets")["network"]) == {
        "east_asia"
    }


def test_explicit_network_wins_over_location(tmp_path: Path) -> None:
    # Sydney would get generic with a warning; an explicit network gets none.
    src = tmp_path / "sydney.gpkg"
    write_normalized(layer_at(151.21, -33.87, "EPSG:28356"), src)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        result = sample(src, tmp_path / "lit.gpkg", network="north_america", seed=1)
    assert result.network == "north_america" and result.location is None
    assert set(gpd.read_file(tmp_path / "lit.gpkg")["network"]) == {"north_america"}


def test_layer_without_crs_still_errors(tmp_path: Path) -> None:
    layer = layer_at(2.35, 48.86, "EPSG:32631").set_crs(None, allow_override=True)
    with pytest.raises(InputError, match="no CRS"):
        layer_location(layer, source="paris")
    with pytest.raises(InputError, match="projected CRS"):
        sample(layer)


def test_empty_layer_gets_generic_without_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        result = sample(layer_at(2.35, 48.86, "EPSG:32631").iloc[:0], seed=0)
    assert result.network == "generic" and result.location is not None
    assert math.isnan(result.location[0])


@pytest.mark.parametrize(
    ("crs", "x0", "y0", "expected"),
    [
        ("EPSG:32618", 583_000.0, 4_507_000.0, "north_america"),  # UTM 18N: New York
        ("EPSG:32651", 355_000.0, 3_456_000.0, "east_asia"),  # UTM 51N: Shanghai
    ],
)
def test_fit_and_learn_take_the_base_network_of_the_location(
    crs: str, x0: float, y0: float, expected: str
) -> None:
    # Without a network, fit and learn start from the network streets sample would choose:
    # the tables the evidence says nothing about (SYSTEM, SETBACK) stay those of that base
    # network, not those of the catalogue default (europe).
    from shapely.geometry import LineString, Point

    from bayesnets import load_network
    from nightlights.streets import fit, learn

    streets = gpd.GeoDataFrame(
        {
            "street_class": ["local", "local"],
            "lit": [True, True],
            "mounting_height": [6.0, 8.0],
            "spacing": [24.0, 30.0],
        },
        geometry=[LineString([(x0, y0 + y), (x0 + 400.0, y0 + y)]) for y in (0.0, 60.0)],
        crs=crs,
    )
    lamps = gpd.GeoDataFrame(
        geometry=[Point(x0 + x, y0 + 4.0) for x in (10.0, 40.0, 70.0, 100.0)], crs=crs
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = fit(streets).network
        learned = learn(streets, lamps, seed=0, iterations=1).network
    base, default = load_network(expected), load_network("europe")
    for net in (fitted, learned):
        for variable in ("SYSTEM", "SETBACK"):
            assert np.allclose(net.tables[variable], base.tables[variable]), variable
        assert not np.allclose(net.tables["SYSTEM"], default.tables["SYSTEM"])
