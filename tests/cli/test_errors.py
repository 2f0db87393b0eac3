"""The CLI's error policy across commands, table-driven.

Every bad input gives one ``Error:`` line and a non-zero exit status (1 for a domain error, 2
for a usage error), no traceback (``-v`` shows one), no file left beside the outputs, and the
previous outputs untouched.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import click
import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner, Result

import nightlights as nl
from nightlights._resources import check_memory, set_memory_limit
from nightlights.io import RasterBand, write_cog
from nightlights_cli.main import cli
from nightlights_cli.reference import walk

DATA = Path(__file__).parents[1] / "data"
IES = DATA / "ies" / "holg__eulumdat-rs" / "OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies"
OSM = DATA / "streets" / "berlin-siegessaeule.osm.gz"
OBSERVER = ["--observer", "501500,6698500"]
PREVIOUS = b"previous output"


# --- inputs built once -----------------------------------------------------------------------


def _invoke(args: list[str], **kwargs) -> Result:
    result = CliRunner().invoke(cli, [str(a) for a in args], **kwargs)
    set_memory_limit(None)  # --max-memory is process-wide; do not leak it into other tests
    return result


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """Small inputs of every stage: streets, lights, an irradiance and an emission raster, a
    kernel, and a Q raster (``inverse dim --by``)."""
    folder = tmp_path_factory.mktemp("inputs")
    import geopandas as gpd
    from shapely.geometry import Point

    lights = folder / "lights.gpkg"
    gpd.GeoDataFrame(
        {
            "light_id": [1, 2],
            "street_id": ["a", "a"],
            "system_id": ["street_led_medium", "road_hps"],
            "heading": [90.0, 270.0],
            "mounting_height": [10.0, 12.0],
            "arm_length": [1.0, 0.5],
            "tilt": [0.0, 5.0],
            "side": ["left", "right"],
            "arrangement": ["opposite", "opposite"],
        },
        geometry=[Point(385_000, 6_672_000), Point(385_020, 6_672_000)],
        crs="EPSG:3067",
    ).to_file(lights, layer="lights", driver="GPKG")
    emission = folder / "emission.tif"
    values = np.zeros((30, 30), np.float32)
    values[10:14, 20:24] = 1.0
    write_cog(
        emission,
        [RasterBand(values, "reflected", "lm m-2")],
        transform=Affine(100, 0, 500_000, 0, -100, 6_700_000),
        crs="EPSG:32635",
    )
    kernel = folder / "kernel.nc"
    spec = nl.KernelSpec(r_min=5, r_max=6000, n_distance=8, n_elevation=4, n_azimuth=16, nodes=8)
    nl.build_kernel(spec, kernel, progress=False, backend="numpy")
    streets, lit, irradiance, q = (folder / n for n in ("s.gpkg", "lit.gpkg", "e.tif", "q.tif"))
    for args in (
        ["streets", "normalize", OSM, streets, "--mapping", "osm"],
        ["streets", "sample", streets, lit, "--seed", "1"],
        ["irradiance", lights, irradiance, "--resolution", "4"],
        ["inverse", "q", emission, q, *OBSERVER, "--kernel", kernel],
    ):
        result = _invoke(args)
        assert result.exit_code == 0, result.output
    return SimpleNamespace(
        lights=lights,
        emission=emission,
        kernel=kernel,
        streets=streets,
        lit=lit,
        irradiance=irradiance,
        q=q,
    )


def files(folder: Path) -> dict[str, bytes | None]:
    return {p.name: None if p.is_dir() else p.read_bytes() for p in folder.iterdir()}


def assert_one_line_error(
    result: Result | SimpleNamespace, exit_code: int, words: list[str]
) -> None:
    """Exit status, one ``Error:`` line with every word (case-insensitive), no traceback."""
    assert result.exit_code == exit_code, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, result.output
    assert "Traceback" not in result.output, result.output
    for word in words:
        assert word.lower() in errors[0].lower(), (word, errors[0])


# --- the table -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """A bad command line: ``args(inputs, out_folder)``, the expected exit status and words."""

    args: Callable[[SimpleNamespace, Path], list]
    exit_code: int
    words: list[str]
    previous: list[str] = field(default_factory=list)  # outputs that exist before the run


READ_ONLY: dict[str, Callable[[SimpleNamespace, Path], list]] = {
    "streets normalize": lambda i, d: [
        "streets",
        "normalize",
        OSM,
        d / "s.gpkg",
        "--mapping",
        "osm",
    ],
    "streets sample": lambda i, d: ["streets", "sample", i.streets, d / "lit.gpkg", "--seed", "1"],
    "streets place": lambda i, d: ["streets", "place", i.lit, d / "poles.gpkg", "--seed", "1"],
    "streets fit": lambda i, d: ["streets", "fit", i.lit, d / "network"],
    "irradiance": lambda i, d: ["irradiance", i.lights, d / "e.tif", "--resolution", "4"],
    "emission ground": lambda i, d: [
        *("emission", "ground", i.irradiance, i.lights, d / "em.tif"),
        *("--resolution", "8", "--albedo", "0.1"),
    ],
    "emission viirs": lambda i, d: ["emission", "viirs", i.emission, d / "v.tif"],
    "kernel build": lambda i, d: [
        *("kernel", "build", d / "k.nc", "--r-min", "5", "--r-max", "6000"),
        *("--n-distance", "16", "--n-elevation", "8", "--n-azimuth", "32"),
    ],
    "skyglow": lambda i, d: ["skyglow", i.emission, d / "p.nc", *OBSERVER, "--kernel", i.kernel],
    "inverse q": lambda i, d: [
        "inverse",
        "q",
        i.emission,
        d / "q.tif",
        *OBSERVER,
        "--kernel",
        i.kernel,
    ],
    "inverse s": lambda i, d: [
        *("inverse", "s", i.emission, d / "s.tif", *OBSERVER, "--kernel", i.kernel),
        *("--region", "horizon:0,90,30"),
    ],
    "inverse dim": lambda i, d: [
        *("inverse", "dim", i.emission, d / "r.tif", "--by", i.q, "--qa", "0", "--qb", "1"),
    ],
    "darkness": lambda i, d: ["darkness", i.emission, d / "d.tif", "--kernel", i.kernel],
    "photometry info --plot": lambda i, d: ["photometry", "info", IES, "--plot", d / "x.png"],
}


@pytest.mark.parametrize("command", list(READ_ONLY))
def test_read_only_output_folder(inputs, tmp_path: Path, command: str, read_only) -> None:
    with read_only(tmp_path / "ro") as folder:
        result = _invoke(READ_ONLY[command](inputs, folder))
        assert_one_line_error(result, 1, [str(folder)])
        reasons = ("permission denied", "not permitted", "read-only")
        assert any(w in result.output.lower() for w in reasons), result.output
        assert files(folder) == {}


EXTRA_OUTPUTS: dict[str, Case] = {
    "skyglow --png": Case(
        lambda i, d: [
            *("skyglow", i.emission, d / "p.nc", *OBSERVER, "--kernel", i.kernel),
            *("--png", d / "nodir" / "p.png", "--overwrite"),
        ],
        1,
        ["nodir", "p.png"],
        previous=["p.nc"],
    ),
    "skyglow --polar-output": Case(
        lambda i, d: [
            *("skyglow", i.emission, d / "p.nc", *OBSERVER, "--kernel", i.kernel),
            *("--polar-output", d / "nodir" / "x.nc", "--overwrite"),
        ],
        1,
        ["nodir", "x.nc"],
        previous=["p.nc"],
    ),
    **{
        f"inverse dim {option}": Case(
            lambda i, d, option=option, name=name: [
                *("inverse", "dim", i.emission, d / "r.tif", "--by", i.q, "--qa", "0"),
                *("--qb", "1", option, d / "nodir" / name, "--overwrite"),
            ],
            1,
            ["nodir", name],
            previous=["r.tif"],
        )
        for option, name in (
            ("--dimming-output", "d.tif"),
            ("--summary-output", "s.json"),
            ("--png", "p.png"),
        )
    },
    "photometry info --plot": Case(
        lambda i, d: ["photometry", "info", IES, "--plot", d / "nodir" / "x.png"],
        1,
        ["nodir", "x.png", "does not exist"],
    ),
    "irradiance OUTPUT": Case(
        lambda i, d: ["irradiance", i.lights, d / "nodir" / "e.tif", "--resolution", "4"],
        1,
        ["nodir", "does not exist"],
    ),
}


@pytest.mark.parametrize("name", list(EXTRA_OUTPUTS))
def test_missing_folder_of_any_output(inputs, tmp_path: Path, name: str) -> None:
    case = EXTRA_OUTPUTS[name]
    for previous in case.previous:
        (tmp_path / previous).write_bytes(PREVIOUS)
    before = files(tmp_path)
    result = _invoke(case.args(inputs, tmp_path))
    assert_one_line_error(result, case.exit_code, case.words)
    assert files(tmp_path) == before


BAD_CRS: dict[str, Callable[[SimpleNamespace, Path], list]] = {
    "streets normalize --crs": lambda i, d: [
        *("streets", "normalize", OSM, d / "s.gpkg", "--mapping", "osm", "--crs", "garbage"),
    ],
    "streets normalize --target-crs": lambda i, d: [
        *("streets", "normalize", OSM, d / "s.gpkg", "--mapping", "osm"),
        *("--target-crs", "garbage"),
    ],
    "irradiance --crs": lambda i, d: [
        *("irradiance", i.lights, d / "e.tif", "--resolution", "4", "--crs", "garbage"),
    ],
    "emission ground --crs": lambda i, d: [
        *("emission", "ground", i.irradiance, i.lights, d / "em.tif"),
        *("--resolution", "8", "--albedo", "0.1", "--crs", "garbage"),
    ],
    "emission viirs --target-crs": lambda i, d: [
        *("emission", "viirs", i.emission, d / "v.tif", "--target-crs", "garbage"),
    ],
    "skyglow --observer-crs": lambda i, d: [
        *("skyglow", i.emission, d / "p.nc", *OBSERVER, "--kernel", i.kernel),
        *("--observer-crs", "garbage"),
    ],
    "inverse q --observer-crs": lambda i, d: [
        *("inverse", "q", i.emission, d / "q.tif", *OBSERVER, "--kernel", i.kernel),
        *("--observer-crs", "garbage"),
    ],
}


@pytest.mark.parametrize("name", list(BAD_CRS))
def test_garbage_crs(inputs, tmp_path: Path, name: str) -> None:
    result = _invoke(BAD_CRS[name](inputs, tmp_path))
    assert result.exit_code in (1, 2), result.output
    assert_one_line_error(result, result.exit_code, ["garbage", "crs"])
    assert files(tmp_path) == {}


HUGE: dict[str, Callable[[SimpleNamespace, Path], list]] = {
    "irradiance --resolution": lambda i, d: [
        *("irradiance", i.lights, d / "e.tif", "--resolution", "0.001"),
    ],
    "kernel build --n-distance": lambda i, d: [
        *("kernel", "build", d / "k.nc", "--n-distance", "1000000"),
    ],
    "kernel build --n-azimuth": lambda i, d: [
        *("kernel", "build", d / "k.nc", "--n-azimuth", "1000000"),
    ],
    # emission viirs: windowed, its memory no longer grows with the output grid (a huge
    # --resolution is refused for its disk space: tests/cli/test_ground_bad_inputs.py)
    "skyglow --n-elevation": lambda i, d: [
        *("skyglow", i.emission, d / "p.nc", *OBSERVER, "--n-elevation", "1000000"),
    ],
    "streets sample --candidates": lambda i, d: [
        *("streets", "sample", i.streets, d / "lit.gpkg", "--candidates", "1000000000"),
    ],
}


#: Runs the oversized requests in a child process whose address space is capped, each under an
#: alarm, so that a stage that does not estimate fails its case instead of the machine.
HUGE_RUNNER = """
import json, resource, signal, sys
from pathlib import Path
resource.setrlimit(resource.RLIMIT_AS, (4 * 1024**3, resource.RLIM_INFINITY))
from click.testing import CliRunner
from nightlights_cli.main import cli

def expire(signum, frame):
    raise TimeoutError("no refusal within 10 s: the request was not estimated")

signal.signal(signal.SIGALRM, expire)
results = {}
for name, (args, folder) in json.loads(sys.argv[1]).items():
    signal.alarm(10)
    try:
        result = CliRunner().invoke(cli, args)
    finally:
        signal.alarm(0)
    left = sorted(p.name for p in Path(folder).iterdir())
    results[name] = [result.exit_code, result.output, left]
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def huge_results(inputs, tmp_path_factory: pytest.TempPathFactory) -> dict[str, list]:
    cases = {}
    for name, make in HUGE.items():
        folder = tmp_path_factory.mktemp("huge")
        args = ["--max-memory", "100M", *(str(a) for a in make(inputs, folder))]
        cases[name] = (args, str(folder))
    done = subprocess.run(
        [sys.executable, "-c", HUGE_RUNNER, json.dumps(cases)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=Path(__file__).parents[2],
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("name", list(HUGE))
def test_max_memory_refuses_an_oversized_request(huge_results, name: str) -> None:
    exit_code, output, left = huge_results[name]
    result = SimpleNamespace(exit_code=exit_code, output=output)
    assert_one_line_error(result, 1, ["ResourceError", "needs about", "100.0 MiB", "--max-memory"])
    assert left == []


# --- what the group does with any exception ----------------------------------------------------


def _raise(exc: BaseException) -> Callable[..., None]:
    def stage(*args, **kwargs) -> None:
        raise exc

    return stage


def _allocate(*args, **kwargs) -> None:
    np.empty(2**60, dtype=np.uint8)


def _needs_a_lot(*args, **kwargs) -> None:
    check_memory(3 * 1024**3, "the test grid", option="--resolution")


def _bad_crs(*args, **kwargs) -> None:
    import pyproj

    pyproj.CRS.from_user_input("garbage")


FAILING_STAGES = {
    "domain error": (_raise(nl.errors.InputError("in.gpkg: no layer 'x'")), [], ["InputError"]),
    "permission error": (
        _raise(PermissionError(13, "Permission denied", "/data/out.tif")),
        [],
        ["PermissionError", "/data/out.tif", "Permission denied"],
    ),
    "numpy allocation": (_allocate, [], ["MemoryError", "Unable to allocate", "--max-memory"]),
    "estimate over --max-memory": (
        _needs_a_lot,
        ["--max-memory", "1G"],
        ["ResourceError", "3.0 GiB", "1.0 GiB", "--resolution", "--max-memory"],
    ),
    "pyproj CRSError": (_bad_crs, [], ["CRSError", "garbage"]),
    "timeout": (_raise(TimeoutError("timed out after 30 s")), [], ["TimeoutError", "30 s"]),
    "bug": (
        _raise(ZeroDivisionError("division by zero")),
        [],
        ["ZeroDivisionError", "run with -v"],
    ),
}


@pytest.mark.parametrize("name", list(FAILING_STAGES))
def test_exceptions_of_a_stage_are_one_line(monkeypatch, tmp_path: Path, name: str) -> None:
    stage, options, words = FAILING_STAGES[name]
    monkeypatch.setattr(nl, "darkness", stage)
    args = [*options, "darkness", str(DATA / "README.md"), str(tmp_path / "d.tif")]
    result = _invoke(args)
    assert_one_line_error(result, 1, words)


def test_verbose_shows_the_traceback(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setattr(nl, "darkness", _raise(ZeroDivisionError("division by zero")))
    args = ["darkness", str(DATA / "README.md"), str(tmp_path / "d.tif")]
    result = _invoke(["-v", *args])
    assert result.exit_code == 1
    assert "Traceback" in result.output and "ZeroDivisionError" in result.output
    assert result.output.rstrip().splitlines()[-1].startswith("Error: ZeroDivisionError")


def test_unreachable_scheduler(inputs, tmp_path: Path) -> None:
    """Every case is in ``test_scheduler_bad_inputs.py``; here the failing stage's line."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{probe.getsockname()[1]}"
    for scheduler, code, words in (
        (address, 1, ["InputError", "--scheduler", address, "connection refused"]),
        ("garbage", 2, ["--scheduler", "'garbage': not a scheduler address"]),
    ):
        result = _invoke(
            [
                *("irradiance", inputs.lights, tmp_path / "e.tif", "--resolution", "4"),
                *("--scheduler", scheduler),
            ]
        )
        assert_one_line_error(result, code, words)
    assert files(tmp_path) == {}


# --- usage errors: exit status 2 ----------------------------------------------------------------


def _float_options() -> list[tuple[list[str], str]]:
    found = []
    for command, ctx in walk(cli, "nightlights"):
        for param in command.params:
            if isinstance(param, click.Option) and isinstance(
                param.type, click.types.FloatParamType
            ):
                found.append((ctx.command_path.split()[1:], param.opts[-1]))
    return found


@pytest.mark.parametrize(("path", "option"), _float_options(), ids=lambda v: str(v))
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_every_float_option_refuses_non_finite_values(path, option: str, value: str) -> None:
    result = _invoke([*path, option, value])
    if "not in the range" in result.output:  # a click.FloatRange refuses infinities itself
        assert_one_line_error(result, 2, [option, value])
    else:
        assert_one_line_error(result, 1, ["InputError", f"{option}={value}", "finite"])


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--max-memory", "lots", "photometry", "info", IES], ["--max-memory", "lots", "8G"]),
        (["--max-memory", "-1G", "photometry", "info", IES], ["--max-memory", "-1G"]),
        (["streets", "sample", OSM, "x.gpkg", "--seed", "-1"], ["--seed", "-1", ">=0"]),
        (["skyglow", "e.tif", "p.nc", "--observer", "1,2,3"], ["--observer", "expected X,Y"]),
        (["irradiance", "missing.gpkg", "e.tif", "--resolution", "4"], ["missing.gpkg"]),
    ],
    ids=["max-memory-text", "max-memory-negative", "seed-negative", "observer-triple", "no-input"],
)
def test_usage_errors(args: list, words: list[str]) -> None:
    assert_one_line_error(_invoke(args), 2, words)


def test_a_malformed_environment_limit_is_reported_before_any_work(
    tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.setenv("NIGHTLIGHTS_MAX_MEMORY", "plenty")
    result = _invoke(["photometry", "info", IES, "--plot", tmp_path / "x.png"])
    assert_one_line_error(result, 1, ["InputError", "NIGHTLIGHTS_MAX_MEMORY", "plenty"])
    assert files(tmp_path) == {}
