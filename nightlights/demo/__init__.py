"""The bundled example: Helsinki centre from OpenStreetMap (ODbL, (c) OpenStreetMap contributors).

The demo is a project file, ``helsinki.toml`` beside the data (:func:`example_path`), run by
:func:`nightlights.project.run`; :func:`run_demo` runs it and ``nightlights demo`` is its
command.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import geopandas as gpd
from pyproj import CRS

from nightlights.io import ensure_projected, read_vector

if TYPE_CHECKING:
    from nightlights.project import ProjectResult

#: The demo's project file, in the bundled data folder.
DEMO_PROJECT = "helsinki.toml"
#: The demo's default seed (its project file's).
DEMO_SEED = 2011


def example_path(name: str = "helsinki.osm.pbf") -> Path:
    """Path of a bundled example file (``helsinki.osm.pbf``, ``helsinki.toml``)."""
    path = Path(str(resources.files("nightlights.demo") / "data" / name))
    if not path.exists():
        raise FileNotFoundError(f"bundled example {name!r} is missing from {path.parent}")
    return path


def mapped_street_lamps(crs: str | CRS | None = None) -> gpd.GeoDataFrame:
    """The ``highway=street_lamp`` nodes mapped in the bundled Helsinki extract.

    Parameters
    ----------
    crs
        CRS to return them in (default: local UTM).
    """
    points = read_vector(example_path(), layer="points")
    tags = points["highway"] if "highway" in points else None
    lamps = points.loc[tags == "street_lamp"] if tags is not None else points.iloc[:0]
    return ensure_projected(lamps, source="helsinki.osm.pbf", target_crs=crs)


def run_demo(
    out_dir: str | os.PathLike[str],
    *,
    seed: int = DEMO_SEED,
    force: tuple[str, ...] = (),
    progress: bool = False,
) -> ProjectResult:
    """Run the bundled Helsinki project, writing every product to ``out_dir``.

    Stages whose outputs in ``out_dir`` are up to date are skipped.

    Parameters
    ----------
    out_dir
        Output folder (created if missing).
    seed
        Random seed for sampling and placement.
    force
        Stages to rerun even when up to date (and those downstream).
    progress
        Show the stages' progress bars.

    Returns
    -------
    ProjectResult
        Outputs, zenith brightness per observer and what the inverse maps found.
    """
    from nightlights.project import load_project, run

    project = load_project(example_path(DEMO_PROJECT), overrides={"project": {"seed": seed}})
    return run(project, out_dir, force=force, progress=progress)
