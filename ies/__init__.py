"""Photometry: IES LM-63 and EULUMDAT files, luminous flux, BUG ratings, spectra and sensors.

Readers return a :class:`Photometry` (absolute candela on an unfolded grid) with vectorised
lookups and exact flux integrals; :mod:`ies.spectra` weights lux by any sensor's spectral
response; :mod:`ies.library` holds the luminaire database of light systems.

Examples
--------
>>> import ies
>>> p = ies.parse_ies("IESNA:LM-63-2002\\nTILT=NONE\\n1 -1 1 2 1 1 2 0 0 0\\n1 1 10\\n"
...                   "0 180\\n0\\n1 1\\n")
>>> float(p.intensity(30.0, 45.0))
1.0
"""

from ies.bug import BUGRating
from ies.errors import (
    FluxMismatchWarning,
    LuminaireDatabaseError,
    PhotometryError,
    PhotometryParseError,
    PhotometryWarning,
)
from ies.eulumdat import parse_ldt, read_ldt
from ies.frames import direction_from_angles, photometric_angles
from ies.lm63 import parse_ies, read_ies
from ies.photometry import Photometry
from ies.reader import parse_photometry, read_photometry

__all__ = [
    "BUGRating",
    "FluxMismatchWarning",
    "LuminaireDatabaseError",
    "Photometry",
    "PhotometryError",
    "PhotometryParseError",
    "PhotometryWarning",
    "direction_from_angles",
    "parse_ies",
    "parse_ldt",
    "parse_photometry",
    "photometric_angles",
    "read_ies",
    "read_ldt",
    "read_photometry",
]
