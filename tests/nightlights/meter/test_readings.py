"""Tests of the readings reader: every format to the documented table, hand-checked values, the
errors (table-driven), many files and folders. The fixtures are synthetic files written after
the published formats (tests/data/readings/README.md)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest

from nightlights.errors import CRSError, DataQualityWarning, EmptyInputError, InputError
from nightlights.meter.readings import (
    BLACK_SKY_LIMITING_MAGNITUDE,
    BRIGHTEST_LIMITING_MAGNITUDE,
    INSTRUMENT_NAMES,
    READING_COLUMNS,
    limiting_magnitude_to_sky_brightness,
    read_readings,
    write_ida,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "readings"
SQM_LE = DATA / "sqm_le_kumpula.dat"
SQM_LU = DATA / "sqm_lu_lake.dat"
TESS_W = DATA / "tess_w_madrid.dat"
POINTS_CSV = DATA / "points.csv"
POINTS_GPKG = DATA / "points_etrs_tm35fin.gpkg"
GAN_2019 = DATA / "globe_at_night_2019_layout.csv"
GAN_UT = DATA / "globe_at_night_ut_layout.csv"

HEADER = """# Community Standard Skyglow Data Format 1.0
# Device type: {device}
# Instrument ID: test
# Location name: Test site
{position}
# Moving / Stationary position: {moving}
# Number of channels: {channels}
# Field of view (degrees): 20
{fields}
# YYYY-MM-DDTHH:mm:ss.fff;YYYY-MM-DDTHH:mm:ss.fff;Celsius;number;Hz;mag/arcsec^2
# END OF HEADER
"""
FIELDS = "# UTC Date & Time, Local Date & Time, Temperature, Counts, Frequency, MSAS"
POSITION = "# Position (lat, lon, elev(m)): 60.2, 24.9, 30"
LINE = "2024-01-10T18:00:05.000;2024-01-10T20:00:05.000;-3.5;0;12.48;{magnitude}"


def ida_text(
    *,
    device: str = "SQM-LE",
    position: str = POSITION,
    moving: str = "STATIONARY",
    channels: str = "1",
    fields: str = FIELDS,
    lines: tuple[str, ...] = (LINE.format(magnitude="18.12"),),
) -> str:
    header = HEADER.format(
        device=device, position=position, moving=moving, channels=channels, fields=fields
    )
    return header.replace("\n\n", "\n") + "\n".join(lines) + "\n"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def check_schema(readings: gpd.GeoDataFrame) -> None:
    assert list(readings.columns) == list(READING_COLUMNS)
    for column, (dtype, _, _) in READING_COLUMNS.items():
        if column != "geometry":
            assert str(readings[column].dtype) == dtype, column
    assert readings.geometry.geom_type.eq("Point").all()
    assert readings["time"].dt.tz is not None
    assert readings["lon"].between(-180, 180).all() and readings["lat"].between(-90, 90).all()
    keys = list(zip(readings["station"], readings["time"], strict=True))
    assert keys == sorted(keys)


# -- each format ----------------------------------------------------------------------------------


def test_sqm_le_file_reads_to_the_schema_with_hand_checked_values():
    readings = read_readings(SQM_LE)
    check_schema(readings)
    assert len(readings) == 5
    first = readings.iloc[0]
    assert first["time"] == pd.Timestamp("2024-01-10T18:00:05Z")
    assert first["magnitude"] == 18.12
    assert first["ambient_temperature"] == -3.5
    assert math.isnan(first["sky_temperature"])
    assert first["station"] == "Synthetic_Kumpula"
    assert first["instrument"] == "sqm-l"  # SQM-LE: lensed
    assert (first["fov"], first["pointing_elevation"], first["pointing_azimuth"]) == (20, 90, 0)
    assert (first["lat"], first["lon"]) == (60.2050, 24.9610)
    assert readings.crs.to_epsg() == 4326
    assert readings.geometry.x.tolist() == readings["lon"].tolist()
    assert readings["source"].eq(str(SQM_LE)).all()
    assert readings.attrs["sources"] == [str(SQM_LE)]
    # the file's last line: 2024-01-11T01:30:05 UTC (03:30:05 Helsinki), 18.60
    assert readings["time"].iloc[-1] == pd.Timestamp("2024-01-11T01:30:05Z")
    assert readings["magnitude"].iloc[-1] == 18.60


def test_sqm_lu_fields_in_another_order_are_found_by_name():
    readings = read_readings(SQM_LU)
    check_schema(readings)
    assert readings["magnitude"].tolist() == [21.31, 21.35, 21.40]
    temperatures = readings["ambient_temperature"].tolist()
    assert temperatures[:2] == [-12.0, -12.4] and math.isnan(temperatures[2])  # empty field
    assert readings["instrument"].eq("sqm-l").all()
    assert readings["fov"].eq(20.0).all()  # "FWHM ~ 20 degrees"
    assert readings["time"].iloc[0] == pd.Timestamp("2024-02-05T20:00:00Z")


def test_tess_w_file_reads_sky_temperature_and_its_position_line():
    readings = read_readings(TESS_W)
    check_schema(readings)
    assert readings["instrument"].eq("tess-w").all()
    assert readings["sky_temperature"].tolist() == [-18.3, -18.6, -2.1]
    assert readings["ambient_temperature"].tolist() == [11.5, 11.4, 11.4]
    assert readings["magnitude"].tolist() == [18.72, 18.73, 18.61]
    assert readings["fov"].eq(17.0).all()
    assert (readings["lat"].iloc[0], readings["lon"].iloc[0]) == (40.45, -3.73)
    assert readings["station"].eq("synthetic-tess1").all()


def test_device_type_sets_the_instrument_unless_instrument_is_given(tmp_path):
    wide = write(tmp_path, "wide.dat", ida_text(device="SQM"))
    assert read_readings(wide)["instrument"].tolist() == ["sqm"]
    assert read_readings(wide, instrument="sqm-l")["instrument"].tolist() == ["sqm-l"]


def test_measurement_direction_is_azimuth_then_zenith_angle(tmp_path):
    text = ida_text().replace(
        "# Field of view", "# Measurement direction per channel: 180, 30\n# Field of view"
    )
    readings = read_readings(write(tmp_path, "tilted.dat", text))
    assert readings["pointing_azimuth"].iloc[0] == 180.0
    assert readings["pointing_elevation"].iloc[0] == 60.0


def test_csv_with_aliases_offsets_and_default_stations():
    readings = read_readings(POINTS_CSV)
    check_schema(readings)
    helsinki = readings[readings["instrument"] == "sqm-l"]
    # 21:00+02:00 is 19:00 UTC; 'mpsas' is an alias
    assert helsinki["time"].tolist() == [
        pd.Timestamp("2024-01-10T19:00Z"),
        pd.Timestamp("2024-01-10T20:00Z"),
    ]
    assert helsinki["magnitude"].tolist() == [17.95, 18.02]
    assert helsinki["station"].unique().tolist() == ["sqm-l@60.1699,24.9384"]
    assert helsinki["fov"].eq(20.0).all()
    oulu = readings[readings["station"] == "Oulu park"]
    assert oulu["pointing_elevation"].eq(90.0).all() and oulu["pointing_azimuth"].eq(0.0).all()
    assert oulu["fov"].isna().all()


def test_gpkg_points_keep_their_crs_and_get_wgs84_positions():
    readings = read_readings(POINTS_GPKG)
    check_schema(readings)
    assert readings.crs.to_epsg() == 3067
    square = readings[readings["station"] == "Senate Square"]
    np.testing.assert_allclose(square["lon"], 24.9384, atol=2e-6)
    np.testing.assert_allclose(square["lat"], 60.1699, atol=2e-6)
    assert readings["sky_temperature"].dropna().tolist() == [-21.5]
    assert readings.geometry.x.iloc[0] > 1e5  # metres, not degrees


def test_dataframe_with_x_y_needs_and_uses_crs():
    frame = pd.DataFrame(
        {
            "x": [385611.3],
            "y": [6672118.4],
            "time": ["2024-01-12T20:00:00Z"],
            "magnitude": [17.8],
            "instrument": ["sqm"],
        }
    )
    with pytest.raises(CRSError, match="x, y columns without crs="):
        read_readings(frame)
    readings = read_readings(frame, crs="EPSG:3067")
    assert readings.crs.to_epsg() == 3067
    assert readings["lat"].iloc[0] == pytest.approx(60.1699, abs=2e-6)


def test_globe_at_night_exports_both_layouts():
    with pytest.warns(DataQualityWarning, match=r"dropped 3 of 6 reports"):
        recent = read_readings(GAN_2019)
    check_schema(recent)
    assert recent["instrument"].eq("eye").all()
    assert len(recent) == 3
    expected = limiting_magnitude_to_sky_brightness([6.0, 4.5, 5.0])
    by_place = recent.set_index("lat")
    np.testing.assert_allclose(
        by_place.loc[[52.7152, 52.52, 48.6852], "magnitude"], expected, rtol=0, atol=1e-12
    )
    clouds = by_place.loc[[52.7152, 52.52, 48.6852], "cloud_cover"].tolist()
    assert math.isnan(clouds[0]) and clouds[1:] == [0.25, 0.5]
    assert by_place.loc[52.7152, "time"] == pd.Timestamp("2024-02-05T20:15Z")

    older = read_readings(GAN_UT)
    check_schema(older)
    assert older["time"].tolist() == [
        pd.Timestamp("2024-03-02T03:30Z"),
        pd.Timestamp("2024-03-03T03:45Z"),
    ]
    assert older["cloud_cover"].tolist() == [0.0, 0.25]
    assert older["station"].nunique() == 1  # one place, one instrument


# -- the limiting-magnitude relation --------------------------------------------------------------


def test_limiting_magnitude_relation_inverts_the_common_forward_form():
    # the forward form in common use (Schaefer 1990 night vision, KS91 Eq. 1 scale):
    # m = 7.93 - 5 log10(10^(4.316 - V/5) + 1); the constants round 4.31625 to 4.316
    limiting = np.linspace(BRIGHTEST_LIMITING_MAGNITUDE, 7.5, 25)
    sky = limiting_magnitude_to_sky_brightness(limiting)
    forward = 7.93 - 5 * np.log10(10 ** (4.316 - sky / 5) + 1)
    np.testing.assert_allclose(forward, limiting, atol=2e-3)
    assert np.all(np.diff(sky) > 0)  # fainter stars seen, darker sky


def test_limiting_magnitude_hand_value_and_range_ends():
    # m = 6: sqrt(C2 B) = 10^(1.93/5) - 1 = 1.4322; B = 162.9 nL;
    # V = (20.7233 - ln(162.9 / 34.08)) / 0.92104 = 20.80
    assert limiting_magnitude_to_sky_brightness(6.0) == pytest.approx(20.801, abs=1e-3)
    # the brightest night-vision sky is 1500 nL: V = (20.7233 - ln(1500/34.08)) / 0.92104
    brightest = limiting_magnitude_to_sky_brightness(BRIGHTEST_LIMITING_MAGNITUDE)
    assert brightest == pytest.approx((20.7233 - math.log(1500 / 34.08)) / 0.92104, abs=1e-9)
    assert BRIGHTEST_LIMITING_MAGNITUDE == pytest.approx(4.290, abs=1e-3)
    assert BLACK_SKY_LIMITING_MAGNITUDE == pytest.approx(7.93, abs=1e-4)


@pytest.mark.parametrize("value", [4.0, 7.93, 8.5, float("nan"), float("inf")])
def test_limiting_magnitude_outside_the_range_is_refused(value):
    with pytest.raises(InputError, match="outside the night-vision relation's range"):
        limiting_magnitude_to_sky_brightness(value)


# -- round trip -----------------------------------------------------------------------------------


def test_write_ida_round_trip(tmp_path):
    original = read_readings(TESS_W)
    path = write_ida(original, tmp_path / "copy.dat", time_zone="Europe/Madrid")
    text = path.read_bytes().decode("ascii")
    assert "\r\n" in text and "# Local timezone: Europe/Madrid" in text
    assert "2024-03-12T22:00:00.000;2024-03-12T23:00:00.000;11.5;-18.3;18.72" in text
    again = read_readings(path)
    for column in ("time", "magnitude", "sky_temperature", "ambient_temperature", "fov"):
        assert again[column].tolist() == original[column].tolist(), column
    assert again["instrument"].tolist() == original["instrument"].tolist()
    np.testing.assert_allclose(again[["lon", "lat"]], original[["lon", "lat"]], atol=1e-6)


def test_write_ida_refuses_several_stations(tmp_path):
    with pytest.raises(InputError, match="expected one station of one photometer"):
        write_ida(read_readings([SQM_LE, SQM_LU]), tmp_path / "both.dat")


# -- errors (table-driven) ------------------------------------------------------------------------

IDA_ERRORS = [
    ("no position", ida_text(position=""), "the header has no position"),
    (
        "unparsable position",
        ida_text(position="# Position (lat, lon, elev(m)): NoInf"),
        "is not 'LAT, LON[, ELEV]'",
    ),
    (
        "lon, lat swapped",
        ida_text(position="# Position (lat, lon, elev(m)): 174.7, -36.8, 20"),
        "latitude 174.7 outside -90..90; the standard orders it latitude",
    ),
    ("no field line", ida_text(fields=""), "the header has no field line"),
    (
        "no MSAS field",
        ida_text(fields="# UTC Date & Time, Local Date & Time, Temperature, Counts, Frequency"),
        "expected a 'MSAS' field",
    ),
    ("too few fields", ida_text(lines=("2024-01-10T18:00:05.000;x;1;2;3",)), ":12: 5 fields"),
    (
        "bad UTC time",
        ida_text(lines=("2024-13-40T18:00:05.000;x;-3.5;0;12.48;18.1",)),
        ":12: UTC time '2024-13-40T18:00:05.000'",
    ),
    ("bad magnitude", ida_text(lines=(LINE.format(magnitude="dark"),)), ":12: MSAS 'dark'"),
    ("unknown device", ida_text(device="Lightmeter"), "device type 'Lightmeter' is no known"),
    ("moving", ida_text(moving="MOVING"), "only stationary instruments"),
    ("four channels", ida_text(channels="4"), "only single-channel files"),
    (
        "header among readings",
        ida_text(lines=(LINE.format(magnitude="18.1"), "# Comment: late")),
        ":13: a header line among the readings",
    ),
]


@pytest.mark.parametrize(
    ("text", "fragment"), [case[1:] for case in IDA_ERRORS], ids=[case[0] for case in IDA_ERRORS]
)
def test_community_standard_errors(tmp_path, text, fragment):
    path = write(tmp_path, "bad.dat", text)
    with pytest.raises(InputError, match=None) as info:
        read_readings(path)
    message = str(info.value)
    assert fragment in message
    assert message.startswith(str(path))
    assert "\n" not in message


def table(**columns: list[object]) -> pd.DataFrame:
    base: dict[str, list[object]] = {
        "lon": [24.9],
        "lat": [60.2],
        "time": ["2024-01-10T21:00:00Z"],
        "magnitude": [18.0],
        "instrument": ["sqm"],
    }
    base.update(columns)
    return pd.DataFrame({name: values for name, values in base.items() if values is not None})


TABLE_ERRORS = [
    ("no position", table(lon=None, lat=None), {}, InputError, "no position; expected lon"),
    ("missing position", table(lat=[None]), {}, InputError, "row 0: a reading without position"),
    ("naive time", table(time=["2024-01-10 21:00"]), {}, InputError, "give time_zone="),
    (
        "unknown zone",
        table(),
        {"time_zone": "Mars/Olympus"},
        InputError,
        "time_zone='Mars/Olympus': no such time zone",
    ),
    (
        "mixed offsets",
        table(
            lon=[24.9, 24.9],
            lat=[60.2, 60.2],
            magnitude=[18.0, 18.1],
            instrument=["sqm", "sqm"],
            time=["2024-01-10T21:00Z", "2024-01-10T22:00"],
        ),
        {"time_zone": "UTC"},
        InputError,
        "row 1: time '2024-01-10T22:00' has no UTC offset",
    ),
    (
        "ambiguous local time",
        table(time=["2024-10-27T03:30:00"]),
        {"time_zone": "Europe/Helsinki"},
        InputError,
        "is ambiguous or does not exist in Europe/Helsinki",
    ),
    ("bad time", table(time=["yesterday"]), {}, InputError, "row 0: time 'yesterday'"),
    ("unknown instrument", table(instrument=["sqm-x"]), {}, InputError, "'sqm-x'"),
    ("no instrument", table(instrument=None), {}, InputError, "no instrument column"),
    (
        "unknown instrument=",
        table(),
        {"instrument": "telescope"},
        InputError,
        "instrument=: unknown instrument 'telescope'",
    ),
    ("two magnitudes", table(mag=[18.0]), {}, InputError, "both give magnitude"),
    ("text magnitude", table(magnitude=["dark"]), {}, InputError, "magnitude 'dark' is not"),
    ("no magnitude", table(magnitude=None), {}, InputError, "no magnitude column"),
    ("unknown format", table(), {"format": "xlsx"}, InputError, "format='xlsx': unknown"),
    ("bad crs", table(x=[1.0], y=[2.0]), {"crs": "garbage"}, CRSError, "crs='garbage'"),
    ("lon/lat with crs", table(), {"crs": "EPSG:3067"}, CRSError, "crs= is for x, y"),
    ("cloud percent", table(cloud_cover=[50.0]), {}, InputError, "cloud_cover 50; expected a"),
    (
        "below the horizon",
        table(pointing_elevation=[-5.0]),
        {},
        InputError,
        "pointing_elevation -5 deg",
    ),
]


@pytest.mark.parametrize(
    ("frame", "options", "error", "fragment"),
    [case[1:] for case in TABLE_ERRORS],
    ids=[case[0] for case in TABLE_ERRORS],
)
def test_table_errors(frame, options, error, fragment):
    with pytest.raises(error) as info:
        read_readings(frame, **options)
    assert fragment in str(info.value)
    assert "\n" not in str(info.value)


def test_csv_errors_name_the_file_line(tmp_path):
    path = write(
        tmp_path,
        "bad.csv",
        "lon,lat,time,mag,instrument\n24.9,60.2,2024-01-10T21:00Z,18.0,sqm\n"
        "24.9,,2024-01-10T22:00Z,18.1,sqm\n",
    )
    with pytest.raises(InputError, match=r"bad\.csv:3: a reading without position"):
        read_readings(path)


def test_gpkg_without_crs_needs_crs(tmp_path):
    frame = gpd.GeoDataFrame(
        table(lon=None, lat=None), geometry=gpd.points_from_xy([385611.3], [6672118.4])
    )
    with pytest.raises(CRSError, match="the layer has no CRS"):
        read_readings(frame)
    assert read_readings(frame, crs="EPSG:3067")["lat"].iloc[0] == pytest.approx(60.17, abs=0.01)


def test_missing_file_empty_list_empty_folder(tmp_path):
    with pytest.raises(InputError, match=r"nowhere\.dat: no such file"):
        read_readings(tmp_path / "nowhere.dat")
    with pytest.raises(EmptyInputError, match="an empty list of files"):
        read_readings([])
    with pytest.raises(EmptyInputError, match="no readings files in the folder"):
        read_readings(tmp_path)


def test_unknown_format_of_a_named_file(tmp_path):
    path = tmp_path / "notes.bin"
    path.write_bytes(b"\0\1\2")
    with pytest.raises(InputError, match="cannot tell its format; give format="):
        read_readings(path)


# -- magnitudes dropped, naive times with a zone ---------------------------------------------------


def test_implausible_magnitudes_are_dropped_with_a_warning(tmp_path):
    lines = tuple(LINE.format(magnitude=value) for value in ("0.00", "18.12", "nan", "27.5"))
    path = write(tmp_path, "day.dat", ida_text(lines=lines))
    with pytest.warns(DataQualityWarning, match=r"day\.dat: dropped 3 of 4 readings"):
        readings = read_readings(path)
    assert readings["magnitude"].tolist() == [18.12]


def test_all_readings_dropped_is_empty_input(tmp_path):
    path = write(tmp_path, "day.dat", ida_text(lines=(LINE.format(magnitude="0.00"),)))
    with pytest.warns(DataQualityWarning), pytest.raises(EmptyInputError, match="no readings"):
        read_readings(path)


def test_a_file_of_headers_only_adds_nothing(tmp_path):
    empty = write(tmp_path, "empty.dat", ida_text(lines=()))
    with pytest.warns(DataQualityWarning, match=r"empty\.dat: holds no readings"):
        readings = read_readings([empty, SQM_LU])
    assert len(readings) == 3
    with pytest.warns(DataQualityWarning), pytest.raises(EmptyInputError, match="no readings"):
        read_readings(empty)


def test_naive_times_with_time_zone_become_utc():
    frame = table(time=["2024-01-10 21:00"])
    readings = read_readings(frame, time_zone="Europe/Helsinki")
    assert readings["time"].iloc[0] == pd.Timestamp("2024-01-10T19:00Z")


# -- many files, stations ------------------------------------------------------------------------


def test_folder_reads_every_readable_file_sorted_by_station_and_time():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataQualityWarning)  # the Globe at Night drops
        readings = read_readings(DATA)
    check_schema(readings)
    assert readings.attrs["sources"] == sorted(
        str(path) for path in DATA.iterdir() if path.suffix != ".md"
    )
    assert readings.crs.to_epsg() == 4326  # inputs in EPSG:4326 and EPSG:3067
    assert set(readings["instrument"]) == {"sqm", "sqm-l", "tess-w", "eye"}
    assert len(readings) == 5 + 3 + 3 + 4 + 3 + 3 + 2


def test_list_of_files_and_a_folder_with_other_files(tmp_path):
    readings = read_readings([SQM_LE, TESS_W])
    assert readings["station"].unique().tolist() == ["Synthetic_Kumpula", "synthetic-tess1"]
    (tmp_path / "a.dat").write_text(SQM_LU.read_text())
    (tmp_path / "image.bin").write_bytes(b"\0\0")
    with pytest.warns(DataQualityWarning, match="skipped 1 files of no readings format: image"):
        assert len(read_readings(tmp_path)) == 3


def test_one_name_at_two_places_is_split_into_two_stations():
    frame = table(
        lon=[24.9, 25.5],
        lat=[60.2, 65.0],
        time=["2024-01-10T21:00Z", "2024-01-10T21:00Z"],
        magnitude=[18.0, 20.5],
        instrument=["sqm", "sqm"],
        station=["roof", "roof"],
    )
    stations = read_readings(frame)["station"].tolist()
    assert stations == ["roof sqm@60.2000,24.9000", "roof sqm@65.0000,25.5000"]


def test_station_option_names_every_reading():
    readings = read_readings([SQM_LE, SQM_LU], station="mine")
    # the same name at two places is still two stations
    assert readings["station"].nunique() == 2
    assert readings["station"].str.startswith("mine ").all()


# -- the package's face ---------------------------------------------------------------------------


def test_public_names_are_lazy_names_of_the_meter_package():
    import nightlights.meter as meter

    assert meter.read_readings is read_readings
    assert meter.READING_COLUMNS is READING_COLUMNS
    assert meter.limiting_magnitude_to_sky_brightness is limiting_magnitude_to_sky_brightness


def test_instrument_names_are_the_instrument_models():
    instruments = pytest.importorskip("nightlights.sky.instruments")
    assert set(INSTRUMENT_NAMES) == set(instruments.INSTRUMENTS)


def test_reading_columns_document_dtype_unit_and_meaning():
    for column, entry in READING_COLUMNS.items():
        assert len(entry) == 3 and entry[0] and entry[2], column
    assert READING_COLUMNS["magnitude"][1] == "mag arcsec-2"


@pytest.mark.parametrize(
    ("line", "elevation", "azimuth"),
    [
        ("0.0, 90.0 - 90.0", 90.0, 0.0),  # the TESS-W network's template: a difference
        ("120.0, 90.0 - 60.0", 60.0, 120.0),
        ("0,0 (Zenith)", 90.0, 0.0),
    ],
)
def test_measurement_direction_forms(tmp_path, line, elevation, azimuth):
    text = TESS_W.read_text().replace(
        "# Measurement direction per channel: (0.0, 0.0)",
        f"# Measurement direction per channel: {line}",
    )
    path = tmp_path / "tess.dat"
    path.write_text(text)
    frame = read_readings(path)
    assert frame["pointing_elevation"].unique().tolist() == [elevation]
    assert frame["pointing_azimuth"].unique().tolist() == [azimuth]


@pytest.mark.parametrize(
    ("line", "fragment"), [("1, 2, 3", "expected 'AZIMUTH, ZENITH ANGLE'"), ("0, 120", "0-90")]
)
def test_bad_measurement_direction_refused(tmp_path, line, fragment):
    text = TESS_W.read_text().replace(
        "# Measurement direction per channel: (0.0, 0.0)",
        f"# Measurement direction per channel: {line}",
    )
    path = tmp_path / "tess.dat"
    path.write_text(text)
    with pytest.raises(InputError, match=fragment):
        read_readings(path)


def test_altitude_column_is_not_a_pointing(tmp_path):
    """A table's 'altitude' is a site height: ignored, the meter points at the zenith."""
    path = tmp_path / "sites.csv"
    path.write_text(
        "lon,lat,time,magnitude,instrument,altitude\n24.9,60.2,2026-01-18T21:00:00Z,20.1,sqm,25\n"
    )
    assert read_readings(path)["pointing_elevation"].tolist() == [90.0]


def test_commented_table_is_a_table(tmp_path):
    path = tmp_path / "commented.csv"
    path.write_text(
        "# my meters\nlon,lat,time,magnitude,instrument\n24.9,60.2,2026-01-18T21:00:00Z,20.1,sqm\n"
    )
    assert len(read_readings(path)) == 1
