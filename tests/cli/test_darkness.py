"""``nightlights darkness``."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import click
import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner

import nightlights
from nightlights.io import Raster, RasterBand, write_cog
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.darkness import darkness as darkness_command
from nightlights_cli.main import NightlightsGroup, cli

TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)


def command_group() -> click.Group:
    """The ``nightlights`` group, with ``darkness`` added if it is not registered yet."""
    if "darkness" in cli.commands:
        return cli
    return NightlightsGroup(commands=[darkness_command])


@pytest.fixture
def stage(monkeypatch: pytest.MonkeyPatch) -> None:
    """``nl.darkness``: the stage itself (the top-level name may not be exported yet)."""
    from nightlights.inverse import darkness

    if not hasattr(nightlights, "darkness"):
        monkeypatch.setattr(nightlights, "darkness", darkness, raising=False)


def write_emission(path: Path, crs: str = "EPSG:32635") -> Path:
    values = np.zeros((20, 20), np.float32)
    values[5:8, 12:15] = 1.0
    write_cog(path, [RasterBand(values, "reflected", "lm m-2")], transform=TRANSFORM, crs=crs)
    return path


@pytest.fixture
def emission(tmp_path: Path) -> Path:
    return write_emission(tmp_path / "emission.tif")


@pytest.fixture
def kernel(tmp_path: Path) -> Path:
    path = tmp_path / "kernel.nc"
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    build_kernel(spec, path, progress=False)
    return path


def test_darkness_command_writes_the_zenith_map(
    stage: None, emission: Path, kernel: Path, tmp_path: Path
) -> None:
    out = tmp_path / "zenith.tif"
    args = ["darkness", str(emission), str(out), "--kernel", str(kernel)]
    result = CliRunner().invoke(command_group(), [*args, "--observer-height", "0"])
    assert result.exit_code == 0, result.output
    assert "mag arcsec-2" in result.output and "20 x 20 cells" in result.output
    written = Raster.read(out)
    assert written.descriptions == ("zenith_luminance", "zenith_sky_brightness")
    assert float(written.tags["observer_height_m"]) == 0.0
    zenith = written.data[0]
    assert np.unravel_index(zenith.argmax(), zenith.shape)[0] in (5, 6, 7)
    # an existing output is refused without --overwrite, replaced with it
    again = CliRunner().invoke(command_group(), args)
    assert again.exit_code == 1 and "--overwrite" in again.output
    replaced = CliRunner().invoke(command_group(), [*args, "--overwrite", "--observer-height", "5"])
    assert replaced.exit_code == 0, replaced.output
    assert float(Raster.read(out).tags["observer_height_m"]) == 5.0


def test_darkness_command_in_instrument_units(
    stage: None, emission: Path, kernel: Path, tmp_path: Path
) -> None:
    from nightlights.brightness import luminance_to_magnitude

    out = tmp_path / "sqm.tif"
    args = ["darkness", str(emission), str(out), "--kernel", str(kernel)]
    result = CliRunner().invoke(
        command_group(), [*args, "--instrument", "sqm", "--spectrum", "HPS"]
    )
    assert result.exit_code == 0, result.output
    assert "sqm over 20 x 20 cells" in result.output and "natural sky" in result.output
    written = Raster.read(out)
    assert written.descriptions == ("instrument_luminance", "instrument_sky_brightness")
    assert (written.tags["instrument"], written.tags["instrument_spectrum"]) == ("sqm", "HPS")
    natural = float(written.tags["instrument_natural_cd_m2"])
    np.testing.assert_allclose(
        written.data[1], luminance_to_magnitude(written.data[0] + natural), atol=1e-5
    )  # float32 bands
    unknown = CliRunner().invoke(command_group(), [*args, "--overwrite", "--instrument", "sqm-x"])
    assert unknown.exit_code == 2 and "sqm-x" in unknown.output and "tess-w" in unknown.output


def test_darkness_command_passes_its_options(fake_stage, emission: Path, tmp_path: Path) -> None:
    dem = write_emission(tmp_path / "dem.tif")
    raster = Raster(np.ones((2, 3, 4)), TRANSFORM, "EPSG:32635")
    recorder = fake_stage("darkness", SimpleNamespace(raster=raster, seconds=0.5))
    out = tmp_path / "zenith.tif"
    args = ["darkness", str(emission), "-o", str(out), "--dem", str(dem), "--chunk-size", "512"]
    args += ["--scheduler", "tcp://127.0.0.1:8786", "--turbidity", "3", "--n-distance", "32"]
    result = CliRunner().invoke(command_group(), args)
    assert result.exit_code == 0, result.output
    scene, written = recorder.args
    assert (scene.emission, written) == (str(emission), str(out))
    assert scene.dem == str(dem) and scene.turbidity == 3.0 and scene.kernel is None
    assert scene.n_distance == 32 and scene.n_azimuth is None
    kwargs = recorder.kwargs
    assert kwargs["chunk_size"] == 512 and kwargs["height"] == 1.7
    assert kwargs["scheduler"] == "tcp://127.0.0.1:8786"
    assert kwargs["instrument"] is None and kwargs["spectrum"] is None
    assert kwargs["tiled"] is None and kwargs["target_crs"] is None and kwargs["store"] is None
    assert kwargs["resume"] is True and kwargs["keep_store"] is False and kwargs["retries"] == 2
    assert "3 x 4 cells" in result.output
    tiled = ["--tiled", "--target-crs", "EPSG:3067", "--store", str(tmp_path / "s")]
    tiled += ["--no-resume", "--keep-store", "--retries", "0", "--overwrite"]
    assert CliRunner().invoke(command_group(), [*args, *tiled]).exit_code == 0
    kwargs = recorder.calls[-1][1]
    assert kwargs["tiled"] is True and kwargs["target_crs"] == "EPSG:3067"
    assert kwargs["store"] == str(tmp_path / "s") and kwargs["resume"] is False
    assert kwargs["keep_store"] is True and kwargs["retries"] == 0


def test_darkness_command_maps_a_geographic_emission_in_tiles(
    stage: None, kernel: Path, tmp_path: Path
) -> None:
    values = np.zeros((40, 80), np.float32)
    values[18:22, 38:42] = 1.0  # [lm m-2]
    step = 3 / 3600  # 3 arcsec at 60 N: 93 m x 46 m
    emission = tmp_path / "geographic.tif"
    write_cog(
        emission,
        [RasterBand(values, "reflected", "lm m-2")],
        transform=Affine(step, 0, 25.0, 0, -step, 60.0),
        crs="EPSG:4326",
    )
    out = tmp_path / "zenith.tif"
    args = ["darkness", str(emission), str(out), "--kernel", str(kernel), "--chunk-size", "32"]
    result = CliRunner().invoke(command_group(), args)
    assert result.exit_code == 0, result.output
    assert (
        "40 x 80 cells" in result.output and "(6 tiles; read from its overviews)" in result.output
    )
    written = Raster.read(out)
    assert written.crs is not None and written.crs.is_geographic and written.shape == (40, 80)
    zenith = written.data[0]
    assert np.unravel_index(zenith.argmax(), zenith.shape) in {
        (r, c) for r in (19, 20) for c in (39, 40)
    }


def test_darkness_command_errors_are_one_line(stage: None, tmp_path: Path) -> None:
    geographic = write_emission(tmp_path / "geographic.tif", crs="EPSG:4326")
    result = CliRunner().invoke(
        command_group(), ["darkness", str(geographic), str(tmp_path / "z.tif")]
    )
    assert (
        result.exit_code == 1
        and "CRSError" in result.output
        and "within the globe" in result.output
    )
    assert "Traceback" not in result.output and not (tmp_path / "z.tif").exists()
    bad_chunk = CliRunner().invoke(
        command_group(), ["darkness", str(geographic), "-o", "z.tif", "--chunk-size", "0"]
    )
    assert bad_chunk.exit_code == 2 and "--chunk-size" in bad_chunk.output
    missing = CliRunner().invoke(command_group(), ["darkness", "nowhere.tif", "z.tif"])
    assert missing.exit_code == 2 and "does not exist" in missing.output


def test_darkness_command_maps_the_sky_under_a_cloud_deck(
    stage: None, emission: Path, kernel: Path, tmp_path: Path
) -> None:
    clear, overcast = tmp_path / "clear.tif", tmp_path / "overcast.tif"
    args = ["darkness", str(emission), "--kernel", str(kernel), "--observer-height", "0"]
    assert CliRunner().invoke(command_group(), [*args, str(clear)]).exit_code == 0
    deck = ["--cloud-base", "800", "--cloud-optical-depth", "30", "--cloud-cover", "0.5"]
    result = CliRunner().invoke(command_group(), [*args, str(overcast), *deck])
    assert result.exit_code == 0, result.output
    written = Raster.read(overcast)
    assert (written.tags["cloud_base_height_m"], written.tags["cloud_cover"]) == ("800.0", "0.5")
    lit = np.unravel_index(Raster.read(clear).data[0].argmax(), written.data[0].shape)
    assert written.data[0][lit] > Raster.read(clear).data[0][lit]  # the deck reflects the town
