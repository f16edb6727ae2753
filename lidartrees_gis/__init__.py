"""lidartrees_gis: LiDAR point clouds of planted forests to canopy height rasters, tree tops,
crowns and stand summaries (GeoTIFF, GeoPackage) for QGIS, the command line and Python.

The Python API (:mod:`lidartrees_gis.api`) is loaded on first use, so that ``import
lidartrees_gis`` and the command table stay light (no numpy, GDAL or GEOS)."""

from ._version import __version__  # noqa: E402

from .errors import (  # noqa: E402
    Cancelled, CRSError, InputError, LidarTreesError, OutputExistsError, ReadError,
)

_API = ("canopy_height", "find_trees", "classify_ground", "point_info", "raster_profile",
        "metrics", "volume")

__all__ = ["__version__", "LidarTreesError", "InputError", "ReadError", "CRSError",
           "OutputExistsError", "Cancelled", *_API]


def __getattr__(name):
    if name in _API:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
