"""The Python API: the commands' defaults, results in memory.

>>> import lidartrees_gis as lt
>>> chm, profile = lt.canopy_height("stand.xyz", a_srs="SAD69 24K")   # doctest: +SKIP
>>> with rasterio.open("chm.tif", "w", **profile) as ds:              # doctest: +SKIP
...     ds.write(chm, 1)
>>> tops, crowns, summary = lt.find_trees("stand.xyz", a_srs="SAD69 24K")  # doctest: +SKIP
>>> tops.plot(column="height")                                    # doctest: +SKIP

Every function takes the same options as its command (``chm``, ``trees``, ``ground``) (``res``,
``dtm``, ``chm``, ``a_srs``, ``t_srs``, ``drop_class``, ...) and runs the same chain; nothing is
written.
"""
from __future__ import annotations

import numpy as np

from .grid import GridSpec

__all__ = ["canopy_height", "find_trees", "classify_ground", "point_info", "raster_profile",
           "metrics", "volume"]


def raster_profile(spec: GridSpec, dtype="float32", nodata=float("nan")) -> dict:
    """A rasterio profile (GTiff, one band) for an array on ``spec``: ``rasterio.open(path, "w",
    **profile)``."""
    from .io.raster import rio_crs

    return {"driver": "GTiff", "dtype": dtype, "nodata": nodata, "width": spec.width,
            "height": spec.height, "count": 1, "crs": rio_crs(spec.crs),
            "transform": spec.transform, "tiled": True, "compress": "deflate"}


def _options(res, dtm, chm, fill, outliers, drop_class, keep_class, a_srs, t_srs, read_kw):
    from .als.surfaces import SurfaceOptions
    from .io.options import ReadOptions

    return (SurfaceOptions(res=res, dtm=dtm, chm=chm, fill=fill, outliers=outliers),
            ReadOptions(a_srs=a_srs, t_srs=t_srs, drop_class=drop_class, keep_class=keep_class,
                        **read_kw))


def canopy_height(input, *, res="auto", dtm="auto", chm="pitfree", fill="mean8", outliers=True,
                  drop_class=(7, 18), keep_class=None, a_srs=None, t_srs=None, progress=None,
                  **read_kw):
    """Canopy height model of point files, as ``lidartrees chm`` builds it (the area as one
    tile).

    Returns
    -------
    chm : (rows, cols) ndarray of float32
        Heights above ground in metres, NaN where there is no data.
    profile : dict
        rasterio profile (CRS, transform, nodata) to write or to place the array.
    """
    from .als.chain import area_surfaces

    surface, read = _options(res, dtm, chm, fill, outliers, drop_class, keep_class, a_srs, t_srs,
                             read_kw)
    s, _, _ = area_surfaces(input, surface=surface, read=read, progress=progress)
    return s["chm"].astype(np.float32), raster_profile(s["spec"])


def find_trees(input, *, params=None, res="auto", dtm="auto", chm="pitfree", fill="mean8",
               outliers=True, drop_class=(7, 18), keep_class=None, a_srs=None, t_srs=None,
               tile_size=None, workers=None, stands=None, stand_id=None, progress=None,
               **read_kw):
    """Tree tops and crowns of point files or a CHM GeoTIFF, as ``lidartrees trees`` finds them.

    Parameters
    ----------
    params : lidartrees_gis.als.trees.TreeParams, optional
        Detection parameters (default: automatic smoothing and window; ``spacing="3x2"`` for the
        plantation mode).
    stands : str, Path or geopandas.GeoDataFrame, optional
        Stand (talhão) polygons (``PATH[:LAYER]``): each tree gets its ``stand_id`` and
        ``summary["stands"]`` is a GeoDataFrame of the per-stand inventory.
    stand_id : str, optional
        The stands' id field (default: ``stand_id``, ``talhao``, ... or numbered).

    Returns
    -------
    tops : geopandas.GeoDataFrame
        One point per tree: ``tree_id``, ``height``, ``crown_area``, ``crown_diameter``, ...
    crowns : geopandas.GeoDataFrame
        One polygon per tree with the same ``tree_id``.
    summary : dict
        The stand summary (trees, trees per ha, mean height, crown scale, stocking ...); in
        the plantation mode ``summary["gaps"]``, a GeoDataFrame of the empty planting positions
        (the ``gaps`` layer: row and plant numbers, status missing / suppressed / uncertain).
    """
    from .als.chain import trees_run
    from .catalog.catalog import TilingOptions

    surface, read = _options(res, dtm, chm, fill, outliers, drop_class, keep_class, a_srs, t_srs,
                             read_kw)
    r = trees_run(input, None, params=params, surface=surface, read=read,
                  tiling=TilingOptions(tile_size=tile_size, workers=workers), stands=stands,
                  stand_id=stand_id, progress=progress)
    layers = r["layers"]
    summary = layers["summary"].iloc[0].to_dict()
    for k in ("stands", "gaps"):
        if k in layers:
            summary[k] = layers[k]
    return layers["tree_tops"], layers["crowns"], summary


def point_info(input, *, a_srs=None, progress=None, **read_kw) -> dict:
    """What ``lidartrees info`` prints, as a dict: points, bounds, density, CRS, classes of a
    file; of a folder, glob, list or ``.vpc``, each file's and the whole's."""
    from .catalog.info import describe_input
    from .io.options import ReadOptions

    return describe_input(input, ReadOptions(a_srs=a_srs, **read_kw), progress)


def classify_ground(input, *, params=None, a_srs=None, t_srs=None, progress=None, **read_kw):
    """Ground points of a file by the ground filter (``lidartrees ground``).

    Returns
    -------
    points : lidartrees_gis.io.points.PointChunk
        x, y, z (and classification, returns when the file has them).
    ground : (N,) ndarray of bool
    """
    from .ground.chain import ground_points
    from .io.options import ReadOptions

    src = ReadOptions(a_srs=a_srs, t_srs=t_srs, **read_kw).open(input, filtered=False)
    return ground_points(src, params, progress)


def metrics(input, output=None, *, res=20.0, plots=None, plot_id=None, plot_radius=None,
            stands=None, stand_id=None, min_height=2.0, returns="all", dtm="auto",
            drop_class=(7, 18), keep_class=None, a_srs=None, t_srs=None, tile_size=None,
            workers=None, overwrite=False, progress=None, **read_kw):
    """The standard height metrics (lidR's ``.stdmetrics_z``, FUSION's L-moments and cover;
    :mod:`lidartrees_gis.inventory.metrics`) per cell of ``res`` m, or per plot and stand
    (``lidartrees metrics``).

    Without ``output`` nothing is written: the result holds ``grid`` = ``(GridSpec, (bands,
    rows, cols) array)`` (bands in the order of
    :data:`~lidartrees_gis.inventory.metrics.METRICS`) or ``layers`` = ``{"plot_metrics":
    GeoDataFrame, "stand_metrics": GeoDataFrame}``. With ``output`` (``.tif`` or ``.gpkg``)
    they are written there too.
    """
    from .inventory.chain import metrics_run

    o = _inventory_options(min_height, returns, dtm, drop_class, keep_class, a_srs, t_srs,
                           tile_size, workers, overwrite, read_kw)
    return metrics_run(input, output, res=res, plots=plots, plot_id=plot_id,
                       plot_radius=plot_radius, stands=stands, stand_id=stand_id,
                       options=o["metric"], surface=o["surface"], read=o["read"],
                       tiling=o["tiling"], out=o["out"], progress=progress)


def _inventory_options(min_height, returns, dtm, drop_class, keep_class, a_srs, t_srs,
                       tile_size, workers, overwrite, read_kw) -> dict:
    """The option dataclasses :func:`metrics` and :func:`volume` pass alike: ``metric``,
    ``surface`` (heights above the DTM, no CHM filling), ``read``, ``tiling``, ``out``."""
    from .als.surfaces import SurfaceOptions
    from .catalog.catalog import TilingOptions
    from .inventory.tiles import MetricOptions
    from .io.options import ReadOptions
    from .io.output import OutputOptions

    return {"metric": MetricOptions(min_height=min_height, returns=returns),
            "surface": SurfaceOptions(dtm=dtm, chm="max", fill="none", outliers=False),
            "read": ReadOptions(a_srs=a_srs, t_srs=t_srs, drop_class=drop_class,
                                keep_class=keep_class, **read_kw),
            "tiling": TilingOptions(tile_size=tile_size, workers=workers),
            "out": OutputOptions(overwrite=overwrite)}


def volume(input, plots, output=None, *, stands, trees_table=None, plot_id=None,
           plot_radius=None, stand_id=None, stand_csv=None, volume_field=None,
           volume_equation=None, approach="aba", res="auto", min_height=2.0, returns="all",
           dtm="auto", resamples=400, estimator="eblup", drop_class=(7, 18), keep_class=None,
           a_srs=None, t_srs=None, tile_size=None, workers=None, overwrite=False, progress=None,
           **read_kw):
    """Wood volume per stand from points and field plots (``lidartrees volume``;
    docs/VOLUME.md).

    Parameters
    ----------
    plots : str, Path or GeoDataFrame
        Plot polygons, or plot centres with ``plot_radius``.
    stands : str, Path or GeoDataFrame
        Stand polygons.
    trees_table : str, Path or pandas.DataFrame, optional
        The plots' measured trees (``parcela;arvore;dap;ht``, pt-BR or English; CSV/TXT or
        ``.xlsx``, or a DataFrame with those columns).
    stand_csv : str or Path, optional
        Also write the stands' figures as a table (``.csv`` in the locale's dialect, or
        ``.xlsx``); needs ``output``.
    volume_field : str, optional
        The plots' field holding their volume (m³/ha) when there is no ``trees_table``
        (default: the first of volume_m3_ha, vol_ha, vtcc_ha, volume, vol).
    volume_equation : str or (b0, b1, b2), optional
        Schumacher-Hall ``V = b0·DAP^b1·HT^b2``, or ``"ff:F"``: a form factor F
        (``V = F·g·HT``).
    approach : {"aba", "trees", "both"}
    estimator : {"eblup", "model"}
        A stand's figure: the model's corrected by the stand's own plots (eblup), or the
        model's alone.

    Returns
    -------
    dict with ``layers`` (``plots``, ``stands``, and ``tree_tops`` for the tree approach:
    GeoDataFrames), ``report`` (the model report), ``volume_grid`` ``(GridSpec, m³/ha
    array)``; with ``output`` (a ``.gpkg``) everything is also written (the raster and the
    report beside it).
    """
    from .inventory.field import Equation
    from .inventory.volume import VolumeOptions, volume_run

    eq = volume_equation
    if eq is not None and not isinstance(eq, Equation):
        eq = Equation.parse(eq if isinstance(eq, str) else ",".join(map(str, eq)))
    o = _inventory_options(min_height, returns, dtm, drop_class, keep_class, a_srs, t_srs,
                           tile_size, workers, overwrite, read_kw)
    return volume_run(input, plots, output, stands=stands, trees_table=trees_table,
                      plot_id=plot_id, plot_radius=plot_radius, stand_id=stand_id,
                      stand_csv=stand_csv, volume_field=volume_field,
                      options=VolumeOptions(approach=approach, equation=eq, res=res,
                                            resamples=resamples, estimator=estimator),
                      metric=o["metric"], surface=o["surface"], read=o["read"],
                      tiling=o["tiling"], out=o["out"], progress=progress)
