"""Published zenith sky brightness at real sites: the validation set of real skies.

A table of clear, moonless zenith readings taken from the literature (Sky Quality Meters,
V-band CCD photometry, sky monitors), one row per site, each with its citation: the site's
name and position (and where the position came from), the value [mag arcsec-2], the statistic
it is (median, mean, darkest, a fitted zenith value, ...), the instrument and band, the period,
the conditions, a class (``city centre``, ``suburb``, ``rural``, ``observatory``), caveats, and
how far the row was checked against the source text (column ``verified``).

Numbers are only as good as their sources: a value is a fact of the cited paper, read from its
text; positions are often approximate (the column ``coordinate_source`` says which ones were
placed by hand at the named place). The bundled table lies inside the 73-135 E, 18-54 N window
of a freely available VIIRS mosaic, so that the model can be run at every site.

The columns (:data:`COLUMNS`) and their checks (:func:`read_real_skies`) are the contract; the
benchmark ``benchmarks/bench_real_skies.py`` reads the table through this module.

Examples
--------
>>> table = read_real_skies()
>>> sorted(set(table["site_class"])) <= sorted(SITE_CLASSES)
True
>>> bool(((table["value"] > 10) & (table["value"] < 23)).all())
True
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from nightlights.errors import InputError

__all__ = ["COLUMNS", "SITE_CLASSES", "VALUE_RANGE", "read_real_skies"]

#: Columns of the table, in order.
COLUMNS = (
    "name",
    "latitude",  # [deg]
    "longitude",  # [deg]
    "coordinate_source",
    "value",  # [mag arcsec-2]
    "statistic",
    "instrument",
    "band",
    "period",
    "conditions",
    "site_class",
    "caveats",
    "citation",
    "verified",
)

#: The classes a site may take, brightest first.
SITE_CLASSES = ("city centre", "suburb", "rural", "observatory")

#: Plausible zenith sky brightness [mag arcsec-2]: brighter than the darkest natural sky
#: (about 22.3) cannot be a ground reading, 10 is brighter than any published city zenith.
VALUE_RANGE = (10.0, 23.0)

_BUNDLED = "real_skies.csv"


def read_real_skies(path: str | os.PathLike[str] | None = None) -> pd.DataFrame:
    """The validation set of real skies, checked.

    Parameters
    ----------
    path
        A CSV with the columns of :data:`COLUMNS`; None reads the bundled table.

    Returns
    -------
    pandas.DataFrame
        One row per site, the columns of :data:`COLUMNS`; ``latitude``, ``longitude`` [deg]
        and ``value`` [mag arcsec-2] as floats.

    Raises
    ------
    InputError
        A column is missing, a name is repeated or empty, a position or value is not a number
        or out of range (latitude within +-90, longitude within +-180 deg, the value within
        :data:`VALUE_RANGE`), a class is not one of :data:`SITE_CLASSES`, or a row has no
        citation or no statistic.
    """
    if path is None:
        text = resources.files("nightlights.meter").joinpath("data", _BUNDLED)
        label = _BUNDLED
        with resources.as_file(text) as local:
            frame = pd.read_csv(local, dtype=str, keep_default_na=False)
    else:
        label = Path(path).name
        frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    missing = [c for c in COLUMNS if c not in frame.columns]
    if missing:
        raise InputError(f"path: {label} lacks the columns {', '.join(missing)}")
    frame = frame[list(COLUMNS)].copy()
    for column in ("name", "statistic", "citation", "site_class"):
        empty = np.flatnonzero(frame[column].str.strip() == "")
        if empty.size:
            raise InputError(f"path: {label}:{empty[0] + 2}: empty {column}; expected text")
    repeated = frame["name"][frame["name"].duplicated()]
    if not repeated.empty:
        raise InputError(f"path: {label}: the site {repeated.iloc[0]!r} appears twice")
    bounds = {"latitude": (-90.0, 90.0), "longitude": (-180.0, 180.0), "value": VALUE_RANGE}
    for column, (low, high) in bounds.items():
        numbers = pd.to_numeric(frame[column], errors="coerce")
        bad = np.flatnonzero(~((numbers >= low) & (numbers <= high)).to_numpy())
        if bad.size:
            raise InputError(
                f"path: {label}:{bad[0] + 2}: {column} {frame[column].iloc[bad[0]]!r}; "
                f"expected a number from {low:g} to {high:g}"
            )
        frame[column] = numbers.astype(float)
    unknown = np.flatnonzero(~frame["site_class"].isin(SITE_CLASSES).to_numpy())
    if unknown.size:
        raise InputError(
            f"path: {label}:{unknown[0] + 2}: site_class "
            f"{frame['site_class'].iloc[unknown[0]]!r}; expected one of {', '.join(SITE_CLASSES)}"
        )
    return frame.reset_index(drop=True)
