"""Canonical street fields shared by the street stages.

:func:`~nightlights.streets._normalize` writes these fields,
:func:`~nightlights.streets._sample` fills the missing ones and adds the lighting fields,
:func:`~nightlights.streets._place` reads them.
"""

from __future__ import annotations

from ies.plausibility import MOUNTING_RANGES, PlausibleRange
from nightlights.io.vector import FieldType

#: Street classes, from fastest to slowest traffic. Municipal schemas and OSM ``highway``
#: values map onto these (Chuang 2011, Sec. 3.2: "major arterial, minor arterial,
#: collector, freeway ...").
STREET_CLASSES: tuple[str, ...] = (
    "motorway",
    "arterial",
    "collector",
    "local",
    "service",
    "path",
)

#: Street fields written by ``normalize``: name -> field type. Each has a companion
#: ``<name>_observed`` boolean saying whether the value came from the input.
STREET_FIELDS: dict[str, FieldType] = {
    "street_class": "str",
    "lanes": "int",
    "width": "float",  # carriageway width [m]
    "has_median": "bool",
    "oneway": "bool",
    "lit": "bool",
}

#: Lighting fields added by ``sample``: name -> field type.
LIGHTING_FIELDS: dict[str, FieldType] = {
    "arrangement": "str",  # one of ARRANGEMENTS
    "mounting_height": "float",  # [m]
    "spacing": "float",  # pole spacing along the street [m]
    "arm_length": "float",  # [m]
    "setback": "float",  # pole distance from the carriageway edge [m]
    "tilt": "float",  # [deg]
    "system_id": "str",  # light system id in the luminaire database
}

#: Pole arrangements (Chuang 2011, Fig. 8): poles on one side, staggered (triangular
#: grid), opposite pairs (rectangular grid), central on the median.
ARRANGEMENTS: tuple[str, ...] = ("single_sided", "staggered", "opposite", "central")


#: Allowed and usual values of the numeric street and lighting fields (see
#: :class:`ies.mounting.PlausibleRange`): outside the allowed range a value is an error (or,
#: read from a street layer by ``normalize``, treated as missing and counted); outside the
#: usual range it is kept with a warning. Lanes count both directions (the widest roads
#: carry about 25); carriageways reach about 150 m across plazas and boulevards; poles stand
#: at most a few metres from the kerb and tens of metres apart (spacing is 2-6 mounting
#: heights in practice). Occupancy, the share of a street's pole positions at its spacing that
#: hold a pole, is at most 1 and above 0 on a lit street.
VALUE_RANGES: dict[str, PlausibleRange] = {
    "lanes": PlausibleRange("lanes", "", 1.0, 30.0, 1.0, 12.0),
    "width": PlausibleRange("width", "m", 0.0, 200.0, 0.5, 80.0, low_open=True),
    **MOUNTING_RANGES,
    "setback": PlausibleRange("setback", "m", 0.0, 100.0, 0.0, 10.0),
    "spacing": PlausibleRange("spacing", "m", 1.0, 5000.0, 5.0, 200.0),
    "spacing_ratio": PlausibleRange("spacing_ratio", "", 0.0, 50.0, 1.5, 8.0, low_open=True),
    "occupancy": PlausibleRange("occupancy", "", 0.0, 1.0, 0.2, 1.0, low_open=True),
}


def observed_field(name: str) -> str:
    """Name of the companion field that says whether ``name`` was observed.

    Examples
    --------
    >>> observed_field("lanes")
    'lanes_observed'
    """
    return f"{name}_observed"
