"""The Python API: the commands' defaults, results in memory.

>>> import lidartrees_gis as lt
>>> chm, profile = lt.canopy_height("stand.xyz", a_srs="SAD69 24K")   # doctest: +SKIP
>>> with rasterio.open("chm.tif", "w", **profile) as ds:              # doctest: +SKIP
...     ds.write(chm, 1)
>>> tops, crowns, summary = lt.find_trees("stand.xyz", a_srs="SAD69 24K")  # doctest: +SKIP
>>> tops.plot(column="height")                                    # doctest: +SKIP

Every function takes the same options as its command (``chm``, ``trees``, ``ground``) (``res``, ``dtm``,
``chm``, ``a_srs``, ``t_srs``, ``drop_class``, ...) and runs the same code; nothing is written.
"""
from __future__ import annotations

import numpy as np

from .grid import GridSpec

__all__ = ["canopy_height", "find_trees", "classify_ground", "raster_profile"]


def raster_profile(spec: GridSpec, dtype="float32", nodata=float("nan")) -> dict:
    """A rasterio profile (GTiff, one band) for an array on ``spec``: ``rasterio.open(path, "w",
    **profile)``."""
    from .io.raster import rio_crs

    return {"driver": "GTiff", "dtype": dtype, "nodata": nodata, "width": spec.width,
            "height": spec.height, "count": 1, "crs": rio_crs(spec.crs),
            "transform": spec.transform, "tiled": True, "compress": "deflate"}


def canopy_height(input, *, res="auto", dtm="auto", chm="pitfree", fill="mean8", outliers=True,
        drop_class=(7, 18), keep_class=None, a_srs=None, t_srs=None, progress=None, **read_kw):
    """Canopy height model of a point file, as ``lidartrees chm`` builds it.

    Returns
    -------
    chm : (rows, cols) ndarray of float32
        Heights above ground in metres, NaN where there is no data.
    profile : dict
        rasterio profile (CRS, transform, nodata) to write or to place the array.
    """
    from .als.pipeline import compute_surfaces
    from .io.options import open_filtered

    src = open_filtered(input, a_srs=a_srs, t_srs=t_srs, drop_class=drop_class,
                        keep_class=keep_class, **read_kw)
    s = compute_surfaces(src, res, dtm=dtm, chm=chm, fill=fill, outliers=outliers,
                         progress=progress)
    return s["chm"].astype(np.float32), raster_profile(s["spec"])


def find_trees(input, *, params=None, res="auto", dtm="auto", chm="pitfree", fill="mean8",
          outliers=True, drop_class=(7, 18), keep_class=None, a_srs=None, t_srs=None,
          progress=None, **read_kw):
    """Tree tops and crowns of a point file or a CHM GeoTIFF, as ``lidartrees trees`` finds them.

    Parameters
    ----------
    params : lidartrees_gis.trees.TreeParams, optional
        Detection parameters (default: automatic smoothing and window; ``spacing="3x2"`` for the
        plantation mode).

    Returns
    -------
    tops : geopandas.GeoDataFrame
        One point per tree: ``tree_id``, ``height``, ``crown_area``, ``crown_diameter``, ...
    crowns : geopandas.GeoDataFrame
        One polygon per tree with the same ``tree_id``.
    summary : dict
        The stand summary (trees, trees per ha, mean height, crown scale, stocking ...).
    """
    from .als.pipeline import detect_with_stocking, load_chm, trees_frames
    from .als.trees import TreeParams

    p = params or TreeParams()
    arr, spec, _, built = load_chm(input, res=res, dtm=dtm, chm=chm, fill=fill,
                                   outliers=outliers, drop_class=drop_class, keep_class=keep_class,
                                   a_srs=a_srs, t_srs=t_srs, progress=progress,
                                   returns=p.looks_at_planting, **read_kw)
    result = detect_with_stocking(arr, spec, p, built.get("heights"), returns=built.get("returns"),
                                  density=built.get("density"))
    frames = trees_frames(result, spec, "")
    summary = frames["summary"].iloc[0].to_dict()
    return frames["tree_tops"], frames["crowns"], summary


def classify_ground(input, *, params=None, a_srs=None, t_srs=None, progress=None, **read_kw):
    """Ground points of a file by the ground filter (``lidartrees ground``).

    Returns
    -------
    points : lidartrees_gis.io.points.PointChunk
        x, y, z (and classification, returns when the file has them).
    ground : (N,) ndarray of bool
    """
    from .ground.chain import ground_points
    from .io.options import open_input

    src = open_input(input, a_srs=a_srs, t_srs=t_srs, **read_kw)
    return ground_points(src, params, progress)
