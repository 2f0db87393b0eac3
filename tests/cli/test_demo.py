"""``nightlights demo``: end to end on the bundled Helsinki extract, and its paths."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from nightlights.demo import mapped_street_lamps
from nightlights_cli.main import cli


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "out"
    result = CliRunner().invoke(cli, ["demo", str(out), "--seed", "7"])
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


def test_demo_inverse_maps_and_dimming(demo_out: Path) -> None:
    import json

    import xarray as xr

    with rasterio.open(demo_out / "inverse_q_esplanadi.tif") as src:
        q = src.read(1)
        assert src.descriptions == ("zenith_luminance",) and src.units == ("cd m-2",)
    with rasterio.open(demo_out / "emission.tif") as src:
        lit = np.any(src.read() > 0, axis=0)
    assert np.array_equal(np.isfinite(q), lit)
    centre = xr.open_dataset(demo_out / "skyglow_esplanadi.nc", engine="h5netcdf")
    # the cells' parts add up to the panorama's zenith (float32 storage of the parts)
    assert np.nansum(q.astype(float)) == pytest.approx(float(centre["luminance"][0].mean()), 1e-5)
    centre.close()
    with rasterio.open(demo_out / "inverse_s_suomenlinna.tif") as src:
        assert src.tags()["region"].startswith("horizon:")
        assert np.nanmax(src.read(1)) > 0
    summary = json.loads((demo_out / "dimming_suomenlinna.json").read_text())
    region = summary["observers"][0]["regions"][0]
    assert region["after_mag_arcsec2"] > region["before_mag_arcsec2"]
    assert 0 < summary["flux_removed_percent"] < 100
    assert (demo_out / "dimming_suomenlinna.png").stat().st_size > 10_000


def test_demo_observers_summary(demo_out: Path) -> None:
    summary = gpd.read_file(demo_out / "observers.gpkg", layer="observers")
    assert sorted(summary["name"]) == ["esplanadi", "suomenlinna"]
    zenith = dict(zip(summary["name"], summary["zenith_artificial"], strict=True))
    assert zenith["esplanadi"] > 10 * zenith["suomenlinna"]


def test_demo_is_a_project_run_again_in_its_folder_skips_every_stage(demo_out: Path) -> None:
    again = CliRunner().invoke(cli, ["demo", str(demo_out), "--seed", "7", "--overwrite"])
    assert again.exit_code == 0, again.output
    assert "ran 0 stages, 11 up to date" in again.stderr
    assert "zenith sky at esplanadi:" in again.stderr
    records = sorted(p.name for p in (demo_out / ".nightlights").glob("*.json"))
    assert "skyglow@suomenlinna.json" in records and len(records) == 11


@pytest.fixture
def fake_demo(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, int]]:
    calls: list[tuple[str, int]] = []

    def run_demo(out_dir: str, *, seed: int) -> SimpleNamespace:
        calls.append((out_dir, seed))
        return SimpleNamespace(
            outputs={"lights": Path(out_dir) / "lights.gpkg"}, zenith={}, findings=[]
        )

    monkeypatch.setattr("nightlights.demo.run_demo", run_demo)
    return calls


def test_demo_output_spellings(
    fake_demo: list[tuple[str, int]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    assert runner.invoke(cli, ["demo"]).exit_code == 0
    assert runner.invoke(cli, ["demo", "a"]).exit_code == 0
    assert runner.invoke(cli, ["demo", "-o", "b", "--seed", "3"]).exit_code == 0
    old = runner.invoke(cli, ["demo", "--out", "c"])
    assert old.exit_code == 0, old.output
    assert "DeprecationWarning: --out is deprecated; use OUTPUT or -o/--output." in old.stderr
    assert fake_demo == [("nightlights-demo", 2011), ("a", 2011), ("b", 3), ("c", 2011)]


def test_demo_refuses_a_folder_that_is_not_empty(
    fake_demo: list[tuple[str, int]], tmp_path: Path
) -> None:
    (tmp_path / "empty").mkdir()
    assert CliRunner().invoke(cli, ["demo", str(tmp_path / "empty")]).exit_code == 0
    full = tmp_path / "full"
    full.mkdir()
    (full / "notes.txt").write_text("keep")
    result = CliRunner().invoke(cli, ["demo", str(full)])
    assert result.exit_code == 1
    assert result.output == f"Error: {full}: exists; give --overwrite to replace it\n"
    assert CliRunner().invoke(cli, ["demo", str(full), "--overwrite"]).exit_code == 0
    assert fake_demo == [(str(tmp_path / "empty"), 2011), (str(full), 2011)]
    assert (full / "notes.txt").read_text() == "keep"
