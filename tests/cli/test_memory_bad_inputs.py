"""Every stage estimates its memory before it allocates and obeys ``--max-memory``, table-driven.

Each row is one stage: a request over the limit given with the command's own ``--max-memory``
(a size that would take minutes and many GiB, or, where the size is the input's, a limit below
the input's estimate) must be refused with one ``ResourceError`` line, before any large
allocation (the refusals run in a child process whose address space is capped at 4 GiB, each
under a 20 s alarm) and leave no file; the same stage on a small request passes the check under
the same kind of limit and writes its output.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import pytest
import rasterio
import shapely
from affine import Affine
from click.testing import CliRunner

from nightlights._resources import set_memory_limit
from nightlights.explore import _app
from nightlights.io import Raster, write_gpkg
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli

from .conftest import Recorder

DATA = Path(__file__).parents[1] / "data"
OSM = DATA / "streets" / "berlin-siegessaeule.osm.gz"
TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)  # 20 x 20 cells of 100 m
OBSERVER = "--observer 501500,6698500"
#: An observer on the 200 000 x 200 000 rasters.
FAR = "--observer 301000,6999000"


def _sparse(path: Path, size: int, crs: str, transform: Affine, band: str, unit: str) -> Path:
    """A ``size`` x ``size`` GeoTIFF of which one block is written (a few MB on disk)."""
    with rasterio.open(
        path, "w", driver="GTiff", width=size, height=size, count=1, dtype="float32", crs=crs,
        transform=transform, tiled=True, blockxsize=512, blockysize=512, compress="deflate",
        sparse_ok=True,
    ) as dataset:  # fmt: skip
        block = np.zeros((512, 512), np.float32)
        block[100:103, 200:203] = 1.0
        dataset.write(block, 1, window=rasterio.windows.Window(1024, 1024, 512, 512))
        dataset.set_band_description(1, band)
        dataset.update_tags(1, units=unit)
    return path


def _streets(path: Path, length: float, spacing: float) -> Path:
    """Three lit streets of ``length`` metres with poles every ``spacing`` metres."""
    lines = [shapely.LineString([(0, 40 * i), (length, 40 * i)]) for i in range(3)]
    frame = gpd.GeoDataFrame(
        {"source_id": ["a", "b", "c"], "width": 8.0, "lit": True, "arrangement": "single_sided",
         "spacing": spacing, "mounting_height": 8.0, "arm_length": 1.0, "setback": 1.0,
         "tilt": 0.0, "system_id": "road_hps"},
        geometry=lines, crs="EPSG:3067",
    )  # fmt: skip
    write_gpkg(frame, path, layer="streets")
    return path


def _points(path: Path, xy: np.ndarray, crs: str) -> Path:
    gpd.GeoDataFrame(geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=crs).to_file(path)
    return path


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """Small inputs of every stage, and rasters of 200 000 x 200 000 cells."""
    folder = tmp_path_factory.mktemp("memory_inputs")
    flux = np.zeros((1, 20, 20))
    flux[0, 4:7, 14:17] = 2.0
    emission = Raster(flux, TRANSFORM, "EPSG:32635", ("reflected",), ("lm m-2",))
    emission = emission.write(folder / "emission.tif")
    kernel = folder / "kernel.nc"
    spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    build_kernel(spec, kernel, progress=False)
    lights = folder / "lights.gpkg"
    gpd.GeoDataFrame(
        {"system_id": ["street_led_small"] * 2, "heading": [0.0, 180.0]},
        geometry=[shapely.Point(385_000, 6_672_000), shapely.Point(385_020, 6_672_010)],
        crs="EPSG:3067",
    ).to_file(lights, driver="GPKG")
    streets, irradiance, q = folder / "streets.gpkg", folder / "irr.tif", folder / "q.tif"
    for args in (
        ["streets", "normalize", OSM, streets, "--mapping", "osm"],
        ["irradiance", lights, irradiance, "--resolution", "2"],
        ["inverse", "q", emission, q, *OBSERVER.split(), "--kernel", kernel],
    ):
        result = CliRunner().invoke(cli, [str(a) for a in args])
        assert result.exit_code == 0, result.output
    viirs = folder / "viirs.tif"
    with rasterio.open(
        viirs, "w", driver="GTiff", width=8, height=8, count=1, dtype="float32",
        crs="EPSG:4326", transform=Affine(0.004, 0, 24.9, 0, -0.002, 60.2),
    ) as dataset:  # fmt: skip
        dataset.write(np.full((1, 8, 8), 20.0, np.float32))
        dataset.set_band_description(1, "dnb")
    learn_streets = folder / "learn_streets.gpkg"
    gpd.GeoDataFrame(
        {"source_id": ["a"], "street_class": ["local"], "street_class_observed": [True]},
        geometry=[shapely.LineString([(0, 0), (200, 0)])], crs="EPSG:3067",
    ).to_file(learn_streets, driver="GPKG")  # fmt: skip
    lamps = _points(
        folder / "lamps.gpkg", np.array([(x, -6.0) for x in range(10, 200, 20)]), "EPSG:3067"
    )
    rng = np.random.default_rng(0)
    many = np.column_stack([500_100 + rng.random(2000) * 1800, 6_698_100 + rng.random(2000) * 1800])
    return SimpleNamespace(
        emission=emission,
        kernel=kernel,
        lights=lights,
        streets=streets,
        irradiance=irradiance,
        q=q,
        viirs=viirs,
        learn_streets=learn_streets,
        lamps=lamps,
        sampled=_streets(folder / "sampled.gpkg", 300.0, 30.0),
        long_streets=_streets(folder / "long.gpkg", 1e8, 1.0),
        observers=_points(folder / "observers.gpkg", many[:3], "EPSG:32635"),
        many_observers=_points(folder / "many_observers.gpkg", many, "EPSG:32635"),
        huge_emission=_sparse(
            folder / "huge_emission.tif", 200_000, "EPSG:32635",
            Affine(10, 0, 300_000, 0, -10, 7_000_000), "reflected", "lm m-2",
        ),
        huge_irradiance=_sparse(
            folder / "huge_irradiance.tif", 200_000, "EPSG:3067",
            Affine(1, 0, 300_000, 0, -1, 6_800_000), "photopic", "lx",
        ),
    )  # fmt: skip


#: Per stage: (the request over the limit, its --max-memory, key words of the refusal; the
#: small request that passes the same kind of limit). ``{name}`` is an input of the fixture,
#: ``{out}`` the folder of the outputs.
STAGES: dict[str, tuple[str, str, list[str], str]] = {
    "streets normalize": (
        "streets normalize {osm} {out}/s.gpkg --mapping osm",
        "10K",
        ["reading", "berlin-siegessaeule.osm.gz", "read a smaller extract"],
        "streets normalize {osm} {out}/s.gpkg --mapping osm",
    ),
    "streets sample": (
        "streets sample {streets} {out}/l.gpkg --candidates 1000000000",
        "1G",
        ["sampling 124 street segments with 1000000000 candidates", "--candidates"],
        "streets sample {streets} {out}/l.gpkg --seed 1",
    ),
    "streets fit": (
        "streets fit {streets} {out}/net",
        "10K",
        ["reading", "streets.gpkg"],
        "streets fit {streets} {out}/net",
    ),
    "streets learn": (
        "streets learn {learn_streets} {lamps} {out}/net --network europe --max-distance 1e9",
        "50K",
        ["learning from 10 lamps (about 10 lamp-street pairs", "--max-distance"],
        "streets learn {learn_streets} {lamps} {out}/net --network europe --seed 1",
    ),
    "streets place": (
        "streets place {long_streets} {out}/p.gpkg --seed 1",
        "1G",
        ["placing about 3e+08 luminaires", "spacing"],
        "streets place {sampled} {out}/p.gpkg --seed 1",
    ),
    "irradiance": (
        "irradiance {lights} {out}/e.tif --resolution 0.05 --tile-size 1",
        "1G",
        ["the irradiance raster of", "--tile-size"],
        "irradiance {lights} {out}/e.tif --resolution 2",
    ),
    # emission ground is windowed: a raster of any size needs a read, a window and the
    # writer's cache (about 0.45 GiB), refused under a limit below that
    "emission ground": (
        "emission ground {huge_irradiance} {out}/em.tif --resolution 20 --albedo 0.2",
        "100M",
        ["emission from", "200000 x 200000 pixels"],
        "emission ground {irradiance} {out}/em.tif --resolution 8 --albedo 0.2",
    ),
    # emission viirs is windowed: its memory does not grow with the output grid, and a huge
    # --resolution is refused for its disk space (tests/cli/test_ground_bad_inputs.py)
    "kernel build": (
        "kernel build {out}/k.nc --n-distance 1000000",
        "1G",
        ["the kernel of", "--n-distance"],
        "kernel build {out}/k.nc --r-max 3000 --n-distance 8 --n-elevation 8 --n-azimuth 16",
    ),
    "skyglow": (
        "skyglow {emission} {out}/p.nc {observer} --n-elevation 1000000",
        "1G",
        ["the kernel of", "--n-elevation"],
        "skyglow {emission} {out}/p.nc {observer} --kernel {kernel}",
    ),
    # inverse q and s read the window the kernel reaches: a scene kernel's 300 km
    "inverse q": (
        "inverse q {huge_emission} {out}/q.tif {far}",
        "1G",
        ["the pca-norm raster of 30100 x 30100 cells"],
        "inverse q {emission} {out}/q.tif {observer} --kernel {kernel}",
    ),
    "inverse s": (
        "inverse s {huge_emission} {out}/s.tif {far} --region zenith:30",
        "1G",
        ["the region raster of 30100 x 30100 cells"],
        "inverse s {emission} {out}/s.tif {observer} --kernel {kernel} --region zenith:30",
    ),
    "inverse dim": (
        "inverse dim {huge_emission} {out}/r.tif --kernel {kernel} --by {q} --qa 0 --qb 1",
        "1G",
        ["dimming the 200000 x 200000 emission raster"],
        "inverse dim {emission} {out}/r.tif --kernel {kernel} --by {q} --qa 0 --qb 1e-9",
    ),
    "inverse plan": (
        "inverse plan {huge_emission} {out}/r.tif --target-zenith 21 {far} --kernel {kernel}",
        "1G",
        ["dimming the 200000 x 200000 emission raster"],
        "inverse plan {emission} {out}/r.tif --target-zenith 30 {observer} --kernel {kernel} "
        "--max-dimming 1",
    ),
    "darkness": (
        # the whole-raster map (the tiled one's memory does not grow with the raster)
        "darkness {huge_emission} {out}/z.tif --kernel {kernel} --in-memory",
        "1G",
        ["the darkness map of 200000 x 200000 cells", "coarsen or crop"],
        "darkness {emission} {out}/z.tif --kernel {kernel}",
    ),
    "sky observers": (
        "sky observers {emission} {many_observers} {out}/o.gpkg --kernel {kernel} --top-cells 662",
        "100M",
        [
            "computing the skies of 2000 observers over 9 lit cells (662 top cells each",
            "--top-cells",
        ],
        "sky observers {emission} {observers} {out}/o.gpkg --kernel {kernel} --top-cells 662",
    ),
    "sky render": (
        "sky render {out}/sky.png --time 2026-01-25T20:00:00Z --lonlat 24.95,60.17 --width 2000000",
        "1G",
        ["the sky picture of 2000000 x 512 pixels", "--width"],
        "sky render {out}/sky.png --time 2026-01-25T20:00:00Z --lonlat 24.95,60.17 "
        "--width 256 --height 64",
    ),
    "explore": (
        "explore {huge_emission} --kernel {kernel} --port 0 --no-browser --export-dir {out}",
        "1G",
        ["an explore session of the 200000 x 200000 cells", "coarsen or crop"],
        "explore {emission} --kernel {kernel} --port 0 --no-browser --export-dir {out}",
    ),
}


def _args(template: str, inputs: SimpleNamespace, out: Path, limit: str) -> list[str]:
    """A row's command line, the limit given after the command."""
    names = {**vars(inputs), "osm": OSM, "out": out, "observer": OBSERVER, "far": FAR}
    return [*template.format(**names).split(), "--max-memory", limit]


#: Runs the refusals in a child process whose address space is capped, each under an alarm, so
#: that a stage that allocates before it estimates fails its case instead of the machine.
RUNNER = """
import json, resource, signal, sys
from pathlib import Path
resource.setrlimit(resource.RLIMIT_AS, (4 * 1024**3, resource.RLIM_INFINITY))
from click.testing import CliRunner
from nightlights._resources import set_memory_limit
from nightlights_cli.main import cli

def expire(signum, frame):
    raise TimeoutError("no refusal within 20 s: the request was not estimated first")

signal.signal(signal.SIGALRM, expire)
results = {}
for name, (args, folder) in json.loads(sys.argv[1]).items():
    signal.alarm(20)
    try:
        result = CliRunner().invoke(cli, args)
    finally:
        signal.alarm(0)
        set_memory_limit(None)
    left = sorted(p.name for p in Path(folder).iterdir())
    results[name] = [result.exit_code, result.output, left]
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def refusals(inputs: SimpleNamespace, tmp_path_factory: pytest.TempPathFactory) -> dict:
    cases = {}
    for name, (over, limit, _, _) in STAGES.items():
        folder = tmp_path_factory.mktemp("over")
        cases[name] = (_args(over, inputs, folder, limit), str(folder))
    done = subprocess.run(
        [sys.executable, "-c", RUNNER, json.dumps(cases)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=Path(__file__).parents[2],
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("stage", list(STAGES))
def test_a_request_over_the_limit_is_refused_before_it_allocates(
    refusals: dict, stage: str
) -> None:
    exit_code, output, left = refusals[stage]
    _, limit, words, _ = STAGES[stage]
    assert exit_code == 1, output
    errors = [line for line in output.splitlines() if line.startswith("Error")]
    assert len(errors) == 1 and "Traceback" not in output, output
    shown = {"10K": "10.0 KiB", "50K": "50.0 KiB", "100M": "100.0 MiB", "1G": "1.0 GiB"}[limit]
    for word in ["ResourceError: ", "needs about", f"more than the {shown} allowed",
                 "raise the limit with --max-memory", *words]:  # fmt: skip
        assert word in errors[0], (word, errors[0])
    assert left == []


@pytest.mark.parametrize("stage", list(STAGES))
def test_a_request_under_the_limit_passes_the_check(
    inputs: SimpleNamespace, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str
) -> None:
    _, limit, _, under = STAGES[stage]
    monkeypatch.setenv("NIGHTLIGHTS_CACHE", str(tmp_path / "cache"))
    served = Recorder(None)
    monkeypatch.setattr(_app, "serve", served)  # explore: the session is made, not served
    out = tmp_path / "out"
    out.mkdir()
    args = _args(under, inputs, out, "1G" if limit != "100M" else limit)
    try:
        result = CliRunner().invoke(cli, args)
    finally:
        set_memory_limit(None)
    assert result.exit_code == 0, result.output
    assert "ResourceError" not in result.output
    written = [path for path in out.iterdir() if path.name != "cache"]
    assert written or served.calls, result.output
    shutil.rmtree(out)


def test_the_command_s_limit_holds_for_that_command_only(inputs: SimpleNamespace) -> None:
    """``--max-memory`` after a command replaces the group's for that command, and is gone
    after it (the group may run again in the same process)."""
    from nightlights import _resources

    set_memory_limit(None)
    before = _resources.memory_limit()
    args = ["--max-memory", "8G", "darkness", str(inputs.huge_emission), "z.tif", "--kernel",
            str(inputs.kernel), "--in-memory", "--max-memory", "2G"]  # fmt: skip
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1 and "more than the 2.0 GiB allowed" in result.output
    assert _resources.memory_limit() == before
