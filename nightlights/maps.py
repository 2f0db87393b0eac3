"""Quick-look map figures of raster products with point layers on top (PNG, matplotlib)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import geopandas as gpd
import matplotlib

matplotlib.use("Agg")
import matplotlib.patches
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import LogNorm

from nightlights.io import Raster, as_raster, atomic_output

if TYPE_CHECKING:
    import xarray as xr


def plot_raster_map(
    raster: Raster | xr.DataArray | str | os.PathLike[str],
    out_png: str | os.PathLike[str],
    *,
    band: int = 1,
    points: gpd.GeoDataFrame | None = None,
    floor: float = 0.1,
    title: str | None = None,
    credit: str | None = None,
    zoom: tuple[float, float, float, float] | None = None,
    points_label: str = "poles",
    points_size: float = 2.0,
) -> Path:
    """Draw one band of a raster on a logarithmic colour scale, with points on top.

    Parameters
    ----------
    raster
        Raster to draw: a :class:`~nightlights.io.Raster`, a DataArray or a GeoTIFF path.
    out_png
        Output PNG, written atomically.
    band
        1-based band index.
    points
        Optional point layer (e.g. poles) in the raster's CRS.
    floor
        Values below this are drawn as the lowest colour [band unit].
    title
        Figure title (default: the band description).
    credit
        Data credit printed in the corner.
    zoom
        Optional ``(xmin, ymin, xmax, ymax)`` [m] drawn as a second, enlarged panel.
    points_label
        Legend label of the points.
    points_size
        Marker size of the points in the main panel [pt^2].

    Returns
    -------
    pathlib.Path
        The written PNG.
    """
    image_raster = as_raster(raster)
    values = image_raster.data[band - 1]
    transform = image_raster.transform
    rows, cols = values.shape
    extent = (
        transform.c,
        transform.c + transform.a * cols,
        transform.f + transform.e * rows,
        transform.f,
    )
    unit = image_raster.units[band - 1] or ""
    description = image_raster.descriptions[band - 1] or f"band {band}"
    finite = values[np.isfinite(values)]
    top = max(float(finite.max()) if finite.size else 1.0, floor * 10)
    panels = 2 if zoom else 1
    fig, axes = plt.subplots(
        1, panels, figsize=(6.5 * panels + 1, 7.5), squeeze=False, layout="constrained"
    )
    norm = LogNorm(vmin=floor, vmax=top)
    crs = image_raster.crs
    for index, ax in enumerate(axes[0]):
        image = ax.imshow(
            np.clip(values, floor, None),
            extent=extent,
            norm=norm,
            cmap="inferno",
            interpolation="nearest",
        )
        if points is not None and not points.empty:
            ax.scatter(
                points.geometry.x,
                points.geometry.y,
                s=points_size if index == 0 else 6 * points_size,
                c="cyan",
                linewidths=0,
                label=points_label,
            )
            ax.legend(loc="lower left", markerscale=2)
        if index == 1 and zoom is not None:
            ax.set_xlim(zoom[0], zoom[2])
            ax.set_ylim(zoom[1], zoom[3])
            ax.set_title("enlarged")
            axes[0][0].add_patch(
                matplotlib.patches.Rectangle(
                    (zoom[0], zoom[1]),
                    zoom[2] - zoom[0],
                    zoom[3] - zoom[1],
                    fill=False,
                    edgecolor="w",
                    linewidth=1,
                )
            )
        else:
            ax.set_title(title or description)
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.tick_params(axis="x", labelrotation=30)
        ax.set_xlabel(f"easting [m] ({crs.to_string() if crs else 'no CRS'})")
        ax.set_ylabel("northing [m]")
        if credit:
            ax.text(0.99, 0.01, credit, transform=ax.transAxes, ha="right", fontsize=7, color="w")
    fig.colorbar(image, ax=axes[0].tolist(), shrink=0.8, label=f"{description} [{unit}]")
    with atomic_output(out_png) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(out_png)
