"""QGIS plugin entry point: registers the "LiDAR Trees" processing provider (id ``lidartrees``)."""


def classFactory(iface):  # noqa: N802 - QGIS API name
    from .plugin import LidarTreesPlugin

    return LidarTreesPlugin(iface)
