"""The toolkit's stages as Processing algorithms: streets, light, sky.

Each class names its parameters and the ``nightlights`` command lines they become; running
them, progress, cancel and outputs are the base class's (:mod:`.base`).
"""

from __future__ import annotations

from typing import Any

from qgis.core import (
    QgsProcessing,
    QgsProcessingOutputNumber,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterPoint,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorDestination,
)

from .base import VECTOR_FORMATS, NightlightsAlgorithm
from .choices import (
    DEFAULT_VIIRS_SPECTRUM,
    MAPPINGS,
    NETWORKS,
    PROJECTIONS,
    Q_METRICS,
    SENSORS,
)
from .messages import parse_zenith

#: Network choice meaning "chosen by where the streets lie" (the command's default).
BY_LOCATION = "by location"


def _given(parameters: dict, name: str) -> bool:
    """Whether an optional parameter has a value (the dialog sends None or "" for none)."""
    value = parameters.get(name)
    return value is not None and not (isinstance(value, str) and not value)


def _seed(algorithm: NightlightsAlgorithm, parameters: dict, context: Any) -> list[str]:
    if not _given(parameters, "SEED"):
        return []
    return ["--seed", str(algorithm.parameterAsInt(parameters, "SEED", context))]


def _seed_parameter() -> QgsProcessingParameterNumber:
    return QgsProcessingParameterNumber(
        "SEED",
        "Random seed (empty: a different layout each run)",
        QgsProcessingParameterNumber.Integer,
        optional=True,
        minValue=0,
    )


def _network(algorithm: NightlightsAlgorithm, parameters: dict, context: Any) -> list[str]:
    choice = (BY_LOCATION, *NETWORKS)[algorithm.parameterAsEnum(parameters, "NETWORK", context)]
    return [] if choice == BY_LOCATION else ["--network", choice]


def _network_parameter() -> QgsProcessingParameterEnum:
    return QgsProcessingParameterEnum(
        "NETWORK", "Bayesian network of street lighting", [BY_LOCATION, *NETWORKS], defaultValue=0
    )


def _streets_parameter(description: str) -> QgsProcessingParameterFeatureSource:
    return QgsProcessingParameterFeatureSource("INPUT", description, [QgsProcessing.TypeVectorLine])


def _lights_destination(description: str) -> QgsProcessingParameterVectorDestination:
    return QgsProcessingParameterVectorDestination(
        "OUTPUT", description, QgsProcessing.TypeVectorPoint
    )


class StreetsNormalize(NightlightsAlgorithm):
    NAME = "streetsnormalize"
    TITLE = "Normalize streets"
    GROUP = "Streets"
    HELP = (
        "Maps a street layer's fields onto the canonical street fields (class, lanes, width, "
        "median, one-way, lit) and reprojects it to a projected CRS (local UTM for geographic "
        "input). nightlights streets normalize."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(_streets_parameter("Streets (line layer)"))
        self.addParameter(
            QgsProcessingParameterEnum("MAPPING", "Field mapping", list(MAPPINGS), defaultValue=1)
        )
        self.addParameter(
            QgsProcessingParameterVectorDestination(
                "OUTPUT", "Normalized streets", QgsProcessing.TypeVectorLine
            )
        )

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, "INPUT", context, VECTOR_FORMATS, "gpkg", feedback
        )
        mapping = MAPPINGS[self.parameterAsEnum(parameters, "MAPPING", context)]
        line = ["streets", "normalize", path, self.output_path(parameters, "OUTPUT", context)]
        line += ["--mapping", mapping, "--overwrite"]
        return [line + (["--layer", layer] if layer else [])]


class StreetsSample(NightlightsAlgorithm):
    NAME = "streetssample"
    TITLE = "Sample street lighting"
    GROUP = "Streets"
    HELP = (
        "Fills the missing street and lighting fields of normalized streets by "
        "likelihood-weighted sampling of a Bayesian network (Chuang 2011, Sec. 3.3). "
        "nightlights streets sample."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(_streets_parameter("Normalized streets"))
        self.addParameter(_network_parameter())
        self.addParameter(_seed_parameter())
        self.addParameter(
            QgsProcessingParameterVectorDestination(
                "OUTPUT", "Streets with lighting", QgsProcessing.TypeVectorLine
            )
        )

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        path = self.vector_path(parameters, "INPUT", context, feedback)
        line = ["streets", "sample", path, self.output_path(parameters, "OUTPUT", context)]
        line += [*_network(self, parameters, context), *_seed(self, parameters, context)]
        return [[*line, "--overwrite"]]


class StreetsPlace(NightlightsAlgorithm):
    NAME = "streetsplace"
    TITLE = "Place streetlights"
    GROUP = "Streets"
    HELP = (
        "Places light systems along streets with lighting fields, in jittered rectangular or "
        "staggered grids (Chuang 2011, Sec. 3.4): one point per luminaire, with its pole, "
        "heading and photometry. nightlights streets place."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(_streets_parameter("Streets with lighting"))
        self.addParameter(_seed_parameter())
        self.addParameter(_lights_destination("Streetlights"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        path = self.vector_path(parameters, "INPUT", context, feedback)
        line = ["streets", "place", path, self.output_path(parameters, "OUTPUT", context)]
        return [[*line, *_seed(self, parameters, context), "--overwrite"]]


class StreetsToLights(NightlightsAlgorithm):
    NAME = "streetstolights"
    TITLE = "Streetlights from streets"
    GROUP = "Streets"
    HELP = (
        "Normalize, sample and place in one run: from any street line layer to the "
        "streetlights along it. The normalized and sampled streets are temporary files."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(_streets_parameter("Streets (line layer)"))
        self.addParameter(
            QgsProcessingParameterEnum("MAPPING", "Field mapping", list(MAPPINGS), defaultValue=1)
        )
        self.addParameter(_network_parameter())
        self.addParameter(_seed_parameter())
        self.addParameter(_lights_destination("Streetlights"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, "INPUT", context, VECTOR_FORMATS, "gpkg", feedback
        )
        normalized = self.temporary_path("normalized.gpkg")
        lit = self.temporary_path("lit.gpkg")
        mapping = MAPPINGS[self.parameterAsEnum(parameters, "MAPPING", context)]
        seed = _seed(self, parameters, context)
        normalize = ["streets", "normalize", path, normalized, "--mapping", mapping]
        normalize += ["--layer", layer] if layer else []
        sample = ["streets", "sample", normalized, lit, *_network(self, parameters, context)]
        lights = self.output_path(parameters, "OUTPUT", context)
        return [
            [*normalize, "--overwrite"],
            [*sample, *seed, "--overwrite"],
            ["streets", "place", lit, lights, *seed, "--overwrite"],
        ]


class Irradiance(NightlightsAlgorithm):
    NAME = "irradiance"
    TITLE = "Ground irradiance"
    GROUP = "Light"
    HELP = (
        "Illuminance [lx] the streetlights put on the ground (and sensor-weighted irradiance "
        "[W m-2] for other sensors), one band per sensor, from each luminaire's photometry "
        "within its region of influence. nightlights irradiance."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(
            QgsProcessingParameterFeatureSource(
                "LIGHTS", "Streetlights", [QgsProcessing.TypeVectorPoint]
            )
        )
        self.addParameter(
            QgsProcessingParameterNumber(
                "RESOLUTION",
                "Pixel size [m]",
                QgsProcessingParameterNumber.Double,
                defaultValue=1.0,
                minValue=0.01,
            )
        )
        self.addParameter(
            QgsProcessingParameterEnum(
                "SENSORS",
                "Sensors (one band each)",
                list(SENSORS),
                allowMultiple=True,
                defaultValue=[0],
            )
        )
        self.addParameter(
            QgsProcessingParameterRasterLayer(
                "DEM", "Terrain heights above sea level [m]", optional=True
            )
        )
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Irradiance"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        lights = self.vector_path(parameters, "LIGHTS", context, feedback)
        resolution = self.parameterAsDouble(parameters, "RESOLUTION", context)
        line = ["irradiance", lights, self.output_path(parameters, "OUTPUT", context)]
        line += ["--resolution", repr(resolution)]
        for index in self.parameterAsEnums(parameters, "SENSORS", context) or [0]:
            line += ["--sensor", SENSORS[index]]
        dem = self.raster_path(parameters, "DEM", context)
        return [line + (["--dem", dem] if dem else []) + ["--overwrite"]]


class Emission(NightlightsAlgorithm):
    NAME = "emission"
    TITLE = "Upward emission"
    GROUP = "Light"
    HELP = (
        "Upward flux density [lm m-2] for skyglow: the ground-reflected light of an irradiance "
        "raster (Lambertian, times the albedo) plus the luminaires' direct uplight, aggregated "
        "to a coarser grid. nightlights emission ground."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(QgsProcessingParameterRasterLayer("IRRADIANCE", "Irradiance"))
        self.addParameter(
            QgsProcessingParameterFeatureSource(
                "LIGHTS",
                "Streetlights (their direct uplight)",
                [QgsProcessing.TypeVectorPoint],
                optional=True,
            )
        )
        self.addParameter(
            QgsProcessingParameterNumber(
                "RESOLUTION",
                "Cell size [m] (a multiple of the irradiance pixel size)",
                QgsProcessingParameterNumber.Double,
                defaultValue=50.0,
                minValue=0.01,
            )
        )
        self.addParameter(
            QgsProcessingParameterNumber(
                "ALBEDO",
                "Ground albedo [1]",
                QgsProcessingParameterNumber.Double,
                defaultValue=0.15,
                minValue=0.0,
                maxValue=1.0,
            )
        )
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Emission"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        irradiance = self.raster_path(parameters, "IRRADIANCE", context)
        assert irradiance is not None  # a required parameter
        inputs = [irradiance]
        if _given(parameters, "LIGHTS"):
            inputs.append(self.vector_path(parameters, "LIGHTS", context, feedback))
        resolution = self.parameterAsDouble(parameters, "RESOLUTION", context)
        albedo = self.parameterAsDouble(parameters, "ALBEDO", context)
        line = ["emission", "ground", *inputs, self.output_path(parameters, "OUTPUT", context)]
        return [[*line, "--resolution", repr(resolution), "--albedo", repr(albedo), "--overwrite"]]


class EmissionFromViirs(NightlightsAlgorithm):
    NAME = "emissionviirs"
    TITLE = "Upward emission from VIIRS"
    GROUP = "Light"
    HELP = (
        "Upward flux density [lm m-2] from a VIIRS day/night-band radiance raster "
        "[nW cm-2 sr-1], converted with the spectrum of the lights. nightlights emission viirs."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(QgsProcessingParameterRasterLayer("INPUT", "VIIRS DNB radiance"))
        self.addParameter(
            QgsProcessingParameterString(
                "SPECTRUM",
                "Spectrum of the lights (HPS, LED_3000K, LED_4000K, ...)",
                defaultValue=DEFAULT_VIIRS_SPECTRUM,
            )
        )
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Emission"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        viirs = self.raster_path(parameters, "INPUT", context)
        assert viirs is not None  # a required parameter
        spectrum = self.parameterAsString(parameters, "SPECTRUM", context)
        line = ["emission", "viirs", viirs, self.output_path(parameters, "OUTPUT", context)]
        return [[*line, "--spectrum", spectrum, "--overwrite"]]


def _sky_parameters(algorithm: NightlightsAlgorithm) -> None:
    """Observer height, turbidity, kernel and DEM, shared by skyglow and darkness."""
    algorithm.addParameter(
        QgsProcessingParameterNumber(
            "OBSERVER_HEIGHT",
            "Observer height above ground [m]",
            QgsProcessingParameterNumber.Double,
            defaultValue=1.7,
            minValue=0.0,
        )
    )
    algorithm.addParameter(
        QgsProcessingParameterNumber(
            "TURBIDITY",
            "Turbidity (empty: 2)",
            QgsProcessingParameterNumber.Double,
            optional=True,
            minValue=1.0,
        )
    )
    algorithm.addParameter(
        QgsProcessingParameterFile(
            "KERNEL",
            "Precomputed kernel (empty: a cached scene kernel, built on first use)",
            extension="nc",
            optional=True,
        )
    )
    algorithm.addParameter(
        QgsProcessingParameterRasterLayer(
            "DEM", "Terrain heights above sea level [m]", optional=True
        )
    )


def _sky_options(algorithm: NightlightsAlgorithm, parameters: dict, context: Any) -> list[str]:
    height = algorithm.parameterAsDouble(parameters, "OBSERVER_HEIGHT", context)
    options = ["--observer-height", repr(height)]
    if _given(parameters, "TURBIDITY"):
        turbidity = algorithm.parameterAsDouble(parameters, "TURBIDITY", context)
        options += ["--turbidity", repr(turbidity)]
    kernel = algorithm.parameterAsFile(parameters, "KERNEL", context)
    dem = algorithm.raster_path(parameters, "DEM", context)
    return options + (["--kernel", kernel] if kernel else []) + (["--dem", dem] if dem else [])


class Skyglow(NightlightsAlgorithm):
    NAME = "skyglow"
    TITLE = "Skyglow panorama"
    GROUP = "Sky"
    HELP = (
        "The artificial sky glow an observer sees over an emission raster (Dobashi et al. "
        "2023): a panorama of luminance and mag arcsec-2 (NetCDF, or a GeoTIFF on an azimuth "
        "and elevation grid for a .tif), an optional picture, and "
        "the zenith brightness and Bortle class as outputs. nightlights skyglow."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(QgsProcessingParameterRasterLayer("EMISSION", "Emission [lm m-2]"))
        self.addParameter(QgsProcessingParameterPoint("OBSERVER", "Observer"))
        _sky_parameters(self)
        self.addParameter(
            QgsProcessingParameterEnum(
                "PROJECTION", "Picture projection", list(PROJECTIONS), defaultValue=0
            )
        )
        self.addParameter(
            QgsProcessingParameterFileDestination(
                "OUTPUT", "Panorama", "NetCDF (*.nc);;GeoTIFF (*.tif)"
            )
        )
        self.addParameter(
            QgsProcessingParameterFileDestination(
                "PNG", "Picture", "PNG (*.png)", optional=True, createByDefault=False
            )
        )
        self.addOutput(QgsProcessingOutputNumber("ZENITH_LUMINANCE", "Zenith luminance [cd m-2]"))
        self.addOutput(
            QgsProcessingOutputNumber("ZENITH_MAGNITUDE", "Zenith brightness [mag arcsec-2]")
        )
        self.addOutput(QgsProcessingOutputNumber("BORTLE", "Bortle class"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        emission = self.raster_path(parameters, "EMISSION", context)
        assert emission is not None  # a required parameter
        line = ["skyglow", emission, self.output_path(parameters, "OUTPUT", context, layer=False)]
        line += [*_observer_options(self, parameters, context)]
        line += _sky_options(self, parameters, context)
        png = self.output_path(parameters, "PNG", context, layer=False)
        if png:
            projection = PROJECTIONS[self.parameterAsEnum(parameters, "PROJECTION", context)]
            line += ["--png", png, "--projection", projection]
        return [[*line, "--overwrite"]]

    def results(self, messages: list[str]) -> dict[str, Any]:
        return {**super().results(messages), **(parse_zenith(messages) or {})}


def _observer_options(algorithm: NightlightsAlgorithm, parameters: dict, context: Any) -> list[str]:
    """``--observer X,Y`` and ``--observer-crs`` of a point parameter (in its own CRS)."""
    point = algorithm.parameterAsPoint(parameters, "OBSERVER", context)
    crs = algorithm.parameterAsPointCrs(parameters, "OBSERVER", context)
    options = ["--observer", f"{point.x()!r},{point.y()!r}"]
    return options + (["--observer-crs", crs.authid() or crs.toWkt()] if crs.isValid() else [])


class LightPollutionByCell(NightlightsAlgorithm):
    NAME = "inverseq"
    TITLE = "Light pollution by cell"
    GROUP = "Sky"
    HELP = (
        "Which lit cells cause an observer's skyglow: each cell's light-pollution level "
        "(pca-norm: Q_i, Dobashi et al. 2023 Eq. 11), or its part of the zenith luminance or of "
        "the mean luminance of the visible sky [cd m-2], on the emission raster's grid (NaN "
        "where unlit). nightlights inverse q."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(QgsProcessingParameterRasterLayer("EMISSION", "Emission [lm m-2]"))
        self.addParameter(QgsProcessingParameterPoint("OBSERVER", "Observer"))
        self.addParameter(
            QgsProcessingParameterEnum("METRIC", "Measure", list(Q_METRICS), defaultValue=0)
        )
        _sky_parameters(self)
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Light pollution"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        emission = self.raster_path(parameters, "EMISSION", context)
        assert emission is not None  # a required parameter
        metric = Q_METRICS[self.parameterAsEnum(parameters, "METRIC", context)]
        line = ["inverse", "q", emission, self.output_path(parameters, "OUTPUT", context)]
        line += [*_observer_options(self, parameters, context), "--metric", metric]
        return [[*line, *_sky_options(self, parameters, context), "--overwrite"]]


class Darkness(NightlightsAlgorithm):
    NAME = "darkness"
    TITLE = "Zenith darkness map"
    GROUP = "Sky"
    HELP = (
        "The artificial zenith sky brightness with the observer at every cell of an emission "
        "raster (band 1 [cd m-2], band 2 [mag arcsec-2]), by FFT convolution with the zenith "
        "kernel. nightlights darkness."
    )

    def initAlgorithm(self, config: Any = None) -> None:
        self.addParameter(QgsProcessingParameterRasterLayer("EMISSION", "Emission [lm m-2]"))
        _sky_parameters(self)
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Zenith brightness"))

    def steps(self, parameters: dict, context: Any, feedback: Any) -> list[list[str]]:
        emission = self.raster_path(parameters, "EMISSION", context)
        assert emission is not None  # a required parameter
        line = ["darkness", emission, self.output_path(parameters, "OUTPUT", context)]
        return [[*line, *_sky_options(self, parameters, context), "--overwrite"]]


#: The provider's algorithms, in toolbox order.
ALGORITHMS = (
    StreetsNormalize,
    StreetsSample,
    StreetsPlace,
    StreetsToLights,
    Irradiance,
    Emission,
    EmissionFromViirs,
    Skyglow,
    LightPollutionByCell,
    Darkness,
)
