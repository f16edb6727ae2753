"""lidartrees_gis: LiDAR point clouds of planted forests to canopy height rasters, tree tops,
crowns and stand summaries (GeoTIFF, GeoPackage) for QGIS, the command line and Python."""

__version__ = "0.1.0"

from .errors import (  # noqa: E402
    Cancelled, CRSError, InputError, LidarTreesError, OutputExistsError, ReadError,
)

from .api import canopy_height, classify_ground, find_trees, raster_profile  # noqa: E402

__all__ = ["__version__", "LidarTreesError", "InputError", "ReadError", "CRSError",
           "OutputExistsError", "Cancelled", "canopy_height", "find_trees", "classify_ground",
           "raster_profile"]
