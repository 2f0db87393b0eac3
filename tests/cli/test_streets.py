"""``nightlights streets normalize``, ``sample``, ``fit`` and ``place``."""

from __future__ import annotations

import logging
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import pytest
import shapely
from click.testing import CliRunner

from bayesnets.errors import EvidenceRelaxedWarning
from nightlights.io import write_gpkg
from nightlights.streets import NormalizeReport
from nightlights.streets.schema import STREET_FIELDS, observed_field
from nightlights_cli.main import cli


def test_version_and_help() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["--version"])
    assert result.exit_code == 0 and "nightlights, version" in result.output
    result = runner.invoke(cli, ["streets", "--help"])
    assert result.exit_code == 0
    assert {"normalize", "sample", "fit", "place"} <= set(result.output.split())


# --- normalize -----------------------------------------------------------------------------------


def test_normalize_osm_xml(data_dir: Path, tmp_path: Path) -> None:
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


def test_domain_errors_are_one_line_with_nonzero_exit(tmp_path: Path) -> None:
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


def _report() -> NormalizeReport:
    return NormalizeReport(input_features=3, output_features=2, crs="EPSG:3067")


def test_normalize_options_reach_the_stage(fake_stage, tmp_path: Path) -> None:
    stage = fake_stage("normalize", SimpleNamespace(report=_report()))
    out = tmp_path / "n.gpkg"
    args = ["streets", "normalize", "in.osm", "-o", str(out), "--crs", "EPSG:4326"]
    result = CliRunner().invoke(cli, [*args, "--target-crs", "EPSG:3067", "--layer", "lines"])
    assert result.exit_code == 0, result.output
    assert stage.args == ("in.osm", str(out))
    assert stage.kwargs == {
        "mapping": "osm",
        "layer": "lines",
        "crs": "EPSG:4326",
        "target_crs": "EPSG:3067",
    }
    assert "2 street parts from 3 features" in result.output


def test_normalize_refuses_an_existing_output(fake_stage, tmp_path: Path) -> None:
    stage = fake_stage("normalize", SimpleNamespace(report=_report()))
    out = tmp_path / "n.gpkg"
    out.write_text("keep")
    result = CliRunner().invoke(cli, ["streets", "normalize", "in.osm", str(out)])
    assert result.exit_code == 1
    assert result.output == f"Error: {out}: exists; give --overwrite to replace it\n"
    assert stage.calls == [] and out.read_text() == "keep"
    result = CliRunner().invoke(cli, ["streets", "normalize", "in.osm", str(out), "--overwrite"])
    assert result.exit_code == 0, result.output
    assert stage.args == ("in.osm", str(out))


# --- sample and fit --------------------------------------------------------------------------


def _normalised(
    path: Path,
    rows: list[dict],
    *,
    crs: str = "EPSG:3067",
    origin: tuple[float, float] = (385000.0, 6672000.0),
) -> Path:
    """Normalised streets near ``origin`` [m] in ``crs`` (default: Helsinki, ETRS-TM35FIN)."""
    data: dict[str, list] = {"source_id": [f"s{i}" for i in range(len(rows))]}
    for name in STREET_FIELDS:
        data[name] = [row.get(name) for row in rows]
        data[observed_field(name)] = [name in row for row in rows]
    x, y = origin
    lines = [shapely.LineString([(x, y + 30 * i), (x + 100, y + 30 * i)]) for i in range(len(rows))]
    frame = gpd.GeoDataFrame(data, geometry=lines, crs=crs)
    schema = {
        "source_id": "str",
        **STREET_FIELDS,
        **{observed_field(n): "bool" for n in STREET_FIELDS},
    }
    return write_gpkg(frame, path, layer="streets", schema=schema)


ROWS = [
    {"street_class": "local", "lit": True},
    {"street_class": "arterial", "lanes": 4},
    {"street_class": "path", "lit": True},
] * 5


def test_sample_prints_summary(tmp_path: Path) -> None:
    src = _normalised(tmp_path / "norm.gpkg", ROWS)
    out = tmp_path / "lit.gpkg"
    result = CliRunner().invoke(
        cli,
        [
            "streets",
            "sample",
            str(src),
            str(out),
            "--seed",
            "1",
            "--network",
            "north_america",
            "--candidates",
            "8",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "15 street segments" in result.output
    assert "arrangement" in result.output and "light system" in result.output
    assert len(gpd.read_file(out)) == 15


def test_sample_chooses_the_network_by_location(tmp_path: Path, caplog, recwarn) -> None:
    runner = CliRunner()
    helsinki = _normalised(tmp_path / "helsinki.gpkg", ROWS)
    out = tmp_path / "lit.gpkg"
    result = runner.invoke(cli, ["streets", "sample", str(helsinki), str(out), "--seed", "1"])
    assert result.exit_code == 0, result.output
    assert "network europe, chosen by location" in " ".join(result.output.split())
    assert set(gpd.read_file(out)["network"]) == {"europe"}
    # Tokyo (JGD2011 / Japan plane rectangular CS IX): east_asia, without a warning
    tokyo = _normalised(tmp_path / "tokyo.gpkg", ROWS, crs="EPSG:6677", origin=(-5000.0, -35000.0))
    out = tmp_path / "tokyo_lit.gpkg"
    with caplog.at_level(logging.WARNING):
        result = runner.invoke(cli, ["streets", "sample", str(tokyo), str(out), "--seed", "1"])
    assert result.exit_code == 0, result.output
    assert "network east_asia, chosen by location" in " ".join(result.output.split())
    assert "'generic'" not in caplog.text and not [w for w in recwarn if "'generic'" in str(w)]
    assert set(gpd.read_file(out)["network"]) == {"east_asia"}
    caplog.clear()
    recwarn.clear()
    # Sydney (GDA94 / MGA zone 56): generic, with a warning
    sydney = _normalised(
        tmp_path / "sydney.gpkg", ROWS, crs="EPSG:28356", origin=(334000.0, 6250000.0)
    )
    out = tmp_path / "sydney_lit.gpkg"
    with caplog.at_level(logging.WARNING):
        result = runner.invoke(cli, ["streets", "sample", str(sydney), str(out), "--seed", "1"])
    assert result.exit_code == 0, result.output
    assert "network generic, chosen by location" in " ".join(result.output.split())
    # The CLI logs warnings as one line (under pytest they may reach its recorder instead).
    shown = [caplog.text, *(f"{w.category.__name__}: {w.message}" for w in recwarn)]
    assert any("DataQualityWarning" in text and "'generic'" in text for text in shown)
    assert any("--network" in text for text in shown)
    caplog.clear()
    recwarn.clear()
    assert set(gpd.read_file(out)["network"]) == {"generic"}
    # an explicit --network wins
    again = ["streets", "sample", str(sydney), str(out), "--overwrite", "--network", "europe"]
    with caplog.at_level(logging.WARNING):
        result = runner.invoke(cli, again)
    assert result.exit_code == 0, result.output
    assert "network europe" in result.output and "chosen by location" not in result.output
    assert "'generic'" not in caplog.text and not [w for w in recwarn if "'generic'" in str(w)]
    assert set(gpd.read_file(out)["network"]) == {"europe"}


def test_sample_with_output_option_and_overwrite(tmp_path: Path) -> None:
    src = _normalised(tmp_path / "norm.gpkg", ROWS)
    out = tmp_path / "lit.gpkg"
    runner = CliRunner()
    result = runner.invoke(cli, ["streets", "sample", str(src), "-o", str(out), "--seed", "1"])
    assert result.exit_code == 0, result.output
    first = gpd.read_file(out)
    refused = runner.invoke(cli, ["streets", "sample", str(src), str(out), "--seed", "2"])
    assert refused.exit_code == 1 and "give --overwrite" in refused.output
    assert gpd.read_file(out).equals(first)
    again = ["streets", "sample", str(src), str(out), "--seed", "1", "--overwrite"]
    assert runner.invoke(cli, again).exit_code == 0
    assert gpd.read_file(out).equals(first)


def _impossible(tmp_path: Path) -> Path:
    """A divided 21 m road lit by single-sided poles at 5 m: ruled out by the network."""
    src = _normalised(
        tmp_path / "norm.gpkg", [{"street_class": "local", "width": 21.0, "has_median": True}]
    )
    frame = gpd.read_file(src)
    for name, value in (("mounting_height", 5.0), ("arrangement", "single_sided")):
        frame[name] = value
        frame[observed_field(name)] = True
    return write_gpkg(frame, src, layer="streets")


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--network", "atlantis"], "CatalogError: "),
        (["--on-conflict", "error"], "ImpossibleEvidenceError: "),
    ],
)
def test_errors_are_one_line_and_leave_no_output(
    tmp_path: Path, args: list[str], expected: str
) -> None:
    src = _impossible(tmp_path)
    out = tmp_path / "lit.gpkg"
    result = CliRunner().invoke(cli, ["streets", "sample", str(src), str(out), *args])
    assert result.exit_code != 0
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: " + expected), result.output
    assert "Traceback" not in result.output
    assert not out.exists()


def test_relax_succeeds_with_warning(tmp_path: Path, caplog, recwarn) -> None:
    src = _impossible(tmp_path)
    out = tmp_path / "lit.gpkg"
    with caplog.at_level(logging.WARNING):
        result = CliRunner().invoke(
            cli, ["streets", "sample", str(src), str(out), "--on-conflict", "relax"]
        )
    assert result.exit_code == 0, result.output
    # The CLI logs warnings as one line (under pytest they may reach its recorder instead).
    shown = [caplog.text, *(f"{w.category.__name__}: {w.message}" for w in recwarn)]
    assert any(EvidenceRelaxedWarning.__name__ in text and "dropped" in text for text in shown)
    assert gpd.read_file(out)["arrangement"].iloc[0] != "single_sided" or (
        gpd.read_file(out)["mounting_height"].iloc[0] != 5.0
    )


def test_sample_missing_input_is_a_usage_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli, ["streets", "sample", str(tmp_path / "missing.gpkg"), str(tmp_path / "out.gpkg")]
    )
    assert result.exit_code == 2 and "does not exist" in result.output


def test_fit_writes_a_network_that_sample_accepts(tmp_path: Path) -> None:
    src = _normalised(tmp_path / "norm.gpkg", ROWS)
    lit = tmp_path / "lit.gpkg"
    runner = CliRunner()
    assert (
        runner.invoke(cli, ["streets", "sample", str(src), str(lit), "--seed", "2"]).exit_code == 0
    )
    net = tmp_path / "mynet"
    result = runner.invoke(cli, ["streets", "fit", str(lit), str(net), "--prior", "5"])
    assert result.exit_code == 0, result.output
    assert (net / "network.toml").exists() and (net / "ARRANGEMENT.csv").exists()
    again = tmp_path / "again.gpkg"
    result = runner.invoke(cli, ["streets", "sample", str(src), str(again), "--network", str(net)])
    assert result.exit_code == 0, result.output
    bad = runner.invoke(cli, ["streets", "fit", str(lit), "-o", str(net)])
    assert bad.exit_code != 0 and "not an empty folder" in bad.output


# --- place -----------------------------------------------------------------------------------


def _lit_street(path: Path, **fields: object) -> Path:
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
            **{name: [value] for name, value in fields.items()},
        },
        geometry=[shapely.LineString([(0, 0), (500, 0)])],
        crs="EPSG:3067",
    ).to_file(path)
    return path


def test_place_from_sampled_layer(tmp_path: Path) -> None:
    src = _lit_street(tmp_path / "lit.gpkg")
    out = tmp_path / "lights.gpkg"
    result = CliRunner().invoke(cli, ["streets", "place", str(src), str(out), "--seed", "4"])
    assert result.exit_code == 0, result.output
    lights = gpd.read_file(out)
    assert 18 <= len(lights) <= 22 and lights.crs.to_epsg() == 3067
    again = tmp_path / "again.gpkg"
    CliRunner().invoke(cli, ["streets", "place", str(src), "-o", str(again), "--seed", "4"])
    assert gpd.read_file(again).equals(lights)


def test_place_options_reach_the_stage(fake_stage, tmp_path: Path) -> None:
    lights = gpd.GeoDataFrame({"pole_id": [1, 1], "arrangement": ["opposite", "opposite"]})
    stage = fake_stage("place", SimpleNamespace(lights=lights))
    src = _lit_street(tmp_path / "lit.gpkg")
    out = tmp_path / "lights.gpkg"
    result = CliRunner().invoke(
        cli, ["streets", "place", str(src), str(out), "--seed", "3", "--across-jitter", "0"]
    )
    assert result.exit_code == 0, result.output
    assert stage.args == (str(src), str(out))
    assert stage.kwargs["seed"] == 3 and stage.kwargs["across_jitter"] == 0.0
    assert "2 luminaires on 1 poles" in result.output


def test_place_rejects_system_ids_missing_from_the_database(tmp_path: Path) -> None:
    src = _lit_street(tmp_path / "lit.gpkg", system_id="no_such_luminaire")
    out = tmp_path / "lights.gpkg"
    result = CliRunner().invoke(cli, ["streets", "place", str(src), str(out)])
    assert result.exit_code == 1
    assert "no_such_luminaire" in result.output and "not in the luminaire database" in result.output
    assert not out.exists()
