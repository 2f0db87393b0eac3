"""``nightlights streets plan`` on three classed streets: the light layer with its dimming
(re-rated by the audit), the summary in JSON, refusal to replace outputs and usage errors."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
from click.testing import CliRunner

from nightlights import roads
from nightlights.errors import DataQualityWarning
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli


@pytest.fixture(scope="module")
def files(road_plan_case, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    lights, streets, table, _ = road_plan_case
    folder = tmp_path_factory.mktemp("plan")
    lights.to_file(folder / "lights.gpkg", driver="GPKG")
    streets.to_file(folder / "streets.gpkg", driver="GPKG")
    lines = []
    for name, entry in table.items():
        lines.append(f"[classes.{name}]")
        lines += [f"{key} = {value!r}" for key, value in entry.items()]
    (folder / "classes.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    spec = KernelSpec(r_max=3000.0, n_distance=6, n_elevation=4, n_azimuth=8, uplight=True)
    build_kernel(spec, folder / "kernel.nc", progress=False)
    return {
        "lights": folder / "lights.gpkg",
        "streets": folder / "streets.gpkg",
        "requirements": folder / "classes.toml",
        "kernel": folder / "kernel.nc",
    }


def _plan(files: dict[str, Path], out: Path, *options: str):
    args = ["streets", "plan", str(files["lights"]), str(files["streets"]), str(out)]
    args += ["--requirements", str(files["requirements"]), *options]
    return CliRunner().invoke(cli, args)


def test_plan_writes_dimmed_lights_that_keep_every_class(files, tmp_path, road_plan_case) -> None:
    lights, streets, table, _ = road_plan_case
    out, summary = tmp_path / "dimmed.gpkg", tmp_path / "plan.json"
    result = _plan(
        files,
        out,
        "--kernel",
        str(files["kernel"]),
        "--observer",
        "250,50",
        "--zenith-reduction",
        "0.3",
        "--json",
        str(summary),
    )
    assert result.exit_code == 0, result.output
    assert "cost of safety" in result.output
    dimmed = gpd.read_file(out)
    assert len(dimmed) == len(lights) and "dimming" in dimmed
    level = dimmed["dimming"].to_numpy(float)
    assert np.all((level >= 0) & (level <= 1)) and level.min() < 1
    figures = json.loads(summary.read_text())
    assert figures["feasible"] and len(figures["sky"]) == 1
    # the summary's cost is the power of the lights at the written levels
    assert figures["saved"] == pytest.approx(figures["cost_full"] - figures["cost"])
    sky = figures["sky"][0]
    assert sky["after_cd_m2"] <= 0.7 * sky["before_cd_m2"] * (1 + 1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        audited = roads.audit(lights, streets, requirements=table, dimming=level)
    assert bool(audited.segments["status"].eq("pass").all())
    again = _plan(files, out, "--objective", "flux")
    assert again.exit_code != 0 and "exists" in again.output


def test_plan_without_sky_keeps_only_the_road_minima(files, tmp_path) -> None:
    out = tmp_path / "road.gpkg"
    result = _plan(files, out, "--objective", "flux", "--min-dimming", "0.4")
    assert result.exit_code == 0, result.output
    level = gpd.read_file(out)["dimming"].to_numpy(float)
    assert level.min() >= 0.4 - 1e-9


def test_sky_targets_need_an_observer(files, tmp_path) -> None:
    result = _plan(files, tmp_path / "x.gpkg", "--zenith-reduction", "0.3")
    assert result.exit_code == 2 and "--observer" in result.output
    assert not (tmp_path / "x.gpkg").exists()
