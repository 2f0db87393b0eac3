"""Table-driven bad inputs for ``nightlights streets``: each row gives the exit status, key
words of the one-line message, and checks that no file is left behind and a previous output
is untouched (or, for legal but surprising input, that the output is written with a
warning)."""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely
from click.testing import CliRunner

from nightlights.io import write_gpkg
from nightlights_cli.main import cli

PREVIOUS = b"previous output"

# shapely warns when it builds the NaN-vertex lines some rows need
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")


def _raw(path: Path, **overrides) -> Path:
    data = {
        "osm_id": ["1", "2", "3"],
        "highway": ["primary", "residential", "residential"],
        "lanes": ["2", "1", "1"],
        "lit": ["yes", "yes", "no"],
    }
    data.update(overrides)
    lines = [shapely.LineString([(0, 40 * i), (200, 40 * i)]) for i in range(3)]
    frame = gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067")
    frame.to_file(path, driver="GPKG")
    return path


def _sampled(path: Path, **overrides) -> Path:
    data = {
        "source_id": ["a", "b", "c"],
        "width": 8.0,
        "lit": True,
        "arrangement": "single_sided",
        "spacing": 30.0,
        "mounting_height": 8.0,
        "arm_length": 1.0,
        "setback": 1.0,
        "tilt": 0.0,
        "system_id": "road_hps",
    }
    data.update(overrides)
    lines = [shapely.LineString([(0, 40 * i), (300, 40 * i)]) for i in range(3)]
    write_gpkg(gpd.GeoDataFrame(data, geometry=lines, crs="EPSG:3067"), path, layer="streets")
    return path


def _nan_vertex(path: Path) -> Path:
    _raw(path)
    frame = gpd.read_file(path)
    frame.loc[0, "geometry"] = shapely.LineString([(0, 0), (np.nan, 5), (200, 0)])
    frame.to_file(path, driver="GPKG")
    return path


def _mapping(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _catalog(folder: Path, tilt: str) -> Path:
    from ies.library import load_library

    folder.mkdir()
    bundled = load_library().root
    (folder / "lamp.ldt").write_bytes((bundled / "road_luminaire_son_tpp_250w.ldt").read_bytes())
    (folder / "systems.toml").write_text(
        "[systems.road_hps]\n"
        f'description = "t"\nmounting_height = 12.0\narm_length = 1.5\ntilt = {tilt}\n'
        'street_azimuth = 90.0\nphotometry_file = "lamp.ldt"\nspd = "HPS"\n'
        'lumens = 27934.0\nprovenance = "copy"\n'
    )
    return folder


@dataclass
class Case:
    """One bad input: how to build it, the command, and what must happen."""

    id: str
    command: list[str]  # "{in}" is the input made by `make`, "{out}" the output, "{tmp}" tmp
    make: object  # callable(tmp_path) -> input path
    exit_code: int
    words: list[str]
    env: dict[str, str] = field(default_factory=dict)
    extra: object = None  # callable(tmp_path) -> dict of more placeholders


def raw_input(t: Path) -> Path:
    return _raw(t / "raw.gpkg")


def sampled_input(t: Path) -> Path:
    return _sampled(t / "s.gpkg")


def _geographic(path: Path) -> Path:
    _sampled(path)
    frame = gpd.read_file(path).set_crs("EPSG:4326", allow_override=True)
    frame.to_file(path, layer="streets", driver="GPKG")
    return path


NORMALIZE = ["streets", "normalize", "{in}", "{out}", "--overwrite"]
SAMPLE = ["streets", "sample", "{in}", "{out}", "--overwrite", "--seed", "1"]
PLACE = ["streets", "place", "{in}", "{out}", "--overwrite", "--seed", "1"]
MAPPING_UNKNOWN_KEY = 'nmae = "x"\n[fields.lanes]\nsource = ["lanes"]\ntype = "int"\n'

CASES = [
    # --- normalize
    Case("normalize-missing-input", NORMALIZE, lambda t: t / "missing.gpkg", 1, ["no such file"]),
    Case(
        "normalize-mapping-unknown-key",
        [*NORMALIZE, "--mapping", "{mapping}"],
        raw_input,
        1,
        ["MappingError", "unknown top-level key 'nmae'", "expected one of"],
        extra=lambda t: {"mapping": str(_mapping(t / "m.toml", MAPPING_UNKNOWN_KEY))},
    ),
    Case(
        "normalize-mapping-bad-toml",
        [*NORMALIZE, "--mapping", "{mapping}"],
        raw_input,
        1,
        ["MappingError", "not valid TOML"],
        extra=lambda t: {"mapping": str(_mapping(t / "m.toml", "[fields"))},
    ),
    Case(
        "normalize-mapping-bad-type",
        [*NORMALIZE, "--mapping", "{mapping}"],
        raw_input,
        1,
        ["MappingError", "type ['int']"],
        extra=lambda t: {
            "mapping": str(_mapping(t / "m.toml", '[fields.lanes]\nsource = "l"\ntype = ["int"]\n'))
        },
    ),
    Case(
        "normalize-output-folder-missing",
        ["streets", "normalize", "{in}", "{tmp}/nodir/out.gpkg"],
        raw_input,
        1,
        ["nodir"],
    ),
    Case(
        "normalize-lanes-1e9-warns",
        NORMALIZE,
        lambda t: _raw(t / "raw.gpkg", lanes=["1e9", "1e9", "2"]),
        0,
        ["field lanes: 2 values outside", "treated as missing", "out of range"],
    ),
    Case(
        "normalize-nan-vertex-counted",
        NORMALIZE,
        lambda t: _nan_vertex(t / "raw.gpkg"),
        0,
        ["1 line part(s) with NaN or infinite vertex coordinates dropped"],
    ),
    # --- sample
    Case("sample-seed-negative", [*SAMPLE, "--seed", "-1"], raw_input, (1, 2), ["seed", "-1"]),
    Case("sample-candidates-zero", [*SAMPLE, "--candidates", "0"], raw_input, 2, ["--candidates"]),
    Case(
        "sample-candidates-huge",
        [*SAMPLE, "--candidates", "1000000000"],
        lambda t: _sampled(t / "s.gpkg"),
        1,
        ["ResourceError", "1000000000 candidates", "--candidates", "--max-memory"],
        env={"NIGHTLIGHTS_MAX_MEMORY": "2G"},
    ),
    Case(
        "sample-unknown-network",
        [*SAMPLE, "--network", "atlantis"],
        lambda t: _sampled(t / "s.gpkg"),
        1,
        ["atlantis", "europe"],
    ),
    Case(
        "sample-geographic-input",
        SAMPLE,
        lambda t: _geographic(t / "geo.gpkg"),
        1,
        ["InputError", "projected CRS"],
    ),
    # --- place
    Case(
        "place-tilt-1e6",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", tilt=[0.0, 1e6, 0.0]),
        1,
        ["street 'b'", "tilt=1e+06", "[-90, 90] deg"],
    ),
    Case(
        "place-arm-negative",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", arm_length=-50.0),
        1,
        ["street 'a'", "arm_length=-50", "(and 2 more street(s))", "[0, 15] m"],
    ),
    Case(
        "place-mounting-height-1e7",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", mounting_height=1e7),
        1,
        ["mounting_height=1e+07", "(0, 60] m"],
    ),
    Case(
        "place-spacing-tiny",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", spacing=1e-4),
        1,
        ["spacing=0.0001", "[1, 5000] m"],
    ),
    Case(
        "place-spacing-nan",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", spacing=[30.0, np.nan, 30.0]),
        1,
        ["street 'b'", "spacing=nan"],
    ),
    Case(
        "place-too-many-poles",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", spacing=1.0),
        1,
        ["ResourceError", "placing about", "spacing", "--max-memory"],
        env={"NIGHTLIGHTS_MAX_MEMORY": "100K"},
    ),
    Case("place-seed-negative", [*PLACE, "--seed", "-1"], sampled_input, (1, 2), ["seed", "-1"]),
    Case(
        "place-along-jitter-nan",
        [*PLACE, "--along-jitter", "nan"],
        sampled_input,
        (1, 2),
        ["jitter", "nan"],
    ),
    Case(
        "place-across-jitter-huge",
        [*PLACE, "--across-jitter", "1e9"],
        sampled_input,
        1,
        ["--across-jitter=1000000000.0 m", "at most 10 m"],
    ),
    Case(
        "place-unknown-system",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", system_id="gas_lamp"),
        1,
        ["gas_lamp", "not in the luminaire database"],
    ),
    Case(
        "place-catalog-tilt-1e6",
        [*PLACE, "--catalog", "{catalog}"],
        sampled_input,
        1,
        ["LuminaireDatabaseError", "tilt = 1000000.0", "[-90, 90] deg"],
        extra=lambda t: {"catalog": str(_catalog(t / "db", "1e6"))},
    ),
    Case(
        "place-unusual-tilt-warns",
        PLACE,
        lambda t: _sampled(t / "s.gpkg", tilt=50.0),
        0,
        ["tilt: 3 street(s) with unusual values", "usually -15-30 deg"],
    ),
    Case(
        "place-nan-vertex-counted",
        PLACE,
        lambda t: _nan_sampled(t / "s.gpkg"),
        0,
        ["1 lit street part(s) with NaN or infinite vertex coordinates dropped"],
    ),
    # --- fit
    Case(
        "fit-output-parent-missing",
        ["streets", "fit", "{in}", "{tmp}/nodir/net"],
        sampled_input,
        1,
        ["OutputError", "nodir", "does not exist"],
    ),
]


def _not_lines(kind: str):
    """A layer of points or polygons given as the streets of ``streets learn``."""

    def make(t: Path) -> Path:
        shapes = {
            "point": [shapely.Point(10 * i, 0) for i in range(3)],
            "polygon": [shapely.box(0, 40 * i, 200, 40 * i + 8) for i in range(3)],
        }[kind]
        path = t / f"{kind}s.gpkg"
        gpd.GeoDataFrame({"source_id": ["a", "b", "c"]}, geometry=shapes, crs="EPSG:3067").to_file(
            path, driver="GPKG"
        )
        return path

    return make


def _lamps(t: Path) -> dict[str, str]:
    path = t / "lamps.gpkg"
    lamps = [shapely.Point(x, -6) for x in range(10, 200, 20)]
    gpd.GeoDataFrame(geometry=lamps, crs="EPSG:3067").to_file(path, driver="GPKG")
    return {"lamps": str(path)}


LEARN = ["streets", "learn", "{in}", "{lamps}", "{tmp}/net", "--network", "europe"]
CASES += [
    Case(
        "learn-point-streets",
        LEARN,
        _not_lines("point"),
        1,
        ["InputError", "points.gpkg: the streets layer holds Point geometries (3 of 3", "lines"],
        extra=_lamps,
    ),
    Case(
        "learn-polygon-streets",
        LEARN,
        _not_lines("polygon"),
        1,
        ["InputError", "polygons.gpkg", "Polygon geometries", "LineString or MultiLineString"],
        extra=_lamps,
    ),
]


def _nan_sampled(path: Path) -> Path:
    _sampled(path)
    frame = gpd.read_file(path)
    frame.loc[1, "geometry"] = shapely.LineString([(0, 40), (np.nan, 45), (300, 40)])
    frame.to_file(path, layer="streets", driver="GPKG")
    return path


def _build(case: Case, tmp_path: Path) -> tuple[list[str], Path]:
    source = case.make(tmp_path)  # type: ignore[operator]
    out = tmp_path / "out" / "result.gpkg"
    out.parent.mkdir()
    out.write_bytes(PREVIOUS)
    names = {"in": str(source), "out": str(out), "tmp": str(tmp_path)}
    if callable(case.extra):
        names.update(case.extra(tmp_path))
    return [part.format(**names) for part in case.command], out


@pytest.mark.parametrize("case", CASES, ids=[case.id for case in CASES])
def test_bad_input(
    case: Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog, recwarn
) -> None:
    for name, value in case.env.items():
        monkeypatch.setenv(name, value)
    args, out = _build(case, tmp_path)
    before = sorted(os.listdir(out.parent))
    with caplog.at_level(logging.WARNING):
        result = CliRunner().invoke(cli, args, env=case.env)
    codes = case.exit_code if isinstance(case.exit_code, tuple) else (case.exit_code,)
    assert result.exit_code in codes, result.output
    assert "Traceback" not in result.output
    # Warnings reach the terminal through logging (or pytest's recorder, under pytest).
    said = "\n".join([result.output, caplog.text, *(str(w.message) for w in recwarn)])
    for word in case.words:
        assert word in said, said
    if case.exit_code == 0:
        assert out.read_bytes() != PREVIOUS  # written, with the warning above
        return
    if 0 in codes:
        return
    # One line, no file left, the previous output untouched.
    errors = [line for line in result.output.splitlines() if line.strip()]
    assert len(errors) == 1 or result.exit_code == 2, result.output
    assert out.read_bytes() == PREVIOUS
    assert sorted(os.listdir(out.parent)) == before
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
@pytest.mark.parametrize("command", ["normalize", "sample", "place"])
def test_read_only_output_folder_is_one_line_before_any_work(command: str, tmp_path: Path) -> None:
    source = raw_input(tmp_path) if command == "normalize" else sampled_input(tmp_path)
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        result = CliRunner().invoke(cli, ["streets", command, str(source), str(folder / "o.gpkg")])
    finally:
        folder.chmod(0o755)
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert "OutputError" in result.output and "locked" in result.output
    assert list(folder.iterdir()) == []


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
@pytest.mark.parametrize(
    ("command", "output"),
    [
        ("normalize", "/proc/o.gpkg"),
        ("sample", "/proc/o.gpkg"),
        ("place", "/proc/o.gpkg"),
        ("fit", "/proc/nightlights-network"),
    ],
)
def test_unwritable_output_folder_is_one_line_even_for_root(
    command: str, output: str, tmp_path: Path
) -> None:
    source = raw_input(tmp_path) if command == "normalize" else sampled_input(tmp_path)
    result = CliRunner().invoke(cli, ["streets", command, str(source), output])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert "OutputError" in result.output and "/proc" in result.output
    assert len(result.output.strip().splitlines()) == 1


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM")
def test_sigterm_during_the_write_leaves_the_previous_output(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    lines = [shapely.LineString([(0, 100 * i), (10_000, 100 * i)]) for i in range(30)]
    source = tmp_path / "s.gpkg"
    layer = {"source_id": [str(i) for i in range(30)], "width": 8.0, "lit": True}
    layer |= {"arrangement": "opposite", "spacing": 20.0, "mounting_height": 8.0}
    layer |= {"system_id": "road_hps"}
    gpd.GeoDataFrame(layer, geometry=lines, crs="EPSG:3067").to_file(source, layer="streets")
    out = tmp_path / "out"
    out.mkdir()
    (out / "lights.gpkg").write_bytes(PREVIOUS)
    command = [sys.executable, "-m", "nightlights_cli", "streets", "place"]
    command += [str(source), str(out / "lights.gpkg"), "--overwrite", "--seed", "1"]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    signalled = False
    while process.poll() is None:
        # A non-empty temporary: GDAL is writing (an empty one may be a reservation).
        if any(p.name.startswith(".") and _size(p) > 0 for p in out.iterdir()):
            process.send_signal(signal.SIGTERM)
            signalled = True
            break
        time.sleep(0.002)
    process.communicate(timeout=60)
    if not signalled:
        pytest.skip("the write finished before the signal could be sent")
    assert process.returncode != 0
    assert (out / "lights.gpkg").read_bytes() == PREVIOUS
    assert sorted(p.name for p in out.iterdir()) == ["lights.gpkg"]


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0
