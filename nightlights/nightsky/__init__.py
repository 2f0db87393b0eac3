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
    # --- end of the render helper's block ---
}

if TYPE_CHECKING:
    from nightlights.nightsky.astro import airmass, julian_date, refraction, star_positions
    from nightlights.nightsky.catalog import StarCatalog, load_catalog
    from nightlights.nightsky.moon import MoonState, moon_sky_brightness, moon_state, sun_position

    # --- render helper: TYPE_CHECKING imports below ---
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
    # --- end of the render helper's block ---
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights.nightsky' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
