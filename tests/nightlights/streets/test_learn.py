"""Stage ``streets learn``: lamps to streets, per-street evidence, a network fitted to it."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from shapely import LineString, Point

from bayesnets import load_network, read_network
from bayesnets.errors import FitWarning
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError, OutputError
from nightlights.streets import (
    assign_lamps,
    learn,
    learn_lighting_network,
    place,
    sample,
    street_lamp_evidence,
)
from nightlights.streets._learn import (
    MIN_GAP,
    PAIRING_FRACTION,
    _lamp_heights,
    spacing_ratio_states,
)
from tests.nightlights.streets.conftest import normalized_layer

CRS = "EPSG:3067"
X0, Y0 = 385000.0, 6672000.0


# --- assignment --------------------------------------------------------------------------------


def test_lamp_near_junction_goes_to_the_street_it_runs_along() -> None:
    # A through street (0) and a side street (1) ending on it. The lamp stands 3 m beside
    # the through street and only 3.2 m from the side street's end point: it projects onto
    # the through street's interior and onto the side street's end, so the through street
    # wins although the side street ends closer to the lamp than 3.2 m - a tie would
    # otherwise go by distance alone.
    through = LineString([(0, 0), (100, 0)])
    side = LineString([(50, 3.5), (50, 80)])
    lamp = Point(51, 3.0)
    assert shapely.distance(lamp, side) < shapely.distance(lamp, through)
    result = assign_lamps(np.array([lamp]), np.array([through, side]))
    assert result.street.tolist() == [0]
    assert result.interior.tolist() == [True]
    assert result.side.tolist() == [1]  # left of the line direction (west to east)
    assert result.along[0] == pytest.approx(51.0)
    assert result.offset[0] == pytest.approx(3.0)


def test_assignment_reach_ties_and_forbidden_streets() -> None:
    streets = np.array(
        [LineString([(0, -5), (100, -5)]), LineString([(0, 5), (100, 5)])]
    )  # two parallel streets 10 m apart; a lamp on the middle line is equidistant
    lamps = np.array([Point(50, 0), Point(50, 40), Point(50, -7)])
    rank = np.array([3.0, 1.0])  # street 1 is the higher class
    result = assign_lamps(lamps, streets, max_distance=25.0, street_rank=rank)
    assert result.street.tolist() == [1, -1, 0]  # tie -> higher class; out of reach -> -1
    assert np.isnan(result.distance[1]) and not result.assigned[1]
    forbidden = assign_lamps(lamps, streets, street_rank=rank, allowed=np.array([True, False]))
    assert forbidden.street.tolist() == [0, -1, 0]  # street 1 (lit=no) takes no lamps
    on_line = assign_lamps(np.array([Point(20, -5.4)]), streets[:1])
    assert on_line.side.tolist() == [0]  # within the centre tolerance: on the centreline


def test_assignment_of_nothing_is_empty() -> None:
    empty = assign_lamps(np.array([], dtype=object), np.array([LineString([(0, 0), (1, 0)])]))
    assert empty.street.shape == (0,)
    none = assign_lamps(np.array([Point(0, 0)]), np.array([], dtype=object))
    assert none.street.tolist() == [-1]


# --- evidence per street -----------------------------------------------------------------------


def _evidence(lamps: list[tuple[float, float]], *, length: float = 300.0) -> pd.Series:
    street = np.array([LineString([(0, 0), (length, 0)])])
    points = np.array([Point(x, y) for x, y in lamps])
    return street_lamp_evidence(assign_lamps(points, street), 1).iloc[0]


def test_single_sided_row() -> None:
    row = _evidence([(x, -6.0) for x in range(10, 300, 25)])
    assert row["arrangement"] == "single_sided" and row["spacing"] == pytest.approx(25.0)
    assert row["arrangement_agreement"] == 1.0 and row["spacing_agreement"] == 1.0
    assert row["lamps_right"] == 12 and row["lamps_left"] == 0


def test_opposite_pairs_share_a_position() -> None:
    lamps = [(x, side * 7.0) for x in range(10, 300, 30) for side in (-1, 1)]
    row = _evidence(lamps)
    assert row["arrangement"] == "opposite"
    assert row["spacing"] == pytest.approx(30.0)  # the same-side gap; pairs are one position


def test_staggered_row_spacing_is_half_the_same_side_gap() -> None:
    lamps = [(x, (-1) ** k * 7.0) for k, x in enumerate(range(10, 300, 20))]
    row = _evidence(lamps)
    assert row["arrangement"] == "staggered"
    assert row["median_gap"] == pytest.approx(40.0) and row["spacing"] == pytest.approx(20.0)


def test_central_row_and_a_stray_lamp() -> None:
    central = _evidence([(x, 0.3) for x in range(10, 300, 30)])
    assert central["arrangement"] == "central" and central["lamps_centre"] == 10
    # 11 lamps on the right and one on the left: one stray in twelve stays single-sided
    lamps = [(x, -6.0) for x in range(10, 300, 25)] + [(150.0, 6.0)]
    stray = _evidence(lamps)
    assert stray["arrangement"] == "single_sided"
    assert stray["arrangement_agreement"] == pytest.approx(12 / 13)


def test_too_little_or_implausible_evidence_stays_unobserved() -> None:
    one_each_side = _evidence([(50.0, -6.0), (60.0, 6.0)])
    assert one_each_side["lamps"] == 2 and not one_each_side["arrangement_observed"]
    assert not one_each_side["spacing_observed"]
    # one pole mapped twice: the gap under MIN_GAP is dropped, nothing else is left
    twice = _evidence([(50.0, -6.0), (50.0 + MIN_GAP / 2, -6.0)])
    assert not twice["arrangement_observed"]
    # two lamps 400 m apart: a spacing outside the usual range is not taken as evidence
    far = _evidence([(50.0, -6.0), (450.0, -6.0)], length=500.0)
    assert far["arrangement_observed"] and not far["spacing_observed"]
    assert far["unusual_spacing"] == pytest.approx(400.0)
    none = street_lamp_evidence(assign_lamps(np.array([], dtype=object), np.array([])), 3)
    assert len(none) == 3 and not none["arrangement_observed"].any()


def test_pairing_tolerance_separates_opposite_from_staggered() -> None:
    gap = 30.0
    shift = 0.9 * PAIRING_FRACTION * gap  # just inside the tolerance: pairs
    lamps = [(x, -7.0) for x in np.arange(10, 300, gap)]
    paired = _evidence(lamps + [(x + shift, 7.0) for x in np.arange(10, 300, gap)])
    assert paired["arrangement"] == "opposite"
    shifted = _evidence(lamps + [(x + 0.5 * gap, 7.0) for x in np.arange(10, 280, gap)])
    assert shifted["arrangement"] == "staggered"


def test_heights_from_fields_and_osm_tags() -> None:
    points = gpd.GeoDataFrame(
        {
            "height": [None, "8 m", None, "900"],
            "other_tags": ['"height"=>"6"', None, '"lamp_type"=>"electric"', None],
        },
        geometry=[Point(0, 0)] * 4,
        crs=CRS,
    )
    heights = _lamp_heights(points)
    assert heights[:2].tolist() == [6.0, 8.0]
    assert np.isnan(heights[2]) and np.isnan(heights[3])  # untagged; 900 m is impossible
    street = np.array([LineString([(0, 0), (100, 0)])])
    lamps = np.array([Point(x, -5) for x in (10, 40, 70)])
    row = street_lamp_evidence(
        assign_lamps(lamps, street), 1, heights=np.array([6.0, 6.0, np.nan])
    ).iloc[0]
    assert row["mounting_height_observed"] and row["mounting_height"] == 6.0


def test_spacing_ratio_states_cover_base_and_evidence() -> None:
    states = spacing_ratio_states((2.5, 3.0, 3.5, 4.0), np.array([1.3, 2.0, np.nan, 9.6]))
    assert {2.5, 3.0, 3.5, 4.0} <= set(states)
    assert min(states) <= 1.3 and max(states) >= 9.6
    assert list(states) == sorted(states)
    assert spacing_ratio_states((2.5, 3.0), np.array([])) == (2.5, 3.0)


# --- learning ----------------------------------------------------------------------------------


def test_occupancy_is_positions_at_the_spacing_over_the_length() -> None:
    street = np.array([LineString([(0, 0), (300.0, 0)])])

    def evidence(xs: range) -> pd.Series:
        points = np.array([Point(x, -6.0) for x in xs])
        assignment = assign_lamps(points, street)
        return street_lamp_evidence(assignment, 1, lengths=np.array([300.0])).iloc[0]

    # six lamps 25 m apart on the first half: 6 positions x 25 m over 300 m
    half = evidence(range(10, 160, 25))
    assert half["positions"] == 6 and half["occupancy"] == pytest.approx(0.5)
    assert half["occupancy_observed"] and half["occupancy_agreement"] == 1.0
    # a full row: 12 x 25 m = 300 m, capped at one position per spacing
    assert evidence(range(10, 300, 25))["occupancy"] == pytest.approx(1.0)
    # a missing lamp in the row: 11 of the 12 positions
    gap = evidence([x for x in range(10, 300, 25) if x != 135])
    assert gap["spacing"] == pytest.approx(25.0) and gap["occupancy"] == pytest.approx(11 / 12)
    # without street lengths there is no occupancy evidence
    row = _evidence([(x, -6.0) for x in range(10, 300, 25)])
    assert not row["occupancy_observed"] and np.isnan(row["occupancy"])


def _city(
    n_streets: int = 12, spacing: float = 15.0, lit_length: float = 240.0
) -> tuple[gpd.GeoDataFrame, gpd.GeoDataFrame]:
    """Local streets 240 m long, 100 m apart; the first ``n_streets - 2`` have a row of lamps
    every ``spacing`` m on the right over their first ``lit_length`` m; the last two have
    none (one of them tagged lit=no)."""
    rows = [{"street_class": "local"} for _ in range(n_streets)]
    rows[-1]["lit"] = False
    streets = normalized_layer(rows)
    streets["geometry"] = [
        LineString([(X0, Y0 + 100 * i), (X0 + 240, Y0 + 100 * i)]) for i in range(n_streets)
    ]
    points = [
        Point(X0 + x, Y0 + 100 * i - 6.0)
        for i in range(n_streets - 2)
        for x in np.arange(5.0, lit_length, spacing)
    ]
    points.append(Point(X0 + 100, Y0 + 100 * (n_streets - 1) + 3))  # beside the lit=no street
    lamps = gpd.GeoDataFrame({"highway": ["street_lamp"] * len(points)}, geometry=points, crs=CRS)
    signal = gpd.GeoDataFrame({"highway": ["traffic_signals"]}, geometry=[Point(X0, Y0)], crs=CRS)
    return streets, pd.concat([lamps, signal], ignore_index=True)


@pytest.fixture(scope="module")
def learned(tmp_path_factory: pytest.TempPathFactory):
    streets, lamps = _city()
    out = tmp_path_factory.mktemp("learn") / "city_net"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = learn(streets, lamps, out, network="europe", seed=3, iterations=2)
    return streets, lamps, result


def test_learn_reports_what_the_lamps_gave(learned) -> None:
    _, lamps, result = learned
    report = result.report
    assert report.lamps == len(lamps) - 1  # the traffic signal is not a lamp
    assert report.unlit_tagged == 1
    # the lamp beside the lit=no street is out of reach of every other street
    assert report.assigned == report.lamps - 1
    assert report.streets_with_lamps == 10 and report.lit_from_lamps == 10
    spacing = report.fields["spacing"]
    assert spacing.streets == 10 and spacing.agreement == 1.0
    assert spacing.summary["median"] == pytest.approx(15.0)
    assert report.fields["arrangement"].summary["single_sided"] == 10
    assert report.fields["mounting_height"].streets == 0
    lamps_out = result.lamps
    assert lamps_out["street_id"].isna().sum() == 1
    assert set(lamps_out["side"].dropna()) == {"right"}


def test_learned_network_moves_to_the_evidence_and_keeps_the_rest(learned) -> None:
    _, _, result = learned
    net, base = result.network, load_network("europe")
    # the base's variables, plus the occupancy the design-guide networks leave out
    assert net.variables == (*base.variables, "OCCUPANCY")
    assert dict(net.parents) == {**base.parents, "OCCUPANCY": ("STREET_CLASS",)}
    # unobserved everywhere: kept from the base
    for variable in ("MOUNTING_HEIGHT", "SYSTEM", "SETBACK"):
        np.testing.assert_allclose(net.tables[variable], base.tables[variable])
    # lit on every street with lamps; the street without lamps and without a tag is not
    # evidence of an unlit street, and the lit=no street is the only "F"
    local = net.states["STREET_CLASS"].index("local")
    true = net.states["LIT"].index("T")
    lit = net.tables["LIT"][true, local]
    assert lit == pytest.approx((10 + base.tables["LIT"][true, local]) / 12, abs=1e-9)
    # single-sided everywhere in the data
    arrangement = net.tables["ARRANGEMENT"]
    single = net.states["ARRANGEMENT"].index("single_sided")
    assert arrangement[single].max() > 0.8


def test_sampling_with_the_learned_network_gives_the_mapped_spacing(learned) -> None:
    streets, _, result = learned
    many = pd.concat([streets.iloc[:1]] * 400, ignore_index=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filled = sample(many, network=result.network, seed=1).streets
    spacing = filled["spacing"].to_numpy(float)
    # spacing_ratio x mounting height, both drawn: the median lands near the mapped 15 m,
    # within the rounding of the ratio states (0.25) times the largest height (10 m)
    assert np.median(spacing) == pytest.approx(15.0, abs=2.5)
    assert np.median(spacing) < np.median(
        sample(many, network="europe", seed=1).streets["spacing"].to_numpy(float)
    )


def test_written_folder_round_trips(learned) -> None:
    streets, _, result = learned
    folder = result.path
    assert folder is not None and (folder / "network.toml").exists()
    net = read_network(folder)
    assert net.name == "city_net"
    assert net.metadata["base_network"] == "europe" and net.metadata["seed"] == 3
    report = json.loads((folder / "learn_report.json").read_text())
    assert report["fields"]["spacing"]["streets"] == 10
    evidence = gpd.read_file(folder / "evidence_streets.gpkg", layer="streets")
    assert int(evidence["spacing_observed"].sum()) == 10
    assert len(gpd.read_file(folder / "evidence_lamps.gpkg", layer="lamps")) == report["lamps"]
    # the folder is a network for streets sample
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert sample(streets, network=str(folder), seed=0).network == "city_net"


def test_same_seed_same_network() -> None:
    streets, lamps = _city(n_streets=5)
    tables = []
    for _ in range(2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            net = learn(streets, lamps, network="europe", seed=9, iterations=1).network
        tables.append(net.tables["SPACING_RATIO"])
    np.testing.assert_array_equal(*tables)


def test_output_folder_rules(learned, tmp_path: Path) -> None:
    streets, lamps, result = learned
    assert result.path is not None
    with pytest.raises(OutputError, match="give overwrite=True"):
        learn(streets, lamps, result.path, seed=1)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="not a network folder"):
        learn(streets, lamps, other, seed=1, overwrite=True)
    assert (other / "notes.txt").read_text() == "mine"
    with pytest.raises(OutputError, match="parent folder"):
        learn(streets, lamps, tmp_path / "missing" / "net", seed=1)


def test_overwrite_replaces_a_network_folder(tmp_path: Path) -> None:
    streets, lamps = _city(n_streets=4)
    out = tmp_path / "net"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        learn(streets, lamps, out, seed=1, iterations=1)
        (out / "stale.csv.bak").write_text("x")
        learn(streets, lamps, out, seed=2, iterations=1, overwrite=True)
    assert not (out / "stale.csv.bak").exists()
    assert read_network(out).metadata["seed"] == 2
    assert [p.name for p in tmp_path.iterdir()] == ["net"]  # no temporaries left


def test_bad_inputs_are_refused() -> None:
    streets, lamps = _city(n_streets=3)
    with pytest.raises(InputError, match="max_distance=0"):
        learn(streets, lamps, max_distance=0)
    with pytest.raises(InputError, match="iterations=0"):
        learn(streets, lamps, iterations=0)
    with pytest.raises(InputError, match="projected CRS"):
        learn(streets.to_crs("EPSG:4326"), lamps)
    far = lamps.copy()
    far["geometry"] = far.geometry.translate(0, 10_000)
    with pytest.raises(EmptyInputError, match="no street has two lamps on one side"):
        learn(streets, far)
    with pytest.raises(EmptyInputError, match="no lamp points"):
        learn(streets, lamps.loc[lamps["highway"] != "street_lamp"])
    lines = lamps.copy()
    lines["geometry"] = [LineString([(p.x, p.y), (p.x + 1, p.y)]) for p in lines.geometry]
    with pytest.warns(DataQualityWarning, match="not points"):
        with pytest.raises(EmptyInputError, match="no lamp points"):
            learn(streets, lines)


def test_multi_points_are_lamps_each() -> None:
    streets, lamps = _city(n_streets=3)
    row = lamps.loc[lamps["highway"] == "street_lamp"]
    merged = gpd.GeoDataFrame(
        {"highway": ["street_lamp"]}, geometry=[shapely.MultiPoint(list(row.geometry))], crs=CRS
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        one = learn(streets, merged, seed=0, iterations=1).report
        many = learn(streets, row, seed=0, iterations=1).report
    assert one.lamps == many.lamps == len(row)


def test_learn_lighting_network_without_lamp_evidence_keeps_lighting_tables() -> None:
    streets = normalized_layer([{"street_class": "local", "lit": True}] * 30)
    evidence = street_lamp_evidence(
        assign_lamps(np.array([], dtype=object), streets.geometry.to_numpy()), len(streets)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        net = learn_lighting_network(
            streets, evidence, "europe", rng=np.random.default_rng(0), iterations=1
        )
    base = load_network("europe")
    for variable in ("ARRANGEMENT", "SPACING_RATIO", "MOUNTING_HEIGHT"):
        np.testing.assert_allclose(net.tables[variable], base.tables[variable])


def test_partly_lit_streets_teach_an_occupancy_that_sampling_and_placing_honour() -> None:
    # lamps every 15 m over the first 120 m of 240 m streets: occupancy 0.5
    streets, lamps = _city(lit_length=120.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = learn(streets, lamps, network="europe", seed=3, iterations=2)
    assert result.report.fields["occupancy"].streets == 10
    assert result.report.fields["occupancy"].summary["median"] == pytest.approx(0.5)
    net = result.network
    local = net.states["STREET_CLASS"].index("local")
    column = net.tables["OCCUPANCY"][:, local]
    # ten streets at 0.5 against one prior pseudo-observation at 1
    assert column[net.states["OCCUPANCY"].index("0.5")] == pytest.approx(10 / 11, abs=1e-9)
    many = pd.concat([streets.iloc[:1]] * 300, ignore_index=True)
    many["source_id"] = [f"s{i}" for i in range(len(many))]
    # streets 100 m apart, so that no pole merges with another street's
    many["geometry"] = [
        shapely.affinity.translate(g, 0, 100 * i) for i, g in enumerate(many.geometry)
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filled = sample(many, network=net, seed=1).streets
        lit = filled.loc[filled["lit"].astype(bool)].copy()
        assert np.mean(lit["occupancy"] == 0.5) > 0.8
        placed = place(lit, seed=2).lights
        lit["occupancy"] = 1.0
        full = place(lit, seed=2).lights
    # occupancy thins the pole positions: about the occupancy's share of them stand
    poles, full_poles = placed["pole_id"].nunique(), full["pole_id"].nunique()
    expected = float(np.mean(filled.loc[lit.index, "occupancy"]))
    assert poles / full_poles == pytest.approx(expected, abs=0.05)


def test_full_occupancy_places_as_without_it() -> None:
    streets, _ = _city()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filled = sample(streets, network="europe", seed=4).streets
    assert (filled["occupancy"] == 1.0).all()
    lit = filled.loc[filled["lit"].astype(bool)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = place(lit, seed=5).lights
        without = place(lit.drop(columns="occupancy"), seed=5).lights
    assert one.geometry.equals(without.geometry)
