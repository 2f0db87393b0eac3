"""End-to-end test of ``nightlights demo`` on the bundled Helsinki extract."""

from __future__ import annotations

import geopandas as gpd
from click.testing import CliRunner

from cli.main import cli
from nightlights.demo import mapped_street_lamps


def test_demo_runs_every_stage_and_outputs_open_with_crs(tmp_path) -> None:
    out = tmp_path / "demo"
    result = CliRunner().invoke(cli, ["demo", "--out", str(out), "--seed", "7"])
    assert result.exit_code == 0, result.output
    streets = gpd.read_file(out / "streets_lit.gpkg")
    lights = gpd.read_file(out / "lights.gpkg")
    assert streets.crs.to_epsg() == 32635 and lights.crs.to_epsg() == 32635
    assert streets[["arrangement", "system_id", "spacing"]].notna().all().all()
    # Poles stand where the mapped lamps are: most mapped lamps have a predicted pole near.
    lamps = mapped_street_lamps(lights.crs)
    assert len(lamps) == 586
    nearest = lamps.geometry.apply(lambda p: lights.distance(p).min())
    assert nearest.median() < 15.0
