"""No project stage writes over one of the project's inputs, table-driven over every input.

Each input (``inputs.*``, ``observers.file``, ``stages.emission.albedo``) is placed where a
stage would write an output, or reached through a link: ``check`` and ``run`` refuse the
project before any stage runs, in one ``ProjectError`` line naming the stage, the output and
the input, and leave the input as it was.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import geopandas as gpd
import pytest
from click.testing import CliRunner
from shapely.geometry import Point

from nightlights.project import ProjectError, check, run
from nightlights_cli.main import cli

from .conftest import write_emission

STREETS = Path(__file__).parents[2] / "data" / "streets" / "berlin-siegessaeule.osm.gz"
MAPPING = Path(__file__).parents[3] / "nightlights" / "streets" / "mappings" / "osm.toml"


def _observers(path: Path) -> Path:
    gpd.GeoDataFrame(
        {"name": ["a"]}, geometry=[Point(385500.0, 6671500.0)], crs="EPSG:3067"
    ).to_file(path)
    return path


@dataclass(frozen=True)
class Case:
    """A project (``[inputs]`` and the rest, with ``{out}`` the output folder), made by
    ``place(folder)``, which writes the inputs and returns the one at risk; the words of the
    error."""

    text: str
    place: Callable[[Path], Path]
    words: tuple[str, ...]


def _emission_at(name: str) -> Callable[[Path], Path]:
    def place(folder: Path) -> Path:
        return write_emission(folder / name)

    return place


def _streets_at(name: str) -> Callable[[Path], Path]:
    def place(folder: Path) -> Path:
        return Path(shutil.copy(STREETS, folder / name))

    return place


def _emission_and(name: str, make: Callable[[Path], Path]) -> Callable[[Path], Path]:
    def place(folder: Path) -> Path:
        write_emission(folder / "emission.tif")
        return make(folder / name)

    return place


def _dem(path: Path) -> Path:
    return write_emission(path)


def _hard_link(folder: Path) -> Path:
    source = write_emission(folder / "emission.tif")
    os.link(source, folder / "out" / "darkness.tif")
    return source


def _symlink(folder: Path) -> Path:
    write_emission(folder / "out" / "darkness.tif")
    (folder / "link.tif").symlink_to(folder / "out" / "darkness.tif")
    return folder / "out" / "darkness.tif"


def _network(folder: Path) -> Path:
    network = folder / "out" / "streets_lit.gpkg"
    shutil.copytree(Path(__file__).parents[3] / "bayesnets" / "catalog" / "europe", network)
    shutil.copy(STREETS, folder / "streets.osm.gz")
    return network


def _catalog(folder: Path) -> Path:
    (folder / "out" / "systems.csv").write_text("catalogue table")
    shutil.copy(STREETS, folder / "streets.osm.gz")
    return folder / "out"


def _albedo(folder: Path) -> Path:
    shutil.copy(STREETS, folder / "streets.osm.gz")
    return write_emission(folder / "out" / "irradiance.tif")


def _mapping(folder: Path) -> Path:
    shutil.copy(STREETS, folder / "streets.osm.gz")
    return Path(shutil.copy(MAPPING, folder / "out" / "lights.gpkg"))


SKY = """
[observers]
{observers}

[kernel]
r-min = 10.0
r-max = 3000.0
n-distance = 8
n-elevation = 8
n-azimuth = 16
uplight = false
"""
POINTS = "points = { a = [385500.0, 6671500.0] }"
GROUND = """
[stages.normalize]
[stages.sample]
[stages.place]
[stages.irradiance]
resolution = 1.0
"""

CASES: dict[str, Case] = {
    "inputs.emission": Case(
        'emission = "out/darkness.tif"\n[stages.darkness]',
        _emission_at("out/darkness.tif"),
        ("stage darkness", "darkness.tif", "is the input inputs.emission"),
    ),
    "inputs.emission (hard link)": Case(
        'emission = "emission.tif"\n[stages.darkness]',
        _hard_link,
        ("stage darkness", "darkness.tif", "is the input inputs.emission"),
    ),
    "inputs.emission (symbolic link)": Case(
        'emission = "link.tif"\n[stages.darkness]',
        _symlink,
        ("stage darkness", "darkness.tif", "is the input inputs.emission"),
    ),
    "inputs.dem": Case(
        'emission = "emission.tif"\ndem = "out/darkness.tif"\n[stages.darkness]',
        _emission_and("out/darkness.tif", _dem),
        ("stage darkness", "darkness.tif", "is the input inputs.dem"),
    ),
    "inputs.viirs": Case(
        'viirs = "out/emission.tif"\n[stages.emission-viirs]',
        _emission_at("out/emission.tif"),
        ("stage emission-viirs", "emission.tif", "is the input inputs.viirs"),
    ),
    "inputs.streets": Case(
        'streets = "out/streets_norm.gpkg"\n[stages.normalize]',
        _streets_at("out/streets_norm.gpkg"),
        ("stage normalize", "streets_norm.gpkg", "is the input inputs.streets"),
    ),
    "inputs.mapping": Case(
        'streets = "streets.osm.gz"\nmapping = "out/lights.gpkg"' + GROUND,
        _mapping,
        ("stage place", "lights.gpkg", "is the input inputs.mapping"),
    ),
    "inputs.network": Case(
        'streets = "streets.osm.gz"\nnetwork = "out/streets_lit.gpkg"' + GROUND,
        _network,
        ("stage sample", "streets_lit.gpkg", "is the input inputs.network"),
    ),
    "inputs.catalog": Case(
        'streets = "streets.osm.gz"\ncatalog = "out"' + GROUND,
        _catalog,
        ("project.output", "the output folder", "is inputs.catalog"),
    ),
    "stages.emission.albedo": Case(
        'streets = "streets.osm.gz"'
        + GROUND
        + '[stages.emission]\nresolution = 10.0\nalbedo = "out/irradiance.tif"',
        _albedo,
        ("stage irradiance", "irradiance.tif", "is the input stages.emission.albedo"),
    ),
    "observers.file": Case(
        'emission = "emission.tif"\n[stages.observers]'
        + SKY.format(observers='file = "out/observers.gpkg"'),
        _emission_and("out/observers.gpkg", _observers),
        ("stage observers", "observers.gpkg", "is the input observers.file"),
    ),
    "inputs.emission (sky stages)": Case(
        'emission = "out/skyglow_a.nc"\n[stages.skyglow]\npng = false'
        + SKY.format(observers=POINTS),
        _emission_at("out/skyglow_a.nc"),
        ("stage skyglow:a", "skyglow_a.nc", "is the input inputs.emission"),
    ),
}


def _project(folder: Path, case: Case) -> tuple[Path, Path]:
    (folder / "out").mkdir()
    at_risk = case.place(folder)
    inputs, _, rest = case.text.partition("\n[")
    text = f'[project]\noutput = "out"\n\n[inputs]\n{inputs}\n' + (f"[{rest}\n" if rest else "")
    project = folder / "project.toml"
    project.write_text(text, encoding="utf-8")
    return project, at_risk


def _contents(path: Path) -> dict[str, bytes]:
    files = sorted(path.rglob("*")) if path.is_dir() else [path]
    return {str(p): p.read_bytes() for p in files if p.is_file()}


@pytest.mark.parametrize("name", list(CASES))
def test_a_project_output_that_is_an_input_is_refused(
    tmp_path: Path, kernel_cache: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(kernel_cache))
    case = CASES[name]
    project, at_risk = _project(tmp_path, case)
    before = _contents(at_risk)
    for attempt in (check, lambda path: run(path, progress=False)):
        with pytest.raises(ProjectError) as error:
            attempt(project)
        message = str(error.value)
        assert "\n" not in message
        assert message.startswith(f"{project}: project.output: "), message
        for word in case.words:
            assert word in message, (word, message)
        assert str(at_risk) in message or str(at_risk.resolve()) in message, message
        assert message.endswith("choose another output folder"), message
    assert _contents(at_risk) == before
    assert not (tmp_path / "out" / ".nightlights").exists()


def test_the_command_refuses_an_observers_file_in_the_output_folder(
    tmp_path: Path, kernel_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(kernel_cache))
    project, at_risk = _project(tmp_path, CASES["observers.file"])
    before = _contents(at_risk)
    result = CliRunner().invoke(cli, ["run", str(project)])
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "stage observers would write" in errors[0] and "observers.file" in errors[0]
    assert _contents(at_risk) == before
