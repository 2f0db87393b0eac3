"""Quick-look map figures of raster products with point layers on top (PNG, matplotlib)."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import geopandas as gpd
import matplotlib
import matplotlib.patches
import numpy as np
import rasterio
import rasterio.errors
import rasterio.windows
from affine import Affine
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from pyproj import CRS
from rasterio.enums import Resampling
from rasterio.windows import Window

from nightlights.io import Raster, as_raster, atomic_output
from nightlights.io.outputs import refuse_replacing_inputs

if TYPE_CHECKING:
    import xarray as xr

#: Largest side of the image a map draws in a panel when it reads a raster file [pixels]. A
#: larger file is read averaged down to this (from the COG's overviews), and the enlarged
#: panel reads its window alone, so that a city's raster is never read whole for a picture
#: some 700 pixels across.
MAP_PIXELS = 2048


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
    refuse_replacing_inputs([out_png], {"raster": raster})  # before the raster is read
    if isinstance(raster, (str, os.PathLike)):
        images, crs, unit, description = _read_images(raster, band, zoom)
    else:
        image_raster = as_raster(raster)
        values = image_raster.data[band - 1]
        images = [(values, _extent(image_raster.transform, *values.shape))] * 2
        crs = image_raster.crs
        unit = image_raster.units[band - 1] or ""
        description = image_raster.descriptions[band - 1] or ""
    description = description or f"band {band}"
    finite = np.concatenate([values[np.isfinite(values)].ravel() for values, _ in images])
    top = max(float(finite.max()) if finite.size else 1.0, floor * 10)
    panels = 2 if zoom else 1
    fig = Figure(figsize=(6.5 * panels + 1, 7.5), layout="constrained")
    axes = fig.subplots(1, panels, squeeze=False)
    norm = LogNorm(vmin=floor, vmax=top)
    for index, ax in enumerate(axes[0]):
        values, extent = images[index]
        image = ax.imshow(
            np.clip(values, floor, None),
            extent=extent,
            norm=norm,
            cmap=matplotlib.colormaps["inferno"],
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
    return Path(out_png)


def _extent(transform: Affine, rows: int, cols: int) -> tuple[float, float, float, float]:
    """(left, right, bottom, top) of a north-up grid [m]."""
    return (
        transform.c,
        transform.c + transform.a * cols,
        transform.f + transform.e * rows,
        transform.f,
    )


def _read_images(
    path: str | os.PathLike[str], band: int, zoom: tuple[float, float, float, float] | None
) -> tuple[list[tuple[np.ndarray, tuple[float, float, float, float]]], CRS | None, str, str]:
    """The panels' images of a raster file, each at most :data:`MAP_PIXELS` on a side.

    Returns the (values, extent) of the whole raster and of the ``zoom`` window (the whole
    raster again without one), the CRS, the band's unit and description.
    """
    with rasterio.open(path) as dataset:

        def read(window: Window) -> tuple[np.ndarray, tuple[float, float, float, float]]:
            step = max(1, math.ceil(max(window.height, window.width) / MAP_PIXELS))
            shape = (math.ceil(window.height / step), math.ceil(window.width / step))
            data = dataset.read(
                band, window=window, out_shape=shape, resampling=Resampling.average, masked=True
            )
            bounds = rasterio.windows.bounds(window, dataset.transform)
            return data.astype(float).filled(np.nan), (bounds[0], bounds[2], bounds[1], bounds[3])

        whole = Window(0, 0, dataset.width, dataset.height)
        images = [read(whole)]
        if zoom is not None:
            x0, x1 = sorted(zoom[0::2])
            y0, y1 = sorted(zoom[1::2])
            exact = rasterio.windows.from_bounds(x0, y0, x1, y1, transform=dataset.transform)
            # every pixel the zoom touches, its edges rounded outwards
            col, row = math.floor(exact.col_off), math.floor(exact.row_off)
            window = Window(
                col,
                row,
                math.ceil(exact.col_off + exact.width) - col,
                math.ceil(exact.row_off + exact.height) - row,
            )
            try:
                window = window.intersection(whole)
            except rasterio.errors.WindowError:  # the window misses the raster: an empty panel
                window = whole
            images.append(read(window))
        else:
            images.append(images[0])
        crs = CRS.from_user_input(dataset.crs.to_wkt()) if dataset.crs else None
        return images, crs, dataset.units[band - 1] or "", dataset.descriptions[band - 1] or ""
