"""False-colour pictures of panoramas in mag arcsec-2 (equirectangular or fisheye)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from nightlights.errors import InputError
from nightlights.io import atomic_output

PROJECTIONS = ("equirectangular", "fisheye")
#: Colour range of the pictures [mag arcsec-2]: 14 (bright city sky) to 23 (beyond the
#: natural sky's ~22, astronomers' convention for skyglow maps).
MAGNITUDE_RANGE = (14.0, 23.0)


def render_panorama(
    sky_brightness: NDArray[np.float64],
    elevation: NDArray[np.float64],
    azimuth: NDArray[np.float64],
    out_png: str | os.PathLike[str],
    *,
    projection: str = "equirectangular",
    title: str = "",
    magnitude_range: tuple[float, float] = MAGNITUDE_RANGE,
) -> Path:
    """Write a panorama of sky brightness as a PNG with a colour bar.

    Parameters
    ----------
    sky_brightness
        ``(n_el, n_az)`` [mag arcsec-2]; brighter sky (smaller m) is drawn lighter.
    elevation, azimuth
        Pixel centres [deg]; azimuth clockwise from north.
    out_png
        Output file, written atomically.
    projection
        ``equirectangular`` (azimuth across, zenith at the top) or ``fisheye`` (zenith in
        the centre, horizon at the rim, north up and azimuth clockwise as on a map).
    title
        Figure title.
    magnitude_range
        Colour range [mag arcsec-2].
    """
    if projection not in PROJECTIONS:
        raise InputError(f"projection {projection!r}; expected one of {', '.join(PROJECTIONS)}")
    values = np.clip(np.asarray(sky_brightness, dtype=float), *magnitude_range)
    d_az = 360.0 / azimuth.size
    d_el = 90.0 / elevation.size
    az_edges = np.concatenate([azimuth - d_az / 2, [azimuth[-1] + d_az / 2]])
    el_edges = np.concatenate([elevation + d_el / 2, [elevation[-1] - d_el / 2]])
    options: dict[str, Any] = {
        "cmap": matplotlib.colormaps["magma_r"],
        "vmin": magnitude_range[0],
        "vmax": magnitude_range[1],
    }
    if projection == "equirectangular":
        fig = Figure(figsize=(11, 3.6), layout="constrained")
        ax = fig.subplots()
        mesh = ax.pcolormesh(az_edges, el_edges, values, **options)
        ax.set_xlabel("azimuth [deg, clockwise from north]")
        ax.set_ylabel("elevation [deg]")
        ax.set_xticks(np.arange(0, 361, 45))
        ax.set_xlim(0, 360)
        ax.set_ylim(0, 90)
    else:
        fig = Figure(figsize=(6.5, 6), layout="constrained")
        ax = fig.subplots(subplot_kw={"projection": "polar"})
        ax.set_theta_zero_location("N")  # type: ignore[attr-defined]
        ax.set_theta_direction(-1)  # type: ignore[attr-defined]
        mesh = ax.pcolormesh(np.radians(az_edges), 90.0 - el_edges, values, **options)
        ax.set_ylim(0, 90)
        ax.set_yticks([30, 60, 90])
        ax.set_yticklabels(["60", "30", "0"])
        ax.set_xticks(np.radians(np.arange(0, 360, 45)))
        ax.set_xticklabels(["N", "NE", "E", "SE", "S", "SW", "W", "NW"])
    fig.colorbar(mesh, ax=ax, label="sky brightness [mag arcsec-2]", shrink=0.9)
    if title:
        ax.set_title(title)
    with atomic_output(out_png) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return Path(out_png)
