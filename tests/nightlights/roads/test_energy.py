"""Energy: burning hours against an independent sunrise/sunset computation, polar night and day,
dimming schedules against hand integration, the EN 13201-5 indicators by hand, bad input, and
where a light's power comes from."""

from __future__ import annotations

import math
from datetime import time
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nightlights.errors import InputError
from nightlights.roads import (
    CIVIL_TWILIGHT,
    DimmingSchedule,
    annual_burning_hours,
    annual_energy,
    burning_intervals,
    co2_emissions,
    energy_consumption_indicator,
    full_power_hours,
    light_power,
    parse_schedule,
    power_density_indicator,
    schedule_level,
    scheduled_hours,
    sun_elevation,
)


def _spencer(day_of_year: np.ndarray, days_in_year: int) -> np.ndarray:
    """Solar declination [rad] at noon UTC, Spencer (1971) Fourier series (NOAA's General
    Solar Position): independent of the Meeus theory the code uses."""
    g = 2.0 * np.pi / days_in_year * (day_of_year - 1)
    return (
        0.006918
        - 0.399912 * np.cos(g)
        + 0.070257 * np.sin(g)
        - 0.006758 * np.cos(2 * g)
        + 0.000907 * np.sin(2 * g)
        - 0.002697 * np.cos(3 * g)
        + 0.00148 * np.sin(3 * g)
    )


def _independent_night_hours(latitude: float, year: int, h0: float = -0.833) -> float:
    """Hours of a year with the Sun below h0: the year less each day's sunrise-to-sunset span
    from the hour angle cos w = (sin h0 - sin phi sin d) / (cos phi cos d)."""
    days = 366 if year % 4 == 0 else 365
    dec = _spencer(np.arange(1, days + 1), days)
    phi = math.radians(latitude)
    cos_w = (math.sin(math.radians(h0)) - math.sin(phi) * np.sin(dec)) / (
        math.cos(phi) * np.cos(dec)
    )
    day_hours = 2.0 * np.degrees(np.arccos(np.clip(cos_w, -1.0, 1.0))) / 15.0
    return 24.0 * days - float(day_hours.sum())


@pytest.mark.parametrize(
    ("longitude", "latitude"), [(0.0, 0.0), (10.0, 40.0), (-5.0, 60.0), (20.0, -35.0)]
)
def test_burning_hours_and_energy_match_an_independent_sunset_sunrise(
    longitude: float, latitude: float
) -> None:
    expected = _independent_night_hours(latitude, 2023)
    hours = annual_burning_hours(longitude, latitude, 2023)
    assert hours == pytest.approx(expected, rel=0.01)
    assert hours == pytest.approx(expected, rel=0.002)  # much better than the 1 % asked
    kwh = float(annual_energy(150.0, longitude, latitude, 2023)) / 1000.0
    assert kwh == pytest.approx(0.150 * expected, rel=0.01)


def test_civil_twilight_shortens_the_nights_as_the_hour_angle_says() -> None:
    expected = _independent_night_hours(40.0, 2023, h0=CIVIL_TWILIGHT)
    hours = annual_burning_hours(0.0, 40.0, 2023, switch_elevation=CIVIL_TWILIGHT)
    assert hours == pytest.approx(expected, rel=0.002)


def test_sun_elevation_agrees_with_the_night_sky_ephemeris() -> None:
    from nightlights.nightsky.moon import sun_position

    for instant, lon, lat in [
        ("2024-03-05T17:33", 13.4, 52.5),
        ("2021-06-21T03:00", -70.0, -30.0),
        ("2030-11-30T12:00", 150.0, 10.0),
    ]:
        _, elevation = sun_position(instant, lon, lat)
        assert float(sun_elevation(np.datetime64(instant), lon, lat)) == pytest.approx(
            elevation, abs=0.005
        )


def test_crossings_sit_on_the_switch_elevation_and_the_step_does_not_matter() -> None:
    nights = burning_intervals(7.0, 66.0, 2024)
    inner_on = nights.on[1:]
    inner_off = nights.off[:-1]
    assert np.abs(sun_elevation(inner_on, 7.0, 66.0) + 0.8333).max() < 1e-3
    assert np.abs(sun_elevation(inner_off, 7.0, 66.0) + 0.8333).max() < 1e-3
    coarse = burning_intervals(7.0, 66.0, 2024, step_minutes=60.0)
    assert coarse.total_hours == pytest.approx(nights.total_hours, abs=1e-3)


def test_polar_night_and_polar_day_at_78_north() -> None:
    longitude, latitude = 15.6, 78.0
    nights = burning_intervals(longitude, latitude, 2024)
    # independent: the polar night ends on the first day the noon Sun (90 - phi + dec)
    # reaches -0.833 deg; the polar day holds while the midnight Sun (dec - (90 - phi)) is above
    dec = np.degrees(_spencer(np.arange(1, 367), 366))
    noon_up = 90.0 - latitude + dec >= -0.833
    midnight_up = dec - (90.0 - latitude) > -0.833
    first_light = int(np.argmax(noon_up))  # day index, 0 = January 1
    assert nights.on[0] == np.datetime64("2024-01-01T00:00")
    end_of_polar_night = (nights.off[0] - np.datetime64("2024-01-01")) / np.timedelta64(1, "D")
    assert abs(end_of_polar_night - first_light) < 1.5
    assert nights.off[-1] == np.datetime64("2025-01-01T00:00")
    last_light = 365 - int(np.argmax(noon_up[::-1]))
    start_of_polar_night = (nights.on[-1] - np.datetime64("2024-01-01")) / np.timedelta64(1, "D")
    assert abs(start_of_polar_night - last_light) < 1.5
    # no burning in the polar day (two days in from its ends: the declination moves 0.3 deg a
    # day at its ends, and the noon declination stands for the midnight Sun)
    day_start = np.datetime64("2024-01-01") + np.timedelta64(int(np.argmax(midnight_up)) + 2, "D")
    day_end = np.datetime64("2024-01-01") + np.timedelta64(
        366 - int(np.argmax(midnight_up[::-1])) - 2, "D"
    )
    overlaps = (nights.off > day_start) & (nights.on < day_end)
    assert not overlaps.any()
    assert (day_end - day_start) / np.timedelta64(1, "D") > 100


def test_a_schedule_with_a_switch_off_and_a_dimming_step_by_hand() -> None:
    schedule = parse_schedule("21:00=0.5, 00:30=0, 05:00=1", "+01:00")
    on = np.array(["2024-01-10T16:00"], "datetime64[m]")
    off = np.array(["2024-01-11T07:00"], "datetime64[m]")
    # local 17:00-21:00 at 1 (4 h), 21:00-00:30 at 0.5 (1.75 h), 00:30-05:00 off, 05:00-08:00
    # at 1 (3 h)
    assert scheduled_hours(schedule, on, off)[0] == pytest.approx(8.75, abs=1e-9)
    levels = schedule_level(
        schedule, np.array(["2024-01-10T19:59", "2024-01-10T20:00", "2024-01-11T03:59"], "M8[m]")
    )
    assert levels.tolist() == [1.0, 0.5, 0.0]


def test_a_zone_with_daylight_saving_moves_the_steps_in_utc() -> None:
    schedule = parse_schedule("23:00=0,05:00=1", "Europe/Berlin")
    instants = np.array(
        ["2024-07-01T20:59", "2024-07-01T21:00", "2024-01-15T21:59", "2024-01-15T22:00"], "M8[m]"
    )
    assert schedule_level(schedule, instants).tolist() == [1.0, 0.0, 1.0, 0.0]


def test_annual_energy_with_a_schedule_against_minute_sampling() -> None:
    longitude, latitude = 10.0, 50.0
    schedule = DimmingSchedule(((time(22), 0.6), (time(1), 0.0), (time(5), 1.0)), "+01:00")
    # brute force: each minute of the year, burning when the Sun is below -0.833 deg and at the
    # level of the local clock (UTC+1) by hand
    minutes = np.arange("2023-01-01T00:00", "2024-01-01T00:00", dtype="datetime64[m]")
    mid = minutes + np.timedelta64(30, "s")
    burning = sun_elevation(mid, longitude, latitude) < -50.0 / 60.0
    local = ((mid - np.datetime64("2023-01-01")) / np.timedelta64(1, "h") + 1.0) % 24.0
    level = np.where(local >= 22.0, 0.6, np.where(local < 1.0, 0.6, np.where(local < 5.0, 0, 1)))
    expected_hours = float(np.sum(burning * level)) / 60.0
    hours = full_power_hours(longitude, latitude, 2023, schedule=schedule)
    assert hours == pytest.approx(expected_hours, rel=1e-4)
    energy = float(annual_energy(80.0, longitude, latitude, 2023, schedule=schedule))
    assert energy == pytest.approx(80.0 * expected_hours, rel=1e-4)
    assert float(co2_emissions(energy, 0.35)) == pytest.approx(energy / 1000 * 0.35)


def test_power_density_and_energy_consumption_indicators_for_one_segment() -> None:
    # a 30 m section of a 7 m road (210 m2) at 12.0 lx lit by one 40 W luminaire, and its 2 m
    # footway (60 m2) at 5.0 lx
    d_p = power_density_indicator(40.0, [12.0, 5.0], [210.0, 60.0])
    assert d_p == pytest.approx(40.0 / (12.0 * 210.0 + 5.0 * 60.0), rel=1e-3)
    assert d_p == pytest.approx(0.0141844, rel=1e-3)
    # 40 W for 1500 h, dimmed to 20 W for 2500 h, 0.5 W standby for 4760 h
    d_e = energy_consumption_indicator([40.0, 20.0, 0.5], [1500.0, 2500.0, 4760.0], 270.0)
    assert d_e == pytest.approx((60000.0 + 50000.0 + 2380.0) / 270.0, rel=1e-3)
    assert d_e == pytest.approx(416.2222, rel=1e-3)


@pytest.mark.parametrize(
    ("call", "names"),
    [
        (lambda: parse_schedule("22:00=1.5", "UTC"), "1.5"),
        (lambda: parse_schedule("22:00=-0.1", "UTC"), "-0.1"),
        (lambda: parse_schedule("22:00=0.5,22:00=1", "UTC"), "repeat"),
        (lambda: parse_schedule("22:00=0.5,05:00=1,23:00=0", "UTC"), "order"),
        (lambda: parse_schedule("22h=0.5", "UTC"), "schedule="),
        (lambda: parse_schedule("25:00=0.5", "UTC"), "clock time"),
        (lambda: parse_schedule("22:00=half", "UTC"), "half"),
        (lambda: parse_schedule("22:00=0.5", "Mars/Olympus"), "zone="),
        (lambda: parse_schedule("22:00=0.5", "+15:00"), "zone="),
        (lambda: burning_intervals(0.0, 95.0, 2024), "latitude="),
        (lambda: burning_intervals(0.0, 0.0, 1700), "year="),
        (lambda: burning_intervals(0.0, 0.0, 2024, switch_elevation=-30.0), "switch_elevation="),
        (lambda: burning_intervals(0.0, 0.0, 2024, step_minutes=0.0), "step_minutes="),
        (lambda: power_density_indicator(40.0, [10.0, 5.0], [100.0]), "shapes"),
        (lambda: power_density_indicator(40.0, [0.0], [100.0]), "lit area"),
        (lambda: energy_consumption_indicator([40.0], [1000.0], 0.0), "area="),
        (lambda: co2_emissions(1000.0, -0.2), "grid_factor"),
        (lambda: annual_energy(-5.0, 0.0, 0.0, 2024), "power"),
    ],
)
def test_bad_input_raises_one_line_errors(call, names: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError) as raised:
        call()
    message = str(raised.value)
    assert "\n" not in message
    assert names in message


class _Database:
    """A catalogue of two systems: one whose photometry states input watts, one that does not."""

    def get(self, system_id: str) -> SimpleNamespace:
        return SimpleNamespace()

    def photometry(self, system_id: str) -> SimpleNamespace:
        if system_id == "led":
            return SimpleNamespace(input_watts=58.2)
        if system_id == "relative":
            return SimpleNamespace(input_watts=None)
        raise LookupError(system_id)


def test_light_power_prefers_the_layer_then_the_photometry() -> None:
    lights = pd.DataFrame(
        {
            "light_id": [11, 12, 13],
            "system_id": ["led", "led", "relative"],
            "power": [30.0, None, 45.0],
        }
    )
    power = light_power(lights, _Database())  # type: ignore[arg-type]
    assert power.tolist() == [30.0, 58.2, 45.0]
    dimmed = light_power(lights, _Database(), level=[1.0, 0.5, 0.0])  # type: ignore[arg-type]
    assert dimmed.tolist() == [30.0, 29.1, 0.0]
    other = light_power(
        lights.rename(columns={"power": "watts"}),
        _Database(),  # type: ignore[arg-type]
        power_field="watts",
    )
    assert other.tolist() == [30.0, 58.2, 45.0]


def test_light_power_names_the_lights_without_power() -> None:
    lights = pd.DataFrame(
        {
            "light_id": [11, 12, 13, 14],
            "system_id": ["led", "relative", "unknown", None],
            "power": [None, None, None, None],
        }
    )
    with pytest.raises(InputError, match=r"lights \[12, 13, 14\] \(3 in all\) have no power"):
        light_power(lights, _Database())  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"\[11, 12, 13, 14\]"):
        light_power(lights, None)
    with pytest.raises(InputError, match=r"level"):
        light_power(lights.fillna({"power": 10.0}), None, level=1.2)


def test_light_power_reads_the_bundled_catalogue() -> None:
    from nightlights.ground.luminaires import load_database

    lights = pd.DataFrame({"system_id": ["street_led_medium", "road_hps"]})
    # the files' own statements: 58.22 W (IES input watts), 276 W (EULUMDAT, lamp and gear)
    assert light_power(lights, load_database(None)).tolist() == [58.22, 276.0]
