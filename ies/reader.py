"""Format dispatch: read any supported photometric file."""

from __future__ import annotations

import os

from ies.eulumdat import parse_ldt
from ies.lm63 import _TILT_LINE, parse_ies
from ies.photometry import Photometry
from ies.text import read_text


def looks_like_ies(text: str) -> bool:
    """True when some line starts with ``TILT=`` (every LM-63 file has one)."""
    return any(_TILT_LINE.match(line) for line in text.splitlines()[:400])


def parse_photometry(text: str, *, source: str = "<string>") -> Photometry:
    """Parse IES LM-63 or EULUMDAT text, chosen by content (an LM-63 ``TILT=`` line).

    Parameters
    ----------
    text : str
        File contents.
    source : str
        Name used in messages.

    Returns
    -------
    Photometry
        The parsed table.
    """
    if looks_like_ies(text):
        return parse_ies(text, source=source)
    return parse_ldt(text, source=source)


def read_photometry(path: str | os.PathLike[str]) -> Photometry:
    """Read a photometric file: ``.ies`` as LM-63, ``.ldt`` as EULUMDAT, others by content.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    Photometry
        The parsed table.

    Raises
    ------
    PhotometryError
        Unreadable or malformed file.
    """
    from ies.errors import PhotometryError

    name = os.fspath(path)
    try:
        text = read_text(path)
    except OSError as exc:
        raise PhotometryError(f"{name}: cannot read photometric file ({exc.strerror})") from exc
    suffix = os.path.splitext(name)[1].lower()
    if suffix == ".ies":
        return parse_ies(text, source=name)
    if suffix == ".ldt":
        return parse_ldt(text, source=name)
    return parse_photometry(text, source=name)
