"""``nightlights sky render``: argument parsing, the panorama's place, PNG and NetCDF outputs."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from pyproj import Transformer

import nightlights.nightsky
from nightlights_cli import sky as sky_cli
from nightlights_cli.main import NightlightsGroup

TIME = "2026-01-20T22:00:00Z"
#: An observer in Helsinki (ETRS-TM35FIN), for a panorama's attributes.
OBSERVER = (386_000.0, 6_672_000.0)


def run(*args: str) -> object:
    group = NightlightsGroup(commands=sky_cli.commands)
    return CliRunner().invoke(group, ["sky", "render", *args], catch_exceptions=False)


@pytest.fixture
def panorama(tmp_path: Path) -> Path:
    azimuth = (np.arange(16) + 0.5) * 22.5
    elevation = np.linspace(85.0, 5.0, 9)
    pano = xr.Dataset(
        {"luminance": (("elevation", "azimuth"), np.full((9, 16), 1e-3), {"units": "cd m-2"})},
        coords={"elevation": elevation, "azimuth": azimuth},
        attrs={"observer_x": OBSERVER[0], "observer_y": OBSERVER[1], "crs": "EPSG:3067"},
    )
    path = tmp_path / "pano.nc"
    pano.to_netcdf(path, engine="h5netcdf")
    return path


def test_options_reach_the_stage(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[dict] = []

    def fake(observer: object, output: str, **kwargs: object) -> SimpleNamespace:
        calls.append({"observer": observer, "output": output, **kwargs})
        return SimpleNamespace(legend="legend")

    monkeypatch.setattr(nightlights.nightsky, "sky_render", fake, raising=False)
    out = tmp_path / "sky.png"
    result = run(
        str(out),
        "--time",
        TIME,
        "--lonlat",
        "24.95,60.17",
        "--projection",
        "perspective",
        "--view-azimuth",
        "200",
        "--field-of-view",
        "60",
        "--tone",
        "photo",
        "--white",
        "4000",
        "--natural-only",
        "--all-stars",
    )
    assert result.exit_code == 0, result.output
    (call,) = calls
    assert call["output"] == str(out) and call["observer"].lonlat() == (24.95, 60.17)
    assert call["projection"] == "perspective" and call["field_of_view"] == 60.0
    assert call["view_azimuth"] == 200.0 and call["natural_only"] is True
    assert call["limiting_magnitude"] is False and call["time"] == TIME
    tone = call["tone_mapping"]
    assert tone.mode == "photo" and tone.white_temperature == 4000.0


def test_usage_errors(tmp_path: Path) -> None:
    out = str(tmp_path / "sky.png")
    bad = run(out, "--time", TIME, "--lonlat", "24.95")
    assert bad.exit_code == 2 and "LON,LAT" in bad.output
    both = run(out, "--time", TIME, "--lonlat", "0,0", "--natural-only", "--artificial-only")
    assert both.exit_code == 2 and "exclude" in both.output


def test_png_from_a_panorama_place_and_overwrite(panorama: Path, tmp_path: Path) -> None:
    out = tmp_path / "sky.png"
    args = [str(out), "--time", TIME, "--panorama", str(panorama), "--width", "96"]
    result = run(*args, "--projection", "fisheye")
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lon, lat = Transformer.from_crs(3067, 4326, always_xy=True).transform(*OBSERVER)
    assert f"{lon:.3f} E {lat:.3f} N" in result.output
    again = run(*args)
    assert again.exit_code == 1 and "--overwrite" in again.output


def test_netcdf_is_linear_on_elevation_and_azimuth(panorama: Path, tmp_path: Path) -> None:
    out = tmp_path / "sky.nc"
    result = run(
        str(out),
        "--time",
        TIME,
        "--panorama",
        str(panorama),
        "--artificial-only",
        "--width",
        "64",
        "--height",
        "16",
    )
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds["luminance"].dims == ("elevation", "azimuth")
        assert ds["luminance"].attrs["units"] == "cd m-2"
        assert ds["xyz"].dims == ("elevation", "azimuth", "band")
        np.testing.assert_allclose(ds["luminance"].values, 1e-3, rtol=1e-9)
        np.testing.assert_allclose(ds["elevation"].values[[0, -1]], [90 - 90 / 32, 90 / 32])
        assert ds.attrs["zenith_artificial_cd_m2"] == pytest.approx(1e-3)


def test_netcdf_needs_the_equirectangular_grid(tmp_path: Path) -> None:
    result = run(
        str(tmp_path / "sky.nc"), "--time", TIME, "--lonlat", "0,35", "--projection", "fisheye"
    )
    assert result.exit_code == 1 and "equirectangular" in result.output


def test_a_panorama_of_another_place_is_refused(panorama: Path, tmp_path: Path) -> None:
    # the panorama is Helsinki's; its skyglow drawn over the stars of 0 E 35 N is no picture
    out = tmp_path / "sky.png"
    result = run(str(out), "--time", TIME, "--lonlat", "0,35", "--panorama", str(panorama))
    assert result.exit_code == 1
    assert "from the panorama's observer" in result.output and not out.exists()
