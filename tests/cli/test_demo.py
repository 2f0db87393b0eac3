"""End-to-end test of ``nightlights demo`` on the bundled Helsinki extract."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from cli.main import cli
from nightlights.demo import mapped_street_lamps


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "out"
    result = CliRunner().invoke(cli, ["demo", "--out", str(out), "--seed", "7"])
    assert result.exit_code == 0, result.output
    return out


def test_demo_street_layers_open_with_crs(demo_out: Path) -> None:
    streets = gpd.read_file(demo_out / "streets_lit.gpkg")
    lights = gpd.read_file(demo_out / "lights.gpkg")
    assert streets.crs.to_epsg() == 32635 and lights.crs.to_epsg() == 32635
    assert streets[["arrangement", "system_id", "spacing"]].notna().all().all()
    # Poles stand where the mapped lamps are: most mapped lamps have a predicted pole near.
    lamps = mapped_street_lamps(lights.crs)
    assert len(lamps) == 586
    nearest = lamps.geometry.apply(lambda p: lights.distance(p).min())
    assert nearest.median() < 15.0


def test_demo_rasters_are_cogs_in_the_lights_crs(demo_out: Path) -> None:
    with rasterio.open(demo_out / "irradiance.tif") as src:
        assert src.crs.to_epsg() == 32635 and src.res == (1.0, 1.0)
        assert "photopic" in src.descriptions[0]
        lux = src.read(1)
        assert np.nanmax(lux) > 5.0  # under a pole, street lighting gives tens of lux
    with rasterio.open(demo_out / "emission.tif") as src:
        assert src.count == 2 and src.res == (50.0, 50.0)
        assert np.nansum(src.read(1)) > 0
    assert (demo_out / "irradiance.png").stat().st_size > 10_000


def test_demo_skyglow_panoramas(demo_out: Path) -> None:
    import xarray as xr

    centre = xr.open_dataset(demo_out / "skyglow_esplanadi.nc", engine="h5netcdf")
    outside = xr.open_dataset(demo_out / "skyglow_suomenlinna.nc", engine="h5netcdf")
    # In the middle of the lit streets the artificial zenith is much brighter than 3 km away.
    assert float(centre["luminance"][0].mean()) > 10 * float(outside["luminance"][0].mean())
    # From Suomenlinna (south-east of the centre) the glow stands to the north-west.
    horizon = outside["luminance"][-1]
    assert 280 < float(outside["azimuth"][int(horizon.argmax())]) < 350
    centre.close()
    outside.close()
