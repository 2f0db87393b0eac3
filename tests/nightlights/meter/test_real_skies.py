"""The validation set of real skies: the bundled table and the reader's checks."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from nightlights.errors import InputError
from nightlights.meter.real_skies import COLUMNS, SITE_CLASSES, read_real_skies

#: The window of the VIIRS mosaic the benchmark runs on [deg]: (west, east), (south, north).
MOSAIC_LON, MOSAIC_LAT = (73.0, 135.0), (18.0, 54.0)


def test_bundled_table_lies_in_the_mosaic_and_spans_every_class() -> None:
    table = read_real_skies()
    assert list(table.columns) == list(COLUMNS)
    assert table["longitude"].between(*MOSAIC_LON).all()
    assert table["latitude"].between(*MOSAIC_LAT).all()
    assert set(table["site_class"]) == set(SITE_CLASSES)
    assert (table["citation"].str.len() > 20).all()
    assert (table["verified"].str.strip() != "").all()


def test_bundled_values_are_the_published_ones() -> None:
    # transcription check against the abstracts cited in the table
    values = read_real_skies().set_index("name")["value"]
    assert values["Indian Astronomical Observatory (Hanle)"] == 21.28  # Stalin et al. 2008
    assert values["Lulin Observatory (NCU)"] == 20.72  # Tsay et al. 2000
    assert values["Seoul: Namsan Elementary School (Jung-gu)"] == 16.5  # Yu et al. 2015
    # the Mong Kok row: the median of the six check sites of the district survey
    six = [14.60, 14.55, 14.29, 13.99, 14.52, 14.24]
    assert values["Hong Kong: Mong Kok (street-level check sites)"] == pytest.approx(
        sorted(six)[2] / 2 + sorted(six)[3] / 2, abs=0.005
    )


def _write(tmp_path: Path, change: dict[str, object] | None = None, drop: str = "") -> Path:
    frame = read_real_skies().head(3).astype(str)
    for column, value in (change or {}).items():
        frame.loc[1, column] = str(value)
    if drop:
        frame = frame.drop(columns=drop)
    path = tmp_path / "skies.csv"
    frame.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    ("change", "drop", "message"),
    [
        ({}, "citation", "lacks the columns citation"),
        ({"value": 9.0}, "", "skies.csv:3: value '9.0'; expected a number from 10 to 23"),
        ({"value": "dark"}, "", "value 'dark'"),
        ({"latitude": 95.0}, "", "latitude '95.0'"),
        ({"site_class": "village"}, "", "site_class 'village'; expected one of city centre"),
        ({"statistic": " "}, "", "skies.csv:3: empty statistic"),
    ],
)
def test_bad_tables_are_refused(
    tmp_path: Path, change: dict[str, object], drop: str, message: str
) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        read_real_skies(_write(tmp_path, change, drop))


def test_a_repeated_site_is_refused(tmp_path: Path) -> None:
    frame = read_real_skies().head(2)
    path = tmp_path / "skies.csv"
    pd.concat([frame, frame.head(1)]).to_csv(path, index=False)
    with pytest.raises(InputError, match="appears twice"):
        read_real_skies(path)
