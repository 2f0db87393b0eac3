"""CLI: nightlights skyglow."""

from __future__ import annotations

import numpy as np
import xarray as xr
from affine import Affine
from click.testing import CliRunner

from cli.main import cli
from nightlights.io import RasterBand, write_cog
from nightlights.sky.precompute import build_kernel, write_kernel


def _emission(path) -> None:
    values = np.zeros((30, 30), np.float32)
    values[10:14, 20:24] = 1.0
    write_cog(
        path,
        [RasterBand(values, "reflected", "lm m-2")],
        transform=Affine(100, 0, 500_000, 0, -100, 6_700_000),
        crs="EPSG:32635",
    )


def test_skyglow_command_prints_zenith_and_writes_outputs(tmp_path) -> None:
    kernel = tmp_path / "kernel.nc"
    write_kernel(build_kernel(r_min=5, r_max=6000, n_r=16, n_el=8, n_az=32, progress=False), kernel)
    src = tmp_path / "emission.tif"
    _emission(src)
    out, png = tmp_path / "pano.nc", tmp_path / "pano.png"
    result = CliRunner().invoke(
        cli,
        [
            "skyglow",
            str(src),
            "--observer",
            "501500,6698500",
            "--kernel",
            str(kernel),
            "--observer-height",
            "0",
            "--out",
            str(out),
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


def test_skyglow_command_errors_are_one_line(tmp_path) -> None:
    src = tmp_path / "emission.tif"
    _emission(src)
    result = CliRunner().invoke(
        cli,
        [
            "skyglow",
            str(src),
            "--observer",
            "501500,6698500",
            "--mode",
            "naive",
            "--kernel",
            str(src),
            "--out",
            str(tmp_path / "p.nc"),
        ],
    )
    assert result.exit_code != 0 and "Traceback" not in result.output
    result = CliRunner().invoke(
        cli,
        [
            "skyglow",
            str(src),
            "--observer",
            "nowhere",
            "--out",
            str(tmp_path / "p.nc"),
        ],
    )
    assert result.exit_code == 2 and "expected X,Y" in result.output


def test_skyglow_command_over_terrain_uses_absolute_altitudes(tmp_path) -> None:
    src, dem = tmp_path / "emission.tif", tmp_path / "dem.tif"
    _emission(src)
    heights = np.full((30, 30), 120.0, np.float32)
    heights[:, 15:] = 180.0  # the lit block stands on a 60 m higher terrace
    write_cog(
        dem,
        [RasterBand(heights, "height", "m")],
        transform=Affine(100, 0, 500_000, 0, -100, 6_700_000),
        crs="EPSG:32635",
    )
    out = tmp_path / "pano.nc"
    args = ["skyglow", str(src), "--observer", "501250,6698500", "--dem", str(dem)]
    args += ["--n-azimuth", "32", "--n-elevation", "8", "--out", str(out)]
    result = CliRunner(env={"NIGHTLIGHTS_CACHE": str(tmp_path / "cache")}).invoke(cli, args)
    assert result.exit_code == 0, result.output
    pano = xr.open_dataset(out, engine="h5netcdf")
    assert abs(float(pano.attrs["observer_altitude_m"]) - 121.7) < 1e-6
    assert abs(float(pano.attrs["source_altitude_m"]) - 180.0) < 1e-4
    assert np.atleast_1d(pano.attrs["source_altitude_levels_m"]).tolist() == [180.0]
    assert np.nanmax(pano["luminance"].values) > 0
    pano.close()
