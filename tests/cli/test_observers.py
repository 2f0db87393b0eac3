"""``nightlights sky observers``."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner
from shapely.geometry import Point

from nightlights.io import RasterBand, write_cog
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli

CRS = "EPSG:32635"
TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("observers")
    values = np.zeros((20, 20), np.float32)
    values[5:9, 10:14] = 2.0
    emission = folder / "emission.tif"
    write_cog(emission, [RasterBand(values, "flux", "lm m-2")], transform=TRANSFORM, crs=CRS)
    kernel = folder / "kernel.nc"
    spec = KernelSpec(r_max=4000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    build_kernel(spec, kernel, progress=False)
    layer = gpd.GeoDataFrame(
        {"name": ["park", "harbour", "hill"]},
        geometry=[Point(501_000, 6_699_000), Point(500_500, 6_698_500), Point(501_900, 6_698_100)],
        crs=CRS,
    ).to_crs("EPSG:4326")
    observers = folder / "places.gpkg"
    layer.to_file(observers, layer="places")
    return {"emission": emission, "kernel": kernel, "observers": observers, "folder": folder}


def invoke(*args: str) -> object:
    return CliRunner().invoke(cli, ["sky", "observers", *args])


def test_summary_and_panoramas(scene: dict[str, Path], tmp_path: Path) -> None:
    out, skies = tmp_path / "summary.gpkg", tmp_path / "skies"
    common = [str(scene["emission"]), str(scene["observers"]), "--kernel", str(scene["kernel"])]
    result = invoke(*common, str(out), "--panoramas", str(skies), "--top-cells", "2",
                    "--observer-height", "0", "--scheduler", "synchronous")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "3 observers: zenith" in result.output and "Bortle class" in result.output
    summary = gpd.read_file(out, layer="observers")
    assert summary["name"].tolist() == ["park", "harbour", "hill"]
    assert summary.crs.equals(CRS)
    assert {"top2_share", "zenith_mag", "bortle", "panorama"} <= set(summary.columns)
    assert sorted(p.name for p in skies.iterdir()) == ["harbour.nc", "hill.nc", "park.nc"]
    again = invoke(*common, "-o", str(out))
    assert again.exit_code == 1 and "exists" in again.output
    replaced = invoke(*common, "-o", str(out), "--overwrite", "--top-cells", "0")
    assert replaced.exit_code == 0, replaced.output
    assert "top1_x" not in gpd.read_file(out, layer="observers")


@pytest.mark.parametrize(
    ("extra", "code", "message"),
    [
        (["--scheduler", "fast"], 2, "'fast'; expected one of threads"),
        (["--scheduler", "tcp://"], 2, "'tcp://': not a scheduler address (no host name"),
        (["--scheduler", "tcp://127.0.0.1:1"], 1, "connection refused by 127.0.0.1:1"),
        (
            ["--top-cells", "10000"],
            1,
            "--top-cells=10000: the summary GeoPackage holds at most 662",
        ),
        (["--top-cells", "-1"], 2, "-1 is not in the range"),
        (["--observers-layer", "nowhere"], 1, "cannot read vector layer 'nowhere'"),
        (["--observer-height", "-1"], 1, "observer height -1.0 m"),
    ],
)
def test_bad_options(scene: dict[str, Path], tmp_path: Path, extra, code, message) -> None:
    result = invoke(str(scene["emission"]), str(scene["observers"]), str(tmp_path / "s.gpkg"),
                    "--kernel", str(scene["kernel"]), *extra)  # fmt: skip
    assert result.exit_code == code, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_summary_must_be_a_geopackage(scene: dict[str, Path], tmp_path: Path) -> None:
    result = invoke(str(scene["emission"]), str(scene["observers"]), str(tmp_path / "s.shp"))
    assert result.exit_code == 2 and "expected a .gpkg" in result.output


def test_an_observer_out_of_reach_is_named(scene: dict[str, Path], tmp_path: Path) -> None:
    far = gpd.GeoDataFrame({"name": ["moon"]}, geometry=[Point(600_000, 6_600_000)], crs=CRS)
    path = tmp_path / "far.gpkg"
    far.to_file(path)
    result = invoke(str(scene["emission"]), str(path), str(tmp_path / "s.gpkg"),
                    "--kernel", str(scene["kernel"]))  # fmt: skip
    assert result.exit_code == 1
    assert "InputError: observer 'moon': observer (600000.0, 6600000.0) lies" in result.output
    assert not (tmp_path / "s.gpkg").exists()


def test_summary_with_an_instruments_reading(scene: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "sqm.gpkg"
    common = [str(scene["emission"]), str(scene["observers"]), "--kernel", str(scene["kernel"])]
    result = invoke(*common, str(out), "--instrument", "sqm", "--scheduler", "synchronous")
    assert result.exit_code == 0, result.output
    assert "sqm pointing at the zenith" in result.output
    summary = gpd.read_file(out, layer="observers")
    assert {"instrument_luminance", "instrument_sky_brightness"} <= set(summary.columns)
    assert np.all(summary["instrument_sky_brightness"] < 22.0)
