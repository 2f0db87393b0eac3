"""File stage ``sky_render``: the night sky of a place and time as a picture or linear NetCDF.

The sky is composed by :func:`nightlights.nightsky.render.render_sky` (natural background,
twilight, Moon, stars and the artificial skyglow of a panorama written by
``nightlights skyglow``), then either tone-mapped to a PNG with a legend
(:mod:`nightlights.nightsky.tonemap`) or written in linear units to NetCDF.
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import xarray as xr

from nightlights._resources import check_memory
from nightlights._typing import PathLike
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import InputError
from nightlights.io import atomic_output
from nightlights.io.outputs import OutputSet, refuse_replacing_inputs
from nightlights.nightsky.render import SkyImage, SkyOptions, View, render_sky
from nightlights.nightsky.tonemap import ToneMapping, tone_map
from nightlights.sky.forward import panorama_coords
from nightlights.sky.observer import Observer

__all__ = [
    "SkyRenderResult",
    "legend_text",
    "png_bytes",
    "read_panorama",
    "sky_memory",
    "sky_render",
]

#: Bytes per image pixel that ``sky_render`` holds at its peak, by projection: the pixel
#: directions and solid angles, the natural sky, the Moon's and the stars' light, the XYZ and
#: luminance images, the tone-mapped picture and the PNG's rows. Measured (peak resident memory
#: over a 256-pixel-wide picture's): equirectangular 45-50 B (PNG, with or without a panorama;
#: 31 B to NetCDF) at 20000 x 512; fisheye 100 B at 4000 x 4000; perspective 94 B at
#: 4000 x 2500 [B].
BYTES_PER_PIXEL = {"equirectangular": 64.0, "fisheye": 128.0, "perspective": 128.0}
#: Output formats by file suffix.
FORMATS = {".png": "png", ".nc": "netcdf"}
#: Default image size (width, height) [pixel] by projection; a fisheye is width x width.
DEFAULT_SIZE = {"equirectangular": (2048, 512), "fisheye": (1024, 1024), "perspective": (1280, 800)}


@dataclass(frozen=True)
class SkyRenderResult:
    """What ``sky_render`` drew.

    Attributes
    ----------
    image
        The linear image and its summary (:class:`~nightlights.nightsky.render.SkyImage`).
    lonlat
        Observer's longitude and latitude used [deg].
    legend
        The legend line.
    path
        The file written, or None.
    """

    image: SkyImage
    lonlat: tuple[float, float]
    legend: str
    path: Path | None = None


def read_panorama(panorama: xr.Dataset | PathLike) -> xr.Dataset:
    """A skyglow panorama dataset, opened from a NetCDF path or passed through.

    Parameters
    ----------
    panorama
        Dataset or NetCDF path written by ``nightlights skyglow``.

    Returns
    -------
    xarray.Dataset
        Loaded dataset with ``luminance`` on (elevation, azimuth).
    """
    if isinstance(panorama, xr.Dataset):
        dataset = panorama
    else:
        path = Path(panorama)
        if not path.exists():
            raise InputError(f"{path}: panorama does not exist")
        try:
            with xr.open_dataset(path, engine="h5netcdf") as opened:
                dataset = opened.load()
        except (OSError, ValueError) as exc:
            raise InputError(
                f"{path}: not a NetCDF panorama of nightlights skyglow ({exc})"
            ) from exc
    if "luminance" not in dataset or set(dataset["luminance"].dims) != {"elevation", "azimuth"}:
        raise InputError(
            "panorama: expected a 'luminance' variable on (elevation, azimuth) as written by "
            "nightlights skyglow"
        )
    return dataset


def panorama_lonlat(panorama: xr.Dataset) -> tuple[float, float]:
    """Observer longitude and latitude [deg] from a panorama's ``observer_x/y`` and ``crs``.

    Parameters
    ----------
    panorama
        Skyglow panorama dataset.

    Returns
    -------
    tuple of float
        (lon, lat) [deg].
    """
    from pyproj import CRS, Transformer

    attrs = panorama.attrs
    missing = [name for name in ("observer_x", "observer_y", "crs") if name not in attrs]
    if missing:
        raise InputError(
            f"panorama has no {', '.join(missing)} attribute; give the place with lonlat"
        )
    transformer = Transformer.from_crs(CRS.from_user_input(attrs["crs"]), 4326, always_xy=True)
    lon, lat = transformer.transform(float(attrs["observer_x"]), float(attrs["observer_y"]))
    return float(lon), float(lat)


def legend_text(time: Any, lonlat: tuple[float, float], summary: dict[str, Any]) -> str:
    """The picture's legend: time, place, zenith brightness natural + artificial, Bortle class.

    Parameters
    ----------
    time
        The instant (shown in UTC to the minute).
    lonlat
        Observer's longitude and latitude [deg].
    summary
        :attr:`~nightlights.nightsky.render.SkyImage.summary`.

    Returns
    -------
    str
        Two lines of text.

    Examples
    --------
    >>> summary = {"zenith_natural_cd_m2": 171e-6, "zenith_artificial_cd_m2": 0.0,
    ...            "zenith_sky_brightness": 22.0, "bortle_class_zenith": 1, "sky_phase": "night",
    ...            "stars_drawn": 2000, "zenith_limiting_magnitude": 6.6}
    >>> print(legend_text("2026-01-15T20:00Z", (24.95, 60.17), summary))
    2026-01-15 20:00 UTC   24.950 E 60.170 N   night, Moon not drawn
    zenith 22.00 mag arcsec-2 (natural 22.00, artificial none), Bortle 1; 2000 stars to 6.6 mag
    """
    lon, lat = lonlat
    from datetime import datetime, timedelta

    from nightlights.nightsky.astro import julian_date

    # the instant as the astronomy module reads it (an ISO text without offset is UTC)
    instant = datetime(2000, 1, 1, 12) + timedelta(days=julian_date(time) - 2451545.0)
    when = (instant + timedelta(seconds=30)).strftime("%Y-%m-%d %H:%M")

    def mag(value: float) -> str:
        return f"{float(luminance_to_magnitude(value)):.2f}" if value > 0 else "none"

    moon = "Moon not drawn"
    if "moon_elevation_deg" in summary:
        fraction = 100.0 * summary["moon_illuminated_fraction"]
        where = "up" if summary["moon_elevation_deg"] >= 0 else "down"
        moon = f"Moon {where} ({summary['moon_elevation_deg']:.0f} deg), {fraction:.0f} % lit"
    first = (
        f"{when} UTC   {abs(lon):.3f} {'E' if lon >= 0 else 'W'} "
        f"{abs(lat):.3f} {'N' if lat >= 0 else 'S'}   {summary['sky_phase']}, {moon}"
    )
    total = summary["zenith_sky_brightness"]
    second = (
        f"zenith {total:.2f} mag arcsec-2 (natural {mag(summary['zenith_natural_cd_m2'])}, "
        f"artificial {mag(summary['zenith_artificial_cd_m2'])}), "
        f"Bortle {summary['bortle_class_zenith']}; {summary['stars_drawn']} stars to "
        f"{summary['zenith_limiting_magnitude']:.1f} mag"
    )
    return f"{first}\n{second}"


def sky_render(
    observer: Observer | None = None,
    output: PathLike | None = None,
    *,
    time: Any,
    lonlat: tuple[float, float] | None = None,
    panorama: xr.Dataset | PathLike | None = None,
    natural_only: bool = False,
    artificial_only: bool = False,
    projection: str = "equirectangular",
    width: int | None = None,
    height: int | None = None,
    view_azimuth: float = 180.0,
    view_elevation: float = 30.0,
    field_of_view: float = 90.0,
    tone_mapping: ToneMapping | None = None,
    stars: bool = True,
    moon: bool = True,
    limiting_magnitude: bool = True,
    spectrum: str = "LED_4000K",
    legend: bool = True,
) -> SkyRenderResult:
    """Render the night sky of a place and time; write a PNG (tone-mapped) or NetCDF (linear).

    Parameters
    ----------
    observer
        Who looks (:class:`~nightlights.sky.observer.Observer`, e.g.
        ``Observer.from_lonlat(24.95, 60.17)``); default the panorama's observer. With a
        panorama, it must stand where the panorama was computed (within
        :data:`SAME_PLACE`).
    output
        ``.png`` (tone-mapped picture with a legend) or ``.nc`` (``luminance`` [cd m-2] and
        ``xyz`` [cd m-2] on (elevation, azimuth) pixel centres [deg]; equirectangular only);
        None writes nothing.
    time
        Instant: aware datetime, ISO 8601 text or numpy datetime64 (UTC).
    lonlat
        Deprecated: the observer's longitude and latitude [deg]; give ``observer``.
    panorama
        Skyglow panorama (dataset or NetCDF path from ``nightlights skyglow``).
    natural_only, artificial_only
        Draw only the natural sky (background, twilight, Moon, stars) or only the skyglow.
    projection
        ``equirectangular``, ``fisheye`` or ``perspective``.
    width, height
        Image size [pixel] (defaults by projection in :data:`DEFAULT_SIZE`); a picture whose
        memory (:func:`sky_memory`) exceeds the limit (:mod:`nightlights._resources`) is
        refused before anything is drawn.
    view_azimuth, view_elevation, field_of_view
        Perspective view direction and horizontal field of view [deg].
    tone_mapping
        Tone mapping of the PNG (default the dark-adapted eye, ``ToneMapping()``).
    stars, moon
        Draw the stars; draw the Moon and its light.
    limiting_magnitude
        Leave out stars fainter than the eye's limit against the local sky.
    spectrum
        Luminaire spectrum that colours a luminance-only panorama.
    legend
        Add the legend strip below the PNG.

    Returns
    -------
    SkyRenderResult
        The image, the place, the legend and the path written.

    Examples
    --------
    >>> from nightlights.sky import Observer
    >>> result = sky_render(
    ...     Observer.from_lonlat(24.95, 60.17), time="2026-01-25T20:00:00Z", natural_only=True,
    ...     width=256, height=64,
    ... )
    >>> 20.0 < result.image.summary["zenith_sky_brightness"] < 23.0
    True
    """
    flat = observer is not None and not isinstance(observer, Observer)
    if flat:  # the former call: sky_render(output, time=, lonlat=)
        if output is not None:
            raise InputError(f"observer {observer!r}; expected an Observer")
        output, observer = cast("PathLike", observer), None
    if lonlat is not None:
        if observer is not None:
            raise InputError("give observer or lonlat (deprecated), not both")
        observer = _lonlat_observer(lonlat)
    if flat or lonlat is not None:
        warnings.warn(
            "sky_render(output, lonlat=(lon, lat), ...) is deprecated and goes in the next "
            "release: call sky_render(nightlights.Observer.from_lonlat(lon, lat), output, ...)",
            DeprecationWarning,
            stacklevel=2,
        )
    target = Path(output) if output is not None else None
    kind = None
    if target is not None:
        kind = FORMATS.get(target.suffix.lower())
        if kind is None:
            raise InputError(f"{target}: expected a .png or .nc output")
        if kind == "netcdf" and projection != "equirectangular":
            raise InputError(
                f"{target}: NetCDF output holds the (elevation, azimuth) grid; use "
                f"projection 'equirectangular', not {projection!r}"
            )
    if natural_only and artificial_only:
        raise InputError("natural_only and artificial_only exclude each other")
    refuse_replacing_inputs([target], {"panorama": panorama})
    dataset = read_panorama(panorama) if panorama is not None else None
    if artificial_only and dataset is None:
        raise InputError("artificial_only needs a skyglow panorama")
    if observer is None:
        if dataset is None:
            raise InputError("no place: give observer or a panorama with an observer")
        lon, lat = panorama_lonlat(dataset)
    else:
        lon, lat = observer.lonlat()
        if dataset is not None:
            _check_same_place((lon, lat), dataset)
    if not (-180.0 <= lon <= 360.0 and -90.0 <= lat <= 90.0):
        raise InputError(f"observer {lon}, {lat}: expected longitude -180..360, latitude -90..90")
    outputs = OutputSet(target)
    default_w, default_h = DEFAULT_SIZE.get(projection, (1024, 512))
    view = View(
        projection,
        width if width is not None else default_w,
        height if height is not None else default_h,
        azimuth=view_azimuth,
        elevation=view_elevation,
        field_of_view=field_of_view,
    )
    rows, cols = view.shape
    check_memory(
        sky_memory(view),
        f"the sky picture of {cols} x {rows} pixels",
        option="use a smaller width= or height=",
    )
    options = SkyOptions(
        natural=not artificial_only,
        artificial=not natural_only,
        stars=stars,
        moon=moon,
        limiting_magnitude=limiting_magnitude,
        spectrum=spectrum,
    )
    image = render_sky(time, lon, lat, view=view, panorama=dataset, options=options)
    text = legend_text(time, (lon, lat), image.summary)
    with outputs:
        if target is not None and kind == "png":
            rgb = tone_map(
                image.xyz, tone_mapping, pixel_size=image.pixels.pixel_size, dtype=np.uint8
            )
            write_png(rgb, outputs.temporary(target), text if legend else "", view.projection)
        elif target is not None:
            sky_dataset(image, time, (lon, lat)).to_netcdf(
                outputs.temporary(target), engine="h5netcdf"
            )
    return SkyRenderResult(image, (lon, lat), text, target)


def sky_memory(view: View) -> float:
    """Estimated peak memory of :func:`sky_render` for a view [B]: its pixels times
    :data:`BYTES_PER_PIXEL` (the star catalogue and the panorama are small beside them).

    Parameters
    ----------
    view
        The picture's projection and size.

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> round(sky_memory(View("equirectangular", 2048, 512)) / 2**20)
    64
    """
    rows, cols = view.shape
    return float(rows) * float(cols) * BYTES_PER_PIXEL[view.projection]


def sky_dataset(image: SkyImage, time: Any, lonlat: tuple[float, float]) -> xr.Dataset:
    """Linear NetCDF content of an equirectangular sky image.

    Parameters
    ----------
    image
        Equirectangular :class:`~nightlights.nightsky.render.SkyImage`.
    time
        The instant.
    lonlat
        Observer's longitude and latitude [deg].

    Returns
    -------
    xarray.Dataset
        ``luminance`` and ``xyz`` [cd m-2] on (elevation, azimuth) pixel centres [deg].
    """
    if image.pixels.view.projection != "equirectangular":
        raise InputError("only an equirectangular image maps onto (elevation, azimuth)")
    elevation = image.pixels.elevation[:, 0]
    azimuth = image.pixels.azimuth[0]
    summary = {
        key: (value if not isinstance(value, float) or math.isfinite(value) else str(value))
        for key, value in image.summary.items()
    }
    return xr.Dataset(
        {
            "luminance": (
                ("elevation", "azimuth"),
                image.luminance,
                {"units": "cd m-2", "long_name": "sky luminance, natural and artificial"},
            ),
            "xyz": (
                ("elevation", "azimuth", "band"),
                image.xyz,
                {"units": "cd m-2", "long_name": "CIE 1931 XYZ tristimulus luminance"},
            ),
        },
        coords={**panorama_coords(elevation, azimuth), "band": ("band", ["X", "Y", "Z"])},
        attrs={"time": str(time), "longitude": lonlat[0], "latitude": lonlat[1], **summary},
    )


#: Height of the legend strip below the picture [pixel].
LEGEND_STRIP = 40
#: Size of the legend's and the compass marks' text [pixel] (8 and 10 pt at 100 dpi).
LEGEND_FONT_SIZE, MARK_FONT_SIZE = 11, 14
#: zlib level of the PNG: 1 writes a 2048 x 1024 night sky several times faster than the
#: previous writer (matplotlib, zlib's default 6), for a file 1.25 times larger
#: (benchmarks/bench_sky_render.py).
PNG_COMPRESS_LEVEL = 1
#: Bands of rows deflated on their own, in parallel threads, and joined into one zlib stream
#: (a fixed number, so that the file's bytes do not depend on the machine) [1].
PNG_BANDS = 4


def write_png(rgb: np.ndarray, path: PathLike, legend: str, projection: str) -> Path:
    """Write an sRGB image pixel for pixel, with an optional legend strip below it.

    Parameters
    ----------
    rgb
        ``(rows, cols, 3)`` sRGB in [0, 1], or its 8-bit code values (``uint8``, as
        :func:`~nightlights.nightsky.tonemap.tone_map` gives with ``dtype=numpy.uint8``).
    path
        Output PNG, written atomically.
    legend
        Legend text ("" for none), white monospace on black.
    projection
        A fisheye gets N, E, S, W marks at its rim (east on the left: the sky seen from below).

    Returns
    -------
    pathlib.Path
        The written path.
    """
    from PIL import Image, ImageDraw

    if rgb.dtype != np.uint8:
        rgb = np.floor(255.0 * np.clip(rgb, 0.0, 1.0) + 0.5).astype(np.uint8)
    rows, cols = rgb.shape[:2]
    if projection == "fisheye":
        picture = Image.fromarray(rgb)
        draw = ImageDraw.Draw(picture)
        marks = {"N": (0.5, 0.015), "S": (0.5, 0.985), "E": (0.015, 0.5), "W": (0.985, 0.5)}
        for label, (x, y) in marks.items():
            draw.text(
                (x * cols, y * rows),
                label,
                fill=(204, 204, 204),
                font=_font(MARK_FONT_SIZE),
                anchor="mm",
            )
        rgb = np.asarray(picture)
    parts = [rgb]
    if legend:
        strip = Image.new("RGB", (cols, LEGEND_STRIP))
        ImageDraw.Draw(strip).multiline_text(
            (round(0.005 * cols), LEGEND_STRIP / 2),
            legend,
            fill=(255, 255, 255),
            font=_font(LEGEND_FONT_SIZE),
            anchor="lm",
            spacing=2,
        )
        parts.append(np.asarray(strip))
    with atomic_output(path) as tmp:
        Path(tmp).write_bytes(png_bytes(np.concatenate(parts) if len(parts) > 1 else rgb))
    return Path(path)


def png_bytes(rgb: np.ndarray, *, level: int = PNG_COMPRESS_LEVEL) -> bytes:
    """An 8-bit RGB image as a PNG file (ISO/IEC 15948): rows unfiltered, deflated in
    :data:`PNG_BANDS` bands in parallel threads and joined into one zlib stream.

    Each band but the last ends with a sync flush (byte-aligned, no end-of-stream), so the
    concatenated raw deflate data, behind the zlib header and followed by the Adler-32 of all
    rows, is one valid stream (RFC 1950, 1951); only matches across a band's start are lost.

    Parameters
    ----------
    rgb
        ``(rows, cols, 3)`` uint8 sRGB code values.
    level
        zlib compression level, 0-9.

    Returns
    -------
    bytes
        The PNG file.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> image = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    >>> bool(np.array_equal(np.asarray(Image.open(io.BytesIO(png_bytes(image)))), image))
    True
    """
    import struct
    import zlib
    from concurrent.futures import ThreadPoolExecutor

    rows, cols = rgb.shape[:2]
    raw = np.zeros((rows, 1 + 3 * cols), dtype=np.uint8)  # filter type 0 (None) per row
    raw[:, 1:] = rgb.reshape(rows, 3 * cols)
    bands = [band.tobytes() for band in np.array_split(raw, min(PNG_BANDS, rows))]

    def deflate(index: int) -> bytes:
        compressor = zlib.compressobj(level, zlib.DEFLATED, -15)  # raw deflate
        last = index == len(bands) - 1
        return compressor.compress(bands[index]) + compressor.flush(
            zlib.Z_FINISH if last else zlib.Z_SYNC_FLUSH
        )

    with ThreadPoolExecutor(min(len(bands), os.cpu_count() or 1)) as pool:
        deflated = b"".join(pool.map(deflate, range(len(bands))))
    adler = 1
    for band in bands:
        adler = zlib.adler32(band, adler)
    # zlib header: deflate, 32 KiB window, check bits (CMF 0x78, FLG a multiple of 31 with it)
    stream = b"\x78\x01" + deflated + struct.pack(">I", adler)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    header = struct.pack(">IIBBBBB", cols, rows, 8, 2, 0, 0, 0)  # 8-bit RGB, not interlaced
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", stream) + chunk(b"IEND", b"")
    )


@functools.cache
def _font(size: int) -> Any:
    """DejaVu Sans Mono (shipped with matplotlib) at ``size`` pixels."""
    import matplotlib
    from PIL import ImageFont

    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSansMono.ttf"
    return ImageFont.truetype(str(path), size)


#: Farthest an observer may stand from the place a given panorama was computed for [m]: the
#: skyglow of a panorama belongs to its place (a kilometre moves a city's zenith by well under
#: 0.1 mag, while a panorama of one place drawn over another place's stars is a wrong picture).
SAME_PLACE = 1000.0


def _check_same_place(lonlat: tuple[float, float], dataset: xr.Dataset) -> None:
    """Refuse an observer that stands elsewhere than the panorama's observer."""
    from pyproj import Geod

    try:
        lon, lat = panorama_lonlat(dataset)
    except InputError:
        return  # a panorama without its place: the observer places it
    _, _, distance = Geod(ellps="WGS84").inv(lonlat[0], lonlat[1], lon, lat)
    if distance > SAME_PLACE:
        raise InputError(
            f"observer ({lonlat[0]:.5f}, {lonlat[1]:.5f}) stands {distance / 1000:.4g} km from "
            f"the panorama's observer ({lon:.5f}, {lat:.5f}); expected the same place (within "
            f"{SAME_PLACE / 1000:g} km): omit the observer to use the panorama's"
        )


def _lonlat_observer(lonlat: Any) -> Observer:
    try:
        lon, lat = (float(v) for v in lonlat)
    except (TypeError, ValueError):
        raise InputError(f"lonlat {lonlat!r}; expected (longitude, latitude) [deg]") from None
    if not (-180.0 <= lon <= 360.0 and -90.0 <= lat <= 90.0):
        raise InputError(f"lonlat {lon}, {lat}: expected longitude -180..360, latitude -90..90")
    return Observer.from_lonlat(lon, lat)
