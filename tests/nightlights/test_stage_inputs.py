"""No stage function writes over one of its inputs, table-driven over the stages and inputs.

Each stage that takes input files and an output path refuses an output that is one of them
(or lies in an input folder, or holds an input) with an ``OutputError`` that names both,
before it reads or computes anything, whatever ``overwrite``; the input stays as it was. The
inputs are placeholder files: nothing reads them before the check.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

import nightlights as nl
from nightlights.errors import OutputError
from nightlights.maps import plot_raster_map
from nightlights.qgis import build_plugin

ROOT = Path(nl.__file__).parent


@pytest.fixture
def files(tmp_path: Path) -> SimpleNamespace:
    """One placeholder file per input, a network and a catalogue folder, a real mapping."""
    names = (
        "emission.tif kernel.nc dem.tif q.tif lights.gpkg streets.gpkg lamps.gpkg irr.tif "
        "albedo.tif area.gpkg viirs.tif panorama.nc observers.gpkg cap.tif region.json nightlights"
    ).split()
    found: dict[str, Path] = {}
    for name in names:
        path = tmp_path / name
        path.write_text(f"input {name}")
        found[name.split(".")[0]] = path
    found["mapping"] = Path(shutil.copy(ROOT / "streets" / "mappings" / "osm.toml", tmp_path))
    for folder in ("network", "catalog", "holder"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "table.csv").write_text(f"{folder} table")
        found[folder] = tmp_path / folder
    found["held"] = found["holder"] / "table.csv"
    found["command"] = found["nightlights"]
    found["command"].chmod(0o755)  # the plugin records an executable
    return SimpleNamespace(**found)


def _scene(f: SimpleNamespace) -> nl.Scene:
    return nl.Scene(f.emission, dem=f.dem, kernel=f.kernel)


OBSERVER = nl.Observer(501500.0, 6698500.0)

#: Stage call with its output set to an input -> (output, input's name in the message, risk).
Call = Callable[[SimpleNamespace], Any]
STAGES: dict[str, tuple[Call, str, str, str]] = {
    "normalize streets": (lambda f: nl.normalize(f.streets, f.streets), "streets", "streets", ""),
    "normalize mapping": (
        lambda f: nl.normalize(f.streets, f.mapping, mapping=f.mapping),
        "mapping",
        "mapping",
        "",
    ),
    "sample streets": (lambda f: nl.sample(f.streets, f.streets), "streets", "streets", ""),
    "sample network": (
        lambda f: nl.sample(f.streets, f.network / "table.csv", network=f.network),
        "network/table.csv",
        "network",
        "lies in the input folder",
    ),
    "fit network": (
        lambda f: nl.fit(f.streets, f.network, network=f.network),
        "network",
        "network",
        "",
    ),
    "learn network": (
        lambda f: nl.learn(f.streets, f.lamps, f.network, network=f.network, overwrite=True),
        "network",
        "network",
        "",
    ),
    "learn streets in out_dir": (
        lambda f: nl.learn(f.held, f.lamps, f.holder, overwrite=True),
        "holder",
        "streets",
        "holds the input",
    ),
    "place streets": (lambda f: nl.place(f.streets, f.streets), "streets", "streets", ""),
    "place catalog": (
        lambda f: nl.place(f.streets, f.catalog / "table.csv", catalog=f.catalog),
        "catalog/table.csv",
        "catalog",
        "lies in the input folder",
    ),
    **{
        f"irradiance {name}": (
            lambda f, key=key: nl.irradiance(
                f.lights,
                getattr(f, key),
                resolution=4.0,
                dem=f.dem,
                area_sources=f.area,
            ),
            key,
            name,
            "",
        )
        for name, key in (("lights", "lights"), ("dem", "dem"), ("area_sources", "area"))
    },
    **{
        f"emission {name}": (
            lambda f, key=key: nl.emission(
                f.irr, getattr(f, key), lights=f.lights, resolution=8.0, albedo=f.albedo
            ),
            key,
            name,
            "",
        )
        for name, key in (("irradiance", "irr"), ("lights", "lights"), ("albedo", "albedo"))
    },
    "emission_from_viirs viirs": (
        lambda f: nl.emission_from_viirs(f.viirs, f.viirs),
        "viirs",
        "viirs",
        "",
    ),
    **{
        f"{stage} {key}": (call, key, key, "")
        for key in ("emission", "dem", "kernel")
        for stage, call in (
            ("skyglow", lambda f, key=key: nl.skyglow(_scene(f), OBSERVER, getattr(f, key))),
            (
                "skyglow png",
                lambda f, key=key: nl.skyglow(_scene(f), OBSERVER, png=getattr(f, key)),
            ),
            ("inverse_q", lambda f, key=key: nl.inverse_q(_scene(f), OBSERVER, getattr(f, key))),
            (
                "inverse_s",
                lambda f, key=key: nl.inverse_s(
                    _scene(f), OBSERVER, getattr(f, key), region="zenith:30"
                ),
            ),
            (
                "inverse_reduce",
                lambda f, key=key: nl.inverse_reduce(
                    _scene(f), getattr(f, key), by=f.q, qa=0.0, qb=1.0
                ),
            ),
            (
                "least_dimming",
                lambda f, key=key: nl.least_dimming(
                    _scene(f), [OBSERVER], getattr(f, key), target_zenith=22.0
                ),
            ),
            ("darkness", lambda f, key=key: nl.darkness(_scene(f), getattr(f, key))),
            (
                "observers",
                lambda f, key=key: nl.observers(_scene(f), f.observers, getattr(f, key)),
            ),
        )
    },
    "inverse_reduce by": (
        lambda f: nl.inverse_reduce(_scene(f), None, by=f.q, qa=0.0, qb=1.0, png=f.q),
        "q",
        "by",
        "",
    ),
    "least_dimming max_dimming": (
        lambda f: nl.least_dimming(
            _scene(f), [OBSERVER], dimming_output=f.cap, target_zenith=22.0, max_dimming=f.cap
        ),
        "cap",
        "max_dimming",
        "",
    ),
    "least_dimming target_region": (
        lambda f: nl.least_dimming(
            _scene(f), [OBSERVER], summary_output=f.region, target_region=[(f.region, 22.0)]
        ),
        "region",
        "target_region",
        "",
    ),
    "observers observers": (
        lambda f: nl.observers(_scene(f), f.observers, f.observers, overwrite=True),
        "observers",
        "observers",
        "",
    ),
    "sky_render panorama": (
        lambda f: nl.sky_render(
            OBSERVER, f.panorama, time="2024-01-15T22:00Z", panorama=f.panorama
        ),
        "panorama",
        "panorama",
        "",
    ),
    "plot_raster_map raster": (lambda f: plot_raster_map(f.q, f.q), "q", "raster", ""),
    "build_plugin command": (
        lambda f: build_plugin(f.command, [], command=f.command, overwrite=True),
        "command",
        "command",
        "",
    ),
}


@pytest.mark.parametrize("name", list(STAGES))
def test_a_stage_refuses_an_output_that_is_an_input(files: SimpleNamespace, name: str) -> None:
    call, output, label, risk = STAGES[name]
    out = getattr(files, output) if hasattr(files, output) else files.emission.parent / output
    folder = files.emission.parent
    before = {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}
    with pytest.raises(OutputError) as error:
        call(files)
    message = str(error.value)
    assert message.startswith(f"{out}: {risk or 'is the input'} {label} ("), message
    assert message.endswith("an output never replaces an input: choose another output path")
    assert {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()} == before
