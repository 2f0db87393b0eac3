"""The catalogue network chosen from where a street layer lies."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import geopandas as gpd
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

ROWS = [{"street_class": "local", "lanes": 2}, {"street_class": "arterial"}, {}]


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
    ("Sydney", 151.21, -33.87, "EPSG:28356", "generic"),  # GDA94 / MGA 56
    ("Tokyo", 139.69, 35.69, "EPSG:6677", "generic"),  # JGD2011 / Japan plane IX
    ("Sao Paulo", -46.63, -23.55, "EPSG:31983", "generic"),  # SIRGAS 2000 / UTM 23S
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
        with pytest.warns(DataQualityWarning, match=r"'generic' network.*--network"):
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
    assert set(REGION_BOXES) == {"europe", "north_america"}
    for boxes in REGION_BOXES.values():
        for west, south, east, north in boxes:
            assert -180 <= west < east <= 180 and -90 <= south < north <= 90


def test_sample_records_the_network_chosen_by_location(tmp_path: Path) -> None:
    src, dst = tmp_path / "sydney.gpkg", tmp_path / "lit.gpkg"
    write_normalized(layer_at(151.21, -33.87, "EPSG:28356"), src)
    with pytest.warns(DataQualityWarning, match=r"sydney\.gpkg.*151\.21, -33\.87.*--network"):
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


def test_explicit_network_wins_over_location(tmp_path: Path) -> None:
    src = tmp_path / "tokyo.gpkg"
    write_normalized(layer_at(139.69, 35.69, "EPSG:6677"), src)
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


def test_fit_and_learn_take_the_base_network_of_the_location(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Without a network, fit and learn start from the network streets sample would choose.
    from shapely.geometry import LineString, Point

    import nightlights.streets._fit as fit_module
    import nightlights.streets._learn as learn_module
    from nightlights.streets import fit, learn

    streets = gpd.GeoDataFrame(
        {
            "street_class": ["local", "local"],
            "lit": [True, True],
            "mounting_height": [6.0, 8.0],
            "spacing": [24.0, 30.0],
        },
        geometry=[
            LineString([(583_000.0, 4_507_000.0 + y), (583_400.0, 4_507_000.0 + y)])
            for y in (0.0, 60.0)
        ],
        crs="EPSG:32618",  # UTM 18N: New York
    )
    chosen: list[object] = []
    for module in (fit_module, learn_module):
        original = module.resolve_network

        def spy(network: object, _original: object = original) -> object:
            chosen.append(network)
            return _original(network)  # type: ignore[operator]

        monkeypatch.setattr(module, "resolve_network", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit(streets)
        lamps = gpd.GeoDataFrame(
            geometry=[Point(583_000 + x, 4_507_004) for x in (10.0, 40.0, 70.0, 100.0)],
            crs="EPSG:32618",
        )
        learn(streets, lamps, seed=0, iterations=1)
    assert chosen[0] == "north_america"
    assert "north_america" in chosen[1:]
