"""The bundled example: Helsinki centre from OpenStreetMap (ODbL, (c) OpenStreetMap contributors).

:func:`run_demo` runs the pipeline stages on it; ``nightlights demo`` is its command.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import geopandas as gpd
from pyproj import CRS

from nightlights.io import ensure_projected, read_vector
from nightlights.sky.spec import KernelSpec


def example_path(name: str = "helsinki.osm.pbf") -> Path:
    """Path of a bundled example file."""
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


@dataclass
class DemoResult:
    """Paths written by :func:`run_demo`, in pipeline order."""

    outputs: dict[str, Path] = field(default_factory=dict)
    #: Zenith sky brightness [mag arcsec-2] and Bortle class per observer.
    zenith: dict[str, tuple[float, int]] = field(default_factory=dict)


#: Ground albedo of the demo [1]: a typical value for a city centre of asphalt, paving and
#: roofs (urban surface albedo 0.10-0.20; Taha 1997, Energy and Buildings 25, 99-103).
DEMO_ALBEDO = 0.15
#: Pixel size of the demo's illuminance raster [m].
DEMO_IRRADIANCE_RESOLUTION = 1.0
#: Cell size of the demo's emission raster [m].
DEMO_EMISSION_RESOLUTION = 50.0
CREDIT = "(c) OpenStreetMap contributors, ODbL"
#: Skyglow observers: name, (longitude, latitude) [deg], picture projection. Esplanadi park
#: in the centre, and the Suomenlinna sea fortress ~3 km south looking back at the city.
DEMO_OBSERVERS = (
    ("esplanadi", (24.9480, 60.1675), "fisheye"),
    ("suomenlinna", (24.9880, 60.1455), "equirectangular"),
)
#: Kernel of the demo: 48 distance bins from 10 m to 10 km, 32 x 128 panorama, Lambertian
#: and uplight tables, observer eye height 1.7 m, turbidity 2 (cached after the first run).
DEMO_KERNEL = KernelSpec(
    r_min=10.0,
    r_max=10_000.0,
    n_distance=48,
    n_elevation=32,
    n_azimuth=128,
    uplight=True,
    observer_altitudes=(1.7,),
)
#: Window enlarged in the demo's map (around the Esplanadi park) [m, EPSG:32635].
DEMO_ZOOM = (385850.0, 6671700.0, 386150.0, 6672000.0)


def run_demo(out_dir: str | os.PathLike[str], *, seed: int = 2011) -> DemoResult:
    """Run the pipeline on the bundled Helsinki extract, writing every product to ``out_dir``.

    Parameters
    ----------
    out_dir
        Output folder (created if missing).
    seed
        Random seed for sampling and placement.
    """
    import nightlights as nl
    from nightlights.maps import plot_raster_map
    from nightlights.sky.store import get_or_build_kernel

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result = DemoResult()
    paths = {
        name: out / f"{name}.{ext}"
        for name, ext in (
            ("streets_norm", "gpkg"),
            ("streets_lit", "gpkg"),
            ("lights", "gpkg"),
            ("irradiance", "tif"),
            ("emission", "tif"),
        )
    }
    streets = nl.normalize(example_path(), paths["streets_norm"], mapping="osm").streets
    streets = nl.sample(streets, paths["streets_lit"], seed=seed).streets
    lights = nl.place(streets, paths["lights"], seed=seed).lights
    ground = nl.irradiance(
        lights,
        paths["irradiance"],
        resolution=DEMO_IRRADIANCE_RESOLUTION,
        sensors=("photopic", "scotopic"),
        progress=False,
    ).raster
    result.outputs.update({name: paths[name] for name in ("streets_norm", "streets_lit")})
    result.outputs["lights"] = paths["lights"]
    result.outputs["irradiance"] = paths["irradiance"]
    result.outputs["irradiance_map"] = plot_raster_map(
        ground,
        out / "irradiance.png",
        points=lights.drop_duplicates("pole_id"),
        title="Helsinki: predicted poles and ground illuminance",
        credit=CREDIT,
        zoom=DEMO_ZOOM,
    )
    upward = nl.emission(
        ground,
        paths["emission"],
        lights=lights,
        resolution=DEMO_EMISSION_RESOLUTION,
        albedo=DEMO_ALBEDO,
    ).raster
    result.outputs["emission"] = paths["emission"]
    kernel = get_or_build_kernel(DEMO_KERNEL, progress=False)
    for name, (lon, lat), projection in DEMO_OBSERVERS:
        panorama = out / f"skyglow_{name}.nc"
        sky = nl.skyglow(
            upward,
            panorama,
            observer=(lon, lat),
            observer_crs="EPSG:4326",
            observer_height=DEMO_KERNEL.observer_altitudes[0],
            kernel=kernel,
            png=out / f"skyglow_{name}.png",
            projection=projection,
        )
        result.outputs[f"skyglow_{name}"] = panorama
        result.outputs[f"skyglow_{name}_png"] = out / f"skyglow_{name}.png"
        result.zenith[name] = (sky.zenith_magnitude, sky.bortle)
    return result
