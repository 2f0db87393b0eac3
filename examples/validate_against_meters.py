"""Validate against meters: the bundled Helsinki scene checked and calibrated against SQM-L files.

No sky-brightness readings of Helsinki are bundled (none with a licence that allows it), so this
example makes its own, and says so: 24 SQM-L stations across the scene, each with three nights
of readings every 15 minutes from dusk to dawn in the community-standard text format, made from
the model's own sky at a "true" emission scale of 0.6 (the real city emitting 60 % of what the
streets predict) with 0.08 mag of scatter per reading, plus what real series carry: twilight
and a setting Moon (which the selection removes) and a cloudy night that brightens the sky
(which the station statistic sees through). ``nl.validate`` then reads the files, keeps the
clear moonless astronomical-night readings, reduces each station to one value, predicts each
meter's reading and fits the emission's flux scale with leave-one-station-out
cross-validation. It should find about 0.6, and a held-out RMS well below the 0.08 mag of one
reading: a station's value is the mode of some hundred readings.

Writes ``examples/figures/helsinki_validation.png`` (predicted against measured, before and
after), ``helsinki_validation_residuals.png`` (the residual map), ``helsinki_station.png`` (one
station's night series and its statistic) and ``helsinki_validation.json``. Usage::

    python examples/validate_against_meters.py [--seed 2011] [--out examples/figures]

Data: (c) OpenStreetMap contributors, ODbL 1.0.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from pyproj import Transformer

import nightlights as nl
from nightlights.demo import example_path
from nightlights.errors import DataQualityWarning
from nightlights.io import Raster
from nightlights.meter import plot_statistic, read_readings, select_readings, sky_conditions
from nightlights.meter.readings import write_ida

#: The made-up truth: the city emits this share of the streets' prediction [1].
TRUE_SCALE = 0.6
#: Scatter of the made-up readings about the truth [mag arcsec-2].
NOISE = 0.08
#: Three January nights: new Moon (2026-01-18), then a waxing crescent that sets in the
#: evening (2026-01-21, -23); readings every 15 minutes, 14-06 UTC.
NIGHTS = ("2026-01-18", "2026-01-21", "2026-01-23")
#: The darkness map's kernel grid (the demo's).
KERNEL_GRID = {"n_distance": 48, "n_elevation": 32, "n_azimuth": 128}


def stations(raster: Raster, count: int, rng: np.random.Generator) -> pd.DataFrame:
    """Meters spread over the scene (away from its edges), named after their place."""
    west, south, east, north = raster.bounds
    x = rng.uniform(west + 200, east - 200, count)
    y = rng.uniform(south + 200, north - 200, count)
    lon, lat = Transformer.from_crs(raster.crs, "EPSG:4326", always_xy=True).transform(x, y)
    return pd.DataFrame(
        {
            "station": [f"meter_{i + 1:02d}" for i in range(count)],
            "instrument": "sqm-l",
            "lon": lon,
            "lat": lat,
            "magnitude": 20.0,
            "n_readings": 1,
            "n_nights": 1,
            "spread": 0.0,
            "statistic": "mode",
            "time": pd.Timestamp("2026-01-18T22:00Z"),
            "pointing_elevation": 90.0,
            "pointing_azimuth": 0.0,
            "fov": np.nan,
        }
    )


def night_series(sky: float, rng: np.random.Generator, cloudy_night: int) -> pd.DataFrame:
    """A station's readings: the clear sky ``sky`` [mag arcsec-2] with scatter, brighter in
    twilight and moonlight (as the Sun and Moon stand), and under clouds on one night."""
    times = pd.DatetimeIndex(
        [t for night in NIGHTS for t in pd.date_range(f"{night}T14:00Z", periods=65, freq="15min")]
    )
    magnitude = sky + rng.normal(0.0, NOISE, times.size)
    cloudy = times.normalize() == pd.Timestamp(NIGHTS[cloudy_night], tz="UTC")
    magnitude[cloudy] -= rng.uniform(0.6, 1.2, int(cloudy.sum()))  # clouds reflect city light
    return pd.DataFrame({"time": times, "magnitude": magnitude})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2011, help="pipeline and readings seed")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "figures")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    streets = nl.normalize(example_path(), mapping="osm").streets
    lit = nl.sample(streets, network="europe", seed=args.seed).streets
    lights = nl.place(lit, seed=args.seed).lights
    lux = nl.irradiance(lights, resolution=2.0, progress=False).raster
    upward = nl.emission(lux, lights=lights, resolution=50.0, albedo=0.15).raster
    scene = nl.Scene(upward, **KERNEL_GRID)

    # the made-up truth: each meter's clear-sky reading at the true scale, from its own panorama
    sites = stations(upward, 24, rng)
    truth = Raster(
        upward.data * TRUE_SCALE,
        upward.transform,
        upward.crs,
        upward.descriptions,
        upward.units,
        upward.tags,
        upward.band_tags,
    )
    clear = (
        nl.validate(nl.Scene(truth, **KERNEL_GRID), sites, method="panorama", progress=False)
        .stations["predicted"]
        .to_numpy()
    )

    with tempfile.TemporaryDirectory() as folder:
        for i, site in sites.iterrows():
            series = night_series(clear[i], rng, cloudy_night=i % 3)
            frame = series.assign(
                station=site["station"], instrument="sqm-l", lon=site["lon"], lat=site["lat"]
            )
            write_ida(read_readings(frame), Path(folder) / f"{site['station']}.dat")
        readings = read_readings(folder)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DataQualityWarning)
            checked = select_readings(sky_conditions(readings))
            result = nl.validate(
                scene, readings, Path(folder) / "out", calibrate=True, progress=False
            )
        args.out.mkdir(parents=True, exist_ok=True)
        shutil.copy(result.paths["scatter"], args.out / "helsinki_validation.png")
        shutil.copy(result.paths["residual_map"], args.out / "helsinki_validation_residuals.png")
    figure = plot_statistic(checked, "meter_01")
    figure.savefig(args.out / "helsinki_station.png", dpi=110)

    reasons = checked["reason"].replace("", "kept").value_counts().to_dict()
    calibration = result.calibration
    assert calibration is not None
    summary = {
        "readings": len(readings),
        "selection": {str(k): int(v) for k, v in reasons.items()},
        "stations": len(result.stations),
        "as_given": result.summary["overall"],
        "scale": calibration.parameters["scale"],
        "scale_error": calibration.uncertainties["scale"],
        "true_scale": TRUE_SCALE,
        "held_out": calibration.held_out,
        "noise": NOISE,
    }
    (args.out / "helsinki_validation.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"{summary['readings']} readings: {summary['selection']}")
    given = summary["as_given"]
    print(
        f"{summary['stations']} stations as given: bias {given['bias']:+.3f}, RMS "
        f"{given['rms']:.3f} mag arcsec-2"
    )
    print(
        f"calibrated scale {summary['scale']:.3f} +- {summary['scale_error']:.3f} (truth "
        f"{TRUE_SCALE}); held out: bias {calibration.held_out['bias']:+.3f}, RMS "
        f"{calibration.held_out['rms']:.3f} mag arcsec-2 (scatter {NOISE})"
    )


if __name__ == "__main__":
    main()
