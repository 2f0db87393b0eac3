"""Convert the Yale Bright Star Catalogue (CDS V/50, ``catalog``) into the shipped ``bsc5.npz``.

Run once, by hand, from the repository root::

    python nightlights/nightsky/data/build_bsc5.py path/to/bsc5_catalog.dat

It keeps the records that have a J2000 position and a V magnitude (9,096 of 9,110; the others
are novae and extragalactic objects removed from the catalogue) and the fields that
:class:`nightlights.nightsky.catalog.StarCatalog` holds. The byte columns are those of the
catalogue's ReadMe ("Byte-by-byte Description of file: catalog").
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

#: Where the compact catalogue is written, next to this script.
OUTPUT = Path(__file__).with_name("bsc5.npz")


def _field(line: str, first: int, last: int) -> str:
    """Bytes ``first``-``last`` (1-based, inclusive, as in the ReadMe) of ``line``, stripped."""
    return line[first - 1 : last].strip()


def _float(text: str) -> float:
    return float(text) if text else float("nan")


def star_name(raw: str) -> str:
    """The catalogue's Name field (bytes 5-14) as ``"9 Alp CMa"``: Flamsteed, Bayer, constellation.

    Parameters
    ----------
    raw : str
        Bytes 5-14 of a record: Flamsteed number (5-7), Bayer letter and index (8-11),
        constellation (12-14).

    Returns
    -------
    str
        The non-empty parts joined by single spaces; ``""`` when the star has no name.

    Examples
    --------
    >>> star_name("  9Alp CMa")
    '9 Alp CMa'
    >>> star_name("          ")
    ''
    """
    raw = raw.ljust(10)
    parts = [raw[0:3].strip(), raw[3:7].strip(), raw[7:10].strip()]
    if not parts[0] and not parts[1]:
        return ""
    return " ".join(p for p in parts if p)


def parse_bsc5(text: str) -> dict[str, np.ndarray]:
    """Parse the fixed-width ``catalog`` file of the Bright Star Catalogue, 5th revised edition.

    Parameters
    ----------
    text : str
        The file's content, one 197-byte record per line.

    Returns
    -------
    dict of str to ndarray
        ``hr``, ``name``, ``ra`` and ``dec`` [deg] (equinox J2000, epoch 2000.0), ``pm_ra``
        (mu_alpha * cos(dec)) and ``pm_dec`` [arcsec yr-1], ``vmag`` and ``bv`` [mag] (NaN
        where missing), for the records with a J2000 position and a V magnitude.
    """
    rows: list[tuple[int, str, float, float, float, float, float, float]] = []
    for line in text.splitlines():
        if not _field(line, 76, 77) or not _field(line, 103, 107):
            continue
        ra = 15.0 * (
            int(_field(line, 76, 77))
            + int(_field(line, 78, 79)) / 60.0
            + float(_field(line, 80, 83)) / 3600.0
        )
        dec = (
            int(_field(line, 85, 86))
            + int(_field(line, 87, 88)) / 60.0
            + int(_field(line, 89, 90)) / 3600.0
        )
        if line[83] == "-":
            dec = -dec
        rows.append(
            (
                int(_field(line, 1, 4)),
                star_name(line[4:14]),
                ra,
                dec,
                _float(_field(line, 149, 154)),
                _float(_field(line, 155, 160)),
                float(_field(line, 103, 107)),
                _float(_field(line, 110, 114)),
            )
        )
    columns = list(zip(*rows, strict=True)) if rows else [()] * 8
    return {
        "hr": np.asarray(columns[0], dtype=np.int16),
        "name": np.asarray(columns[1], dtype="<U12"),
        "ra": np.asarray(columns[2], dtype=np.float64),
        "dec": np.asarray(columns[3], dtype=np.float64),
        "pm_ra": np.asarray(columns[4], dtype=np.float32),
        "pm_dec": np.asarray(columns[5], dtype=np.float32),
        "vmag": np.asarray(columns[6], dtype=np.float32),
        "bv": np.asarray(columns[7], dtype=np.float32),
    }


def main(argv: list[str]) -> int:
    """Write :data:`OUTPUT` from the catalogue file named by ``argv[1]``."""
    if len(argv) != 2:
        sys.stderr.write("usage: build_bsc5.py path/to/bsc5_catalog.dat\n")
        return 2
    fields = parse_bsc5(Path(argv[1]).read_text(encoding="ascii"))
    np.savez_compressed(OUTPUT, **fields)  # type: ignore[arg-type]
    sys.stdout.write(f"{OUTPUT}: {fields['hr'].size} stars\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
