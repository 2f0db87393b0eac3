"""Coordinate reference system policy.

Computation happens in a projected CRS in metres. Geographic input is reprojected to its
local UTM zone; input without a CRS is an error unless the user names one.
"""

from __future__ import annotations

import geopandas as gpd
from pyproj import CRS

from nightlights.errors import CRSError


def ensure_projected(
    frame: gpd.GeoDataFrame,
    *,
    source: str = "layer",
    assume_crs: str | CRS | None = None,
    target_crs: str | CRS | None = None,
) -> gpd.GeoDataFrame:
    """Return ``frame`` in a projected CRS with metre units.

    Parameters
    ----------
    frame
        Input layer.
    source
        Name of the file or layer, used in error messages.
    assume_crs
        CRS to assign when the layer has none. Without it, a layer with no CRS is an error.
    target_crs
        Projected CRS to use. Default: the layer's own CRS if it is projected in metres,
        otherwise the local UTM zone (``estimate_utm_crs``).

    Raises
    ------
    CRSError
        The layer has no CRS and none was assumed, or the target is not projected in metres.
    """
    if frame.crs is None:
        if assume_crs is None:
            raise CRSError(
                f"{source}: the layer has no coordinate reference system; "
                "name one (e.g. crs='EPSG:4326')"
            )
        frame = frame.set_crs(CRS.from_user_input(assume_crs))
    if target_crs is not None:
        target = CRS.from_user_input(target_crs)
    elif _is_metric_projected(frame.crs):
        return frame
    else:
        if frame.empty:
            raise CRSError(f"{source}: cannot choose a UTM zone for an empty layer")
        target = frame.estimate_utm_crs()
    if not _is_metric_projected(target):
        raise CRSError(f"{source}: target CRS {target.to_string()} is not projected in metres")
    return frame.to_crs(target)


def _is_metric_projected(crs: CRS) -> bool:
    if not crs.is_projected:
        return False
    units = {axis.unit_name.lower() for axis in crs.axis_info}
    return units <= {"metre", "meter", "m"}
