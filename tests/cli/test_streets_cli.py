"""CLI tests of ``nightlights streets normalize`` and ``place``."""

from __future__ import annotations

import geopandas as gpd
import shapely
from click.testing import CliRunner

from cli.main import cli


def test_version_and_help() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["--version"])
    assert result.exit_code == 0 and "nightlights, version" in result.output
    result = runner.invoke(cli, ["streets", "--help"])
    assert result.exit_code == 0
    assert {"normalize", "place"} <= set(result.output.split())


def test_normalize_osm_xml(data_dir, tmp_path) -> None:
    out = tmp_path / "streets.gpkg"
    result = CliRunner().invoke(
        cli,
        [
            "streets",
            "normalize",
            str(data_dir / "streets" / "berlin-siegessaeule.osm.gz"),
            str(out),
            "--mapping",
            "osm",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "canonical fields" in result.output
    frame = gpd.read_file(out)
    assert frame.crs.to_epsg() == 32633 and len(frame) > 50


def test_domain_errors_are_one_line_with_nonzero_exit(tmp_path) -> None:
    out = tmp_path / "out.gpkg"
    result = CliRunner().invoke(
        cli, ["streets", "normalize", str(tmp_path / "missing.gpkg"), str(out)]
    )
    assert result.exit_code == 1
    assert result.output.strip().count("\n") == 0
    assert "InputError" in result.output and "no such file" in result.output
    assert "Traceback" not in result.output and not out.exists()
    result = CliRunner().invoke(
        cli, ["streets", "normalize", str(tmp_path / "missing.gpkg"), str(out), "--mapping", "nope"]
    )
    assert result.exit_code == 1 and "MappingError" in result.output


def test_place_from_sampled_layer(tmp_path) -> None:
    src = tmp_path / "lit.gpkg"
    gpd.GeoDataFrame(
        {
            "source_id": ["a"],
            "street_class": ["local"],
            "width": [7.0],
            "lit": [True],
            "arrangement": ["staggered"],
            "spacing": [25.0],
            "mounting_height": [8.0],
            "arm_length": [1.0],
            "setback": [1.0],
            "tilt": [0.0],
            "system_id": ["street_led_small"],
        },
        geometry=[shapely.LineString([(0, 0), (500, 0)])],
        crs="EPSG:3067",
    ).to_file(src)
    out = tmp_path / "lights.gpkg"
    result = CliRunner().invoke(cli, ["streets", "place", str(src), str(out), "--seed", "4"])
    assert result.exit_code == 0, result.output
    lights = gpd.read_file(out)
    assert 18 <= len(lights) <= 22 and lights.crs.to_epsg() == 3067
    again = tmp_path / "again.gpkg"
    CliRunner().invoke(cli, ["streets", "place", str(src), str(again), "--seed", "4"])
    assert gpd.read_file(again).equals(lights)


def test_place_rejects_system_ids_missing_from_the_database(tmp_path) -> None:
    src = tmp_path / "lit.gpkg"
    gpd.GeoDataFrame(
        {
            "source_id": ["a"],
            "width": [7.0],
            "lit": [True],
            "arrangement": ["opposite"],
            "spacing": [25.0],
            "mounting_height": [8.0],
            "system_id": ["no_such_luminaire"],
        },
        geometry=[shapely.LineString([(0, 0), (500, 0)])],
        crs="EPSG:3067",
    ).to_file(src)
    out = tmp_path / "lights.gpkg"
    result = CliRunner().invoke(cli, ["streets", "place", str(src), str(out)])
    assert result.exit_code == 1
    assert "no_such_luminaire" in result.output and "not in the luminaire database" in result.output
    assert not out.exists()
