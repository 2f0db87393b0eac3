"""Inverse investigation: which lights cause the glow, and the least dimming that removes it.

Dobashi et al. (2023, Sec. 4) map, for an observer, each lit cell's share of the light pollution
(Q_i, Eqs. 10-11) and of the skyglow in a region of the sky (S_i, Eqs. 13-14), and dim the cells
by those maps (Eq. 12). This package computes them as rasters on the emission grid, with
physical variants (each cell's part of the zenith or hemispherical sky luminance), the dimming
that meets sky-brightness targets while removing the least flux (a linear program: skyglow is
linear in the emission). The region-wide zenith darkness map, a forward map of many observers,
lives beside them in :mod:`nightlights.sky.darkness`; :func:`darkness` and
:class:`DarknessResult` are handed on here too.

References
----------
Dobashi, Y., Ishikawa, N. & Iwasaki, K. 2023, "Efficient Visualization of Light Pollution for
the Night Sky", ACM TOG 42(6) 219, Sec. 4.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY: dict[str, str] = {
    "SkyRegion": "nightlights.inverse._region",
    "dimming_fraction": "nightlights.inverse._dimming",
    "least_flux_dimming": "nightlights.inverse._dimming",
    "DimmingPlan": "nightlights.inverse._dimming",
    "InfeasibleTargetError": "nightlights.inverse._dimming",
    "darkness": "nightlights.sky.darkness",
    "DarknessResult": "nightlights.sky.darkness",
    "inverse_q": "nightlights.inverse.stage",
    "inverse_s": "nightlights.inverse.stage",
    "inverse_reduce": "nightlights.inverse.plan",
    "least_dimming": "nightlights.inverse.plan",
    "InfluenceResult": "nightlights.inverse.stage",
    "ReduceResult": "nightlights.inverse.plan",
    "RegionKind": "nightlights.inverse._region",
    "register_region_kind": "nightlights.inverse._region",
    "unregister_region_kind": "nightlights.inverse._region",
    "region_kinds": "nightlights.inverse._region",
    "region_numbers": "nightlights.inverse._region",
    "sky_matrix": "nightlights.inverse.road_sky",
    "lights_emission": "nightlights.inverse.road_sky",
}

if TYPE_CHECKING:
    from nightlights.inverse._dimming import (
        DimmingPlan,
        InfeasibleTargetError,
        dimming_fraction,
        least_flux_dimming,
    )
    from nightlights.inverse._region import (
        RegionKind,
        SkyRegion,
        region_kinds,
        region_numbers,
        register_region_kind,
        unregister_region_kind,
    )
    from nightlights.inverse.plan import ReduceResult, inverse_reduce, least_dimming
    from nightlights.inverse.road_sky import lights_emission, sky_matrix
    from nightlights.inverse.stage import InfluenceResult, inverse_q, inverse_s
    from nightlights.sky.darkness import DarknessResult, darkness

__all__ = [
    "DarknessResult",
    "DimmingPlan",
    "InfeasibleTargetError",
    "InfluenceResult",
    "ReduceResult",
    "RegionKind",
    "SkyRegion",
    "darkness",
    "dimming_fraction",
    "inverse_q",
    "inverse_reduce",
    "inverse_s",
    "least_dimming",
    "least_flux_dimming",
    "lights_emission",
    "region_kinds",
    "region_numbers",
    "register_region_kind",
    "sky_matrix",
    "unregister_region_kind",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights.inverse' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
