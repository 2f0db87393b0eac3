"""Bad inputs to ``kernel build``, ``skyglow``, ``inverse q | s | dim | plan`` and ``darkness``.

Every case is one line on the terminal, exit code 1 (2 for what click itself refuses), no
traceback, no new file, and the previous output (``old.*``, given with ``--overwrite``) left
as it was.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from affine import Affine
from click.testing import CliRunner

import nightlights as nl
from nightlights._resources import set_memory_limit
from nightlights.io import Raster
from nightlights.sky import KernelSpec, build_kernel
from nightlights_cli.main import cli

TRANSFORM = Affine(100, 0, 500_000, 0, -100, 6_700_000)  # 20 x 20 cells of 100 m
OBSERVER = ["--observer", "501000,6699000"]
PREVIOUS = b"previous output"


def _raster(folder: Path, name: str, fill: float = 0.0, **changes: float) -> Path:
    data = np.full((1, 20, 20), fill)
    data[0, 4:7, 14:17] = 2.0
    if changes.get("inf"):
        data[0, 1, 1] = data[0, 2, 2] = np.inf
    if changes.get("dark"):
        data[0, 4:7, 14:17] = fill
    path = folder / name
    Raster(data, TRANSFORM, "EPSG:32635", ("reflected",), ("lm m-2",)).write(path)
    return path


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    folder = tmp_path_factory.mktemp("sky_bad_inputs")
    kernel = folder / "kernel.nc"
    build_kernel(
        KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), kernel, progress=False
    )
    emission = _raster(folder, "emission.tif")
    q = folder / "q.tif"
    nl.inverse_q(emission, q, observer=(501_000.0, 6_699_000.0), kernel=kernel, progress=False)
    return SimpleNamespace(
        kernel=kernel,
        emission=emission,
        q=q,
        inf=_raster(folder, "inf.tif", inf=1),
        nan=_raster(folder, "nan.tif", np.nan, dark=1),
        zero=_raster(folder, "zero.tif", dark=1),
        holes=_holes(folder / "holes.tif"),
    )


def _holes(path: Path) -> Path:
    """A flat DEM at 0 m on the emission grid with one nodata cell, under a lit cell."""
    heights = np.zeros((1, 20, 20))
    heights[0, 5, 14] = np.nan
    return Raster(heights, TRANSFORM, "EPSG:32635", ("height",), ("m",)).write(path)


@pytest.fixture(autouse=True)
def _reset_memory_limit() -> Iterator[None]:
    """``--max-memory`` sets a process-wide limit: put it back for the next test."""
    yield
    set_memory_limit(None)


#: What every stage says of a DEM with a hole under a lit cell.
HOLE = ["no terrain height under 1 of 9 lit emission cells", "holes.tif", "(501450.0, 6699450.0)"]

#: (name, arguments with {placeholders}, exit code, key words of the message)
CASES = [
    # kernel build: absurd atmosphere and grids, resources
    ("turbidity-1e6", "kernel build {out} --turbidity 1e6", 1, ["turbidity", "64"]),
    ("turbidity-nan", "kernel build {out} --turbidity nan", 1, ["--turbidity", "finite"]),
    ("wavelength", "kernel build {out} --wavelength-nm 5", 1, ["300-1100 nm"]),
    ("aod", "kernel build {out} --aerosol-optical-depth 1e4", 1, ["optical depth"]),
    ("r-max-inf", "kernel build {out} --r-max inf", 1, ["--r-max", "finite"]),
    # beyond the kernel's supported range (MAX_KERNEL_RANGE): it moved zeniths silently
    ("r-max-1e9", "kernel build {out} --r-max 1e9", 1, ["--r-max=1000000000.0", "300000 m"]),
    ("r-max-above", "kernel build {out} --r-max 300001", 1, ["--r-max=300001.0", "at most"]),
    ("n-azimuth-odd", "kernel build {out} --n-azimuth 7", 1, ["--n-azimuth=7", "even"]),
    ("nodes-0", "kernel build {out} --nodes 0", 1, ["nodes=0"]),
    ("n-distance-huge", "kernel build {out} --n-distance 1000000", 1, ["needs about", "--n-dist"]),
    ("n-azimuth-huge", "kernel build {out} --n-azimuth 1000000", 1, ["needs about", "--max-mem"]),
    ("kernel-no-folder", "kernel build {nodir}/k.nc", 1, ["does not exist"]),
    # skyglow: emission nonsense
    ("sky-inf", "skyglow {inf} {out} {obs} --kernel {kernel}", 1, ["2 non-finite", "inf.tif"]),
    ("sky-nan", "skyglow {nan} {out} {obs} --kernel {kernel}", 1, ["no lit cell", "nodata"]),
    ("sky-zero", "skyglow {zero} {out} {obs} --kernel {kernel}", 1, ["no lit cell"]),
    # skyglow: observers
    (
        "sky-6000km",
        "skyglow {em} {out} --observer 6501000,6699000 --kernel {kernel}",
        1,
        ["outside", "kernel's range"],
    ),
    (
        "sky-degrees",
        "skyglow {em} {out} --observer 24.9,60.2 --kernel {kernel}",
        1,
        ["look like degrees", "--observer-crs='EPSG:4326'"],
    ),
    (
        "sky-lat-95",
        "skyglow {em} {out} --observer 24.9,95 --observer-crs EPSG:4326 --kernel {kernel}",
        1,
        ["latitude"],
    ),
    (
        "sky-bad-crs",
        "skyglow {em} {out} {obs} --observer-crs EPSG:999999 --kernel {kernel}",
        1,
        ["not a CRS"],
    ),
    ("sky-obs-text", "skyglow {em} {out} --observer 1,2,3 --kernel {kernel}", 2, ["X,Y"]),
    # skyglow: options a given kernel fixes, scene-kernel resources, atmosphere
    (
        "sky-n-azimuth-0",
        "skyglow {em} {out} {obs} --kernel {kernel} --n-azimuth 0",
        1,
        ["--n-azimuth=0", "expected an integer >= 1"],
    ),
    (
        "sky-n-elevation",
        "skyglow {em} {out} {obs} --kernel {kernel} --n-elevation 1000000",
        1,
        ["--n-elevation=1000000", "kernel fixes"],
    ),
    ("sky-turbidity", "skyglow {em} {out} {obs} --kernel {kernel} --turbidity 3", 1, ["differs"]),
    ("sky-scene-huge", "skyglow {em} {out} {obs} --n-elevation 1000000", 1, ["needs about"]),
    ("sky-scene-t", "skyglow {em} {out} {obs} --turbidity 1e6", 1, ["turbidity", "64"]),
    # skyglow: every output location checked first (OUTPUT exists and must survive)
    (
        "sky-png-nodir",
        "skyglow {em} {out} {obs} --kernel {kernel} --png {nodir}/p.png",
        1,
        ["does not exist"],
    ),
    (
        "sky-polar-nodir",
        "skyglow {em} {out} {obs} --kernel {kernel} --polar-output {nodir}/x.nc",
        1,
        ["does not exist"],
    ),
    # inverse q / s
    ("q-inf", "inverse q {inf} {out} {obs} --kernel {kernel}", 1, ["non-finite"]),
    ("q-far", "inverse q {em} {out} --observer 501000,9699000 --kernel {kernel}", 1, ["outside"]),
    (
        "q-n-azimuth",
        "inverse q {em} {out} {obs} --kernel {kernel} --n-azimuth 2",
        1,
        ["--n-azimuth=2", "kernel fixes"],
    ),
    (
        "s-n-distance",
        "inverse s {em} {out} {obs} --kernel {kernel} --region zenith:30 --n-distance 5",
        1,
        ["--n-distance=5"],
    ),
    (
        "s-zero",
        "inverse s {zero} {out} {obs} --kernel {kernel} --region zenith:30",
        1,
        ["no lit cell"],
    ),
    # inverse dim: every output location checked first
    (
        "reduce-qa-qb",
        "inverse dim {em} {out} --kernel {kernel} --by {q} --qa 2 --qb 1",
        1,
        ["qa", "qb"],
    ),
    (
        "reduce-png-nodir",
        "inverse dim {em} {out} --kernel {kernel} --by {q} --qa 0 --qb 1 --png {nodir}/p.png",
        1,
        ["does not exist"],
    ),
    (
        "reduce-summary-nodir",
        "inverse dim {em} {out} --kernel {kernel} --by {q} --qa 0 "
        "--qb 1 --summary-output {nodir}/s.json",
        1,
        ["does not exist"],
    ),
    # a DEM with a hole (nodata) under a lit cell: the same refusal in every stage
    ("sky-dem-hole", "skyglow {em} {out} {obs} --kernel {kernel} --dem {holes}", 1, HOLE),
    ("q-dem-hole", "inverse q {em} {out} {obs} --kernel {kernel} --dem {holes}", 1, HOLE),
    (
        "s-dem-hole",
        "inverse s {em} {out} {obs} --kernel {kernel} --region zenith:30 --dem {holes}",
        1,
        HOLE,
    ),
    ("dark-dem-hole", "darkness {em} {out} --kernel {kernel} --dem {holes}", 1, ["no terrain"]),
    # darkness
    ("dark-inf", "darkness {inf} {out} --kernel {kernel}", 1, ["non-finite"]),
    ("dark-zero", "darkness {zero} {out} --kernel {kernel}", 1, ["no lit cell"]),
    ("dark-n-azimuth", "darkness {em} {out} --kernel {kernel} --n-azimuth 2", 1, ["kernel fixes"]),
    ("dark-chunk", "darkness {em} {out} --kernel {kernel} --chunk-size 0", 2, ["--chunk-size"]),
    (
        "dark-memory",
        "--max-memory 100K darkness {em} {out} --kernel {kernel}",
        1,
        ["needs about", "--chunk-size"],
    ),
]


@pytest.mark.parametrize(("name", "arguments", "code", "words"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_leaves_the_previous_output(
    inputs: SimpleNamespace, tmp_path: Path, name: str, arguments: str, code: int, words: list
) -> None:
    suffix = ".nc" if arguments.startswith(("kernel", "skyglow")) else ".tif"
    out = tmp_path / f"old{suffix}"
    out.write_bytes(PREVIOUS)
    values = {
        "out": f"{out} --overwrite",
        "nodir": str(tmp_path / "nodir"),
        "kernel": str(inputs.kernel),
        "em": str(inputs.emission),
        "obs": " ".join(OBSERVER),
        "inf": str(inputs.inf),
        "nan": str(inputs.nan),
        "zero": str(inputs.zero),
        "q": str(inputs.q),
        "holes": str(inputs.holes),
    }
    args = arguments.format(**values).split()
    env = {"NIGHTLIGHTS_CACHE": str(tmp_path / "cache")}
    result = CliRunner().invoke(cli, args, env=env)
    output = result.output
    assert result.exit_code == code, output
    assert "Traceback" not in output
    lines = [line for line in output.strip().splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("Error")]
    assert len(errors) == 1 and (code == 2 or len(lines) == 1), output  # click adds usage
    for word in words:
        assert word in output, output
    assert out.read_bytes() == PREVIOUS
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "cache") == [out.name]
