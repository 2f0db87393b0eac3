"""The region-wide zenith darkness map: the artificial zenith sky brightness at every cell.

The forward panorama's zenith luminance (:func:`~nightlights.sky.forward.skyglow_panorama`, the
mean of its top row) is linear in the emission and, averaged over azimuth, no longer depends on
the direction of a source, only on its distance. With the observer at a cell centre ``o`` and
every lit cell ``s`` split into the k x k sub-points ``p`` of the polar map
(:func:`~nightlights.sky.polar.polar_cells`), the zenith luminance is a 2-D convolution of the
flux per cell with a radial stencil:

.. math::

    L_z(o) = \\sum_b \\sum_s F_b(s)\\, W_b(s - o), \\qquad
    W_b(m) = \\frac{1}{k^2} \\sum_p z_b\\big(|m + p|\\big), \\qquad
    z_b(d) = \\frac{1}{n_\\phi} \\sum_j b_b(d, \\theta_0, \\phi_j)
    \\quad [\\mathrm{cd\\,m^{-2}}],

with ``F_b`` the flux of emission band ``b`` (Lambertian, uplight) in a cell [lm] and ``z_b(r)``
the azimuth mean of the kernel's top row [cd m-2 lm-1] (Dobashi et al. 2023, Eq. 4: the DC
term of its PCA form when no raw tables are stored) read at a sub-point's distance ``r`` as the
polar map reads it: shared between the two distance bins around ``r``, linearly in ln r
between their centres (:func:`~nightlights.sky.polar.distance_shares`; sub-points beyond the
last edge left out). The stencil samples every cell offset exactly as the polar map samples a
cell around an observer at a cell centre, so on flat terrain the map equals the panorama's
zenith at any cell up to float rounding.

Over terrain the emission is split between the kernel's source levels by each cell's height
(:func:`~nightlights.sky.polar.source_level_weights`), one convolution is made per (source level,
observer level) pair, and each cell interpolates linearly between the two observer levels
around its eye altitude: the rule by which the panorama interpolates the kernel
(:func:`~nightlights.sky.panorama.kernel_slice`). The convolutions are FFTs (one forward
transform per plane and stencil, one inverse per observer level), chunked with
:func:`dask.array.map_overlap` (depth = the stencil radius in cells) on local threads or a
``dask.distributed`` cluster. Beyond Dobashi et al. 2023, who render one observer at a time.

In an instrument's units (``instrument=``) the top row gives way to every row weighted by the
instrument's elevation weights :math:`w_i` (its angular response times the rows' solid angles,
summing to 1, :func:`~nightlights.sky.instruments.elevation_weights`), and the result is scaled
by the colour term of the light's spectrum (:mod:`nightlights.sky.instrument_units`):

.. math::

    z^w_b(d) = \\sum_i w_i \\frac{1}{n_\\phi} \\sum_j b_b(d, \\theta_i, \\phi_j), \\qquad
    L_\\mathrm{inst}(o) = 10^{-0.4\\, C(S)} \\sum_b \\sum_s F_b(s)\\, W^w_b(s - o)
    \\quad [\\mathrm{cd\\,m^{-2}}],

:math:`W^w_b` the stencil of :math:`z^w_b`. For an azimuth-symmetric instrument pointing at
the zenith this is the panorama read with its angular weights
(:func:`~nightlights.sky.instruments.angular_weights`), as exact as the zenith is.

Under a cloud deck (the scene's ``clouds``, flat ground, uniform cover c) the zenith table of
each distance bin becomes :math:`(1 - c)\\, z_b(d) + c\\, z^c_b(d)`, with :math:`z^c_b` the
overcast zenith per lumen of :func:`~nightlights.sky.cloudy.cloudy_zenith_per_lumen` (the
cloudy panorama's top row, or its rows under an instrument's weights, every ground-cloud
reflection included): the map is then the cloudy panorama's zenith at every cell, and an
instrument's natural sky is dimmed by the deck's
:meth:`~nightlights.sky.clouds.CloudLayer.natural_sky_factor`.

Length: the stage, the stencil geometry, the FFT plan every chunk and every tile receives,
the Dask scheduling and the tiled stage (its geometry and engines in
:mod:`nightlights.sky.tiled`) share that private plan; apart, each piece would serve only
this stage.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 3.3-3.4.
Falchi, F. et al. 2016, "The new world atlas of artificial night sky brightness", Sci. Adv. 2,
e1600377 (the same quantity world-wide, with Garstang's model).
"""

from __future__ import annotations

import functools
import logging
import math
import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import dask
import dask.array as da
import numpy as np
import scipy.fft
from affine import Affine
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS
from rich.progress import Progress

from nightlights._parallel import TaskProgress, check_scheduler, compute_distributed
from nightlights._progress import progress_bar
from nightlights._resources import check_memory
from nightlights._typing import FloatArray, PathLike
from nightlights.brightness import luminance_to_magnitude
from nightlights.errors import CRSError, DataQualityWarning, InputError
from nightlights.ground.checks import raster_header
from nightlights.io import Raster, as_raster, source_label
from nightlights.io.outputs import OutputSet
from nightlights.io.styles import PRODUCT_TAG
from nightlights.sky._flat import flat_keywords
from nightlights.sky._tile_run import ProgressHook
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.cloudy import cloudy_zenith_per_lumen
from nightlights.sky.horizon import terrain_under
from nightlights.sky.instrument_units import InstrumentSky, instrument_sky
from nightlights.sky.instruments import Instrument
from nightlights.sky.multiple import scattering_note
from nightlights.sky.observer import OBSERVER_HEIGHT
from nightlights.sky.panorama import KernelSlice, band_slice, kernel_levels
from nightlights.sky.polar import distance_shares, source_level_weights, supersampling
from nightlights.sky.scene import Scene
from nightlights.sky.setup import (
    RasterInput,
    band_emission_functions,
    kernel_band_functions,
    level_offset,
)
from nightlights.sky.spec import MAX_KERNEL_RANGE, source_levels

__all__ = ["DEFAULT_CHUNK_SIZE", "DarknessResult", "darkness", "zenith_per_lumen"]

log = logging.getLogger(__name__)

#: Chunk edge [cells] when ``chunk_size`` is None; a chunk is never smaller than twice the
#: stencil radius, so that a padded chunk costs at most four times its own FFT.
DEFAULT_CHUNK_SIZE = 4096
#: Sub-points per cell side at most, as the polar map (:func:`polar_cells`) [1].
MAX_SAMPLES = 16
#: Bytes per cell of the whole-raster arrays held from the read to the written map, besides
#: 24 B per emission band (its float64 raster, the NaN-free flux density and the flux): the
#: lit mask (1 B) and the ground, eye and source altitudes (8 B each) [B].
BYTES_PER_CELL = 25.0
#: Bytes per cell once the luminance is computed: the luminance, the two output bands (with
#: the magnitude's temporary), their float32 copies and GDAL's blocks written [B]. With
#: :data:`BYTES_PER_CELL` and the bands' 24 B, 97 B measured (``VmHWM`` over the imports) at
#: the write of a 4000 x 4000 single-band map (``bench_memory_estimates.py``), 96 B counted.
OUTPUT_BYTES_PER_CELL = 48.0
#: Bytes per cell that a DEM adds: its heights sampled under every cell centre (coordinates,
#: indices, masks, the interpolation's copies) and the per-cell level weights [B].
TERRAIN_BYTES_PER_CELL = 96.0
#: An observer this far outside a given kernel's observer levels is warned about [m] (the
#: panorama's rule, :func:`~nightlights.sky.panorama.kernel_slice`).
LEVEL_TOLERANCE = 5.0


@dataclass(frozen=True)
class DarknessResult:
    """What :func:`darkness` computed.

    Attributes
    ----------
    raster
        Two bands on the output grid (the emission's, or ``target_crs``'s on the tiled path):
        ``zenith_luminance`` [cd m-2] and
        ``zenith_sky_brightness`` [mag arcsec-2] (+inf where no flux reaches).
        With an instrument: ``instrument_luminance`` [cd m-2] (the V-equivalent luminance
        its reading of the artificial sky stands for) and ``instrument_sky_brightness``
        [mag arcsec-2] (its band, artificial + natural sky).
        None on the tiled path with an ``output``: the map is only in the file (read it, or
        its overviews with :func:`~nightlights.sky.tiled.read_overview`).
    seconds
        Time of the map once the kernel is loaded: stencils and convolutions [s].
    path
        The COG written, or None.
    instrument
        The instrument's name (:data:`~nightlights.sky.instruments.INSTRUMENTS`), or None.
    tiles
        Tiles computed in this call on the tiled path (0 in memory) [1].
    reused_tiles
        Tiles taken from the tile store (a resumed run) [1].
    """

    raster: Raster | None
    seconds: float
    path: Path | None = None
    instrument: str | None = None
    tiles: int = 0
    reused_tiles: int = 0


def zenith_per_lumen(tables: KernelSlice, weights: ArrayLike | None = None) -> FloatArray:
    """Zenith luminance per lumen in each distance bin: the azimuth mean of the top kernel row,
    or of every row weighted by an instrument's elevation weights.

    .. math:: z_b(d) = \\frac{1}{n_\\phi}\\sum_j b_b(d, \\theta_0, \\phi_j)
        = \\frac{1}{n_\\phi}\\sum_k c_{b,d,k}\\, \\mathrm{Re}\\,\\hat B_k(\\theta_0, 0)

    (the raw tables when the kernel stores them, else the DC term of the PCA bases, Dobashi
    et al. 2023, Eq. 4); with elevation weights :math:`w_i` (summing to 1)

    .. math:: z_b^w(d) = \\sum_i w_i \\frac{1}{n_\\phi}\\sum_j b_b(d, \\theta_i, \\phi_j)
        = \\frac{1}{n_\\phi}\\sum_k c_{b,d,k} \\sum_i w_i\\, \\mathrm{Re}\\,\\hat B_k(\\theta_i, 0),

    the reading of an azimuth-symmetric, zenith-pointing instrument
    (:func:`~nightlights.sky.instruments.elevation_weights`) per lumen.

    Parameters
    ----------
    tables
        A kernel slice (:func:`~nightlights.sky.panorama.kernel_slice`).
    weights
        ``(n_el,)`` weights of the slice's elevation rows, in the order of
        ``tables.elevation`` (zenith first), summing to 1 [1]; None: the top row alone.

    Returns
    -------
    numpy.ndarray
        ``(bands, n_r)`` [cd m-2 lm-1].

    Raises
    ------
    InputError
        ``weights`` of another length than the slice's rows, or not finite.

    Examples
    --------
    >>> from nightlights.sky import KernelSpec, build_kernel
    >>> from nightlights.sky.panorama import kernel_slice
    >>> spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    >>> tables = kernel_slice(build_kernel(spec, progress=False).kernel, observer_altitude=0.0)
    >>> z = zenith_per_lumen(tables)
    >>> z.shape, bool(z[0, 0] > z[0, -1] > 0)
    ((1, 8), True)
    >>> top = np.eye(8)[0]  # all the weight on the top row: the zenith
    >>> bool(np.allclose(zenith_per_lumen(tables, top), z, rtol=1e-12))
    True
    """
    if weights is None:
        if tables.has_tables:
            return np.asarray(tables.kernel[:, :, 0, :].mean(axis=-1), dtype=float)
        dc = tables.basis_fft[:, 0, 0].real  # (components,)
        return np.asarray(tables.coefficient @ dc / tables.n_az, dtype=float)
    w = np.asarray(weights, dtype=float)
    if w.shape != tables.elevation.shape or not np.isfinite(w).all():
        raise InputError(
            f"weights of shape {w.shape}; expected {tables.elevation.size} finite weights, one "
            "per elevation row of the kernel"
        )
    if tables.has_tables:
        return np.asarray(tables.kernel.mean(axis=-1) @ w, dtype=float)
    dc = tables.basis_fft[:, :, 0].real @ w  # (components,): the weighted DC terms
    return np.asarray(tables.coefficient @ dc / tables.n_az, dtype=float)


class _Stencil:
    """Where the polar map's sub-points of every cell offset fall in the distance bins.

    Offsets ``(di, dj)`` (source row, column minus the observer's) up to ``half`` cells; an
    offset sampled by one sub-point (its centre) keeps its lower distance bin (``bins``,
    ``n_r`` = beyond the last edge) and the upper bin's weight (``frac``), as the polar map
    shares it (:func:`~nightlights.sky.polar.distance_shares`); the few near the centre
    (k > 1) keep a row of bin shares. ``bins`` selects the distance rule (the former one-bin
    rule, :func:`~nightlights.sky.polar._nearest_bin`, for the benchmark that compares them).
    """

    def __init__(
        self,
        cell: float | tuple[float, float],
        edges: FloatArray,
        n_az: int,
        half: tuple[int, int],
        bins: Callable[[ArrayLike, ArrayLike], tuple[NDArray[np.int64], FloatArray]] = (
            distance_shares
        ),
    ) -> None:
        self.half = half
        self.n_r = edges.size - 1
        # a cell's east-west and north-south size [m] (the near field of a geographic grid's
        # cells, :func:`nightlights.sky._tile_run.near_field`, has them differ)
        if isinstance(cell, tuple):
            cx, cy = float(cell[0]), float(cell[1])
        else:
            cx = cy = float(cell)
        size = max(cx, cy)  # sub-points from the longer side
        rows, cols = 2 * half[0] + 1, 2 * half[1] + 1
        dx = (np.arange(cols) - half[1]) * cx  # east
        self.bins = np.empty((rows, cols), dtype=np.uint8 if self.n_r < 255 else np.uint16)
        # the upper bin's weight [1]; float64: the map equals the panorama to float rounding
        self.frac = np.zeros((rows, cols))
        near: list[NDArray[np.int64]] = []
        strip = max(1, 2**20 // cols)  # bound the temporaries of a wide stencil
        for top in range(0, rows, strip):
            dy = -(np.arange(top, min(top + strip, rows)) - half[0])[:, None] * cy  # north
            r = np.hypot(dx[None, :], dy)
            k = supersampling(size, r, n_az, max_samples=MAX_SAMPLES)
            lower, weight = bins(r, edges)
            far = k == 1
            self.bins[top : top + dy.shape[0]] = np.where(far, lower, self.n_r)
            self.frac[top : top + dy.shape[0]] = np.where(far & (lower < self.n_r), 1 - weight, 0)
            near.append(np.flatnonzero(~far) + top * cols)
        self.near = np.concatenate(near)
        self.share = np.zeros((self.near.size, self.n_r))
        if self.near.size == 0:
            return
        near_dx = dx[self.near % cols]
        near_dy = -(self.near // cols - half[0]) * cy
        k = supersampling(size, np.hypot(near_dx, near_dy), n_az, max_samples=MAX_SAMPLES)
        for samples in np.unique(k):  # the sub-points of polar_cells, offset by the observer
            members = np.flatnonzero(k == samples)
            offsets = (np.arange(samples) + 0.5) / samples - 0.5
            ox, oy = np.meshgrid(offsets * cx, offsets * cy)
            px = near_dx[members, None] + ox.ravel()[None, :]
            py = near_dy[members, None] + oy.ravel()[None, :]
            lower, weight = bins(np.hypot(px, py).ravel(), edges)
            inside = lower < self.n_r
            shared = inside & (weight < 1.0)
            member = np.repeat(members, samples**2)
            index = np.concatenate(
                [
                    member[inside] * self.n_r + lower[inside],
                    member[shared] * self.n_r + lower[shared] + 1,
                ]
            )
            parts = np.concatenate([weight[inside], 1.0 - weight[shared]])
            self.share += np.bincount(index, weights=parts, minlength=self.share.size).reshape(
                self.share.shape
            ) / float(samples**2)

    def weights(self, per_lumen: FloatArray) -> FloatArray:
        """The stencil W(m) [cd m-2 lm-1] of a zenith table ``(n_r,)``, indexed by offset:
        (1 - f) z[lo] + f z[lo + 1] with lo = ``bins`` and f = ``frac``."""
        extended = np.append(np.asarray(per_lumen, dtype=float), [0.0, 0.0])
        stencil = extended[self.bins]
        stencil += self.frac * (extended[self.bins + 1] - stencil)
        stencil.flat[self.near] = self.share @ extended[:-2]
        return stencil


@functools.lru_cache(maxsize=1024)
def _near_stencil(
    cell: tuple[float, float], edges: tuple[float, ...], n_az: int, half: tuple[int, int]
) -> _Stencil:
    """A near field's stencil, kept: the tiles of one row of a map share their bands' cells."""
    return _Stencil(cell, np.asarray(edges), n_az, half)


@dataclass(frozen=True)
class _Plan:
    """What every chunk needs: the stencil geometry, the zenith tables and the levels."""

    stencil: _Stencil
    zenith: FloatArray  # (observer levels, source levels, bands, n_r) [cd m-2 lm-1]
    source_levels: FloatArray  # [m], kernel frame
    observer_levels: FloatArray  # [m], kernel frame
    bands: int
    terrain: bool
    flat_source: float  # without terrain: the source altitude of every cell [m], kernel frame
    flat_eye: float  # and the eye altitude of every cell [m], kernel frame
    # the near field's zenith tables, summed on the output grid itself (the tiled map of a
    # geographic grid, :func:`nightlights.sky._tile_run.near_field`); ``zenith`` then holds
    # the rest, and the two add up to the whole table in every distance bin
    near_zenith: FloatArray | None = None
    near_radius: float = 0.0  # where the near field ends [m]
    edges: FloatArray | None = None  # the kernel's distance edges [m]
    n_az: int = 0

    def near_plan(self, cell: tuple[float, float]) -> _Plan:
        """The plan of the near field on a grid of (east-west, north-south) ``cell`` [m]."""
        assert self.near_zenith is not None and self.edges is not None
        half = (math.ceil(self.near_radius / cell[1]), math.ceil(self.near_radius / cell[0]))
        return replace(
            self,
            stencil=_near_stencil(cell, tuple(self.edges), self.n_az, half),
            zenith=self.near_zenith,
            near_zenith=None,
        )

    @property
    def depth(self) -> tuple[int, int]:
        """Stencil radius in rows and columns [cells]."""
        return self.stencil.half

    def convolve(
        self,
        flux: list[FloatArray],
        heights: FloatArray | float,
        eye: FloatArray | float,
        region: tuple[int, int, int, int],
        workers: int = 1,
    ) -> FloatArray:
        """:func:`_convolve` with this plan (the tiled map's engines reach it through the
        plan they are given)."""
        return _convolve(flux, heights, eye, self, region, workers)

    def spectrum(
        self, level: int, source: int, band: int, shape: tuple[int, int], workers: int
    ) -> Any:
        """rfft2 of the flipped stencil wrapped onto an FFT grid of ``shape``."""
        a, b = self.depth
        wrapped = np.zeros(shape)
        rows = np.arange(-a, a + 1) % shape[0]
        cols = np.arange(-b, b + 1) % shape[1]
        # convolution: out(o) = sum_s F(s) K(o - s) with K(m) = W(-m)
        weights = self.stencil.weights(self.zenith[level, source, band])
        wrapped[np.ix_(rows, cols)] = weights[::-1, ::-1]
        return scipy.fft.rfft2(wrapped, workers=workers)


def _convolve(
    flux: list[FloatArray],
    heights: FloatArray | float,
    eye: FloatArray | float,
    plan: _Plan,
    region: tuple[int, int, int, int],
    workers: int = 1,
) -> FloatArray:
    """The zenith luminance [cd m-2] on ``region`` (row0, row1, col0, col1) of the inputs.

    ``flux``: per band, the flux per cell [lm] on the (padded) input window; ``heights``: the
    source altitudes there [m]; ``eye``: the eye altitudes on the region [m] (either one value
    for all cells without terrain). A circular FFT of a size that keeps every needed offset
    alias-free.
    """
    r0, r1, c0, c1 = region
    rows, cols = flux[0].shape
    a, b = plan.depth
    shape = (
        scipy.fft.next_fast_len(max(r1 - 1, rows - 1 - r0) + a + 1, real=True),
        scipy.fft.next_fast_len(max(c1 - 1, cols - 1 - c0) + b + 1, real=True),
    )
    source_w = source_level_weights(heights, plan.source_levels)  # (n_s, ...) or (n_s,)
    observer_w = source_level_weights(eye, plan.observer_levels)  # (n_o, ...) or (n_o,)
    planes = []
    for s in range(source_w.shape[0]):
        for band in range(plan.bands):
            values = source_w[s] * flux[band]
            if np.any(values):
                planes.append((s, band, values))
    levels = [o for o in range(observer_w.shape[0]) if np.any(observer_w[o])]
    out = np.zeros((r1 - r0, c1 - c0))
    if not planes or not levels:
        return out

    def transform(values: FloatArray) -> Any:
        return scipy.fft.rfft2(values, s=shape, workers=workers)

    def add_level(level: int, spectrum: Any) -> None:
        full = scipy.fft.irfft2(spectrum, s=shape, workers=workers)
        out[:] += observer_w[level] * full[r0:r1, c0:c1]

    # Hold min(planes, observer levels) spectra at a time.
    if len(planes) <= len(levels):
        inputs = [(s, band, transform(values)) for s, band, values in planes]
        for level in levels:
            total = sum(
                plan.spectrum(level, s, band, shape, workers) * fx for s, band, fx in inputs
            )
            add_level(level, total)
    else:
        totals: dict[int, Any] = {}
        for s, band, values in planes:
            fx = transform(values)
            for level in levels:
                product = plan.spectrum(level, s, band, shape, workers) * fx
                totals[level] = totals[level] + product if level in totals else product
        for level in levels:
            add_level(level, totals[level])
    return np.maximum(out, 0.0)  # FFT rounding can dip just below zero far from any light


def _chunk(*arrays: FloatArray, plan: _Plan) -> FloatArray:
    """One map_overlap block: padded flux planes (and heights), the eye altitudes unpadded."""
    a, b = plan.depth
    flux = list(arrays[: plan.bands])
    heights = arrays[plan.bands] if plan.terrain else plan.flat_source
    eye = arrays[plan.bands + 1] if plan.terrain else plan.flat_eye
    rows, cols = flux[0].shape
    return _convolve(flux, heights, eye, plan, (a, rows - a, b, cols - b))


@flat_keywords(legacy=("output",), observer="height")
def darkness(
    scene: Scene,
    output: PathLike | None = None,
    *,
    height: float = OBSERVER_HEIGHT,
    instrument: str | Instrument | None = None,
    spectrum: str | None = None,
    natural_luminance: float | None = None,
    chunk_size: int | None = None,
    scheduler: str | Any | None = None,
    progress: bool | Callable[[int, int], None] = True,
    tiled: bool | None = None,
    target_crs: Any | None = None,
    store: PathLike | None = None,
    resume: bool = True,
    keep_store: bool = False,
    retries: int = 2,
) -> DarknessResult:
    """The artificial zenith sky brightness with the observer at every cell of a region.

    One FFT convolution of the flux per cell with the radial zenith stencil (module docstring),
    per (source level, observer level) pair over terrain; chunked with Dask when the raster is
    larger than ``chunk_size``. A geographic emission, a ``target_crs``, a ``store``,
    ``tiled=True`` or an emission file whose in-memory map would need more than
    :data:`~nightlights.sky.tiled.TILED_ABOVE` is mapped tile by tile, out of core and
    geodesically (:mod:`nightlights.sky.tiled`; flat terrain).

    Parameters
    ----------
    scene
        The emission (upward flux density [lm m-2] in a projected CRS, one or two bands, each
        with the emission function of its ``emission_function`` tag), terrain, atmosphere and
        kernel (:class:`~nightlights.sky.scene.Scene`); its cloud deck is read on flat
        ground with a uniform cover, in memory (module docstring). Its DEM must cover every
        cell: each observer stands ``height`` above its cell, each source at its own height.
        Without a kernel, a scene kernel over the region's diagonal (at most
        :data:`~nightlights.sky.spec.MAX_KERNEL_RANGE`), its observer and source levels.
    output
        COG to write atomically (2 bands); None writes nothing (the tiled path then needs the
        map to fit in memory).
    height
        Eye height above the ground of the observer at every cell [m].
    instrument
        Report what this instrument reads, pointing at the zenith: a key of
        :data:`~nightlights.sky.instruments.INSTRUMENTS` (``sqm``, ``sqm-l``, ``tess-w``,
        ``eye``) or an :class:`~nightlights.sky.instruments.Instrument`; None: the zenith
        luminance (the kernel's top row).
    spectrum
        With an instrument: the artificial light's spectrum for its colour term, a name of
        :data:`ies.spectra.SPDS`; None: the emission raster's ``spectrum`` tag, else
        :data:`~nightlights.sky.instrument_units.DEFAULT_SPECTRUM` (LED_4000K).
    natural_luminance
        With an instrument: the natural sky's reading, V-equivalent with its colour term
        [cd m-2]; None: a uniform moonless sky of 22.0 mag arcsec-2 (V) seen by the
        instrument (:func:`~nightlights.sky.instrument_units.instrument_sky`).
    chunk_size
        Chunk edge [cells]; default :data:`DEFAULT_CHUNK_SIZE`. A raster within one chunk is
        one FFT in memory; larger ones are chunked (never below twice the stencil radius).
        On the tiled path the tile edge in output cells, default
        :data:`~nightlights.sky.tiled.DEFAULT_TILE_SIZE`.
    scheduler
        None: local threads; a ``dask.distributed`` address or ``Client``: that cluster
        (on the tiled path its workers read the emission file and write the tile store).
    progress
        Progress bars (kernel build, chunks or tiles, with the time left); or a callable
        ``progress(done, total)`` called after every tile or chunk, with no bars.
    tiled
        Map tile by tile (True), in memory (False), or choose (None: see above).
    target_crs
        The tiled map's output CRS, on a grid of the input's metres per cell; None: the
        emission's grid (geographic in, geographic out).
    store
        Tile store of the tiled path: a folder or an fsspec URL, one file per finished tile;
        default with a ``scheduler``: ``OUTPUT.tiles`` beside the output; without one, none.
    resume
        Reuse the tiles of the same input and plan already in the store.
    keep_store
        Keep the store's tiles once the map is written (else they are removed).
    retries
        Extra attempts of a tile whose task fails on a cluster [1].

    Returns
    -------
    DarknessResult
        Zenith luminance [cd m-2] and sky brightness [mag arcsec-2] at every cell (with an
        instrument: its V-equivalent reading of the artificial sky [cd m-2] and its sky
        brightness with the natural sky [mag arcsec-2]), the time and the written path.

    Examples
    --------
    >>> import numpy as np
    >>> from affine import Affine
    >>> from nightlights.io import Raster
    >>> from nightlights.sky import KernelSpec, Scene, build_kernel
    >>> flux = np.zeros((1, 20, 20)); flux[0, 5, 15] = 1.0  # [lm m-2]
    >>> raster = Raster(flux, Affine(100, 0, 0, 0, -100, 2000), "EPSG:32635")
    >>> spec = KernelSpec(r_max=3000.0, n_distance=8, n_elevation=8, n_azimuth=16)
    >>> scene = Scene(raster, kernel=build_kernel(spec, progress=False))
    >>> result = darkness(scene, progress=False)
    >>> result.raster.descriptions
    ('zenith_luminance', 'zenith_sky_brightness')
    >>> zenith = result.raster.data[0]
    >>> bool(zenith[5, 15] == zenith.max()), bool(np.all(zenith > 0))
    (True, True)
    """
    scheduler = check_scheduler(scheduler)  # an address is parsed and probed before any work
    target = _check_output(output, scene)
    emission, dem, observer_height = scene.raster_input("darkness"), scene.dem, height
    label = source_label(emission, "emission raster")
    tiled_path = _tiled_path(scene, chunk_size, tiled, target_crs, store, label)
    _check_clouds(scene, tiled=tiled_path)
    if tiled_path:
        return _tiled_darkness(
            scene,
            target,
            height=height,
            instrument=instrument,
            spectrum=spectrum,
            natural_luminance=natural_luminance,
            chunk_size=chunk_size,
            scheduler=scheduler,
            progress=progress,
            target_crs=target_crs,
            store=store,
            resume=resume,
            keep_store=keep_store,
            retries=retries,
        )
    chunk = _check_chunk_size(chunk_size)
    _check_memory_early(emission, dem, chunk, label)  # from the headers, before any read
    raster = as_raster(emission)
    data = _check_emission(raster, label)
    reader = instrument_sky(
        instrument,
        spectrum=spectrum,
        natural_luminance=natural_luminance,
        emission=raster,
        label=label,
    )
    # each band's emission function (its tag, or the default), read as the skyglow stage does
    functions, notes = band_emission_functions(raster, data.shape[0], label=label)
    if not (math.isfinite(observer_height) and observer_height >= 0):
        raise InputError(f"height={observer_height!r} m; expected a finite value >= 0")
    cell = raster.resolution
    rows, cols = raster.shape
    lit = np.any(data != 0, axis=0)
    ground = (
        _terrain(dem, raster, source_label(dem, "DEM")) if dem is not None else np.zeros(lit.shape)
    )
    eye = ground + observer_height
    table, _ = scene.find_kernel(
        raster,
        (raster.transform.c, raster.transform.f),  # a corner: range = the diagonal
        observer_altitudes=tuple(source_levels(eye)),
        source_altitudes=source_levels(ground[lit]),
        functions=functions,
        progress=progress is True,
    )
    start = time.perf_counter()
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    observer_levels = np.sort(np.asarray(table["observer_altitude"].values, dtype=float))
    offset = level_offset(np.where(lit, ground, np.nan), lit, levels)
    eye = eye - offset
    low, high = float(eye.min()), float(eye.max())
    if low < observer_levels[0] - LEVEL_TOLERANCE or high > observer_levels[-1] + LEVEL_TOLERANCE:
        warnings.warn(
            f"eye altitudes {low:g}-{high:g} m lie outside the kernel's observer levels "
            f"{observer_levels[0]:g}-{observer_levels[-1]:g} m; the nearest level is used there",
            DataQualityWarning,
            stacklevel=2,
        )
    edges = np.asarray(table["distance_edges"].values, dtype=float)
    _warn_range(raster.bounds, edges[-1])
    zenith, n_az, functions, notes = _zenith_tables(
        table, observer_levels, functions, notes, reader, data.shape[0], label
    )
    zenith, cloud_tags, reader = _overcast(scene, zenith, table, n_az, functions, reader)
    radius = math.ceil(edges[-1] / cell)
    half = (min(radius, rows - 1), min(radius, cols - 1))
    estimate = darkness_memory(
        (rows, cols),
        half,
        chunk,
        bands=data.shape[0],
        planes=levels.size * data.shape[0],
        observer_levels=observer_levels.size,
        terrain=dem is not None,
        kernel_bytes=float(table.nbytes),
    )
    whole = _raster_memory((rows, cols), bands=data.shape[0], terrain=dem is not None)
    check_memory(
        estimate,
        f"the darkness map of {rows} x {cols} cells",
        option=_memory_hint(estimate, whole),
    )
    plan = _Plan(
        stencil=_Stencil(cell, edges, n_az, half),
        zenith=zenith,
        source_levels=levels,
        observer_levels=observer_levels,
        bands=data.shape[0],
        terrain=dem is not None,
        flat_source=-offset,
        flat_eye=float(observer_height - offset),
    )
    flux = [data[band] * cell * cell for band in range(data.shape[0])]
    heights = np.where(lit, ground - offset, levels[0])
    luminance, n_chunks, used_chunk = _compute(flux, heights, eye, plan, chunk, scheduler, progress)
    seconds = time.perf_counter() - start
    tags = _map_tags(
        label=label,
        functions=functions,
        notes=notes,
        table=table,
        observer_height=observer_height,
        terrain=source_label(dem, "DEM") if dem is not None else "flat (0 m)",
        levels=levels,
        observer_levels=observer_levels,
        offset=offset,
        layout=f"{n_chunks} chunk(s) of {used_chunk} cells",
        reader=reader,
    )
    tags.update(cloud_tags)
    bands, descriptions, band_tags = _map_bands(reader, luminance)
    result = Raster(
        bands,
        raster.transform,
        raster.crs,
        descriptions=descriptions,
        units=("cd m-2", "mag arcsec-2"),
        tags=tags,
        band_tags=band_tags,
    )
    if target is not None:
        result.write(target)
    return DarknessResult(
        result, seconds, target, None if reader is None else reader.instrument.name
    )


def _check_clouds(scene: Scene, *, tiled: bool) -> None:
    """Refuse a cloud deck where the map cannot carry it: the tiled map, a DEM and a cover
    raster."""
    cloud = scene.clouds
    if cloud is None:
        return
    why = (
        "the tiled (geographic or out-of-core) map"
        if tiled
        else "a scene with a DEM"
        if scene.dem is not None
        else "a cover raster"
        if cloud.cover_raster is not None
        else None
    )
    if why is not None:
        raise InputError(
            f"clouds={cloud!r}: the darkness map reads a cloud deck only in memory, on flat "
            f"ground and with a uniform cover, not for {why}; give the "
            "scene clouds=None or skyglow one observer at a time"
        )


def _overcast(
    scene: Scene,
    zenith: FloatArray,
    table: Any,
    n_az: int,
    functions: tuple[Any, ...],
    reader: InstrumentSky | None,
) -> tuple[FloatArray, dict[str, str], InstrumentSky | None]:
    """The zenith tables under the scene's deck, (1 - c) clear + c cloudy per distance bin
    (:func:`~nightlights.sky.cloudy.cloudy_zenith_per_lumen`, an instrument's rows weighted),
    the deck's tags, and the instrument's natural sky dimmed by the deck
    (:meth:`~nightlights.sky.clouds.CloudLayer.natural_sky_factor`)."""
    cloud = scene.clouds
    if cloud is None:
        return zenith, {}, reader
    cover = float(cloud.cover)
    tags = {
        "cloud_cover": str(cover),
        "cloud_base_height_m": str(float(cloud.base_height)),
        "cloud_reflectance": str(cloud.reflectance),
        "cloud_ground_albedo": str(float(cloud.ground_albedo)),
        "natural_sky_factor": str(cloud.natural_sky_factor(cover)),
    }
    if cover == 0.0:
        return zenith, tags, reader
    edges = np.asarray(table["distance_edges"].values, dtype=float)
    elevation = np.asarray(table["elevation"].values, dtype=float)
    weights = None
    if reader is not None:
        weights = reader.elevation_weights(elevation)
        factor = cloud.natural_sky_factor(cover)
        reader = replace(
            reader,
            natural=reader.natural * factor,
            natural_source=f"{reader.natural_source}, x{factor:.4g} through the cloud deck",
        )
    cloudy = cloudy_zenith_per_lumen(
        edges,
        elevation,
        n_az,
        functions[: zenith.shape[2]],
        cloud,
        Atmosphere.from_parameters(table.attrs),
        weights=weights,
    )
    return (1.0 - cover) * zenith + cover * cloudy[None, None], tags, reader


def _map_tags(
    *,
    label: str,
    functions: tuple[Any, ...],
    notes: tuple[str, ...],
    table: Any,
    observer_height: float,
    terrain: str,
    levels: FloatArray,
    observer_levels: FloatArray,
    offset: float,
    layout: str,
    reader: InstrumentSky | None,
) -> dict[str, str]:
    """The map's dataset tags (in memory and tiled: ``layout`` says how it was computed)."""
    edges = np.asarray(table["distance_edges"].values, dtype=float)
    tags = {
        PRODUCT_TAG: "zenith_brightness",
        "nightlights_stage": "darkness",
        "emission": label,
        "emission_functions": "; ".join(function.tag for function in functions),
        "emission_function_sources": "; ".join(notes),
        "kernel_hash": str(table.attrs.get("content_hash", "")),
        "kernel_range_m": float(edges[-1]),
        "turbidity": float(table.attrs.get("turbidity", np.nan)),
        "observer_height_m": float(observer_height),
        "terrain": terrain,
        "source_altitude_levels_m": [float(h) for h in levels],
        "observer_altitude_levels_m": [float(h) for h in observer_levels],
        "kernel_altitude_offset_m": offset,
        "method": "FFT convolution of the flux per cell with the zenith stencil (azimuth mean "
        "of the kernel's top row, cells sampled as the polar map); terrain: per source and "
        "observer level; " + layout,
        "note": "artificial skyglow only (no natural sky background), "
        + scattering_note(table.attrs),
        "reference": "Dobashi et al. 2023, Sec. 3.3-3.4 (zenith of the forward panorama)",
    }
    if reader is not None:
        tags.update(
            {
                "method": "FFT convolution of the flux per cell with the instrument's stencil "
                "(azimuth means of the kernel's rows weighted by its elevation weights, cells "
                "sampled as the polar map); terrain: per source and observer level; " + layout,
                "note": "artificial skyglow in the instrument's units, plus the natural sky in "
                "the sky-brightness band; " + scattering_note(table.attrs),
                **reader.tags(),
            }
        )
    return {key: str(value) for key, value in tags.items()}


def _map_bands(
    reader: InstrumentSky | None, luminance: FloatArray
) -> tuple[FloatArray, tuple[str, str], tuple[dict[str, str], ...]]:
    """The two output bands of a luminance map (in place for an instrument), their names and
    long names."""
    if reader is not None:
        return _instrument_bands(reader, luminance)
    bands = np.stack([luminance, luminance_to_magnitude(luminance)])
    band_tags: tuple[dict[str, str], ...] = (
        {"long_name": "artificial zenith sky luminance, observer at the cell centre"},
        {"long_name": "zenith sky brightness, -2.5 log10(L / 1.08e5)"},
    )
    return bands, ("zenith_luminance", "zenith_sky_brightness"), band_tags


def _zenith_tables(
    table: Any,
    observer_levels: FloatArray,
    functions: tuple[Any, ...],
    notes: tuple[str, ...],
    reader: InstrumentSky | None,
    bands: int,
    label: str,
) -> tuple[FloatArray, int, tuple[Any, ...], tuple[str, ...]]:
    """Zenith per lumen ``(observer levels, source levels, bands, n_r)`` [cd m-2 lm-1] (or the
    instrument's weighted rows), the kernel's azimuth count and the bands' functions."""
    by_level = [kernel_levels(table, observer_altitude=h) for h in observer_levels]
    functions, notes = kernel_band_functions(functions, notes, by_level[0][0].emissions, label)
    by_level = [[band_slice(s, functions) for s in slices] for slices in by_level]
    weights = None if reader is None else reader.elevation_weights(by_level[0][0].elevation)
    zenith = [[zenith_per_lumen(t, weights)[:bands] for t in slices] for slices in by_level]
    return np.asarray(zenith), by_level[0][0].n_az, functions, notes


def _instrument_bands(
    reader: InstrumentSky, weighted: FloatArray
) -> tuple[FloatArray, tuple[str, str], tuple[dict[str, str], ...]]:
    """The two bands of a map in an instrument's units, their names and long names.

    ``weighted``, the angular-weighted artificial luminance [cd m-2], becomes the instrument's
    V-equivalent reading in place: the colour term is one factor
    (:func:`~nightlights.sky.instruments.instrument_luminance` is linear in the luminance), so
    the map needs no more memory than in plain luminance.
    """
    name = reader.instrument.name
    weighted *= float(reader.artificial(1.0))
    bands = np.stack([weighted, reader.magnitude(weighted)])
    long_names = (
        {
            "long_name": f"V-equivalent luminance of the {name} reading of the artificial sky, "
            f"{reader.spectrum} light, observer at the cell centre"
        },
        {
            "long_name": f"{name} sky brightness, artificial + natural sky, "
            "-2.5 log10(L / 1.08e5) in its band"
        },
    )
    return bands, ("instrument_luminance", "instrument_sky_brightness"), long_names


def _check_memory_early(
    emission: RasterInput, dem: RasterInput | None, chunk: int, label: str
) -> None:
    """Refuse a map whose whole-raster arrays alone exceed the limit, from the headers of the
    emission and the DEM, before either is read or a kernel is built (the stencil's reach is
    known only then: :func:`darkness` checks the full estimate again before it computes)."""
    header = raster_header(emission)
    if header is None:
        return  # the reader names what is wrong with it
    dem_header = raster_header(dem) if dem is not None else None
    rows, cols = header.rows, header.cols
    dem_cells = 0 if dem_header is None else dem_header.rows * dem_header.cols
    estimate = darkness_memory(
        (rows, cols),
        (0, 0),
        chunk,
        bands=header.count,
        planes=header.count,
        observer_levels=1,
        terrain=dem is not None,
        dem_cells=dem_cells,
    )
    whole = _raster_memory(
        (rows, cols), bands=header.count, terrain=dem is not None, dem_cells=dem_cells
    )
    check_memory(
        estimate,
        f"the darkness map of {rows} x {cols} cells of {label}",
        option=_memory_hint(estimate, whole),
    )


def darkness_memory(
    shape: tuple[int, int],
    half: tuple[int, int],
    chunk_size: int,
    *,
    bands: int,
    planes: int,
    observer_levels: int,
    terrain: bool = False,
    dem_cells: int = 0,
    kernel_bytes: float = 0.0,
) -> float:
    """Estimated peak memory of :func:`darkness` in memory [B] (the tiled map's, which does
    not grow with the raster, is :func:`nightlights.sky.tiled.tile_memory`).

    The first calls (:data:`~nightlights.sky.tiled.MAP_FIXED_MEMORY`), the kernel, the
    stencil and the whole-raster arrays held throughout (:data:`BYTES_PER_CELL` and 24 B per
    band; over terrain the DEM and the arrays that sample it, :data:`TERRAIN_BYTES_PER_CELL`),
    and the larger of two phases. Computing: in one FFT (a raster within one chunk) the
    source planes and the luminance on the raster (8 B per cell each; over terrain the level
    weights too) and the spectra held at once on the FFT grid, the raster padded by the
    stencil radius on one side (8 B per cell each: the fewer of the source planes and the
    observer levels, and three working ones); in chunks, per chunk in flight (one per
    thread) its padded inputs and source planes, its luminance and the spectra on its FFT
    grid, and the chunks' results with the map assembled from them (16 B per cell). Writing:
    :data:`OUTPUT_BYTES_PER_CELL`. Measured against this estimate: within 1.1x of the peak
    over the imports from 1000 x 1000 to 4000 x 4000 cells (``bench_memory_estimates.py``).

    Parameters
    ----------
    shape
        Raster (rows, cols) [cells].
    half
        Stencil radius in rows and columns [cells].
    chunk_size
        Chunk edge [cells].
    bands
        Emission bands [1].
    planes
        Source levels x bands [1].
    observer_levels
        Observer levels of the kernel [1].
    terrain
        Whether a DEM gives the ground under every cell.
    dem_cells
        Cells of the DEM raster, read whole [1].
    kernel_bytes
        The kernel's arrays in memory [B].

    Returns
    -------
    float
        Bytes.

    Examples
    --------
    >>> round(darkness_memory((1000, 1000), (50, 50), 4096, bands=1, planes=1,
    ...                       observer_levels=1) / 2**20)
    146
    """
    from nightlights.sky.tiled import MAP_FIXED_MEMORY

    raster = _held_memory(shape, bands=bands, terrain=terrain, dem_cells=dem_cells)
    rows, cols = shape
    cells = float(rows) * float(cols)
    a, b = half
    chunk = max(chunk_size, 2 * a, 2 * b, 1)
    stencil = 18.0 * (2 * a + 1) * (2 * b + 1)  # lower bin (2 B), upper weight (8 B), W (8 B)
    held = min(planes, observer_levels) + 3
    # over terrain the level weights of every input cell: source levels and observer levels
    weights = planes // max(bands, 1) + observer_levels if terrain else 0
    if rows <= chunk and cols <= chunk:  # one FFT; its inputs are the raster's own arrays
        fft = float(_fast(rows + a) * _fast(cols + b))
        computing = 8.0 * cells * (planes + 1 + weights) + 8.0 * fft * held
    else:
        padded = float(min(rows, chunk) + 2 * a) * float(min(cols, chunk) + 2 * b)
        fft = float(_fast(min(rows, chunk) + 2 * a) * _fast(min(cols, chunk) + 2 * b))
        inputs = bands + planes + (2 + weights if terrain else 0)
        per_chunk = 8.0 * padded * inputs + 8.0 * min(rows, chunk) * min(cols, chunk)
        per_chunk += 8.0 * fft * held
        n_chunks = -(-rows // chunk) * -(-cols // chunk)
        in_flight = min(n_chunks, os.cpu_count() or 1)
        computing = in_flight * per_chunk + 16.0 * cells
    writing = OUTPUT_BYTES_PER_CELL * cells
    return MAP_FIXED_MEMORY + kernel_bytes + raster + stencil + max(computing, writing)


def _fast(n: int) -> int:
    """The FFT length scipy pads ``n`` to (:func:`_convolve`'s grid)."""
    return int(scipy.fft.next_fast_len(max(n, 1), real=True))


def _held_memory(shape: tuple[int, int], *, bands: int, terrain: bool, dem_cells: int = 0) -> float:
    """The whole-raster arrays :func:`darkness_memory` holds throughout [B]."""
    per_cell = BYTES_PER_CELL + 24.0 * bands + (TERRAIN_BYTES_PER_CELL if terrain else 0.0)
    return float(shape[0]) * float(shape[1]) * per_cell + 8.0 * dem_cells


def _raster_memory(
    shape: tuple[int, int], *, bands: int, terrain: bool, dem_cells: int = 0
) -> float:
    """The whole-raster part of :func:`darkness_memory` [B] (no chunk size lowers it): the
    arrays held throughout and those of the map written."""
    held = _held_memory(shape, bands=bands, terrain=terrain, dem_cells=dem_cells)
    return held + OUTPUT_BYTES_PER_CELL * float(shape[0]) * float(shape[1])


def _memory_hint(estimate: float, whole_raster: float) -> str:
    """How to lower a darkness map's need: smaller chunks, unless the whole-raster arrays
    make most of it."""
    if whole_raster > estimate / 2:
        return "coarsen or crop the emission raster"
    return "lower chunk_size= (or coarsen the emission raster)"


def _compute(
    flux: list[FloatArray],
    heights: FloatArray,
    eye: FloatArray,
    plan: _Plan,
    chunk_size: int,
    scheduler: str | Any | None,
    progress: bool | Callable[[int, int], None],
) -> tuple[FloatArray, int, int]:
    """The map in one FFT, or chunked with map_overlap; also the chunk count and edge.
    ``progress``: bars, or a callable ``progress(done, total)`` after every chunk."""
    rows, cols = flux[0].shape
    a, b = plan.depth
    chunk = max(chunk_size, 2 * a, 2 * b, 1)
    terrain = [heights, eye] if plan.terrain else []
    hook = progress if callable(progress) else None
    done = [0]

    def advance(bar: Progress, task: Any, total: int) -> None:
        bar.advance(task)
        done[0] += 1
        if hook is not None:
            hook(done[0], total)

    if rows <= chunk and cols <= chunk:
        with _bar(progress is True) as bar:
            task = bar.add_task("darkness: one FFT", total=1)
            h, e = (heights, eye) if plan.terrain else (plan.flat_source, plan.flat_eye)
            out = _convolve(flux, h, e, plan, (0, rows, 0, cols), workers=-1)
            advance(bar, task, 1)
        return out, 1, max(rows, cols)
    chunks = (_axis_chunks(rows, chunk, a), _axis_chunks(cols, chunk, b))
    arrays = [da.from_array(x, chunks=chunks) for x in (*flux, *terrain)]
    depth = [(a, b)] * (len(arrays) - (1 if plan.terrain else 0))
    if plan.terrain:
        depth.append((0, 0))  # the eye altitudes are only read on the chunk itself
    name = f"darkness-{dask.base.tokenize(*arrays, plan.depth, plan.zenith)}"
    shared = dask.delayed(plan, pure=True)
    result = da.map_overlap(
        _chunk,
        *arrays,
        depth=depth,
        boundary=0,
        trim=False,
        chunks=arrays[0].chunks,
        dtype=float,
        meta=np.empty((0, 0)),
        name=name,
        plan=shared,
    )
    n_chunks = result.npartitions
    with _bar(progress is True) as bar:
        task = bar.add_task(f"darkness: {n_chunks} chunks", total=n_chunks)
        if scheduler is None:
            with TaskProgress(lambda: advance(bar, task, n_chunks), name):
                out = result.compute(scheduler="threads")
        else:
            blocks = result.to_delayed()
            values = compute_distributed(
                list(blocks.flat), scheduler, lambda: advance(bar, task, n_chunks)
            )
            width = blocks.shape[1]
            out = np.block([values[i : i + width] for i in range(0, len(values), width)])
    return np.asarray(out, dtype=float), n_chunks, chunk


def _bar(progress: bool) -> Progress:
    return progress_bar(progress)


def _axis_chunks(size: int, chunk: int, depth: int) -> tuple[int, ...]:
    """Chunk sizes along an axis, none smaller than ``depth`` (map_overlap would rechunk)."""
    sizes = [chunk] * (size // chunk)
    rest = size - chunk * len(sizes)
    if rest and sizes and rest < depth:
        sizes[-1] += rest
    elif rest:
        sizes.append(rest)
    return tuple(sizes)


def _tiled_path(
    scene: Scene,
    chunk_size: int | None,
    tiled: bool | None,
    target_crs: Any | None,
    store: PathLike | None,
    label: str,
) -> bool:
    """Whether the map is made tile by tile (:mod:`nightlights.sky.tiled`): when asked, for a
    geographic emission, a ``target_crs`` or a ``store``, or for an emission file whose
    in-memory map would need more than :data:`~nightlights.sky.tiled.TILED_ABOVE` (or the
    memory limit) with the stencil of the kernel it will use (:func:`_expected_reach`)."""
    from nightlights._resources import memory_limit
    from nightlights.sky.tiled import TILED_ABOVE

    emission, dem = scene.raster_input("darkness"), scene.dem
    if tiled is not None and not isinstance(tiled, bool):
        raise InputError(f"tiled={tiled!r}; expected True, False or None")
    header = raster_header(emission)
    geographic = header is not None and header.crs is not None and header.crs.is_geographic
    asked = target_crs is not None or store is not None
    if tiled is False:
        if asked:
            raise InputError("target_crs= and store= need the tiled map; omit tiled=False")
        return False
    if tiled or geographic or asked:
        if dem is not None:
            raise InputError(
                f"{label}: the tiled map (geographic emission, target_crs=, store= or "
                "tiled=True) is made over flat terrain; omit dem= or give a projected "
                "emission mapped in memory"
            )
        return True
    if header is None or dem is not None or not isinstance(emission, (str, os.PathLike)):
        return False
    cell = abs(header.transform.a) or 1.0
    radius = math.ceil(_expected_reach(scene, header.bounds) / cell)
    estimate = darkness_memory(
        (header.rows, header.cols),
        (min(radius, header.rows - 1), min(radius, header.cols - 1)),
        _check_chunk_size(chunk_size),
        bands=header.count,
        planes=header.count,
        observer_levels=1,
    )
    return estimate > min(TILED_ABOVE, memory_limit())


def _expected_reach(scene: Scene, bounds: tuple[float, float, float, float]) -> float:
    """The reach [m] of the kernel the in-memory map will use: a given kernel's range, else
    the scene kernel's (:func:`~nightlights.sky.spec.scene_kernel_spec` from a corner: the
    diagonal, at most :data:`~nightlights.sky.spec.MAX_KERNEL_RANGE`)."""
    table = scene.kernel_dataset()
    if table is not None:
        return float(np.asarray(table["distance_edges"].values, dtype=float)[-1])
    left, bottom, right, top = bounds
    return float(min(MAX_KERNEL_RANGE, max(1.01 * math.hypot(right - left, top - bottom), 100.0)))


def _check_output(output: PathLike | None, scene: Scene) -> Path | None:
    if output is None:
        return None
    # its folder exists and is writable and it is none of the scene's inputs, checked first
    OutputSet(output, inputs=scene.inputs)
    return Path(output)


def _check_emission(raster: Raster, label: str) -> FloatArray:
    """The flux density, NaN as 0, after the checks of the forward panorama."""
    if raster.crs is None or not raster.crs.is_projected:
        raise CRSError(f"{label}: the emission raster needs a projected CRS in metres")
    data = raster.data
    if data.shape[0] > 2:
        raise InputError(
            f"{label}: {data.shape[0]} bands; expected 1 or 2 (e.g. Lambertian + uplight)"
        )
    infinite = int(np.count_nonzero(np.isinf(data)))
    if infinite:
        raise InputError(
            f"{label}: {infinite} non-finite (inf) values; expected finite flux densities "
            "[lm m-2] (nodata as NaN)"
        )
    if np.isfinite(data).any() and np.nanmin(data) < 0:
        raise InputError(f"{label}: negative flux density {np.nanmin(data):g} lm m-2")
    raster.resolution  # noqa: B018  (raises InputError unless square, north-up cells)
    flux = np.nan_to_num(data, nan=0.0)
    if not flux.any():
        rows, cols = raster.shape
        raise InputError(
            f"{label}: no lit cell (all {rows} x {cols} cells are zero or nodata); nothing "
            "lights the sky"
        )
    return flux


def _check_chunk_size(chunk_size: int | None) -> int:
    if chunk_size is None:
        return DEFAULT_CHUNK_SIZE
    whole = isinstance(chunk_size, (int, np.integer)) and not isinstance(chunk_size, bool)
    if not whole or chunk_size < 1:
        raise InputError(f"chunk size {chunk_size!r}; expected a whole number of cells >= 1")
    return int(chunk_size)


def _terrain(dem: RasterInput, raster: Raster, label: str) -> FloatArray:
    """Terrain height under every emission cell centre [m], bilinear as the panorama reads it
    (:func:`~nightlights.sky.horizon.terrain_under`, the check every stage with a DEM makes):
    every cell is an observer here, so every cell needs a height, lit or not."""
    relief = as_raster(dem)
    if relief.crs is None or raster.crs is None or not relief.crs.equals(raster.crs):
        raise CRSError(f"{label}: the DEM must be in the emission raster's CRS")
    rows, cols = raster.shape
    t = raster.transform
    cx, cy = np.meshgrid(t.c + t.a * (np.arange(cols) + 0.5), t.f + t.e * (np.arange(rows) + 0.5))
    return terrain_under(
        relief,
        cx,
        cy,
        label=label,
        what="emission cells",
        expected="a DEM covering the whole emission raster",
    )


def _warn_range(
    bounds: tuple[float, float, float, float], kernel_range: float, diagonal: float | None = None
) -> None:
    """Warn when the region's diagonal (``diagonal`` [m], or that of projected ``bounds``)
    exceeds the kernel's range."""
    x0, y0, x1, y1 = bounds
    diagonal = math.hypot(x1 - x0, y1 - y0) if diagonal is None else diagonal
    if diagonal > kernel_range:
        limit = " (the limit, MAX_KERNEL_RANGE)" if kernel_range >= MAX_KERNEL_RANGE else ""
        warnings.warn(
            f"the region's diagonal ({diagonal / 1000:g} km) exceeds the kernel's range "
            f"({kernel_range / 1000:g} km{limit}): flux farther than that from a cell is left "
            "out of its zenith",
            DataQualityWarning,
            stacklevel=3,
        )


def _tiled_darkness(
    scene: Scene,
    output: Path | None,
    *,
    height: float,
    instrument: str | Instrument | None,
    spectrum: str | None,
    natural_luminance: float | None,
    chunk_size: int | None,
    scheduler: Any | None,
    progress: bool | ProgressHook,
    target_crs: Any | None,
    store: str | os.PathLike[str] | None,
    resume: bool,
    keep_store: bool,
    retries: int,
) -> DarknessResult:
    """The darkness map tile by tile (flat terrain); called by
    :func:`~nightlights.sky.darkness.darkness`, whose parameters these are (``output`` is
    already checked).

    Returns
    -------
    DarknessResult
        ``raster`` None when an ``output`` was written (the map is in the file), else the map
        in memory; ``tiles`` and ``reused_tiles`` count the tiles computed and taken from the
        store.

    Raises
    ------
    InputError
        A ``scheduler`` without an emission file, or without ``output=`` or ``store=`` for the
        tile store; no ``output=`` for a map too large to hold.
    """
    from nightlights.io.streamed import CogWriter
    from nightlights.sky import _tile_run
    from nightlights.sky._tile_run import TiledGrid, run_tiles
    from nightlights.sky._tiles import TileStore
    from nightlights.sky.tiled import (
        DEFAULT_TILE_SIZE,
        IMPORTED_MEMORY,
        _as_stored,
        _emission,
        _extent_metres,
        check_tiled_inputs,
        default_store,
        map_token,
        output_grid,
        tile_memory,
        tile_workers,
    )

    source = scene.raster_input("darkness")
    label = source_label(source, "emission raster")
    emission = _emission(source, label)
    check_tiled_inputs(emission)
    if not (math.isfinite(height) and height >= 0):
        raise InputError(f"height={height!r} m; expected a finite value >= 0")
    if scheduler is not None and emission.path is None:
        raise InputError(
            f"{label}: scheduler= needs the emission as a file its workers can read; give the "
            "scene a path"
        )
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise InputError(f"retries={retries!r}; expected a whole number >= 0")
    edge = DEFAULT_TILE_SIZE if chunk_size is None else _check_chunk_size(chunk_size)
    crs, transform, shape, cell = output_grid(emission, target_crs)
    local = emission.geographic or target_crs is not None
    reader = instrument_sky(
        instrument,
        spectrum=spectrum,
        natural_luminance=natural_luminance,
        emission=source,
        label=label,
    )
    functions, notes = band_emission_functions(source, emission.bands, label=label)
    width, depth = _extent_metres(emission)
    metres = CRS.from_epsg(3857)
    proxy = Raster(np.zeros((1, 1, 1)), Affine(width, 0, 0, 0, -depth, depth), metres)
    table, _ = scene.find_kernel(
        proxy,  # a 1-cell stand-in of the region's size in metres: its diagonal sets the range
        (0.0, depth),
        observer_altitudes=tuple(source_levels(np.array([height]))),
        source_altitudes=source_levels(np.zeros(1)),
        functions=functions,
        progress=progress is True,
    )
    start = time.perf_counter()
    levels = np.sort(np.asarray(table["source_altitude"].values, dtype=float))
    observer_levels = np.sort(np.asarray(table["observer_altitude"].values, dtype=float))
    offset = level_offset(np.zeros(1), None, levels)
    edges = np.asarray(table["distance_edges"].values, dtype=float)
    _warn_range((0.0, 0.0, width, depth), edges[-1])
    zenith, n_az, functions, notes = _zenith_tables(
        table, observer_levels, functions, notes, reader, emission.bands, label
    )
    radius = math.ceil(edges[-1] / cell)
    rows, cols = emission.shape
    half = (radius, radius) if local else (min(radius, rows - 1), min(radius, cols - 1))
    plan = _Plan(
        stencil=_Stencil(cell, edges, n_az, half),
        zenith=zenith,
        source_levels=levels,
        observer_levels=observer_levels,
        bands=emission.bands,
        terrain=False,
        flat_source=-offset,
        flat_eye=float(height - offset),
    )
    if emission.geographic and target_crs is None:  # the output is the emission's grid
        near_radius = _tile_run.NEAR_CELLS * cell
        share = _tile_run.near_taper(edges, near_radius)
        plan = replace(
            plan,
            zenith=zenith * (1.0 - share),
            near_zenith=zenith * share,
            near_radius=near_radius,
            edges=edges,
            n_az=n_az,
        )
    delay = _tile_run._TILE_DELAY  # a test's hook, read at call time
    grid = TiledGrid(emission, crs, transform, shape, local, cell, half, edge, delay)
    sizes = {"bands": emission.bands, "planes": levels.size * emission.bands}
    sizes["observer_levels"] = observer_levels.size
    per_tile = tile_memory(grid, **sizes, workers=1) - tile_memory(grid, **sizes, workers=0)
    workers = 1 if scheduler is not None else min(tile_workers(per_tile), len(grid.windows()))
    whole = 0.0 if output is not None else 32.0 * shape[0] * shape[1]
    # the process's peak less the interpreter and its modules, as every stage's estimate
    process = tile_memory(grid, **sizes, workers=workers) - IMPORTED_MEMORY
    check_memory(
        process + float(table.nbytes) + whole,
        f"the tiled darkness map of {shape[0]} x {shape[1]} cells",
        option="lower chunk_size=" if output is not None else "give output= (tiles stream there)",
    )
    location = store
    if location is None and scheduler is not None:
        if output is None:
            raise InputError(
                "scheduler= on the tiled map needs output= (its tile store goes beside it) "
                "or store="
            )
        location = default_store(output)
    tiles = None if location is None else TileStore(location, map_token(grid, plan))
    windows = grid.windows()
    layout = f"{len(windows)} tile(s) of {edge} cells" + (
        f", each on a local azimuthal equidistant grid of {cell:g} m" if local else ""
    )
    tags = _map_tags(
        label=label,
        functions=functions,
        notes=notes,
        table=table,
        observer_height=height,
        terrain="flat (0 m)",
        levels=levels,
        observer_levels=observer_levels,
        offset=offset,
        layout=layout,
        reader=reader,
    )
    _, descriptions, band_tags = _map_bands(reader, np.zeros((1, 1)))

    def run(write: Callable[[int, int, FloatArray], None]) -> tuple[int, int]:
        return run_tiles(
            grid,
            plan,
            write,
            store=tiles,
            resume=resume,
            scheduler=scheduler,
            workers=workers,
            retries=retries,
            progress=progress,
        )

    raster: Raster | None = None
    if output is not None:
        with CogWriter(
            output,
            shape=(2, *shape),
            transform=transform,
            crs=crs,
            descriptions=descriptions,
            units=("cd m-2", "mag arcsec-2"),
            band_tags=band_tags,
            tags=tags,
        ) as writer:

            def write(row: int, col: int, luminance: FloatArray) -> None:
                values = _as_stored(luminance)
                writer.write(_map_bands(reader, values)[0], row=row, col=col)

            computed, reused = run(write)
    else:
        luminance = np.zeros(shape)

        def keep(row: int, col: int, values: FloatArray) -> None:
            rows, cols = values.shape
            luminance[row : row + rows, col : col + cols] = _as_stored(values)

        computed, reused = run(keep)
        bands, _, _ = _map_bands(reader, luminance)
        raster = Raster(
            bands,
            transform,
            CRS.from_user_input(crs),
            descriptions=descriptions,
            units=("cd m-2", "mag arcsec-2"),
            tags=tags,
            band_tags=band_tags,
        )
    if tiles is not None and not keep_store:
        tiles.remove()
    return DarknessResult(
        raster,
        time.perf_counter() - start,
        output,
        None if reader is None else reader.instrument.name,
        tiles=computed,
        reused_tiles=reused,
    )
