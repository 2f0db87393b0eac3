"""Grids as PNG images for the browser: colour-mapped, transparent where nothing is shown."""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nightlights.errors import InputError

#: Colour scales of :func:`raster_png`.
SCALES = ("log", "linear")
#: Colour stops in a legend (enough for a smooth CSS gradient) [1].
LEGEND_STOPS = 9


def _colormap(name: str) -> Any:
    import matplotlib

    try:
        return matplotlib.colormaps[name]
    except KeyError:
        raise InputError(f"cmap {name!r}; expected a matplotlib colormap name") from None


def _block_max(grid: np.ndarray, block: int) -> np.ndarray:
    """The largest shown value of each ``block`` x ``block`` cell block (NaN where none)."""
    if block == 1:
        return grid
    rows, cols = grid.shape
    padded = np.full((-(-rows // block) * block, -(-cols // block) * block), np.nan)
    padded[:rows, :cols] = grid
    blocks = padded.reshape(padded.shape[0] // block, block, padded.shape[1] // block, block)
    # fmax ignores NaN unless both are NaN: an empty block stays NaN
    return np.fmax.reduce(np.fmax.reduce(blocks, axis=3), axis=1)


#: Decades of a log scale below its largest value when no vmin is given: smaller values take
#: the lowest colour [1].
LOG_DECADES = 4.0


def _limit(value: float | None, name: str, *, scale: str) -> float | None:
    if value is None:
        return None
    number = float(value)
    if not math.isfinite(number) or (scale == "log" and number <= 0):
        expected = "a finite number > 0 for a log scale" if scale == "log" else "a finite number"
        raise InputError(f"{name}={value}; expected {expected}")
    return number


def raster_png(
    grid: ArrayLike,
    *,
    scale: str = "log",
    cmap: str = "magma",
    vmin: float | None = None,
    vmax: float | None = None,
    max_size: int = 1024,
    decades: float = LOG_DECADES,
) -> tuple[bytes, dict[str, Any]]:
    """A colour-mapped RGBA PNG of a grid, first row at the top, and its legend.

    Cells that are NaN (and, on a log scale, <= 0) are transparent. A grid larger than
    ``max_size`` on a side is reduced by blocks of ``ceil(side / max_size)`` cells, each pixel
    showing the *largest* value of its block, so that a single bright cell stays visible in an
    overview (a mean would dilute it); a block with nothing shown is transparent.

    Parameters
    ----------
    grid
        Values of shape (rows, cols) [any unit; the legend carries no unit].
    scale
        ``log`` (colour by log10 of the value) or ``linear``.
    cmap
        Matplotlib colormap name.
    vmin, vmax
        Values at the two ends of the colour scale (values beyond are clipped to the end
        colours); default: the smallest and largest shown value of ``grid``, on a log scale
        at most ``decades`` apart [unit of grid].
    max_size
        Largest width or height of the image [pixel].
    decades
        Span of a log scale without ``vmin``, in decades below its top [1].

    Returns
    -------
    tuple of (bytes, dict)
        The PNG, and the legend ``{"vmin", "vmax", "scale", "cmap", "colors", "block",
        "reduction"}``: ``colors`` are ``LEGEND_STOPS`` CSS colours (``#rrggbb``) evenly spaced
        from ``vmin`` to ``vmax`` along the scale, ``block`` the cells per pixel side and
        ``reduction`` ``"max"``. ``vmin`` and ``vmax`` are None when neither is given and nothing
        is shown (the image is then fully transparent).

    Raises
    ------
    InputError
        ``grid`` is not 2-D or is empty, an unknown ``scale`` or ``cmap``, ``vmin``/``vmax``
        not finite (or <= 0 on a log scale) or ``vmin > vmax``, ``max_size < 1``.

    Examples
    --------
    >>> png, legend = raster_png([[1.0, 10.0], [100.0, float("nan")]])
    >>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n", legend["vmin"], legend["vmax"], legend["scale"]
    (True, 1.0, 100.0, 'log')
    """
    from PIL import Image

    values = np.asarray(grid, dtype=np.float64)
    if values.ndim != 2 or values.size == 0:
        raise InputError(f"grid of shape {values.shape}; expected a non-empty (rows, cols) grid")
    if scale not in SCALES:
        raise InputError(f"scale {scale!r}; expected one of {', '.join(SCALES)}")
    if isinstance(max_size, bool) or not isinstance(max_size, int | np.integer) or max_size < 1:
        raise InputError(f"max_size={max_size!r}; expected an integer >= 1 [pixel]")
    colormap = _colormap(cmap)
    low, high = _limit(vmin, "vmin", scale=scale), _limit(vmax, "vmax", scale=scale)
    if low is not None and high is not None and low > high:
        raise InputError(f"vmin={low} > vmax={high}; expected vmin <= vmax")

    shown = np.isfinite(values) & (values > 0 if scale == "log" else True)
    values = np.where(shown, values, np.nan)
    if shown.any():
        high = float(values[shown].max()) if high is None else high
        if low is None:
            low = float(values[shown].min())
            if scale == "log":
                # a few cells far below the rest would push every other cell to the top
                # colour: the scale spans at most ``decades`` below the largest value
                low = max(low, high / 10.0**decades)
        low, high = min(low, high), max(low, high)  # one limit given beyond the data's range
    block = max(1, math.ceil(max(values.shape) / int(max_size)))
    reduced = _block_max(values, block)

    def position(v: np.ndarray) -> np.ndarray:
        """Place of ``v`` on the scale, 0 at vmin and 1 at vmax [1]."""
        assert low is not None and high is not None
        ends = np.log10([low, high]) if scale == "log" else np.array([low, high])
        v = np.log10(v) if scale == "log" else v
        span = ends[1] - ends[0]
        return np.clip((v - ends[0]) / span, 0.0, 1.0) if span > 0 else np.ones_like(v)

    rgba = np.zeros((*reduced.shape, 4), dtype=np.uint8)
    visible = np.isfinite(reduced)
    if visible.any():
        rgba[visible] = colormap(position(reduced[visible]), bytes=True)
    buffer = io.BytesIO()
    # the image goes to a browser on this machine: fast compression beats small files
    Image.fromarray(rgba, "RGBA").save(buffer, format="PNG", compress_level=1)
    stops = colormap(np.linspace(0.0, 1.0, LEGEND_STOPS), bytes=True)
    legend = {
        "vmin": low,
        "vmax": high,
        "scale": scale,
        "cmap": cmap,
        "colors": [f"#{r:02x}{g:02x}{b:02x}" for r, g, b, _ in stops.tolist()],
        "block": block,
        "reduction": "max",
    }
    return buffer.getvalue(), legend
