"""CLI tests of ``nightlights streets sample`` and ``streets fit``."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import pytest
import shapely
from click.testing import CliRunner

from bayesnets.errors import EvidenceRelaxedWarning
from cli.main import cli
from nightlights.io import write_gpkg
from nightlights.streets.schema import STREET_FIELDS, observed_field


def _normalised(path: Path, rows: list[dict]) -> Path:
    data: dict[str, list] = {"source_id": [f"s{i}" for i in range(len(rows))]}
    for name in STREET_FIELDS:
        data[name] = [row.get(name) for row in rows]
        data[observed_field(name)] = [name in row for row in rows]
    lines = [shapely.LineString([(0, 30 * i), (100, 30 * i)]) for i in range(len(rows))]
    frame = gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067")
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


def test_relax_succeeds_with_warning(tmp_path: Path) -> None:
    src = _impossible(tmp_path)
    out = tmp_path / "lit.gpkg"
    with pytest.warns(EvidenceRelaxedWarning, match="dropped"):
        result = CliRunner().invoke(
            cli, ["streets", "sample", str(src), str(out), "--on-conflict", "relax"]
        )
    assert result.exit_code == 0, result.output
    assert gpd.read_file(out)["arrangement"].iloc[0] != "single_sided" or (
        gpd.read_file(out)["mounting_height"].iloc[0] != 5.0
    )


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
    bad = runner.invoke(cli, ["streets", "fit", str(lit), str(net)])
    assert bad.exit_code != 0 and "not an empty folder" in bad.output
