"""Dobashi et al. 2023's kernel configuration and the error measure the kernel benchmarks share.

Dobashi, Ishikawa & Iwasaki 2023 (Sec. 5) precompute 256 x 64 panoramas for 128 distances
(78.125 m steps to 10 km), 16 source and 16 observer altitudes (62.5 m steps), turbidity 1.3.
The benchmarks of the kernel's precompute and storage build that configuration, in full or
on reduced grids, with :func:`dobashi_spec`, and compare images with
:func:`bright_relative_errors`. The first distance bin starts at 1 m (the kernel's grid needs
edges > 0; Dobashi's first sample is at r = 0).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nightlights.sky import KernelSpec
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.pca import BRIGHT_FRACTION

#: Altitude step of the source and observer levels [m], range of the distances [m] and the
#: turbidity of Dobashi's configuration.
LEVEL_STEP = 62.5
RANGE = 10_000.0
TURBIDITY = 1.3


def dobashi_spec(
    n_levels: int = 16,
    n_r: int = 128,
    n_el: int = 64,
    n_az: int = 256,
    *,
    exact: bool = True,
    **knobs: Any,
) -> KernelSpec:
    """Dobashi's configuration (the defaults), or the same altitudes and range on a reduced
    grid; ``knobs`` are further :class:`~nightlights.sky.KernelSpec` fields. ``exact``: on
    the reference build (:meth:`~nightlights.sky.KernelSpec.exact`, the lever benchmarks'
    baseline), else on the library's defaults."""
    altitudes = np.arange(n_levels) * LEVEL_STEP
    edges = np.concatenate([[1.0], np.arange(1, n_r + 1) * (RANGE / n_r)])
    return (KernelSpec.exact if exact else KernelSpec)(
        distance_edges=edges,
        source_altitudes=altitudes,
        observer_altitudes=altitudes,
        n_elevation=n_el,
        n_azimuth=n_az,
        atmosphere=Atmosphere(turbidity=TURBIDITY),
        **knobs,
    )


def bright_relative_errors(approx: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|approx - exact| / exact over the pixels brighter than ``BRIGHT_FRACTION`` of their
    image's maximum; images are the last two axes (elevation, azimuth)."""
    exact = np.asarray(exact, dtype=float)
    approx = np.asarray(approx, dtype=float)
    bright = exact > BRIGHT_FRACTION * exact.max(axis=(-2, -1), keepdims=True)
    return np.abs(approx[bright] - exact[bright]) / exact[bright]
