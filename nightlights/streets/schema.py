"""Canonical street fields shared by the street stages.

:func:`~nightlights.streets._normalize` writes these fields,
:func:`~nightlights.streets._sample` fills the missing ones and adds the lighting fields,
:func:`~nightlights.streets._place` reads them.
"""

from __future__ import annotations

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


def observed_field(name: str) -> str:
    """Name of the companion field that says whether ``name`` was observed.

    Examples
    --------
    >>> observed_field("lanes")
    'lanes_observed'
    """
    return f"{name}_observed"
