"""The zenith Q map under a cloud deck: each lit cell's part of the overcast zenith.

The zenith of the cloudy panorama (:mod:`nightlights.sky.cloudy`) is, per distance bin, the
bin's flux times the overcast zenith per lumen
(:func:`~nightlights.sky.cloudy.cloudy_zenith_per_lumen`, every ground-cloud reflection
included), whatever the source's azimuth. With the cover c the zenith table of each cell's
polar bin becomes

.. math:: q_b(d, a) = (1 - c)\\, q^{clear}_b(d, a) + c\\, z^c_b(d),

so the cells' values still add up to the panorama's zenith, now the mixed one. Carried on flat
ground, for the zenith metric and a uniform cover; the rest is refused.
"""

from __future__ import annotations

import numpy as np

from nightlights._typing import FloatArray
from nightlights.errors import InputError
from nightlights.sky.atmosphere import Atmosphere
from nightlights.sky.cloudy import cloudy_panorama, cloudy_zenith_per_lumen
from nightlights.sky.polar import PolarCells
from nightlights.sky.scene import Scene
from nightlights.sky.setup import SceneSetup


def check_deck(scene: Scene, metric: str) -> bool:
    """Whether the scene's deck is carried (True), absent (False); refused otherwise.

    Raises
    ------
    InputError
        A deck with a metric other than ``zenith``, a DEM or a cover raster.
    """
    cloud = scene.clouds
    if cloud is None:
        return False
    why = (
        f"metric={metric!r}"
        if metric != "zenith"
        else "a scene with a DEM"
        if scene.dem is not None
        else "a cover raster"
        if cloud.cover_raster is not None
        else None
    )
    if why is not None:
        raise InputError(
            f"clouds={cloud!r}: the inverse map reads a cloud deck only for metric='zenith', "
            f"on flat ground and with a uniform cover, not for {why}; give the scene "
            "clouds=None"
        )
    return True


def overcast_tables(setup: SceneSetup, tables: list[FloatArray]) -> list[FloatArray]:
    """The zenith tables ``(bands, n_r, n_az)`` of every source level under the deck."""
    cloud = setup.scene.clouds if setup.scene is not None else None
    if cloud is None or cloud.cover == 0.0:
        return tables
    first = setup.slices[0]
    cloudy = cloudy_zenith_per_lumen(
        np.asarray(setup.table["distance_edges"].values, dtype=float),
        float(first.elevation[0]),
        first.n_az,
        setup.functions[: tables[0].shape[0]],
        cloud,
        Atmosphere.from_parameters(setup.table.attrs),
    )
    c = float(cloud.cover)
    return [(1.0 - c) * t + c * cloudy[: t.shape[0], :, None] for t in tables]


def overcast_zenith(setup: SceneSetup, cells: PolarCells, clear: FloatArray) -> float:
    """The zenith of the cloudy panorama of ``clear`` [cd m-2] (what the cells add up to)."""
    cloud = setup.scene.clouds if setup.scene is not None else None
    assert cloud is not None
    first = setup.slices[0]
    luminance, _ = cloudy_panorama(
        clear,
        cells.binned(),
        cells.distance_edges,
        first.elevation,
        setup.functions,
        cloud,
        Atmosphere.from_parameters(setup.table.attrs),
        cover=float(cloud.cover),
    )
    return float(np.mean(luminance[0]))


def deck_tags(scene: Scene) -> dict[str, str]:
    """The deck's tags on a map (none without one)."""
    cloud = scene.clouds
    if cloud is None:
        return {}
    return {
        "cloud_cover": str(float(cloud.cover)),
        "cloud_base_height_m": str(float(cloud.base_height)),
        "cloud_reflectance": str(cloud.reflectance),
        "cloud_ground_albedo": str(float(cloud.ground_albedo)),
    }
