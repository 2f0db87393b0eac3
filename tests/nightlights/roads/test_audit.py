"""The street audit: matrices against point-by-point sums, figures against the metric
functions, ratings against ``compliance``, and bad input."""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
from shapely import LineString

from nightlights import roads
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.ground.luminaires import load_database
from nightlights.roads._rating import section_figures
from nightlights.streets import place


def _streets(**overrides: list) -> gpd.GeoDataFrame:
    data = {
        "source_id": ["a", "b", "c"],
        "width": [7.0, 12.0, 6.0],
        "lanes": [2, 4, 2],
        "lit": [True] * 3,
        "arrangement": ["single_sided", "opposite", "staggered"],
        "spacing": [30.0, 40.0, 25.0],
        "mounting_height": [8.0, 10.0, 6.0],
        "system_id": ["street_led_small", "road_led_large", "street_led_small"],
        "lighting_class": ["M4", "M3", "P3"],
    }
    data.update(overrides)
    return gpd.GeoDataFrame(
        data,
        geometry=[
            LineString([(0, 0), (300, 0)]),
            LineString([(0, 100), (200, 150), (400, 100)]),
            LineString([(500, 0), (500, 200)]),
        ],
        crs="EPSG:3067",
    )


@pytest.fixture(scope="module")
def layers() -> tuple[gpd.GeoDataFrame, gpd.GeoDataFrame]:
    streets = _streets()
    lights = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0).lights
    return lights, streets


@pytest.fixture(scope="module")
def everything(layers: tuple) -> roads.RoadModel:
    """A model in which every light reaches every point (the brute-force sums' scope)."""
    lights, streets = layers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        return roads.road_model(lights, streets, reach_heights=1e4)


def _photometric(model: roads.RoadModel) -> list:
    """Each light's intensity straight from its photometry file (not the sampled table)."""
    database = load_database(None)
    lum = model.luminaires
    functions = {name: database.photometry(name).intensity for name in lum.names}
    return [functions[lum.names[t]] for t in lum.table_index]


def test_luminance_matrix_equals_point_by_point_sum(everything: roads.RoadModel) -> None:
    model = everything
    lum, fields, influence = model.luminaires, model.fields, model.influence
    intensity = [
        (lambda table: lambda v, h: table.lookup(v, h))(lum.tables[t]) for t in lum.table_index
    ]
    total = influence.luminance @ np.ones(len(lum))
    for o in range(len(fields.observers)):
        rows = np.flatnonzero(influence.sample_observer == o)
        points = fields.luminance.xy[influence.sample_point[rows]]
        eye = np.array([*fields.observers.xy[o], 1.5])
        expected = roads.road_luminance(
            np.column_stack([points, np.zeros(len(points))]),
            eye,
            lum.light_point,
            lum.rotation,
            intensity,
            model.rtable,
            street_azimuth=lum.street_azimuth,
        )
        # the kernel reads r bilinearly off the table resampled on a fine grid (next test)
        np.testing.assert_allclose(total[rows], expected, rtol=1e-4, atol=1e-12)


@pytest.mark.parametrize("interpolation", ["cubic", "bilinear"])
def test_resampled_rtable_reads_within_1e_4(interpolation: str) -> None:
    from nightlights.roads import _influence

    table = roads.synthetic_rtable()
    grid = _influence.resample_rtable(table, "zero", interpolation)
    rng = np.random.default_rng(3)
    beta, tan = rng.uniform(0, 180, 20000), rng.uniform(0, 12, 20000)
    ft, fb = tan / grid.tan_step, beta / grid.beta_step
    it = np.minimum(ft.astype(int), grid.values.shape[0] - 2)
    ib = np.minimum(fb.astype(int), grid.values.shape[1] - 2)
    wt, wb = ft - it, fb - ib
    v = grid.values
    low = v[it, ib] + wb * (v[it, ib + 1] - v[it, ib])
    high = v[it + 1, ib] + wb * (v[it + 1, ib + 1] - v[it + 1, ib])
    read = low + wt * (high - low)
    exact = roads.reduced_luminance_coefficient(table, beta, tan, interpolation=interpolation)
    assert np.max(np.abs(read - exact)) < 1e-4 * table.r.max()


def test_illuminance_matrix_equals_point_by_point_sum(everything: roads.RoadModel) -> None:
    model = everything
    lum, fields = model.luminaires, model.fields
    xy = fields.illuminance.xy
    expected = np.zeros(len(xy))
    for k in range(len(lum)):  # E = I cos(gamma) / d^2, one luminaire at a time
        table = lum.tables[lum.table_index[k]]
        direction = np.column_stack([xy - lum.light_point[k, :2], -np.full(len(xy), 8.0)])
        direction[:, 2] = -lum.light_point[k, 2]
        from nightlights.ground.frames import direction_to_photometric

        v, h = direction_to_photometric(
            direction, lum.rotation[k], street_azimuth=lum.street_azimuth[k]
        )
        d = np.linalg.norm(direction, axis=1)
        expected += table.lookup(v, h) * (lum.light_point[k, 2] / d) / d**2
    got = model.influence.illuminance @ np.ones(len(lum))
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_veiling_equals_glare_geometry_on_a_straight_street(layers: tuple) -> None:
    lights, streets = layers
    straight = streets.iloc[[0]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        model = roads.road_model(lights, straight)
    lum = model.luminaires
    intensity = [
        (lambda table: lambda v, h: table.lookup(v, h))(lum.tables[t]) for t in lum.table_index
    ]
    veil = model.influence.veiling @ np.ones(len(lum))
    for o in range(len(model.fields.observers)):
        eye = np.array([*model.fields.observers.xy[o], 1.5])
        near = np.linalg.norm(lum.light_point[:, :2] - eye[:2], axis=1) <= 500.0
        glare = roads.glare_geometry(
            eye,
            lum.light_point[near],
            lum.rotation[near],
            [f for f, n in zip(intensity, near, strict=True) if n],
            street_azimuth=lum.street_azimuth[near],
        )
        expected = roads.veiling_luminance(
            glare.eye_illuminance[glare.counted], glare.angle[glare.counted]
        )
        assert veil[o] == pytest.approx(expected, rel=1e-12)


def test_figures_against_brute_force_from_the_photometry(layers: tuple) -> None:
    """Default reach and sampled tables against every light and the photometry itself:
    within 0.5 % (the accuracy the audit promises)."""
    lights, streets = layers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        model = roads.road_model(lights, streets)
    figures = section_figures(model.influence)
    lum, fields = model.luminaires, model.fields
    photometric = _photometric(model)
    for section in np.flatnonzero(np.isfinite(figures["average_luminance"])):
        observers = np.flatnonzero(fields.observers.section == section)
        points = fields.luminance.section == section
        xy = fields.luminance.xy[points]
        n_rows = fields.luminance.row[points].max() + 1
        grid = np.column_stack([xy, np.zeros(len(xy))]).reshape(n_rows, -1, 3)
        per_observer = np.stack(
            [
                roads.road_luminance(
                    grid,
                    np.array([*fields.observers.xy[o], 1.5]),
                    lum.light_point,
                    lum.rotation,
                    photometric,
                    model.rtable,
                    street_azimuth=lum.street_azimuth,
                )
                for o in observers
            ]
        )
        average = roads.average_luminance(per_observer).min()
        uniformity = roads.overall_uniformity(per_observer).min()
        longitudinal = roads.longitudinal_uniformity(
            per_observer, [3 * j + 1 for j in range(len(observers))]
        )
        assert figures["average_luminance"][section] == pytest.approx(average, rel=5e-3)
        assert figures["overall_uniformity"][section] == pytest.approx(uniformity, rel=5e-3)
        assert figures["longitudinal_uniformity"][section] == pytest.approx(longitudinal, rel=5e-3)
    for section in np.flatnonzero(np.isfinite(figures["average_illuminance"])):
        points = fields.illuminance.section == section
        xy = fields.illuminance.xy[points]
        from nightlights.roads._geometry import intensities

        target = np.column_stack([xy, np.zeros(len(xy))])
        candela = intensities(
            target, lum.light_point, lum.rotation, photometric, street_azimuth=lum.street_azimuth
        )
        d = np.linalg.norm(target[None] - lum.light_point[:, None], axis=2)
        e = np.sum(candela * lum.light_point[:, 2, None] / d**3, axis=0)
        assert figures["average_illuminance"][section] == pytest.approx(e.mean(), rel=5e-3)
        assert figures["minimum_illuminance"][section] == pytest.approx(e.min(), rel=5e-3)


def test_ratings_agree_with_compliance(layers: tuple) -> None:
    lights, streets = layers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(lights, streets)
    table = roads.read_requirements()
    for _, row in result.segments.iterrows():
        needed = table[row["lighting_class"]]
        expected = roads.compliance(row["lighting_class"], {n: row[n] for n in needed})
        assert (row["status"] == "pass") == expected.passed
        assert row["binding"] == expected.binding.name
        assert row["binding_margin"] == pytest.approx(expected.binding.margin, rel=1e-12)
    summary = result.summary
    assert summary.segments == 3 and summary.rated == 3
    passed = result.segments["status"] == "pass"
    assert summary.passed_length == pytest.approx(result.segments.length[passed].sum())


def test_dimming_scales_levels_and_keeps_ratios(layers: tuple) -> None:
    lights, streets = layers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        model = roads.road_model(lights, streets)
    full = model.rate()
    half = model.rate(np.full(len(model.luminaires), 0.5))
    for name in ("average_luminance", "average_illuminance", "minimum_illuminance"):
        np.testing.assert_allclose(half[name], 0.5 * full[name], rtol=1e-12)
    for name in ("overall_uniformity", "longitudinal_uniformity", "edge_illuminance_ratio"):
        np.testing.assert_allclose(half[name], full[name], rtol=1e-12)
    # f_TI = 65 L_v / L_av^0.8 with both halved grows by 0.5 / 0.5^0.8 = 0.5^0.2
    np.testing.assert_allclose(
        half["threshold_increment"], full["threshold_increment"] * 0.5**0.2, rtol=1e-12
    )


def test_writes_a_styled_layer(layers: tuple, tmp_path) -> None:
    lights, streets = layers
    out = tmp_path / "audit.gpkg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(lights, streets, out)
    assert result.path == out
    written = gpd.read_file(out, layer="segments")
    assert list(written["status"]) == list(result.segments["status"])
    styles = pyogrio.read_dataframe(out, layer="layer_styles", read_geometry=False)
    assert styles["styleName"].tolist() == ["segments by compliance"]


def test_segment_without_spacing_takes_the_lights_gap(layers: tuple) -> None:
    lights, streets = layers
    no_spacing = streets.assign(spacing=[np.nan, 40.0, 25.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        model = roads.road_model(lights, no_spacing)
    first = model.fields.spacing[model.fields.segment == 0]
    assert np.allclose(first, 30.0)  # the placed poles' gap on street a


def test_short_segment_warns_and_is_one_section(layers: tuple) -> None:
    lights, streets = layers
    short = streets.assign(spacing=[30.0, 40.0, 500.0])
    with pytest.warns(DataQualityWarning, match="shorter than their spacing"):
        model = roads.road_model(lights, short, rtable=roads.synthetic_rtable())
    assert np.count_nonzero(model.fields.segment == 2) == 1
    assert model.fields.spacing[model.fields.segment == 2][0] == pytest.approx(200.0)


def test_unrated_segments_say_why(layers: tuple) -> None:
    lights, streets = layers
    layer = streets.assign(lighting_class=[None, "M3", "P3"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(lights, layer)
    first = result.segments.iloc[0]
    assert first["status"] == "not rated" and first["reason"] == "no lighting class"
    assert result.summary.rated == 2


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"lighting_class": ["M9", "M3", "P3"]}, "unknown lighting_class"),
        ({"width": None}, "no field 'width'"),
    ],
)
def test_bad_streets_write_nothing(layers: tuple, tmp_path, change: dict, match: str) -> None:
    lights, streets = layers
    layer = streets.copy()
    for name, value in change.items():
        if value is None:
            layer = layer.drop(columns=[name])
        else:
            layer[name] = value
    out = tmp_path / "audit.gpkg"
    with pytest.raises(InputError, match=match):
        roads.audit(lights, layer, out)
    assert not out.exists()


def test_bad_dimming_and_empty_lights(layers: tuple) -> None:
    lights, streets = layers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        with pytest.raises(InputError, match="one level per light"):
            roads.audit(lights, streets, dimming=[0.5])
        with pytest.raises(InputError, match="outside 0-1"):
            roads.audit(lights, streets, dimming=np.full(len(lights), 1.5))
    with pytest.raises(EmptyInputError, match="no lights"):
        roads.audit(lights.iloc[:0], streets)


def test_stand_in_rtable_warns_only_for_luminance_classes(layers: tuple) -> None:
    lights, streets = layers
    with pytest.warns(DataQualityWarning, match="stand-in"):
        roads.audit(lights, streets)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        roads.audit(lights, streets.iloc[[2]])  # a P class only


def test_classes_come_from_the_selection_rules_unless_given(layers: tuple) -> None:
    lights, streets = layers
    layer = streets.assign(
        street_class=["arterial", "collector", "local"], lighting_class=[None, None, "P2"]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        result = roads.audit(lights, layer)
        expected = roads.select_classes(layer)
    assert list(result.segments["lighting_class"]) == list(expected)
    assert result.segments["lighting_class"].iloc[2] == "P2"


def test_criteria_the_audit_does_not_compute_warn(layers: tuple) -> None:
    lights, streets = layers
    table = {"P3": {"average_illuminance": 7.5, "minimum_vertical_illuminance": 1.0}}
    with pytest.warns(DataQualityWarning, match="does not compute"):
        result = roads.audit(lights, streets.iloc[[2]], requirements=table)
    assert result.segments["status"].iloc[0] in ("pass", "fail")


def test_lights_without_photometry_or_a_bad_rtable_write_nothing(layers: tuple, tmp_path) -> None:
    lights, streets = layers
    out = tmp_path / "audit.gpkg"
    unknown = lights.assign(system_id=["no_such_system", *list(lights["system_id"][1:])])
    with pytest.raises(InputError, match="unknown system_id"):
        roads.audit(unknown, streets, out)
    assert not out.exists()
    table = tmp_path / "r.txt"
    table.write_text("0 90 180\n0 1 2 3\n0.25 1 2\n")  # a row of the wrong length
    with pytest.raises(InputError, match=r"r\.txt"):
        roads.audit(lights, streets, out, rtable=table)
    assert not out.exists()
