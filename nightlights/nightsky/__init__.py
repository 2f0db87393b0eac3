"""The natural night sky and the eye: stars, the Sun, the Moon, the sky's own glow, tone mapping.

Star positions come from the Yale Bright Star Catalogue shipped with the package (9,096 stars
to V = 6.5) and Meeus's algorithms (apparent place, sidereal time, refraction); the Sun and the
Moon from Meeus's low-accuracy theories; moonlight on the sky from Krisciunas & Schaefer
(1991). The natural background, the composed picture in three projections and the
night-vision tone mapping are in ``background``, ``render`` and ``tonemap``;
:func:`sky_render` is the stage. Everything is imported lazily.

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
}

if TYPE_CHECKING:
    from nightlights.nightsky.astro import (
        airmass,
        julian_date,
        refraction,
        star_positions,
    )
    from nightlights.nightsky.background import (
        NaturalSky,
        natural_sky_luminance,
        schaefer_twilight,
        starlight_density,
        twilight_phase,
        van_rhijn_factor,
    )
    from nightlights.nightsky.catalog import (
        StarCatalog,
        load_catalog,
    )
    from nightlights.nightsky.moon import (
        MoonState,
        moon_sky_brightness,
        moon_state,
        sun_position,
    )
    from nightlights.nightsky.render import (
        SkyImage,
        SkyOptions,
        View,
        ballesteros_temperature,
        render_sky,
        schaefer_limiting_magnitude,
        splat_points,
        view_pixels,
        zenith_summary,
    )
    from nightlights.nightsky.stage import (
        SkyRenderResult,
        sky_render,
    )
    from nightlights.nightsky.tonemap import (
        ToneMapping,
        blue_shift,
        mesopic_weight,
        scotopic_luminance,
        tone_map,
        visual_acuity,
    )

__all__ = [
    "MoonState",
    "NaturalSky",
    "SkyImage",
    "SkyOptions",
    "SkyRenderResult",
    "StarCatalog",
    "ToneMapping",
    "View",
    "airmass",
    "ballesteros_temperature",
    "blue_shift",
    "julian_date",
    "load_catalog",
    "mesopic_weight",
    "moon_sky_brightness",
    "moon_state",
    "natural_sky_luminance",
    "refraction",
    "render_sky",
    "schaefer_limiting_magnitude",
    "schaefer_twilight",
    "scotopic_luminance",
    "sky_render",
    "splat_points",
    "star_positions",
    "starlight_density",
    "sun_position",
    "tone_map",
    "twilight_phase",
    "van_rhijn_factor",
    "view_pixels",
    "visual_acuity",
    "zenith_summary",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nightlights.nightsky' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
