"""The emission a scene's sky sees when obstacles stand around the lit ground.

The obstacle model (:mod:`nightlights.ground.obstacles`) gives, for each cell's obstacle height
h, spacing d and filling factor f, the transmission t(e) = 1 - f + f tau(e) of rays of
elevation e. A band's emission of shape I_s (per lumen, a kernel shape) then leaves the street
as

.. math::
    I_s(\\theta)\\, t = (1 - f)\\, I_s(\\theta) + f\\, \\tau(e)\\, I_s(\\theta).

The first term, the light through the gaps between the obstacles, keeps the shape exactly and
is the shape's flux times (1 - f). The second, the light that clears the obstacles, leaves only
above the low angles: the kernel has no table of every truncated shape, so it is carried as a
Lambertian source of the same flux, f G_s (G_s the canyon factor of
:func:`~nightlights.ground.obstacles.escaping_fraction`). That is the one approximation: it puts
a little light back at low elevations, where the exact truncated shape has tau(e) I_s, which
goes to 0 at the horizon (its error on a test sky is in ``docs/obstacles.md``).

So an obstructed emission is two bands on the emission's grid: ``lambertian`` (the Lambertian
share through the gaps and all the light over the obstacles) and the one other shape the bands
use (``uplight``, Garstang's lobe ``garstang:1,0``, a tabulated function), reduced by 1 - f.
A scene (:class:`~nightlights.sky.scene.Scene` with ``obstacles=``) hands that raster to every
sky stage in place of its emission. Where no cell has both h > 0 and f > 0 nothing changes:
the scene keeps its own emission object.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr

from nightlights._typing import FloatArray
from nightlights.emission_functions import (
    DEFAULT_EMISSION_FUNCTION,
    EMISSION_FUNCTION_TAG,
    TABULATED_PREFIX,
    EmissionFunction,
    emission_shape,
)
from nightlights.errors import InputError
from nightlights.ground.obstacles import ObstacleProperties, check_obstacles, escaping_fraction
from nightlights.io import Raster
from nightlights.io.raster import as_raster, source_label

__all__ = [
    "OBSTACLE_BANDS",
    "ObstacleInput",
    "obstacle_grids",
    "obstructed_emission",
]

#: Band descriptions of an obstacle raster, in order (height [m], spacing [m], filling [1]).
OBSTACLE_BANDS = ("height", "spacing", "filling")
#: What a scene's ``obstacles`` may be: uniform properties or a three-band raster.
ObstacleInput = ObstacleProperties | Raster | xr.DataArray | str | os.PathLike[str]
#: Emission functions of the bands of an untagged raster, as the sky stages read them
#: (:func:`nightlights.sky.setup.band_emission_functions`).
_UNTAGGED = {1: (DEFAULT_EMISSION_FUNCTION,), 2: ("lambertian", "uplight")}


def obstacle_grids(
    obstacles: ObstacleInput, emission: Raster, *, label: str = "obstacles"
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Obstacle height, spacing and filling factor on the emission's grid.

    Parameters
    ----------
    obstacles
        :class:`~nightlights.ground.obstacles.ObstacleProperties` (the same in every cell) or
        a raster of three bands, height [m], spacing [m] and filling factor [1] (by band
        description when they are named so, else in that order), on the emission's grid.
        NaN (nodata): no obstacle in that cell.
    emission
        The emission raster.
    label
        How messages name the obstacles.

    Returns
    -------
    height, spacing, filling : numpy.ndarray
        (rows, cols) each [m], [m], [1].

    Raises
    ------
    InputError
        A raster of another grid or band count, or bad values
        (:func:`~nightlights.ground.obstacles.check_obstacles`).
    """
    shape = emission.shape
    if isinstance(obstacles, ObstacleProperties):
        return (
            np.full(shape, obstacles.height),
            np.full(shape, obstacles.spacing),
            np.full(shape, obstacles.filling),
        )
    if not isinstance(obstacles, Raster | xr.DataArray | str | os.PathLike):
        raise InputError(
            f"obstacles of type {type(obstacles).__name__}; expected ObstacleProperties or a "
            "three-band raster (height, spacing, filling)"
        )
    name = source_label(obstacles, label)
    raster = as_raster(obstacles)
    if raster.count != 3:
        raise InputError(
            f"{name}: {raster.count} bands; expected 3 (height [m], spacing [m], filling [1])"
        )
    if raster.shape != shape or not raster.transform.almost_equals(emission.transform):
        raise InputError(
            f"{name}: grid {raster.shape} at {tuple(raster.transform)[:6]}; expected the "
            f"emission's grid {shape} at {tuple(emission.transform)[:6]}"
        )
    order = (
        [raster.descriptions.index(band) for band in OBSTACLE_BANDS]
        if set(OBSTACLE_BANDS) <= set(raster.descriptions)
        else [0, 1, 2]
    )
    h, d, f = (raster.data[i] for i in order)
    check_obstacles(h, d, f)
    return h, d, f


def _band_functions(raster: Raster, label: str) -> tuple[EmissionFunction, ...]:
    """The bands' emission functions: the tag, or the sky stages' default for the count."""
    if raster.count not in _UNTAGGED:
        raise InputError(f"{label}: {raster.count} bands; expected 1 or 2")
    functions = []
    for band in range(raster.count):
        text = raster.band_tags[band].get(EMISSION_FUNCTION_TAG) or _UNTAGGED[raster.count][band]
        source = f"{label} band {band + 1} tag {EMISSION_FUNCTION_TAG}"
        functions.append(EmissionFunction.parse(text, source=source))
    return tuple(functions)


def _band_tag(shape: str, label: str) -> str:
    """The band tag that names one kernel shape alone."""
    if shape == "garstang_lobe":
        return "garstang:1,0"
    if shape.startswith(TABULATED_PREFIX) or emission_shape(shape).band_tag:
        return shape
    raise InputError(f"{label}: shape {shape!r} cannot be named alone in a band tag")


def obstructed_emission(
    emission: Raster | xr.DataArray | str | os.PathLike[str],
    obstacles: ObstacleInput,
    *,
    label: str = "emission raster",
) -> Raster | None:
    """The emission that leaves the streets: two bands, ``lambertian`` and one other shape.

    Parameters
    ----------
    emission
        Upward flux density [lm m-2], one or two bands with their ``emission_function``
        tags (untagged: as the sky stages read them).
    obstacles
        Uniform properties or a three-band raster on the emission's grid
        (:func:`obstacle_grids`).
    label
        How messages name the emission.

    Returns
    -------
    Raster or None
        The obstructed emission [lm m-2], its dataset tags kept and ``obstacles`` added; None
        when no cell has obstacles (h > 0 and f > 0).

    Raises
    ------
    InputError
        Bad obstacles, or bands whose functions use more than one shape besides the
        Lambertian one (the kernel's two bands cannot hold them).

    Examples
    --------
    A uniform Lambertian emission in canyons as high as they are wide keeps 0.447 of its flux:

    >>> from affine import Affine
    >>> raster = Raster(np.ones((1, 2, 2)), Affine(100, 0, 0, 0, -100, 200), "EPSG:32635",
    ...                 band_tags=({"emission_function": "lambertian"},))
    >>> out = obstructed_emission(raster, ObstacleProperties(10.0, 10.0, 1.0))
    >>> round(float(out.data[0, 0, 0]), 4), out.count
    (0.4472, 1)
    """
    raster = as_raster(emission)
    h, d, f = obstacle_grids(obstacles, raster)
    blocked = (h > 0) & (f > 0)
    if not np.any(blocked):
        return None
    functions = _band_functions(raster, label)
    flux: dict[str, FloatArray] = {}
    for band, function in enumerate(functions):
        for shape, weight in function.weights:
            if weight > 0:
                flux[shape] = flux.get(shape, 0.0) + weight * raster.data[band]
    others = [shape for shape in flux if shape != "lambertian"]
    if len(others) > 1:
        raise InputError(
            f"{label}: the bands' emission functions use {', '.join(others)} besides "
            "lambertian; obstacles take one other shape (two kernel bands)"
        )
    fill = np.where(blocked, f, 0.0)
    hb, db = h[blocked], d[blocked]
    over = np.zeros(raster.shape)
    for shape, values in flux.items():
        canyon = escaping_fraction(shape, hb, db, 1.0)
        over[blocked] += fill[blocked] * canyon * values[blocked]
    lambertian = flux.get("lambertian", np.zeros(raster.shape))
    bands = [np.where(blocked, (1.0 - fill) * lambertian + over, lambertian)]
    tags = [{**raster.band_tags[0], EMISSION_FUNCTION_TAG: "lambertian"}]
    descriptions = ["reflected and over the obstacles"]
    for shape in others:
        bands.append(np.where(blocked, (1.0 - fill) * flux[shape], flux[shape]))
        tags.append({**raster.band_tags[-1], EMISSION_FUNCTION_TAG: _band_tag(shape, label)})
        descriptions.append(f"{shape} through the gaps between the obstacles")
    unit = raster.units[0]
    return Raster(
        np.stack(bands),
        raster.transform,
        raster.crs,
        tuple(descriptions),
        (unit,) * len(bands),
        {**raster.tags, "obstacles": "ILLUMINA obstacles, street-canyon geometry"},
        tuple(tags),
    )
