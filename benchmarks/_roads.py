"""Road installations shared by the road-lighting benchmarks (grid density, r-table interpolation).

Three realistic installations on a two-lane road (2 x 3.5 m), each with a bundled real
photometry of the luminaire database (``ies.library``, :func:`load_database(None)
<nightlights.ground.luminaires.load_database>`) at its system's mounting height, arm length
and street C-plane:

- ``single``: single-sided, ``street_led_medium`` (60 W LED, 9156 lm, 10 m), S = 35 m;
- ``opposite``: opposite, ``road_led_large`` (full cut-off LED, 10,580 lm, 12 m), S = 45 m;
- ``staggered``: staggered, ``street_led_small`` (type IV LED, 4000 lm, 8 m), S = 25 m, the
  far side shifted by S / 2.

Poles stand 1 m behind the kerb, the light point ``arm_length - 1`` m over the road (near
side facing +y, heading 0; far side facing -y, heading 180). Every luminaire within 120 m of
the field (before or beyond) enters the sums: beyond it the r-table ends (tan gamma 12 at
8-12 m height is 96-144 m) and the cut-off optics send nothing towards the road.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from nightlights import roads
from nightlights.ground.frames import luminaire_rotation
from nightlights.ground.luminaires import load_database
from nightlights.roads._geometry import intensities
from nightlights.roads._rtables import DEFAULT_INTERPOLATION

#: Lane width [m] and lanes of every installation.
LANE_WIDTH, LANES = 3.5, 2
#: Poles behind the kerb [m].
SETBACK = 1.0
#: Luminaires this far before and beyond the field enter the sums [m].
REACH = 120.0


@dataclass(frozen=True)
class Installation:
    """Luminaires around one calculation field (road frame, see :mod:`nightlights.roads`)."""

    name: str
    arrangement: str
    system: str
    spacing: float
    height: float
    lights: np.ndarray
    rotation: np.ndarray
    street_azimuth: float
    intensity: Any

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "arrangement": self.arrangement,
            "system": self.system,
            "spacing_m": self.spacing,
            "mounting_height_m": self.height,
            "lanes": LANES,
            "lane_width_m": LANE_WIDTH,
            "luminaires": int(self.lights.shape[0]),
        }


def installation(name: str, arrangement: str, system_id: str, spacing: float) -> Installation:
    """Luminaires of one arrangement with a bundled light system."""
    database = load_database(None)
    system = database.get(system_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        photometry = database.photometry(system_id)
    height = float(system.mounting_height)
    overhang = float(system.arm_length) - SETBACK
    width = LANES * LANE_WIDTH
    count = int(np.ceil(REACH / spacing))
    near_x = spacing * np.arange(-count, count + 2)
    rows = [(x, overhang, 0.0) for x in near_x]
    if arrangement == "opposite":
        rows += [(x, width - overhang, 180.0) for x in near_x]
    elif arrangement == "staggered":
        rows += [(x + spacing / 2, width - overhang, 180.0) for x in near_x]
    elif arrangement != "single":
        raise ValueError(arrangement)
    table = np.array(rows)
    lights = np.column_stack([table[:, 0], table[:, 1], np.full(len(rows), height)])
    return Installation(
        name,
        arrangement,
        system_id,
        spacing,
        height,
        lights,
        luminaire_rotation(table[:, 2]),
        float(system.street_azimuth),
        photometry.intensity,
    )


def installations() -> list[Installation]:
    """The three installations of the module docstring."""
    return [
        installation("single 35 m, 10 m", "single", "street_led_medium", 35.0),
        installation("opposite 45 m, 12 m", "opposite", "road_led_large", 45.0),
        installation("staggered 25 m, 8 m", "staggered", "street_led_small", 25.0),
    ]


def luminance(
    inst: Installation,
    points: np.ndarray,
    observer: np.ndarray,
    table: roads.RTable,
    interpolation: str = DEFAULT_INTERPOLATION,
) -> np.ndarray:
    """Road luminance at points for one observer [cd m-2]."""
    return roads.road_luminance(
        points,
        observer,
        inst.lights,
        inst.rotation,
        inst.intensity,
        table,
        street_azimuth=inst.street_azimuth,
        interpolation=interpolation,
    )


def illuminance(inst: Installation, points: np.ndarray) -> np.ndarray:
    """Horizontal illuminance on the road, E = sum I h / d^3 [lx]."""
    flat = points.reshape(-1, 3)
    candela = intensities(
        flat, inst.lights, inst.rotation, inst.intensity, street_azimuth=inst.street_azimuth
    )
    offset = inst.lights[:, None, :] - flat[None, :, :]
    distance = np.linalg.norm(offset, axis=-1)
    return np.sum(candela * offset[..., 2] / distance**3, axis=0).reshape(points.shape[:-1])


def luminance_metrics(
    inst: Installation,
    table: roads.RTable,
    density: int = 1,
    interpolation: str = DEFAULT_INTERPOLATION,
) -> dict[str, float]:
    """L_av and U_o (lowest over the observers) and U_l of the luminance field at a density.

    U_l is taken along each lane's centre line at the field's rows (for even densities no
    column lies on it), seen by that lane's observer.
    """
    field = roads.calculation_field(inst.spacing, LANE_WIDTH, LANES, density=density)
    points = roads.field_points(field)
    values = np.stack(
        [luminance(inst, points, eye, table, interpolation) for eye in field.observers]
    )
    ratios = []
    for eye in field.observers:
        line = np.column_stack([field.x, np.full(field.x.size, eye[1]), np.zeros(field.x.size)])
        along = luminance(inst, line, eye, table, interpolation)
        ratios.append(along.min() / along.max())
    return {
        "L_av": float(roads.average_luminance(values).min()),
        "U_o": float(roads.overall_uniformity(values).min()),
        "U_l": float(min(ratios)),
    }


def illuminance_metrics(inst: Installation, density: int = 1) -> dict[str, float]:
    """E_av, E_min and U_o of the illuminance field at a density."""
    field = roads.calculation_field(
        inst.spacing, LANE_WIDTH, LANES, quantity="illuminance", density=density
    )
    values = illuminance(inst, roads.field_points(field))
    return {
        "E_av": roads.average_illuminance(values),
        "E_min": roads.minimum_illuminance(values),
        "U_o(E)": roads.illuminance_uniformity(values),
    }
