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
DEMO_KERNEL: dict = {
    "r_min": 10.0,
    "r_max": 10_000.0,
    "n_r": 48,
    "n_el": 32,
    "n_az": 128,
    "uplight": True,
    "observer_altitudes": (1.7,),
}
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
    from nightlights.emission import emission
    from nightlights.irradiance import irradiance
    from nightlights.maps import plot_raster_map
    from nightlights.sky.precompute import get_or_build_kernel
    from nightlights.sky.stage import skyglow
    from nightlights.streets.normalize import normalize
    from nightlights.streets.place import place
    from nightlights.streets.sample import sample_streets

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result = DemoResult()
    streets_norm = out / "streets_norm.gpkg"
    normalize(example_path(), streets_norm, mapping="osm")
    result.outputs["streets_norm"] = streets_norm
    streets_lit = out / "streets_lit.gpkg"
    sample_streets(streets_norm, streets_lit, seed=seed)
    result.outputs["streets_lit"] = streets_lit
    lights = out / "lights.gpkg"
    poles = place(streets_lit, lights, seed=seed)
    result.outputs["lights"] = lights
    irradiance_tif = out / "irradiance.tif"
    irradiance(
        lights,
        irradiance_tif,
        resolution=DEMO_IRRADIANCE_RESOLUTION,
        sensors=("photopic", "scotopic"),
        progress=False,
    )
    result.outputs["irradiance"] = irradiance_tif
    result.outputs["irradiance_map"] = plot_raster_map(
        irradiance_tif,
        out / "irradiance.png",
        points=poles.drop_duplicates("pole_id"),
        title="Helsinki: predicted poles and ground illuminance",
        credit=CREDIT,
        zoom=DEMO_ZOOM,
    )
    emission_tif = out / "emission.tif"
    emission(
        irradiance_tif,
        lights,
        emission_tif,
        resolution=DEMO_EMISSION_RESOLUTION,
        albedo=DEMO_ALBEDO,
    )
    result.outputs["emission"] = emission_tif
    kernel = get_or_build_kernel(progress=False, **DEMO_KERNEL)
    for name, (lon, lat), projection in DEMO_OBSERVERS:
        panorama = out / f"skyglow_{name}.nc"
        sky = skyglow(
            emission_tif,
            panorama,
            observer=(lon, lat),
            observer_crs="EPSG:4326",
            observer_height=DEMO_KERNEL["observer_altitudes"][0],
            kernel=kernel,
            png=out / f"skyglow_{name}.png",
            projection=projection,
        )
        result.outputs[f"skyglow_{name}"] = panorama
        result.outputs[f"skyglow_{name}_png"] = out / f"skyglow_{name}.png"
        result.zenith[name] = (sky.zenith_magnitude, sky.bortle)
    return result
