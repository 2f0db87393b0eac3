"""Range checks, seeds, NaN vertices and memory estimates of the street stages."""

from __future__ import annotations

import warnings
from dataclasses import replace

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely

from bayesnets import load_network
from bayesnets.errors import BindingError
from nightlights._resources import set_memory_limit
from nightlights.errors import DataQualityWarning, InputError, ResourceError
from nightlights.streets import (
    PlacementOptions,
    fill_lighting,
    normalize,
    place,
    place_lights,
    sample,
)
from nightlights.streets._checks import (
    check_network_values,
    check_street_values,
    finite_vertices,
    rng_from_seed,
)
from nightlights.streets.schema import VALUE_RANGES

# shapely warns when it builds the NaN-vertex lines these tests need
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")


@pytest.fixture
def memory_limit():
    """Set a memory limit for one test; the default comes back afterwards."""
    yield set_memory_limit
    set_memory_limit(None)


def _lit(n: int = 1, length: float = 300.0, **fields) -> gpd.GeoDataFrame:
    data = {
        "source_id": [f"s{i}" for i in range(n)],
        "width": 8.0,
        "lit": True,
        "arrangement": "single_sided",
        "spacing": 30.0,
        "mounting_height": 8.0,
        "system_id": "road_hps",
        **fields,
    }
    lines = [shapely.LineString([(0, 50 * i), (length, 50 * i)]) for i in range(n)]
    return gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067")


# --- seeds and vertices -------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [-1, 1.5, "7", True])
def test_bad_seeds_are_input_errors(seed) -> None:
    with pytest.raises(InputError, match="expected an integer >= 0"):
        rng_from_seed(seed)


def test_good_seeds_are_reproducible() -> None:
    assert rng_from_seed(2**70).random() == rng_from_seed(2**70).random()
    assert rng_from_seed(np.int64(3)).random() == np.random.default_rng(3).random()
    assert isinstance(rng_from_seed(None), np.random.Generator)


def test_seed_is_checked_before_reading_input(tmp_path) -> None:
    with pytest.raises(InputError, match="seed -1"):
        place(tmp_path / "missing.gpkg", seed=-1)
    with pytest.raises(InputError, match="seed -1"):
        sample(tmp_path / "missing.gpkg", seed=-1)


def test_finite_vertices_flags_nan_and_inf_anywhere() -> None:
    geoms = np.array(
        [
            shapely.LineString([(0, 0), (1, 1)]),
            shapely.LineString([(0, 0), (np.nan, 1), (2, 2)]),
            shapely.MultiLineString([[(0, 0), (1, 0)], [(0, 1), (np.inf, 1)]]),
            None,
        ]
    )
    assert finite_vertices(geoms).tolist() == [True, False, False, True]


@pytest.mark.parametrize(
    ("knobs", "words"),
    [
        ({"across_jitter": 1e9}, "across_jitter=1000000000.0 m; expected at most 10 m"),
        ({"merge_fraction": 3.0}, "merge_fraction=3.0; expected a fraction"),
        ({"tangent_step": 0.0}, "tangent_step=0; expected a length > 0"),
        ({"along_jitter": float("nan")}, "along_jitter=nan; expected a number >= 0"),
        ({"across_jitter": -1.0}, "across_jitter=-1.0; expected a number >= 0"),
    ],
)
def test_absurd_placement_options_are_input_errors(knobs, words) -> None:
    with pytest.raises(InputError) as info:
        PlacementOptions(**knobs)
    assert words in str(info.value)


# --- value ranges -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        ("tilt", 1e6, ["tilt=1e+06", "[-90, 90] deg"]),
        ("tilt", np.inf, ["tilt=inf"]),
        ("arm_length", -50.0, ["arm_length=-50", "[0, 15] m"]),
        ("mounting_height", 1e7, ["mounting_height=1e+07", "(0, 60] m"]),
        ("mounting_height", 0.0, ["mounting_height=0"]),
        ("spacing", 1e-4, ["spacing=0.0001", "[1, 5000] m"]),
        ("spacing", np.nan, ["spacing=nan"]),
        ("width", -3.0, ["width=-3"]),
        ("setback", -1.0, ["setback=-1"]),
        ("tilt", "steep", ["tilt='steep'"]),
    ],
)
def test_impossible_values_name_street_value_and_range(field, value, words) -> None:
    streets = _lit(3, **{field: [8.0 if field != "tilt" else 0.0, value, value]})
    with pytest.raises(InputError) as info:
        place_lights(streets, rng=np.random.default_rng(0), source="in.gpkg")
    message = str(info.value)
    assert message.startswith("in.gpkg: street 's1': ") and "(and 1 more street(s))" in message
    for word in words:
        assert word in message


def test_unlit_streets_are_not_checked() -> None:
    streets = _lit(2, tilt=[0.0, 1e6], lit=[True, False])
    lights = place_lights(streets, rng=np.random.default_rng(0))
    assert set(lights["street_id"]) == {"s0"}


@pytest.mark.parametrize(
    ("field", "value", "usual"),
    [
        ("tilt", 45.0, "-15-30 deg"),
        ("mounting_height", 40.0, "2.5-30 m"),
        ("spacing", 2.0, "5-200"),
    ],
)
def test_unusual_values_are_counted_warnings(field, value, usual) -> None:
    streets = _lit(3, **{field: value})
    with pytest.warns(DataQualityWarning, match=f"{field}: 3 street\\(s\\) with unusual") as record:
        lights = place_lights(streets, rng=np.random.default_rng(0))
    assert usual in str(record[0].message)
    assert len(lights) > 0 and (lights[field] == value).all() if field in lights else True


def test_check_street_values_skips_absent_fields() -> None:
    check_street_values(pd.DataFrame({"width": [7.0]}), ["tilt", "width"], source="x")


def test_network_with_impossible_states_is_refused() -> None:
    network = load_network("europe")
    binding = network.bindings["TILT"]
    numbers = (1e6, *binding.numbers[1:])
    bad = replace(network, bindings={**network.bindings, "TILT": replace(binding, numbers=numbers)})
    with pytest.raises(BindingError, match=r"variable TILT state '0' gives tilt=1e\+06"):
        check_network_values(bad, VALUE_RANGES)
    check_network_values(network, VALUE_RANGES)  # the catalogue itself is plausible
    with pytest.raises(BindingError, match="tilt=1e"):
        fill_lighting(_lit(1), bad, rng=np.random.default_rng(0))


# --- NaN vertices, lanes ------------------------------------------------------------------------


def test_nan_vertices_are_dropped_and_counted_by_normalize() -> None:
    raw = gpd.GeoDataFrame(
        {"highway": ["primary"] * 3},
        geometry=[
            shapely.LineString([(0, 0), (np.nan, 1), (20, 20)]),
            shapely.LineString([(0, 0), (50, 0)]),
            shapely.LineString([(0, 5), (np.inf, 5), (50, 5)]),
        ],
        crs="EPSG:3067",
    )
    with pytest.warns(DataQualityWarning, match="2 line part\\(s\\) with NaN or infinite"):
        result = normalize(raw)
    assert result.report.dropped["non-finite coordinates"] == 2
    assert result.report.output_features == 1


def test_nan_vertices_are_dropped_and_counted_by_place() -> None:
    streets = _lit(2)
    streets.loc[1, "geometry"] = shapely.LineString([(0, 50), (np.nan, 50), (300, 50)])
    with pytest.warns(DataQualityWarning, match="1 lit street part\\(s\\) with NaN or infinite"):
        lights = place_lights(streets, rng=np.random.default_rng(0))
    assert set(lights["street_id"]) == {"s0"}


def test_absurd_lanes_are_missing_and_counted() -> None:
    raw = gpd.GeoDataFrame(
        {"highway": ["primary"] * 4, "lanes": ["1e9", "1e9", "2", "14"]},
        geometry=[shapely.LineString([(0, 10 * i), (50, 10 * i)]) for i in range(4)],
        crs="EPSG:3067",
    )
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        result = normalize(raw)
    messages = [str(w.message) for w in record if issubclass(w.category, DataQualityWarning)]
    assert any("field lanes: 2 values outside the allowed range [1, 30]" in m for m in messages)
    assert any("field lanes: 1 unusual values" in m and "'14' x1" in m for m in messages)
    lanes = result.streets["lanes"]
    assert lanes.isna().sum() == 2 and list(lanes.dropna()) == [2, 14]
    assert not result.streets["lanes_observed"].iloc[0]
    assert result.report.implausible_values["lanes"]["1e9"] == 2


# --- memory estimates ---------------------------------------------------------------------------


def test_place_refuses_before_allocating(memory_limit) -> None:
    memory_limit("50M")
    streets = _lit(1, length=1e6, spacing=1.0)  # 1e6 poles at 1 m spacing
    with pytest.warns(DataQualityWarning), pytest.raises(ResourceError) as info:
        place_lights(streets, rng=np.random.default_rng(0))
    message = str(info.value)
    assert "placing about 1e+06 luminaires" in message and "spacing" in message
    assert "NIGHTLIGHTS_MAX_MEMORY" in message


def test_sample_refuses_huge_candidates(memory_limit) -> None:
    memory_limit("1G")
    streets = _lit(2).drop(columns=["arrangement", "spacing", "mounting_height", "system_id"])
    with pytest.raises(ResourceError, match="lower candidates="):
        fill_lighting(streets, "europe", candidates=10**9, rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="candidates=0"):
        sample(streets, candidates=0)
