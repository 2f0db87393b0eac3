"""Rasters: the in-memory :class:`Raster` and its float32 Cloud-Optimised GeoTIFF form.

Every GeoTIFF is written with its QGIS style beside it (a ``.qml`` of the same name, chosen
from the bands by :func:`nightlights.io.styles.raster_qml`).

Every raster stage computes on a :class:`Raster` (bands, transform, CRS, band names and
units) and has a file form that reads and writes one; :func:`as_raster` accepts a
:class:`Raster`, an :class:`xarray.DataArray` with ``band``/``y``/``x`` dims and
``transform``/``crs`` attributes, or a path. Writes are atomic: the output appears complete or
not at all.

:class:`LitCells` is the sparse form of a raster whose few cells carry a value (an emission
raster of a city in a large, dark region): :func:`read_lit_cells` reads a file window by window
and keeps only the cells with a non-zero value, so that memory grows with the lit cells, not
with the raster.

Length: the dense raster, its COG writer and its sparse form share the grid conventions
(transform, CRS, band names, nodata as NaN) that each half would otherwise restate.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rasterio
import rasterio.shutil
import rasterio.windows
from affine import Affine
from numpy.typing import NDArray
from pyproj import CRS
from rasterio.io import MemoryFile

from nightlights._resources import check_memory, memory_limit
from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError, OutputError
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import raster_qml, sidecar_path

if TYPE_CHECKING:
    import xarray as xr


@dataclass(frozen=True)
class RasterBand:
    """One band of a raster with its metadata.

    Attributes
    ----------
    data
        2-D array (rows, cols).
    description
        Band description shown by QGIS and ``gdalinfo``.
    unit
        Physical unit, e.g. ``lx`` or ``lm m-2``.
    tags
        Extra band metadata.
    """

    data: np.ndarray
    description: str
    unit: str
    tags: Mapping[str, str] = field(default_factory=dict)


def write_cog(
    path: str | os.PathLike[str],
    bands: Sequence[RasterBand],
    *,
    transform: Affine,
    crs: CRS | str,
    nodata: float = np.nan,
    tags: Mapping[str, Any] | None = None,
    compress: str = "DEFLATE",
    level: int | None = None,
    num_threads: int | str | None = None,
    overview_resampling: str | None = None,
    blocksize: int = 512,
    qml: str | bool = True,
) -> Path:
    """Write bands to a float32 Cloud-Optimised GeoTIFF and its QGIS style, atomically.

    Parameters
    ----------
    path
        Output ``.tif``.
    bands
        Bands of equal shape.
    transform
        Affine transform of the top-left corner (pixel edges).
    crs
        Coordinate reference system of the grid.
    nodata
        Nodata value [same unit as the bands].
    tags
        Dataset-level metadata (model parameters, provenance).
    compress
        GDAL compression (``DEFLATE``, ``ZSTD``, ``LZW``).
    level
        Compression level of ``DEFLATE`` (1-12) or ``ZSTD`` (1-22); ``None``: GDAL's default
        (6 and 9). Lower is faster and compresses less.
    num_threads
        Threads compressing the blocks (a number or ``"ALL_CPUS"``); ``None``: one. The file
        is the same for any number.
    overview_resampling
        How the overviews are computed (``AVERAGE``, ``NEAREST``, ``CUBIC``, ...); ``None``:
        the GDAL COG driver's default (``CUBIC``).
    blocksize
        Tile size [pixels].
    qml
        The style written beside the GeoTIFF as ``<name>.qml`` (:func:`sidecar_path`), which
        QGIS loads as the raster's default style: True chooses it from the bands
        (:func:`~nightlights.io.styles.raster_qml`), a string is the QML document itself,
        False writes none. The two files appear together or not at all.
    """
    if not bands:
        raise OutputError(f"{path}: no bands to write")
    shape = bands[0].data.shape
    if any(band.data.shape != shape for band in bands) or len(shape) != 2:
        raise OutputError(
            f"{path}: bands must be 2-D arrays of one shape, got "
            f"{[band.data.shape for band in bands]}"
        )
    rows, cols = shape
    crs_text = CRS.from_user_input(crs).to_wkt()
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": len(bands),
        "dtype": "float32",
        "crs": crs_text,
        "transform": transform,
        "nodata": nodata,
    }
    with MemoryFile() as memfile, memfile.open(**profile) as mem:
        for index, band in enumerate(bands, start=1):
            mem.write(np.asarray(band.data, dtype=np.float32), index)
        label_bands(
            mem,
            [band.description for band in bands],
            [band.unit for band in bands],
            [band.tags for band in bands],
            tags,
        )
        if qml is True:
            qml = raster_qml(
                [band.description for band in bands],
                [band.unit for band in bands],
                [band.data for band in bands],
                {key: str(value) for key, value in (tags or {}).items()},
            )
        style = sidecar_path(path) if qml else None
        with OutputSet(path, style) as outputs:
            copy_to_cog(
                mem,
                outputs.temporary(path),
                compress=compress,
                level=level,
                num_threads=num_threads,
                overview_resampling=overview_resampling,
                blocksize=blocksize,
            )
            if style is not None and isinstance(qml, str):
                outputs.temporary(style).write_text(qml, encoding="utf-8")
    return Path(path)


def label_bands(
    dataset: Any,
    descriptions: Sequence[str],
    units: Sequence[str],
    band_tags: Sequence[Mapping[str, str]],
    tags: Mapping[str, Any] | None,
) -> None:
    """Band names, units (also as each band's ``unit`` tag) and metadata on an open dataset."""
    for index, (description, unit, extra) in enumerate(
        zip(descriptions, units, band_tags, strict=True), start=1
    ):
        dataset.set_band_description(index, description)
        dataset.update_tags(index, **{**dict(extra), "unit": unit})
        dataset.set_band_unit(index, unit)
    if tags:
        dataset.update_tags(**{key: str(value) for key, value in tags.items()})


def copy_to_cog(
    source: Any,
    destination: Path,
    *,
    compress: str = "DEFLATE",
    level: int | None = None,
    num_threads: int | str | None = None,
    overview_resampling: str | None = None,
    blocksize: int = 512,
) -> None:
    """Copy an open float32 GDAL dataset to a Cloud-Optimised GeoTIFF (see :func:`write_cog`).

    Overviews are built when the raster is larger than one block on both sides.
    """
    extra = {} if level is None else {"LEVEL": str(level)}
    if num_threads is not None:
        extra["NUM_THREADS"] = str(num_threads)
    if overview_resampling is not None:
        extra["RESAMPLING"] = overview_resampling
    rasterio.shutil.copy(
        source,
        destination,
        driver="COG",
        COMPRESS=compress,
        BLOCKSIZE=str(blocksize),
        OVERVIEWS="AUTO" if min(source.height, source.width) > blocksize else "NONE",
        PREDICTOR="YES",
        **extra,
    )


@dataclass(frozen=True, eq=False)
class Raster:
    """A geo-referenced multi-band raster in memory.

    Attributes
    ----------
    data
        Array (bands, rows, cols), float64, nodata as NaN [band unit].
    transform
        Affine transform of the top-left pixel corner [m or deg per pixel].
    crs
        Coordinate reference system, or ``None`` when the source had none.
    descriptions
        One name per band (e.g. ``photopic``, ``reflected``).
    units
        One unit per band (e.g. ``lx``, ``lm m-2``).
    tags
        Dataset-level metadata (model parameters, provenance).
    band_tags
        Per-band metadata, one mapping per band.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> r = Raster(np.ones((1, 2, 3)), Affine(10, 0, 0, 0, -10, 20), "EPSG:32635", ("a",), ("lx",))
    >>> r.shape, r.resolution, r.bounds
    ((2, 3), 10.0, (0.0, 0.0, 30.0, 20.0))
    """

    data: FloatArray
    transform: Affine
    crs: CRS | None
    descriptions: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    tags: Mapping[str, str] = field(default_factory=dict)
    band_tags: tuple[Mapping[str, str], ...] = ()

    def __post_init__(self) -> None:
        data = np.asarray(self.data, dtype=np.float64)
        if data.ndim == 2:
            data = data[None]
        if data.ndim != 3:
            raise InputError(f"raster data of shape {data.shape}; expected (bands, rows, cols)")
        object.__setattr__(self, "data", data)
        if self.crs is not None and not isinstance(self.crs, CRS):
            object.__setattr__(self, "crs", CRS.from_user_input(self.crs))
        count = data.shape[0]
        descriptions = tuple(d or "" for d in self.descriptions) or ("",) * count
        units = tuple(u or "" for u in self.units) or ("",) * count
        band_tags = tuple(dict(t) for t in self.band_tags) or tuple({} for _ in range(count))
        for name, values in (
            ("descriptions", descriptions),
            ("units", units),
            ("band_tags", band_tags),
        ):
            if len(values) != count:
                raise InputError(f"raster has {count} bands but {len(values)} {name}")
        object.__setattr__(self, "descriptions", descriptions)
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "band_tags", band_tags)
        object.__setattr__(self, "tags", {str(k): str(v) for k, v in dict(self.tags).items()})

    @property
    def count(self) -> int:
        """Number of bands."""
        return int(self.data.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return int(self.data.shape[1]), int(self.data.shape[2])

    @property
    def resolution(self) -> float:
        """Pixel size of a north-up grid with square pixels [CRS unit].

        Raises
        ------
        InputError
            The grid is rotated or its pixels are not square.
        """
        t = self.transform
        if t.b != 0 or t.d != 0 or not np.isclose(abs(t.a), abs(t.e), rtol=1e-9):
            raise InputError(
                f"raster transform {tuple(t)[:6]}: expected a north-up grid with square pixels"
            )
        return float(abs(t.a))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the pixel edges [CRS unit]."""
        rows, cols = self.shape
        xs = (self.transform.c, self.transform.c + self.transform.a * cols)
        ys = (self.transform.f, self.transform.f + self.transform.e * rows)
        return (float(min(xs)), float(min(ys)), float(max(xs)), float(max(ys)))

    def band_index(self, name: str) -> int:
        """0-based index of the band described ``name``.

        Raises
        ------
        InputError
            No band has that description.
        """
        if name not in self.descriptions:
            raise InputError(f"raster has no band {name!r}; bands are {list(self.descriptions)}")
        return self.descriptions.index(name)

    def band(self, name: str) -> FloatArray:
        """The 2-D array of the band described ``name``."""
        return self.data[self.band_index(name)]

    def projected_crs(self, *, source: str = "raster") -> CRS:
        """The CRS, checked to be projected (metres).

        Raises
        ------
        CRSError
            The raster has no CRS or a geographic one.
        """
        if self.crs is None or not self.crs.is_projected:
            raise CRSError(
                f"{source}: CRS {self.crs.name if self.crs else None}; expected a projected "
                "CRS in metres"
            )
        return self.crs

    @classmethod
    def read(cls, path: str | os.PathLike[str]) -> Raster:
        """Read every band of a raster file as float64 with nodata as NaN.

        Raises
        ------
        InputError
            The file does not exist or GDAL cannot read it.
        """
        source = Path(path)
        if not source.exists():
            raise InputError(f"{source}: no such file")
        try:
            with rasterio.open(source) as dataset:
                data = dataset.read(masked=True).astype(np.float64).filled(np.nan)
                return cls(
                    data,
                    dataset.transform,
                    CRS.from_user_input(dataset.crs.to_wkt()) if dataset.crs else None,
                    tuple(d or "" for d in dataset.descriptions),
                    tuple(u or "" for u in dataset.units),
                    dataset.tags(),
                    tuple(dataset.tags(i) for i in range(1, dataset.count + 1)),
                )
        except rasterio.errors.RasterioIOError as exc:
            raise InputError(f"{source}: cannot read raster: {exc}") from exc

    def write(self, path: str | os.PathLike[str], **options: Any) -> Path:
        """Write as a float32 Cloud-Optimised GeoTIFF, atomically (see :func:`write_cog`)."""
        if self.crs is None:
            raise OutputError(f"{path}: the raster has no CRS")
        bands = [
            RasterBand(self.data[i], self.descriptions[i], self.units[i], self.band_tags[i])
            for i in range(self.count)
        ]
        return write_cog(
            path, bands, transform=self.transform, crs=self.crs, tags=self.tags, **options
        )

    def lit_cells(self) -> LitCells:
        """The sparse form: the cells with a non-zero value in some band (:class:`LitCells`)."""
        return _raster_lit_cells(self)

    def to_xarray(self) -> xr.DataArray:
        """A DataArray (band, y, x) with pixel-centre coordinates; ``transform``, ``crs`` (WKT),
        ``descriptions``, ``units`` and the tags in its attributes."""
        import xarray as xr

        rows, cols = self.shape
        t = self.transform
        x = t.c + t.a * (np.arange(cols) + 0.5)
        y = t.f + t.e * (np.arange(rows) + 0.5)
        return xr.DataArray(
            self.data,
            dims=("band", "y", "x"),
            coords={"band": list(self.descriptions), "y": y, "x": x},
            attrs={
                **self.tags,
                "transform": tuple(t)[:6],
                "crs": self.crs.to_wkt() if self.crs is not None else "",
                "units": list(self.units),
            },
        )

    @classmethod
    def from_xarray(cls, array: xr.DataArray) -> Raster:
        """The inverse of :meth:`to_xarray`: a DataArray with ``band``/``y``/``x`` (or ``y``/``x``)
        dims and ``transform`` and ``crs`` attributes.

        Raises
        ------
        InputError
            Missing dims or attributes.
        """
        da = array if "band" in array.dims else array.expand_dims("band")
        if tuple(da.dims) != ("band", "y", "x"):
            da = da.transpose("band", "y", "x") if set(da.dims) == {"band", "y", "x"} else da
        if tuple(da.dims) != ("band", "y", "x"):
            raise InputError(f"DataArray dims {tuple(array.dims)}; expected (band, y, x)")
        attrs = dict(da.attrs)
        if "transform" not in attrs:
            raise InputError("DataArray has no 'transform' attribute (Affine coefficients a..f)")
        transform = Affine(*tuple(attrs.pop("transform"))[:6])
        crs = attrs.pop("crs", None) or None
        units = attrs.pop("units", None)
        count = da.sizes["band"]
        names = [str(b) for b in da["band"].values] if "band" in da.coords else [""] * count
        units_t = tuple(units) if isinstance(units, (list, tuple)) else (str(units or ""),) * count
        return cls(da.values, transform, crs, tuple(names), units_t, attrs)


def as_raster(source: Raster | xr.DataArray | str | os.PathLike[str]) -> Raster:
    """A :class:`Raster` from a raster, a DataArray (see :meth:`Raster.from_xarray`) or a path."""
    if isinstance(source, Raster):
        return source
    if isinstance(source, (str, os.PathLike)):
        return Raster.read(source)
    import xarray as xr

    if isinstance(source, xr.DataArray):
        return Raster.from_xarray(source)
    raise InputError(
        f"raster input of type {type(source).__name__}; expected a Raster, an xarray.DataArray "
        "or a path"
    )


def source_label(source: Raster | xr.DataArray | str | os.PathLike[str], name: str) -> str:
    """How messages name a raster input: its path, or ``in-memory <name>``.

    Parameters
    ----------
    source
        The raster input.
    name
        What it is (``DEM``, ``albedo raster``).
    """
    if isinstance(source, (str, os.PathLike)):
        return str(source)
    return f"in-memory {name}"


#: Cells read at once by :func:`read_lit_cells` (a window of whole block rows) [1].
WINDOW_CELLS = 4_000_000
#: GDAL block cache while :func:`read_lit_cells` reads [MB].
READ_CACHE_MB = 64


@dataclass(frozen=True, eq=False)
class LitCells:
    """The cells of a raster with a non-zero value in some band: the sparse form of a raster.

    Cells that are zero or nodata (NaN) in every band are left out; a lit cell keeps its
    values in every band (NaN in a band where it has none). The counts of the cells left out
    and of the non-finite values seen are kept for the checks of the stages.

    Attributes
    ----------
    rows, cols
        Row and column of each lit cell, row-major order, shape ``(n_cells,)``.
    values
        Shape ``(bands, n_cells)``, float64 [band unit].
    transform
        Affine transform of the raster [m or deg per pixel].
    crs
        Coordinate reference system, or ``None``.
    shape
        (rows, cols) of the raster.
    descriptions, units
        One per band.
    nodata_cells
        Cells that are nodata (NaN) in every band [1].
    infinite_values
        Values that are +-inf, all bands together [1].

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> data = np.zeros((1, 3, 4)); data[0, 1, 2] = 5.0; data[0, 2, 0] = np.nan
    >>> cells = Raster(data, Affine(10, 0, 0, 0, -10, 30), "EPSG:32635").lit_cells()
    >>> cells.rows.tolist(), cells.cols.tolist(), cells.values.tolist(), cells.nodata_cells
    ([1], [2], [[5.0]], 1)
    """

    rows: NDArray[np.int64]
    cols: NDArray[np.int64]
    values: FloatArray
    transform: Affine
    crs: CRS | None
    shape: tuple[int, int]
    descriptions: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    nodata_cells: int = 0
    infinite_values: int = 0

    @property
    def count(self) -> int:
        """Number of bands."""
        return int(self.values.shape[0])

    @property
    def n_cells(self) -> int:
        """Number of lit cells."""
        return int(self.rows.size)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the raster's pixel edges [CRS unit]."""
        return _bounds(self.transform, 0, 0, *self.shape)

    def lit_bounds(self) -> tuple[float, float, float, float] | None:
        """(xmin, ymin, xmax, ymax) of the lit cells' pixel edges, None without lit cells
        [CRS unit]."""
        if self.n_cells == 0:
            return None
        row0, col0 = int(self.rows.min()), int(self.cols.min())
        row1, col1 = int(self.rows.max()) + 1, int(self.cols.max()) + 1
        return _bounds(self.transform, row0, col0, row1 - row0, col1 - col0)

    def centres(self) -> tuple[FloatArray, FloatArray]:
        """(x, y) of each lit cell's centre [CRS unit]."""
        t = self.transform
        x = t.c + t.a * (self.cols + 0.5) + t.b * (self.rows + 0.5)
        y = t.f + t.d * (self.cols + 0.5) + t.e * (self.rows + 0.5)
        return x, y

    def dense(self) -> tuple[FloatArray, Affine]:
        """The lit cells' bounding window as a dense ``(bands, rows, cols)`` array (zero where
        unlit) and its transform.

        Returns
        -------
        tuple
            The array [band unit] and the window's affine transform.
        """
        if self.n_cells == 0:
            return np.zeros((self.count, 0, 0)), self.transform
        row0, col0 = int(self.rows.min()), int(self.cols.min())
        shape = (int(self.rows.max()) + 1 - row0, int(self.cols.max()) + 1 - col0)
        out = np.zeros((self.count, *shape))
        out[:, self.rows - row0, self.cols - col0] = self.values
        return out, self.transform @ Affine.translation(col0, row0)


def _bounds(
    transform: Affine, row: int, col: int, rows: int, cols: int
) -> tuple[float, float, float, float]:
    xs = [
        transform.c + transform.a * c + transform.b * r
        for c in (col, col + cols)
        for r in (row, row + rows)
    ]
    ys = [
        transform.f + transform.d * c + transform.e * r
        for c in (col, col + cols)
        for r in (row, row + rows)
    ]
    return (float(min(xs)), float(min(ys)), float(max(xs)), float(max(ys)))


def lit_cell_bytes(bands: int) -> float:
    """Bytes per lit cell while they are collected (:func:`read_lit_cells`): the row and
    column indices and the float64 values of the windows, their concatenation, the sort order
    and the sorted arrays [B].

    Parameters
    ----------
    bands
        Bands of the raster [1].

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> lit_cell_bytes(1)
    80.0
    """
    return 3.0 * (16.0 + 8.0 * bands) + 8.0


class _LitCollector:
    """Collects the lit cells of consecutive row windows of a raster, refusing (before it
    keeps a window's cells) a total whose memory (:func:`lit_cell_bytes`) passes the limit."""

    def __init__(self, count: int, label: str = "the raster") -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.values: list[np.ndarray] = []
        self.count = count
        self.label = label
        self.nodata_cells = 0
        self.infinite_values = 0
        self.n_cells = 0
        self.limit = memory_limit()

    def add(self, block: np.ndarray, row0: int, nodata: float | None, col0: int = 0) -> None:
        """Add a ``(bands, rows, cols)`` window whose first cell is (``row0``, ``col0``)."""
        if not block.any():  # the usual window of a sparse raster: all zero, one fast pass
            return
        missing = np.isnan(block) if np.issubdtype(block.dtype, np.floating) else None
        if nodata is not None and not np.isnan(nodata):
            missing = block == nodata if missing is None else missing | (block == nodata)
        if np.issubdtype(block.dtype, np.floating):
            self.infinite_values += int(np.count_nonzero(np.isinf(block)))
        lit = block != 0
        if missing is not None:
            lit &= ~missing
            self.nodata_cells += int(np.count_nonzero(missing.all(axis=0)))
        lit_any = lit.any(axis=0)
        found = int(np.count_nonzero(lit_any))
        need = (self.n_cells + found) * lit_cell_bytes(self.count)
        if need > self.limit:
            check_memory(
                need,
                f"the lit cells of {self.label} (more than {self.n_cells + found} of them)",
                option="coarsen or crop the raster (or set its unlit cells to 0)",
            )
        self.n_cells += found
        rows, cols = np.nonzero(lit_any)
        values = block[:, rows, cols].astype(np.float64)
        if missing is not None:
            values[missing[:, rows, cols]] = np.nan
        self.rows.append(rows.astype(np.int64) + row0)
        self.cols.append(cols.astype(np.int64) + col0)
        self.values.append(values)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not self.rows:
            return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((self.count, 0)))
        rows, cols = np.concatenate(self.rows), np.concatenate(self.cols)
        order = np.lexsort((cols, rows))  # row-major, whatever the windows
        return rows[order], cols[order], np.concatenate(self.values, axis=1)[:, order]


#: A part of a raster grid: (first row, first column, rows, columns) [cells].
GridWindow = tuple[int, int, int, int]


def _raster_lit_cells(raster: Raster, window: GridWindow | None = None) -> LitCells:
    collector = _LitCollector(raster.count)
    row_start, col_start, rows, cols = window or (0, 0, *raster.shape)
    step = max(1, WINDOW_CELLS // max(1, cols))
    for row0 in range(row_start, row_start + rows, step):
        row1 = min(row0 + step, row_start + rows)
        block = raster.data[:, row0:row1, col_start : col_start + cols]
        collector.add(block, row0, None, col_start)
    r, c, v = collector.arrays()
    return LitCells(
        r,
        c,
        v,
        raster.transform,
        raster.crs,
        raster.shape,
        raster.descriptions,
        raster.units,
        collector.nodata_cells,
        collector.infinite_values,
    )


def _window_shape(dataset: Any, width: int | None = None) -> tuple[int, int]:
    """(rows, cols) of the windows :func:`read_lit_cells` reads: whole blocks, about
    :data:`WINDOW_CELLS` cells (at least one block), across ``width`` columns (default: the
    raster's)."""
    width = dataset.width if width is None else width
    block_rows, block_cols = dataset.block_shapes[0] if dataset.block_shapes else (1, 1)
    block_rows, block_cols = max(1, block_rows), max(1, block_cols)
    blocks_across = -(-width // block_cols)
    blocks_per_window = max(1, WINDOW_CELLS // (block_rows * block_cols))
    if blocks_per_window >= blocks_across:  # whole rows of blocks
        rows = max(1, blocks_per_window // blocks_across) * block_rows
        return rows, width
    return block_rows, blocks_per_window * block_cols


def read_lit_cells(path: str | os.PathLike[str], window: GridWindow | None = None) -> LitCells:
    """Read a raster file window by window, keeping only its lit cells.

    Memory holds one window of whole block rows (about :data:`WINDOW_CELLS` cells per band in
    the file's data type) and the lit cells, never the whole raster; the lit cells found so far
    are checked against the memory limit (:func:`lit_cell_bytes` each) before a window's are
    kept.

    Parameters
    ----------
    path
        Any raster GDAL reads.
    window
        Only this part of the grid is read, ``(row, col, rows, cols)`` [cells]; the cells keep
        their place on the whole grid (rows, columns, transform and shape are the raster's).
        None: the whole raster.

    Returns
    -------
    LitCells
        The cells with a non-zero, non-nodata value in some band.

    Raises
    ------
    InputError
        The file does not exist or GDAL cannot read it.
    ResourceError
        A window, or the lit cells found, would pass the memory limit.
    """
    source = Path(path)
    if not source.exists():
        raise InputError(f"{source}: no such file")
    try:
        # A small block cache (GDAL's default is 5 % of the memory) and threaded decoding.
        with (
            rasterio.Env(GDAL_CACHEMAX=READ_CACHE_MB, GDAL_NUM_THREADS="ALL_CPUS"),
            rasterio.open(source) as dataset,
        ):
            collector = _LitCollector(dataset.count, str(source))
            row_start, col_start, n_rows, n_cols = window or (0, 0, dataset.height, dataset.width)
            height, width = _window_shape(dataset, n_cols)
            itemsize = np.dtype(dataset.dtypes[0]).itemsize
            check_memory(
                dataset.count * height * width * (itemsize + 3.0) + READ_CACHE_MB * 2**20,
                f"reading {source} in windows of {height} x {width} cells",
            )
            nodata = dataset.nodata
            row_end, col_end = row_start + n_rows, col_start + n_cols
            for row0 in range(row_start, row_end, height):
                for col0 in range(col_start, col_end, width):
                    part = rasterio.windows.Window(
                        col0, row0, min(width, col_end - col0), min(height, row_end - row0)
                    )
                    collector.add(dataset.read(window=part), row0, nodata, col0)
            r, c, v = collector.arrays()
            return LitCells(
                r,
                c,
                v,
                dataset.transform,
                CRS.from_user_input(dataset.crs.to_wkt()) if dataset.crs else None,
                (dataset.height, dataset.width),
                tuple(d or "" for d in dataset.descriptions),
                tuple(u or "" for u in dataset.units),
                collector.nodata_cells,
                collector.infinite_values,
            )
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{source}: cannot read raster: {exc}") from exc


def as_lit_cells(
    source: Raster | xr.DataArray | str | os.PathLike[str] | LitCells,
    window: GridWindow | None = None,
) -> LitCells:
    """The :class:`LitCells` of a raster input; a path is read window by window
    (:func:`read_lit_cells`), never whole. With ``window`` (``(row, col, rows, cols)``
    [cells]) only the cells in that part of the grid are kept (a file reads only that part),
    at their place on the whole grid."""
    if isinstance(source, LitCells):
        if window is None:
            return source
        row, col, rows, cols = window
        inside = (
            (source.rows >= row)
            & (source.rows < row + rows)
            & (source.cols >= col)
            & (source.cols < col + cols)
        )
        return dataclasses.replace(
            source,
            rows=source.rows[inside],
            cols=source.cols[inside],
            values=source.values[:, inside],
        )
    if isinstance(source, (str, os.PathLike)):
        return read_lit_cells(source, window)
    return _raster_lit_cells(as_raster(source), window)
