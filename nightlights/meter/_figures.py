"""The validation's pictures: predicted against measured with the 1:1 line, and the residual map."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm
from matplotlib.figure import Figure

from nightlights.io import Raster, atomic_output
from nightlights.io.styles import RESIDUAL_COLOURS, RESIDUAL_EDGES

__all__ = ["residual_map", "scatter"]

#: Marker of each instrument in the scatter plot.
MARKERS = {"sqm": "o", "sqm-l": "s", "tess-w": "^", "eye": "D"}


def scatter(stations: Any, path: Path, calibration: Any = None) -> Path:
    """Predicted against measured, one marker per instrument, with the 1:1 line.

    Parameters
    ----------
    stations
        The validation's stations (``measured``, ``predicted``, ``instrument``; ``held_out``
        after a calibration).
    path
        Output PNG, written atomically.
    calibration
        The calibration, if any: its held-out predictions are drawn beside the model's.

    Returns
    -------
    pathlib.Path
    """
    from nightlights.meter.calibrate import residual_statistics

    panels = [("predicted", "model as given")]
    if calibration is not None:
        panels.append(("held_out", "calibrated, held out"))
    fig = Figure(figsize=(5.2 * len(panels), 5.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(panels), squeeze=False)[0])
    measured = stations["measured"].to_numpy(float)
    every = [measured] + [stations[column].to_numpy(float) for column, _ in panels]
    values = np.concatenate([v[np.isfinite(v)] for v in every])
    low, high = float(values.min()) - 0.3, float(values.max()) + 0.3
    for ax, (column, title) in zip(axes, panels, strict=True):
        for name, group in stations.groupby("instrument", sort=True):
            ax.scatter(
                group["measured"],
                group[column],
                marker=MARKERS.get(str(name), "o"),
                s=22,
                alpha=0.8,
                label=f"{name} ({len(group)})",
            )
        ax.plot([low, high], [low, high], color="0.3", lw=1, label="1:1")
        stats = residual_statistics(measured - stations[column].to_numpy(float))
        ax.set_title(
            f"{title}\nbias {stats['bias']:+.2f}, RMS {stats['rms']:.2f}, "
            f"MAD {stats['mad']:.2f} mag arcsec$^{{-2}}$ (n = {stats['n']})",
            fontsize=9,
        )
        ax.set_xlim(high, low)  # darker skies to the left, as magnitudes read
        ax.set_ylim(high, low)
        ax.set_aspect("equal")
        ax.set_xlabel("measured [mag arcsec$^{-2}$]")
        ax.set_ylabel("predicted [mag arcsec$^{-2}$]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    return Path(path)


def residual_map(stations: Any, path: Path, emission: Raster) -> Path:
    """The stations coloured by residual over the emission (log grey).

    Parameters
    ----------
    stations
        The validation's stations (``x``, ``y``, ``residual``) in the emission's CRS.
    path
        Output PNG, written atomically.
    emission
        The emission raster drawn underneath [lm m-2].

    Returns
    -------
    pathlib.Path
    """
    total = np.nansum(emission.data, axis=0)
    step = max(1, int(np.ceil(max(total.shape) / 1500)))  # at most ~1500 pixels a side
    shown = total[::step, ::step]
    west, south, east, north = emission.bounds
    fig = Figure(figsize=(7.5, 6.5), layout="constrained")
    ax = fig.subplots()
    lit = shown[shown > 0]
    if lit.size:
        norm = LogNorm(vmin=float(np.quantile(lit, 0.02)), vmax=float(lit.max()))
        ax.imshow(
            np.where(shown > 0, shown, np.nan),
            extent=(west, east, south, north),
            cmap="Greys_r",
            norm=norm,
            interpolation="nearest",
        )
    ax.set_facecolor("black")
    cmap = ListedColormap(list(RESIDUAL_COLOURS))
    norm_r = BoundaryNorm(list(RESIDUAL_EDGES[1:-1]), cmap.N, extend="both")
    points = ax.scatter(
        stations["x"],
        stations["y"],
        c=np.clip(stations["residual"].to_numpy(float), -0.99, 0.99),
        cmap=cmap,
        norm=norm_r,
        s=36,
        edgecolors="white",
        linewidths=0.6,
    )
    bar = fig.colorbar(points, ax=ax, shrink=0.8)
    bar.set_label("measured - predicted [mag arcsec$^{-2}$] (red: brighter than predicted)")
    ax.set_xlim(west, east)
    ax.set_ylim(south, north)
    ax.set_xlabel(f"x [m] ({emission.crs.to_string() if emission.crs else ''})")
    ax.set_ylabel("y [m]")
    ax.set_title("Residuals at the stations over the emission", fontsize=10)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return Path(path)
