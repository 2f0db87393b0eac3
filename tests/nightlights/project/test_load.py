"""Project files are checked before anything runs: each bad file is one line naming the key."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import pytest
from shapely.geometry import Point

from nightlights.project import ProjectError, load_project, run
from nightlights.project._schema import STAGES

from .conftest import SMALL_PROJECT


def _edited(path: Path, old: str, new: str) -> Path:
    text = path.read_text(encoding="utf-8")
    assert old in text, old
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


BAD = [
    pytest.param(
        "[stages.skyglow]",
        "[stages.skyglw]",
        "stages.skyglw: unknown stage in [stages]; allowed: " + ", ".join(STAGES),
        id="unknown stage",
    ),
    pytest.param(
        "png = false",
        "png = false\nresolutin = 1.0",
        "stages.skyglow.resolutin: unknown key in [stages.skyglow]; allowed: n-azimuth, "
        "n-elevation, n-distance, observer, mode, components, png, projection, polar-output",
        id="unknown key",
    ),
    pytest.param(
        'emission = "emission.tif"',
        'emission = "missing.tif"',
        "inputs.emission: {folder}/missing.tif does not exist",
        id="missing input",
    ),
    pytest.param(
        "[observers]",
        '[observers]\ncrs = "EPSG:99999"',
        "observers.crs = 'EPSG:99999': not a coordinate reference system",
        id="wrong CRS",
    ),
    pytest.param(
        "a = [385500.0, 6671500.0]",
        "a = [6671500.0, 385500.0]",
        "km from the data (inputs.emission), beyond the [kernel] table's r-max (3 km); check "
        "the coordinates and observers.crs",
        id="observer outside the data",
    ),
    pytest.param(
        "png = false",
        "png = false\nn-azimuth = 64",
        "stages.skyglow.n-azimuth: the [kernel] table fixes the grid (kernel.n-azimuth); "
        "remove one of the two",
        id="contradictory grid",
    ),
    pytest.param(
        'emission = "emission.tif"',
        'emission = "emission.tif"\nstreets = "emission.tif"',
        "inputs: give exactly one of streets, emission, viirs (given: streets, emission)",
        id="two inputs",
    ),
    pytest.param(
        "png = false",
        'png = false\nmode = "fast"',
        "stages.skyglow.mode = 'fast': not allowed; allowed: 'pca', 'exact', 'naive'",
        id="value not allowed",
    ),
    pytest.param(
        'metric = "zenith"',
        'metric = "zenith"\nobserver = "c"',
        "stages.inverse-q.observer = 'c': no such observer; allowed: a, b",
        id="unknown observer",
    ),
    pytest.param(
        "[stages.skyglow]",
        "[stages.irradiance]\nresolution = 1.0\n\n[stages.skyglow]",
        "stages.irradiance: reads the streets, but the project's input is inputs.emission",
        id="stage without its input",
    ),
    pytest.param(
        "[stages.skyglow]",
        '[stages.inverse-reduce]\nby = "inverse-q"\nobserver = "a"\nqa = "90%"\nqb = "50%"\n\n'
        "[stages.skyglow]",
        "stages.inverse-reduce.qa = '90%', qb = '50%': expected qa < qb <= 100%",
        id="contradictory thresholds",
    ),
    pytest.param(
        "[stages.skyglow]",
        '[stages.inverse-reduce]\nby = "inverse-s"\nqa = 1.0\nqb = 2.0\n\n[stages.skyglow]',
        "stages.inverse-reduce.by = 'inverse-s': that stage does not run; add "
        "[stages.inverse-s] (allowed: inverse-q)",
        id="reduce by a stage that does not run",
    ),
    pytest.param(
        "r-max = 3000.0",
        "r-max = -1.0",
        "kernel.r-max = -1.0: input should be greater than 0",
        id="negative number",
    ),
    pytest.param(
        "r-max = 3000.0",
        "r-max = 1e9",
        "kernel.r-max = 1000000000.0: input should be less than or equal to 300000",
        id="r-max beyond any kernel's range",
    ),
    pytest.param(
        "[observers]",
        "[observer]",
        "observer: unknown key in the file; allowed: project, inputs, observers, atmosphere, "
        "kernel, stages",
        id="unknown table",
    ),
    pytest.param(
        "[stages.skyglow]",
        "[stages.skyglow",
        "not a TOML file",
        id="not TOML",
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_a_bad_project_is_one_line_naming_the_key_and_runs_nothing(
    small_project: Path, old: str, new: str, message: str
) -> None:
    path = _edited(small_project, old, new)
    with pytest.raises(ProjectError) as info:
        run(path)
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith(f"{path}: ")
    assert message.format(folder=path.parent) in text
    assert not (path.parent / "out").exists()


def test_a_missing_required_option_is_named(small_project: Path) -> None:
    path = _edited(small_project, "[stages.skyglow]", "[stages.irradiance]\n\n[stages.skyglow]")
    with pytest.raises(ProjectError, match=r"stages\.irradiance\.resolution: missing"):
        load_project(path)


def test_a_stage_without_its_upstream_stage_is_refused(tmp_path: Path) -> None:
    streets = tmp_path / "streets.gpkg"
    gpd.GeoDataFrame(geometry=[Point(0, 0)], crs="EPSG:3067").to_file(streets)
    tables = {
        "inputs": {"streets": "streets.gpkg"},
        "stages": {"normalize": {}, "place": {}},
    }
    with pytest.raises(ProjectError, match=r"stages\.place: needs the output of stages\.sample"):
        load_project(tables, base=tmp_path)


def test_the_small_project_loads(small_project: Path) -> None:
    project = load_project(small_project)
    assert project.stages == ["skyglow", "inverse-q"]
    assert [o.name for o in project.observers] == ["a", "b"]
    assert project.output == small_project.parent / "out"
    assert project.file.inputs.emission == small_project.parent / "emission.tif"


def test_tables_as_a_mapping_take_paths_from_base(small_project: Path) -> None:
    import tomllib

    tables = tomllib.loads(SMALL_PROJECT)
    project = load_project(tables, base=small_project.parent)
    assert project.file.inputs.emission == small_project.parent / "emission.tif"
    assert project.source == "project"


def test_observers_from_a_point_layer_with_names(small_project: Path) -> None:
    layer = small_project.parent / "observers.gpkg"
    gpd.GeoDataFrame(
        {"site": ["harbour", "park"]},
        geometry=[Point(24.946, 60.167), Point(24.947, 60.168)],
        crs="EPSG:4326",
    ).to_file(layer)
    _edited(
        small_project,
        "points = { a = [385500.0, 6671500.0], b = [385200.0, 6671200.0] }",
        'file = "observers.gpkg"\nname-field = "site"',
    )
    project = load_project(small_project)
    assert [o.name for o in project.observers] == ["harbour", "park"]
    assert project.observers[0].crs is not None and "4326" in project.observers[0].crs
    _edited(small_project, 'name-field = "site"', 'name-field = "label"')
    with pytest.raises(ProjectError, match=r"observers\.name-field = 'label': .* fields: site"):
        load_project(small_project)


def test_a_seed_override_is_checked_like_the_file(small_project: Path) -> None:
    project = load_project(small_project, overrides={"project": {"seed": 5}})
    assert project.file.project.seed == 5
    with pytest.raises(ProjectError, match=r"project\.seed = -1: input should be greater"):
        load_project(small_project, overrides={"project": {"seed": -1}})


def test_the_reach_without_a_kernel_is_the_longest_any_kernel_tabulates() -> None:
    from nightlights.project._schema import MAX_REACH
    from nightlights.sky.spec import MAX_KERNEL_RANGE

    assert MAX_REACH == MAX_KERNEL_RANGE


def test_a_projection_per_observer_names_observers_that_exist(small_project: Path) -> None:
    _edited(small_project, "png = false", 'projection = { a = "fisheye", c = "fisheye" }')
    with pytest.raises(ProjectError, match=r"stages\.skyglow\.projection\.c: no such observer"):
        load_project(small_project)
