"""Tests of ``streets place`` (Chuang 2011, Sec. 3.1, Fig. 8)."""

from __future__ import annotations

import geopandas as gpd
import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nightlights.errors import InputError
from nightlights.streets._place import LIGHT_FIELDS, PlacementOptions, place_lights

EXACT = PlacementOptions(along_jitter=0.0, across_jitter=0.0)


def _streets(lines, **fields) -> gpd.GeoDataFrame:
    n = len(lines)
    base = {
        "source_id": [f"s{i}" for i in range(n)],
        "street_class": ["local"] * n,
        "width": [8.0] * n,
        "lit": [True] * n,
        "arrangement": ["single_sided"] * n,
        "spacing": [30.0] * n,
        "mounting_height": [8.0] * n,
        "arm_length": [1.0] * n,
        "setback": [1.0] * n,
        "tilt": [0.0] * n,
        "system_id": ["street_led_small"] * n,
    }
    for key, value in fields.items():
        base[key] = value if isinstance(value, list) else [value] * n
    return gpd.GeoDataFrame(base, geometry=lines, crs="EPSG:3067")


def _bearing(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(dx, dy)) % 360


@pytest.mark.parametrize(
    ("arrangement", "lights_per_position", "sides"),
    [
        ("single_sided", 1, {"right"}),
        ("opposite", 2, {"left", "right"}),
        ("staggered", 1, {"left", "right"}),
        ("central", 2, {"center"}),
    ],
)
def test_arrangements_offsets_and_headings(arrangement, lights_per_position, sides) -> None:
    street = _streets([shapely.LineString([(0, 0), (300, 0)])], arrangement=arrangement)
    lights = place_lights(street, rng=np.random.default_rng(0), options=EXACT)
    assert set(lights["side"]) == sides
    positions = np.unique(np.round(lights.geometry.x, 6))
    assert len(lights) == lights_per_position * len(positions)
    y = lights.geometry.y.to_numpy()
    expected_offset = 0.0 if arrangement == "central" else 8.0 / 2 + 1.0
    assert np.allclose(np.abs(y), expected_offset)
    heading = lights["heading"].to_numpy()
    if arrangement == "central":
        # Twin-arm poles: two luminaires per pole, facing both carriageways.
        assert lights.groupby("pole_id").size().eq(2).all()
        assert set(np.round(heading)) == {0.0, 180.0}
    else:
        # Each luminaire faces the centreline: north from the south side, south from the north.
        assert np.allclose(heading, np.where(y < 0, 0.0, 180.0))
    if arrangement == "staggered":
        order = np.argsort(lights.geometry.x.to_numpy())
        assert np.all(np.diff(np.sign(y[order])) != 0)  # sides alternate


def test_spacing_follows_the_curve_not_the_chord() -> None:
    arc = shapely.LineString(
        [(100 * np.cos(t), 100 * np.sin(t)) for t in np.linspace(0, np.pi, 200)]
    )
    street = _streets([arc], width=0.0001, setback=0.0, spacing=20.0)
    lights = place_lights(street, rng=np.random.default_rng(3), options=EXACT)
    along = shapely.line_locate_point(arc, lights.geometry.to_numpy())
    assert np.allclose(np.diff(np.sort(along)), 20.0, atol=1e-3)
    assert len(lights) in (15, 16)  # floor(314.1/20 + U)


def test_expected_pole_count_is_length_over_spacing() -> None:
    # Many short pieces (as OSM splits streets): the count is right on average.
    pieces = [shapely.LineString([(0, 100 * i), (13, 100 * i)]) for i in range(4000)]
    street = _streets(pieces, spacing=30.0)
    lights = place_lights(street, rng=np.random.default_rng(5), options=EXACT)
    expected = 4000 * 13 / 30
    assert abs(len(lights) - expected) < 4 * np.sqrt(expected * 0.25)


def test_unlit_and_zero_length_streets_get_no_lights() -> None:
    lines = [shapely.LineString([(0, 0), (100, 0)]), shapely.LineString([(0, 50), (0, 50)])]
    street = _streets(lines, lit=[False, True])
    assert place_lights(street, rng=np.random.default_rng(0)).empty


def test_empty_layer_gives_empty_lights_with_fields() -> None:
    lights = place_lights(_streets([]), rng=np.random.default_rng(0))
    assert lights.empty and set(LIGHT_FIELDS) <= set(lights.columns)


def test_poles_where_streets_meet_are_merged() -> None:
    # Two collinear pieces of one street, meeting at x=100: without merging, poles near the
    # joint may stand closer than the spacing.
    lines = [shapely.LineString([(0, 0), (100, 0)]), shapely.LineString([(100, 0), (200, 0)])]
    for seed in range(30):
        lights = place_lights(_streets(lines), rng=np.random.default_rng(seed), options=EXACT)
        x = np.sort(lights.geometry.x.to_numpy())
        assert np.all(np.diff(x) >= 0.5 * 30.0 - 1e-9)


def test_higher_class_street_keeps_its_pole() -> None:
    lines = [shapely.LineString([(0, 0), (0.5, 0)]), shapely.LineString([(0, 0.2), (0.5, 0.2)])]
    street = _streets(lines, street_class=["local", "arterial"], width=0.0001, setback=0.0)
    lights = place_lights(street, rng=np.random.default_rng(0), options=EXACT)
    assert list(lights["street_id"].unique()) in ([], ["s1"])


def test_bad_fields_are_clear_errors() -> None:
    line = [shapely.LineString([(0, 0), (100, 0)])]
    with pytest.raises(InputError, match="arrangement 'zigzag'"):
        place_lights(_streets(line, arrangement="zigzag"), rng=np.random.default_rng(0))
    with pytest.raises(InputError, match=r"spacing=0; expected a number in \[1, 5000\] m"):
        place_lights(_streets(line, spacing=0.0), rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="run `nightlights streets sample`"):
        place_lights(_streets(line).drop(columns="spacing"), rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="along_jitter"):
        PlacementOptions(along_jitter=0.5)


lines_strategy = st.lists(
    st.lists(
        st.tuples(st.floats(-500, 500), st.floats(-500, 500)), min_size=2, max_size=5, unique=True
    ),
    min_size=1,
    max_size=6,
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    coords=lines_strategy,
    arrangement=st.sampled_from(["single_sided", "opposite", "staggered", "central"]),
    width=st.floats(3, 25),
    spacing=st.floats(10, 60),
    seed=st.integers(0, 2**32 - 1),
)
def test_placement_properties(coords, arrangement, width, spacing, seed) -> None:
    """Every pole lies within its street's buffer; poles of different streets keep the
    minimum distance; the same seed reproduces the same layer."""
    lines = [shapely.LineString(c) for c in coords]
    streets = _streets(lines, arrangement=arrangement, width=width, spacing=spacing)
    options = PlacementOptions()
    lights = place_lights(streets, rng=np.random.default_rng(seed), options=options)
    again = place_lights(streets, rng=np.random.default_rng(seed), options=options)
    assert lights.equals(again)
    if lights.empty:
        return
    by_id = dict(zip(streets["source_id"], lines, strict=True))
    # Offset is half the width plus setback, with across-jitter (6 sigma bound).
    reach = width / 2 + 1.0 + 6 * options.across_jitter + 1e-6
    for street_id, point in zip(lights["street_id"], lights.geometry, strict=True):
        assert by_id[street_id].distance(point) <= reach
    poles = lights.drop_duplicates("pole_id")
    xy = np.column_stack([poles.geometry.x, poles.geometry.y])
    street = poles["street_id"].to_numpy()
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    other = street[:, None] != street[None, :]
    assert np.all(d[other] >= options.merge_fraction * spacing - 1e-6)
    assert set(lights["heading"].between(0, 360)) == {True}
