"""A float32 Cloud-Optimised GeoTIFF written window by window, never whole in memory.

:class:`CogWriter` is the streaming form of :func:`~nightlights.io.write_cog` for a raster too
large to hold: the windows go, as they are computed and from any thread, into a tiled GeoTIFF
in a scratch folder beside the output; closing the writer copies that file to the COG
(compression, overviews) and writes the QGIS style, chosen from an evenly decimated read of
the bands. Memory stays at the windows in flight and GDAL's block cache, whatever the raster's
size. The output appears complete or not at all: a failure, Ctrl-C or ``SIGTERM`` removes
the scratch file and leaves the output as it was (:class:`~nightlights.io.OutputSet`).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import threading
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import rasterio
import rasterio.windows
from affine import Affine
from numpy.typing import NDArray
from pyproj import CRS
from rasterio.enums import Resampling

from nightlights.errors import OutputError
from nightlights.io.outputs import OutputSet
from nightlights.io.raster import copy_to_cog, label_bands
from nightlights.io.styles import SAMPLE_LIMIT, raster_qml, sidecar_path

__all__ = ["CogWriter"]

#: GDAL's block cache while a writer is open: while the windows are written and while the COG
#: is made from the scratch file [MiB]. Without a limit GDAL keeps up to 5 % of the machine's
#: memory of blocks: 281 MiB more for 8000 x 8000 float32 windows written from two threads,
#: 30 MiB with this limit; the irradiance stage's peak on a 10,000 x 10,000 raster was
#: 1.10 GiB with no limit on the copy, 0.53 GiB with one. The copy took as long with 32 MiB
#: as with no limit (2.9-3.6 s on 2 cores).
CACHE_MB = 64


class CogWriter:
    """Write a float32 COG window by window (a context manager).

    Parameters
    ----------
    path
        Output ``.tif``. Its folder is checked here, before anything is computed, for
        write access and for free space for the scratch file (4 B per pixel and band), the
        COG and its temporary overviews (2.7 times the scratch file in all).
    shape
        (bands, rows, cols) of the raster.
    transform
        Affine transform of the top-left corner (pixel edges).
    crs
        Coordinate reference system of the grid.
    descriptions, units
        Band names and units.
    band_tags
        Metadata per band.
    tags
        Dataset-level metadata.
    nodata
        Nodata value; windows never written read as nodata [band units].
    compress, level, num_threads, overview_resampling, blocksize
        The COG's options, as :func:`~nightlights.io.write_cog`.
    qml
        Write the QGIS style beside the output (chosen from the bands).

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from affine import Affine
    >>> folder = tempfile.mkdtemp()
    >>> with CogWriter(
    ...     f"{folder}/ramp.tif",
    ...     shape=(1, 4, 6),
    ...     transform=Affine(10, 0, 0, 0, -10, 40),
    ...     crs="EPSG:3067",
    ...     descriptions=("photopic",),
    ...     units=("lx",),
    ... ) as writer:
    ...     writer.write(np.ones((1, 4, 3)), row=0, col=0)
    ...     writer.write(np.full((1, 4, 3), 2.0), row=0, col=3)
    >>> import rasterio
    >>> with rasterio.open(f"{folder}/ramp.tif") as dataset:
    ...     dataset.read(1)[0].tolist(), dataset.descriptions
    ([1.0, 1.0, 1.0, 2.0, 2.0, 2.0], ('photopic',))
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        shape: tuple[int, int, int],
        transform: Affine,
        crs: CRS | str,
        descriptions: Sequence[str],
        units: Sequence[str],
        band_tags: Sequence[Mapping[str, str]] = (),
        tags: Mapping[str, Any] | None = None,
        nodata: float = np.nan,
        compress: str = "DEFLATE",
        level: int | None = None,
        num_threads: int | str | None = None,
        overview_resampling: str | None = None,
        blocksize: int = 512,
        qml: bool = True,
    ) -> None:
        count, rows, cols = shape
        if count < 1 or rows < 1 or cols < 1:
            raise OutputError(f"{path}: raster shape {shape}; expected (bands, rows, cols) >= 1")
        if len(descriptions) != count or len(units) != count:
            raise OutputError(f"{path}: {count} bands but {len(descriptions)} names")
        if band_tags and len(band_tags) != count:
            raise OutputError(f"{path}: {count} bands but {len(band_tags)} sets of band tags")
        self.path = Path(path)
        self.shape = (count, rows, cols)
        self._profile = {
            "driver": "GTiff",
            "height": rows,
            "width": cols,
            "count": count,
            "dtype": "float32",
            "crs": CRS.from_user_input(crs).to_wkt(),
            "transform": transform,
            "nodata": nodata,
            "tiled": True,
            # a block per band: GDAL fills a new pixel-interleaved block's later bands with
            # zeros, not nodata, when the block cache is small
            "interleave": "band",
            "blockxsize": blocksize,
            "blockysize": blocksize,
            "BIGTIFF": "IF_SAFER",
        }
        self._descriptions = tuple(descriptions)
        self._units = tuple(units)
        self._band_tags = tuple(band_tags) or tuple({} for _ in range(count))
        self._tags = {key: str(value) for key, value in (tags or {}).items()}
        self._cog: dict[str, Any] = {
            "compress": compress,
            "level": level,
            "num_threads": num_threads,
            "overview_resampling": overview_resampling,
            "blocksize": blocksize,
        }
        # the scratch file (float32, uncompressed), the COG (a lit raster hardly compresses:
        # as large again and a third for the overviews) and the COG driver's temporary
        # overviews (a third)
        scratch_bytes = 4.0 * count * rows * cols
        self._outputs = OutputSet(
            self.path,
            sidecar_path(self.path) if qml else None,
            free_bytes=(1 + 4 / 3 + 1 / 3) * scratch_bytes,
        )
        self._qml = qml
        self._lock = threading.Lock()
        self._scratch: Path | None = None
        self._dataset: Any = None
        self._env: Any = None

    def __enter__(self) -> CogWriter:
        self._outputs.__enter__()
        try:
            # a limit on GDAL's (process-wide) block cache, for writes from any thread
            self._env = rasterio.Env(GDAL_CACHEMAX=CACHE_MB)
            self._env.__enter__()
            self._scratch = Path(
                tempfile.mkdtemp(prefix=f".{self.path.stem}-", dir=self.path.parent)
            )
            self._dataset = rasterio.open(self._scratch / "windows.tif", "w", **self._profile)
        except BaseException as exc:
            self._close(type(exc), exc, exc.__traceback__)
            raise
        return self

    def update_tags(self, **tags: Any) -> None:
        """Add dataset-level metadata (written when the writer closes)."""
        self._tags.update({key: str(value) for key, value in tags.items()})

    def write(self, values: NDArray[np.floating], *, row: int, col: int) -> None:
        """Write a window of every band (bands, rows, cols) at pixel (``row``, ``col``).

        Safe to call from several threads at once; the window is converted to float32.
        """
        _, rows, cols = values.shape
        window = rasterio.windows.Window(col, row, cols, rows)
        data = np.asarray(values, dtype=np.float32)
        with self._lock:
            # checked under the lock: a failing run closes the writer while tiles still
            # finish in other threads
            if self._dataset is None:
                raise OutputError(f"{self.path}: the writer is not open")
            self._dataset.write(data, window=window)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._close(exc_type, exc, traceback)

    def _close(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        try:
            with self._lock:
                dataset, self._dataset = self._dataset, None
            if dataset is not None:
                try:
                    if exc_type is None:
                        label_bands(
                            dataset, self._descriptions, self._units, self._band_tags, self._tags
                        )
                finally:
                    dataset.close()
            if exc_type is None and self._scratch is not None:
                self._finish(self._scratch / "windows.tif")
        except BaseException as error:
            exc_type, exc, traceback = type(error), error, error.__traceback__
            raise
        finally:
            if self._scratch is not None:
                shutil.rmtree(self._scratch, ignore_errors=True)
                self._scratch = None
            if self._env is not None:
                self._env.__exit__(None, None, None)
                self._env = None
            self._outputs.__exit__(exc_type, exc, traceback)

    def _finish(self, scratch: Path) -> None:
        """The COG and its style from the scratch file."""
        with rasterio.open(scratch) as source:
            copy_to_cog(source, self._outputs.temporary(self.path), **self._cog)
            if self._qml:
                style = sidecar_path(self.path)
                text = raster_qml(self._descriptions, self._units, _decimated(source), self._tags)
                self._outputs.temporary(style).write_text(text, encoding="utf-8")


def _decimated(dataset: Any) -> list[NDArray[np.float32]]:
    """Every band read at about :data:`SAMPLE_LIMIT` evenly spaced pixels (nearest)."""
    step = max(1.0, math.sqrt(dataset.height * dataset.width / SAMPLE_LIMIT))
    shape = (max(1, round(dataset.height / step)), max(1, round(dataset.width / step)))
    data = dataset.read(out_shape=(dataset.count, *shape), resampling=Resampling.nearest)
    return list(data)
