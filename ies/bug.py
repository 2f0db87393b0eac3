"""Backlight-Uplight-Glare (BUG) ratings from zone lumens (IES TM-15-11, Addendum A).

The solid angle around a type C luminaire is split into the TM-15 secondary solid angles,
with vertical angles measured from nadir and "front" the half-space on the street side:

======  ==================  ===============
zone    vertical angle      half
======  ==================  ===============
FL      0-30 deg            front
FM      30-60 deg           front
FH      60-80 deg           front
FVH     80-90 deg           front
BL      0-30 deg            back
BM      30-60 deg           back
BH      60-80 deg           back
BVH     80-90 deg           back
UL      90-100 deg          all around
UH      100-180 deg         all around
======  ==================  ===============

Each rating is the lowest class whose every limit the zone lumens do not exceed; a value
above the class-4 limits is class 5. The thresholds below are the maximum zone lumens of
IES TM-15-11 Addendum A, Tables A-1 (backlight), A-2 (uplight) and A-3 (glare, asymmetric
luminaire types I-IV), as reproduced in the IDA/IES Model Lighting Ordinance (2011), Table
B. The glare table for quadrilateral-symmetric (type V) distributions is not applied.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

#: TM-15 zones: name -> (vertical from, vertical to [deg], half) with half in front/back/all.
BUG_ZONES: dict[str, tuple[float, float, str]] = {
    "FL": (0.0, 30.0, "front"),
    "FM": (30.0, 60.0, "front"),
    "FH": (60.0, 80.0, "front"),
    "FVH": (80.0, 90.0, "front"),
    "BL": (0.0, 30.0, "back"),
    "BM": (30.0, 60.0, "back"),
    "BH": (60.0, 80.0, "back"),
    "BVH": (80.0, 90.0, "back"),
    "UL": (90.0, 100.0, "all"),
    "UH": (100.0, 180.0, "all"),
}

# IES TM-15-11 Addendum A, Table A-1: maximum zone lumens for backlight ratings B0..B4 [lm].
BACKLIGHT_LIMITS: dict[str, tuple[float, ...]] = {
    "BH": (110.0, 500.0, 1000.0, 2500.0, 5000.0),
    "BM": (220.0, 1000.0, 2500.0, 5000.0, 8500.0),
    "BL": (110.0, 500.0, 1000.0, 2500.0, 5000.0),
}
# IES TM-15-11 Addendum A, Table A-2: maximum zone lumens for uplight ratings U0..U4 [lm].
UPLIGHT_LIMITS: dict[str, tuple[float, ...]] = {
    "UH": (0.0, 10.0, 50.0, 500.0, 1000.0),
    "UL": (0.0, 10.0, 50.0, 500.0, 1000.0),
}
# IES TM-15-11 Addendum A, Table A-3 (asymmetric types I-IV): limits for G0..G4 [lm].
GLARE_LIMITS: dict[str, tuple[float, ...]] = {
    "FVH": (10.0, 100.0, 225.0, 350.0, 500.0),
    "BVH": (10.0, 100.0, 225.0, 350.0, 500.0),
    "FH": (660.0, 1800.0, 5000.0, 7500.0, 12000.0),
    "BH": (110.0, 500.0, 1000.0, 2500.0, 5000.0),
}

#: Zone lumens below this are treated as zero (round-off of the integration) [lm].
ZERO_LUMENS = 1e-9


@dataclass(frozen=True)
class BUGRating:
    """A BUG rating and the zone lumens it came from.

    Attributes
    ----------
    backlight, uplight, glare : int
        Ratings 0 (best) to 5.
    zone_lumens : Mapping[str, float]
        Luminous flux in each TM-15 zone (see :data:`BUG_ZONES`) [lm].
    """

    backlight: int
    uplight: int
    glare: int
    zone_lumens: Mapping[str, float]

    def __str__(self) -> str:
        return f"B{self.backlight} U{self.uplight} G{self.glare}"


def rating_class(values: Mapping[str, float], limits: Mapping[str, tuple[float, ...]]) -> int:
    """Lowest class (0-5) whose limits none of the zone lumens exceed.

    Parameters
    ----------
    values : Mapping[str, float]
        Zone lumens by zone name [lm].
    limits : Mapping[str, tuple of float]
        Per zone, the maximum lumens of classes 0..4 [lm].

    Returns
    -------
    int
        The class, 5 when class 4 is exceeded.
    """
    worst = 0
    for zone, maxima in limits.items():
        value = values[zone] if values[zone] > ZERO_LUMENS else 0.0
        level = next((k for k, limit in enumerate(maxima) if value <= limit), len(maxima))
        worst = max(worst, level)
    return worst


def bug_rating_from_zones(zone_lumens: Mapping[str, float]) -> BUGRating:
    """BUG rating from the lumens in the TM-15 zones.

    Parameters
    ----------
    zone_lumens : Mapping[str, float]
        Flux in each zone of :data:`BUG_ZONES` [lm].

    Returns
    -------
    BUGRating
        The backlight, uplight and glare ratings.

    References
    ----------
    IES TM-15-11, Addendum A, Tables A-1 to A-3.

    Examples
    --------
    >>> zones = dict.fromkeys(BUG_ZONES, 0.0)
    >>> str(bug_rating_from_zones(zones))
    'B0 U0 G0'
    """
    return BUGRating(
        backlight=rating_class(zone_lumens, BACKLIGHT_LIMITS),
        uplight=rating_class(zone_lumens, UPLIGHT_LIMITS),
        glare=rating_class(zone_lumens, GLARE_LIMITS),
        zone_lumens=dict(zone_lumens),
    )
