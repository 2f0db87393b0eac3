"""Reader for IES LM-63 photometric files (1986, 1991, 1995, 2002 and 2019 editions).

The header (version line, keyword or label lines) is read line by line up to the line that
starts with ``TILT=``; everything after it is one stream of numbers that may wrap anywhere,
be separated by spaces or commas and use ``.21``-style decimals. The values are:

``[TILT table] n_lamps lumens_per_lamp multiplier n_vertical n_horizontal type units
width length height ballast_factor <field> input_watts V... H... candela...``

where ``<field>`` is the ballast-lamp photometric factor up to LM-63-1995 (applied as a
multiplier), "future use" in LM-63-2002 and the file-generation type in LM-63-2019 (neither
applied). Candela are stored per horizontal angle.
"""

from __future__ import annotations

import os
import re
from dataclasses import replace

import numpy as np

from ies.errors import PhotometryParseError
from ies.grid import unfold_type_c
from ies.photometry import Photometry, check_declared_flux
from ies.plausibility import check_magnitudes, implausible_flux
from ies.text import TokenStream, read_text, tokenize

_VERSION_LINE = re.compile(r"^\s*IES(?:NA)?\s*:?\s*(?:LM-63-)?(\d{2,4})\b", re.IGNORECASE)
_TILT_LINE = re.compile(r"^\s*TILT\s*=\s*(.*?)\s*$", re.IGNORECASE)
_KEYWORD_LINE = re.compile(r"^\s*\[([^\]]+)\]\s?(.*?)\s*$")
_TYPES = {1: "C", 2: "B", 3: "A"}
FEET_TO_METRES = 0.3048


def _version_from(first_line: str) -> str | None:
    match = _VERSION_LINE.match(first_line)
    if not match:
        return None
    year = match.group(1)
    if len(year) == 2:
        year = ("19" if int(year) > 50 else "20") + year
    return year


def parse_ies(text: str, *, source: str = "<string>") -> Photometry:
    """Parse the text of an IES LM-63 file.

    Parameters
    ----------
    text : str
        File contents.
    source : str
        Name used in messages and stored on the result.

    Returns
    -------
    Photometry
        Absolute candela table, type C unfolded to 0..360 deg.

    Raises
    ------
    PhotometryParseError
        Malformed file; the message names the file, line and token.

    Warns
    -----
    FluxMismatchWarning
        Declared and integrated flux differ by more than 5 %.

    References
    ----------
    ANSI/IES LM-63-19 (and the 1986, 1991, 1995, 2002 editions), Sec. 5.

    Examples
    --------
    >>> p = parse_ies("IESNA:LM-63-2002\\nTILT=NONE\\n1 -1 1 2 1 1 2 0 0 0\\n1 1 10\\n"
    ...               "0 180\\n0\\n1 1\\n")
    >>> round(p.luminous_flux(), 6)
    12.566371
    """
    lines = text.removeprefix("\ufeff").splitlines()
    if not lines:
        raise PhotometryParseError("empty file", source=source)
    version = _version_from(lines[0])
    header_start = 1 if version is not None else 0
    version = version or "1986"
    tilt_index = next((k for k, line in enumerate(lines) if _TILT_LINE.match(line)), None)
    if tilt_index is None:
        raise PhotometryParseError(
            "no line starts with 'TILT=' (not an IES LM-63 file, or truncated header)",
            source=source,
        )
    keywords = _read_keywords(lines[header_start:tilt_index])
    tilt_match = _TILT_LINE.match(lines[tilt_index])
    assert tilt_match is not None
    tilt_value = tilt_match.group(1)
    stream = TokenStream(tokenize(lines[tilt_index + 1 :], tilt_index + 2), source)
    found: list[str] = []

    tilt_angles: tuple[float, ...] = ()
    tilt_factors: tuple[float, ...] = ()
    if tilt_value.upper() == "INCLUDE":
        geometry = stream.read_int("TILT lamp-to-luminaire geometry")
        count = stream.read_int("number of TILT angle/factor pairs")
        if count < 1:
            raise stream.error("number of TILT pairs must be >= 1", stream.last_token())
        angles = stream.read_floats(count, "TILT angles")
        factors = stream.read_floats(count, "TILT multiplying factors")
        if any(np.diff(angles) <= 0) or any(f < 0 for f in factors):
            raise stream.error("TILT angles must increase and factors be >= 0", stream.last_token())
        tilt_angles, tilt_factors = tuple(angles), tuple(factors)
        keywords["_TILT_GEOMETRY"] = str(geometry)
    elif tilt_value.upper() != "NONE":
        raise PhotometryParseError(
            f"TILT={tilt_value} refers to a separate tilt file, which is not supported "
            "(expected TILT=NONE or TILT=INCLUDE)",
            source=source,
            line=tilt_index + 1,
            token=tilt_value,
        )

    n_lamps = stream.read_int("number of lamps")
    if n_lamps < 1:
        raise stream.error("number of lamps must be >= 1", stream.last_token())
    lumens_per_lamp = stream.read_float("lumens per lamp")
    multiplier = stream.read_float("candela multiplier")
    if multiplier <= 0:
        raise stream.error("candela multiplier must be > 0", stream.last_token())
    n_vertical = stream.read_int("number of vertical angles")
    if n_vertical < 1:
        raise stream.error("number of vertical angles must be >= 1", stream.last_token())
    n_horizontal = stream.read_int("number of horizontal angles")
    if n_horizontal < 1:
        raise stream.error("number of horizontal angles must be >= 1", stream.last_token())
    type_code = stream.read_int("photometric type")
    if type_code not in _TYPES:
        raise stream.error("photometric type must be 1 (C), 2 (B) or 3 (A)", stream.last_token())
    units = stream.read_int("units type")
    if units not in (1, 2):
        raise stream.error("units type must be 1 (feet) or 2 (metres)", stream.last_token())
    opening = stream.read_floats(3, "luminous opening width, length, height")
    scale = FEET_TO_METRES if units == 1 else 1.0
    ballast_factor = stream.read_float("ballast factor")
    second_field = stream.read_float(
        "ballast-lamp photometric factor / future use / file generation type"
    )
    input_watts = stream.read_float("input watts")
    if ballast_factor <= 0:
        ballast_factor = 1.0
        found.append("ballast factor <= 0 read as 1")
    if version in ("1986", "1991", "1995"):
        ballast_lamp_factor = second_field if second_field > 0 else 1.0
    else:
        ballast_lamp_factor = 1.0
        keywords["_FILEGENTYPE" if version == "2019" else "_FUTURE_USE"] = f"{second_field:g}"

    vertical = np.array(stream.read_floats(n_vertical, "vertical angles"))
    first_horizontal = stream.peek()
    horizontal = np.array(stream.read_floats(n_horizontal, "horizontal angles"))
    last_horizontal = stream.last_token()
    start = stream.position
    values = np.array(stream.read_floats(n_vertical * n_horizontal, "candela values"))
    bad = np.nonzero(values < 0)[0]
    if bad.size:
        raise stream.error("negative candela value", stream.token_at(start + int(bad[0])))
    if stream.remaining:
        extra = stream.peek()
        assert extra is not None
        found.append(
            f"{stream.remaining} value(s) after the candela table ignored (from line {extra.line})"
        )
    candela = values.reshape(n_horizontal, n_vertical)

    vertical, horizontal, candela = _order_angles(vertical, horizontal, candela, stream)
    photometric_type = _TYPES[type_code]
    try:
        if photometric_type == "C":
            horizontal, candela, symmetry = unfold_type_c(horizontal, candela)
        else:
            vertical, horizontal, candela, symmetry = _unfold_type_ab(vertical, horizontal, candela)
    except ValueError as exc:
        assert first_horizontal is not None and last_horizontal is not None
        raise PhotometryParseError(
            str(exc),
            source=source,
            line=last_horizontal.line,
            token=f"{first_horizontal.text} .. {last_horizontal.text}",
        ) from None

    tilt_scale = 1.0
    if tilt_angles:
        tilt_scale = float(np.interp(0.0, tilt_angles, tilt_factors))
    absolute = lumens_per_lamp < 0
    if absolute and lumens_per_lamp != -1:
        found.append(f"lumens per lamp {lumens_per_lamp:g} < 0 read as absolute photometry")
    factor = multiplier * ballast_factor * ballast_lamp_factor * tilt_scale
    check_magnitudes(
        values, factor, error=lambda message, k: stream.error(message, stream.token_at(start + k))
    )
    photometry = Photometry(
        photometric_type=photometric_type,  # type: ignore[arg-type]
        vertical_angles=vertical,
        horizontal_angles=horizontal,
        candela=candela * factor,
        declared_lumens=None if absolute else lumens_per_lamp * n_lamps,
        source=source,
        format=f"IES LM-63-{version}",
        version=version,
        keywords=keywords,
        symmetry=symmetry,
        luminous_opening=(opening[0] * scale, opening[1] * scale, opening[2] * scale),
        ballast_factor=ballast_factor * ballast_lamp_factor,
        candela_multiplier=multiplier,
        input_watts=input_watts,
        tilt_angles=tilt_angles,
        tilt_factors=tilt_factors,
    )
    photometry = replace(
        photometry, keywords={**keywords, "_UNITS": "feet" if units == 1 else "metres"}
    )
    too_bright = implausible_flux(photometry)
    return check_declared_flux(photometry, found=found + ([too_bright] if too_bright else []))


def _read_keywords(lines: list[str]) -> dict[str, str]:
    """Keyword lines ``[KEY] value`` ([MORE] continues the previous one); other lines are
    1986-style labels collected under ``LABEL``."""
    keywords: dict[str, str] = {}
    previous: str | None = None
    for line in lines:
        match = _KEYWORD_LINE.match(line)
        if match:
            key, value = match.group(1).strip().upper(), match.group(2)
            if key == "MORE" and previous is not None:
                keywords[previous] += "\n" + value
                continue
            if key in keywords:
                keywords[key] += "\n" + value
            else:
                keywords[key] = value
            previous = key
        elif line.strip():
            keywords["LABEL"] = (
                keywords["LABEL"] + "\n" if "LABEL" in keywords else ""
            ) + line.strip()
    return keywords


def _order_angles(
    vertical: np.ndarray, horizontal: np.ndarray, candela: np.ndarray, stream: TokenStream
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accept descending vertical angles (reversed); any other disorder is an error."""
    if vertical.size > 1 and np.all(np.diff(vertical) < 0):
        vertical, candela = vertical[::-1], candela[:, ::-1]
    if vertical.size > 1 and np.any(np.diff(vertical) <= 0):
        raise stream.error(f"vertical angles must increase, got {vertical.tolist()[:8]}...")
    if horizontal.size > 1 and np.any(np.diff(horizontal) <= 0):
        raise stream.error(f"horizontal angles must increase, got {horizontal.tolist()[:8]}...")
    return vertical, horizontal, candela


def _unfold_type_ab(
    vertical: np.ndarray, horizontal: np.ndarray, candela: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Mirror type A/B tables that start at 0 deg onto negative angles."""
    labels = []
    if horizontal.size > 1 and abs(horizontal[0]) < 1e-9:
        horizontal = np.concatenate([-horizontal[:0:-1], horizontal])
        candela = np.vstack([candela[:0:-1], candela])
        labels.append("mirrored about H=0")
    if vertical.size > 1 and abs(vertical[0]) < 1e-9:
        vertical = np.concatenate([-vertical[:0:-1], vertical])
        candela = np.hstack([candela[:, :0:-1], candela])
        labels.append("mirrored about V=0")
    return vertical, horizontal, candela, ", ".join(labels) or "none"


def read_ies(path: str | os.PathLike[str]) -> Photometry:
    """Read an IES LM-63 file (UTF-8, else latin-1).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.ies`` file.

    Returns
    -------
    Photometry
        See :func:`parse_ies`.
    """
    return parse_ies(read_text(path), source=os.fspath(path))
