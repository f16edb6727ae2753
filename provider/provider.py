"""The "LiDAR Trees" processing provider: one algorithm per ``lidartrees`` command."""
from qgis.core import QgsProcessingProvider

from ._lib import commands, executable_error
from .texts import tr
from .translation import install_translator


class LidarTreesProvider(QgsProcessingProvider):
    def __init__(self):
        super().__init__()
        install_translator()  # QGIS's language, before any algorithm is created

    def id(self):
        return "lidartrees"

    def name(self):
        return "LiDAR Trees"

    def longName(self):  # noqa: N802
        return tr("LiDAR Trees (lidartrees_gis)")

    def loadAlgorithms(self):  # noqa: N802
        from .algorithm import CommandAlgorithm

        install_translator()  # the language may have changed since the provider was made
        for cmd in commands().values():
            self.addAlgorithm(CommandAlgorithm(cmd.name))

    def canBeActivated(self):  # noqa: N802
        return True

    def warningMessage(self):  # noqa: N802
        return executable_error() or ""
