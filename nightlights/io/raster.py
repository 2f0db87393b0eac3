"""Rasters: the in-memory :class:`Raster` and its float32 Cloud-Optimised GeoTIFF form.

Every raster stage computes on a :class:`Raster` (bands, transform, CRS, band names and
units) and has a file form that reads and writes one; :func:`as_raster` accepts a
:class:`Raster`, an :class:`xarray.DataArray` with ``band``/``y``/``x`` dims and
``transform``/``crs`` attributes, or a path. Writes are atomic: the output appears complete or
not at all.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rasterio
import rasterio.shutil
from affine import Affine
from pyproj import CRS
from rasterio.io import MemoryFile

from nightlights._typing import FloatArray
from nightlights.errors import CRSError, InputError, OutputError
from nightlights.io.atomic import atomic_output

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
    blocksize: int = 512,
) -> Path:
    """Write bands to a float32 Cloud-Optimised GeoTIFF, atomically.

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
    blocksize
        Tile size [pixels].
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
            mem.set_band_description(index, band.description)
            mem.update_tags(index, **{**dict(band.tags), "unit": band.unit})
            mem.set_band_unit(index, band.unit)
        if tags:
            mem.update_tags(**{key: str(value) for key, value in tags.items()})
        with atomic_output(path) as tmp:
            rasterio.shutil.copy(
                mem,
                tmp,
                driver="COG",
                COMPRESS=compress,
                BLOCKSIZE=str(blocksize),
                OVERVIEWS="AUTO" if min(rows, cols) > blocksize else "NONE",
                PREDICTOR="YES",
            )
    return Path(path)


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
