"""Meet the measured sky: photometer readings in, which readings count, validation against them.

Sky Quality Meter, TESS-W and naked-eye readings are read into one table
(:mod:`nightlights.meter.readings`), the clear, moonless, astronomical-night ones are kept and
reduced to one value per station (:mod:`nightlights.meter.conditions`), and the model's sky is
predicted as each instrument sees it and compared with them (:mod:`nightlights.meter.validation`).

The names are imported on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    # readings in
    "READING_COLUMNS": "nightlights.meter.readings",
    "limiting_magnitude_to_sky_brightness": "nightlights.meter.readings",
    "read_readings": "nightlights.meter.readings",
    # which readings count
    "sky_conditions": "nightlights.meter.conditions",
    "select_readings": "nightlights.meter.conditions",
    "station_values": "nightlights.meter.conditions",
    "station_statistic": "nightlights.meter.conditions",
    "plot_statistic": "nightlights.meter.conditions",
    "local_night": "nightlights.meter.conditions",
    "SUN_LIMIT": "nightlights.meter.conditions",
    "MOON_LIMIT": "nightlights.meter.conditions",
    "CLOUD_LIMIT": "nightlights.meter.conditions",
    "STATISTICS": "nightlights.meter.conditions",
    "DEFAULT_STATISTIC": "nightlights.meter.conditions",
    # predicted against measured
    "validate": "nightlights.meter.validation",
    "ValidationResult": "nightlights.meter.validation",
    "natural_reading": "nightlights.meter.natural",
    "Calibration": "nightlights.meter.calibrate",
    # published skies at real sites
    "read_real_skies": "nightlights.meter.real_skies",
    "SITE_CLASSES": "nightlights.meter.real_skies",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
