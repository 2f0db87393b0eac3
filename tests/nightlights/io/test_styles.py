"""QGIS styles: the QML documents, the sidecars beside rasters, GeoPackage 1.2 and layer_styles.

The documents are checked here as XML against what each product kind asks for; tests/qgis/
opens the written files in QGIS itself.
"""

from __future__ import annotations

import sqlite3
import xml.etree.ElementTree as ET
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from shapely.geometry import LineString, Point

from nightlights.brightness import BORTLE_LOWER_EDGES
from nightlights.errors import InputError, NightlightsWarning, OutputError
from nightlights.io import OutputSet, Raster, RasterBand, write_cog, write_gpkg
from nightlights.io.styles import (
    BORTLE_COLOURS,
    FAINTEST_MAGNITUDE,
    PRODUCT_TAG,
    QUANTILE_CLASSES,
    dimming_qml,
    emission_qml,
    illuminance_qml,
    influence_qml,
    log_ramp_range,
    observers_style,
    poles_style,
    raster_qml,
    raster_styles,
    register_raster_style,
    sidecar_path,
    sky_brightness_qml,
    streets_style,
    unregister_raster_style,
)
from nightlights.streets.schema import ARRANGEMENTS

TRANSFORM = Affine(10.0, 0.0, 385_000.0, 0.0, -10.0, 6_672_000.0)


def _shader(qml: str) -> tuple[ET.Element, ET.Element, list[ET.Element]]:
    root = ET.fromstring(qml)
    renderer = root.find("pipe/rasterrenderer")
    assert renderer is not None
    shader = renderer.find("rastershader/colorrampshader")
    assert shader is not None
    return renderer, shader, shader.findall("item")


def _values(items: list[ET.Element]) -> np.ndarray:
    return np.array([float(item.get("value", "nan")) for item in items])


# --- raster documents ------------------------------------------------------------------------


def test_log_ramp_range_rounds_out_to_whole_decades_and_caps_its_span() -> None:
    rng = np.random.default_rng(1)
    values = 10.0 ** rng.uniform(-0.9, 1.6, 10_000)
    low, high = log_ramp_range(values, default=(1.0, 10.0))
    assert (low, high) == (0.1, 100.0)
    wide = np.array([1e-9, *10.0 ** rng.uniform(-8, 2, 10_000)])
    low, high = log_ramp_range(wide, default=(1.0, 10.0))
    assert high == 100.0 and low == pytest.approx(1e-3)  # five decades at most
    assert log_ramp_range([0.0, np.nan, -1.0], default=(0.1, 100.0)) == (0.1, 100.0)


def test_illuminance_is_a_log_ramp_with_four_stops_per_decade() -> None:
    values = np.array([0.0, 0.2, 3.0, 40.0, 80.0])
    renderer, shader, items = _shader(illuminance_qml(values, band=2))
    assert renderer.get("type") == "singlebandpseudocolor" and renderer.get("band") == "2"
    assert shader.get("colorRampType") == "INTERPOLATED"
    stops = _values(items)
    assert stops[0] == pytest.approx(0.1) and stops[-1] == pytest.approx(100.0)
    np.testing.assert_allclose(np.diff(np.log10(stops)), 0.25)
    assert items[0].get("label") == "0.1 lx" and items[-1].get("label") == "100 lx"
    assert items[0].get("color") == "#000004" and items[-1].get("color") == "#fcffa4"
    zero = renderer.find("rasterTransparency/singleValuePixelList/pixelListEntry")
    assert zero is not None  # cells without light are transparent
    assert (zero.get("min"), zero.get("max"), zero.get("percentTransparent")) == ("0", "0", "100")


def test_emission_log_ramp_is_labelled_in_its_unit() -> None:
    _, _, items = _shader(emission_qml(np.array([0.002, 0.5, 3.0])))
    assert items[-1].get("label") == "10 lm m-2"
    assert all(label.endswith("lm m-2") for label in (i.get("label", "") for i in items))


def test_sky_brightness_uses_the_bortle_classes_and_their_colours() -> None:
    renderer, shader, items = _shader(sky_brightness_qml(band=2))
    assert renderer.get("band") == "2" and shader.get("colorRampType") == "DISCRETE"
    np.testing.assert_allclose(_values(items), [*sorted(BORTLE_LOWER_EDGES), FAINTEST_MAGNITUDE])
    assert [item.get("color") for item in items] == list(reversed(BORTLE_COLOURS))
    assert items[0].get("label", "").startswith("Bortle 9")
    assert items[-1].get("label", "").startswith("Bortle 1")


def test_influence_classes_hold_equal_counts_of_the_lit_cells() -> None:
    rng = np.random.default_rng(2)
    values = np.concatenate([rng.lognormal(size=1000), np.zeros(500), [np.nan] * 10])
    _, shader, items = _shader(influence_qml(values))
    assert shader.get("colorRampType") == "DISCRETE" and shader.get("classificationMode") == "3"
    edges = _values(items)
    assert edges.size == QUANTILE_CLASSES
    lit = values[values > 0]
    counts = np.histogram(lit, bins=[0.0, *edges])[0]
    assert counts.min() >= 95 and counts.max() <= 105  # 1000 lit cells in ten classes


def test_dimming_runs_linearly_over_zero_to_one() -> None:
    _, _, items = _shader(dimming_qml())
    np.testing.assert_allclose(_values(items), np.linspace(0.0, 1.0, 9))
    assert items[0].get("label") == "0 (unchanged)" and items[-1].get("label") == "1 (off)"


@pytest.mark.parametrize(
    ("descriptions", "units", "tags", "band", "kind"),
    [
        (("zenith_luminance", "zenith_sky_brightness"), ("cd m-2", "mag arcsec-2"), {}, 2, "mag"),
        (("dimming",), ("1",), {}, 1, "dimming"),
        (("zenith_luminance",), ("cd m-2",), {"metric": "zenith"}, 1, "quantile"),
        (("photopic", "scotopic"), ("lx", "W m-2"), {}, 1, "lx"),
        (("melanopic",), ("W m-2",), {}, 1, "W m-2"),
        (("reflected", "uplight"), ("lm m-2", "lm m-2"), {}, 1, "lm m-2"),
        (("luminance",), ("cd m-2",), {}, 1, "cd m-2"),
        (("height",), ("m",), {}, 1, "m"),
    ],
)
def test_raster_qml_chooses_the_style_from_the_bands(
    descriptions: tuple[str, ...],
    units: tuple[str, ...],
    tags: dict[str, str],
    band: int,
    kind: str,
) -> None:
    arrays = [np.linspace(0.01, 50.0, 100).reshape(10, 10) for _ in descriptions]
    renderer, shader, items = _shader(raster_qml(descriptions, units, arrays, tags))
    assert renderer.get("band") == str(band)
    labels = " ".join(item.get("label", "") for item in items)
    if kind == "mag":
        assert "Bortle" in labels
    elif kind == "dimming":
        assert "(off)" in labels
    elif kind == "quantile":
        assert shader.get("classificationMode") == "3"
    else:
        assert kind in labels


#: The bands each stage writes, by product tag (descriptions, units, tags besides the product).
PRODUCTS = {
    "irradiance": (("photopic", "melanopic"), ("lx", "W m-2"), {}),
    "emission": (("reflected", "uplight"), ("lm m-2", "lm m-2"), {}),
    "polar_emission": (("flux_density_1",), ("lm m-2",), {}),
    "panorama": (("luminance", "sky_brightness"), ("cd m-2", "mag arcsec-2"), {}),
    "zenith_brightness": (
        ("zenith_luminance", "zenith_sky_brightness"),
        ("cd m-2", "mag arcsec-2"),
        {},
    ),
    "influence_q": (("q_pca_norm",), ("cd m-2",), {"metric": "pca-norm"}),
    "influence_s": (("region_luminance",), ("cd m-2",), {"metric": "region"}),
    "dimming": (("dimming",), ("1",), {}),
}


@pytest.mark.parametrize("product", sorted(PRODUCTS))
def test_each_product_tag_keeps_the_style_its_bands_had(product: str) -> None:
    """The registry's style of every stage's product is byte-identical to the one the unit
    rules chose before products were tagged (and still choose for untagged files)."""
    descriptions, units, tags = PRODUCTS[product]
    rng = np.random.default_rng(3)
    arrays = [rng.lognormal(0.0, 2.0, (12, 12)) for _ in descriptions]
    tagged = raster_qml(descriptions, units, arrays, {**tags, PRODUCT_TAG: product})
    assert tagged == raster_qml(descriptions, units, arrays, tags)
    assert set(PRODUCTS) <= set(raster_styles())


def test_the_product_tag_decides_over_the_units() -> None:
    """A new product in cd m-2 no longer passes for a luminance map once it has its style."""
    arrays = [np.linspace(0.0, 1.0, 100).reshape(10, 10)]
    register_raster_style("fraction_lit", lambda d, u, b, t: dimming_qml())
    try:
        qml = raster_qml(("share",), ("cd m-2",), arrays, {PRODUCT_TAG: "fraction_lit"})
        assert qml == dimming_qml()
        with pytest.raises(InputError, match="already has a style"):
            register_raster_style("fraction_lit", lambda d, u, b, t: "")
    finally:
        unregister_raster_style("fraction_lit")
    with pytest.warns(NightlightsWarning, match="'fraction_lit' has no registered style"):
        neutral = raster_qml(("share",), ("cd m-2",), arrays, {PRODUCT_TAG: "fraction_lit"})
    assert "values: linear ramp" in neutral


# --- the sidecar beside a raster -----------------------------------------------------------


def _raster(unit: str = "lx") -> Raster:
    data = np.linspace(0.0, 30.0, 400).reshape(1, 20, 20)
    return Raster(data, TRANSFORM, "EPSG:32635", ("photopic",), (unit,))


def test_a_raster_is_written_with_its_style_beside_it(tmp_path: Path) -> None:
    path = _raster().write(tmp_path / "irradiance.tif")
    assert sidecar_path(path) == tmp_path / "irradiance.qml"
    _, _, items = _shader(sidecar_path(path).read_text(encoding="utf-8"))
    assert items[-1].get("label") == "100 lx"


def test_a_raster_is_a_cog_with_crs_nodata_band_names_and_units(tmp_path: Path) -> None:
    import rasterio

    path = Raster(
        np.ones((2, 600, 600)), TRANSFORM, "EPSG:32635", ("photopic", "scotopic"), ("lx", "W m-2")
    ).write(tmp_path / "irradiance.tif")
    with rasterio.open(path) as dataset:
        assert dataset.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert dataset.overviews(1)  # larger than one block: overviews
        assert dataset.crs.to_epsg() == 32635 and np.isnan(dataset.nodata)
        assert dataset.descriptions == ("photopic", "scotopic")
        assert dataset.units == ("lx", "W m-2")
    assert sidecar_path(path).exists()


def test_the_style_can_be_given_or_left_out(tmp_path: Path) -> None:
    band = RasterBand(np.ones((4, 4)), "a", "lx")
    given = dimming_qml()
    write_cog(tmp_path / "given.tif", [band], transform=TRANSFORM, crs="EPSG:32635", qml=given)
    assert (tmp_path / "given.qml").read_text(encoding="utf-8") == given
    write_cog(tmp_path / "none.tif", [band], transform=TRANSFORM, crs="EPSG:32635", qml=False)
    assert not (tmp_path / "none.qml").exists()


def test_an_output_set_carries_the_sidecar_onto_its_output(tmp_path: Path) -> None:
    target = tmp_path / "emission.tif"
    with OutputSet(target) as outputs:
        _raster("lm m-2").write(outputs.temporary(target))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["emission.qml", "emission.tif"]


def test_a_failed_block_leaves_neither_the_raster_nor_its_sidecar(tmp_path: Path) -> None:
    target = tmp_path / "emission.tif"
    with pytest.raises(RuntimeError), OutputSet(target) as outputs:
        _raster("lm m-2").write(outputs.temporary(target))
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


# --- GeoPackages -------------------------------------------------------------------------------


def _points() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {"system_id": ["led_a", "led_b", "led_a"], "heading": [0.0, 90.0, 200.0]},
        geometry=[Point(385_000, 6_671_800), Point(385_050, 6_671_850), Point(385_100, 6_671_700)],
        crs="EPSG:32635",
    )


def _style_rows(path: Path) -> list[tuple[object, ...]]:
    with sqlite3.connect(path) as db:
        return db.execute(
            "SELECT f_table_schema, f_table_name, f_geometry_column, styleName, useAsDefault, "
            "styleQML FROM layer_styles"
        ).fetchall()


def test_geopackages_are_version_1_2(tmp_path: Path) -> None:
    path = write_gpkg(_points(), tmp_path / "lights.gpkg", layer="lights")
    with sqlite3.connect(path) as db:
        assert db.execute("PRAGMA application_id").fetchone()[0] == 0x47504B47  # "GPKG"
        assert db.execute("PRAGMA user_version").fetchone()[0] == 10200
    assert not any(
        row[0] == "layer_styles"
        for row in sqlite3.connect(path).execute("SELECT table_name FROM gpkg_contents")
    )


def test_the_style_is_stored_as_the_layer_default(tmp_path: Path) -> None:
    frame = _points()
    path = write_gpkg(
        frame, tmp_path / "lights.gpkg", layer="lights", style=poles_style(frame["system_id"])
    )
    [(schema, table, geometry, name, default, qml)] = _style_rows(path)
    assert (schema, table, geometry, name, default) == ("", "lights", "geom", "poles by system", 1)
    with sqlite3.connect(path) as db:
        kinds = dict(db.execute("SELECT table_name, data_type FROM gpkg_contents").fetchall())
    assert kinds == {"lights": "features", "layer_styles": "attributes"}
    renderer = ET.fromstring(str(qml)).find("renderer-v2")
    assert renderer is not None and renderer.get("attr") == "system_id"
    values = [c.get("value") for c in renderer.iter("category")]
    assert values == ["led_a", "led_b", ""]  # "" takes every other system
    angle = renderer.find(".//data_defined_properties//Option[@name='angle']")
    assert angle is not None
    assert angle.find("Option[@name='field']").get("value") == "heading"  # type: ignore[union-attr]
    assert angle.find("Option[@name='active']").get("value") == "true"  # type: ignore[union-attr]


def test_streets_are_coloured_by_arrangement(tmp_path: Path) -> None:
    streets = gpd.GeoDataFrame(
        {"arrangement": ["opposite", None]},
        geometry=[LineString([(0, 0), (50, 0)]), LineString([(0, 10), (50, 10)])],
        crs="EPSG:32635",
    )
    path = write_gpkg(
        streets, tmp_path / "streets.gpkg", layer="streets", style=streets_style(ARRANGEMENTS)
    )
    [row] = _style_rows(path)
    renderer = ET.fromstring(str(row[5])).find("renderer-v2")
    assert renderer is not None and renderer.get("attr") == "arrangement"
    assert [c.get("value") for c in renderer.iter("category")] == [*ARRANGEMENTS, ""]
    assert {s.get("type") for s in renderer.iter("symbol")} == {"line"}


def test_observers_are_coloured_by_the_bortle_class_of_their_zenith() -> None:
    style = observers_style()
    renderer = ET.fromstring(style.qml).find("renderer-v2")
    assert renderer is not None and renderer.get("type") == "graduatedSymbol"
    assert renderer.get("attr") == "zenith_mag"
    uppers = [float(r.get("upper", "nan")) for r in renderer.iter("range")]
    np.testing.assert_allclose(uppers, [*sorted(BORTLE_LOWER_EDGES), FAINTEST_MAGNITUDE])
    assert ET.fromstring(style.qml).find("labeling/settings/text-style").get("fieldName") == "name"  # type: ignore[union-attr]


def test_a_style_for_a_missing_layer_file_is_a_one_line_error(tmp_path: Path) -> None:
    from nightlights.io.styles import add_layer_style

    with pytest.raises(OutputError, match="cannot store the style"):
        add_layer_style(
            tmp_path / "none" / "x.gpkg", "x", observers_style(), geometry_column="geom"
        )
