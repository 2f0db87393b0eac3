"""Luminaires from a light layer: kernel-ready arrays, the luminaire database, sensor bands.

:func:`resolve_luminaires` turns a point layer of poles (``system_id``, ``heading`` and
optional mounting overrides) into :class:`Luminaires`: light points, body-to-world
rotations (:mod:`nightlights.ground.frames`) and candela tables of the light systems.
A sensor band multiplies each luminaire's illuminance by its spectrum's sensor factor
:math:`k = \\int S R / (683 \\int S V)` (Chuang 2011, Eq. 10, :func:`sensor_factors`); the
photopic band is the illuminance itself [lx], any other band is sensor-weighted irradiance
[W m-2].
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import geopandas as gpd
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ies import spectra as ies_spectra
from ies.library import load_library
from ies.plausibility import MOUNTING_RANGES
from nightlights._typing import FloatArray
from nightlights.errors import DataQualityWarning, InputError
from nightlights.ground.frames import (
    FluxProfile,
    IntensityTable,
    PhotometryLike,
    flux_profile,
    light_points,
    luminaire_rotation,
)
from nightlights.ground.influence import InfluenceThreshold, influence_radius
from nightlights.io import sample_raster, source_label

if TYPE_CHECKING:
    import xarray as xr

    from nightlights.io import Raster

__all__ = [
    "DatabaseLike",
    "LightSystemLike",
    "Luminaires",
    "band_unit",
    "load_database",
    "resolve_luminaires",
    "sample_elevation",
    "sensor_factors",
]

#: Tilt, roll and street azimuth are rounded to this step when lights are grouped for their
#: flux profile (region of influence, uplight); 0.05 deg changes uplight by < 0.05 % [deg].
PROFILE_ANGLE_STEP = 0.1

#: Fields of the light layer read by the stage; missing or null values fall back to the
#: light system's defaults (``roll`` to 0).
LIGHT_OVERRIDES = ("mounting_height", "arm_length", "tilt")
#: Units of the light layer's numeric fields, for messages.
UNITS = {"mounting_height": "m", "arm_length": "m", "tilt": "deg", "roll": "deg", "heading": "deg"}


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
    light_point: FloatArray
    rotation: FloatArray
    street_azimuth: FloatArray
    mounting_height: FloatArray
    tilt: FloatArray
    roll: FloatArray
    table_index: NDArray[np.intp]
    intensity_scale: FloatArray
    tables: tuple[IntensityTable, ...]
    spectra: tuple[str | None, ...]
    names: tuple[str, ...]
    influence_scale: FloatArray | None = None
    profiles: dict[tuple[int, float, float, float], FluxProfile] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.light_id)

    def flux_profile(self, index: int) -> FluxProfile:
        """World-frame flux profile of light ``index``, cached per table and rounded angles.

        Parameters
        ----------
        index
            Light index.
        """
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

    def radius(self, threshold: InfluenceThreshold) -> FloatArray:
        """Region-of-influence radius per light [m].

        Parameters
        ----------
        threshold
            Energy fraction or illuminance floor.
        """
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
    def roi_scale(self) -> FloatArray:
        """Intensity factor of the region of influence per light [1]."""
        return self.intensity_scale if self.influence_scale is None else self.influence_scale

    def upward_flux(self) -> FloatArray:
        """Direct uplight of each light in the world frame (after tilt and roll) [lm]."""
        flux = np.zeros(len(self))
        for profile, members in self.profile_groups():
            flux[members] = profile.upward_flux * self.intensity_scale[members]
        return flux

    def downward_flux(self) -> FloatArray:
        """Flux below the horizontal of each light in the world frame [lm]."""
        flux = np.zeros(len(self))
        for profile, members in self.profile_groups():
            flux[members] = profile.downward_flux * self.intensity_scale[members]
        return flux

    def subset(self, keep: NDArray[np.bool_]) -> Luminaires:
        """The lights where ``keep`` is true.

        Parameters
        ----------
        keep
            Boolean mask (n,).
        """
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
        """Join luminaire sets, renumbering their tables.

        Parameters
        ----------
        parts
            Luminaire sets, each with its own tables.
        """
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
    """The luminaire database of the ``ies`` package.

    Parameters
    ----------
    catalog
        Database folder; ``None`` for the bundled one.
    """
    return load_library(catalog)


def resolve_luminaires(
    lights: gpd.GeoDataFrame,
    database: DatabaseLike,
    *,
    source: str = "lights",
    skip_unknown: bool = False,
    ground_elevation: FloatArray | None = None,
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
        infinite field values, mounting height, arm length or tilt outside
        :data:`ies.plausibility.MOUNTING_RANGES` (unusual values the layer gives warn with a
        :class:`~nightlights.errors.DataQualityWarning`).
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
            f"{source}: lights {describe_ids(ids[bad_geometry.to_numpy()])} are not points; "
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
            f"{source}: lights {describe_ids(ids[unknown])} have no or an unknown system_id "
            f"({sorted({str(s) for s in system_ids[unknown]})})"
        )
        if not skip_unknown:
            raise InputError(message + "; fix them or pass skip_unknown=True to drop them")
        warnings.warn(message + "; dropped", DataQualityWarning, stacklevel=2)
        frame = frame.loc[~unknown].reset_index(drop=True)
        ids = ids[~unknown]
        if ground_elevation is not None:
            ground_elevation = np.asarray(ground_elevation)[~unknown]
    names = tuple(sorted({str(s) for s in frame["system_id"]}))
    systems = [known[name] for name in names]
    table_index = np.searchsorted(np.array(names, dtype=object), frame["system_id"].to_numpy())
    values: dict[str, FloatArray] = {}
    from_layer: dict[str, NDArray[np.bool_]] = {}
    for name in (*LIGHT_OVERRIDES, "street_azimuth"):
        default = np.array([float(getattr(system, name)) for system in systems])[table_index]
        given = (
            pd.to_numeric(frame[name], errors="coerce").to_numpy(float)
            if name in frame and name != "street_azimuth"
            else np.full(len(frame), np.nan)
        )
        from_layer[name] = ~np.isnan(given)
        values[name] = np.where(np.isnan(given), default, given)
    heading = pd.to_numeric(frame["heading"], errors="coerce").to_numpy(float)
    roll = (
        pd.to_numeric(frame["roll"], errors="coerce").fillna(0.0).to_numpy(float)
        if "roll" in frame
        else np.zeros(len(frame))
    )
    if np.isnan(heading).any():
        raise InputError(f"{source}: lights {describe_ids(ids[np.isnan(heading)])} have no heading")
    for name, field_values, unit in (
        ("heading", heading, "deg"),
        ("roll", roll, "deg"),
        *((name, values[name], UNITS[name]) for name in LIGHT_OVERRIDES),
    ):
        if (bad := ~np.isfinite(field_values)).any():
            raise InputError(
                f"{source}: lights {describe_ids(ids[bad])} have {name} "
                f"{field_values[bad][:5].tolist()} {unit}; expected finite numbers"
            )
    _check_ranges(values, from_layer, ids, source)
    height = values["mounting_height"]
    if (bad := ~(height > 0)).any():
        raise InputError(
            f"{source}: lights {describe_ids(ids[bad])} have mounting_height {height[bad][:5]} m; "
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


def _check_ranges(
    values: dict[str, FloatArray],
    from_layer: dict[str, NDArray[np.bool_]],
    ids: NDArray[Any],
    source: str,
) -> None:
    """Refuse impossible mounting geometry; warn about unusual values the layer gave.

    The ranges are those of the luminaire database (:data:`ies.plausibility.MOUNTING_RANGES`);
    defaults of the database were checked when it was read, so only the layer's values warn.
    """
    for name in LIGHT_OVERRIDES:
        limits = MOUNTING_RANGES[name]
        value = values[name]
        if (bad := limits.impossible(value)).any():
            raise InputError(
                f"{source}: lights {describe_ids(ids[bad])} have {name} "
                f"{value[bad][:5].tolist()} {limits.unit}; expected {limits.expected}"
            )
        odd = limits.unusual(value) & from_layer[name]
        if odd.any():
            warnings.warn(
                f"{source}: lights {describe_ids(ids[odd])} have an unusual {name} "
                f"{value[odd][:5].tolist()} {limits.unit} (usually {limits.usual})",
                DataQualityWarning,
                stacklevel=3,
            )


def describe_ids(ids: NDArray[Any], limit: int = 10) -> str:
    """The first ``limit`` ids and their number, for messages.

    Parameters
    ----------
    ids
        Identifiers.
    limit
        How many to list.

    Examples
    --------
    >>> describe_ids(np.array([3, 8]))
    '[3, 8] (2 in all)'
    """
    listed = ", ".join(str(i) for i in ids[:limit])
    return f"[{listed}{', ...' if len(ids) > limit else ''}] ({len(ids)} in all)"


def sensor_factors(
    spectra: Sequence[str | None],
    sensors: Sequence[str],
    *,
    names: Sequence[str] | None = None,
) -> FloatArray:
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
        if sensor not in ies_spectra.SENSORS:
            raise InputError(
                f"sensor {sensor!r} is unknown; expected one of {sorted(ies_spectra.SENSORS)}"
            )
        for i, spectrum in enumerate(spectra):
            if spectrum is None:
                who = names[i] if names is not None else f"number {i}"
                hint = " (name one with area_options.spectrum=)" if who == "area_source" else ""
                raise InputError(
                    f"sensor {sensor!r} needs a spectrum, but light system {who} has none{hint}"
                )
            factors[i, j] = float(ies_spectra.sensor_factor(spectrum, sensor))
    return factors


def band_unit(sensor: str) -> str:
    """Unit of a sensor band: ``lx`` for photopic, ``W m-2`` otherwise.

    Parameters
    ----------
    sensor
        Sensor name (``photopic`` or one of ``ies.spectra.SENSORS``).
    """
    return "lx" if sensor == "photopic" else "W m-2"


def sample_elevation(
    dem: Raster | xr.DataArray | str | os.PathLike[str],
    points: gpd.GeoDataFrame,
    *,
    source: str = "lights",
) -> FloatArray:
    """Ground elevation at point features from a DEM (the pixel holding each point).

    Parameters
    ----------
    dem
        Elevation raster [m]: a :class:`~nightlights.io.Raster`, a DataArray or a path.
    points
        Point features (``light_id`` names them in messages).
    source
        Name of the features for messages.

    Returns
    -------
    numpy.ndarray
        Elevation (n,) [m].

    Raises
    ------
    InputError
        The DEM cannot be read, or a point falls on nodata or outside it (naming the points).
    """
    elevation = sample_raster(dem, points, name="DEM")
    bad = np.isnan(elevation)
    if bad.any():
        ids = points["light_id"].to_numpy()[bad] if "light_id" in points else np.flatnonzero(bad)
        raise InputError(
            f"{source_label(dem, 'DEM')}: {source} features {describe_ids(ids)} "
            "fall outside the DEM or on nodata"
        )
    return elevation
