"""The "LiDAR Trees" processing provider: one algorithm per ``lidartrees`` command."""
from qgis.core import QgsProcessingProvider

from ._lib import commands, executable_error


class LidarTreesProvider(QgsProcessingProvider):
    def id(self):
        return "lidartrees"

    def name(self):
        return "LiDAR Trees"

    def longName(self):  # noqa: N802
        return "LiDAR Trees (lidartrees_gis)"

    def loadAlgorithms(self):  # noqa: N802
        from .algorithm import CommandAlgorithm

        for cmd in commands().values():
            self.addAlgorithm(CommandAlgorithm(cmd.name))

    def canBeActivated(self):  # noqa: N802
        return True

    def warningMessage(self):  # noqa: N802
        return executable_error() or ""
