"""Energy of road lighting: luminaire power, annual energy, the EN 13201-5 indicators, CO2.

- Power of a light (:func:`light_power`): a power field of the light layer wins, else the
  input watts of its light system's photometry (IES LM-63 ``input watts``, EULUMDAT lamp
  wattage with ballast), scaled by a per-light dimming level.
- Annual energy (:func:`annual_energy`): with the burning intervals :math:`[a_k, b_k]` of a
  photocell (:func:`~nightlights.roads.burning_intervals`) and a dimming level :math:`L(t)`
  (:class:`~nightlights.roads.DimmingSchedule`),

  .. math:: W = P \\sum_k \\int_{a_k}^{b_k} L(t)\\,dt,

  integrated exactly (the level is piecewise constant). The input power is taken as linear
  in the level, :math:`P(L) = L P`: a modelling choice. Real drivers draw somewhat more than
  that when dimmed deep (their efficiency falls at low load) and a little in standby; no
  published figure general enough to build in was at hand, so a standby or an offset is
  for the user to add (as one more period of :func:`energy_consumption_indicator`).
- EN 13201-5:2015 indicators: the power density indicator

  .. math:: D_P = \\frac{P}{\\sum_i \\bar E_i A_i}\\quad[\\mathrm{W\\,lx^{-1}\\,m^{-2}}]

  with :math:`P` the system power of the installation [W], :math:`\\bar E_i` the average
  maintained horizontal illuminance of sub-area :math:`i` [lx] and :math:`A_i` its area [m2];
  and the annual energy consumption indicator

  .. math:: D_E = \\frac{\\sum_j P_j t_j}{A}\\quad[\\mathrm{Wh\\,m^{-2}}]

  with :math:`P_j` the power in operating period :math:`j` [W], :math:`t_j` its duration over
  a year [h] and :math:`A` the lit area [m2].
- CO2: :math:`m = W \\cdot f / 1000` [kg] with the user's grid emission factor :math:`f`
  [kg CO2 per kWh]; no factor is built in (it depends on the grid, the year and the
  accounting).

References
----------
1. EN 13201-5:2015, "Road lighting - Part 5: Energy performance indicators", CEN: the power
   density indicator D_P and the annual energy consumption indicator D_E.
2. ANSI/IES LM-63-19 and the EULUMDAT format: the luminaire's input watts
   (:mod:`ies.photometry`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.ground.luminaires import DatabaseLike, describe_ids
from nightlights.roads._burning import STEP_MINUTES, SWITCH_ELEVATION, burning_intervals
from nightlights.roads._dimming import DimmingSchedule, scheduled_hours

__all__ = [
    "annual_energy",
    "co2_emissions",
    "energy_consumption_indicator",
    "full_power_hours",
    "light_power",
    "power_density_indicator",
]


def _finite_array(values: ArrayLike, name: str, unit: str) -> FloatArray:
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}={values!r}; expected numbers [{unit}]") from None
    if (bad := ~np.isfinite(array) | (array < 0)).any():
        raise InputError(
            f"{name} holds {array[bad].ravel()[:5].tolist()} {unit}; expected finite values >= 0"
        )
    return array


def full_power_hours(
    longitude: float,
    latitude: float,
    year: int,
    *,
    schedule: DimmingSchedule | None = None,
    switch_elevation: float = SWITCH_ELEVATION,
    step_minutes: float = STEP_MINUTES,
) -> float:
    """Burning hours of a year weighted by the dimming level: :math:`\\sum_k\\int L\\,dt` [h].

    Parameters
    ----------
    longitude, latitude : float
        Location [deg], longitude positive east.
    year : int
        UTC year.
    schedule : DimmingSchedule or None, optional
        Dimming schedule; None burns at full power from dusk to dawn.
    switch_elevation, step_minutes : float, optional
        As :func:`~nightlights.roads.burning_intervals`.

    Returns
    -------
    float
        Full-power equivalent hours [h].
    """
    nights = burning_intervals(
        longitude, latitude, year, switch_elevation=switch_elevation, step_minutes=step_minutes
    )
    return float(np.sum(scheduled_hours(schedule, nights.on, nights.off)))


def annual_energy(
    power: ArrayLike,
    longitude: float,
    latitude: float,
    year: int,
    *,
    schedule: DimmingSchedule | None = None,
    switch_elevation: float = SWITCH_ELEVATION,
    step_minutes: float = STEP_MINUTES,
) -> FloatArray:
    """Energy a year of each light: full power times the level-weighted burning hours.

    Parameters
    ----------
    power : array_like
        Full input power of each light [W] (:func:`light_power`).
    longitude, latitude : float
        Location of the installation [deg], longitude positive east.
    year : int
        UTC year.
    schedule : DimmingSchedule or None, optional
        Dimming schedule (the level scales the power linearly); None: full power dusk to dawn.
    switch_elevation, step_minutes : float, optional
        As :func:`~nightlights.roads.burning_intervals`.

    Returns
    -------
    ndarray
        Energy [Wh], the shape of ``power``.

    Examples
    --------
    >>> round(float(annual_energy(100.0, 0.0, 0.0, 2024)) / 1000)  # 100 W on the equator
    435
    """
    watts = _finite_array(power, "power", "W")
    return watts * full_power_hours(
        longitude,
        latitude,
        year,
        schedule=schedule,
        switch_elevation=switch_elevation,
        step_minutes=step_minutes,
    )


def power_density_indicator(power: float, illuminance: ArrayLike, area: ArrayLike) -> float:
    """EN 13201-5 power density indicator :math:`D_P = P / \\sum_i \\bar E_i A_i`.

    Parameters
    ----------
    power : float
        System power of the installation lighting the areas [W].
    illuminance : array_like
        Average maintained horizontal illuminance of each sub-area [lx].
    area : array_like
        Area of each sub-area [m2], the shape of ``illuminance``.

    Returns
    -------
    float
        :math:`D_P` [W lx-1 m-2].

    Examples
    --------
    >>> power_density_indicator(100.0, [10.0], [500.0])
    0.02
    """
    watts = float(_finite_array(power, "power", "W"))
    lux = _finite_array(illuminance, "illuminance", "lx")
    square_metres = _finite_array(area, "area", "m2")
    if lux.shape != square_metres.shape:
        raise InputError(
            f"illuminance and area have shapes {lux.shape} and {square_metres.shape}; "
            "expected one value of each per sub-area"
        )
    lit = float(np.sum(lux * square_metres))
    if not lit > 0:
        raise InputError("illuminance times area sums to 0; expected a lit area")
    return watts / lit


def energy_consumption_indicator(power: ArrayLike, hours: ArrayLike, area: float) -> float:
    """EN 13201-5 annual energy consumption indicator :math:`D_E = \\sum_j P_j t_j / A`.

    Parameters
    ----------
    power : array_like
        Power of the installation in each operating period [W] (full power, a dimmed level,
        a standby power).
    hours : array_like
        Duration of each period over a year [h], the shape of ``power``.
    area : float
        Area lit by the installation [m2].

    Returns
    -------
    float
        :math:`D_E` [Wh m-2].

    Examples
    --------
    1000 W for 2000 h and 500 W for 2000 h over 1000 m2:

    >>> energy_consumption_indicator([1000.0, 500.0], [2000.0, 2000.0], 1000.0)
    3000.0
    """
    watts = _finite_array(power, "power", "W")
    duration = _finite_array(hours, "hours", "h")
    if watts.shape != duration.shape:
        raise InputError(
            f"power and hours have shapes {watts.shape} and {duration.shape}; "
            "expected one of each per operating period"
        )
    lit = float(_finite_array(area, "area", "m2"))
    if not lit > 0:
        raise InputError(f"area={area!r} m2; expected > 0")
    return float(np.sum(watts * duration)) / lit


def co2_emissions(energy: ArrayLike, grid_factor: float) -> FloatArray:
    """CO2 emitted to supply an energy: :math:`m = W f / 1000`.

    Parameters
    ----------
    energy : array_like
        Electric energy [Wh].
    grid_factor : float
        Emission factor of the grid [kg CO2 per kWh]; the user's (it depends on the country,
        the year and the accounting, so none is built in).

    Returns
    -------
    ndarray
        CO2 [kg], the shape of ``energy``.

    Examples
    --------
    >>> float(co2_emissions(435_000.0, 0.4))
    174.0
    """
    factor = float(_finite_array(grid_factor, "grid_factor", "kg/kWh"))
    return _finite_array(energy, "energy", "Wh") * factor / 1000.0


def light_power(
    lights: pd.DataFrame,
    database: DatabaseLike | None,
    *,
    power_field: str = "power",
    level: ArrayLike | None = None,
    source: str = "lights",
) -> FloatArray:
    """Input power of each light: the layer's field, else its light system's photometry.

    Parameters
    ----------
    lights : DataFrame or GeoDataFrame
        Light layer; ``system_id`` names the light system, ``light_id`` (optional) names the
        lights in messages, ``power_field`` (optional) gives a power per light [W].
    database : DatabaseLike or None
        Luminaire database (:func:`~nightlights.ground.luminaires.load_database`); its
        photometry's ``input_watts`` is the power of a light without a field value. None:
        every light needs the field.
    power_field : str, optional
        Field of the layer holding the power [W]; a null value falls back to the database.
    level : array_like or None, optional
        Dimming level of each light (or one for all) [1], 0 to 1; the power scales linearly.

    Returns
    -------
    ndarray
        Power of each light [W], shape (n,).

    Raises
    ------
    InputError
        Lights with neither a power nor a system whose photometry states input watts (the
        message names them), negative or infinite powers, levels outside 0 to 1.
    """
    frame = lights.reset_index(drop=True)
    n = len(frame)
    ids = frame["light_id"].to_numpy() if "light_id" in frame else np.arange(n, dtype=np.int64)
    given = (
        pd.to_numeric(frame[power_field], errors="coerce").to_numpy(float)
        if power_field in frame
        else np.full(n, np.nan)
    )
    if (bad := np.isinf(given) | (given < 0)).any():
        raise InputError(
            f"{source}: lights {describe_ids(ids[bad])} have {power_field} "
            f"{given[bad][:5].tolist()} W; expected finite values >= 0"
        )
    power = given.copy()
    missing = np.isnan(power)
    if missing.any() and database is not None and "system_id" in frame:
        watts: dict[Any, float] = {}
        systems = frame["system_id"].to_numpy()
        for position in np.flatnonzero(missing):
            system_id = systems[position]
            if system_id is None or (isinstance(system_id, float) and math.isnan(system_id)):
                continue
            if system_id not in watts:
                watts[system_id] = _input_watts(database, str(system_id))
            power[position] = watts[system_id]
    if (unknown := np.isnan(power)).any():
        raise InputError(
            f"{source}: lights {describe_ids(ids[unknown])} have no power: no {power_field} "
            "value and no light system whose photometry states input watts; "
            f"give their power in the field {power_field!r}"
        )
    if level is not None:
        levels = np.broadcast_to(_finite_array(level, "level", "1"), (n,))
        if (high := levels > 1).any():
            raise InputError(
                f"{source}: lights {describe_ids(ids[high])} have level "
                f"{levels[high][:5].tolist()}; expected 0 to 1"
            )
        power = power * levels
    return power


def _input_watts(database: DatabaseLike, system_id: str) -> float:
    """Input watts of a system's photometry; NaN when unknown or not stated."""
    try:
        photometry = database.photometry(system_id)
    except (KeyError, LookupError, ValueError):
        return math.nan
    watts = getattr(photometry, "input_watts", None)
    if watts is None or not math.isfinite(float(watts)) or float(watts) <= 0:
        return math.nan
    return float(watts)
