"""The toolkit's stages as Processing algorithms, made from the description of the commands.

Each stage that ``stages.json`` describes (:mod:`.stages`) becomes a :class:`StageAlgorithm`:
one parameter per path and option of its command, of the QGIS type that fits it (a raster or
vector layer for an input, a destination for an output, a file or folder, a number, a choice, a
check box, a CRS, a point picked on the map, a point layer for a repeatable point), and the
command line made from the values (:func:`.stages.command_line`). Running it, progress, cancel
and outputs are the base class's (:mod:`.base`). Two algorithms add something to their
commands:

- ``streetstolights`` (:class:`StreetsToLights`) runs ``streets normalize``, ``sample`` and
  ``place`` in one go, with parameters taken from theirs;
- ``skyglow`` (:class:`Skyglow`) also returns the zenith luminance, brightness and Bortle
  class the command prints.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterPoint,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorDestination,
)

from .base import VECTOR_FORMATS, NightlightsAlgorithm
from .messages import parse_zenith
from .stages import (
    PATH_TYPES,
    command_line,
    enum_default,
    enum_options,
    enum_value,
    split_values,
)

Stage = Mapping[str, Any]
Parameter = Mapping[str, Any]

#: QGIS's layer types of the description's vector geometries.
GEOMETRIES = {
    "point": QgsProcessing.TypeVectorPoint,
    "line": QgsProcessing.TypeVectorLine,
    "polygon": QgsProcessing.TypeVectorPolygon,
    None: QgsProcessing.TypeVectorAnyGeometry,
}
#: QGIS's number types of the description's.
NUMBERS = {
    "integer": QgsProcessingParameterNumber.Integer,
    "float": QgsProcessingParameterNumber.Double,
}
#: What a file input asks for.
FILES = {"file": QgsProcessingParameterFile.File, "folder": QgsProcessingParameterFile.Folder}


def _given(parameters: Mapping[str, Any], name: str) -> bool:
    """Whether a parameter has a value (the dialog sends None or "" for none)."""
    value = parameters.get(name)
    return value is not None and not (isinstance(value, str) and not value)


def _file_filter(parameter: Parameter) -> str:
    """A Qt file filter of the parameter's extensions (empty: any file)."""
    return ";;".join(
        f"{extension.upper()} files (*.{extension})"
        for extension in parameter.get("extensions", ())
    )


def _crs_text(crs: QgsCoordinateReferenceSystem) -> str | None:
    """A CRS as the command reads it: its authority id, else its WKT (None: no CRS)."""
    return (crs.authid() or crs.toWkt()) if crs.isValid() else None


def parameter_definition(parameter: Parameter) -> QgsProcessingParameterDefinition:
    """The QGIS parameter of one parameter of a stage."""
    name, label, kind = parameter["name"], parameter["label"], parameter["type"]
    optional, default = not parameter["required"], parameter["default"]
    multiple = parameter["multiple"]
    definition: QgsProcessingParameterDefinition
    if kind in PATH_TYPES:
        definition = _path_definition(parameter)
    elif kind == "point" and multiple:
        definition = QgsProcessingParameterFeatureSource(
            name, f"{label} (a point layer: each point)", [GEOMETRIES["point"]], optional=optional
        )
    elif kind == "point":
        definition = QgsProcessingParameterPoint(name, label, optional=optional)
    elif kind == "enum":
        # one choice always has a value (its default, or "the command's default" first);
        # several may be none (then the command's default)
        indices = enum_default(parameter)
        definition = QgsProcessingParameterEnum(
            name,
            label,
            enum_options(parameter),
            allowMultiple=multiple,
            defaultValue=(indices or None) if multiple else indices,
            optional=multiple,
        )
    elif kind == "boolean":
        definition = QgsProcessingParameterBoolean(name, label, defaultValue=bool(default))
    elif kind == "crs":
        definition = QgsProcessingParameterCrs(name, label, optional=optional)
    elif kind in ("integer", "float") and multiple:
        definition = QgsProcessingParameterString(
            name, f"{label} (several: separated by commas or spaces)", optional=optional
        )
    elif kind in ("integer", "float"):
        number = NUMBERS[kind]
        limits = {
            key: value
            for key, value in (("minValue", parameter["min"]), ("maxValue", parameter["max"]))
            if value is not None
        }
        definition = QgsProcessingParameterNumber(
            name, label, number, defaultValue=default, optional=optional, **limits
        )
    elif multiple:
        definition = QgsProcessingParameterString(
            name, f"{label} (one per line)", multiLine=True, optional=optional
        )
    else:
        definition = QgsProcessingParameterString(
            name, label, defaultValue=default, optional=optional
        )
    flag = parameter["flag"]
    definition.setHelp(f"{parameter['help']} ({flag})" if flag else parameter["help"])
    return definition


def _path_definition(parameter: Parameter) -> QgsProcessingParameterDefinition:
    name, label, kind = parameter["name"], parameter["label"], parameter["type"]
    optional = not parameter["required"]
    geometry = GEOMETRIES[parameter.get("geometry")]
    if parameter["output"]:
        create = not optional
        if kind == "raster":
            return QgsProcessingParameterRasterDestination(
                name, label, optional=optional, createByDefault=create
            )
        if kind == "vector":
            return QgsProcessingParameterVectorDestination(
                name, label, geometry, optional=optional, createByDefault=create
            )
        if kind == "folder":
            return QgsProcessingParameterFolderDestination(
                name, label, optional=optional, createByDefault=create
            )
        return QgsProcessingParameterFileDestination(
            name, label, _file_filter(parameter), optional=optional, createByDefault=create
        )
    if kind == "raster":
        return QgsProcessingParameterRasterLayer(name, label, optional=optional)
    if kind == "vector":
        return QgsProcessingParameterFeatureSource(name, label, [geometry], optional=optional)
    behavior = FILES[kind]
    return QgsProcessingParameterFile(
        name, label, behavior, optional=optional, fileFilter=_file_filter(parameter)
    )


def parameter_value(
    algorithm: NightlightsAlgorithm,
    parameter: Parameter,
    parameters: dict[str, Any],
    context: Any,
    feedback: Any,
) -> Any:
    """The value of one parameter as :func:`.stages.command_line` takes it (None: not given)."""
    name, kind = parameter["name"], parameter["type"]
    if kind in PATH_TYPES and parameter["output"]:
        layer = kind in ("raster", "vector")
        return algorithm.output_path(parameters, name, context, layer=layer) or None
    if kind == "boolean":
        return algorithm.parameterAsBoolean(parameters, name, context)
    if kind == "enum":
        if parameter["multiple"]:
            indices = algorithm.parameterAsEnums(parameters, name, context)
            return [enum_options(parameter)[index] for index in indices]
        return enum_value(parameter, algorithm.parameterAsEnum(parameters, name, context))
    if not _given(parameters, name):
        return None
    if kind == "raster":
        return algorithm.raster_path(parameters, name, context)
    if kind == "vector" and parameter.get("layer_flag"):
        return algorithm.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, name, context, VECTOR_FORMATS, "gpkg", feedback
        )
    if kind == "vector":
        return algorithm.vector_path(parameters, name, context, feedback)
    if kind in ("file", "folder"):
        return algorithm.parameterAsFile(parameters, name, context) or None
    if kind == "point":
        return _points(algorithm, parameter, parameters, context)
    if kind == "crs":
        return _crs_text(algorithm.parameterAsCrs(parameters, name, context))
    if kind in ("integer", "float") and parameter["multiple"]:
        return split_values(algorithm.parameterAsString(parameters, name, context))
    if kind == "integer":
        return algorithm.parameterAsInt(parameters, name, context)
    if kind == "float":
        return algorithm.parameterAsDouble(parameters, name, context)
    text = algorithm.parameterAsString(parameters, name, context)
    return split_values(text, lines=True) if parameter["multiple"] else text


def _points(
    algorithm: NightlightsAlgorithm, parameter: Parameter, parameters: dict[str, Any], context: Any
) -> Any:
    """A point parameter's ``(x, y, crs)``: in its own CRS, or in the CRS the command takes;
    for a repeatable one, the points of a point layer, in the layer's CRS."""
    name = parameter["name"]
    if parameter["multiple"]:
        source = algorithm.parameterAsSource(parameters, name, context)
        if source is None:
            return None
        crs = _crs_text(source.sourceCrs())
        return [
            (vertex.x(), vertex.y(), crs)
            for feature in source.getFeatures()
            for vertex in feature.geometry().vertices()
        ]
    if parameter.get("crs"):
        target = QgsCoordinateReferenceSystem(parameter["crs"])
        point = algorithm.parameterAsPoint(parameters, name, context, target)
        return (point.x(), point.y(), None)
    point = algorithm.parameterAsPoint(parameters, name, context)
    crs = algorithm.parameterAsPointCrs(parameters, name, context)
    return (point.x(), point.y(), _crs_text(crs))


def stage_values(
    algorithm: NightlightsAlgorithm,
    stage: Stage,
    parameters: dict[str, Any],
    context: Any,
    feedback: Any,
    names: Iterable[str] | None = None,
) -> dict[str, Any]:
    """The values of a stage's parameters (of ``names`` only, when given)."""
    wanted = None if names is None else set(names)
    return {
        parameter["name"]: parameter_value(algorithm, parameter, parameters, context, feedback)
        for parameter in stage["parameters"]
        if wanted is None or parameter["name"] in wanted
    }


def _line(stage: Stage, values: Mapping[str, Any]) -> list[str]:
    try:
        return command_line(stage, values)
    except ValueError as exc:
        raise QgsProcessingException(f"{stage['title']}: {exc}") from exc


class StageAlgorithm(NightlightsAlgorithm):
    """The algorithm of one stage command: its parameters and its command line."""

    def __init__(self, stage: Stage) -> None:
        super().__init__()
        self.stage = stage
        self.NAME = stage["id"]
        self.TITLE = stage["title"]
        self.GROUP = stage["group"]
        self.HELP = stage["help"]

    def createInstance(self) -> StageAlgorithm:
        return type(self)(self.stage)

    def initAlgorithm(self, config: Any = None) -> None:
        for parameter in self.stage["parameters"]:
            self.addParameter(parameter_definition(parameter))

    def steps(self, parameters: dict[str, Any], context: Any, feedback: Any) -> list[list[str]]:
        return [_line(self.stage, stage_values(self, self.stage, parameters, context, feedback))]


class Skyglow(StageAlgorithm):
    """``skyglow``, with the zenith luminance, brightness and Bortle class as outputs."""

    def initAlgorithm(self, config: Any = None) -> None:
        super().initAlgorithm(config)
        self.addOutput(QgsProcessingOutputNumber("ZENITH_LUMINANCE", "Zenith luminance [cd m-2]"))
        self.addOutput(
            QgsProcessingOutputNumber("ZENITH_MAGNITUDE", "Zenith brightness [mag arcsec-2]")
        )
        self.addOutput(QgsProcessingOutputNumber("BORTLE", "Bortle class"))

    def results(self, messages: list[str]) -> dict[str, Any]:
        return {**super().results(messages), **(parse_zenith(messages) or {})}


class StreetsToLights(NightlightsAlgorithm):
    """Normalize, sample and place in one run; the intermediate layers are temporary."""

    NAME = "streetstolights"
    TITLE = "Streetlights from streets"
    GROUP = "Streets"
    HELP = (
        "Normalize, sample and place in one run: from any street line layer to the "
        "streetlights along it. The normalized and sampled streets are temporary files."
    )
    #: The stages it runs, in order, and the parameters it takes from each.
    PARTS = (
        ("streetsnormalize", ("INPUT", "MAPPING")),
        ("streetssample", ("NETWORK", "SEED")),
        ("streetsplace", ("OUTPUT",)),
    )

    def __init__(self, stages: Mapping[str, Stage]) -> None:
        super().__init__()
        self.stages = stages

    def createInstance(self) -> StreetsToLights:
        return type(self)(self.stages)

    def initAlgorithm(self, config: Any = None) -> None:
        for stage_id, names in self.PARTS:
            for parameter in self.stages[stage_id]["parameters"]:
                if parameter["name"] in names:
                    self.addParameter(parameter_definition(parameter))

    def steps(self, parameters: dict[str, Any], context: Any, feedback: Any) -> list[list[str]]:
        (normalize, first), (sample, second), (place, third) = (
            (self.stages[stage_id], names) for stage_id, names in self.PARTS
        )
        normalized = self.temporary_path("normalized.gpkg")
        lit = self.temporary_path("lit.gpkg")
        sampling = stage_values(self, sample, parameters, context, feedback, second)
        return [
            _line(
                normalize,
                {
                    **stage_values(self, normalize, parameters, context, feedback, first),
                    "OUTPUT": normalized,
                },
            ),
            _line(sample, {**sampling, "INPUT": normalized, "OUTPUT": lit}),
            _line(
                place,
                {
                    **stage_values(self, place, parameters, context, feedback, third),
                    "INPUT": lit,
                    "SEED": sampling["SEED"],
                },
            ),
        ]


#: Algorithms that add to their stage's: stage id -> class.
SPECIAL: dict[str, type[StageAlgorithm]] = {"skyglow": Skyglow}


def algorithms(stages: Iterable[Stage]) -> list[NightlightsAlgorithm]:
    """The provider's algorithms: one per stage, and :class:`StreetsToLights`."""
    by_id = {stage["id"]: stage for stage in stages}
    made: list[NightlightsAlgorithm] = [
        SPECIAL.get(stage_id, StageAlgorithm)(stage) for stage_id, stage in by_id.items()
    ]
    if all(stage_id in by_id for stage_id, _ in StreetsToLights.PARTS):
        made.append(StreetsToLights(by_id))
    return made
