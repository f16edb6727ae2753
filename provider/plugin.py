"""The plugin object: adds the processing provider when QGIS (or qgis_process) starts."""
from qgis.core import QgsApplication


class LidarTreesPlugin:
    def __init__(self, iface=None):
        from .translation import install_translator

        self.iface = iface
        self.provider = None
        install_translator()  # pt_BR when QGIS's locale/userLocale starts with pt

    def initProcessing(self):  # noqa: N802 - QGIS API name
        from .provider import LidarTreesProvider

        self.provider = LidarTreesProvider()
        QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802
        self.initProcessing()

    def unload(self):
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
