"""The plugin: registers the Processing provider. initProcessing() holds no GUI code, so that
qgis_process (which has no interface) sees the provider too."""
from qgis.core import QgsApplication

from .provider import RvoronoiProvider


class RvoronoiPlugin:
    def __init__(self, iface):
        self.iface = iface
        self.provider = None

    def initProcessing(self):  # noqa: N802 (QGIS's name)
        if self.provider is None:
            self.provider = RvoronoiProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802
        self.initProcessing()

    def unload(self):
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
