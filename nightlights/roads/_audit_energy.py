"""Energy of an audited street layer: power, annual energy, D_P, D_E and CO2 per segment.

Each light is assigned to one segment: the segment whose ``source_id`` equals the light's
``street_id`` (the nearest such part when a street was split into several), else the nearest
segment within :data:`ASSIGN_DISTANCE`; a light farther from every street counts in no
segment (with a warning) and in no total. Per segment, with :math:`P` the summed input power
of its lights [W] (:func:`~nightlights.roads.light_power`, scaled by the audit's dimming
level), :math:`H` the full-power equivalent burning hours of the year at the layer's location
(:func:`~nightlights.roads.full_power_hours`: photocell switching and the dimming schedule),
:math:`A = \\ell w` the carriageway area (length times ``width``) [m2] and :math:`\\bar E` the
segment's average horizontal illuminance [lx]:

- ``power_w`` :math:`= P`, ``energy_kwh`` :math:`= P H / 1000`;
- ``power_density`` :math:`D_P = P / (\\bar E A)` [W lx-1 m-2] (EN 13201-5:2015, the power
  density indicator with one sub-area);
- ``energy_density`` :math:`D_E = P H / A` [Wh m-2] (EN 13201-5:2015, the annual energy
  consumption indicator);
- ``co2_kg`` :math:`= P H f / 1000` with the user's grid factor :math:`f` [kg CO2 per kWh].

Modelling choices:

- :math:`\\bar E` is the ``average_illuminance`` figure of the audit: the average horizontal
  illuminance of the carriageway's illuminance field, which every section carries (for the
  luminance classes only for this indicator), the least over the segment's sections.
- One location for the whole layer, the centroid of its extent in longitude and latitude: the
  burning hours change by minutes a year over the tens of kilometres of a city.
- The total :math:`D_E` is the energy of all assigned lights over the area of all segments
  with a width.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
from shapely.geometry import box

from nightlights._typing import FloatArray
from nightlights.errors import DataQualityWarning, InputError
from nightlights.ground.luminaires import DatabaseLike, describe_ids
from nightlights.roads._burning import STEP_MINUTES, SWITCH_ELEVATION
from nightlights.roads._dimming import DimmingSchedule, parse_schedule
from nightlights.roads._energy import co2_emissions, full_power_hours, light_power

__all__ = ["ASSIGN_DISTANCE", "EnergyOptions", "segment_energy"]

#: Farthest a light may stand from a segment that does not name it and still count in it [m]
#: (a light stands within a few metres of its street's axis; 50 m keeps the lights of a
#: neighbouring street out of a lone segment's count).
ASSIGN_DISTANCE = 50.0
#: Fields the energy adds to the audit layer, with their types.
ENERGY_FIELDS = ("power_w", "energy_kwh", "power_density", "energy_density", "co2_kg")


@dataclass(frozen=True)
class EnergyOptions:
    """How the audit computes energy (EN 13201-5).

    Attributes
    ----------
    year
        UTC year of the burning hours.
    schedule
        Dimming schedule (:class:`~nightlights.roads.DimmingSchedule` or its short form
        ``"22:00=0.5,05:00=1"``); None burns at full power from dusk to dawn.
    zone
        IANA zone or UTC offset of a schedule given as text.
    grid_factor
        Grid emission factor [kg CO2 per kWh]; None: no CO2.
    power_field
        Field of the light layer with each light's input power [W]; a light without a value
        takes its system's input watts.
    switch_elevation
        Elevation of the Sun's centre at which the photocell switches [deg].
    step_minutes
        Sampling step of the Sun's elevation [min] (speed only).
    """

    year: int
    schedule: str | DimmingSchedule | None = None
    zone: str = "UTC"
    grid_factor: float | None = None
    power_field: str = "power"
    switch_elevation: float = SWITCH_ELEVATION
    step_minutes: float = STEP_MINUTES

    def dimming_schedule(self) -> DimmingSchedule | None:
        """The schedule, parsed when given as text."""
        if isinstance(self.schedule, str):
            return parse_schedule(self.schedule, self.zone)
        if self.schedule is None or isinstance(self.schedule, DimmingSchedule):
            return self.schedule
        raise InputError(
            f"schedule={self.schedule!r}; expected a DimmingSchedule, text like "
            "'22:00=0.5,05:00=1' or None"
        )


def layer_location(segments: gpd.GeoDataFrame) -> tuple[float, float]:
    """Longitude and latitude of the centre of the layer's extent [deg]."""
    centre = gpd.GeoSeries([box(*segments.total_bounds).centroid], crs=segments.crs)
    point = centre.to_crs("EPSG:4326").iloc[0]
    return float(point.x), float(point.y)


def assign_lights(segments: gpd.GeoDataFrame, lights: gpd.GeoDataFrame) -> np.ndarray:
    """Row of the segment of each light (-1: none); module docstring."""
    out = np.full(len(lights), -1, dtype=np.intp)
    lines = segments.geometry.reset_index(drop=True)
    points = lights.geometry.reset_index(drop=True)
    if "street_id" in lights and "source_id" in segments:
        rows_by_id = pd.Series(np.arange(len(segments))).groupby(
            segments["source_id"].astype(str).to_numpy()
        )
        groups = {key: value.to_numpy() for key, value in rows_by_id}
        ids = lights["street_id"].to_numpy(dtype=object)
        for position, sid in enumerate(ids):
            rows = groups.get(str(sid)) if not pd.isna(sid) else None
            if rows is not None:
                distance = lines.iloc[rows].distance(points.iloc[position]).to_numpy()
                out[position] = rows[int(np.argmin(distance))]
    rest = np.flatnonzero(out < 0)
    if rest.size:
        free = gpd.GeoDataFrame(geometry=points.iloc[rest].reset_index(drop=True), crs=lights.crs)
        near = gpd.sjoin_nearest(
            free,
            gpd.GeoDataFrame(geometry=lines, crs=segments.crs),
            max_distance=ASSIGN_DISTANCE,
            how="left",
        )
        near = near[~near.index.duplicated(keep="first")]
        found = near["index_right"].to_numpy(dtype=float)
        ok = np.isfinite(found)
        out[rest[ok]] = found[ok].astype(np.intp)
    return out


def segment_energy(
    segments: gpd.GeoDataFrame,
    lights: gpd.GeoDataFrame,
    database: DatabaseLike | None,
    options: EnergyOptions,
    *,
    level: FloatArray | None = None,
    source: str = "lights",
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Energy fields per segment and the totals (module docstring).

    Parameters
    ----------
    segments
        The audited segments (projected, with ``width`` and ``average_illuminance``).
    lights
        The light layer in the segments' CRS.
    database
        Luminaire database for the lights without a power value.
    options
        Year, schedule, grid factor.
    level
        Dimming level of each light [1], or None (full output).
    source
        The light layer's name in messages.

    Returns
    -------
    tuple of (DataFrame, dict)
        The fields of :data:`ENERGY_FIELDS` per segment, and the totals ``power_w``,
        ``energy_kwh``, ``energy_density`` [Wh m-2], ``co2_kg``, ``burning_hours``,
        ``longitude``, ``latitude``, ``year`` and ``unassigned_lights``.
    """
    if options.grid_factor is not None and not (
        np.isfinite(options.grid_factor) and options.grid_factor >= 0
    ):
        raise InputError(f"grid_factor={options.grid_factor!r} kg/kWh; expected a number >= 0")
    schedule = options.dimming_schedule()
    power = light_power(
        lights, database, power_field=options.power_field, level=level, source=source
    )
    row = assign_lights(segments, lights)
    if (lost := row < 0).any():
        ids = lights["light_id"].to_numpy() if "light_id" in lights else np.flatnonzero(lost)
        warnings.warn(
            f"{source}: lights {describe_ids(np.asarray(ids)[lost])} stand farther than "
            f"{ASSIGN_DISTANCE:g} m from every street and name none; they count in no segment",
            DataQualityWarning,
            stacklevel=3,
        )
    longitude, latitude = layer_location(segments)
    hours = full_power_hours(
        longitude,
        latitude,
        options.year,
        schedule=schedule,
        switch_elevation=options.switch_elevation,
        step_minutes=options.step_minutes,
    )
    n = len(segments)
    watts = np.bincount(row[~lost], weights=power[~lost], minlength=n).astype(float)
    energy_wh = watts * hours
    width = pd.to_numeric(segments["width"], errors="coerce").to_numpy(float)
    area = segments.geometry.length.to_numpy() * width
    has_area = area > 0
    lux = (
        pd.to_numeric(segments["average_illuminance"], errors="coerce").to_numpy(float)
        if "average_illuminance" in segments
        else np.full(n, np.nan)
    )
    lit = lux * area
    power_density = np.full(n, np.nan)
    np.divide(watts, lit, out=power_density, where=lit > 0)
    energy_density = np.full(n, np.nan)
    np.divide(energy_wh, area, out=energy_density, where=has_area)
    co2 = (
        co2_emissions(energy_wh, options.grid_factor)
        if options.grid_factor is not None
        else np.full(n, np.nan)
    )
    fields = pd.DataFrame(
        {
            "power_w": watts,
            "energy_kwh": energy_wh / 1000.0,
            "power_density": power_density,
            "energy_density": energy_density,
            "co2_kg": co2,
        }
    )
    total_area = float(area[has_area].sum())
    total_wh = float(power[~lost].sum()) * hours
    totals: dict[str, Any] = {
        "year": int(options.year),
        "longitude": round(longitude, 6),
        "latitude": round(latitude, 6),
        "burning_hours": round(hours, 3),
        "power_w": round(float(power[~lost].sum()), 3),
        "energy_kwh": round(total_wh / 1000.0, 3),
        "energy_density": round(total_wh / total_area, 6) if total_area > 0 else None,
        "co2_kg": (
            round(float(co2_emissions(total_wh, options.grid_factor)), 3)
            if options.grid_factor is not None
            else None
        ),
        "unassigned_lights": int(lost.sum()),
    }
    return fields, totals
