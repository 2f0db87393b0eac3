"""Bad inputs of ``irradiance``, ``emission`` and ``emission viirs``, table-driven.

Each row: the arguments, the exit status, key words of the one-line message; and for every
row, no traceback, the previous output untouched (the command runs with ``--overwrite``) and
no file left beside it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin
from shapely.geometry import Point

import nightlights as nl
from nightlights._resources import set_memory_limit
from nightlights_cli.main import cli

PREVIOUS = b"previous output"


def _tif(path: Path, values: np.ndarray, crs: str | None, transform: object, name: str) -> Path:
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=values.shape[0],
        width=values.shape[1],
        count=1,
        dtype="float32",
        crs=crs,
        transform=transform,
        nodata=np.nan,
    ) as dataset:
        dataset.write(values.astype(np.float32), 1)
        dataset.set_band_description(1, name)
    return path


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """Good and bad inputs of the ground commands."""
    folder = tmp_path_factory.mktemp("ground_inputs")
    frame = gpd.GeoDataFrame(
        {"light_id": [1, 2], "system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
        geometry=[Point(385_000, 6_672_000), Point(385_020, 6_672_010)],
        crs="EPSG:3067",
    )
    paths = {"lights": folder / "lights.gpkg"}
    frame.to_file(paths["lights"], driver="GPKG")
    for name, field, value in (
        ("high", "mounting_height", 1e7),
        ("negative_arm", "arm_length", -50.0),
        ("big_tilt", "tilt", 1e6),
        ("inf_tilt", "tilt", np.inf),
        ("inf_heading", "heading", np.inf),
    ):
        bad = frame.copy()
        bad[field] = value
        paths[name] = folder / f"{name}.gpkg"
        bad.to_file(paths[name], driver="GPKG")
    paths["irradiance"] = folder / "irradiance.tif"
    ground = nl.irradiance(frame, paths["irradiance"], resolution=2.0, progress=False).raster
    photopic = ground.data[0]
    for name, change in (("inf", np.inf), ("negative", -3.0)):
        values = photopic.copy()
        values[5, 5] = change
        paths[f"irradiance_{name}"] = _tif(
            folder / f"irradiance_{name}.tif", values, "EPSG:3067", ground.transform, "photopic"
        )
    paths["irradiance_nan"] = _tif(
        folder / "irradiance_nan.tif",
        np.full_like(photopic, np.nan),
        "EPSG:3067",
        ground.transform,
        "photopic",
    )
    geo = from_origin(24.9, 60.2, 0.004, 0.002)
    paths["viirs"] = _tif(folder / "viirs.tif", np.full((8, 8), 20.0), "EPSG:4326", geo, "dnb")
    inf = np.full((8, 8), 20.0)
    inf[2, 2] = np.inf
    paths["viirs_inf"] = _tif(folder / "viirs_inf.tif", inf, "EPSG:4326", geo, "dnb")
    paths["viirs_nan"] = _tif(
        folder / "viirs_nan.tif", np.full((8, 8), np.nan), "EPSG:4326", geo, "dnb"
    )
    paths["viirs_nocrs"] = _tif(folder / "viirs_nocrs.tif", np.full((8, 8), 20.0), None, geo, "d")
    # what is recognisably not radiance: the toolkit's own products, photometric units
    paths["viirs_emission"] = folder / "viirs_emission.tif"
    nl.emission_from_viirs(paths["viirs"], paths["viirs_emission"])
    paths["ground_emission"] = folder / "ground_emission.tif"
    nl.emission(
        paths["irradiance"],
        paths["ground_emission"],
        lights=paths["lights"],
        resolution=20.0,
        albedo=0.2,
    )
    bands = np.full((2, 8, 8), 0.3)
    paths["two_bands"] = nl.io.Raster(
        bands, geo, "EPSG:4326", ("reflected", "uplight"), ("", "")
    ).write(folder / "two_bands.tif")
    paths["viirs_lm"] = nl.io.Raster(
        np.full((1, 8, 8), 0.3), geo, "EPSG:4326", ("flux",), ("lm m-2",)
    ).write(folder / "viirs_lm.tif")
    return SimpleNamespace(**paths)


@dataclass(frozen=True)
class Case:
    """One bad input: arguments ({name} is an input of ``data``, {out} the output), exit
    status, key words of the message, a regular expression it must match (where the CLI and
    the library may name the option differently) and environment variables."""

    name: str
    args: tuple[str, ...]
    code: int
    words: tuple[str, ...]
    env: tuple[tuple[str, str], ...] = ()
    pattern: str = ""


IRR = ("irradiance", "{lights}", "{out}", "--resolution", "2")
EMI = ("emission", "{irradiance}", "{out}", "--resolution", "20", "--albedo", "0.2")
VIIRS = ("emission", "viirs", "{viirs}", "{out}")

CASES = [
    # irradiance: options
    Case("resolution nan", (*IRR[:3], "--resolution", "nan"), 1, ("resolution=nan",)),
    Case("resolution 0", (*IRR[:3], "--resolution", "0"), 1, ("resolution=0", "positive")),
    # streamed to the file, the raster needs no memory but disk space, checked beforehand
    Case("resolution huge disk", (*IRR[:3], "--resolution", "0.0005"), 1,
         ("OutputError", "need about", "of disk space")),
    Case("tiny tiles memory", (*IRR, "--resolution", "0.05", "--tile-size", "1"), 1,
         ("ResourceError", "larger --tile-size")),
    Case("margin nan", (*IRR, "--margin", "nan"), 1, ("margin=nan", "finite")),
    Case("margin negative", (*IRR, "--margin", "-1000"), 1, ("margin=-1000",)),
    Case("max radius nan", (*IRR, "--max-radius", "nan"), 1, (), pattern=r"max.radius=nan"),
    Case("threshold inf", (*IRR, "--threshold", "floor:inf"), 1, ("floor inf lx",)),
    Case("threshold garbage", (*IRR, "--threshold", "floor:x"), 1, ("threshold 'floor:x'",)),
    Case("bounds nan", (*IRR, "--bounds", "0,0,nan,1"), 1, ("bounds=", "finite")),
    Case("bounds three", (*IRR, "--bounds", "0,0,1"), 2, ("four numbers",)),
    Case("bounds inverted", (*IRR, "--bounds", "10,10,0,0"), 1, ("xmin < xmax",)),
    Case("tile size 0", (*IRR, "--tile-size", "0"), 1, ("--tile-size=0",)),
    Case("area height nan", (*IRR, "--area-height", "nan"), 1, (),
         pattern=r"(area-source height|area-height)=nan"),
    Case("area spacing -1", (*IRR, "--area-spacing", "-1"), 1, ("spacing=-1",)),
    Case("sensor unknown", (*IRR, "--sensor", "bogus"), 1, ("sensor 'bogus' is unknown",)),
    Case("crs garbage", (*IRR, "--crs", "garbage"), 1, ("CRSError", "--crs='garbage'")),
    Case("mounting height 1e7", ("irradiance", "{high}", "{out}", "--resolution", "2"), 1,
         ("mounting_height [10000000.0, 10000000.0] m", "(0, 60] m")),
    Case("arm length -50", ("irradiance", "{negative_arm}", "{out}", "--resolution", "2"), 1,
         ("arm_length [-50.0, -50.0] m", "[0, 15] m")),
    Case("tilt 1e6", ("irradiance", "{big_tilt}", "{out}", "--resolution", "2"), 1,
         ("tilt [1000000.0, 1000000.0] deg", "[-90, 90] deg")),
    Case("infinite tilt", ("irradiance", "{inf_tilt}", "{out}", "--resolution", "2"), 1,
         ("have tilt [inf", "finite")),
    Case("infinite heading", ("irradiance", "{inf_heading}", "{out}", "--resolution", "2"), 1,
         ("have heading [inf", "finite")),
    Case("output folder missing", ("irradiance", "{lights}", "{nodir}", "--resolution", "2"), 1,
         ("OutputError", "does not exist")),
    # emission from ground light
    Case("albedo nan", (*EMI[:5], "--albedo", "nan"), 1, ("albedo=nan", "[0, 1]")),
    Case("albedo 1.5", (*EMI[:5], "--albedo", "1.5"), 1, ("albedo=1.5", "[0, 1]")),
    Case("albedo -inf", (*EMI[:5], "--albedo", "-inf"), 1, ("albedo=-inf",)),
    Case("albedo no file", (*EMI[:5], "--albedo", "nofile.tif"), 2,
         ("neither a number nor an existing raster",)),
    Case("emission resolution nan", (*EMI[:3], "--resolution", "nan", "--albedo", "0.2"), 1,
         ("resolution=nan",)),
    Case("emission not a multiple", (*EMI[:3], "--resolution", "3", "--albedo", "0.2"), 1,
         ("not an integer multiple",)),
    Case("irradiance inf", ("emission", "{irradiance_inf}", "{out}", *EMI[3:]), 1,
         ("infinite illuminance",)),
    Case("irradiance negative", ("emission", "{irradiance_negative}", "{out}", *EMI[3:]), 1,
         ("negative illuminance", "min -3")),
    Case("irradiance all nan", ("emission", "{irradiance_nan}", "{out}", *EMI[3:]), 1,
         ("every pixel is nodata",)),
    Case("emission crs garbage", ("emission", "{irradiance}", "{lights}", "{out}", *EMI[3:],
                                  "--crs", "EPSG:0"), 1, ("--crs='EPSG:0'",)),
    Case("emission memory", EMI, 1, ("ResourceError", "emission from", "needs about"),
         env=(("NIGHTLIGHTS_MAX_MEMORY", "1K"),)),
    Case("emission output folder missing", ("emission", "{irradiance}", "{nodir}", *EMI[3:]), 1,
         ("OutputError", "does not exist")),
    # emission from VIIRS
    # streamed window by window: memory is no limit, the disk is
    Case("viirs resolution 0.01", (*VIIRS, "--resolution", "0.01"), 1,
         ("OutputError", "GiB of disk space")),
    Case("viirs resolution inf", (*VIIRS, "--resolution", "inf"), 1, ("resolution=inf",)),
    Case("viirs resolution huge", (*VIIRS, "--resolution", "1e7"), 1,
         ("resolution=1e+07 m is larger than the raster's extent",)),
    Case("viirs target crs garbage", (*VIIRS, "--target-crs", "garbage"), 1,
         ("CRSError", "--target-crs='garbage'")),
    Case("viirs target crs geographic", (*VIIRS, "--target-crs", "EPSG:4326"), 1,
         ("not projected",)),
    Case("viirs inf", ("emission", "viirs", "{viirs_inf}", "{out}"), 1, ("infinite radiance",)),
    Case("viirs all nan", ("emission", "viirs", "{viirs_nan}", "{out}"), 1,
         ("every pixel is nodata",)),
    Case("viirs no crs", ("emission", "viirs", "{viirs_nocrs}", "{out}"), 1, ("has no CRS",)),
    Case("viirs spectrum", (*VIIRS, "--spectrum", "bogus"), 1, ("unknown SPD 'bogus'",)),
    Case("viirs output folder missing", ("emission", "viirs", "{viirs}", "{nodir}"), 1,
         ("OutputError", "does not exist")),
    # not radiance at all: once taken for it, now refused
    Case("viirs of an emission", ("emission", "viirs", "{viirs_emission}", "{out}"), 1,
         ("a nightlights 'emission' raster (tag product), not radiance",
          "give it to the sky stages")),
    Case("viirs of a ground emission", ("emission", "viirs", "{ground_emission}", "{out}"), 1,
         ("a nightlights 'emission' raster", "not radiance")),
    Case("viirs of emission bands", ("emission", "viirs", "{two_bands}", "{out}"), 1,
         ("a nightlights emission raster (its bands: reflected, uplight), not radiance",)),
    Case("viirs in lm m-2", ("emission", "viirs", "{viirs_lm}", "{out}"), 1,
         ("band 1 is in lm m-2, not a radiance",)),
]  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_bad_input(case: Case, data: SimpleNamespace, tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(PREVIOUS)
    names = {**vars(data), "out": out, "nodir": tmp_path / "missing" / "out.tif"}
    args = [arg.format(**names) for arg in case.args]
    if "{nodir}" not in case.args:
        args.append("--overwrite")
    try:
        result = CliRunner().invoke(cli, args, env=dict(case.env))
    finally:
        set_memory_limit(None)
    assert result.exit_code == case.code, result.output
    assert "Traceback" not in result.output
    message = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(message) == 1, result.output
    for word in case.words:
        assert word in message[0], (word, message[0])
    assert re.search(case.pattern, message[0]), (case.pattern, message[0])
    assert out.read_bytes() == PREVIOUS
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.tif"]


def _radiance(
    folder: Path, name: str, changes: dict[tuple[int, int], float], **grid: float
) -> Path:
    """An 8 x 8 geographic radiance raster of 20 nW cm-2 sr-1 with some pixels changed."""
    values = np.full((8, 8), 20.0)
    for (row, col), value in changes.items():
        values[row, col] = value
    west, north = grid.get("west", 24.9), grid.get("north", 60.2)
    transform = from_origin(west, north, grid.get("width", 0.004), grid.get("height", 0.002))
    return _tif(folder / name, values, "EPSG:4326", transform, "dnb")


#: (name, changed pixels, grid, words of the warning, whether the flux is the city's alone):
#: usable input that is suspicious is converted, and said so on one line.
WARNINGS = [
    ("fill 65535", {(0, c): 65535.0 for c in range(4)}, {},
     ("4 pixels hold a common fill value the file does not declare as nodata", "65535 x4",
      "treated as nodata"), True),
    ("fill -999", {(1, 1): -999.0, (2, 2): -999.0}, {}, ("-999 x2", "treated as nodata"), True),
    ("fill 1e20", {(3, 3): 1e20}, {}, ("1e+20 x1", "treated as nodata"), True),
    ("implausible radiance", {(4, 4): 5e4}, {},
     ("1 pixel holds radiances above 10000 nW cm-2 sr-1 (50000 x1", "taken as radiance"), False),
]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "changes", "grid", "words", "city"), WARNINGS, ids=[w[0] for w in WARNINGS]
)
def test_suspicious_viirs_is_converted_with_a_warning(
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    name: str,
    changes: dict[tuple[int, int], float],
    grid: dict[str, float],
    words: tuple[str, ...],
    city: bool,
) -> None:
    source = _radiance(tmp_path, "dnb.tif", changes, **grid)
    with caplog.at_level("WARNING"):
        result = CliRunner().invoke(
            cli, ["emission", "viirs", str(source), str(tmp_path / "e.tif")]
        )
    assert result.exit_code == 0, result.output
    warned = [r.getMessage() for r in caplog.records if "DataQualityWarning" in r.getMessage()]
    assert len(warned) == 1, warned
    for word in words:
        assert word in warned[0], (word, warned[0])
    if city:  # the fill pixels add no light: at most the flux of the plain raster
        plain = nl.emission_from_viirs(_radiance(tmp_path, "plain.tif", {}, **grid))
        with rasterio.open(tmp_path / "e.tif") as dataset:
            total = float(np.nansum(dataset.read(1))) * abs(
                dataset.transform.a * dataset.transform.e
            )
        assert 0 < total < plain.total_flux["upward"]


def test_plain_viirs_is_converted_without_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    source = _radiance(tmp_path, "dnb.tif", {})
    with caplog.at_level("WARNING"):
        result = CliRunner().invoke(
            cli, ["emission", "viirs", str(source), str(tmp_path / "e.tif")]
        )
    assert result.exit_code == 0, result.output
    assert "DataQualityWarning" not in caplog.text


def test_a_stack_of_bands_is_read_from_band_one_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    stack = nl.io.Raster(
        np.stack([np.full((8, 8), 20.0), np.full((8, 8), 12.0)]),
        from_origin(24.9, 60.2, 0.004, 0.002),
        "EPSG:4326",
        ("avg_rade9h", "cf_cvg"),
        ("nW cm-2 sr-1", "1"),
    ).write(tmp_path / "stack.tif")
    with caplog.at_level("WARNING"):
        result = CliRunner().invoke(cli, ["emission", "viirs", str(stack), str(tmp_path / "e.tif")])
    assert result.exit_code == 0, result.output
    assert "stack.tif: 2 bands; band 1 (avg_rade9h) is read as radiance, band 2 is ignored" in (
        caplog.text
    )
