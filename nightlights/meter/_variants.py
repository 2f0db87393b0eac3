"""The scenes a calibration tabulates: the scene at other turbidities, its low-angle band alone.

A turbidity calibration reads the stations through darkness maps at a grid of turbidities
(scene kernels built at each, or precomputed kernels each at its own), and a share calibration
through the emission's second, low-angle band alone (:mod:`nightlights.meter.calibrate`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from nightlights.errors import InputError
from nightlights.io import Raster
from nightlights.sky.scene import DEFAULT_TURBIDITY, KernelInput, Scene

__all__ = ["low_angle_band", "low_angle_share", "scene_turbidity", "turbidity_scenes"]

#: Turbidities a turbidity calibration tabulates the artificial sky at, relative to the
#: scene's (a darkness map each); the fit interpolates in ln A between them [1].
TURBIDITY_GRID = (-1.0, -0.5, 0.0, 0.5, 1.0, 2.0)
#: Lowest turbidity tabulated (Preetham's model starts at 2; the kernels accept lower) [1].
MIN_TURBIDITY = 1.2


def low_angle_share(emission: Raster, label: str) -> float:
    """The share of an emission's second band (its low-angle, direct-uplight band) in its flux."""
    if emission.count != 2:
        raise InputError(
            f"calibrate='share' fits the share of the low-angle band of a two-band emission; "
            f"{label} has {emission.count} band{'s' if emission.count > 1 else ''}"
        )
    flux = np.nansum(emission.data, axis=(1, 2))
    if not (flux[0] > 0 and flux[1] > 0):
        raise InputError(
            f"calibrate='share': {label} has no flux in one of its bands ({flux[0]:.3g}, "
            f"{flux[1]:.3g}); both are needed to fit their shares"
        )
    return float(flux[1] / flux.sum())


def low_angle_band(emission: Raster) -> Raster:
    """The emission with its first band dark: what the low-angle band alone lights."""
    data = emission.data.copy()
    data[0] = 0.0
    return dataclasses.replace(emission, data=data)


def scene_turbidity(scene: Scene) -> float:
    """The scene's turbidity: given, else its kernel's, else the default [1]."""
    if scene.turbidity is not None:
        return float(scene.turbidity)
    table = scene.kernel_dataset()
    if table is not None and "turbidity" in table.attrs:
        return float(table.attrs["turbidity"])
    return DEFAULT_TURBIDITY


def turbidity_scenes(
    scene: Scene,
    turbidities: Sequence[float] | None,
    kernels: Sequence[KernelInput] | None,
    base: float,
) -> list[tuple[float, Scene]]:
    """The scene at each turbidity a turbidity calibration tabulates, ascending."""
    if kernels is not None:
        from nightlights.sky.store import load_kernel

        tabulated = []
        for kernel in kernels:
            table = load_kernel(kernel)
            tabulated.append(
                (float(table.attrs["turbidity"]), scene.replace(kernel=table, turbidity=None))
            )
        tabulated.sort(key=lambda pair: pair[0])
        values = [t for t, _ in tabulated]
        if len(values) < 2 or len(set(values)) < len(values):
            raise InputError(
                f"kernels at turbidities {values}; a turbidity calibration needs kernels at two "
                "or more different turbidities"
            )
        return tabulated
    if turbidities is None:
        grid = np.array([base + step for step in TURBIDITY_GRID])
        grid = grid[grid >= MIN_TURBIDITY]
    else:
        grid = np.unique(np.asarray(turbidities, dtype=float))
        if grid.size < 2 or not np.all(np.isfinite(grid)) or grid[0] <= 0:
            raise InputError(
                f"turbidities={list(turbidities)!r}; expected two or more finite values > 0"
            )
    return [(float(t), scene.replace(turbidity=float(t), kernel=None)) for t in grid]
