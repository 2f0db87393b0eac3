"""``nightlights streets audit``: outputs, the summary, refusals and bad flag values."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import pytest
from click.testing import CliRunner
from shapely import LineString

from nightlights.roads import EnergyOptions
from nightlights.streets import place
from nightlights_cli.main import cli


@pytest.fixture(scope="module")
def layers(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """One P3 street of 200 m in Helsinki and the lights placed along it."""
    folder = tmp_path_factory.mktemp("audit")
    streets = gpd.GeoDataFrame(
        {
            "source_id": ["a"],
            "width": [6.0],
            "lanes": [2],
            "lit": [True],
            "arrangement": ["single_sided"],
            "spacing": [25.0],
            "mounting_height": [6.0],
            "system_id": ["street_led_small"],
            "lighting_class": ["P3"],
        },
        geometry=[LineString([(385_000, 6_672_000), (385_200, 6_672_000)])],
        crs="EPSG:3067",
    )
    lights = place(streets, seed=0, along_jitter=0.0, across_jitter=0.0).lights
    lights["power"] = 40.0
    lights["level"] = 0.5
    streets.to_file(folder / "streets.gpkg")
    lights.to_file(folder / "lights.gpkg")
    return folder / "lights.gpkg", folder / "streets.gpkg"


def test_writes_the_layer_and_the_summary(layers: tuple[Path, Path], tmp_path: Path) -> None:
    lights, streets = layers
    out, summary = tmp_path / "audit.gpkg", tmp_path / "audit.json"
    args = ["streets", "audit", str(lights), str(streets), str(out), "--json", str(summary)]
    result = CliRunner().invoke(cli, [*args, "--year", "2024", "--grid-factor", "0.4"])
    assert result.exit_code == 0, result.output
    frame = gpd.read_file(out, layer="segments")
    assert frame["lighting_class"].tolist() == ["P3"]
    assert frame["power_w"].iloc[0] == pytest.approx(40.0 * len(gpd.read_file(lights)))
    data = json.loads(summary.read_text())
    assert data["segments"] == 1 and data["length_m"] == pytest.approx(200.0)
    assert data["energy"]["co2_kg"] == pytest.approx(0.4 * data["energy"]["energy_kwh"], rel=1e-3)
    assert "lighting classes" in result.output and "P3" in result.output
    assert "compliant:" in result.output and "kWh" in result.output


def _inputs(folder: Path) -> list[str]:
    """Two input files (the stand-in stage does not read them)."""
    paths = [folder / "l.gpkg", folder / "s.gpkg"]
    for path in paths:
        path.write_text("")
    return [str(path) for path in paths]


def _summary() -> SimpleNamespace:
    data = {
        "segments": 2,
        "rated": 1,
        "passed": 1,
        "rated_length_m": 1500.0,
        "share_compliant": 1.0,
        "by_class": {"M4": {"segments": 1, "length_m": 1500.0, "share": 1.0}},
    }
    return SimpleNamespace(summary=SimpleNamespace(to_dict=lambda: data))


def test_options_reach_the_stage(fake_stage, tmp_path: Path) -> None:
    stage = fake_stage("audit", _summary())
    out, summary = tmp_path / "a.gpkg", tmp_path / "a.json"
    args = ["streets", "audit", *_inputs(tmp_path), "-o", str(out), "--json", str(summary)]
    more = ["--dimming", "level", "--age", "60", "--year", "2025", "--schedule", "23:00=0,05:00=1"]
    result = CliRunner().invoke(cli, [*args, *more, "--zone", "Europe/Helsinki"])
    assert result.exit_code == 0, result.output
    assert stage.args == (*_inputs(tmp_path), str(out))
    assert stage.kwargs["dimming"] == "level" and stage.kwargs["age"] == 60.0
    assert stage.kwargs["summary_json"] == str(summary)
    assert stage.kwargs["energy"] == EnergyOptions(
        2025, schedule="23:00=0,05:00=1", zone="Europe/Helsinki"
    )
    assert "100.0% of 1.500 km" in result.output


@pytest.mark.parametrize("existing", ["a.gpkg", "a.json"])
def test_refuses_existing_outputs(fake_stage, tmp_path: Path, existing: str) -> None:
    stage = fake_stage("audit", _summary())
    (tmp_path / existing).write_text("keep")
    out, summary = tmp_path / "a.gpkg", tmp_path / "a.json"
    args = ["streets", "audit", *_inputs(tmp_path), str(out), "--json", str(summary)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1
    assert (
        result.output == f"Error: {tmp_path / existing}: exists; give --overwrite to replace it\n"
    )
    assert stage.calls == [] and (tmp_path / existing).read_text() == "keep"
    result = CliRunner().invoke(cli, [*args, "--overwrite"])
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(
    ("flags", "expected"),
    [
        (["--year", "1800"], "--year"),
        (["--year", "2024", "--grid-factor", "-1"], "--grid-factor"),
        (["--schedule", "22:00=0.5"], "need --year"),
        (["--year", "2024", "--schedule", "22=0.5"], "--schedule='22=0.5'"),
        (["--year", "2024", "--schedule", "22:00=0.5", "--zone", "Mars/Base"], "zone"),
        (["--dimming", "nope"], "--dimming='nope'"),
    ],
)
def test_bad_flag_values_are_one_line_and_write_nothing(
    layers: tuple[Path, Path], tmp_path: Path, flags: list[str], expected: str
) -> None:
    lights, streets = layers
    out, summary = tmp_path / "a.gpkg", tmp_path / "a.json"
    args = ["streets", "audit", str(lights), str(streets), str(out), "--json", str(summary)]
    result = CliRunner().invoke(cli, [*args, *flags])
    assert result.exit_code in (1, 2), result.output
    error = [line for line in result.output.splitlines() if "Error" in line]
    assert len(error) == 1 and expected in error[0], result.output
    assert "Traceback" not in result.output
    assert not out.exists() and not summary.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []
