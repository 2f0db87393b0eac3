"""``nightlights validate``: readings files and an emission raster in, the four outputs and a
one-line summary out; bad readings stop it with one line and nothing written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from affine import Affine
from click.testing import CliRunner
from pyproj import Transformer

from nightlights.io import RasterBand, write_cog
from nightlights.meter.readings import read_readings, write_ida
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli

TRANSFORM = Affine(200, 0, 380_000, 0, -200, 6_690_000)
CRS = "EPSG:32635"
NIGHT = pd.date_range("2026-01-18T19:00", "2026-01-18T23:00", periods=9, tz="UTC")


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """An emission raster (a town), a kernel reaching over it, and one community-standard
    file per station (four SQM-L stations, a moonless January night near Helsinki)."""
    folder = tmp_path_factory.mktemp("validate")
    rows, cols = np.mgrid[0:40, 0:40]
    values = 0.8 * np.exp(-((rows - 15) ** 2 + (cols - 18) ** 2) / 8.0)
    values[values < 1e-3] = 0.0
    emission = write_cog(
        folder / "emission.tif",
        [RasterBand(values.astype(np.float32), "lambertian", "lm m-2")],
        transform=TRANSFORM,
        crs=CRS,
    )
    kernel = folder / "kernel.nc"
    spec = KernelSpec(
        r_max=12_000.0, n_distance=16, n_elevation=24, n_azimuth=32, observer_altitudes=(1.7,)
    )
    build_kernel(spec, kernel, progress=False)
    to_lonlat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True)
    readings = folder / "readings"
    readings.mkdir()
    for i, (x, y) in enumerate(
        [(381_000, 6_687_000), (383_500, 6_686_900), (386_000, 6_684_000), (387_500, 6_683_000)]
    ):
        lon, lat = to_lonlat.transform(x, y)
        frame = pd.DataFrame(
            {
                "station": f"meter{i}",
                "time": NIGHT,
                "magnitude": 19.5 + 0.4 * i,
                "instrument": "sqm-l",
                "lon": lon,
                "lat": lat,
            }
        )
        write_ida(read_readings(frame), readings / f"meter{i}.dat")
    return {"emission": emission, "kernel": kernel, "readings": readings}


def test_validate_writes_the_four_outputs(files: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "validation"
    result = CliRunner().invoke(
        cli,
        [
            "validate",
            str(files["emission"]),
            str(files["readings"]),
            str(out),
            "--kernel",
            str(files["kernel"]),
            "--calibrate",
            "scale",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "4 stations: bias" in result.output and "calibrated: scale" in result.output
    for name in (
        "stations.gpkg",
        "validation.json",
        "validation.png",
        "residuals.png",
        "emission_calibrated.tif",
    ):
        assert (out / name).is_file(), name
    summary = json.loads((out / "validation.json").read_text())
    assert summary["overall"]["n"] == 4
    assert summary["calibration"]["folds"] == "station"


def test_existing_outputs_need_overwrite(files: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "validation"
    args = [
        "validate",
        str(files["emission"]),
        str(files["readings"]),
        str(out),
        "--kernel",
        str(files["kernel"]),
    ]
    assert CliRunner().invoke(cli, args).exit_code == 0
    again = CliRunner().invoke(cli, args)
    assert again.exit_code != 0 and "exists" in again.output
    assert CliRunner().invoke(cli, [*args, "--overwrite"]).exit_code == 0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("station,time,magnitude,instrument\na,2026-01-18T21:00:00Z,20.1,sqm\n", "lon"),
        ("lon,lat,time,magnitude,instrument\n24.9,60.2,2026-01-18 21:00,20.1,sqm\n", "--time-zone"),
        (
            "lon,lat,time,magnitude,instrument\n24.9,60.2,2026-01-18T21:00:00Z,20.1,meter\n",
            "unknown instrument",
        ),
    ],
)
def test_bad_readings_stop_with_one_line(
    files: dict[str, Path], tmp_path: Path, text: str, message: str
) -> None:
    readings = tmp_path / "readings.csv"
    readings.write_text(text)
    out = tmp_path / "validation"
    result = CliRunner().invoke(
        cli,
        [
            "validate",
            str(files["emission"]),
            str(readings),
            str(out),
            "--kernel",
            str(files["kernel"]),
        ],
    )
    assert result.exit_code != 0
    assert message in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert not out.exists()


def test_bad_folds_is_a_usage_error(files: dict[str, Path], tmp_path: Path) -> None:
    result = CliRunner().invoke(
        cli,
        [
            "validate",
            str(files["emission"]),
            str(files["readings"]),
            str(tmp_path / "o"),
            "--calibrate",
            "scale",
            "--folds",
            "half",
        ],
    )
    assert result.exit_code == 2 and "--folds" in result.output


def test_darkness_reports_the_natural_sky_of_a_night(
    files: dict[str, Path], tmp_path: Path
) -> None:
    """``darkness --instrument sqm-l --night``: the natural sky of that instant (read by the
    instrument over the raster's centre) replaces the typical night's in the instrument band,
    and is recorded in the tags."""
    from nightlights.io import Raster

    typical = tmp_path / "typical.tif"
    night = tmp_path / "night.tif"
    base = [
        "darkness",
        str(files["emission"]),
        "--kernel",
        str(files["kernel"]),
        "--instrument",
        "sqm-l",
    ]
    assert CliRunner().invoke(cli, [*base[:2], str(typical), *base[2:]]).exit_code == 0
    result = CliRunner().invoke(
        cli, [*base[:2], str(night), *base[2:], "--night", "2026-01-18T21:00Z"]
    )
    assert result.exit_code == 0, result.output
    a, b = Raster.read(typical), Raster.read(night)
    np.testing.assert_array_equal(a.data[0], b.data[0])  # the artificial part is the same
    assert not np.allclose(a.data[1], b.data[1])  # the natural sky differs
    missing = CliRunner().invoke(
        cli,
        [
            *base[:2],
            str(tmp_path / "x.tif"),
            "--kernel",
            str(files["kernel"]),
            "--night",
            "2026-01-18T21:00Z",
        ],
    )
    assert missing.exit_code == 2 and "--instrument" in missing.output
