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


def test_demo_rasters_are_cogs_in_the_lights_crs(tmp_path) -> None:
    import numpy as np
    import rasterio

    out = tmp_path / "demo"
    result = CliRunner().invoke(cli, ["demo", "--out", str(out)])
    assert result.exit_code == 0, result.output
    with rasterio.open(out / "irradiance.tif") as src:
        assert src.crs.to_epsg() == 32635 and src.res == (1.0, 1.0)
        assert src.descriptions[0].startswith("photopic") or "photopic" in src.descriptions[0]
        lux = src.read(1)
        assert np.nanmax(lux) > 5.0  # under a pole, street lighting gives tens of lux
    with rasterio.open(out / "emission.tif") as src:
        assert src.count == 2 and src.res == (50.0, 50.0)
        assert np.nansum(src.read(1)) > 0
    assert (out / "irradiance.png").stat().st_size > 10_000
