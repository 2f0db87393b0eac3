"""The ``nightlights`` Processing provider: the toolkit's stages in the Processing Toolbox, one
algorithm per stage that the plugin's ``stages.json`` describes."""

from __future__ import annotations

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from .algorithms import algorithms
from .runner import COMMAND_SETTING
from .stages import STAGES_FILE, read_stages

#: Provider id: algorithms are ``nightlights:<name>``.
PROVIDER_ID = "nightlights"


class NightlightsProvider(QgsProcessingProvider):
    """Registers the algorithms and the setting for the command's path."""

    def id(self) -> str:
        return PROVIDER_ID

    def name(self) -> str:
        return "nightlights"

    def longName(self) -> str:
        return "nightlights: streetlights, irradiance, emission and skyglow"

    def icon(self) -> QIcon:
        return QgsApplication.getThemeIcon("/processingAlgorithm.svg")

    def load(self) -> bool:
        try:
            from processing.core.ProcessingConfig import ProcessingConfig, Setting
        except ImportError:  # Processing's Python plugin absent: no settings page
            return super().load()
        ProcessingConfig.settingIcons[self.name()] = self.icon()
        ProcessingConfig.addSetting(
            Setting(
                self.name(),
                COMMAND_SETTING,
                "nightlights command (empty: $NIGHTLIGHTS_COMMAND, the one recorded by "
                "`nightlights qgis-plugin build`, then PATH)",
                "",
                valuetype=Setting.FILE,
            )
        )
        ProcessingConfig.readSettings()
        return super().load()

    def unload(self) -> None:
        try:
            from processing.core.ProcessingConfig import ProcessingConfig
        except ImportError:
            return
        ProcessingConfig.removeSetting(COMMAND_SETTING)

    def loadAlgorithms(self) -> None:
        try:
            stages = read_stages()
        except (OSError, ValueError) as exc:
            QgsMessageLog.logMessage(
                f"nightlights: no algorithms, {STAGES_FILE} unreadable ({exc}); rebuild the "
                "plugin with `nightlights qgis-plugin build`",
                "Processing",
                Qgis.Critical,
            )
            return
        for algorithm in algorithms(stages):
            self.addAlgorithm(algorithm)

    def supportedOutputVectorLayerExtensions(self) -> list[str]:
        return ["gpkg"]

    def supportedOutputRasterLayerExtensions(self) -> list[str]:
        return ["tif"]

    def defaultVectorFileExtension(self, hasGeometry: bool = True) -> str:
        return "gpkg"

    def defaultRasterFileExtension(self) -> str:
        return "tif"
