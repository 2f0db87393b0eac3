"""Before/after pictures of a dimming: the two panoramas side by side on one colour scale."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import luminance_to_magnitude
from nightlights.io import atomic_output
from nightlights.sky.render import MAGNITUDE_RANGE

__all__ = ["render_before_after"]


def render_before_after(
    before: FloatArray,
    after: FloatArray,
    elevation: FloatArray,
    out_png: PathLike,
    *,
    title: str = "",
    magnitude_range: tuple[float, float] = MAGNITUDE_RANGE,
) -> Path:
    """Write two panoramas (before and after a dimming) side by side, with their zeniths.

    Parameters
    ----------
    before, after
        ``(n_el, n_az)`` sky luminance, NaN under the terrain [cd m-2].
    elevation
        Row centres, zenith first [deg].
    out_png
        Output PNG, written atomically.
    title
        Figure title.
    magnitude_range
        Colour range [mag arcsec-2].

    Returns
    -------
    pathlib.Path
        The written path.
    """
    n_az = before.shape[1]
    az_edges = np.linspace(0.0, 360.0, n_az + 1)
    d_el = 90.0 / elevation.size
    el_edges = np.concatenate([elevation + d_el / 2, [elevation[-1] - d_el / 2]])
    fig = Figure(figsize=(13, 3.4), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    mesh = None
    for ax, luminance, name in zip(axes, (before, after), ("before", "after"), strict=True):
        magnitude = luminance_to_magnitude(np.maximum(luminance, 1e-30))
        magnitude = np.where(np.isfinite(luminance), magnitude, np.nan)
        mesh = ax.pcolormesh(
            az_edges,
            el_edges,
            np.clip(magnitude, *magnitude_range),
            cmap=matplotlib.colormaps["magma_r"],
            vmin=magnitude_range[0],
            vmax=magnitude_range[1],
        )
        zenith = float(np.nanmean(luminance[0]))
        ax.set_title(f"{name}: zenith {float(luminance_to_magnitude(zenith)):.2f} mag arcsec-2")
        ax.set_xlabel("azimuth [deg, clockwise from north]")
        ax.set_xticks(np.arange(0, 361, 90))
        ax.set_xlim(0, 360)
        ax.set_ylim(0, 90)
    axes[0].set_ylabel("elevation [deg]")
    assert mesh is not None
    fig.colorbar(mesh, ax=axes, label="sky brightness [mag arcsec-2]", shrink=0.9)
    if title:
        fig.suptitle(title)
    with atomic_output(out_png) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return Path(out_png)
