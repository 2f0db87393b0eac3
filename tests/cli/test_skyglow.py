"""``nightlights skyglow``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr
from affine import Affine
from click.testing import CliRunner

import nightlights as nl
from nightlights.io import RasterBand, write_cog
from nightlights_cli.main import cli

OBSERVER = ["--observer", "501500,6698500"]


def _emission(path: Path) -> Path:
    values = np.zeros((30, 30), np.float32)
    values[10:14, 20:24] = 1.0
    write_cog(
        path,
        [RasterBand(values, "reflected", "lm m-2")],
        transform=Affine(100, 0, 500_000, 0, -100, 6_700_000),
        crs="EPSG:32635",
    )
    return path


@pytest.fixture
def emission(tmp_path: Path) -> Path:
    return _emission(tmp_path / "emission.tif")


def test_skyglow_command_prints_zenith_and_writes_outputs(emission: Path, tmp_path: Path) -> None:
    kernel = tmp_path / "kernel.nc"
    spec = nl.KernelSpec(r_min=5, r_max=6000, n_distance=16, n_elevation=8, n_azimuth=32)
    nl.build_kernel(spec, kernel, progress=False)
    out, png = tmp_path / "pano.nc", tmp_path / "pano.png"
    result = CliRunner().invoke(
        cli,
        [
            "skyglow",
            str(emission),
            str(out),
            *OBSERVER,
            "--kernel",
            str(kernel),
            "--observer-height",
            "0",
            "--png",
            str(png),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "mag arcsec-2" in result.output and "Bortle class" in result.output
    pano = xr.open_dataset(out, engine="h5netcdf")
    assert pano["luminance"].shape == (8, 32)
    # The lit block lies east-north-east of the observer: the brightest horizon column there.
    brightest = float(pano["azimuth"][int(pano["luminance"][-1].argmax())])
    assert 30 < brightest < 110
    pano.close()
    assert png.stat().st_size > 5000


def test_skyglow_command_reports_an_instruments_reading(emission: Path, tmp_path: Path) -> None:
    kernel = tmp_path / "kernel.nc"
    spec = nl.KernelSpec(r_min=5, r_max=6000, n_distance=16, n_elevation=8, n_azimuth=32)
    nl.build_kernel(spec, kernel, progress=False)
    out = tmp_path / "pano.nc"
    args = ["skyglow", str(emission), str(out), *OBSERVER, "--kernel", str(kernel)]
    result = CliRunner().invoke(cli, [*args, "--instrument", "sqm", "--spectrum", "LED_3000K"])
    assert result.exit_code == 0, result.output
    assert "sqm pointing at the zenith" in result.output and "LED_3000K light" in result.output
    with xr.open_dataset(out, engine="h5netcdf") as pano:
        assert pano.attrs["instrument"] == "sqm"
        assert pano.attrs["instrument_spectrum"] == "LED_3000K"
        assert pano.attrs["instrument_sky_brightness"] < 22.0
    wrong = CliRunner().invoke(cli, [*args, "--overwrite", "--spectrum", "sodium"])
    assert wrong.exit_code == 2 and "sodium" in wrong.output


def test_skyglow_command_errors_are_one_line(emission: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli,
        [
            "skyglow",
            str(emission),
            str(tmp_path / "p.nc"),
            *OBSERVER,
            "--mode",
            "naive",
            "--kernel",
            str(emission),
        ],
    )
    assert result.exit_code != 0 and "Traceback" not in result.output
    result = CliRunner().invoke(
        cli, ["skyglow", str(emission), str(tmp_path / "p.nc"), "--observer", "nowhere"]
    )
    assert result.exit_code == 2 and "expected X,Y" in result.output


def test_skyglow_command_over_terrain_uses_absolute_altitudes(
    emission: Path, tmp_path: Path
) -> None:
    dem = tmp_path / "dem.tif"
    heights = np.full((30, 30), 120.0, np.float32)
    heights[:, 15:] = 180.0  # the lit block stands on a 60 m higher terrace
    write_cog(
        dem,
        [RasterBand(heights, "height", "m")],
        transform=Affine(100, 0, 500_000, 0, -100, 6_700_000),
        crs="EPSG:32635",
    )
    out = tmp_path / "pano.nc"
    args = ["skyglow", str(emission), "--observer", "501250,6698500", "--dem", str(dem)]
    args += ["--n-azimuth", "32", "--n-elevation", "8", "-o", str(out)]
    result = CliRunner(env={"NIGHTLIGHTS_CACHE": str(tmp_path / "cache")}).invoke(cli, args)
    assert result.exit_code == 0, result.output
    pano = xr.open_dataset(out, engine="h5netcdf")
    assert abs(float(pano.attrs["observer_altitude_m"]) - 121.7) < 1e-6
    assert abs(float(pano.attrs["source_altitude_m"]) - 180.0) < 1e-4
    assert np.atleast_1d(pano.attrs["source_altitude_levels_m"]).tolist() == [180.0]
    assert np.nanmax(pano["luminance"].values) > 0
    pano.close()


@pytest.fixture
def fake_skyglow(fake_stage):
    result = SimpleNamespace(zenith_luminance=1e-3, zenith_magnitude=20.0, bortle=5, seconds=0.01)
    return fake_stage("skyglow", result)


def test_options_reach_the_stage(fake_skyglow, emission: Path, tmp_path: Path) -> None:
    out, polar = tmp_path / "p.nc", tmp_path / "polar.nc"
    args = ["skyglow", str(emission), str(out), *OBSERVER, "--polar-output", str(polar)]
    result = CliRunner().invoke(cli, [*args, "--components", "3", "--n-distance", "32"])
    assert result.exit_code == 0, result.output
    scene, observer, written = fake_skyglow.args
    assert (scene.emission, written) == (str(emission), str(out))
    kwargs = fake_skyglow.kwargs
    assert (observer.x, observer.y, observer.height) == (501500.0, 6698500.0, 1.7)
    assert kwargs["polar_output"] == str(polar) and kwargs["components"] == 3
    assert (scene.n_elevation, scene.n_azimuth, scene.n_distance) == (None, None, 32)
    assert "Bortle class 5" in result.output and result.stderr.count("Deprecation") == 0


def test_deprecated_out_and_polar_out(fake_skyglow, emission: Path, tmp_path: Path) -> None:
    out, polar = tmp_path / "p.nc", tmp_path / "polar.nc"
    args = ["skyglow", str(emission), *OBSERVER, "--out", str(out), "--polar-out", str(polar)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert fake_skyglow.args[0].emission == str(emission) and fake_skyglow.args[2] == str(out)
    assert fake_skyglow.kwargs["polar_output"] == str(polar)
    assert "DeprecationWarning: --out is deprecated; use OUTPUT or -o/--output." in result.stderr
    assert "DeprecationWarning: --polar-out is deprecated; use --polar-output." in result.stderr
    both = ["skyglow", str(emission), *OBSERVER, "--out", str(out), "-o", str(out)]
    result = CliRunner().invoke(cli, both)
    assert result.exit_code == 2 and "give only one of" in result.output


@pytest.mark.parametrize("which", ["output", "--png", "--polar-output"])
def test_any_existing_output_is_refused(
    fake_skyglow, emission: Path, tmp_path: Path, which: str
) -> None:
    out, png, polar = tmp_path / "p.nc", tmp_path / "p.png", tmp_path / "polar.nc"
    existing = {"output": out, "--png": png, "--polar-output": polar}[which]
    existing.write_bytes(b"keep")
    args = ["skyglow", str(emission), str(out), *OBSERVER, "--png", str(png)]
    args += ["--polar-output", str(polar)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1
    assert result.output == f"Error: {existing}: exists; give --overwrite to replace it\n"
    assert fake_skyglow.calls == [] and existing.read_bytes() == b"keep"
    assert CliRunner().invoke(cli, [*args, "--overwrite"]).exit_code == 0


def test_cloud_options_give_the_scene_a_deck(fake_skyglow, emission: Path, tmp_path: Path) -> None:
    args = ["skyglow", str(emission), str(tmp_path / "p.nc"), *OBSERVER]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert fake_skyglow.args[0].clouds is None  # no --cloud-base: a clear sky
    more = ["--cloud-base", "800", "--cloud-optical-depth", "30", "--cloud-cover", "0.5"]
    result = CliRunner().invoke(cli, [*args, "--overwrite", *more])
    assert result.exit_code == 0, result.output
    deck = fake_skyglow.calls[-1][0][0].clouds
    assert (deck.base_height, deck.optical_depth, deck.cover) == (800.0, 30.0, 0.5)


def test_a_bad_cloud_cover_is_named_by_its_flag(emission: Path, tmp_path: Path) -> None:
    args = ["skyglow", str(emission), str(tmp_path / "p.nc"), *OBSERVER, "--cloud-base", "800"]
    result = CliRunner().invoke(cli, [*args, "--cloud-cover", "1.5"])
    assert result.exit_code != 0
    assert "--cloud-cover" in result.output and "fraction from 0 to 1" in result.output
    assert not (tmp_path / "p.nc").exists()
