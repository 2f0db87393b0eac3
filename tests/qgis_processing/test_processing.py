"""The plugin in real QGIS: installed from the built zip, two algorithms run with
``processing.run`` on the bundled example, their outputs opened by QGIS, and a cancel.

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


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Build the zip, install it into a plugin folder, run the QGIS script on the example."""
    root = tmp_path_factory.mktemp("qgis")
    plugins = root / "plugins"
    work = root / "work"
    work.mkdir()
    with zipfile.ZipFile(build_plugin(root / "nightlights.zip")) as archive:
        archive.extractall(plugins)
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "XDG_RUNTIME_DIR": str(root)}
    env.pop("NIGHTLIGHTS_COMMAND", None)  # the command recorded in the zip is the one used
    done = subprocess.run(
        [QGIS_PYTHON, str(SCRIPT), str(plugins), f"{example_path()}|layername=lines", str(work)],
        capture_output=True,
        text=True,
        env=env,
        cwd=root,
        timeout=600,
        check=False,
    )
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0 and lines, done.stdout[-3000:] + done.stderr[-3000:]
    return dict(json.loads(lines[-1]), work=str(work), stderr=done.stderr[-3000:])


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


def test_cancel_stops_the_command_and_leaves_no_output(report: dict[str, Any]) -> None:
    run = report["cancelled"]
    assert "cancelled" in run.get("error", ""), run
    assert not (Path(report["work"]) / "cancelled.tif").exists()
    assert list(Path(report["work"]).glob("cancelled*")) == []
