"""Importing nightlights and running its figure-making stages leave the user's process as it was.

The stages draw with matplotlib's object API: they neither select a backend nor import
``matplotlib.pyplot``, and they restore every process-wide setting they touch (warnings
filters, NumPy's floating-point error handling and print options, the environment, the root
logger, matplotlib's rcParams, numba's thread count). A fresh interpreter with
``MPLBACKEND=svg`` runs each stage on a tiny synthetic scene and reports that state before
and after. That ``import nightlights`` alone loads none of numba, dask, xarray or matplotlib is
``test_api.py::test_import_is_light``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Imported before the first snapshot: these packages change the process on their own import
#: (scipy.sparse and scipy.special add warnings filters, rasterio sets GDAL's and PROJ's
#: certificate-bundle variables), which a user who imports them gets without nightlights.
THIRD_PARTY_FIRST = ("scipy.sparse", "scipy.special", "rasterio")

SCRIPT = """
import importlib, json, logging, os, sys, warnings
from pathlib import Path

import matplotlib
import numpy as np

for name in {third_party!r}:
    importlib.import_module(name)


def state():
    root = logging.getLogger()
    return {{
        "backend": matplotlib.get_backend(),
        "filters": [repr(f) for f in warnings.filters],
        "geterr": np.geterr(),
        "printoptions": repr(np.get_printoptions()),
        "environ": dict(os.environ),
        "root_logger": [root.level, [repr(h) for h in root.handlers]],
        "rcparams": repr(sorted(matplotlib.rcParams.items())),
    }}


out = Path(sys.argv[1])
before = state()

import nightlights as nl
from affine import Affine
from ies.library import load_library
from ies.plot import write_polar_plot
from nightlights.io import Raster
from nightlights.maps import plot_raster_map
from nightlights.sky import KernelSpec, build_kernel
from nightlights.sky.colour import render_colour_panorama, tristimulus_flux_ratios

flux = np.zeros((1, 20, 20))
flux[0, 5, 15] = 1.0  # [lm m-2], north-east of the observer
flux[0, 9, 11] = 0.5  # beside the observer
transform = Affine(100.0, 0.0, 500_000.0, 0.0, -100.0, 6_702_000.0)
emission = Raster(flux, transform, "EPSG:32635", ("reflected",), ("lm m-2",))
observer = nl.Observer(501_000.0, 6_701_000.0, height=0.0)
kernel = build_kernel(
    KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16), progress=False
)
scene = nl.Scene(emission, kernel=kernel)
sky = nl.skyglow(scene, observer, png=out / "skyglow.png")
nl.skyglow(scene, observer, png=out / "fisheye.png", projection="fisheye")
# the colour picture of skyglow(bands="RGB"), whose scene kernel takes minutes to build
ratios = tristimulus_flux_ratios("HPS")
luminance = sky.panorama["luminance"].values
xyz = np.stack([ratios[band] * luminance for band in "XYZ"], axis=-1)
render_colour_panorama(xyz, sky.panorama["elevation"].values, out / "colour.png")
q = nl.inverse_q(scene, observer, progress=False).raster
nl.inverse_reduce(
    scene,
    by=q,
    qa=float(np.nanmin(q.data)),
    qb=float(np.nanmax(q.data)),
    gamma=0.5,
    png=out / "reduce.png",
    progress=False,
)
plot_raster_map(
    emission, out / "map.png", floor=0.01, zoom=(500_800.0, 6_700_800.0, 501_200.0, 6_701_200.0)
)
nl.sky_render(
    None,
    out / "sky.png",
    time="2026-01-25T20:00:00Z",
    panorama=sky.panorama,
    width=128,
    height=64,
)
library = load_library()
write_polar_plot(library.photometry(sorted(library.systems)[0]), out / "polar.png")

after = state()
import numba

print(json.dumps({{
    "before": before,
    "after": after,
    "pyplot": "matplotlib.pyplot" in sys.modules,
    "numba_threads": [numba.get_num_threads(), numba.config.NUMBA_NUM_THREADS],
}}))
"""

PNGS = (
    "skyglow.png",
    "fisheye.png",
    "colour.png",
    "reduce.png",
    "map.png",
    "sky.png",
    "polar.png",
)


def _run(code: str, *args: str) -> subprocess.CompletedProcess[str]:
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "svg", "PYTHONPATH": path},
        cwd=ROOT,
    )


def test_figures_leave_the_process_as_it_was(tmp_path: Path) -> None:
    done = _run(SCRIPT.format(third_party=THIRD_PARTY_FIRST), str(tmp_path))
    assert done.returncode == 0, done.stderr[-4000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    before, after = report["before"], report["after"]
    assert before["backend"] == "svg"
    assert after["backend"] == "svg"
    assert not report["pyplot"], "matplotlib.pyplot was imported"
    for key in ("filters", "geterr", "printoptions", "environ", "root_logger", "rcparams"):
        assert after[key] == before[key], key
    threads, default = report["numba_threads"]
    assert threads == default
    for name in PNGS:
        png = tmp_path / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        assert png.stat().st_size > 2000, name
