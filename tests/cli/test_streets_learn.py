"""``nightlights streets learn`` end to end on the bundled Berlin extract (ODbL)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from bayesnets import read_network
from nightlights_cli.main import cli


@pytest.fixture(scope="module")
def berlin_streets(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    data = Path(__file__).parents[1] / "data" / "streets" / "berlin-siegessaeule.osm.gz"
    out = tmp_path_factory.mktemp("berlin") / "streets.gpkg"
    result = CliRunner().invoke(cli, ["streets", "normalize", str(data), str(out)])
    assert result.exit_code == 0, result.output
    return data, out


def test_learn_writes_a_network_that_sample_accepts(
    berlin_streets: tuple[Path, Path], tmp_path: Path
) -> None:
    osm, streets = berlin_streets
    net = tmp_path / "berlin_net"
    runner = CliRunner()
    result = runner.invoke(
        cli, ["streets", "learn", str(streets), str(osm), str(net), "--seed", "1"]
    )
    assert result.exit_code == 0, result.output
    # the OSM file's points layer holds 47 highway=street_lamp nodes
    assert "of 47 lamps" in result.output and "streets with evidence" in result.output
    assert read_network(net).metadata["base_network"] == "europe"
    report = json.loads((net / "learn_report.json").read_text())
    assert report["lamps"] == 47 and report["fields"]["spacing"]["streets"] >= 3
    lit = tmp_path / "lit.gpkg"
    result = runner.invoke(
        cli, ["streets", "sample", str(streets), str(lit), "--network", str(net), "--seed", "1"]
    )
    assert result.exit_code == 0, result.output
    assert "network berlin_net" in result.output

    again = runner.invoke(cli, ["streets", "learn", str(streets), str(osm), str(net)])
    assert again.exit_code == 1 and again.output.strip().count("\n") == 0
    assert "OutputError" in again.output and "--overwrite" in again.output
    replaced = runner.invoke(
        cli,
        ["streets", "learn", str(streets), str(osm), str(net), "--overwrite", "--seed", "2"],
    )
    assert replaced.exit_code == 0, replaced.output
    assert read_network(net).metadata["seed"] == 2


def test_learn_usage_errors(berlin_streets: tuple[Path, Path], tmp_path: Path) -> None:
    osm, streets = berlin_streets
    runner = CliRunner()
    result = runner.invoke(cli, ["streets", "learn", str(streets), str(tmp_path / "net")])
    assert result.exit_code == 2 and "STREETS LAMPS OUT_DIR" in result.output
    result = runner.invoke(
        cli,
        ["streets", "learn", str(streets), str(osm), str(tmp_path / "n"), "--max-distance", "0"],
    )
    assert result.exit_code == 2 and "max-distance" in result.output
    result = runner.invoke(
        cli, ["streets", "learn", str(streets), str(streets), str(tmp_path / "n2")]
    )  # the street layer holds no points
    assert result.exit_code == 1 and "no lamp points" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "n2").exists()
