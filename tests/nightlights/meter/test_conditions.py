"""Which readings count: the Sun and the Moon per reading, the selection, the station statistic.

The ephemerides are checked against PyEphem 4 (libastro: VSOP87 Sun, ELP Moon; airless with
``pressure = 0``, the Moon topocentric) at random instants and sites; the selection on a
synthetic night whose expected reasons come from PyEphem; the statistics on synthetic series
whose clear level is known; and the one-line errors and warnings.
"""

from __future__ import annotations

import math
import re
import warnings
from datetime import UTC, datetime, timedelta
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest

import nightlights.meter.conditions as conditions
from nightlights.brightness import NATURAL_ZENITH_LUMINANCE
from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.meter.conditions import (
    CLOUD_LIMIT,
    DEFAULT_STATISTIC,
    MOON_LIMIT,
    SUN_LIMIT,
    local_night,
    plot_statistic,
    select_readings,
    sky_conditions,
    station_statistic,
    station_values,
)
from nightlights.nightsky import schaefer_twilight
from nightlights.nightsky._photometry import moon_v_magnitude

ephem = pytest.importorskip("ephem")

#: The columns of the station table (:func:`station_values`), as the validation reads them.
STATION_COLUMNS = {
    "station",
    "instrument",
    "lon",
    "lat",
    "geometry",
    "magnitude",
    "n_readings",
    "n_nights",
    "spread",
    "statistic",
    "time",
    "pointing_elevation",
    "pointing_azimuth",
    "fov",
}


def _readings(
    times: Any,
    lon: Any,
    lat: Any,
    *,
    station: Any = "s",
    magnitude: Any = 20.0,
    instrument: str = "sqm",
    sky_temperature: Any = np.nan,
    ambient_temperature: Any = np.nan,
) -> gpd.GeoDataFrame:
    """A readings table with the documented columns."""
    time = pd.Series(pd.to_datetime(times, utc=True)).dt.as_unit("ns")
    n = len(time)
    lon = np.broadcast_to(np.asarray(lon, dtype=float), (n,))
    lat = np.broadcast_to(np.asarray(lat, dtype=float), (n,))
    return gpd.GeoDataFrame(
        {
            "station": np.broadcast_to(np.asarray(station, dtype=object), (n,)),
            "time": time,
            "magnitude": np.broadcast_to(np.asarray(magnitude, dtype=float), (n,)),
            "instrument": instrument,
            "fov": np.nan,
            "pointing_elevation": 90.0,
            "pointing_azimuth": 0.0,
            "sky_temperature": np.broadcast_to(np.asarray(sky_temperature, dtype=float), (n,)),
            "ambient_temperature": np.broadcast_to(
                np.asarray(ambient_temperature, dtype=float), (n,)
            ),
            "lon": lon,
            "lat": lat,
            "source": "synthetic",
        },
        geometry=gpd.points_from_xy(lon, lat),
        crs="EPSG:4326",
    )


def _ephem_state(when: datetime, lon: float, lat: float) -> tuple[float, float, float]:
    """PyEphem's airless Sun and (topocentric) Moon altitudes [deg] and the Moon's phase [1]."""
    observer = ephem.Observer()
    observer.lon, observer.lat = math.radians(lon), math.radians(lat)
    observer.elevation = 0.0
    observer.pressure = 0.0  # no refraction: geometric altitudes, like ours
    observer.date = ephem.Date(when.astimezone(UTC).replace(tzinfo=None))
    sun, moon = ephem.Sun(observer), ephem.Moon(observer)
    return math.degrees(sun.alt), math.degrees(moon.alt), float(moon.moon_phase)


# --- the Sun and the Moon against PyEphem -----------------------------------------------------


def test_sky_conditions_agree_with_ephem_at_random_instants_and_sites() -> None:
    # 40 instants of 1990-2040 at latitudes -60..70, one reading each (the direct path):
    # measured Sun 0.009 deg, Moon 0.004 deg, illuminated fraction 0.009
    rng = np.random.default_rng(2016)
    start = datetime(1990, 1, 1, tzinfo=UTC)
    when = [start + timedelta(days=float(d)) for d in rng.uniform(0, 50 * 365.25, 40)]
    lon, lat = rng.uniform(-180, 180, 40), rng.uniform(-60, 70, 40)
    table = sky_conditions(_readings(when, lon, lat, station=[f"p{i}" for i in range(40)]))
    reference = np.array([_ephem_state(w, x, y) for w, x, y in zip(when, lon, lat, strict=True)])
    sun_error = np.abs(table["sun_elevation"].to_numpy() - reference[:, 0])
    moon_error = np.abs(table["moon_elevation"].to_numpy() - reference[:, 1])
    phase_error = np.abs(table["moon_illumination"].to_numpy() - reference[:, 2])
    assert sun_error.max() < 0.1 and moon_error.max() < 0.1
    assert phase_error.max() < 0.02


@pytest.mark.parametrize("lat", [-35.0, 0.0, 20.0, 52.0, 69.0])
def test_interpolated_series_agree_with_ephem(lat: float) -> None:
    # a month of readings every 7 minutes at one place goes through the interpolation;
    # 30 of them against PyEphem (measured over the five latitudes: Sun 0.005 deg, Moon
    # 0.003 deg, illuminated fraction 0.008)
    times = pd.date_range("2031-05-03T00:00Z", periods=6000, freq="7min")
    table = sky_conditions(_readings(times, 17.0, lat))
    for i in np.random.default_rng(int(lat) + 100).choice(len(times), 30, replace=False):
        sun, moon, phase = _ephem_state(times[i].to_pydatetime(), 17.0, lat)
        row = table.iloc[i]
        assert row.sun_elevation == pytest.approx(sun, abs=0.1)
        assert row.moon_elevation == pytest.approx(moon, abs=0.1)
        assert row.moon_illumination == pytest.approx(phase, abs=0.02)


@pytest.mark.parametrize("lat", [0.0, 20.0, 45.0, 65.0, -80.0])
def test_interpolation_matches_the_direct_ephemerides(lat: float) -> None:
    # the interpolation between hourly nodes departs from the direct evaluation by < 1e-3 deg
    # (measured: at most 5e-5 deg), near the zenith too (the sines are interpolated)
    rng = np.random.default_rng(7)
    ns = np.int64(1_700_000_000) * 10**9 + np.sort(rng.integers(0, 30 * 86_400 * 10**9, 4000))
    sample = rng.choice(ns.size, 200, replace=False)
    interpolated = conditions._ephemerides(ns, 10.0, lat)[:, sample]
    direct = conditions._direct(ns[sample], 10.0, lat)
    assert np.abs(interpolated[:2] - direct[:2]).max() < 1e-3
    assert np.abs(interpolated[2] - direct[2]).max() < 1e-4


def test_a_dense_series_evaluates_the_ephemerides_hourly(monkeypatch: pytest.MonkeyPatch) -> None:
    # 2 days of readings every minute (2880) need the Moon at about 48 + 8 hourly nodes
    calls = []
    original = conditions.moon_state

    def counting(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(conditions, "moon_state", counting)
    times = pd.date_range("2024-03-01T00:00Z", periods=2880, freq="1min")
    sky_conditions(_readings(times, 2.35, 48.85))
    assert len(calls) <= 48 + 8


def test_empty_readings_give_empty_conditions() -> None:
    table = sky_conditions(_readings([], [], []))
    assert len(table) == 0
    assert {"sun_elevation", "moon_elevation", "moon_illumination"} <= set(table.columns)
    assert len(select_readings(table)) == 0


# --- the limits -------------------------------------------------------------------------------


def test_moon_limit_keeps_even_a_full_moons_twilight_out() -> None:
    # Schaefer's (1993) twilight with the full Moon's V (Krisciunas & Schaefer 1991, Eq. 9):
    # with the Moon just below the horizon the zenith is 80 % brighter than a 22.0 sky; at
    # MOON_LIMIT the Moon adds 1.1e-4 of it
    full = moon_v_magnitude(0.0)

    def share(elevation: float) -> float:
        twilight = schaefer_twilight([90.0], [0.0], elevation, 180.0, sun_magnitude=full)
        return float(twilight[0] / NATURAL_ZENITH_LUMINANCE)

    assert share(-0.5) > 0.5
    assert share(MOON_LIMIT) < 2e-4
    # the Sun at SUN_LIMIT: a few per cent of the darkest sky (Schaefer's fit)
    sun = schaefer_twilight([90.0], [0.0], SUN_LIMIT, 180.0)
    assert float(sun[0] / NATURAL_ZENITH_LUMINANCE) < 0.05


# --- the selection on a synthetic night -------------------------------------------------------


def test_selection_of_a_synthetic_night_follows_sun_moon_and_clouds() -> None:
    # Paris, the night of 2024 January 11/12 (new Moon at 11:57 UTC) and of January 25/26
    # (full Moon at 17:54 UTC), a reading every 10 minutes from noon to noon; every fifth
    # reading of the first night carries a cloudy sky temperature, one has no magnitude
    lon, lat = 2.35, 48.85
    times = list(pd.date_range("2024-01-11T12:00Z", "2024-01-12T12:00Z", freq="10min")) + list(
        pd.date_range("2024-01-25T12:00Z", "2024-01-26T12:00Z", freq="10min")
    )
    n = len(times)
    sky = np.full(n, -35.0)
    sky[: n // 2 : 5] = -8.0  # overcast: 8 degC below ambient
    magnitude = np.full(n, 21.0)
    magnitude[3] = np.nan
    table = select_readings(
        _readings(
            times, lon, lat, magnitude=magnitude, sky_temperature=sky, ambient_temperature=0.0
        )
    )
    expected = []
    for i, when in enumerate(times):
        sun, moon, _ = _ephem_state(when.to_pydatetime(), lon, lat)
        if not np.isfinite(magnitude[i]):
            expected.append("invalid")
        elif sun >= SUN_LIMIT:
            expected.append("sun")
        elif moon >= MOON_LIMIT:
            expected.append("moon")
        elif sky[i] >= CLOUD_LIMIT:
            expected.append("cloud")
        else:
            expected.append("")
    reasons = table["reason"].tolist()
    assert reasons == expected
    assert table["kept"].tolist() == [r == "" for r in expected]
    counts = pd.Series(expected).value_counts()
    # the new-Moon night is dark and partly cloudy, the full-Moon night all moonlit
    assert counts[""] > 50 and counts["cloud"] > 10 and counts["moon"] > 50
    assert "" not in set(reasons[n // 2 :])
    assert reasons[3] == "invalid"  # the first failed test wins: invalid before sun


def test_limits_are_parameters() -> None:
    table = _readings(["2024-01-11T22:00Z"], 2.35, 48.85, sky_temperature=-20.0)
    table["ambient_temperature"] = 0.0
    assert select_readings(table)["reason"].tolist() == ["cloud"]
    assert select_readings(table, cloud_limit=-15.0)["reason"].tolist() == [""]
    assert select_readings(table, sun_limit=-90.0)["reason"].tolist() == ["sun"]
    with pytest.raises(InputError, match=r"^moon_limit=nan; expected a finite value"):
        select_readings(table, moon_limit=float("nan"))


# --- the station statistic --------------------------------------------------------------------


def _series(
    clear: float, cloudy: tuple[float, float], *, nights: int = 30, cloudy_share: float = 0.4
) -> tuple[np.ndarray, np.ndarray]:
    """Readings of many nights: clear ones steady at ``clear``, cloudy ones spread evenly."""
    rng = np.random.default_rng(11)
    magnitude, night = [], []
    for k in range(nights):
        count = int(rng.integers(40, 90))
        if rng.random() < cloudy_share:
            values = rng.uniform(*cloudy, count)
        elif rng.random() < 0.3:  # partly cloudy: clear half the night
            values = np.r_[
                clear + rng.normal(0.0, 0.03, count // 2), rng.uniform(*cloudy, count - count // 2)
            ]
        else:
            values = clear + rng.normal(0.0, 0.03, count)
        magnitude.append(values)
        night.append(np.full(count, k))
    return np.concatenate(magnitude), np.concatenate(night)


@pytest.mark.parametrize(
    ("clear", "cloudy"),
    [(19.80, (17.0, 19.5)), (21.80, (21.95, 22.8))],
    ids=["light-polluted: clouds brighten", "pristine: clouds darken"],
)
def test_mode_recovers_the_clear_sky_whichever_way_clouds_push(
    clear: float, cloudy: tuple[float, float]
) -> None:
    magnitude, night = _series(clear, cloudy)
    value, spread = station_statistic(magnitude, night)
    assert DEFAULT_STATISTIC == "mode"
    assert value == pytest.approx(clear, abs=0.05)
    assert spread > 0.0
    # the darkest readings are the clouds at the pristine site, the clear sky in the city
    darkest, _ = station_statistic(magnitude, night, statistic="percentile:90")
    if cloudy[0] > clear:
        assert darkest - clear > 0.3
    else:
        assert darkest == pytest.approx(clear, abs=0.1)


def test_statistics_by_hand() -> None:
    values = np.array([20.0, 20.2, 20.4, 20.6, 20.8, 21.0])
    one_night = np.zeros(values.size, int)
    assert station_statistic(values, one_night, statistic="median")[0] == pytest.approx(20.5)
    # the darkest third: mean of 20.8 and 21.0 (Bará 2016's m_1/3)
    assert station_statistic(values, one_night, statistic="darkest_third")[0] == pytest.approx(20.9)
    for p in (10, 37.5, 90):
        expected = np.percentile(values, p, method="hazen")
        got, _ = station_statistic(values, one_night, statistic=f"percentile:{p}")
        assert got == pytest.approx(expected)
    # every night weighs the same: 100 readings of one night against 1 each of three others
    values = np.r_[np.full(100, 20.0), [21.0, 21.0, 21.0]]
    night = np.r_[np.zeros(100, int), [1, 2, 3]]
    assert station_statistic(values, night, statistic="median")[0] == pytest.approx(21.0)
    assert station_statistic(values, night)[0] == pytest.approx(21.0, abs=0.01)


def test_a_wild_reading_does_not_move_or_stall_the_mode() -> None:
    magnitude, night = _series(19.8, (17.0, 19.5))
    wild = np.r_[magnitude, 1e9, -1e9]
    value, _ = station_statistic(wild, np.r_[night, 0, 0])
    assert value == pytest.approx(station_statistic(magnitude, night)[0], abs=0.01)


def test_local_night_runs_noon_to_noon_at_the_stations_longitude() -> None:
    times = pd.Series(pd.to_datetime(["2024-03-01T11:59Z", "2024-03-01T12:01Z"], utc=True))
    assert np.diff(local_night(times, 0.0)).tolist() == [1]
    # at 90 deg east local noon is 06:00 UTC: both instants in the same night
    assert np.diff(local_night(times, 90.0)).tolist() == [0]


def test_station_values_one_row_per_station() -> None:
    # two stations over three new-Moon nights of 2024 January at Paris and Madrid
    times = pd.date_range("2024-01-09T12:00Z", "2024-01-12T12:00Z", freq="5min")
    rng = np.random.default_rng(3)
    paris = _readings(
        times, 2.35, 48.85, station="paris", magnitude=18.5 + rng.normal(0, 0.02, len(times))
    )
    madrid = _readings(
        times,
        -3.70,
        40.42,
        station="madrid",
        magnitude=17.9 + rng.normal(0, 0.02, len(times)),
        instrument="tess-w",
        sky_temperature=-30.0,
        ambient_temperature=5.0,
    )
    readings = pd.concat([paris, madrid], ignore_index=True)
    stations = station_values(readings)
    assert set(stations.columns) == STATION_COLUMNS
    assert stations["station"].tolist() == ["madrid", "paris"]
    assert stations.crs == readings.crs
    assert stations["magnitude"].to_numpy() == pytest.approx([17.9, 18.5], abs=0.03)
    assert stations["n_nights"].tolist() == [3, 3]
    assert stations["instrument"].tolist() == ["tess-w", "sqm"]
    assert (stations["statistic"] == "mode").all()
    selected = select_readings(readings)
    for row in stations.itertuples():
        kept = selected[selected["kept"] & (selected["station"] == row.station)]
        assert row.n_readings == len(kept)
        assert row.time in set(kept["time"])  # a real, kept instant
    assert stations.geometry.x.to_numpy() == pytest.approx([-3.70, 2.35])


# --- errors and warnings ----------------------------------------------------------------------


def test_readings_without_time_or_position_are_refused() -> None:
    table = _readings(["2024-01-11T22:00Z", "2024-01-11T23:00Z"], 2.35, 48.85)
    with pytest.raises(InputError, match=r"^readings have no 'time' column"):
        sky_conditions(table.drop(columns="time"))
    missing = table.copy()
    missing.loc[1, "time"] = pd.NaT
    with pytest.raises(InputError, match=r"^readings: 1 of 2 rows have no time \(NaT\)"):
        sky_conditions(missing)
    naive = table.copy()
    naive["time"] = naive["time"].dt.tz_localize(None)
    with pytest.raises(InputError, match=r"has no time zone \(naive\)"):
        select_readings(naive)
    with pytest.raises(InputError, match=r"^readings have no 'lon' column"):
        sky_conditions(table.drop(columns="lon"))
    nowhere = table.copy()
    nowhere.loc[0, "lat"] = np.nan
    with pytest.raises(InputError, match=r"^readings: 1 of 2 rows have no usable position"):
        station_values(nowhere)


def test_unknown_statistic_names_the_choices() -> None:
    table = _readings(["2024-01-11T22:00Z"], 2.35, 48.85)
    for bad in ("mean", "percentile:100", "percentile:x"):
        with pytest.raises(InputError, match=r"expected one of 'mode', 'median', 'darkest_third'"):
            station_values(table, statistic=bad)


def test_a_station_with_nothing_kept_is_named_and_left_out() -> None:
    dark = _readings(pd.date_range("2024-01-11T20:00Z", periods=12, freq="10min"), 2.35, 48.85)
    day = _readings(
        pd.date_range("2024-01-11T10:00Z", periods=12, freq="10min"), 2.35, 48.85, station="noon"
    )
    with pytest.warns(DataQualityWarning) as caught:
        stations = station_values(pd.concat([dark, day], ignore_index=True))
    assert stations["station"].tolist() == ["s"]
    (message,) = [str(w.message) for w in caught]
    assert message == "station 'noon': none of its 12 readings count (12 sun); left out"
    assert "\n" not in message


def test_every_station_empty_counts_the_reasons() -> None:
    day = _readings(pd.date_range("2024-01-11T10:00Z", periods=6, freq="10min"), 2.35, 48.85)
    moonlit = _readings(
        pd.date_range("2024-01-25T23:00Z", periods=4, freq="10min"), 2.35, 48.85, station="m"
    )
    cloudy = _readings(
        pd.date_range("2024-01-11T22:00Z", periods=3, freq="10min"),
        2.35,
        48.85,
        station="c",
        sky_temperature=-5.0,
        ambient_temperature=0.0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)
        with pytest.raises(EmptyInputError) as raised:
            station_values(pd.concat([day, moonlit, cloudy], ignore_index=True))
    assert str(raised.value) == (
        "no clear moonless astronomical-night readings: 6 sun, 4 moon, 3 cloud"
    )


def test_a_station_of_two_instruments_is_refused() -> None:
    table = _readings(["2024-01-11T22:00Z", "2024-01-11T23:00Z"], 2.35, 48.85)
    table.loc[1, "instrument"] = "tess-w"
    with pytest.raises(InputError, match=r"^station 's': readings of 2 instruments"):
        station_values(table)


# --- the chart --------------------------------------------------------------------------------


def test_plot_statistic_marks_the_choice() -> None:
    magnitude, night = _series(19.8, (17.0, 19.5), nights=8)
    start = pd.Timestamp("2024-01-06T20:00Z")  # new-Moon week at Paris: 3 minutes apart
    times = [
        start + pd.Timedelta(days=int(k)) + pd.Timedelta(minutes=3 * int(j))
        for k, j in zip(night, _rank_within(night), strict=True)
    ]
    readings = _readings(times, 2.35, 48.85, magnitude=magnitude)
    figure = plot_statistic(readings, "s")
    series_ax, hist_ax = figure.axes
    value = float(station_values(readings)["magnitude"].iloc[0])
    chosen = [line for line in hist_ax.get_lines() if line.get_label().startswith("mode ")]
    assert len(chosen) == 1 and chosen[0].get_xdata()[0] == pytest.approx(value)
    assert any(
        line.get_ydata()[0] == pytest.approx(value)
        for line in series_ax.get_lines()
        if len(line.get_ydata()) == 2
    )
    assert re.search(r"station s: mode", figure.get_suptitle())
    with pytest.raises(InputError, match=r"^station='x'; expected one of 's'"):
        plot_statistic(readings, "x")


def _rank_within(night: np.ndarray) -> np.ndarray:
    """The position of each reading within its night."""
    rank = np.zeros(night.size, int)
    for k in np.unique(night):
        where = np.flatnonzero(night == k)
        rank[where] = np.arange(where.size)
    return rank


def test_naked_eye_reports_of_clouds_are_rejected() -> None:
    """Globe at Night reports: clear (0) and unknown (NaN) cover kept, any cloud rejected; a
    looser cloud_cover_limit keeps a quarter-clouded report."""
    midnight = datetime(2026, 1, 18, 22, 0, tzinfo=UTC)  # new Moon, dark at 60 N
    table = _readings([midnight] * 4, 24.9, 60.2, station=["a", "b", "c", "d"], instrument="eye")
    table["cloud_cover"] = [0.0, np.nan, 0.25, 0.75]
    selected = select_readings(table)
    assert selected["reason"].tolist() == ["", "", "cloud", "cloud"]
    looser = select_readings(table, cloud_cover_limit=0.25)
    assert looser["reason"].tolist() == ["", "", "", "cloud"]


def test_a_selection_without_reasons_is_kept() -> None:
    """A table selected elsewhere (``kept`` without ``reason``) keeps its selection."""
    midnight = datetime(2026, 1, 18, 22, 0, tzinfo=UTC)
    times = [midnight + timedelta(minutes=5 * i) for i in range(6)]
    table = _readings(times, 24.9, 60.2, magnitude=[20.0, 20.0, 20.0, 18.0, 18.0, 18.0])
    table["kept"] = [True, True, True, False, False, False]
    values = station_values(table)
    assert values["magnitude"].iloc[0] == pytest.approx(20.0, abs=0.01)
    assert values["n_readings"].iloc[0] == 3
