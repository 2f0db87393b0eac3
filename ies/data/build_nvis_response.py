"""Build ``nvis_response.csv``: a MIL-STD-3009-style night-vision-goggle spectral response.

This is a documented *model*, not the tabulated response of the standard (which is not
redistributed here). It multiplies

* a Gen III (GaAs) image-intensifier photocathode response: zero below 450 nm, raised-cosine
  rise to a plateau from 600 to 850 nm, raised-cosine fall to zero at 930 nm (the upper end
  of the NVIS response range of MIL-STD-3009, Sec. 4), and
* the objective's minus-blue filter, a logistic edge with its 50 % point at 625 nm (NVIS
  class A) or 665 nm (class B), the class definitions of MIL-STD-3009 (2001), Sec. 3, and a
  10-90 % width of about 26 nm,

normalised to a peak of 1. Run ``python ies/data/build_nvis_response.py`` to regenerate.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

PLATEAU = (600.0, 850.0)  # photocathode plateau [nm]
LIMITS = (450.0, 930.0)  # photocathode response range [nm]
EDGE_WIDTH = 6.0  # logistic scale of the filter edge [nm]
CUT_ON = {"nvis_class_a": 625.0, "nvis_class_b": 665.0}  # MIL-STD-3009 classes [nm]


def photocathode(wavelength: np.ndarray) -> np.ndarray:
    """Relative Gen III photocathode response."""
    rise = 0.5 - 0.5 * np.cos(
        np.pi * np.clip((wavelength - LIMITS[0]) / (PLATEAU[0] - LIMITS[0]), 0, 1)
    )
    fall = 0.5 + 0.5 * np.cos(
        np.pi * np.clip((wavelength - PLATEAU[1]) / (LIMITS[1] - PLATEAU[1]), 0, 1)
    )
    return rise * fall


def response(wavelength: np.ndarray, cut_on: float) -> np.ndarray:
    """Photocathode x minus-blue filter, peak-normalised."""
    values = photocathode(wavelength) / (1.0 + np.exp(-(wavelength - cut_on) / EDGE_WIDTH))
    return values / values.max()


def main() -> None:
    wavelength = np.arange(400.0, 951.0, 5.0)
    lines = [
        "# NVIS goggle spectral response model (MIL-STD-3009 style), peak-normalised; "
        "built by build_nvis_response.py (see its docstring); not the standard's table",
        "wavelength_nm," + ",".join(CUT_ON),
    ]
    columns = [response(wavelength, cut) for cut in CUT_ON.values()]
    for k, nm in enumerate(wavelength):
        lines.append(f"{nm:.0f}," + ",".join(f"{c[k]:.6f}" for c in columns))
    Path(__file__).with_name("nvis_response.csv").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
