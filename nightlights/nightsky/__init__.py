"""The natural night sky: stars, the Sun and the Moon, seen from a place at a time.

Star positions come from the Yale Bright Star Catalogue shipped with the package (9,096 stars
to V = 6.5) and Meeus's algorithms (apparent place, sidereal time, refraction); the Sun and the
Moon from Meeus's low-accuracy theories; moonlight on the sky from Krisciunas & Schaefer (1991).
Everything is imported lazily.

References
----------
1. Meeus, J. 1998, "Astronomical Algorithms", 2nd ed., Willmann-Bell.
2. Hoffleit, D. & Warren Jr, W. H. 1991, "The Bright Star Catalogue, 5th Revised Ed.",
   NSSDC/ADC (CDS V/50).
3. Krisciunas, K. & Schaefer, B. E. 1991, "A model of the brightness of moonlight",
   PASP 103, 1033-1039.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY: dict[str, str] = {
    "StarCatalog": "nightlights.nightsky.catalog",
    "load_catalog": "nightlights.nightsky.catalog",
    "julian_date": "nightlights.nightsky.astro",
    "star_positions": "nightlights.nightsky.astro",
    "airmass": "nightlights.nightsky.astro",
    "refraction": "nightlights.nightsky.astro",
    "sun_position": "nightlights.nightsky.moon",
    "MoonState": "nightlights.nightsky.moon",
    "moon_state": "nightlights.nightsky.moon",
    "moon_sky_brightness": "nightlights.nightsky.moon",
    # --- render helper: names of background.py, tonemap.py, render.py, stage.py below ---
    "NaturalSky": "nightlights.nightsky.background",
    "natural_sky_luminance": "nightlights.nightsky.background",
    "schaefer_twilight": "nightlights.nightsky.background",
    "starlight_density": "nightlights.nightsky.background",
    "twilight_phase": "nightlights.nightsky.background",
    "van_rhijn_factor": "nightlights.nightsky.background",
    "SkyImage": "nightlights.nightsky.render",
    "SkyOptions": "nightlights.nightsky.render",
    "View": "nightlights.nightsky.render",
    "ballesteros_temperature": "nightlights.nightsky.render",
    "render_sky": "nightlights.nightsky.render",
    "schaefer_limiting_magnitude": "nightlights.nightsky.render",
    "splat_points": "nightlights.nightsky.render",
    "view_pixels": "nightlights.nightsky.render",
    "zenith_summary": "nightlights.nightsky.render",
    "SkyRenderResult": "nightlights.nightsky.stage",
    "sky_render": "nightlights.nightsky.stage",
    "ToneMapping": "nightlights.nightsky.tonemap",
    "blue_shift": "nightlights.nightsky.tonemap",
    "mesopic_weight": "nightlights.nightsky.tonemap",
    "scotopic_luminance": "nightlights.nightsky.tonemap",
    "tone_map": "nightlights.nightsky.tonemap",
    "visual_acuity": "nightlights.nightsky.tonemap",
    # --- end of the render helper's block ---
}

if TYPE_CHECKING:
    from nightlights.nightsky.astro import airmass, julian_date, refraction, star_positions
    from nightlights.nightsky.catalog import StarCatalog, load_catalog
    from nightlights.nightsky.moon import MoonState, moon_sky_brightness, moon_state, sun_position

    # --- render helper: TYPE_CHECKING imports below ---
    # isort: split
    from nightlights.nightsky.background import NaturalSky as NaturalSky
    from nightlights.nightsky.background import natural_sky_luminance as natural_sky_luminance
    from nightlights.nightsky.background import schaefer_twilight as schaefer_twilight
    from nightlights.nightsky.background import starlight_density as starlight_density
    from nightlights.nightsky.background import twilight_phase as twilight_phase
    from nightlights.nightsky.background import van_rhijn_factor as van_rhijn_factor
    from nightlights.nightsky.render import SkyImage as SkyImage
    from nightlights.nightsky.render import SkyOptions as SkyOptions
    from nightlights.nightsky.render import View as View
    from nightlights.nightsky.render import ballesteros_temperature as ballesteros_temperature
    from nightlights.nightsky.render import render_sky as render_sky
    from nightlights.nightsky.render import (
        schaefer_limiting_magnitude as schaefer_limiting_magnitude,
    )
    from nightlights.nightsky.render import splat_points as splat_points
    from nightlights.nightsky.render import view_pixels as view_pixels
    from nightlights.nightsky.render import zenith_summary as zenith_summary
    from nightlights.nightsky.stage import SkyRenderResult as SkyRenderResult
    from nightlights.nightsky.stage import sky_render as sky_render
    from nightlights.nightsky.tonemap import ToneMapping as ToneMapping
    from nightlights.nightsky.tonemap import blue_shift as blue_shift
    from nightlights.nightsky.tonemap import mesopic_weight as mesopic_weight
    from nightlights.nightsky.tonemap import scotopic_luminance as scotopic_luminance
    from nightlights.nightsky.tonemap import tone_map as tone_map
    from nightlights.nightsky.tonemap import visual_acuity as visual_acuity
    # --- end of the render helper's block ---

__all__ = [
    "MoonState",
    "StarCatalog",
    "airmass",
    "julian_date",
    "load_catalog",
    "moon_sky_brightness",
    "moon_state",
    "refraction",
    "star_positions",
    "sun_position",
    # --- render helper: public names below ---
    *(
        name
        for name, module in _LAZY.items()
        if module.rsplit(".", 1)[1] in ("background", "tonemap", "render", "stage")
    ),
    # --- end of the render helper's block ---
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights.nightsky' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
