"""nightlights.inverse.SkyRegion: the input forms, azimuth wrap through north, the
zenith-enclosing ring, and one-line errors for every malformed region."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nightlights.errors import InputError
from nightlights.inverse import SkyRegion

#: A 1 deg grid of pixel centres (elevation 89.5 ... 0.5, azimuth 0.5 ... 359.5) [deg].
ELEVATION = 90.0 - (np.arange(90) + 0.5)
AZIMUTH = np.arange(360) + 0.5


def _inside(region: SkyRegion, elevation: float, azimuth: float) -> bool:
    return bool(region.mask(np.array([elevation]), np.array([azimuth]))[0, 0])


def _box(mask: np.ndarray) -> tuple[set[float], set[float]]:
    """The elevations and azimuths of the True pixels of a mask on the 1 deg grid."""
    rows, cols = np.nonzero(mask)
    return set(ELEVATION[rows].tolist()), set(AZIMUTH[cols].tolist())


# --- the input forms ----------------------------------------------------------------------------


def test_polygon_text_covers_the_pixel_centres_inside() -> None:
    region = SkyRegion.parse("100,10 140,10 140,40 100,40 100,10")
    assert region.kind == "polygon" and str(region) == "100,10 140,10 140,40 100,40 100,10"
    assert region.vertices[0] == region.vertices[-1] == (100.0, 10.0)
    mask = region.mask(ELEVATION, AZIMUTH)
    assert mask.shape == (90, 360) and mask.dtype == bool
    elevations, azimuths = _box(mask)
    assert min(azimuths) == 100.5 and max(azimuths) == 139.5 and len(azimuths) == 40
    assert min(elevations) == 10.5 and max(elevations) == 39.5 and len(elevations) == 30
    assert mask.sum() == 40 * 30  # a rectangle: every pixel of its box


def test_boundary_pixels_belong_to_the_region() -> None:
    region = SkyRegion.parse("10,10 20,10 20,20 10,20 10,10")
    assert _inside(region, 15.0, 10.0) and _inside(region, 20.0, 15.0)
    assert not _inside(region, 20.001, 15.0)


def test_zenith_cap() -> None:
    region = SkyRegion.parse("zenith:30")
    assert (region.kind, region.radius) == ("zenith", 30.0)
    mask = region.mask(ELEVATION, AZIMUTH)
    assert mask[ELEVATION >= 60].all() and not mask[ELEVATION < 60].any()
    assert _inside(region, 60.0, 123.0)  # elevation >= 90 - R
    assert SkyRegion.parse("zenith:90").mask(ELEVATION, AZIMUTH).all()


def test_horizon_band() -> None:
    region = SkyRegion.parse("horizon:90,180,15")
    assert region.azimuths == (90.0, 180.0) and region.top == 15.0
    elevations, azimuths = _box(region.mask(ELEVATION, AZIMUTH))
    assert (min(azimuths), max(azimuths), len(azimuths)) == (90.5, 179.5, 90)
    assert (min(elevations), max(elevations), len(elevations)) == (0.5, 14.5, 15)
    full = SkyRegion.parse("horizon:0,360,10").mask(ELEVATION, AZIMUTH)
    assert full[ELEVATION < 10].all() and not full[ELEVATION > 10].any()


def test_geojson_forms_equal_the_text_polygon(tmp_path: Path) -> None:
    ring = [[350, 0], [10, 0], [10, 30], [350, 30], [350, 0]]
    text = " ".join(f"{az},{el}" for az, el in ring)
    expected = SkyRegion.parse(text).mask(ELEVATION, AZIMUTH)
    geometry = {"type": "Polygon", "coordinates": [ring]}
    feature = {"type": "Feature", "properties": {}, "geometry": geometry}
    multi = {"type": "MultiPolygon", "coordinates": [[ring]]}
    forms = {
        "geometry.geojson": geometry,
        "feature.json": feature,
        "collection.geojson": {"type": "FeatureCollection", "features": [feature]},
        "multi.geojson": multi,
    }
    for name, content in forms.items():
        path = tmp_path / name
        path.write_text(json.dumps(content), encoding="utf-8")
        for value in (path, str(path)):
            region = SkyRegion.parse(value)
            assert region.kind == "polygon" and region.text == str(path)
            assert np.array_equal(region.mask(ELEVATION, AZIMUTH), expected), name


def test_wkt_file_is_read_with_the_same_wrap(tmp_path: Path) -> None:
    path = tmp_path / "region.wkt"
    # x = azimuth, y = elevation; 350 -> 10 is the short way round, through north
    path.write_text("POLYGON ((350 0, 10 0, 10 30, 350 30, 350 0))\n", encoding="utf-8")
    region = SkyRegion.parse(path)
    assert _inside(region, 15.0, 355.0) and _inside(region, 15.0, 5.0)
    assert not _inside(region, 15.0, 180.0)


def test_parse_returns_a_region_unchanged_and_regions_compare_by_value() -> None:
    region = SkyRegion.parse("zenith:10")
    assert SkyRegion.parse(region) is region
    assert region == SkyRegion.parse("zenith:10") and hash(region) == hash(
        SkyRegion("zenith", "zenith:10", radius=10.0)
    )


# --- azimuth wrap through north -------------------------------------------------------------


@pytest.mark.parametrize("text", ["350,0 10,0 10,30 350,30 350,0", "-10,0 10,0 10,30 -10,30 -10,0"])
def test_polygon_across_north_takes_the_short_arc(text: str) -> None:
    region = SkyRegion.parse(text)
    assert _inside(region, 15.0, 355.0) and _inside(region, 15.0, 5.0)
    assert not _inside(region, 15.0, 180.0) and not _inside(region, 15.0, 340.0)
    _, azimuths = _box(region.mask(ELEVATION, AZIMUTH))
    assert len(azimuths) == 20 and azimuths == {*np.arange(350.5, 360), *np.arange(0.5, 10)}
    # pixel azimuths outside [0, 360) are the same directions
    assert _inside(region, 15.0, -5.0) and _inside(region, 15.0, 365.0)


def test_horizon_band_across_north() -> None:
    region = SkyRegion.parse("horizon:300,60,20")
    assert _inside(region, 10.0, 355.0) and _inside(region, 10.0, 5.0)
    assert _inside(region, 10.0, 300.5) and _inside(region, 10.0, 59.5)
    assert not _inside(region, 10.0, 180.0) and not _inside(region, 25.0, 5.0)
    _, azimuths = _box(region.mask(ELEVATION, AZIMUTH))
    assert len(azimuths) == 120


def test_polygon_across_north_equals_the_horizon_band_it_traces() -> None:
    polygon = SkyRegion.parse("300,0 0,0 60,0 60,20 0,20 300,20 300,0")
    band = SkyRegion.parse("horizon:300,60,20")
    assert np.array_equal(polygon.mask(ELEVATION, AZIMUTH), band.mask(ELEVATION, AZIMUTH))


# --- the zenith-enclosing ring -------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "0,60 90,60 180,60 270,60 0,60",  # clockwise
        "0,60 270,60 180,60 90,60 0,60",  # anticlockwise
        "45,60 135,60 225,60 315,60 45,60",  # starting elsewhere
    ],
)
def test_ring_round_the_zenith_encloses_the_cap(text: str) -> None:
    mask = SkyRegion.parse(text).mask(ELEVATION, AZIMUTH)
    cap = SkyRegion.parse("zenith:30").mask(ELEVATION, AZIMUTH)
    assert np.array_equal(mask, cap)


def test_tilted_ring_round_the_zenith_is_above_its_curve() -> None:
    # low (20 deg) in the south, high (70 deg) in the north
    region = SkyRegion.parse("0,70 90,45 180,20 270,45 0,70")
    assert _inside(region, 89.0, 0.0) and _inside(region, 89.0, 180.0)
    assert _inside(region, 30.0, 180.0) and not _inside(region, 30.0, 0.0)
    assert _inside(region, 75.0, 0.0) and not _inside(region, 65.0, 0.0)
    assert not _inside(region, 10.0, 180.0)
    # at the seam (the first vertex's azimuth) the region is as continuous as elsewhere
    assert _inside(region, 70.0, 0.0) and _inside(region, 71.0, 359.99)


# --- errors: one line, naming the bad value ----------------------------------------------------


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("0,0 10,0 10,10", "open"),
        ("0,0 10,10 10,0 0,10 0,0", "crosses"),  # bow-tie
        ("0,40 120,40 60,60 100,20 240,40 0,40", "crosses"),  # bow-tie round the zenith
        ("0,0 10,0 0,0", "2 distinct vertices"),
        ("0,0 10,0 10,0 0,0", "2 distinct vertices"),
        ("0,0", "expected a closed ring"),
        ("0,10 10,10 20,10 0,10", "no area"),
        ("0,0 10,0 10,95 0,0", "elevation 95"),
        ("0,-5 10,0 10,10 0,-5", "elevation -5"),
        ("0,0 180,0 180,10 0,0", "180 deg apart"),
        ("0,60 120,60 240,60 0,60 120,60 240,60 0,60", "winds 2 times"),
        ("0,10 150,10 300,10 90,10 90,20 300,20 150,20 0,20 0,10", "overlaps itself"),
        ("moon:5", "unknown shortcut 'moon'"),
        ("zenith:x", "zenith:R"),
        ("zenith:", "zenith:R"),
        ("zenith:0", "radius 0"),
        ("zenith:91", "radius 91"),
        ("zenith:nan", "finite"),
        ("horizon:10,20", "horizon:AZ1,AZ2,EL"),
        ("horizon:10,20,x", "horizon:AZ1,AZ2,EL"),
        ("horizon:10,10,20", "spans nothing"),
        ("horizon:10,20,0", "EL = 0"),
        ("horizon:10,20,95", "EL = 95"),
        ("a,b 1,2 3,4 a,b", "vertex 'a,b'"),
        ("1,2,3 4,5 6,7 1,2,3", "vertex '1,2,3'"),
        ("0;0 1;0 1;1 0;0", "vertex '0;0'"),
        ("0,inf 10,0 10,10 0,inf", "finite"),
        ("", "expected"),
        ("missing.geojson", "does not exist"),
    ],
)
def test_bad_regions_raise_one_line_input_errors(text: str, words: str) -> None:
    with pytest.raises(InputError) as info:
        SkyRegion.parse(text)
    message = str(info.value)
    assert words in message and "\n" not in message
    assert repr(text) in message or text in message


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ("not a polygon at all", "not GeoJSON or WKT"),
        ("POINT (1 2)", "Point"),
        ("POLYGON ((0 0, 40 0, 40 40, 0 40, 0 0), (10 10, 20 10, 20 20, 10 10))", "hole"),
        ("POLYGON ((0 0, 10 10, 10 0, 0 10, 0 0))", "crosses"),
        ('{"type": "FeatureCollection", "features": []}', "0 features"),
        ('{"type": "Polygon"', "not valid JSON"),
        ('{"type": "Feature", "geometry": null}', "no geometry"),
        ('{"type": "Polygon", "coordinates": "x"}', "unreadable GeoJSON"),
        ('{"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 99], [0, 0]]]}', "99"),
    ],
)
def test_bad_region_files_raise_one_line_input_errors(
    tmp_path: Path, content: str, words: str
) -> None:
    path = tmp_path / "region.txt"
    path.write_text(content, encoding="utf-8")
    with pytest.raises(InputError) as info:
        SkyRegion.parse(path)
    message = str(info.value)
    assert words in message and "\n" not in message and str(path) in message


def test_direct_construction_is_checked() -> None:
    with pytest.raises(InputError, match="kind 'circle'"):
        SkyRegion("circle", "circle")
    with pytest.raises(InputError, match="open"):
        SkyRegion("polygon", "p", vertices=((0, 0), (1, 0), (1, 1)))
    with pytest.raises(InputError, match="radius"):
        SkyRegion("zenith", "z")
    with pytest.raises(InputError, match="horizon band needs"):
        SkyRegion("horizon", "h", azimuths=(0.0, 10.0))
