"""The bundled example: Helsinki centre from OpenStreetMap (ODbL, (c) OpenStreetMap contributors).

:func:`run_demo` runs the pipeline stages on it; ``nightlights demo`` is its command.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

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
    #: What the inverse maps found, one line each.
    findings: list[str] = field(default_factory=list)


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
#: Width [deg] and top [deg] of the horizon band searched for the far observer's brightest sky.
DEMO_REGION_WIDTH = 60.0
DEMO_REGION_TOP = 20.0
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
    panoramas: dict[str, Any] = {}
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
        panoramas[name] = sky.panorama
    _inverse_demo(upward, kernel, panoramas, out, result)
    return result


def brightest_band(panorama: Any, *, width: float, top: float) -> str:
    """The horizon band (``horizon:AZ1,AZ2,EL``) of a panorama with the highest mean luminance.

    Parameters
    ----------
    panorama
        A ``skyglow`` panorama Dataset.
    width
        Band width in azimuth [deg].
    top
        Band top elevation [deg].

    Returns
    -------
    str
        The band as a region text for :class:`nightlights.inverse.SkyRegion`.
    """
    import numpy as np

    luminance = np.nan_to_num(panorama["luminance"].values)
    elevation = panorama["elevation"].values
    azimuth = panorama["azimuth"].values
    rows = luminance[elevation <= top]
    step = 360.0 / azimuth.size
    half = max(1, round(width / step / 2))
    kernel = np.ones(2 * half)
    columns = rows.mean(axis=0)
    wrapped = np.concatenate([columns[-half:], columns, columns[:half]])
    means = np.convolve(wrapped, kernel, mode="valid")[: azimuth.size]
    centre = (int(np.argmax(means)) + 0.5) * step
    start, end = (round(centre - half * step) % 360, round(centre + half * step) % 360)
    return f"horizon:{start},{end},{top:g}"


def _inverse_demo(
    upward: Any, kernel: Any, panoramas: dict[str, Any], out: Path, result: DemoResult
) -> None:
    """Q for the central observer, S of the far observer's brightest sky, and a dimming by S."""
    import geopandas as gpd
    import numpy as np
    from shapely.geometry import Point

    import nightlights as nl
    from nightlights.maps import plot_raster_map

    height = DEMO_KERNEL.observer_altitudes[0]
    (near, near_lonlat, _), (far, far_lonlat, _) = DEMO_OBSERVERS

    def marker(lonlat: tuple[float, float]) -> gpd.GeoDataFrame:
        return gpd.GeoDataFrame(geometry=[Point(lonlat)], crs="EPSG:4326").to_crs(upward.crs)

    def share_map(raster: Any, path: Path, title: str, lonlat: tuple[float, float]) -> Path:
        top = float(np.nanmax(raster.data))
        return plot_raster_map(
            raster,
            path,
            points=marker(lonlat),
            points_label="observer",
            points_size=40.0,
            floor=top * 1e-3,
            title=title,
            credit=CREDIT,
        )

    q = nl.inverse_q(
        upward,
        out / f"inverse_q_{near}.tif",
        observer=near_lonlat,
        observer_crs="EPSG:4326",
        observer_height=height,
        kernel=kernel,
        metric="zenith",
    )
    result.outputs[f"inverse_q_{near}"] = out / f"inverse_q_{near}.tif"
    result.outputs[f"inverse_q_{near}_map"] = share_map(
        q.raster,
        out / f"inverse_q_{near}.png",
        f"Q (zenith): each cell's part of the zenith at {near}",
        near_lonlat,
    )
    values = np.sort(q.raster.data[np.isfinite(q.raster.data)])[::-1]
    result.findings.append(
        f"zenith at {near}: the brightest 10 of {values.size} lit cells give "
        f"{100 * values[:10].sum() / values.sum():.0f} % of it"
    )
    region = brightest_band(panoramas[far], width=DEMO_REGION_WIDTH, top=DEMO_REGION_TOP)
    s = nl.inverse_s(
        upward,
        out / f"inverse_s_{far}.tif",
        observer=far_lonlat,
        observer_crs="EPSG:4326",
        observer_height=height,
        kernel=kernel,
        region=region,
    )
    result.outputs[f"inverse_s_{far}"] = out / f"inverse_s_{far}.tif"
    result.outputs[f"inverse_s_{far}_map"] = share_map(
        s.raster,
        out / f"inverse_s_{far}.png",
        f"S: each cell's part of the sky {region} from {far}",
        far_lonlat,
    )
    lit = s.raster.data[np.isfinite(s.raster.data)]
    qa, qb = (float(v) for v in np.quantile(lit, [0.5, 0.9]))
    reduced = nl.inverse_reduce(
        upward,
        out / f"emission_dimmed_{far}.tif",
        by=s.raster,
        qa=qa,
        qb=qb,
        gamma=1.0,
        kernel=kernel,
        dimming_output=out / f"dimming_{far}.tif",
        summary_output=out / f"dimming_{far}.json",
        png=out / f"dimming_{far}.png",
    )
    for name in (f"emission_dimmed_{far}", f"dimming_{far}"):
        result.outputs[name] = out / f"{name}.tif"
    result.outputs[f"dimming_{far}_summary"] = out / f"dimming_{far}.json"
    result.outputs[f"dimming_{far}_png"] = out / f"dimming_{far}.png"
    summary = reduced.summary
    band = summary["observers"][0]["regions"][0]
    result.findings.append(
        f"dimming the cells by S ({region} from {far}; Q_a, Q_b = median, 90th percentile) "
        f"removes {summary['flux_removed_percent']:.1f} % of the flux and darkens that sky "
        f"from {band['before_mag_arcsec2']:.2f} to {band['after_mag_arcsec2']:.2f} mag arcsec-2"
    )
