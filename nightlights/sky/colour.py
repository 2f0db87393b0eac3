"""Colour of skyglow: CIE XYZ panoramas from wavelength-dependent scattering (``--bands RGB``).

Each tristimulus band is treated as scattered at the peak wavelength of its CIE 1931 colour
matching function, and the emission of each band is the photopic flux scaled by the
luminaire spectrum's ratio of that band to Y, so orange (sodium) and blue-white (LED) lights
give differently coloured skies (Dobashi et al. 2023, Fig. 10).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from nightlights.io import atomic_output

#: Wavelength at which each tristimulus band is scattered [nm]: the peaks of the CIE 1931
#: 2-degree colour matching functions x-bar (599 nm), y-bar (555 nm) and z-bar (446 nm)
#: (CIE 015:2018, Table T.4). An approximation: each band's light is scattered as one line.
TRISTIMULUS_WAVELENGTHS: dict[str, float] = {"X": 599.0, "Y": 555.0, "Z": 446.0}


def tristimulus_flux_ratios(spectrum: str) -> dict[str, float]:
    """Flux in each tristimulus band per photopic lumen for a luminaire spectrum [1].

    Parameters
    ----------
    spectrum
        Name of a spectrum in :data:`ies.spectra.SPDS` (e.g. ``HPS``, ``LED_4000K``).

    Returns
    -------
    dict
        ``{"X": int S x / int S y, "Y": 1, "Z": int S z / int S y}``.
    """
    from ies.spectra import sensor_factor

    y = sensor_factor(spectrum, "cie_y")
    return {
        "X": sensor_factor(spectrum, "cie_x") / y,
        "Y": 1.0,
        "Z": sensor_factor(spectrum, "cie_z") / y,
    }


def render_colour_panorama(
    xyz: NDArray[np.float64],
    elevation: NDArray[np.float64],
    out_png: str | os.PathLike[str],
    *,
    title: str = "",
) -> Path:
    """Write an equirectangular sRGB picture of an XYZ panorama (log tone mapping).

    Parameters
    ----------
    xyz
        ``(n_el, n_az, 3)`` tristimulus luminances [cd m-2].
    elevation
        Row centres [deg].
    out_png
        Output file, written atomically.
    title
        Figure title.
    """
    xyz = np.nan_to_num(np.asarray(xyz, dtype=float), nan=0.0)
    y = xyz[..., 1]
    positive = y[y > 0]
    top = np.percentile(positive, 99.5) if positive.size else 1.0
    # Log tone mapping of Y over four decades; chromaticity kept.
    mapped = np.clip(np.log10(np.maximum(y, top * 1e-4) / (top * 1e-4)) / 4.0, 0.0, 1.0)
    scale = np.divide(mapped, y, out=np.zeros_like(y), where=y > 0)
    # colour-science and matplotlib load in about a second: only when drawing
    from matplotlib.figure import Figure

    from ies.spectra import colour_science

    colour = colour_science()
    rgb = np.clip(colour.XYZ_to_sRGB(xyz * scale[..., None]), 0.0, 1.0)
    fig = Figure(figsize=(11, 3.4), layout="constrained")
    ax = fig.subplots()
    ax.imshow(
        rgb,
        extent=(0, 360, float(elevation[-1]) - 0.5 * (90 / elevation.size), 90),
        aspect="auto",
        interpolation="nearest",
    )
    ax.set_xlabel("azimuth [deg, clockwise from north]")
    ax.set_ylabel("elevation [deg]")
    ax.set_xticks(np.arange(0, 361, 45))
    if title:
        ax.set_title(title)
    with atomic_output(out_png) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return Path(out_png)
