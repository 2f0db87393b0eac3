"""``nightlights irradiance``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import rasterio
from click.testing import CliRunner
from shapely.geometry import box

from nightlights_cli.main import cli

CRS = "EPSG:3067"


def test_irradiance_bands_per_sensor(lights: Path, tmp_path: Path) -> None:
    out = tmp_path / "e.tif"
    result = CliRunner().invoke(
        cli,
        [
            "irradiance",
            str(lights),
            str(out),
            "--resolution",
            "2",
            "--sensor",
            "photopic",
            "--sensor",
            "scotopic",
            "--tile-size",
            "64",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "3 lights" in result.output
    with rasterio.open(out) as dataset:
        assert dataset.descriptions == ("photopic", "scotopic")
        assert dataset.units == ("lx", "W m-2")
        assert dataset.crs.to_epsg() == 3067
        photopic, scotopic = dataset.read().astype(float)
    assert photopic.max() > 10  # tens of lux under a street light
    # Sensor band = k x lux per light; k(scotopic) is within (0, 1/683 * 2.5) for these SPDs.
    ratio = scotopic[photopic > 1] / photopic[photopic > 1]
    assert np.all((ratio > 0) & (ratio < 2.5 / 683))


def test_numpy_backend_is_the_reference(lights: Path, tmp_path: Path) -> None:
    bands = {}
    for backend in ("numba", "numpy"):
        out = tmp_path / f"{backend}.tif"
        args = ["irradiance", str(lights), str(out), "--resolution", "2", "--backend", backend]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output
        with rasterio.open(out) as dataset:
            bands[backend] = dataset.read(1).astype(float)
            assert dataset.tags()["kernel"] == backend
    lit = bands["numpy"] > 0
    assert lit.any() and np.array_equal(bands["numba"] > 0, lit)
    np.testing.assert_allclose(bands["numba"][lit], bands["numpy"][lit], rtol=1e-6)
    args = ["irradiance", str(lights), str(tmp_path / "x.tif"), "--resolution", "2"]
    result = CliRunner().invoke(cli, [*args, "--backend", "cuda"])
    assert result.exit_code == 2 and "'cuda' is not one of 'numba', 'numpy'" in result.output


def test_irradiance_with_area_sources(lights: Path, tmp_path: Path) -> None:
    areas = tmp_path / "areas.gpkg"
    gpd.GeoDataFrame(
        {"exitance": [20.0]}, geometry=[box(385_100, 6_672_000, 385_140, 6_672_030)], crs=CRS
    ).to_file(areas, driver="GPKG")
    out = tmp_path / "e.tif"
    result = CliRunner().invoke(
        cli,
        [
            "irradiance",
            str(lights),
            "--output",
            str(out),
            "--resolution",
            "2",
            "--area-sources",
            str(areas),
            "--bounds",
            "384900,6671900,385300,6672200",
        ],
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as dataset:
        data = dataset.read(1)
        row, col = dataset.index(385_120, 6_672_015)
    assert data[row, col] > 5  # under the lit area


def test_errors_are_one_line(lights: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    result = runner.invoke(
        cli, ["irradiance", str(lights), str(tmp_path / "e.tif"), "--resolution", "0"]
    )
    assert result.exit_code != 0
    assert "InputError: --resolution=0.0 m" in result.output
    assert "Traceback" not in result.output
    result = runner.invoke(
        cli,
        [
            "irradiance",
            str(lights),
            str(tmp_path / "e.tif"),
            "--resolution",
            "1",
            "--threshold",
            "fancy:2",
        ],
    )
    assert result.exit_code != 0 and "threshold" in result.output
    assert not (tmp_path / "e.tif").exists()


def _fake_result() -> SimpleNamespace:
    return SimpleNamespace(grid=SimpleNamespace(rows=4, cols=5), n_lights=3, n_pairs=60)


def test_options_reach_the_stage(fake_stage, lights: Path, tmp_path: Path) -> None:
    stage = fake_stage("irradiance", _fake_result())
    out = tmp_path / "e.tif"
    args = ["irradiance", str(lights), str(out), "--resolution", "2", "--crs", CRS]
    args += ["--bounds", "0,1,2,3", "--area-height", "5", "--threshold", "none"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert stage.args == (str(lights), str(out))
    kwargs = stage.kwargs
    assert kwargs["crs"] == CRS and kwargs["resolution"] == 2.0
    assert kwargs["bounds"] == (0.0, 1.0, 2.0, 3.0)
    assert kwargs["area_options"].height == 5.0
    assert kwargs["sensors"] == ("photopic",)
    assert kwargs["backend"] == "numba"
    assert "3 lights, 4 x 5 pixels" in result.output


def test_existing_output_is_refused(fake_stage, lights: Path, tmp_path: Path) -> None:
    stage = fake_stage("irradiance", _fake_result())
    out = tmp_path / "e.tif"
    out.write_bytes(b"keep")
    args = ["irradiance", str(lights), str(out), "--resolution", "2"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1
    assert result.output == f"Error: {out}: exists; give --overwrite to replace it\n"
    assert stage.calls == [] and out.read_bytes() == b"keep"
    assert CliRunner().invoke(cli, [*args, "--overwrite"]).exit_code == 0
    assert len(stage.calls) == 1


def test_wrong_number_of_paths_is_a_usage_error(lights: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["irradiance", str(lights), "--resolution", "2"])
    assert result.exit_code == 2 and "expected LIGHTS OUTPUT" in result.output
    result = CliRunner().invoke(
        cli, ["irradiance", str(lights), str(lights), "-o", "x.tif", "--resolution", "2"]
    )
    assert result.exit_code == 2 and "expected LIGHTS OUTPUT" in result.output
