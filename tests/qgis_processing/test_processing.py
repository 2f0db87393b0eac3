"""The plugin in real QGIS: installed from the built zip, every stage an algorithm with the
parameters its command describes; two algorithms run with ``processing.run`` on the bundled
example, their outputs opened by QGIS, and a cancel of a run on a worker thread, as the
Processing dialog runs it; a tiny kernel built, and inverse s, the dimming rule, the least
dimming and the skies of many observers run with it on a small scene, each giving what its
command gives.

QGIS runs in its own interpreter (``/usr/bin/python3`` with Debian's ``python3-qgis``), as it
would for a user: the plugin there runs a ``nightlights`` command of this environment, which
``build_plugin`` records in the zip (the checkout under test, when ``PYTHONPATH`` names one).
Skipped when that interpreter has no ``qgis.core``.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from nightlights.demo import example_path
from nightlights.qgis import PLUGIN_FOLDER, build_plugin, toolkit_command
from nightlights_cli.describe import describe_stages
from nightlights_cli.main import cli

QGIS_PYTHON = "/usr/bin/python3"
SCRIPT = Path(__file__).with_name("qgis_processing_run.py")


def _qgis_missing() -> str | None:
    if not os.path.exists(QGIS_PYTHON):
        return f"{QGIS_PYTHON} does not exist"
    probe = subprocess.run(
        [QGIS_PYTHON, "-c", "import qgis.core"], capture_output=True, text=True, check=False
    )
    if probe.returncode:
        return (
            f"{QGIS_PYTHON} cannot import qgis.core (install Debian's python3-qgis and "
            "qgis-providers)"
        )
    return None


_MISSING = _qgis_missing()
pytestmark = pytest.mark.skipif(_MISSING is not None, reason=str(_MISSING))


def _run_in_qgis(mode: str, plugins: Path, source: str, work: Path) -> dict[str, Any]:
    """Run the QGIS script in QGIS's Python; its JSON report, with its stderr's end."""
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "XDG_RUNTIME_DIR": str(work)}
    env.pop("NIGHTLIGHTS_COMMAND", None)  # the command recorded in the zip is the one used
    done = subprocess.run(
        [QGIS_PYTHON, str(SCRIPT), mode, str(plugins), source, str(work)],
        capture_output=True,
        text=True,
        env=env,
        cwd=work,
        timeout=1200,
        check=False,
    )
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0 and lines, done.stdout[-3000:] + done.stderr[-3000:]
    return dict(json.loads(lines[-1]), work=str(work), stderr=done.stderr[-3000:])


def _command(folder: Path) -> Path:
    """The ``nightlights`` command the plugin runs: the installed one, or, when ``PYTHONPATH``
    names the code under test, a script that runs it with that path (the plugin's runner
    leaves QGIS's ``PYTHONPATH`` out of the command's environment)."""
    path = os.environ.get("PYTHONPATH")
    if not path:
        return toolkit_command()
    script = folder / "nightlights"
    script.write_text(
        f"#!/bin/sh\nPYTHONPATH={shlex.quote(path)} exec {shlex.quote(sys.executable)} "
        '-m nightlights_cli "$@"\n'
    )
    script.chmod(0o755)
    return script


@pytest.fixture(scope="module")
def plugins(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The built zip, installed (unzipped) into a QGIS plugin folder."""
    root = tmp_path_factory.mktemp("qgis")
    zipped = build_plugin(root / "nightlights.zip", describe_stages(cli), command=_command(root))
    with zipfile.ZipFile(zipped) as archive:
        archive.extractall(root / "plugins")
    return root / "plugins"


@pytest.fixture(scope="module")
def report(plugins: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Streets to lights and their irradiance in QGIS, on the bundled example."""
    work = tmp_path_factory.mktemp("light")
    return _run_in_qgis("light", plugins, f"{example_path()}|layername=lines", work)


@pytest.fixture(scope="module")
def sky_report(
    plugins: Path, report: dict[str, Any], tmp_path_factory: pytest.TempPathFactory
) -> dict[str, Any]:
    """Emission, skyglow, inverse q, darkness and sky render in QGIS, from the light run's
    outputs."""
    work = tmp_path_factory.mktemp("sky")
    return _run_in_qgis("sky", plugins, report["work"], work)


def test_the_zip_installs_as_a_processing_plugin(report: dict[str, Any]) -> None:
    from nightlights import __version__

    assert report["available"] and report["started"], report["stderr"]
    assert report["metadata"]["version"] == __version__
    assert report["metadata"]["hasProcessingProvider"] == "yes"
    assert PLUGIN_FOLDER == "nightlights_processing"


def test_every_stage_is_an_algorithm_with_its_commands_parameters(report: dict[str, Any]) -> None:
    """One algorithm per stage command, with one parameter per parameter of its description
    (the ids of earlier versions among them), and the chain of the three street stages."""
    algorithms = report["algorithms"]
    stages = describe_stages(cli)
    assert set(algorithms) == {f"nightlights:{stage['id']}" for stage in stages} | {
        "nightlights:streetstolights"
    }
    for earlier in ("streetsnormalize", "streetssample", "streetsplace", "irradiance"):
        assert f"nightlights:{earlier}" in algorithms
    for earlier in ("emission", "emissionviirs", "skyglow", "inverseq", "darkness"):
        assert f"nightlights:{earlier}" in algorithms
    for stage in stages:
        algorithm = algorithms[f"nightlights:{stage['id']}"]
        assert algorithm["parameters"] == [p["name"] for p in stage["parameters"]], stage["id"]
    chain = algorithms["nightlights:streetstolights"]
    assert chain["parameters"] == ["INPUT", "MAPPING", "NETWORK", "SEED", "OUTPUT"]
    assert {"ZENITH_LUMINANCE", "ZENITH_MAGNITUDE", "BORTLE", "OUTPUT", "PNG"} <= set(
        algorithms["nightlights:skyglow"]["outputs"]
    )

    def kind(algorithm: str, name: str) -> str:
        entry = algorithms[f"nightlights:{algorithm}"]
        return str(entry["types"][entry["parameters"].index(name)])

    # each kind of parameter as QGIS offers it
    assert kind("inverses", "OBSERVER") == "point"
    assert kind("inverseplan", "OBSERVERS") == "source"  # a point layer: --observer each
    assert kind("inverses", "KERNEL") == "file"
    assert kind("inverses", "EMISSION") == "raster"
    assert kind("inversedim", "DIMMING_OUTPUT") == "rasterDestination"
    assert kind("kernelbuild", "OUTPUT") == "fileDestination"
    assert kind("kernelbuild", "UPLIGHT") == "boolean"
    assert kind("kernelbuild", "N_AZIMUTH") == "number"
    assert kind("skyobservers", "SUMMARY") == "vectorDestination"
    assert kind("skyrender", "LONLAT") == "point"
    assert kind("run", "OUTPUT") == "folderDestination"
    assert kind("run", "FORCE") == "enum"
    assert kind("streetsnormalize", "TARGET_CRS") == "crs"
    assert kind("inverseplan", "TARGET_REGION") == "string"


def test_streets_to_lights_in_qgis(report: dict[str, Any]) -> None:
    run = report["streetstolights"]
    assert "error" not in run, run
    layer = run["layer"]
    assert layer["valid"]
    assert layer["geometry"] == "Point"
    # the Helsinki extract lies in UTM zone 35N; its ~1.0 x 1.7 km of lit streets carry
    # thousands of luminaires (2462 with the command line's own seed in the demo)
    assert layer["crs"] == "EPSG:32635"
    assert 1000 < layer["features"] < 5000
    assert {"pole_id", "arrangement"} <= set(layer["fields"])
    # three commands in a row: progress reaches each third in turn, never goes back
    progress = run["progress"]
    assert progress == sorted(progress)
    assert progress[-1] == pytest.approx(100.0)
    assert any(33.0 <= value <= 34.0 for value in progress)
    assert any(66.0 <= value <= 67.0 for value in progress)
    # the OSM file is read in place, its layer named to the command (not exported first)
    commands = [line for line in run["log"] if " streets " in line]
    assert len(commands) == 3
    assert str(example_path()) in commands[0] and "--layer lines" in commands[0]
    # the commands' own messages reach QGIS's log
    assert any("street parts from" in line for line in run["log"])
    assert any("luminaires on" in line for line in run["log"])


def test_irradiance_in_qgis(report: dict[str, Any]) -> None:
    run = report["irradiance"]
    assert "error" not in run, run
    raster, lights = run["layer"], report["streetstolights"]["layer"]
    assert raster["valid"]
    assert raster["crs"] == lights["crs"]
    assert raster["pixel"] == pytest.approx([5.0, 5.0])
    # the raster covers every light (its extent grows by the regions of influence)
    xmin, ymin, xmax, ymax = raster["extent"]
    lxmin, lymin, lxmax, lymax = lights["extent"]
    assert xmin <= lxmin and ymin <= lymin and xmax >= lxmax and ymax >= lymax
    photopic, scotopic = raster["bands"]
    # street lighting: tens of lux under the poles at 5 m pixels, none below zero
    assert photopic["min"] >= 0.0 and 5.0 < photopic["max"] < 1000.0
    assert photopic["mean"] > 0.0 and scotopic["max"] > 0.0
    assert run["progress"][-1] == pytest.approx(100.0)
    # the lights' GeoPackage (its data layer first, then its layer_styles table) is passed as
    # it is, not copied to a temporary file
    command = next(line for line in run["log"] if " irradiance " in line)
    assert str(Path(report["work"]) / "lights.gpkg") in command


def test_cancel_stops_the_command_and_leaves_no_output(report: dict[str, Any]) -> None:
    """Cancelled on the dialog's worker thread: the task fails with the cancel, the command is
    stopped and neither the output nor a temporary of it is left."""
    run = report["cancelled"]
    assert "cancelled" in run.get("error", ""), run
    assert not (Path(report["work"]) / "cancelled.tif").exists()
    assert list(Path(report["work"]).glob("cancelled*")) == []


@pytest.mark.slow
def test_emission_skyglow_inverse_q_darkness_and_sky_render_in_qgis(
    sky_report: dict[str, Any],
) -> None:
    """The sky stages in QGIS (slow: the first skyglow and darkness build scene kernels), and
    the night sky over the skyglow panorama."""
    emission = sky_report["emission"]
    assert "error" not in emission, emission
    raster = emission["layer"]
    assert raster["valid"] and raster["crs"] == "EPSG:32635"
    assert raster["pixel"] == pytest.approx([50.0, 50.0])
    reflected, uplight = raster["bands"]
    assert reflected["min"] >= 0.0 and reflected["max"] > 0.0 and uplight["max"] > 0.0

    skyglow = sky_report["skyglow"]
    assert "error" not in skyglow, skyglow
    outputs = skyglow["outputs"]
    assert Path(outputs["OUTPUT"]).stat().st_size > 0
    assert Path(outputs["PNG"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # a city-centre sky from streetlights: far brighter than a dark site's ~22 mag arcsec-2
    assert 14.0 < outputs["ZENITH_MAGNITUDE"] < 21.0
    assert outputs["ZENITH_LUMINANCE"] > 0.0
    assert 1 <= outputs["BORTLE"] <= 9

    q = sky_report["inverseq"]
    assert "error" not in q, q
    raster = q["layer"]
    assert raster["valid"] and raster["crs"] == "EPSG:32635"
    assert raster["extent"] == pytest.approx(sky_report["emission"]["layer"]["extent"])
    (zenith_part,) = raster["bands"]
    # each lit cell's part of the zenith luminance [cd m-2]: skyglow is linear in the
    # emission, so the parts add up to the skyglow run's zenith (printed to 3 digits)
    assert zenith_part["min"] >= 0.0
    assert zenith_part["sum"] == pytest.approx(outputs["ZENITH_LUMINANCE"], rel=5e-3)

    darkness = sky_report["darkness"]
    assert "error" not in darkness, darkness
    raster = darkness["layer"]
    assert raster["valid"] and raster["crs"] == "EPSG:32635"
    luminance, magnitude = raster["sample"]
    # the same observer in the darkness map, which puts it at its 50 m cell's centre (up to
    # 35 m away) and integrates the raster directly, not through the polar grid: 0.03 mag
    # apart when this was written, against 1.8 mag between the map's brightest and darkest
    assert magnitude == pytest.approx(outputs["ZENITH_MAGNITUDE"], abs=0.1)
    assert luminance == pytest.approx(outputs["ZENITH_LUMINANCE"], rel=0.1)

    render = sky_report["skyrender"]
    assert "error" not in render, render
    assert Path(render["outputs"]["OUTPUT"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the point picked in UTM reaches the command in longitude and latitude
    command = next(line for line in render["log"] if " sky render " in line)
    lonlat = command.split("--lonlat ")[1].split()[0].split(",")
    assert [float(value) for value in lonlat] == pytest.approx([24.9480, 60.1675], abs=1e-6)


#: The small scene of the stages run: 20 x 20 cells of 100 m in UTM 35N [m].
SCENE_ORIGIN = (500_000.0, 6_700_000.0)
#: Its observers, the first at the centre (the run's SMALL_OBSERVER) [m].
SCENE_OBSERVERS = ((501_000.0, 6_699_000.0), (500_550.0, 6_698_450.0))


@pytest.fixture(scope="module")
def stages_report(plugins: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A tiny kernel, inverse s, dim, plan and the skies of two observers in QGIS."""
    import geopandas as gpd
    from affine import Affine
    from shapely.geometry import Point

    from nightlights.io import Raster

    scene = tmp_path_factory.mktemp("scene")
    data = np.zeros((2, 20, 20))
    data[0, 4:7, 14:17] = 2.0  # a bright block north-east of the observer [lm m-2]
    data[1, 4:7, 14:17] = 0.2
    data[0, 15, 3] = 1.0  # one faint cell south-west
    x0, y0 = SCENE_ORIGIN
    Raster(
        data,
        Affine(100, 0, x0, 0, -100, y0),
        "EPSG:32635",
        ("reflected", "uplight"),
        ("lm m-2", "lm m-2"),
    ).write(scene / "emission.tif")
    points = [Point(x, y) for x, y in SCENE_OBSERVERS]
    observers = gpd.GeoDataFrame({"name": ["centre", "south"]}, geometry=points, crs="EPSG:32635")
    observers.to_file(scene / "observers.gpkg")
    work = tmp_path_factory.mktemp("stages")
    return dict(_run_in_qgis("stages", plugins, str(scene), work), scene=str(scene))


def _cli(*args: Any) -> None:
    result = CliRunner().invoke(cli, [str(arg) for arg in args])
    assert result.exit_code == 0, result.output


def _band(path: Path | str) -> np.ndarray:
    with rasterio.open(path) as dataset:
        return dataset.read(1)


def test_kernel_build_through_processing(stages_report: dict[str, Any]) -> None:
    """The kernel of the options given; those left at their defaults are left to the command."""
    import xarray as xr

    run = stages_report["kernelbuild"]
    assert "error" not in run, run
    command = next(line for line in run["log"] if " kernel build " in line)
    given = command.split(" kernel build ")[1].split()[1:]
    assert given == [
        *("--r-max", "3000.0", "--n-distance", "8", "--n-elevation", "8", "--n-azimuth", "16"),
        *("--uplight", "--overwrite"),
    ]
    with xr.open_dataset(run["outputs"]["OUTPUT"]) as kernel:
        assert (kernel.sizes["distance"], kernel.sizes["elevation"]) == (8, 8)
        assert kernel.sizes["azimuth"] == 16
        assert kernel.attrs["distance_edges"][-1] == pytest.approx(3000.0)
        assert kernel.attrs["uplight"] == 1 and kernel.attrs["turbidity"] == 2.0
    assert run["progress"][-1] == pytest.approx(100.0)


def test_inverse_s_dim_plan_and_observers_through_processing(
    stages_report: dict[str, Any], tmp_path: Path
) -> None:
    """Each algorithm writes what its command writes given the same values (run here on the
    kernel QGIS built)."""
    scene, work = Path(stages_report["scene"]), Path(stages_report["work"])
    emission, kernel = scene / "emission.tif", work / "kernel.nc"
    observer = ["--observer", "501000,6699000", "--kernel", kernel]

    run = stages_report["inverses"]
    assert "error" not in run, run
    layer = run["layer"]
    assert layer["valid"] and layer["crs"] == "EPSG:32635"
    assert layer["pixel"] == pytest.approx([100.0, 100.0])
    command = next(line for line in run["log"] if " inverse s " in line)
    assert "--observer 501000.0,6699000.0 --observer-crs EPSG:32635" in command
    _cli("inverse", "s", emission, tmp_path / "s.tif", *observer, "--region", "zenith:30")
    s = _band(run["outputs"]["OUTPUT"])
    np.testing.assert_array_equal(s, _band(tmp_path / "s.tif"))
    assert np.nanmax(s) > 0.0 and np.isnan(s).sum() == 400 - 10  # NaN where unlit

    run = stages_report["inversedim"]
    assert "error" not in run, run
    rule = ["--qa", "0.0", "--qb", repr(stages_report["qb"]), "--kernel", kernel]
    _cli("inverse", "dim", emission, tmp_path / "dim.tif", "--by", work / "s.tif", *rule)
    dimmed = _band(run["outputs"]["OUTPUT"])
    np.testing.assert_array_equal(dimmed, _band(tmp_path / "dim.tif"))
    assert 0.0 < dimmed.sum() < _band(emission).sum()  # the brightest cells dimmed
    assert np.nanmax(_band(run["outputs"]["DIMMING_OUTPUT"])) == pytest.approx(1.0)
    summary = json.loads(Path(run["outputs"]["SUMMARY_OUTPUT"]).read_text())
    assert 0.0 < summary["flux_removed_percent"] < 100.0

    run = stages_report["inverseplan"]
    assert "error" not in run, run
    command = next(line for line in run["log"] if " inverse plan " in line)
    # the points of the observers' layer, each its own --observer, in the layer's CRS
    assert "--observer 501000.0,6699000.0 --observer 500550.0,6698450.0" in command
    assert "--observer-crs EPSG:32635" in command
    targets = ["--target-zenith", "23.0", "--kernel", kernel]
    points = ["--observer", "501000,6699000", "--observer", "500550,6698450"]
    _cli("inverse", "plan", emission, tmp_path / "plan.tif", *points, *targets)
    np.testing.assert_array_equal(_band(run["outputs"]["OUTPUT"]), _band(tmp_path / "plan.tif"))
    plan = json.loads(Path(run["outputs"]["SUMMARY_OUTPUT"]).read_text())
    for site in plan["observers"]:
        assert site["zenith"]["after_mag_arcsec2"] >= 23.0 - 1e-6

    run = stages_report["skyobservers"]
    assert "error" not in run, run
    layer = run["layer"]
    assert layer["valid"] and layer["features"] == 2 and layer["geometry"] == "Point"
    assert {"name", "zenith_mag", "bortle"} <= set(layer["fields"])
    _cli("sky", "observers", emission, scene / "observers.gpkg", tmp_path / "o.gpkg", *observer[2:])
    import geopandas as gpd

    ours = gpd.read_file(run["outputs"]["SUMMARY"], layer="observers")
    theirs = gpd.read_file(tmp_path / "o.gpkg", layer="observers")
    np.testing.assert_allclose(ours["zenith_mag"], theirs["zenith_mag"], rtol=0, atol=1e-9)
