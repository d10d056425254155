"""rvoronoi for QGIS: a Processing provider whose algorithms are made from the process descriptions
of an rvoronoi server (OGC API - Processes), or of the local Python module."""


def classFactory(iface):  # noqa: N802 (QGIS's name)
    from .plugin import RvoronoiPlugin
    return RvoronoiPlugin(iface)
