"""Reader for EULUMDAT (``.ldt``) photometric files.

EULUMDAT holds one value per line: 26 header lines, six lines per lamp set, ten direct
ratios, the C-plane angles, the gamma angles and the intensities in cd/klm. The header is
read line by line (text fields may hold anything); the numeric tail is read as a stream so
that wrapped or comma-separated values still parse. Intensities become absolute candela with
the flux of the first (standard) lamp set: ``I = value x flux / 1000 x conversion factor``.
A negative number of lamps marks absolute photometry (the flux field then holds the
luminaire flux, and ``declared_lumens`` is None).

C-planes stored per symmetry indicator Isym:

====  =====================  ==========================
Isym  stored C-planes        symmetry
====  =====================  ==========================
0     all (0 .. 360 - Dc)    none
1     one                    about the vertical axis
2     C0 .. C180             about the C0-C180 plane
3     C90 .. C270            about the C90-C270 plane
4     C0 .. C90              about C0-C180 and C90-C270
====  =====================  ==========================
"""

from __future__ import annotations

import os

import numpy as np

from ies.errors import PhotometryParseError
from ies.grid import unfold_type_c
from ies.photometry import Photometry, check_declared_flux
from ies.plausibility import check_magnitudes, implausible_flux
from ies.text import TokenStream, read_text, tokenize

_HEADER_FIELDS = (
    "company",
    "type_indicator",
    "symmetry_indicator",
    "n_c_planes",
    "c_plane_distance",
    "n_intensities",
    "intensity_distance",
    "report_number",
    "luminaire_name",
    "luminaire_number",
    "file_name",
    "date_user",
    "length",
    "width",
    "height",
    "luminous_length",
    "luminous_width",
    "luminous_height_c0",
    "luminous_height_c90",
    "luminous_height_c180",
    "luminous_height_c270",
    "downward_flux_fraction",
    "light_output_ratio",
    "conversion_factor",
    "measurement_tilt",
    "n_lamp_sets",
)
_TEXT_FIELDS = {
    "company",
    "report_number",
    "luminaire_name",
    "luminaire_number",
    "file_name",
    "date_user",
}
_STORED_RANGES = {0: (0.0, 360.0), 1: (0.0, 0.0), 2: (0.0, 180.0), 3: (90.0, 270.0), 4: (0.0, 90.0)}


def parse_ldt(text: str, *, source: str = "<string>") -> Photometry:
    """Parse the text of a EULUMDAT file.

    Parameters
    ----------
    text : str
        File contents.
    source : str
        Name used in messages and stored on the result.

    Returns
    -------
    Photometry
        Type C table in absolute candela, unfolded to 0..360 deg.

    Raises
    ------
    PhotometryParseError
        Malformed file; the message names the file, line and token.

    References
    ----------
    Stockmar A., "EULUMDAT/2: extended version of a well established luminaire data
    format", CIBSE/LiTG (1998); EULUMDAT file format description (LiTG, 1990).
    """
    lines = text.splitlines()
    header: dict[str, str] = {}
    numbers: dict[str, float] = {}
    position = 0

    def take_line(name: str) -> tuple[str, int]:
        nonlocal position
        if position >= len(lines):
            raise PhotometryParseError(
                f"file ends early: expected {name}", source=source, line=len(lines)
            )
        position += 1
        return lines[position - 1].strip(), position

    def take_number(name: str, *, integer: bool = False) -> float:
        value_text, line = take_line(name)
        try:
            value = float(value_text.replace(",", "."))
        except ValueError:
            raise PhotometryParseError(
                f"expected a number for {name}", source=source, line=line, token=value_text
            ) from None
        if not np.isfinite(value) or (integer and value != int(value)):
            kind = "an integer" if integer else "a finite number"
            raise PhotometryParseError(
                f"expected {kind} for {name}", source=source, line=line, token=value_text
            )
        return value

    for name in _HEADER_FIELDS:
        if name in _TEXT_FIELDS:
            header[name] = take_line(name)[0]
        else:
            integer = name in (
                "type_indicator",
                "symmetry_indicator",
                "n_c_planes",
                "n_intensities",
                "n_lamp_sets",
            )
            numbers[name] = take_number(name, integer=integer)
    symmetry_line = 3
    isym = int(numbers["symmetry_indicator"])
    if isym not in _STORED_RANGES:
        raise PhotometryParseError(
            "symmetry indicator Isym must be 0-4",
            source=source,
            line=symmetry_line,
            token=lines[symmetry_line - 1].strip(),
        )
    n_sets = int(numbers["n_lamp_sets"])
    if n_sets < 1:
        raise PhotometryParseError(
            "number of lamp sets must be >= 1", source=source, line=26, token=lines[25].strip()
        )
    lamp_sets = []
    for k in range(n_sets):
        n_lamps = take_number(f"number of lamps of set {k + 1}", integer=True)
        lamp_type = take_line(f"lamp type of set {k + 1}")[0]
        flux = take_number(f"luminous flux of set {k + 1}")
        colour = take_line(f"colour temperature of set {k + 1}")[0]
        rendering = take_line(f"colour rendering of set {k + 1}")[0]
        watts = take_number(f"wattage of set {k + 1}")
        lamp_sets.append((int(n_lamps), lamp_type, flux, colour, rendering, watts))

    stream = TokenStream(tokenize(lines[position:], position + 1, decimal_comma=True), source)
    stream.read_floats(10, "direct ratios")
    n_c = int(numbers["n_c_planes"])
    n_g = int(numbers["n_intensities"])
    if n_c < 1 or n_g < 1:
        raise PhotometryParseError(f"Mc={n_c} and Ng={n_g} must be >= 1", source=source, line=4)
    c_angles = np.array(stream.read_floats(n_c, "C-plane angles"))
    gammas = np.array(stream.read_floats(n_g, "gamma angles"))
    low, high = _STORED_RANGES[isym]
    if isym == 0:
        stored = c_angles
    elif isym == 1:
        stored = c_angles[:1] if c_angles.size else np.array([0.0])
    else:
        stored = c_angles[(c_angles >= low - 1e-6) & (c_angles <= high + 1e-6)]
    start = stream.position
    values = np.array(stream.read_floats(stored.size * n_g, "luminous intensities"))
    bad = np.nonzero(values < 0)[0]
    if bad.size:
        raise stream.error("negative luminous intensity", stream.token_at(start + int(bad[0])))
    found: list[str] = []
    if stream.remaining:
        found.append(f"{stream.remaining} value(s) after the intensity table ignored")
    table = values.reshape(stored.size, n_g)
    if isym == 1:
        stored = np.array([0.0])

    n_lamps, lamp_type, flux, colour, _, watts = lamp_sets[0]
    absolute = n_lamps < 0
    if flux <= 0:
        found.append(f"lamp flux {flux:g} lm <= 0: intensities kept in cd/klm, read as cd")
        scale = 1.0
        declared: float | None = None
    else:
        scale = flux / 1000.0
        declared = None if absolute else flux
    conversion = numbers["conversion_factor"] if numbers["conversion_factor"] > 0 else 1.0
    check_magnitudes(
        values,
        scale * conversion,
        error=lambda message, k: stream.error(message, stream.token_at(start + k)),
    )
    try:
        horizontal, candela, symmetry = unfold_type_c(stored, table)
    except ValueError as exc:
        raise PhotometryParseError(str(exc), source=source, line=4) from None
    if np.any(np.diff(gammas) <= 0):
        raise PhotometryParseError("gamma angles must increase", source=source)
    lor = numbers["light_output_ratio"] / 100.0
    keywords = {key: value for key, value in header.items()}
    keywords.update(
        {
            "type_indicator": f"{numbers['type_indicator']:g}",
            "symmetry_indicator": str(isym),
            "downward_flux_fraction": f"{numbers['downward_flux_fraction']:g}",
            "light_output_ratio": f"{numbers['light_output_ratio']:g}",
            "measurement_tilt": f"{numbers['measurement_tilt']:g}",
            "lamp_type": lamp_type,
            "colour_temperature": colour,
            "lamp_sets": str(n_sets),
        }
    )
    for k, lamp_set in enumerate(lamp_sets[1:], start=2):
        keywords[f"lamp_set_{k}"] = (
            f"{lamp_set[0]} x {lamp_set[1]}, {lamp_set[2]:g} lm, {lamp_set[5]:g} W"
        )
    photometry = Photometry(
        photometric_type="C",
        vertical_angles=gammas,
        horizontal_angles=horizontal,
        candela=candela * scale * conversion,
        declared_lumens=declared,
        source=source,
        format="EULUMDAT",
        version="",
        keywords=keywords,
        symmetry=symmetry,
        luminous_opening=(
            numbers["luminous_width"] / 1000.0,
            numbers["luminous_length"] / 1000.0,
            numbers["luminous_height_c0"] / 1000.0,
        ),
        candela_multiplier=scale * conversion,
        input_watts=watts,
        declared_light_output_ratio=lor if lor > 0 else None,
    )
    too_bright = implausible_flux(photometry)
    return check_declared_flux(photometry, found=found + ([too_bright] if too_bright else []))


def read_ldt(path: str | os.PathLike[str]) -> Photometry:
    """Read a EULUMDAT file (UTF-8, else latin-1).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.ldt`` file.

    Returns
    -------
    Photometry
        See :func:`parse_ldt`.
    """
    return parse_ldt(read_text(path), source=os.fspath(path))
