"""Values of the library that the command's options use, read when first needed.

``nightlights --help`` must not import the library (numpy, GDAL, the kernels): the choices and
defaults that are the library's are named here by module and attribute (:class:`FromLibrary`)
and read when a command's help or arguments first need them; ``tests/cli/test_options.py``
reads every one, so a constant that moves in the library fails there.
"""

from __future__ import annotations

import importlib
import typing
from collections.abc import Mapping
from typing import Any

import click


class FromLibrary:
    """A constant of the library, imported on first use (``--help`` must not load the library).

    Parameters
    ----------
    module
        The module that defines it (``"nightlights.sky.panorama"``).
    attribute
        Its name, dotted for an attribute of a class (``"AreaLightOptions.height"``); a trailing
        ``()`` calls it (``"builtin_mappings()"``); a ``Literal`` type stands for its values.

    Calling the object returns the value; ``str()`` gives it as ``--help`` shows a default.
    """

    def __init__(self, module: str, attribute: str) -> None:
        self.module = module
        self.attribute = attribute

    def __call__(self) -> Any:
        value: Any = importlib.import_module(self.module)
        call = self.attribute.endswith("()")
        for part in self.attribute.removesuffix("()").split("."):
            value = getattr(value, part)
        if call:
            return value()
        # a Literal type (the library's ``OnConflict``) stands for its values
        return typing.get_args(value) if typing.get_origin(value) is typing.Literal else value

    def __str__(self) -> str:
        value = self()
        return ", ".join(map(str, value)) if isinstance(value, list | tuple) else str(value)

    def __repr__(self) -> str:
        return f"FromLibrary({self.module!r}, {self.attribute!r})"


class LibraryChoice(click.Choice):
    """A :class:`click.Choice` whose choices are a constant of the library (:class:`FromLibrary`),
    read when first needed."""

    def __init__(self, source: FromLibrary, case_sensitive: bool = True) -> None:
        self.source = source
        self.case_sensitive = case_sensitive

    @property
    def choices(self) -> tuple[Any, ...]:
        return tuple(self.source())

    @choices.setter
    def choices(self, value: Any) -> None:
        raise AttributeError("the choices of a LibraryChoice are the library's")


class LibraryHelpOption(click.Option):
    """An option whose help names values of the library: ``{name}`` fields of the help are
    filled from ``help_values`` (each a :class:`FromLibrary`) when the help is shown."""

    def __init__(
        self, *args: Any, help_values: Mapping[str, FromLibrary] | None = None, **kwargs: Any
    ) -> None:
        self.help_values = dict(help_values or {})
        super().__init__(*args, **kwargs)

    @property
    def help(self) -> str | None:
        if self._help is None or not self.help_values:
            return self._help
        return self._help.format(**{key: str(v) for key, v in self.help_values.items()})

    @help.setter
    def help(self, value: str | None) -> None:
        self._help = value


# the library's constants that options use (each read when first needed)
SKYGLOW_MODES = FromLibrary("nightlights.sky.panorama", "MODES")
PROJECTIONS = FromLibrary("nightlights.sky.render", "PROJECTIONS")
KERNEL_BACKENDS = FromLibrary("nightlights.sky.kernel", "BACKENDS")
KERNEL_PRECISIONS = FromLibrary("nightlights.sky.pca", "PRECISIONS")
MULTIPLE_SCATTERING_MODELS = FromLibrary("nightlights.sky.multiple", "MULTIPLE_SCATTERING_MODELS")
IRRADIANCE_BACKENDS = FromLibrary("nightlights.ground.illuminance", "BACKENDS")
SENSORS = FromLibrary("ies.spectra", "SENSORS")
DEFAULT_VIIRS_SPECTRUM = FromLibrary("nightlights.ground.upward", "DEFAULT_VIIRS_SPECTRUM")
DEFAULT_AREA_HEIGHT = FromLibrary("nightlights.ground.area_lights", "AreaLightOptions.height")
DEFAULT_MAX_RADIUS = FromLibrary("nightlights.ground.influence", "InfluenceThreshold.max_radius")
DEFAULT_ALONG_JITTER = FromLibrary("nightlights.streets._place", "PlacementOptions.along_jitter")
DEFAULT_ACROSS_JITTER = FromLibrary("nightlights.streets._place", "PlacementOptions.across_jitter")
DEFAULT_CLOUD_OPTICAL_DEPTH = FromLibrary("nightlights.sky.clouds", "DEFAULT_CLOUD_OPTICAL_DEPTH")
DEFAULT_MERGE_FRACTION = FromLibrary(
    "nightlights.streets._place", "PlacementOptions.merge_fraction"
)
DEFAULT_CANDIDATES = FromLibrary("nightlights.streets._sample", "DEFAULT_CANDIDATES")
DEFAULT_MAX_DISTANCE = FromLibrary("nightlights.streets._learn", "DEFAULT_MAX_DISTANCE")
BUILTIN_MAPPINGS = FromLibrary("nightlights.streets", "builtin_mappings()")
NETWORK_CATALOG = FromLibrary("bayesnets", "catalog_names()")
ON_CONFLICT = FromLibrary("bayesnets.sampling", "OnConflict")
Q_METRICS = FromLibrary("nightlights.sky.influence", "METRICS")
S_WEIGHTS = FromLibrary("nightlights.sky.influence", "WEIGHTS")
S_METHODS = FromLibrary("nightlights.inverse.stage", "S_METHODS")
PLAN_OBJECTIVES = FromLibrary("nightlights.roads._plan", "OBJECTIVES")
OBSERVER_SCHEDULERS = FromLibrary("nightlights.sky.observers", "SCHEDULERS")
SKY_PROJECTIONS = FromLibrary("nightlights.nightsky.render", "PROJECTIONS")
TONE_MODES = FromLibrary("nightlights.nightsky.tonemap", "MODES")
PROJECT_STAGES = FromLibrary("nightlights.project", "STAGES")
INSTRUMENT_NAMES = FromLibrary("nightlights.sky.instruments", "INSTRUMENTS")
SPECTRA = FromLibrary("ies.spectra", "SPDS")
DEFAULT_SPECTRUM = FromLibrary("nightlights.sky.instrument_units", "DEFAULT_SPECTRUM")
READING_FORMATS = FromLibrary("nightlights.meter.readings", "FORMATS")
VALIDATION_METHODS = FromLibrary("nightlights.meter.validation", "METHODS")
NATURAL_SKIES = FromLibrary("nightlights.meter.validation", "NATURAL_SKIES")
CALIBRATION_PARAMETERS = FromLibrary("nightlights.meter.calibrate", "PARAMETERS")
DEFAULT_STATISTIC = FromLibrary("nightlights.meter.conditions", "DEFAULT_STATISTIC")


def kernel_default(field: str) -> FromLibrary:
    """The default of a :class:`~nightlights.sky.KernelSpec` field."""
    return FromLibrary("nightlights.sky.spec", f"KernelSpec.{field}")


def atmosphere_default(field: str) -> FromLibrary:
    """The default of an :class:`~nightlights.sky.atmosphere.Atmosphere` field."""
    return FromLibrary("nightlights.sky.atmosphere", f"Atmosphere.{field}")
