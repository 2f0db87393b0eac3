"""Checks of the ground stages: CRS options, finite values, all-zero results, memory estimates.

Every ground stage validates its options before it reads or allocates much, estimates the
memory it will hold at its peak (:func:`irradiance_memory`, :func:`viirs_memory`; the
windowed emission stages' estimates are beside their window loops,
:func:`nightlights.ground._emission_run.check_emission_memory` and
:func:`nightlights.ground._viirs_run.check_viirs_memory`) and refuses an estimate over the
limit through :func:`nightlights._resources.check_memory`. The per-pixel byte counts below
were measured (peak resident memory over the baseline, ``resource.getrusage``) on the bundled
Helsinki example and on synthetic rasters; ``tests/nightlights/ground/test_memory.py`` keeps every
stage within twice its estimate.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike
from pyproj import CRS
from pyproj.exceptions import CRSError as ProjCRSError

from nightlights.errors import CRSError, InputError

if TYPE_CHECKING:
    import xarray as xr
    from affine import Affine

    from nightlights.io import Raster

__all__ = [
    "IRRADIANCE_BYTES_PER_PIXEL",
    "FiniteScan",
    "RasterHeader",
    "check_finite_raster",
    "check_number",
    "irradiance_memory",
    "parse_crs",
    "raster_header",
    "viirs_memory",
]

#: Bytes held per output pixel and band of ``irradiance`` at its peak when it keeps the raster
#: (no output file): the float32 tiles assembled and the float64 raster [B]. With an output
#: file the tiles are streamed to it (:class:`nightlights.io.CogWriter`) and nothing is held
#: per pixel.
IRRADIANCE_BYTES_PER_PIXEL = 24
#: Bytes per output pixel for a DEM: elevation on the grid, its gradients and the
#: (rows, cols, 3) unit normals [B].
DEM_BYTES_PER_PIXEL = 112
#: Bytes per pixel of a tile in flight and per band for the numpy kernel: the float64
#: accumulator, one ``bincount`` result and the float32 tile returned [B].
TILE_BYTES_PER_PIXEL = 24
#: Bytes per pixel of a tile in flight and per band for the compiled kernel: the float64
#: accumulator and the float32 tile returned [B].
COMPILED_TILE_BYTES_PER_PIXEL = 12
#: Memory of ``irradiance``'s first calls besides its arrays [B]: the luminaire database and
#: photometric frames, GDAL's drivers; 35 MiB measured (``VmHWM`` over the imports, up to the
#: first tile) on the 10 lights of a 100 m square (``bench_memory_estimates.py``).
IRRADIANCE_FIXED_BYTES = 35 * 2**20
#: Memory of the first tiles computed in this process besides their arrays [B]: the compiled
#: kernel's code loaded from numba's cache and the worker threads' stacks and heaps; 112 MiB
#: measured (``VmHWM`` over the first tile's start) on the 10 lights of a 100 m square
#: (``bench_memory_estimates.py``).
LOCAL_TILES_FIXED_BYTES = 112 * 2**20
#: Bytes per pixel and band while a streamed raster is made a COG (its scratch file's blocks,
#: the COG's and its overviews' in GDAL's cache, up to :data:`nightlights.io.streamed.CACHE_MB`,
#: and the compression's buffers); 23 B measured (``VmHWM`` of the copy over the tiles')
#: on a 1275 x 1275 grid (``bench_memory_estimates.py``) [B].
COG_BYTES_PER_PIXEL = 24
#: Bytes per value of the style's sample (float32 read, float64 copy, finite and positive
#: values, the quantiles' copy; :data:`nightlights.io.styles.SAMPLE_LIMIT` values at most):
#: 16 B measured as above [B].
STYLE_BYTES_PER_SAMPLE = 16
#: Bytes per light-pixel pair of one numpy batch of the kernel (about 30 float64 and int64
#: arrays; 230 B measured with tracemalloc on a tile of the Helsinki example) [B].
BYTES_PER_PAIR = 240
#: Task-graph bytes per tile (Dask task, arguments, result bookkeeping) [B].
BYTES_PER_TILE = 20_000
#: Bytes per output cell of ``emission_from_viirs``: the float64 target, its float32/float64
#: round trip and the float32 copies of the writer [B].
VIIRS_BYTES_PER_CELL = 28
#: Bytes per input pixel of ``emission_from_viirs`` beyond its float64 bands: the masked
#: float32 read and its float64 copies, the flux density and GDAL's copy of it [B].
VIIRS_BYTES_PER_INPUT_PIXEL = 40


def parse_crs(value: str | CRS | None, *, option: str) -> CRS | None:
    """A CRS option as a :class:`pyproj.CRS`; ``None`` stays ``None``.

    Parameters
    ----------
    value
        Anything PROJ reads (``EPSG:3067``, WKT, a PROJ string) or a CRS.
    option
        Name of the parameter in the message (``crs``).

    Raises
    ------
    CRSError
        PROJ cannot read the value (one line naming it).

    Examples
    --------
    >>> parse_crs("EPSG:3067", option="crs").to_epsg()
    3067
    >>> parse_crs("garbage", option="crs")
    Traceback (most recent call last):
    ...
    nightlights.errors.CRSError: crs='garbage' is not a coordinate reference system; \
expected e.g. EPSG:3067, a WKT or a PROJ string
    """
    if value is None or isinstance(value, CRS):
        return value
    try:
        return CRS.from_user_input(value)
    except (ProjCRSError, TypeError, ValueError):
        raise CRSError(
            f"{option}={value!r} is not a coordinate reference system; expected e.g. "
            "EPSG:3067, a WKT or a PROJ string"
        ) from None


def check_number(
    value: Any,
    name: str,
    unit: str,
    *,
    minimum: float | None = None,
    positive: bool = False,
    allow_inf: bool = False,
) -> float:
    """``value`` as a float, refused when not finite or out of range.

    Parameters
    ----------
    value
        The number.
    name
        Parameter name for the message (``margin``).
    unit
        Unit for the message (``m``).
    minimum
        Smallest allowed value (inclusive) [unit].
    positive
        Require a value above 0.
    allow_inf
        Accept ``+inf`` (a cap that does not bind).

    Raises
    ------
    InputError
        Not a number, NaN, infinite (unless allowed) or out of range.

    Examples
    --------
    >>> check_number(5, "margin", "m", minimum=0.0)
    5.0
    >>> check_number(float("nan"), "margin", "m", minimum=0.0)
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: margin=nan m; expected a finite number >= 0 m
    """
    expected = "a finite number" if not allow_inf else "a number"
    if positive:
        expected += f" > 0 {unit}"
    elif minimum is not None:
        expected += f" >= {minimum:g} {unit}"
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={value!r} {unit}; expected {expected}") from None
    finite = math.isfinite(number) or (allow_inf and number == math.inf)
    in_range = (not positive or number > 0) and (minimum is None or number >= minimum)
    if not (finite and in_range):
        raise InputError(f"{name}={value!r} {unit}; expected {expected}")
    return number


def check_finite_raster(
    values: ArrayLike, label: str, quantity: str, unit: str, *, negative: str = "error"
) -> None:
    """Refuse infinite values and an all-nodata raster; refuse or tolerate negative values.

    Parameters
    ----------
    values
        Raster band (NaN is nodata).
    label
        Name of the raster for messages.
    quantity, unit
        What the values are, for messages (``illuminance``, ``lx``).
    negative
        ``"error"``: negative values are refused; ``"ignore"``: the caller handles them.

    Raises
    ------
    InputError
        Infinite values, negative values (``negative="error"``) or no value at all.
    """
    scan = FiniteScan()
    scan.add(values)
    scan.report(label, quantity, unit, negative=negative)


@dataclass
class FiniteScan:
    """What the pixels of a raster read in parts hold, for the checks of
    :func:`check_finite_raster` over all parts (the same messages as one whole raster's).

    Examples
    --------
    >>> scan = FiniteScan()
    >>> scan.add([[1.0, float("nan")]])
    >>> scan.add([[-2.0, 3.0]])
    >>> scan.report("ground.tif", "illuminance", "lx")
    Traceback (most recent call last):
    ...
    nightlights.errors.InputError: ground.tif: 1 pixels hold a negative illuminance (min -2 \
lx); expected values >= 0
    """

    infinite: int = 0
    negative: int = 0
    lowest: float = math.inf
    finite: bool = False

    def add(self, values: ArrayLike) -> None:
        """Count a part's infinite, finite and negative pixels (NaN is nodata)."""
        array = np.asarray(values)
        self.infinite += int(np.isinf(array).sum())
        self.finite = self.finite or bool(np.isfinite(array).any())
        with np.errstate(invalid="ignore"):
            below = array < 0
        if below.any():
            self.negative += int(below.sum())
            self.lowest = min(self.lowest, float(np.nanmin(array)))

    def report(self, label: str, quantity: str, unit: str, *, negative: str = "error") -> None:
        """Raise what :func:`check_finite_raster` raises for the pixels counted."""
        if self.infinite:
            raise InputError(
                f"{label}: {self.infinite} pixels hold an infinite {quantity}; expected "
                f"finite values [{unit}] (NaN for nodata)"
            )
        if not self.finite:
            raise InputError(f"{label}: every pixel is nodata; expected {quantity} values [{unit}]")
        if negative == "error" and self.negative:
            raise InputError(
                f"{label}: {self.negative} pixels hold a negative {quantity} (min "
                f"{self.lowest:.3g} {unit}); expected values >= 0"
            )


def irradiance_memory(
    rows: int,
    cols: int,
    bands: int,
    *,
    tile_size: int,
    workers: int,
    pairs: float = math.inf,
    dem: bool = False,
    local: bool = True,
    backend: str = "numba",
    streamed: bool = False,
) -> float:
    """Peak memory of ``irradiance`` on a grid [B].

    Parameters
    ----------
    rows, cols
        Output grid [pixels].
    bands
        Output bands [1].
    tile_size
        Tile edge [pixels] (the compiled kernel's balanced edge,
        :func:`~nightlights.ground.tiles.balanced_tile_size`).
    workers
        Tiles computed at once [1].
    pairs
        Light-pixel pairs of the whole grid (bounds a batch on small grids) [1].
    dem
        Whether a DEM is resampled to the grid.
    local
        Whether the tiles run in this process (not on a ``dask.distributed`` cluster).
    backend
        Illuminance kernel: the numpy reference holds one batch of light-pixel pairs per
        tile in flight, the compiled kernel none.
    streamed
        Whether the tiles go to a file as they are computed: the raster is then never
        held; the COG made from the file (:data:`COG_BYTES_PER_PIXEL`, up to GDAL's block
        cache, :data:`nightlights.io.streamed.CACHE_MB`) and its style's sample take its
        place.

    Returns
    -------
    float
        The first calls' memory (:data:`IRRADIANCE_FIXED_BYTES`, and
        :data:`LOCAL_TILES_FIXED_BYTES` for tiles in this process), the output raster (or
        the COG's copy and the style's sample), DEM grids, tiles in flight (tile pixels x
        bands x working arrays, plus one batch of light-pixel pairs each for the numpy
        kernel) and the task graph [B]. Measured against this estimate on 10 to 16,000
        lights over 0.1 to 18 million pixels (``bench_memory_estimates.py``): within 1.1x
        of the peak.

    Examples
    --------
    >>> round(irradiance_memory(1000, 1000, 1, tile_size=256, workers=4, pairs=1e6) / 2**20)
    173
    >>> round(
    ...     irradiance_memory(
    ...         1000, 1000, 1, tile_size=256, workers=4, pairs=1e6, backend="numpy"
    ...     )
    ...     / 2**20
    ... )
    1098
    """
    from nightlights.ground.illuminance import PAIRS_PER_BATCH
    from nightlights.io.streamed import CACHE_MB
    from nightlights.io.styles import SAMPLE_LIMIT

    pixels = float(rows) * float(cols)
    total = float(IRRADIANCE_FIXED_BYTES)
    if streamed:
        total += min(pixels * bands * COG_BYTES_PER_PIXEL, CACHE_MB * 2.0**20)
        total += min(pixels, SAMPLE_LIMIT) * bands * STYLE_BYTES_PER_SAMPLE
    else:
        total += pixels * bands * IRRADIANCE_BYTES_PER_PIXEL
    if dem:
        total += pixels * DEM_BYTES_PER_PIXEL
    tile_rows, tile_cols = min(tile_size, rows), min(tile_size, cols)
    n_tiles = math.ceil(rows / tile_size) * math.ceil(cols / tile_size)
    total += n_tiles * BYTES_PER_TILE
    if local:
        in_flight = min(workers, n_tiles)
        tile_pixels = float(tile_rows) * float(tile_cols)
        total += LOCAL_TILES_FIXED_BYTES
        if backend == "numpy":
            batch = min(PAIRS_PER_BATCH + tile_cols, pairs)
            total += in_flight * (tile_pixels * (bands + 1) * TILE_BYTES_PER_PIXEL)
            total += in_flight * batch * BYTES_PER_PAIR
        else:
            total += in_flight * tile_pixels * bands * COMPILED_TILE_BYTES_PER_PIXEL
    return total


def viirs_memory(in_rows: int, in_cols: int, in_bands: int, out_rows: int, out_cols: int) -> float:
    """Peak memory of ``emission_from_viirs`` [B].

    Parameters
    ----------
    in_rows, in_cols, in_bands
        VIIRS raster shape [pixels], [1].
    out_rows, out_cols
        Output grid [cells].

    Returns
    -------
    float
        The float64 input, its working arrays and the output with its copies [B].
    """
    pixels = float(in_rows) * float(in_cols)
    cells = float(out_rows) * float(out_cols)
    return pixels * (8 * in_bands + VIIRS_BYTES_PER_INPUT_PIXEL) + cells * VIIRS_BYTES_PER_CELL


@dataclass(frozen=True)
class RasterHeader:
    """What a raster's header says, read without its pixels (for memory estimates).

    Attributes
    ----------
    count, rows, cols
        Bands and shape [1], [pixels].
    transform
        Affine transform of the top-left pixel corner.
    crs
        Its CRS, or ``None``.
    bounds
        (left, bottom, right, top) [CRS units].
    """

    count: int
    rows: int
    cols: int
    transform: Affine
    crs: CRS | None
    bounds: tuple[float, float, float, float]


def raster_header(source: Raster | xr.DataArray | str | os.PathLike[str]) -> RasterHeader | None:
    """The header of a raster input without reading its pixels; ``None`` when the file cannot
    be opened (the reader reports that) or the input is not a raster.

    Parameters
    ----------
    source
        A :class:`~nightlights.io.Raster`, a DataArray or a path.
    """
    if isinstance(source, (str, os.PathLike)):
        import rasterio

        try:
            with rasterio.open(source) as dataset:
                crs = None if dataset.crs is None else CRS.from_user_input(dataset.crs.to_wkt())
                return RasterHeader(
                    dataset.count,
                    dataset.height,
                    dataset.width,
                    dataset.transform,
                    crs,
                    (*dataset.bounds,),
                )
        except (rasterio.errors.RasterioError, ProjCRSError, OSError):
            return None
    from nightlights.io import Raster, as_raster

    try:
        raster = source if isinstance(source, Raster) else as_raster(source)
    except InputError:
        return None
    left, bottom, right, top = raster.bounds
    return RasterHeader(
        raster.count, *raster.shape, raster.transform, raster.crs, (left, bottom, right, top)
    )
