"""Choose the catalogue network for a street layer from where the layer lies.

The catalogue (:mod:`bayesnets.catalog`) holds networks for the street-lighting practice of
a region: ``north_america``, ``europe``, ``east_asia`` (China, Japan, Korea, Taiwan), and
``generic``, a blend of ``europe`` and ``north_america`` for the rest of the world.
:func:`network_for_location` maps a WGS84 position to one of them with the rectangular boxes
of :data:`REGION_BOXES`; :func:`layer_location` gives the position of a layer (the centre of
its extent, transformed to WGS84).
"""

from __future__ import annotations

import math

import geopandas as gpd
from pyproj import CRS, Transformer

from nightlights.errors import InputError

__all__ = ["FALLBACK_NETWORK", "REGION_BOXES", "layer_location", "network_for_location"]

#: Catalogue network for each region, as boxes (west, south, east, north) [deg] in WGS84
#: longitude/latitude; the first region with a box that holds the point wins. Coarse,
#: hand-drawn rectangles, not borders:
#: ``north_america``: the contiguous United States, Canada and Alaska (longitude -170 to
#: -50, latitude 24.5 to 84: from the Florida Keys and Newfoundland to the Arctic; it also
#: takes northern Mexico) and Hawaii (-161 to -154, 18.5 to 22.5).
#: ``europe``: longitude -25 to 45 (Iceland to European Russia west of the Volga), latitude
#: 34.5 to 72 (Crete and Cyprus to the North Cape); it also takes the Mediterranean coast of
#: North Africa, Turkey and the Caucasus.
#: ``east_asia``: mainland China east of 98.5 E and south of Mongolia, Korea, Japan and
#: Taiwan, in five boxes: western China (98.5 to 108 E, 23.5 to 41 N: Sichuan, Chongqing,
#: Yunnan, Guizhou, Shaanxi, Gansu, Ningxia, eastern Qinghai; its south edge keeps out
#: Vietnam and Laos); eastern China (108 to 119.5 E, 18 to 41.5 N: Hainan and Hong Kong to
#: Beijing; its west edge keeps out Vietnam's north-east coast); the coast, north-east
#: China, Korea and Taiwan (119.5 to 131 E, 21.5 to 50 N: from Taiwan's south cape, north
#: of Luzon and the Batanes Islands, to the Amur, with the Ryukyu Islands and western
#: Kyushu); Japan from Kyushu to southern Hokkaido (131 to 146 E, 24 to 42 N: south of
#: Vladivostok) and the rest of Hokkaido (139 to 146 E, 42 to 45.6 N: south of Sakhalin).
#: Left to ``generic``: Tibet, Xinjiang, northern Inner Mongolia, the Chinese strip south
#: of 23.5 N and west of 108 E (Xishuangbanna and the other border prefectures of Yunnan
#: and Guangxi), Southeast Asia and India.
#: The boxes also take North Korea, small border strips of the Russian Far East (west of
#: 131 E), the eastern tip of Mongolia and the Kokang corner of Myanmar. No two boxes
#: overlap (they share edges), so the order of the regions does not matter.
REGION_BOXES: dict[str, tuple[tuple[float, float, float, float], ...]] = {
    "north_america": ((-170.0, 24.5, -50.0, 84.0), (-161.0, 18.5, -154.0, 22.5)),
    "europe": ((-25.0, 34.5, 45.0, 72.0),),
    "east_asia": (
        (98.5, 23.5, 108.0, 41.0),
        (108.0, 18.0, 119.5, 41.5),
        (119.5, 21.5, 131.0, 50.0),
        (131.0, 24.0, 146.0, 42.0),
        (139.0, 42.0, 146.0, 45.6),
    ),
}

#: Catalogue network for a position outside every box of :data:`REGION_BOXES`: the blend
#: of ``europe`` and ``north_america`` (see ``bayesnets/catalog/README.md``).
FALLBACK_NETWORK = "generic"

_WGS84 = CRS.from_epsg(4326)


def network_for_location(longitude: float, latitude: float) -> str:
    """Catalogue network for a position, from the boxes of :data:`REGION_BOXES`.

    Parameters
    ----------
    longitude
        WGS84 longitude, east positive [deg]; wrapped into [-180, 180).
    latitude
        WGS84 latitude, north positive [deg].

    Returns
    -------
    str
        ``"north_america"``, ``"europe"``, ``"east_asia"`` or, outside every box or for a
        non-finite position, :data:`FALLBACK_NETWORK` (``"generic"``).

    Examples
    --------
    >>> network_for_location(-87.6, 41.9)  # Chicago
    'north_america'
    >>> network_for_location(13.4, 52.5)  # Berlin
    'europe'
    >>> network_for_location(139.7, 35.7)  # Tokyo
    'east_asia'
    >>> network_for_location(151.2, -33.9)  # Sydney
    'generic'
    """
    if not (math.isfinite(longitude) and math.isfinite(latitude)):
        return FALLBACK_NETWORK
    lon = (longitude + 180.0) % 360.0 - 180.0
    for name, boxes in REGION_BOXES.items():
        for west, south, east, north in boxes:
            if west <= lon <= east and south <= latitude <= north:
                return name
    return FALLBACK_NETWORK


def layer_location(frame: gpd.GeoDataFrame, *, source: str = "streets") -> tuple[float, float]:
    """WGS84 position of the centre of a layer's extent.

    The centre of the bounding box in the layer's CRS is transformed to WGS84 (pyproj,
    longitude first).

    Parameters
    ----------
    frame
        Layer with a CRS (projected or geographic).
    source
        Name of the layer in error messages.

    Returns
    -------
    tuple of float
        ``(longitude, latitude)`` [deg]; NaN for an empty layer.

    Raises
    ------
    InputError
        The layer has no CRS.
    """
    if frame.crs is None:
        raise InputError(f"{source}: the layer has no CRS; give one (crs=) to locate it")
    if frame.empty or frame.geometry.is_empty.all():
        return math.nan, math.nan
    west, south, east, north = (float(v) for v in frame.total_bounds)
    transformer = Transformer.from_crs(frame.crs, _WGS84, always_xy=True)
    longitude, latitude = transformer.transform((west + east) / 2.0, (south + north) / 2.0)
    return float(longitude), float(latitude)
