"""The toolkit's outputs opened in real QGIS: valid layer, CRS, extent, default style, a
rendered map that is not blank.

QGIS runs in the system Python (``/usr/bin/python3`` with Debian's ``python3-qgis``) in a
subprocess on files the toolkit wrote (``qgis_open.py`` beside this file), never in the
toolkit's own interpreter. Skipped when that Python cannot import ``qgis.core``.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pytest
import xarray as xr
from affine import Affine
from shapely.geometry import LineString, Point

from nightlights.io import Raster, write_gpkg
from nightlights.io.styles import observers_style, poles_style, streets_style
from nightlights.sky.forward import panorama_coords
from nightlights.sky.polar import PolarMap
from nightlights.sky.spec import panorama_elevations
from nightlights.sky.stage import panorama_raster, polar_raster
from nightlights.streets.schema import ARRANGEMENTS

SYSTEM_PYTHON = "/usr/bin/python3"
SCRIPT = Path(__file__).with_name("qgis_open.py")
#: Time QGIS may take to start and open the layers [s] (about 6 s alone on a shared machine).
TIMEOUT_S = 300


def _qgis_missing() -> str | None:
    if not Path(SYSTEM_PYTHON).exists():
        return f"{SYSTEM_PYTHON} does not exist"
    probe = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import qgis.core"], capture_output=True, text=True, check=False
    )
    if probe.returncode:
        last = (probe.stderr.strip().splitlines() or ["no message"])[-1]
        return f"{SYSTEM_PYTHON} cannot import qgis.core ({last}); install python3-qgis"
    return None


MISSING = _qgis_missing()
pytestmark = pytest.mark.skipif(MISSING is not None, reason=f"real QGIS: {MISSING}")


def open_in_qgis(*sources: str | Path) -> dict[str, dict[str, Any]]:
    """What QGIS sees of each source (``qgis_open.py``), keyed by the source text."""
    env = {key: value for key, value in os.environ.items() if not key.startswith("PYTHON")}
    env["QT_QPA_PLATFORM"] = "offscreen"
    env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    done = subprocess.run(
        [SYSTEM_PYTHON, str(SCRIPT), *map(str, sources)],
        capture_output=True,
        text=True,
        env=env,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    reports = json.loads(done.stdout)["layers"]
    return {report["source"]: report for report in reports}


def _check_layer(report: dict[str, Any], *, crs: str | None, renderer: str) -> None:
    assert report["valid"], report.get("error")
    assert report["crs_valid"]
    if crs is not None:
        assert report["crs_authid"] == crs
    assert report["renderer"] == renderer
    assert report["painted"] > 0 and report["colours"] > 1  # a map, not a blank image


TRANSFORM = Affine(10.0, 0.0, 385_000.0, 0.0, -10.0, 6_672_000.0)
CRS = "EPSG:32635"


def _ground(rows: int = 40, cols: int = 30) -> np.ndarray:
    """A lit blob: values over four decades, zero at the edges."""
    y, x = np.mgrid[0:rows, 0:cols]
    r2 = (y - rows / 2) ** 2 + (x - cols / 2) ** 2
    values = 50.0 * np.exp(-r2 / 60.0)
    return np.where(values > 1e-3, values, 0.0)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One small output of every kind, written by the toolkit's writers."""
    folder = tmp_path_factory.mktemp("qgis")
    ground = _ground()
    lit = ground > 0
    paths: dict[str, Path] = {}

    def raster(
        name: str,
        bands: list[np.ndarray],
        names: tuple[str, ...],
        units: tuple[str, ...],
        tags: dict[str, str] | None = None,
    ) -> None:
        paths[name] = Raster(np.stack(bands), TRANSFORM, CRS, names, units, tags or {}).write(
            folder / f"{name}.tif"
        )

    raster("irradiance", [ground, ground * 2e-3], ("photopic", "scotopic"), ("lx", "W m-2"))
    raster("emission", [ground * 0.15, ground * 0.01], ("reflected", "uplight"), ("lm m-2",) * 2)
    luminance = np.where(lit, ground * 1e-5 + 1e-7, 1e-7)
    raster(
        "darkness",
        [luminance, -2.5 * np.log10(luminance / 1.08e5)],
        ("zenith_luminance", "zenith_sky_brightness"),
        ("cd m-2", "mag arcsec-2"),
    )
    q = np.where(lit, ground * 1e-7, np.nan)
    raster("inverse_q", [q], ("zenith_luminance",), ("cd m-2",), {"metric": "zenith"})
    raster("dimming", [np.where(lit, np.clip(ground / 50.0, 0, 1), np.nan)], ("dimming",), ("1",))

    elevation = panorama_elevations(16)
    azimuth = (np.arange(64) + 0.5) * 360.0 / 64
    sky = (
        1e-4
        * (1.0 + np.cos(np.radians(azimuth - 120.0)))[None, :]
        * (1.2 - elevation / 90.0)[:, None]
    )
    panorama = xr.Dataset(
        {
            "luminance": (("elevation", "azimuth"), sky, {"units": "cd m-2"}),
            "sky_brightness": (
                ("elevation", "azimuth"),
                -2.5 * np.log10(sky / 1.08e5),
                {"units": "mag arcsec-2"},
            ),
        },
        coords=panorama_coords(elevation, azimuth),
        attrs={"observer_x": 385_150.0, "observer_y": 6_671_800.0, "crs": CRS},
    )
    paths["panorama"] = panorama_raster(panorama).write(folder / "panorama.tif")
    flux = np.outer(np.linspace(5.0, 1.0, 8), 1.0 + np.sin(np.radians(azimuth)))[None]
    polar = PolarMap(flux, np.geomspace(10.0, 2000.0, 9), 64, np.zeros(1), flux.sum(axis=(1, 2)))
    paths["polar"] = polar_raster(polar, (385_150.0, 6_671_800.0), CRS, half_cells=64).write(
        folder / "polar.tif"
    )

    lights = gpd.GeoDataFrame(
        {
            "system_id": ["street_led_small", "road_hps", "street_led_small", "post_top_led"],
            "heading": [0.0, 90.0, 180.0, 270.0],
        },
        geometry=[Point(385_000 + 40 * i, 6_671_800 + 25 * (i % 2)) for i in range(4)],
        crs=CRS,
    )
    paths["lights"] = write_gpkg(
        lights, folder / "lights.gpkg", layer="lights", style=poles_style(lights["system_id"])
    )
    streets = gpd.GeoDataFrame(
        {"arrangement": ["single_sided", "opposite", None]},
        geometry=[
            LineString([(385_000, 6_671_700 + 50 * i), (385_300, 6_671_760)]) for i in range(3)
        ],
        crs=CRS,
    )
    paths["streets"] = write_gpkg(
        streets, folder / "streets.gpkg", layer="streets", style=streets_style(ARRANGEMENTS)
    )
    observers = gpd.GeoDataFrame(
        {"name": ["park", "harbour", "fort"], "zenith_mag": [18.6, 19.9, 21.95]},
        geometry=[Point(385_000 + 100 * i, 6_671_800 - 60 * i) for i in range(3)],
        crs=CRS,
    )
    paths["observers"] = write_gpkg(
        observers, folder / "observers.gpkg", layer="observers", style=observers_style()
    )
    return paths


@pytest.fixture(scope="module")
def seen(outputs: dict[str, Path]) -> dict[str, dict[str, Any]]:
    sources = {
        name: f"{path}|layername={name}" if path.suffix == ".gpkg" else str(path)
        for name, path in outputs.items()
    }
    reports = open_in_qgis(*sources.values())
    return {name: reports[source] for name, source in sources.items()}


@pytest.mark.parametrize(
    ("name", "band", "first_label"),
    [
        ("irradiance", 1, "lx"),
        ("emission", 1, "lm m-2"),
        ("darkness", 2, "Bortle 9"),
        ("inverse_q", 1, "0-10 % of lit cells"),
        ("dimming", 1, "0 (unchanged)"),
    ],
)
def test_rasters_open_with_their_style(
    seen: dict[str, dict[str, Any]], name: str, band: int, first_label: str
) -> None:
    report = seen[name]
    _check_layer(report, crs=CRS, renderer="singlebandpseudocolor")
    assert report["extent"] == pytest.approx([385_000.0, 6_671_600.0, 385_300.0, 6_672_000.0])
    assert report["band"] == [band]
    assert first_label in report["ramp"][0][2]
    zero_transparent = [[0.0, 0.0, 100.0]] if name in ("irradiance", "emission") else []
    assert report["transparent_values"] == zero_transparent


def test_a_panorama_opens_on_its_azimuth_elevation_grid(seen: dict[str, dict[str, Any]]) -> None:
    report = seen["panorama"]
    _check_layer(report, crs=None, renderer="singlebandpseudocolor")
    assert report["extent"] == pytest.approx([0.0, 0.0, 360.0, 90.0])
    assert "sky of an observer" in report["crs_wkt"]
    assert report["bands"] == ["Band 1: luminance", "Band 2: sky_brightness"]
    assert report["band"] == [2] and report["ramp"][0][2].startswith("Bortle 9")


def test_a_polar_map_opens_around_the_observer(seen: dict[str, dict[str, Any]]) -> None:
    report = seen["polar"]
    _check_layer(report, crs=CRS, renderer="singlebandpseudocolor")
    assert report["extent"] == pytest.approx(
        [385_150.0 - 2000, 6_671_800.0 - 2000, 385_150.0 + 2000, 6_671_800.0 + 2000]
    )
    assert report["ramp"][0][2].endswith("lm m-2")


def test_poles_are_arrows_turned_by_heading_and_coloured_by_system(
    seen: dict[str, dict[str, Any]],
) -> None:
    report = seen["lights"]
    _check_layer(report, crs=CRS, renderer="categorizedSymbol")
    assert report["attribute"] == "system_id" and report["data_defined"] == "heading"
    assert report["classes"] == ["street_led_small", "road_hps", "post_top_led", ""]
    assert report["features"] == 4


def test_streets_are_coloured_by_arrangement(seen: dict[str, dict[str, Any]]) -> None:
    report = seen["streets"]
    _check_layer(report, crs=CRS, renderer="categorizedSymbol")
    assert report["attribute"] == "arrangement" and report["classes"] == [*ARRANGEMENTS, ""]


def test_observers_are_coloured_by_bortle_class_and_labelled(
    seen: dict[str, dict[str, Any]],
) -> None:
    report = seen["observers"]
    _check_layer(report, crs=CRS, renderer="graduatedSymbol")
    assert report["attribute"] == "zenith_mag" and report["labels"]
    assert len(report["classes"]) == 9


def validate_cogs(*rasters: Path) -> dict[str, list[str]]:
    """GDAL's Cloud-Optimised GeoTIFF validator (``validate_cloud_optimized_geotiff``, full
    check) in the system Python: errors and warnings per file."""
    code = (
        "import json, sys\n"
        "from osgeo_utils.samples.validate_cloud_optimized_geotiff import validate\n"
        "out = {}\n"
        "for path in sys.argv[1:]:\n"
        "    warnings, errors, _ = validate(path, full_check=True)\n"
        "    out[path] = errors + warnings\n"
        "print(json.dumps(out))"
    )
    done = subprocess.run(
        [SYSTEM_PYTHON, "-c", code, *map(str, rasters)], capture_output=True, text=True, check=True
    )
    return dict(json.loads(done.stdout))


def test_rasters_are_valid_cloud_optimised_geotiffs(outputs: dict[str, Path]) -> None:
    rasters = [path for path in outputs.values() if path.suffix == ".tif"]
    assert validate_cogs(*rasters) == {str(path): [] for path in rasters}


def test_geopackages_open_without_a_version_warning(outputs: dict[str, Path]) -> None:
    """GDAL 3.6 (QGIS's, in the system Python) opens the GeoPackages without a warning."""
    code = (
        "import sys; from osgeo import gdal; messages = []\n"
        "gdal.PushErrorHandler(lambda level, number, text: messages.append(text))\n"
        "[gdal.OpenEx(p) for p in sys.argv[1:]]\n"
        "print(gdal.__version__); print('|'.join(messages))"
    )
    gpkgs = [str(path) for path in outputs.values() if path.suffix == ".gpkg"]
    done = subprocess.run(
        [SYSTEM_PYTHON, "-c", code, *gpkgs], capture_output=True, text=True, check=True
    )
    version, messages = done.stdout.splitlines()[:2]
    assert version and messages == "", messages


def test_every_output_of_the_demo_opens_styled_in_qgis(tmp_path: Path) -> None:
    """The bundled demo project (20-80 s: less once its kernel is cached), then every raster
    and layer it wrote, and its panoramas as GeoTIFF, opened in QGIS (run by default: it is
    the acceptance that every demo output opens styled)."""
    from nightlights.demo import run_demo

    folder = tmp_path / "demo"
    run_demo(folder)
    for panorama in sorted(folder.glob("skyglow_*.nc")):
        with xr.open_dataset(panorama, engine="h5netcdf") as dataset:
            panorama_raster(dataset.load()).write(panorama.with_suffix(".tif"))
    rasters = sorted(folder.glob("*.tif"))
    layers = [
        f"{path}|layername={name}"
        for path in sorted(folder.glob("*.gpkg"))
        for name in _layer_names(path)
    ]
    assert len(rasters) >= 8 and len(layers) >= 3
    assert validate_cogs(*rasters) == {str(path): [] for path in rasters}
    reports = open_in_qgis(*rasters, *layers)
    for raster in rasters:
        report = reports[str(raster)]
        assert raster.with_suffix(".qml").exists(), f"{raster.name}: no style beside it"
        crs = None if raster.name.startswith("skyglow_") else CRS
        _check_layer(report, crs=crs, renderer="singlebandpseudocolor")
    for layer in layers:
        report = reports[layer]
        _check_layer(report, crs=CRS, renderer=report["renderer"])
        assert report["renderer"] in ("categorizedSymbol", "graduatedSymbol"), layer


def _layer_names(path: Path) -> list[str]:
    import pyogrio

    return [str(name) for name, _ in pyogrio.list_layers(path) if name != "layer_styles"]
