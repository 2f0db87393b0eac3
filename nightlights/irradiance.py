"""Geo-referenced ground illuminance from luminaires (Chuang 2011, Secs. 4.3-5.1).

Each luminaire adds

.. math:: E = I(V, H)\\, \\max(0, \\cos\\beta) / d^2

at every pixel centre of the ground raster, where (V, H) are the photometric angles of the
direction from the light point to the pixel in the luminaire's frame
(:mod:`nightlights.luminaire`), :math:`\\beta` the angle of incidence on the ground (flat,
or the surface normal of a DEM) and :math:`d` the distance (Chuang 2011, Eq. 11). A sensor
band multiplies each luminaire's illuminance by its spectrum's sensor factor
:math:`k = \\int S R / (683 \\int S V)` (Chuang 2011, Eq. 10); the photopic band is the
illuminance itself [lx], any other band is sensor-weighted irradiance [W m-2].

Only pixels inside each luminaire's *region of influence* are evaluated: a disc around the
light point whose radius follows from the photometry and a threshold
(:class:`InfluenceThreshold`), evaluated on the pixels of its bounding square.
"""

from __future__ import annotations

import logging
import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import geopandas as gpd
import numpy as np
import pandas as pd
from numpy.typing import NDArray
from pyproj import CRS

from nightlights.errors import DataQualityWarning, EmptyInputError, InputError
from nightlights.io import RasterBand, ensure_projected, read_vector, write_cog
from nightlights.luminaire import (
    FluxProfile,
    IntensityTable,
    PhotometryLike,
    flux_profile,
    light_points,
    luminaire_rotation,
)
from nightlights.tiling import (
    RasterGrid,
    Tile,
    assign_to_tiles,
    compute_tiles,
    grid_from_bounds,
    make_tiles,
)

__all__ = [
    "InfluenceThreshold",
    "Luminaires",
    "ground_illuminance",
    "influence_radius",
    "irradiance",
    "resolve_luminaires",
    "sensor_factors",
]

logger = logging.getLogger(__name__)

#: Closest distance between a light point and a lit point, guarding 1/d^2 when a pixel
#: centre coincides with a light on the ground [m].
MIN_DISTANCE = 0.01

#: Light-pixel pairs evaluated per numpy batch (bounds memory to ~ 40 x this many bytes).
PAIRS_PER_BATCH = 1 << 20

#: Tilt, roll and street azimuth are rounded to this step when lights are grouped for their
#: flux profile (region of influence, uplight); 0.05 deg changes uplight by < 0.05 % [deg].
PROFILE_ANGLE_STEP = 0.1

#: Fields of the light layer read by the stage; missing or null values fall back to the
#: light system's defaults (``roll`` to 0).
LIGHT_OVERRIDES = ("mounting_height", "arm_length", "tilt")


# --------------------------------------------------------------------------------------
# Region of influence


@dataclass(frozen=True)
class InfluenceThreshold:
    """Threshold that sets each luminaire's region of influence.

    Attributes
    ----------
    kind
        ``"energy"``: the radius outside which at most ``value`` of the luminaire's
        downward flux lands on flat ground. ``"floor"``: the radius beyond which no azimuth
        reaches ``value`` lux on flat ground. ``"none"``: every pixel (the reference).
    value
        Flux fraction [1] for ``energy``, illuminance [lx] for ``floor``.
    max_radius
        Cap on the radius [m]; where it binds, the bound above no longer holds (logged).

    Notes
    -----
    The default, ``floor`` 0.01 lx, comes from ``benchmarks/bench_irradiance_roi.py``: at
    the density of a city (1,000 luminaires per km2, the bundled systems, 1 m pixels) it
    loses 0.3 % of the ground flux, with a mean pixel error of 0.03 lx and a largest pixel
    error of 0.08 lx, below full-moon illuminance (0.1-0.3 lx), against the all-pixels
    reference, at 1/17 of its light-pixel evaluations. Per evaluation it beats every
    ``energy`` setting, because dim luminaires get small regions and bright ones large. A
    single luminaire's pixel error outside its region is at most the floor (flat ground).
    """

    kind: Literal["energy", "floor", "none"] = "floor"
    value: float = 0.01
    max_radius: float = 1000.0

    def __post_init__(self) -> None:
        if self.kind not in ("energy", "floor", "none"):
            raise InputError(f"threshold kind {self.kind!r}; expected 'energy', 'floor' or 'none'")
        if self.kind == "energy" and not 0.0 < self.value < 1.0:
            raise InputError(f"energy threshold {self.value!r}; expected a fraction in (0, 1)")
        if self.kind == "floor" and not (math.isfinite(self.value) and self.value > 0):
            raise InputError(f"illuminance floor {self.value!r} lx; expected a positive number")
        if not self.max_radius > 0:
            raise InputError(f"max_radius={self.max_radius!r} m; expected a positive number")

    @classmethod
    def parse(cls, text: str, *, max_radius: float = 1000.0) -> InfluenceThreshold:
        """Parse ``energy:0.01``, ``floor:0.05`` or ``none``."""
        kind, _, value = text.partition(":")
        kind = kind.strip().lower()
        if kind == "none":
            return cls("none", 0.0, max_radius)
        try:
            number = float(value)
        except ValueError:
            raise InputError(
                f"threshold {text!r}; expected 'energy:FRACTION', 'floor:LUX' or 'none'"
            ) from None
        return cls(kind, number, max_radius)  # type: ignore[arg-type]


def influence_radius(
    profile: FluxProfile,
    mounting_height: NDArray[np.float64],
    threshold: InfluenceThreshold,
    *,
    intensity_scale: NDArray[np.float64] | float = 1.0,
) -> NDArray[np.float64]:
    """Region-of-influence radius of luminaires sharing one flux profile.

    Parameters
    ----------
    profile
        World-frame flux profile of the luminaire (photometry, tilt, roll).
    mounting_height
        Height of each light point above the ground [m].
    threshold
        Energy fraction or illuminance floor.
    intensity_scale
        Factor on the profile's intensity per light [1].

    Returns
    -------
    numpy.ndarray
        Horizontal radius around the light point [m]; ``inf`` for ``kind="none"``.

    Notes
    -----
    A direction at nadir angle :math:`\\theta` meets flat ground at :math:`r = h\\tan\\theta`
    with :math:`E = I\\cos^3\\theta / h^2`. *energy*: the smallest node :math:`\\theta_f` with
    :math:`\\Phi(\\theta_f) \\ge (1 - f)\\,\\Phi_\\downarrow`. *floor*: one node past the last
    :math:`\\theta` where the azimuthal peak :math:`\\max_\\phi I\\cos^3\\theta/h^2` reaches the
    floor. Both round outwards to the next node, so the bound holds on flat ground.

    References
    ----------
    Chuang 2011, Sec. 4.4 (a tight bounding region from a visibility threshold).
    """
    height = np.asarray(mounting_height, dtype=float)
    if threshold.kind == "none":
        return np.full(height.shape, np.inf)
    below = profile.nadir_angle < 90.0
    theta = profile.nadir_angle[below]
    if threshold.kind == "energy":
        downward = profile.downward_flux
        if downward <= 0:
            return np.zeros(height.shape)
        target = (1.0 - threshold.value) * downward
        index = int(np.searchsorted(profile.cumulative_flux, target, side="left"))
        theta_limit = np.full(height.shape, profile.nadir_angle[min(index, len(theta))])
    else:
        cos3 = np.cos(np.radians(theta)) ** 3
        envelope = profile.peak_intensity[below][None, :] * cos3[None, :]
        scale = np.broadcast_to(np.asarray(intensity_scale, dtype=float), height.shape)
        reaches = envelope * scale[:, None] >= threshold.value * height[:, None] ** 2
        last = np.where(reaches.any(axis=1), len(theta) - 1 - np.argmax(reaches[:, ::-1], 1), -1)
        theta_limit = np.where(last < 0, 0.0, profile.nadir_angle[np.minimum(last + 1, len(theta))])
    with np.errstate(over="ignore"):
        radius = np.where(
            theta_limit >= 90.0,
            np.inf,
            height * np.tan(np.radians(np.minimum(theta_limit, 89.999))),
        )
    capped = radius > threshold.max_radius
    if capped.any():
        logger.info(
            "%d luminaires: region of influence capped at %g m", capped.sum(), threshold.max_radius
        )
    return np.minimum(radius, threshold.max_radius)


# --------------------------------------------------------------------------------------
# Kernel


def ground_illuminance(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: NDArray[np.float64],
    rotation: NDArray[np.float64],
    street_azimuth: NDArray[np.float64],
    table_index: NDArray[np.intp],
    tables: Sequence[IntensityTable],
    weights: NDArray[np.float64],
    *,
    radius: NDArray[np.float64] | None = None,
    ground_z: NDArray[np.float64] | None = None,
    normals: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Weighted illuminance of point luminaires on a raster window (pure numpy).

    Parameters
    ----------
    shape
        (rows, cols) of the window [pixels].
    origin
        (x, y) of the centre of the window's top-left pixel [m]; rows run south.
    resolution
        Pixel size [m].
    light_point
        Light points (n, 3) [m].
    rotation
        Body-to-world rotations (n, 3, 3) from :func:`~nightlights.luminaire.luminaire_rotation`.
    street_azimuth
        C-plane facing the street per light (n,) [deg].
    table_index
        Index into ``tables`` per light (n,).
    tables
        Candela tables [cd].
    weights
        Band weights (n, bands): the illuminance of light i enters band b times
        ``weights[i, b]`` (1 for photopic lux, the sensor factor for other bands) [band unit
        per lx].
    radius
        Region-of-influence radius per light; ``None`` evaluates every pixel [m].
    ground_z
        Ground elevation at the pixel centres (rows, cols); ``None`` for flat ground at z=0
        [m].
    normals
        Unit surface normals (rows, cols, 3); ``None`` for (0, 0, 1) [1].

    Returns
    -------
    numpy.ndarray
        Array (bands, rows, cols) [band units].

    References
    ----------
    Chuang 2011, Sec. 5.1, Eq. 11 (with luminous intensity in place of radiant energy).
    """
    values, _ = _illuminance_and_pairs(
        shape,
        origin,
        resolution,
        light_point,
        rotation,
        street_azimuth,
        table_index,
        tables,
        weights,
        radius=radius,
        ground_z=ground_z,
        normals=normals,
    )
    return values


def _illuminance_and_pairs(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: NDArray[np.float64],
    rotation: NDArray[np.float64],
    street_azimuth: NDArray[np.float64],
    table_index: NDArray[np.intp],
    tables: Sequence[IntensityTable],
    weights: NDArray[np.float64],
    *,
    radius: NDArray[np.float64] | None = None,
    ground_z: NDArray[np.float64] | None = None,
    normals: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], int]:
    rows, cols = shape
    n_bands = weights.shape[1]
    out = np.zeros((n_bands, rows * cols))
    n = len(light_point)
    if n == 0 or rows == 0 or cols == 0:
        return out.reshape(n_bands, rows, cols), 0
    segments = _disc_segments(shape, origin, resolution, light_point, radius)
    pairs = 0
    for table_id in np.unique(table_index):
        chosen = table_index[segments.light] == table_id
        for batch in _batches(np.flatnonzero(chosen), segments.length[chosen]):
            pairs += _accumulate(
                out,
                _Segments(
                    segments.light[batch],
                    segments.row[batch],
                    segments.col0[batch],
                    segments.length[batch],
                ),
                cols,
                (origin[0], origin[1], resolution),
                light_point,
                rotation,
                street_azimuth,
                tables[table_id],
                weights,
                ground_z,
                normals,
            )
    return out.reshape(n_bands, rows, cols), pairs


@dataclass(frozen=True)
class _Segments:
    """Runs of pixels in one row lit by one light: light index, row, first column, length."""

    light: NDArray[np.intp]
    row: NDArray[np.int64]
    col0: NDArray[np.int64]
    length: NDArray[np.int64]


def _disc_segments(
    shape: tuple[int, int],
    origin: tuple[float, float],
    resolution: float,
    light_point: NDArray[np.float64],
    radius: NDArray[np.float64] | None,
) -> _Segments:
    """Pixel-centre runs inside each light's region-of-influence disc, clipped to the window."""
    rows, cols = shape
    x0, y0 = origin
    n = len(light_point)
    r = np.full(n, np.inf) if radius is None else np.asarray(radius, dtype=float)
    lx, ly = light_point[:, 0], light_point[:, 1]
    with np.errstate(invalid="ignore"):
        r0 = np.clip(np.ceil((y0 - (ly + r)) / resolution), 0, rows).astype(np.int64)
        r1 = np.clip(np.floor((y0 - (ly - r)) / resolution) + 1, 0, rows).astype(np.int64)
    n_rows = np.maximum(r1 - r0, 0)
    light = np.repeat(np.arange(n), n_rows)
    row = r0[light] + (np.arange(n_rows.sum()) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows))
    dy = (y0 - row * resolution) - ly[light]
    with np.errstate(invalid="ignore"):
        half = np.sqrt(np.maximum(r[light] ** 2 - dy * dy, 0.0))
        half = np.where(np.isinf(r[light]), np.inf, half)
        col0 = np.clip(np.ceil((lx[light] - half - x0) / resolution), 0, cols).astype(np.int64)
        col1 = np.clip(np.floor((lx[light] + half - x0) / resolution) + 1, 0, cols)
    length = np.maximum(col1.astype(np.int64) - col0, 0)
    keep = length > 0
    return _Segments(light[keep], row[keep], col0[keep], length[keep])


def _batches(members: NDArray[np.intp], counts: NDArray[np.int64]) -> list[NDArray[np.intp]]:
    if len(members) == 0:
        return []
    group = np.cumsum(counts) // PAIRS_PER_BATCH
    splits = np.flatnonzero(np.diff(group)) + 1
    return np.split(members, splits)


def _accumulate(
    out: NDArray[np.float64],
    segments: _Segments,
    cols: int,
    grid: tuple[float, float, float],
    point: NDArray[np.float64],
    rotation: NDArray[np.float64],
    street_azimuth: NDArray[np.float64],
    table: IntensityTable,
    weights: NDArray[np.float64],
    ground_z: NDArray[np.float64] | None,
    normals: NDArray[np.float64] | None,
) -> int:
    x0, y0, resolution = grid
    total = int(segments.length.sum())
    segment = np.repeat(np.arange(len(segments.length)), segments.length)
    col = segments.col0[segment] + (
        np.arange(total) - np.repeat(np.cumsum(segments.length) - segments.length, segments.length)
    )
    row = segments.row[segment]
    pair = segments.light[segment]
    pixel = row * cols + col
    # Offsets per light (small numbers), then per pixel.
    dx = (x0 - point[:, 0])[pair] + col * resolution
    dy = (y0 - point[:, 1])[pair] - row * resolution
    dz = -point[pair, 2] if ground_z is None else ground_z.ravel()[pixel] - point[pair, 2]
    # Body coordinates b = R^T d (right, forward, up); Chuang 2011, Eq. 5.
    planar = np.abs(rotation[:, 2, 2] - 1.0) <= 1e-15
    if np.all(planar[segments.light]):
        bx = rotation[:, 0, 0][pair] * dx + rotation[:, 1, 0][pair] * dy
        by = rotation[:, 0, 1][pair] * dx + rotation[:, 1, 1][pair] * dy
        bz = dz
    else:
        column = [[np.ascontiguousarray(rotation[:, i, j]) for j in range(3)] for i in range(3)]
        bx = column[0][0][pair] * dx + column[1][0][pair] * dy + column[2][0][pair] * dz
        by = column[0][1][pair] * dx + column[1][1][pair] * dy + column[2][1][pair] * dz
        bz = column[0][2][pair] * dx + column[1][2][pair] * dy + column[2][2][pair] * dz
    d2 = np.maximum(dx * dx + dy * dy + dz * dz, MIN_DISTANCE**2)
    inv_d = 1.0 / np.sqrt(d2)
    vertical = np.degrees(np.arccos(np.clip(-bz * inv_d, -1.0, 1.0)))
    horizontal = np.degrees(np.arctan2(-bx, by)) + street_azimuth[pair]
    horizontal -= 360.0 * np.floor(horizontal * (1.0 / 360.0))
    intensity = table.lookup(vertical, horizontal)
    if normals is None:
        cos_incidence = -dz * inv_d
    else:
        flat_normals = normals.reshape(-1, 3)
        cos_incidence = (
            -(
                flat_normals[pixel, 0] * dx
                + flat_normals[pixel, 1] * dy
                + flat_normals[pixel, 2] * dz
            )
            * inv_d
        )
    illuminance = intensity * np.maximum(cos_incidence, 0.0) * (inv_d * inv_d)
    for band in range(out.shape[0]):
        band_weight = weights[:, band]
        values = illuminance if np.all(band_weight == 1.0) else illuminance * band_weight[pair]
        out[band] += np.bincount(pixel, weights=values, minlength=out.shape[1])
    return total


# --------------------------------------------------------------------------------------
# Luminaires from a light layer


class LightSystemLike(Protocol):
    """What the stage reads from :class:`ies.library.LightSystem`."""

    @property
    def mounting_height(self) -> float: ...

    @property
    def arm_length(self) -> float: ...

    @property
    def tilt(self) -> float: ...

    @property
    def street_azimuth(self) -> float: ...

    @property
    def spd(self) -> str: ...


class DatabaseLike(Protocol):
    """What the stage reads from :class:`ies.library.LuminaireDatabase`."""

    def get(self, system_id: str) -> LightSystemLike: ...

    def photometry(self, system_id: str) -> PhotometryLike: ...


@dataclass(frozen=True, eq=False)
class Luminaires:
    """Point luminaires ready for the kernel, one row per light.

    Attributes
    ----------
    light_id
        Identifier per light (n,).
    light_point
        Photometric centres (n, 3) [m].
    rotation
        Body-to-world rotations (n, 3, 3).
    street_azimuth
        C-plane facing the street (n,) [deg].
    mounting_height
        Light point above the ground at the pole (n,) [m].
    tilt, roll
        Mounting rotations (n,) [deg].
    table_index
        Index into ``tables`` (n,).
    intensity_scale
        Factor applied to the table's candela (n,) [1].
    tables
        Candela tables, one per light system (or area-source model).
    spectra
        Spectrum name per table (``None`` where unknown).
    names
        Light system id per table.
    influence_scale
        Intensity factor used for ``floor`` regions of influence (n,); default
        ``intensity_scale``. Pseudo-lights of one area source carry the whole source's flux
        here, so that the floor bounds the sum of their tails, not each piece's [1].
    """

    light_id: NDArray[np.int64]
    light_point: NDArray[np.float64]
    rotation: NDArray[np.float64]
    street_azimuth: NDArray[np.float64]
    mounting_height: NDArray[np.float64]
    tilt: NDArray[np.float64]
    roll: NDArray[np.float64]
    table_index: NDArray[np.intp]
    intensity_scale: NDArray[np.float64]
    tables: tuple[IntensityTable, ...]
    spectra: tuple[str | None, ...]
    names: tuple[str, ...]
    influence_scale: NDArray[np.float64] | None = None
    profiles: dict[tuple[int, float, float, float], FluxProfile] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.light_id)

    def flux_profile(self, index: int) -> FluxProfile:
        """World-frame flux profile of light ``index``, cached per table and rounded angles."""
        tilt, roll, azimuth = (
            float(np.round(value[index] / PROFILE_ANGLE_STEP) * PROFILE_ANGLE_STEP)
            for value in (self.tilt, self.roll, self.street_azimuth)
        )
        key = (int(self.table_index[index]), tilt, roll, azimuth)
        if key not in self.profiles:
            self.profiles[key] = flux_profile(
                self.tables[key[0]], tilt=key[1], roll=key[2], street_azimuth=key[3]
            )
        return self.profiles[key]

    def profile_groups(self) -> list[tuple[FluxProfile, NDArray[np.intp]]]:
        """Lights grouped by identical flux profile: (profile per unit scale, indices)."""
        angles = np.stack([self.tilt, self.roll, self.street_azimuth], axis=1)
        keys = np.column_stack(
            [self.table_index.astype(float), np.round(angles / PROFILE_ANGLE_STEP)]
        )
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
        return [
            (self.flux_profile(int(index)), np.flatnonzero(inverse == group))
            for group, index in enumerate(first)
        ]

    def radius(self, threshold: InfluenceThreshold) -> NDArray[np.float64]:
        """Region-of-influence radius per light [m]."""
        radius = np.zeros(len(self))
        for profile, members in self.profile_groups():
            radius[members] = influence_radius(
                profile,
                self.mounting_height[members],
                threshold,
                intensity_scale=self.roi_scale[members],
            )
        return radius

    @property
    def roi_scale(self) -> NDArray[np.float64]:
        """Intensity factor of the region of influence per light [1]."""
        return self.intensity_scale if self.influence_scale is None else self.influence_scale

    def upward_flux(self) -> NDArray[np.float64]:
        """Direct uplight of each light in the world frame (after tilt and roll) [lm]."""
        flux = np.zeros(len(self))
        for profile, members in self.profile_groups():
            flux[members] = profile.upward_flux * self.intensity_scale[members]
        return flux

    def downward_flux(self) -> NDArray[np.float64]:
        """Flux below the horizontal of each light in the world frame [lm]."""
        flux = np.zeros(len(self))
        for profile, members in self.profile_groups():
            flux[members] = profile.downward_flux * self.intensity_scale[members]
        return flux

    def subset(self, keep: NDArray[np.bool_]) -> Luminaires:
        """The lights where ``keep`` is true."""
        return Luminaires(
            self.light_id[keep],
            self.light_point[keep],
            self.rotation[keep],
            self.street_azimuth[keep],
            self.mounting_height[keep],
            self.tilt[keep],
            self.roll[keep],
            self.table_index[keep],
            self.intensity_scale[keep],
            self.tables,
            self.spectra,
            self.names,
            self.roi_scale[keep],
            self.profiles,
        )

    @staticmethod
    def concatenate(parts: Sequence[Luminaires]) -> Luminaires:
        """Join luminaire sets, renumbering their tables."""
        offsets = np.cumsum([0] + [len(part.tables) for part in parts[:-1]])
        return Luminaires(
            np.concatenate([p.light_id for p in parts]),
            np.concatenate([p.light_point for p in parts]).reshape(-1, 3),
            np.concatenate([p.rotation for p in parts]).reshape(-1, 3, 3),
            np.concatenate([p.street_azimuth for p in parts]),
            np.concatenate([p.mounting_height for p in parts]),
            np.concatenate([p.tilt for p in parts]),
            np.concatenate([p.roll for p in parts]),
            np.concatenate([p.table_index + o for p, o in zip(parts, offsets, strict=True)]),
            np.concatenate([p.intensity_scale for p in parts]),
            tuple(t for p in parts for t in p.tables),
            tuple(s for p in parts for s in p.spectra),
            tuple(s for p in parts for s in p.names),
            np.concatenate([p.roi_scale for p in parts]),
        )


def load_database(catalog: str | os.PathLike[str] | None) -> DatabaseLike:
    """The luminaire database of the ``ies`` package (bundled, or the folder ``catalog``)."""
    from ies.library import load_library

    return load_library(catalog)


def resolve_luminaires(
    lights: gpd.GeoDataFrame,
    database: DatabaseLike,
    *,
    source: str = "lights",
    skip_unknown: bool = False,
    ground_elevation: NDArray[np.float64] | None = None,
) -> Luminaires:
    """Turn a light layer into kernel-ready luminaires.

    Parameters
    ----------
    lights
        Point layer with ``system_id`` and ``heading`` [deg]; optional ``light_id``,
        ``mounting_height`` [m], ``arm_length`` [m], ``tilt`` [deg], ``roll`` [deg]. Null or
        missing values of the optional fields fall back to the light system's defaults.
    database
        Luminaire database with ``get(system_id)`` and ``photometry(system_id)``.
    source
        Name of the layer for messages.
    skip_unknown
        Drop lights whose ``system_id`` is null or unknown (with a
        :class:`~nightlights.errors.DataQualityWarning`) instead of raising.
    ground_elevation
        Ground elevation at each pole foot (n,) [m]; default 0.

    Raises
    ------
    InputError
        Missing fields, unknown system ids (naming the light ids), non-point geometry,
        non-positive mounting heights.
    """
    frame = lights.reset_index(drop=True)
    ids = (
        frame["light_id"].to_numpy()
        if "light_id" in frame
        else np.arange(len(frame), dtype=np.int64)
    )
    for name in ("system_id", "heading"):
        if name not in frame:
            raise InputError(f"{source}: the light layer has no field {name!r}")
    bad_geometry = frame.geometry.isna() | (frame.geometry.geom_type != "Point")
    if bad_geometry.any():
        raise InputError(
            f"{source}: lights {_ids(ids[bad_geometry.to_numpy()])} are not points; "
            "expected one point per pole foot"
        )
    system_ids = frame["system_id"]
    known: dict[str, LightSystemLike] = {}
    unknown = np.zeros(len(frame), dtype=bool)
    for position, system_id in enumerate(system_ids):
        if system_id is None or (isinstance(system_id, float) and math.isnan(system_id)):
            unknown[position] = True
            continue
        if system_id not in known:
            try:
                known[system_id] = database.get(str(system_id))
            except (KeyError, LookupError, ValueError):
                known[system_id] = None  # type: ignore[assignment]
        unknown[position] = known[system_id] is None
    if unknown.any():
        message = (
            f"{source}: lights {_ids(ids[unknown])} have no or an unknown system_id "
            f"({sorted({str(s) for s in system_ids[unknown]})})"
        )
        if not skip_unknown:
            raise InputError(message + "; fix them or pass --skip-unknown to drop them")
        warnings.warn(message + "; dropped", DataQualityWarning, stacklevel=2)
        frame = frame.loc[~unknown].reset_index(drop=True)
        ids = ids[~unknown]
        if ground_elevation is not None:
            ground_elevation = np.asarray(ground_elevation)[~unknown]
    names = tuple(sorted({str(s) for s in frame["system_id"]}))
    systems = [known[name] for name in names]
    table_index = np.searchsorted(np.array(names, dtype=object), frame["system_id"].to_numpy())
    values: dict[str, NDArray[np.float64]] = {}
    for name in (*LIGHT_OVERRIDES, "street_azimuth"):
        default = np.array([float(getattr(system, name)) for system in systems])[table_index]
        given = (
            pd.to_numeric(frame[name], errors="coerce").to_numpy(float)
            if name in frame and name != "street_azimuth"
            else np.full(len(frame), np.nan)
        )
        values[name] = np.where(np.isnan(given), default, given)
    heading = pd.to_numeric(frame["heading"], errors="coerce").to_numpy(float)
    roll = (
        pd.to_numeric(frame["roll"], errors="coerce").fillna(0.0).to_numpy(float)
        if "roll" in frame
        else np.zeros(len(frame))
    )
    if np.isnan(heading).any():
        raise InputError(f"{source}: lights {_ids(ids[np.isnan(heading)])} have no heading")
    height = values["mounting_height"]
    if (bad := ~(height > 0)).any():
        raise InputError(
            f"{source}: lights {_ids(ids[bad])} have mounting_height {height[bad][:5]} m; "
            "expected > 0"
        )
    ground = np.zeros(len(frame)) if ground_elevation is None else np.asarray(ground_elevation)
    points = light_points(
        frame.geometry.x.to_numpy(),
        frame.geometry.y.to_numpy(),
        heading,
        mounting_height=height,
        arm_length=values["arm_length"],
        ground_z=ground,
    )
    tables = tuple(IntensityTable.from_photometry(database.photometry(name)) for name in names)
    return Luminaires(
        light_id=np.asarray(ids, dtype=np.int64),
        light_point=points.reshape(-1, 3),
        rotation=luminaire_rotation(heading, values["tilt"], roll).reshape(-1, 3, 3),
        street_azimuth=values["street_azimuth"],
        mounting_height=height,
        tilt=values["tilt"],
        roll=roll,
        table_index=table_index.astype(np.intp),
        intensity_scale=np.ones(len(frame)),
        tables=tables,
        spectra=tuple(getattr(system, "spd", None) for system in systems),
        names=names,
    )


def _ids(ids: NDArray[Any], limit: int = 10) -> str:
    listed = ", ".join(str(i) for i in ids[:limit])
    return f"[{listed}{', ...' if len(ids) > limit else ''}] ({len(ids)} in all)"


def sensor_factors(
    spectra: Sequence[str | None],
    sensors: Sequence[str],
    *,
    names: Sequence[str] | None = None,
) -> NDArray[np.float64]:
    """Band weight per spectrum and sensor: 1 for photopic, else k [W m-2 lx-1].

    Parameters
    ----------
    spectra
        Spectrum names (``ies.spectra``) per light system.
    sensors
        Sensor names (``ies.spectra.SENSORS``).
    names
        Light system names per spectrum, for messages.

    Returns
    -------
    numpy.ndarray
        Array (n_spectra, n_sensors).

    References
    ----------
    Chuang 2011, Sec. 5.1, Eq. 10: :math:`k = \\int S R\\,d\\lambda / (683 \\int S V\\,d\\lambda)`.
    """
    factors = np.ones((len(spectra), len(sensors)))
    for j, sensor in enumerate(sensors):
        if sensor == "photopic":
            continue
        from ies import spectra as ies_spectra

        if sensor not in ies_spectra.SENSORS:
            raise InputError(
                f"sensor {sensor!r} is unknown; expected one of {sorted(ies_spectra.SENSORS)}"
            )
        for i, spectrum in enumerate(spectra):
            if spectrum is None:
                who = names[i] if names is not None else f"number {i}"
                hint = " (name one with --area-spectrum)" if who == "area_source" else ""
                raise InputError(
                    f"sensor {sensor!r} needs a spectrum, but light system {who} has none{hint}"
                )
            factors[i, j] = float(ies_spectra.sensor_factor(spectrum, sensor))
    return factors


def band_unit(sensor: str) -> str:
    """Unit of a sensor band: ``lx`` for photopic, ``W m-2`` otherwise."""
    return "lx" if sensor == "photopic" else "W m-2"


# --------------------------------------------------------------------------------------
# Stage


@dataclass(frozen=True)
class IrradianceResult:
    """What :func:`irradiance` wrote.

    Attributes
    ----------
    path
        Output raster.
    grid
        Its grid.
    crs
        Its CRS.
    n_lights
        Luminaires (including area pseudo-lights) that light at least one pixel.
    n_pairs
        Light-pixel evaluations [1].
    """

    path: str
    grid: RasterGrid
    crs: CRS
    n_lights: int
    n_pairs: int


def irradiance(
    lights_path: str | os.PathLike[str],
    out_path: str | os.PathLike[str],
    *,
    resolution: float,
    sensors: Sequence[str] = ("photopic",),
    bounds: Sequence[float] | None = None,
    margin: float | None = None,
    catalog: str | os.PathLike[str] | None = None,
    database: DatabaseLike | None = None,
    dem: str | os.PathLike[str] | None = None,
    threshold: InfluenceThreshold | None = None,
    area_sources: str | os.PathLike[str] | None = None,
    exitance_field: str = "exitance",
    area_options: Any = None,
    skip_unknown: bool = False,
    assume_crs: str | None = None,
    scheduler: str | Any | None = None,
    tile_size: int = 1024,
    progress: bool = True,
) -> IrradianceResult:
    """Stage ``irradiance``: light layer -> ground illuminance COG, one band per sensor.

    Parameters
    ----------
    lights_path
        Point layer of ``streets place`` (projected CRS; geographic input is reprojected to
        its UTM zone).
    out_path
        Output float32 COG.
    resolution
        Pixel size [m].
    sensors
        Band per sensor, ``photopic`` gives illuminance [lx], others sensor-weighted
        irradiance [W m-2].
    bounds
        (xmin, ymin, xmax, ymax) in the lights' CRS [m]; default the lights' extent grown by
        ``margin``.
    margin
        Growth of the default extent [m]; default the largest region-of-influence radius.
    catalog
        Luminaire database folder; default the bundled one.
    database
        A database object (overrides ``catalog``).
    dem
        Elevation raster [m] for ground height and surface normals; default flat z=0.
    threshold
        Region of influence (default :class:`InfluenceThreshold`).
    area_sources
        Polygon layer of area sources (see :mod:`nightlights.area_lights`).
    exitance_field
        Field of ``area_sources`` holding luminous exitance [lm m-2].
    area_options
        :class:`nightlights.area_lights.AreaLightOptions`.
    skip_unknown
        Drop lights with unknown system ids instead of failing.
    assume_crs
        CRS of a light layer that has none.
    scheduler
        ``dask.distributed`` address or Client; default local threads.
    tile_size
        Tile edge [pixels].
    progress
        Show a progress bar.

    Notes
    -----
    Lights outside the raster still contribute where their region of influence reaches
    into it; lights whose region does not touch the raster are ignored, with a
    :class:`~nightlights.errors.DataQualityWarning` giving their number.
    """
    threshold = threshold or InfluenceThreshold()
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise InputError(f"resolution={resolution!r} m; expected a positive number of metres")
    if not sensors:
        raise InputError("no sensors requested; expected at least one (e.g. photopic)")
    frame = read_vector(lights_path)
    frame = ensure_projected(frame, source=str(lights_path), assume_crs=assume_crs)
    crs = CRS.from_user_input(frame.crs)
    if frame.empty and area_sources is None:
        raise EmptyInputError(f"{lights_path}: the light layer holds no lights")
    parts: list[Luminaires] = []
    if not frame.empty:
        database = database or load_database(catalog)
        ground_at_pole = None
        if dem is not None:
            ground_at_pole = sample_elevation(dem, frame, source=str(lights_path))
        parts.append(
            resolve_luminaires(
                frame,
                database,
                source=str(lights_path),
                skip_unknown=skip_unknown,
                ground_elevation=ground_at_pole,
            )
        )
    if area_sources is not None:
        from nightlights.area_lights import AreaLightOptions, read_area_lights

        parts.append(
            read_area_lights(
                area_sources,
                exitance_field=exitance_field,
                crs=crs,
                options=area_options or AreaLightOptions(),
                dem=dem,
            )
        )
    luminaires = Luminaires.concatenate(parts) if len(parts) > 1 else parts[0]
    if len(luminaires) == 0:
        raise EmptyInputError(f"{lights_path}: no usable lights remain")
    radius = luminaires.radius(threshold)
    weights = sensor_factors(luminaires.spectra, sensors, names=luminaires.names)
    weights = weights[luminaires.table_index]
    weights = weights * luminaires.intensity_scale[:, None]
    if bounds is None:
        reach = float(np.max(radius)) if margin is None else float(margin)
        if not math.isfinite(reach):
            raise InputError("threshold 'none' gives unbounded regions: name --bounds or --margin")
        x, y = luminaires.light_point[:, 0], luminaires.light_point[:, 1]
        bounds = (x.min() - reach, y.min() - reach, x.max() + reach, y.max() + reach)
        bounds = (
            *bounds[:2],
            max(bounds[2], bounds[0] + resolution),
            max(bounds[3], bounds[1] + resolution),
        )
    grid = grid_from_bounds(bounds, resolution)
    ground_z = normals = None
    if dem is not None:
        ground_z, normals = ground_on_grid(dem, grid, crs)
    result = compute_irradiance(
        grid,
        luminaires,
        weights,
        radius,
        ground_z=ground_z,
        normals=normals,
        scheduler=scheduler,
        tile_size=tile_size,
        progress=progress,
    )
    bands = [
        RasterBand(
            result.bands[index].astype(np.float32),
            sensor,
            band_unit(sensor),
            {
                "sensor": sensor,
                "quantity": "illuminance" if sensor == "photopic" else "sensor-weighted irradiance",
            },
        )
        for index, sensor in enumerate(sensors)
    ]
    write_cog(
        out_path,
        bands,
        transform=grid.transform,
        crs=crs,
        tags={
            "nightlights_stage": "irradiance",
            "resolution_m": resolution,
            "threshold": f"{threshold.kind}:{threshold.value}",
            "max_radius_m": threshold.max_radius,
            "lights": len(luminaires),
            "light_pixel_evaluations": result.n_pairs,
            "reference": "Chuang 2011, Sec. 5.1, Eq. 11",
        },
    )
    return IrradianceResult(str(out_path), grid, crs, result.n_lights, result.n_pairs)


@dataclass(frozen=True)
class _Computed:
    bands: NDArray[np.float32]
    n_lights: int
    n_pairs: int


def compute_irradiance(
    grid: RasterGrid,
    luminaires: Luminaires,
    weights: NDArray[np.float64],
    radius: NDArray[np.float64],
    *,
    ground_z: NDArray[np.float64] | None = None,
    normals: NDArray[np.float64] | None = None,
    scheduler: str | Any | None = None,
    tile_size: int = 1024,
    num_workers: int | None = None,
    progress: bool = True,
) -> _Computed:
    """Tile ``grid``, bin lights to tiles, run :func:`ground_illuminance` per tile with Dask.

    Parameters
    ----------
    grid
        Output grid.
    luminaires
        Lights.
    weights
        Band weights per light (n, bands) [band unit per lx].
    radius
        Region of influence per light [m].
    ground_z, normals
        Ground on the full grid (see :func:`ground_illuminance`) [m], [1].
    scheduler
        ``None`` (local threads) or a ``dask.distributed`` address/Client.
    tile_size
        Tile edge [pixels].
    num_workers
        Local threads (default one per core).
    progress
        Show a progress bar.
    """
    x, y = luminaires.light_point[:, 0], luminaires.light_point[:, 1]
    finite_radius = np.where(
        np.isfinite(radius), radius, 2.0 * (grid.rows + grid.cols) * grid.resolution
    )
    tiles = make_tiles(grid, tile_size)
    members = assign_to_tiles(grid, tile_size, x, y, finite_radius)
    touching = np.zeros(len(luminaires), dtype=bool)
    for index in members:
        touching[index] = True
    if (~touching).any():
        warnings.warn(
            f"{(~touching).sum()} of {len(luminaires)} lights light no pixel of the raster "
            f"(ids {_ids(luminaires.light_id[~touching])}); ignored",
            DataQualityWarning,
            stacklevel=3,
        )
    per_tile = []
    for tile, index in zip(tiles, members, strict=True):
        rows, cols = tile.slices
        per_tile.append(
            (
                tile,
                luminaires.light_point[index],
                luminaires.rotation[index],
                luminaires.street_azimuth[index],
                luminaires.table_index[index],
                weights[index],
                finite_radius[index],
                None if ground_z is None else ground_z[rows, cols],
                None if normals is None else normals[rows, cols],
            )
        )
    shared = (grid, luminaires.tables)
    results = compute_tiles(
        _irradiance_tile,
        per_tile,
        shared=shared,
        scheduler=scheduler,
        num_workers=num_workers,
        description=f"irradiance: {len(tiles)} tiles",
        progress=progress,
    )
    bands = np.zeros((weights.shape[1], grid.rows, grid.cols), dtype=np.float32)
    n_pairs = 0
    for tile, (values, pairs) in zip(tiles, results, strict=True):
        rows, cols = tile.slices
        bands[:, rows, cols] = values
        n_pairs += pairs
    return _Computed(bands, int(touching.sum()), n_pairs)


def _irradiance_tile(
    tile: Tile,
    light_point: NDArray[np.float64],
    rotation: NDArray[np.float64],
    street_azimuth: NDArray[np.float64],
    table_index: NDArray[np.intp],
    weights: NDArray[np.float64],
    radius: NDArray[np.float64],
    ground_z: NDArray[np.float64] | None,
    normals: NDArray[np.float64] | None,
    shared: tuple[RasterGrid, tuple[IntensityTable, ...]],
) -> tuple[NDArray[np.float32], int]:
    grid, tables = shared
    x, y = grid.centres(tile)
    values, pairs = _illuminance_and_pairs(
        (tile.rows, tile.cols),
        (float(x[0]), float(y[0])),
        grid.resolution,
        light_point,
        rotation,
        street_azimuth,
        table_index,
        tables,
        weights,
        radius=radius,
        ground_z=ground_z,
        normals=normals,
    )
    return values.astype(np.float32), pairs


# --------------------------------------------------------------------------------------
# Terrain


def sample_elevation(
    dem: str | os.PathLike[str], points: gpd.GeoDataFrame, *, source: str = "lights"
) -> NDArray[np.float64]:
    """Ground elevation at point features from a DEM (nearest pixel) [m].

    Raises
    ------
    InputError
        The DEM cannot be read, or a point falls on nodata or outside it (naming the points).
    """
    import rasterio

    try:
        with rasterio.open(dem) as dataset:
            frame = points if dataset.crs is None else points.to_crs(dataset.crs.to_wkt())
            coords = list(zip(frame.geometry.x, frame.geometry.y, strict=True))
            values = np.array([v[0] for v in dataset.sample(coords, masked=True)], dtype=object)
            inside = np.array(
                [
                    0 <= r < dataset.height and 0 <= c < dataset.width
                    for r, c in (dataset.index(x, y) for x, y in coords)
                ],
                dtype=bool,
            )
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{dem}: cannot read the DEM: {exc}") from exc
    elevation = np.array([np.nan if v is np.ma.masked else float(v) for v in values])
    bad = ~inside | np.isnan(elevation)
    if bad.any():
        ids = points["light_id"].to_numpy() if "light_id" in points else np.flatnonzero(bad)
        raise InputError(
            f"{dem}: {source} features {_ids(ids[bad] if 'light_id' in points else ids)} "
            "fall outside the DEM or on nodata"
        )
    return elevation


def ground_on_grid(
    dem: str | os.PathLike[str], grid: RasterGrid, crs: CRS
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """DEM resampled (bilinear) to ``grid`` and its unit surface normals.

    Returns
    -------
    elevation : numpy.ndarray
        (rows, cols) [m].
    normals : numpy.ndarray
        (rows, cols, 3) unit normals, z up [1].

    Raises
    ------
    InputError
        The DEM does not cover the grid.
    """
    import rasterio
    from rasterio.warp import Resampling, reproject

    elevation = np.full((grid.rows, grid.cols), np.nan)
    try:
        with rasterio.open(dem) as dataset:
            reproject(
                rasterio.band(dataset, 1),
                elevation,
                dst_transform=grid.transform,
                dst_crs=crs.to_wkt(),
                dst_nodata=np.nan,
                resampling=Resampling.bilinear,
            )
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{dem}: cannot read the DEM: {exc}") from exc
    if np.isnan(elevation).any():
        raise InputError(
            f"{dem}: the DEM leaves {np.isnan(elevation).sum()} pixels of the output grid "
            f"{grid.bounds} without elevation; expected it to cover the whole raster"
        )
    slope_row, slope_col = np.gradient(elevation, grid.resolution)
    # rows run south: dz/dy = -dz/drow.
    normals = np.stack([-slope_col, slope_row, np.ones_like(elevation)], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    return elevation, normals
