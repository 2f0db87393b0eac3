"""``nightlights emission`` (``ground``, the default) and ``nightlights emission viirs``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import rasterio
from affine import Affine
from click.testing import CliRunner
from pyproj import CRS

from nightlights_cli.main import cli


@pytest.fixture
def irradiance(lights: Path, tmp_path: Path) -> Path:
    out = tmp_path / "e.tif"
    args = ["irradiance", str(lights), str(out), "--resolution", "2", "--tile-size", "64"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    return out


def test_emission_of_irradiance_and_lights(irradiance: Path, lights: Path, tmp_path: Path) -> None:
    emission_out = tmp_path / "m.tif"
    result = CliRunner().invoke(
        cli,
        [
            "emission",
            str(irradiance),
            str(lights),
            str(emission_out),
            "--resolution",
            "20",
            "--albedo",
            "0.1",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "reflected" in result.output and "uplight" in result.output
    with rasterio.open(irradiance) as dataset:
        photopic = dataset.read(1).astype(float)
    with rasterio.open(emission_out) as dataset:
        assert dataset.descriptions == ("reflected", "uplight")
        reflected, uplight = dataset.read().astype(float)
    assert reflected.sum() * 400 == pytest.approx(0.1 * photopic.sum() * 4, rel=1e-4)
    assert uplight.sum() > 0  # street_led_medium has ~50 lm of uplight
    # The same with the subcommand spelled out and -o/--output: the same file.
    again = tmp_path / "again.tif"
    args = ["emission", "ground", str(irradiance), str(lights), "-o", str(again)]
    result = CliRunner().invoke(cli, [*args, "--resolution", "20", "--albedo", "0.1"])
    assert result.exit_code == 0, result.output
    with rasterio.open(again) as dataset:
        np.testing.assert_array_equal(dataset.read().astype(float), [reflected, uplight])


def _fake_result(**total_flux: float) -> SimpleNamespace:
    return SimpleNamespace(total_flux=total_flux, crs=CRS.from_epsg(3067))


def test_ground_options_reach_the_stage(fake_stage, irradiance: Path, tmp_path: Path) -> None:
    stage = fake_stage("emission", _fake_result(reflected=1.0, uplight=2.0))
    out = tmp_path / "m.tif"
    args = ["emission", "--resolution", "20", str(irradiance), str(out), "--albedo", "0.1"]
    result = CliRunner().invoke(cli, [*args, "--crs", "EPSG:3067"])
    assert result.exit_code == 0, result.output
    assert stage.args == (str(irradiance), str(out))
    assert stage.kwargs["lights"] is None  # no LIGHTS: no uplight
    assert stage.kwargs["crs"] == "EPSG:3067" and stage.kwargs["albedo"] == 0.1
    assert stage.kwargs["resolution"] == 20.0


def test_ground_refuses_an_existing_output(fake_stage, irradiance: Path, tmp_path: Path) -> None:
    stage = fake_stage("emission", _fake_result(reflected=1.0, uplight=2.0))
    out = tmp_path / "m.tif"
    out.write_bytes(b"keep")
    args = ["emission", str(irradiance), str(out), "--resolution", "20", "--albedo", "0.1"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1 and "give --overwrite" in result.output
    assert stage.calls == [] and out.read_bytes() == b"keep"
    assert CliRunner().invoke(cli, [*args, "--overwrite"]).exit_code == 0


def test_ground_usage_errors(irradiance: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["emission", "a.tif", "--resolution", "10", "--albedo", "0.1"])
    assert result.exit_code == 2 and "expected IRRADIANCE [LIGHTS] OUTPUT" in result.output
    result = runner.invoke(cli, ["emission", "a.tif", "b.tif", "--resolution", "10"])
    assert result.exit_code == 2 and "--albedo" in result.output
    out = tmp_path / "m.tif"
    args = ["emission", str(irradiance), str(out), "--resolution", "20", "--albedo", "grey"]
    result = runner.invoke(cli, args)
    assert result.exit_code == 2 and "neither a number nor an existing raster" in result.output
    assert not out.exists()


@pytest.fixture
def viirs(tmp_path: Path) -> Path:
    source = tmp_path / "dnb.tif"
    with rasterio.open(
        source,
        "w",
        driver="GTiff",
        height=4,
        width=5,
        count=1,
        dtype="float32",
        crs="EPSG:32635",
        transform=Affine(500, 0, 385_000, 0, -500, 6_673_000),
    ) as dataset:
        dataset.write(np.full((1, 4, 5), 25.0, np.float32))
    return source


def _check_viirs_output(out: Path) -> None:
    with rasterio.open(out) as dataset:
        assert dataset.descriptions == ("upward",)
        assert dataset.tags()["spectrum"] == "HPS"
        assert np.allclose(dataset.read(1), dataset.read(1)[0, 0]) and dataset.read(1)[0, 0] > 0


def test_emission_viirs(viirs: Path, tmp_path: Path) -> None:
    out = tmp_path / "up.tif"
    result = CliRunner().invoke(
        cli, ["emission", "viirs", str(viirs), str(out), "--spectrum", "HPS"]
    )
    assert result.exit_code == 0, result.output
    assert "lm upward" in result.output and "DeprecationWarning" not in result.output
    _check_viirs_output(out)


def test_emission_from_viirs_still_works_with_a_warning(viirs: Path, tmp_path: Path) -> None:
    out = tmp_path / "up.tif"
    result = CliRunner().invoke(
        cli, ["emission", "--from-viirs", str(viirs), str(out), "--spectrum", "HPS"]
    )
    assert result.exit_code == 0, result.output
    warning = result.stderr.splitlines()[0]
    assert warning.startswith("DeprecationWarning: ") and warning.endswith(
        "emission --from-viirs INPUT OUTPUT is deprecated; use cli emission viirs INPUT OUTPUT."
    )
    _check_viirs_output(out)


def test_viirs_options_reach_the_stage(fake_stage, viirs: Path, tmp_path: Path) -> None:
    stage = fake_stage("emission_from_viirs", _fake_result(upward=5.0))
    out = tmp_path / "up.tif"
    args = ["emission", "viirs", "-o", str(out), str(viirs), "--target-crs", "EPSG:3067"]
    result = CliRunner().invoke(cli, [*args, "--resolution", "250"])
    assert result.exit_code == 0, result.output
    assert stage.args == (str(viirs), str(out))
    assert stage.kwargs == {
        "spectrum": "LED_4000K",
        "resolution": 250.0,
        "target_crs": "EPSG:3067",
    }
    out.write_bytes(b"keep")
    refused = CliRunner().invoke(cli, ["emission", "viirs", str(viirs), str(out)])
    assert refused.exit_code == 1 and "give --overwrite" in refused.output
    assert len(stage.calls) == 1


def test_a_wide_geographic_mosaic_keeps_its_grid(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    source = tmp_path / "mosaic.tif"
    with rasterio.open(
        source,
        "w",
        driver="GTiff",
        height=20,
        width=140,
        count=1,
        dtype="float32",
        crs="EPSG:4326",
        transform=Affine(0.5, 0, 10.0, 0, -0.5, 65.0),
    ) as dataset:
        dataset.write(np.full((1, 20, 140), 4.0, np.float32))
    out = tmp_path / "up.tif"
    with caplog.at_level("WARNING"):
        result = CliRunner().invoke(cli, ["emission", "viirs", str(source), str(out)])
    assert result.exit_code == 0, result.output
    assert "geographic grid, WGS 84" in " ".join(result.output.split())  # wrapped at any width
    assert not [r for r in caplog.records if "DataQualityWarning" in r.getMessage()]
    with rasterio.open(out) as dataset:
        assert dataset.crs.to_epsg() == 4326 and dataset.shape == (20, 140)
        assert dataset.tags()["grid"] == "geographic" and dataset.tags()["flux"] == "density"
    # --target-crs still projects it, with the warning that one zone does not fit it
    projected = tmp_path / "projected.tif"
    args = ["emission", "viirs", str(source), str(projected), "--target-crs", "EPSG:3035"]
    with caplog.at_level("WARNING"):
        result = CliRunner().invoke(cli, [*args, "--resolution", "50000"])
    assert result.exit_code == 0, result.output
    assert "projected grid" in result.output
    warned = [r.getMessage() for r in caplog.records if "DataQualityWarning" in r.getMessage()]
    assert len(warned) == 1 and "spans 70 deg of longitude, more than one UTM zone" in warned[0]
    assert "--target-crs" in warned[0]  # the flag, not the parameter
    # a resolution in metres needs a projected output
    refused = CliRunner().invoke(
        cli, ["emission", "viirs", str(source), str(tmp_path / "r.tif"), "--resolution", "1000"]
    )
    assert refused.exit_code == 1 and "keeps its geographic grid" in refused.output
