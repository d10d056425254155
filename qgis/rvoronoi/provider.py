"""The Processing provider "rvoronoi": its algorithms are made from the process descriptions of the
configured server (cached; descriptions.py), or of the local Python module.

Settings (Processing options > Providers > rvoronoi, or the environment for qgis_process):
  - the server's URL (RVORONOI_URL);
  - the authentication configuration holding its token (RVORONOI_AUTHCFG: a Basic
    configuration whose password is the token);
  - the mode (RVORONOI_MODE): "auto" (the server when a URL is set, else local), "server",
    "local".
"""
from qgis.core import Qgis, QgsMessageLog, QgsProcessingProvider, QgsSettings

from . import client, descriptions
from .algorithm import DescribedAlgorithm

try:  # the Processing plugin's settings dialog (present in QGIS and qgis_process)
    from processing.core.ProcessingConfig import ProcessingConfig, Setting
except ImportError:  # pragma: no cover
    ProcessingConfig = None

SETTINGS = (
    (client.SETTINGS_URL, "RVORONOI_URL", "Server URL (e.g. https://voronoi.example.org)", ""),
    (client.SETTINGS_AUTHCFG, "RVORONOI_AUTHCFG", "Authentication configuration of the token (its id)", ""),
    (client.SETTINGS_MODE, "RVORONOI_MODE", "Mode: auto, server or local", "auto"),
)


class RvoronoiProvider(QgsProcessingProvider):
    def id(self):
        return "rvoronoi"

    def name(self):
        return "rvoronoi"

    def longName(self):  # noqa: N802
        return "rvoronoi: raster Voronoi diagrams for delimitation"

    def load(self):
        if ProcessingConfig is not None:
            ProcessingConfig.settingIcons[self.name()] = self.icon()
            for key, env, text, default in SETTINGS:
                ProcessingConfig.addSetting(Setting(self.name(), env, text, QgsSettings().value(key, default)))
            ProcessingConfig.readSettings()
        self.refreshAlgorithms()
        return True

    def unload(self):
        if ProcessingConfig is not None:
            for _, env, _, _ in SETTINGS:
                ProcessingConfig.removeSetting(env)

    def _configured(self):
        """The settings as the Processing options hold them, copied to QGIS's settings (where the
        client reads them, below the environment)."""
        if ProcessingConfig is None:
            return
        for key, env, _, default in SETTINGS:
            value = ProcessingConfig.getSetting(env)
            if value is not None:
                QgsSettings().setValue(key, value)

    def loadAlgorithms(self):  # noqa: N802
        self._configured()
        wanted = client.mode()
        found, local = {}, False
        if wanted in ("server", "auto") and client.server_url():
            found = descriptions.from_server()
        elif wanted in ("local", "auto"):
            found, local = descriptions.from_module(), True
        if not found:
            QgsMessageLog.logMessage("no rvoronoi algorithms: set the server's URL in the Processing options "
                                     "(Providers > rvoronoi) or RVORONOI_URL, or install the Python module",
                                     descriptions.LOG_TAG, Qgis.Warning)
        for process_id, description in sorted(found.items()):
            if process_id == "voronoi":  # describe-seeds helps the pages; QGIS reads layers itself
                self.addAlgorithm(DescribedAlgorithm(process_id, description, local))
