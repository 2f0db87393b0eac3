"""The plugin in real QGIS: installed from the built zip, two algorithms run with
``processing.run`` on the bundled example, their outputs opened by QGIS, and a cancel of a
run on a worker thread, as the Processing dialog runs it.

QGIS runs in its own interpreter (``/usr/bin/python3`` with Debian's ``python3-qgis``), as it
would for a user: the plugin there runs this environment's ``nightlights`` command, which
``build_plugin`` records in the zip. Skipped when that interpreter has no ``qgis.core``.
"""

from __future__ import annotations

import json
import os
import subprocess
import zipfile
from pathlib import Path
from typing import Any

import pytest

from nightlights.demo import example_path
from nightlights.qgis import PLUGIN_FOLDER, build_plugin

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


@pytest.fixture(scope="module")
def plugins(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The built zip, installed (unzipped) into a QGIS plugin folder."""
    root = tmp_path_factory.mktemp("qgis")
    with zipfile.ZipFile(build_plugin(root / "nightlights.zip")) as archive:
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
    """Emission, skyglow, inverse q and darkness in QGIS, from the light run's outputs."""
    work = tmp_path_factory.mktemp("sky")
    return _run_in_qgis("sky", plugins, report["work"], work)


def test_the_zip_installs_as_a_processing_plugin(report: dict[str, Any]) -> None:
    from nightlights import __version__

    assert report["available"] and report["started"], report["stderr"]
    assert report["metadata"]["version"] == __version__
    assert report["metadata"]["hasProcessingProvider"] == "yes"
    expected = {
        "streetsnormalize",
        "streetssample",
        "streetsplace",
        "streetstolights",
        "irradiance",
        "emission",
        "emissionviirs",
        "skyglow",
        "inverseq",
        "darkness",
    }
    assert set(report["algorithms"]) == {f"nightlights:{name}" for name in expected}
    assert PLUGIN_FOLDER == "nightlights_processing"


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
def test_emission_skyglow_inverse_q_and_darkness_in_qgis(sky_report: dict[str, Any]) -> None:
    """The sky stages in QGIS (slow: the first skyglow and darkness build scene kernels)."""
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
