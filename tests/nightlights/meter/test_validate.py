"""Predicted against measured, end to end: synthetic readings from a known emission, scale,
turbidity and noise are recovered by the calibration; the outputs; the map against each
station's own panorama; bad inputs."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pyogrio
import pytest
import xarray as xr
from affine import Affine
from pyproj import Transformer

from nightlights.errors import DataQualityWarning, InputError, OutputError
from nightlights.io import Raster
from nightlights.meter import validate
from nightlights.meter.readings import read_readings, write_ida
from nightlights.sky import KernelSpec, Scene, build_kernel
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.observer import OBSERVER_HEIGHT

CRS = "EPSG:32635"
CELL = 200.0
N = 90
TRANSFORM = Affine(CELL, 0, 380_000, 0, -CELL, 6_690_000)
GRID = {"n_elevation": 16, "n_azimuth": 32, "n_distance": 24}
NOISE = 0.05  # [mag arcsec-2]: the scatter of one SQM over clear nights
#: 2026-01-18 (new Moon), astronomical night near Helsinki.
NIGHT = pd.date_range("2026-01-18T19:00", "2026-01-18T23:00", periods=9, tz="UTC")


def emission() -> Raster:
    """Two towns and a village on 18 km of dark land [lm m-2]."""
    rows, cols = np.mgrid[0:N, 0:N]
    flux = np.zeros((N, N))
    for r0, c0, sigma, peak in ((30, 35, 4.0, 1.2), (62, 60, 2.5, 0.5), (15, 75, 1.0, 0.3)):
        flux += peak * np.exp(-((rows - r0) ** 2 + (cols - c0) ** 2) / (2 * sigma**2))
    flux[flux < 1e-3] = 0.0
    return Raster(flux[None], TRANSFORM, CRS, ("lambertian",), ("lm m-2",))


def station_table(count: int, instrument: str, seed: int) -> gpd.GeoDataFrame:
    """Stations at random places inside the raster (not at cell centres), as the station
    statistic gives them (magnitude filled later)."""
    rng = np.random.default_rng(seed)
    west, south, east, north = Raster(np.zeros((1, N, N)), TRANSFORM, CRS).bounds
    x = rng.uniform(west + 300, east - 300, count)
    y = rng.uniform(south + 300, north - 300, count)
    lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(x, y)
    frame = pd.DataFrame(
        {
            "station": [f"s{i:03d}" for i in range(count)],
            "instrument": instrument,
            "lon": lon,
            "lat": lat,
            "magnitude": np.nan,
            "n_readings": 9,
            "n_nights": 1,
            "spread": 0.0,
            "statistic": "mode",
            "time": NIGHT[4],
            "pointing_elevation": 90.0,
            "pointing_azimuth": 0.0,
            "fov": np.nan,
        }
    )
    return gpd.GeoDataFrame(frame, geometry=gpd.points_from_xy(lon, lat), crs="EPSG:4326")


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("kernels")


def truth(stations: gpd.GeoDataFrame, cache: Path, scale: float, turbidity: float) -> np.ndarray:
    """The readings of a known scale and turbidity, from each station's own panorama (the
    reference path, not the map the calibration uses)."""
    raster = emission()
    scaled = Raster(raster.data * scale, raster.transform, raster.crs, raster.descriptions)
    scene = Scene(scaled, turbidity=turbidity, cache_dir=cache, **GRID)
    result = validate(
        scene, stations.assign(magnitude=20.0), natural="typical", method="panorama", progress=False
    )
    return result.stations["predicted"].to_numpy()


#: The wide scene of the turbidity calibration: a city and towns on 60 km of land, stations
#: from 1 to 70 km away, so that the turbidity's signature (brighter near the lights, darker
#: far from them) is sampled over the distances it acts on.
WIDE = Affine(500.0, 0, 300_000, 0, -500.0, 6_720_000)


def wide_emission() -> Raster:
    rows, cols = np.mgrid[0:120, 0:120]
    flux = np.zeros((120, 120))
    for r0, c0, sigma, peak in ((25, 25, 5.0, 20.0), (90, 40, 2.5, 5.0), (50, 100, 2.0, 3.0)):
        flux += peak * np.exp(-((rows - r0) ** 2 + (cols - c0) ** 2) / (2 * sigma**2))
    flux[flux < 1e-3] = 0.0
    return Raster(flux[None], WIDE, CRS, ("lambertian",), ("lm m-2",))


def wide_stations(count: int, seed: int) -> gpd.GeoDataFrame:
    rng = np.random.default_rng(seed)
    x = rng.uniform(300_500, 359_500, count)
    y = rng.uniform(6_660_500, 6_719_500, count)
    lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(x, y)
    frame = station_table(count, "sqm-l", seed)
    frame["lon"], frame["lat"] = lon, lat
    return gpd.GeoDataFrame(
        frame.drop(columns="geometry"), geometry=gpd.points_from_xy(lon, lat), crs="EPSG:4326"
    )


def single_scattering_kernel(turbidity: float, *, uplight: bool = False) -> xr.Dataset:
    """A small kernel of the wide scene (single scattering: seconds to build at any turbidity;
    the shipped multiple-scattering factors are tabulated at turbidity 2 only)."""
    spec = KernelSpec(
        r_max=90_000.0,
        n_distance=24,
        n_elevation=16,
        n_azimuth=32,
        observer_altitudes=(OBSERVER_HEIGHT,),
        atmosphere=Atmosphere(turbidity=turbidity),
        multiple_scattering="single",
        uplight=uplight,
    )
    return build_kernel(spec, progress=False).kernel


def test_calibration_recovers_scale_turbidity_and_noise() -> None:
    """300 SQM-L stations read (each from its own panorama) at scale 0.7 and turbidity 2.6
    with 0.05 mag of noise: the fit over kernels at turbidities 1.5-3.5 (the map method) finds
    the scale within 2 %, the turbidity within 0.1, and its held-out RMS equals the noise
    within 10 %. The fit's own standard errors are within those tolerances (the turbidity's
    under half of it)."""
    stations = wide_stations(300, seed=3)
    raster = wide_emission()
    scaled = Raster(raster.data * 0.7, raster.transform, raster.crs, raster.descriptions)
    reference = validate(
        Scene(scaled, kernel=single_scattering_kernel(2.6)),
        stations.assign(magnitude=20.0),
        natural="typical",
        method="panorama",
        progress=False,
    )
    noise = np.random.default_rng(4).normal(0.0, NOISE, len(stations))
    measured = reference.stations["predicted"].to_numpy() + noise
    kernels = [single_scattering_kernel(t) for t in (1.5, 2.0, 2.5, 3.0, 3.5)]
    result = validate(
        Scene(raster, kernel=kernels[1]),
        stations.assign(magnitude=measured),
        natural="typical",
        calibrate=("scale", "turbidity"),
        kernels=kernels,
        folds=10,
        progress=False,
    )
    calibration = result.calibration
    assert calibration is not None
    assert calibration.parameters["scale"] == pytest.approx(0.7, rel=0.02)
    assert calibration.parameters["turbidity"] == pytest.approx(2.6, abs=0.1)
    assert calibration.held_out["rms"] == pytest.approx(NOISE, rel=0.10)
    # the fit says how well it knows them
    assert calibration.uncertainties["turbidity"] < 0.05
    assert calibration.uncertainties["scale"] < 0.02 * 0.7


def test_scale_alone_and_outputs(cache: Path, tmp_path: Path) -> None:
    """Scale 2 at the scene's turbidity, 0.05 mag of noise: recovered within 2 %; the four
    files (and the calibrated emission) are written, the summary says what the figures say."""
    stations = station_table(40, "sqm", seed=8)
    measured = truth(stations, cache, 2.0, 2.0)
    measured = measured + np.random.default_rng(1).normal(0.0, 0.05, measured.size)
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    out = tmp_path / "validation"
    result = validate(
        scene,
        stations.assign(magnitude=measured),
        out,
        natural="typical",
        calibrate=True,
        progress=False,
    )
    assert result.calibration is not None
    assert result.calibration.parameters["scale"] == pytest.approx(2.0, rel=0.02)
    # the model as given (scale 1) is darker than the readings (scale 2): measured - predicted < 0
    assert result.summary["overall"]["bias"] < -0.3
    assert set(result.paths) == {"stations", "summary", "scatter", "residual_map", "calibrated"}
    for path in result.paths.values():
        assert path.is_file() and path.stat().st_size > 0
    summary = json.loads(result.paths["summary"].read_text())
    assert summary["overall"]["n"] == 40
    assert summary["per_instrument"]["sqm"]["rms"] == pytest.approx(
        float(np.sqrt(np.mean(result.stations["residual"] ** 2))), abs=1e-4
    )
    layer = gpd.read_file(result.paths["stations"], layer="stations")
    assert {"measured", "predicted", "residual", "station"} <= set(layer.columns)
    assert "layer_styles" in pyogrio.list_layers(result.paths["stations"])[:, 0]
    calibrated = Raster.read(result.paths["calibrated"])
    np.testing.assert_allclose(
        calibrated.data[0],
        emission().data[0] * result.calibration.parameters["scale"],
        rtol=1e-6,
    )


def test_map_matches_own_panoramas(cache: Path) -> None:
    """The darkness-map method against each station's own panorama (same kernel): within
    0.05 mag at every station, also for the wide SQM."""
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    for instrument in ("sqm", "sqm-l"):
        stations = station_table(15, instrument, seed=11).assign(magnitude=20.0)
        fast = validate(scene, stations, natural="typical", progress=False)
        slow = validate(scene, stations, natural="typical", method="panorama", progress=False)
        error = fast.stations["predicted"] - slow.stations["predicted"]
        assert np.abs(error).max() < 0.05, instrument


def test_readings_files_end_to_end(cache: Path, tmp_path: Path) -> None:
    """Community-standard files through the whole chain: read, Sun and Moon, selection,
    station statistic, prediction (natural sky at the station's time)."""
    stations = station_table(3, "sqm-l", seed=2)
    folder = tmp_path / "readings"
    folder.mkdir()
    rows = []
    for _, station in stations.iterrows():
        for when in NIGHT:
            rows.append(
                {
                    "station": station["station"],
                    "time": when,
                    "magnitude": 20.5,
                    "instrument": "sqm-l",
                    "lon": station["lon"],
                    "lat": station["lat"],
                }
            )
    table = pd.DataFrame(rows)
    for name, group in table.groupby("station"):
        frame = read_readings(group.reset_index(drop=True))
        write_ida(frame, folder / f"{name}.dat")
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    result = validate(scene, folder, progress=False)
    assert len(result.stations) == 3
    assert np.allclose(result.stations["measured"], 20.5, atol=0.02)
    assert np.all(np.isfinite(result.stations["predicted"]))
    # the natural sky at that time through a 20 deg field: near 22 mag arcsec-2
    natural = -2.5 * np.log10(result.stations["natural"] / 1.08e5)
    assert np.all((natural > 21.0) & (natural < 23.0))


def test_stations_outside_are_left_out_with_a_warning(cache: Path) -> None:
    stations = station_table(4, "sqm", seed=5).assign(magnitude=20.0)
    stations.loc[0, ["lon", "lat"]] = (30.0, 65.0)  # far north of the raster
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    with pytest.warns(DataQualityWarning, match="1 station outside .* left out: s000"):
        result = validate(scene, stations, natural="typical", progress=False)
    assert len(result.stations) == 3


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"lon": 30.0, "lat": 65.0}, InputError, "none of the 4 stations lies inside"),
        ({"instrument": "photometer"}, InputError, "photometer"),
    ],
)
def test_bad_stations_refused(cache: Path, change: dict, error: type, message: str) -> None:
    stations = station_table(4, "sqm", seed=5).assign(magnitude=20.0)
    for column, value in change.items():
        stations[column] = value
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    with pytest.raises(error, match=message):
        validate(scene, stations, natural="typical", progress=False)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"method": "exact"}, "method='exact'"),
        ({"natural": "moonlit"}, "natural='moonlit'"),
        ({"calibrate": ("scale", "colour")}, "calibrate="),
        ({"calibrate": ("turbidity",), "turbidities": (2.0,)}, "turbidities="),
    ],
)
def test_bad_options_refused(cache: Path, options: dict, message: str) -> None:
    stations = station_table(6, "sqm", seed=5).assign(magnitude=20.0)
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        with pytest.raises(InputError, match=message):
            validate(scene, stations, **{"natural": "typical", "progress": False, **options})


def test_too_few_stations_to_calibrate_writes_nothing(cache: Path, tmp_path: Path) -> None:
    stations = station_table(2, "sqm", seed=5).assign(magnitude=20.0)
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    out = tmp_path / "out"
    with pytest.raises(InputError, match="2 stations for 2 parameters"):
        validate(
            scene,
            stations,
            out,
            natural="typical",
            calibrate=("scale", "turbidity"),
            turbidities=(1.5, 2.5),
            progress=False,
        )
    assert not out.exists() or not any(out.iterdir())


def test_existing_outputs_refused(cache: Path, tmp_path: Path) -> None:
    stations = station_table(4, "sqm", seed=5).assign(magnitude=20.0)
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    out = tmp_path / "out"
    out.mkdir()
    (out / "validation.json").write_text("{}")
    with pytest.raises(OutputError, match=r"validation\.json: exists"):
        validate(scene, stations, out, natural="typical", progress=False)
    assert (out / "validation.json").read_text() == "{}"


def test_viirs_emission_and_terrain() -> None:
    """An emission from a VIIRS radiance raster (its spectrum tag sets the colour term) and the
    same scene over hills: predictions for every station, the terrain changing them."""
    from nightlights import emission_from_viirs

    rows, cols = np.mgrid[0:N, 0:N]
    radiance = 40.0 * np.exp(-((rows - 30) ** 2 + (cols - 35) ** 2) / 30.0) + 0.3
    viirs = Raster(radiance[None], TRANSFORM, CRS, ("radiance",), ("nW cm-2 sr-1",))
    upward = emission_from_viirs(viirs, spectrum="HPS").raster
    stations = station_table(6, "sqm-l", seed=4).assign(magnitude=20.0)
    flat = validate(Scene(upward, **GRID), stations, natural="typical", progress=False)
    assert flat.summary["model"]["spectrum"] == "HPS"
    assert np.all(np.isfinite(flat.stations["predicted"]))
    hills = Raster((150 + 120 * np.sin(cols / 9.0) * np.cos(rows / 13.0))[None], TRANSFORM, CRS)
    over = validate(Scene(upward, dem=hills, **GRID), stations, natural="typical", progress=False)
    assert np.all(np.isfinite(over.stations["predicted"]))
    assert not np.allclose(over.stations["predicted"], flat.stations["predicted"], atol=1e-3)


def test_low_angle_share_recovered_from_a_two_band_emission(tmp_path: Path) -> None:
    """Reflected light and direct uplight (the untagged two-band emission): readings made with
    the uplight's share of the flux raised from 5 % to 15 % and the total scaled by 0.8 give
    back that share within 0.04 (three of the fit's standard errors, which are under 0.02: the
    share moves these stations' readings by under 0.1 mag) and the scale within 3 %; the
    calibrated emission carries them. Without noise both come back exactly."""
    reflected = wide_emission().data[0]
    flux = np.stack([reflected * 0.95, reflected * 0.05])
    emission = Raster(flux, WIDE, CRS)
    truth = Raster(np.stack([reflected * 0.85, reflected * 0.15]) * 0.8, WIDE, CRS)
    kernel = single_scattering_kernel(2.0, uplight=True)
    stations = wide_stations(200, seed=12)
    reference = validate(
        Scene(truth, kernel=kernel),
        stations.assign(magnitude=20.0),
        natural="typical",
        progress=False,
    )
    measured = reference.stations["predicted"].to_numpy()
    measured = measured + np.random.default_rng(5).normal(0.0, NOISE, measured.size)
    result = validate(
        Scene(emission, kernel=kernel),
        stations.assign(magnitude=measured),
        tmp_path / "out",
        natural="typical",
        calibrate=("scale", "share"),
        folds=5,
        progress=False,
    )
    calibration = result.calibration
    assert calibration is not None
    assert calibration.uncertainties["share"] < 0.02
    assert calibration.parameters["share"] == pytest.approx(0.15, abs=0.04)
    assert calibration.parameters["scale"] == pytest.approx(0.8, rel=0.03)
    calibrated = Raster.read(result.paths["calibrated"])
    total = np.nansum(calibrated.data, axis=(1, 2))
    assert total[1] / total.sum() == pytest.approx(calibration.parameters["share"], rel=1e-4)


def test_share_needs_two_bands() -> None:
    stations = station_table(4, "sqm", seed=5).assign(magnitude=20.0)
    with pytest.raises(InputError, match="two-band emission"):
        validate(
            Scene(emission(), **GRID),
            stations,
            natural="typical",
            calibrate=("share",),
            progress=False,
        )


def test_a_given_selection_is_kept(cache: Path) -> None:
    """Readings already selected (``kept``, e.g. with the user's own limits) are not selected
    again with the default limits: twilight readings marked kept are used."""
    from nightlights.errors import EmptyInputError
    from nightlights.meter import select_readings, sky_conditions

    station = station_table(1, "sqm-l", seed=2).iloc[0]
    twilight = pd.date_range("2026-01-18T15:00", periods=6, freq="10min", tz="UTC")
    frame = pd.DataFrame(
        {
            "station": "dusk",
            "time": twilight,
            "magnitude": 19.0,
            "instrument": "sqm-l",
            "lon": station["lon"],
            "lat": station["lat"],
        }
    )
    readings = read_readings(frame)
    scene = Scene(emission(), turbidity=2.0, cache_dir=cache, **GRID)
    with pytest.raises(EmptyInputError, match="sun"):
        validate(scene, readings, natural="typical", progress=False)
    mine = select_readings(sky_conditions(readings), sun_limit=0.0)
    result = validate(scene, mine, natural="typical", progress=False)
    assert result.stations["station"].tolist() == ["dusk"]
