"""The ``metrics`` command: the standard height metrics per cell (a multi-band GeoTIFF, one
named band a metric), per field plot and per stand (GeoPackage layers)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..catalog.catalog import TilingOptions
from ..errors import InputError
from ..io.options import ReadOptions
from ..io.output import OutputOptions, check_outputs
from ..progress import SubProgress, as_progress
from .metrics import METRICS
from .plots import Zones, check_inside, load_plots
from .tiles import MetricOptions, area_metrics

#: the band descriptions / field descriptions of the metrics
METRIC_DOCS = {
    "zmax": "highest return (m)", "zmean": "mean height (m)",
    "zsd": "standard deviation of the heights (m)", "zskew": "skewness of the heights",
    "zkurt": "kurtosis of the heights", "zentropy": "entropy of the heights in 1 m layers",
    "pzabovezmean": "% of returns above the mean height", "pzabove2": "% of returns above 2 m",
    **{f"zq{p}": f"{p}th percentile of the heights (m)" for p in range(5, 100, 5)},
    **{f"zpcum{k}": f"% of returns in the lowest {k} tenths of 0..zmax" for k in range(1, 10)},
    "zL1": "L-moment 1 (m)", "zL2": "L-moment 2 (m)", "zL3": "L-moment 3 (m)",
    "zL4": "L-moment 4 (m)", "zLcv": "L-moment coefficient of variation",
    "zLskew": "L-skewness", "zLkurt": "L-kurtosis",
    "cover": "% of first returns above the minimum height", "n": "returns used",
}


def open_points(input, read: ReadOptions):
    from ..catalog.catalog import Catalog
    from ..catalog.raster import is_raster

    if is_raster(input):
        raise InputError(f"{input}: expected point files (LAS/LAZ, XYZ text), got a raster")
    return Catalog.open(input, read)


def metric_frame(metrics: dict, ids, geoms, crs, id_name: str, attrs=None):
    """A GeoDataFrame of one row per zone: its id, the layer's own fields, the metrics."""
    import geopandas as gpd
    import pandas as pd

    cols = {id_name: list(ids)}
    df = pd.DataFrame(cols)
    if attrs is not None:
        extra = attrs[[c for c in attrs.columns if c not in METRICS and c != id_name]]
        df = pd.concat([df, extra.reset_index(drop=True)], axis=1)
    for k in METRICS:
        df[k] = metrics[k]
    return gpd.GeoDataFrame(df, geometry=list(geoms), crs=crs)


def metrics_run(input, output, *, res=20.0, plots=None, plot_id=None, plot_radius=None,
                stands=None, stand_id=None, options: MetricOptions | None = None,
                surface=None, read: ReadOptions | None = None,
                tiling: TilingOptions | None = None, out: OutputOptions | None = None,
                progress=None) -> dict:
    """The metric set (:data:`~lidartrees_gis.inventory.metrics.METRICS`) per cell of ``res``
    m (``output`` a ``.tif``) or per plot and stand (``output`` a ``.gpkg``: layers
    ``plot_metrics``, ``stand_metrics``)."""
    read, out = read or ReadOptions(), out or OutputOptions()
    prog = as_progress(progress)
    suffix = Path(str(output)).suffix.lower() if output is not None else \
        (".gpkg" if plots or stands else ".tif")
    if suffix not in (".tif", ".tiff", ".gpkg"):
        raise InputError(f"OUTPUT: {output}: expected a .tif (metrics per cell) or a .gpkg "
                         "(metrics per plot and stand)")
    gpkg = suffix == ".gpkg"
    if gpkg and not (plots or stands):
        raise InputError("OUTPUT: a .gpkg holds metrics per plot or stand: give -plots or "
                         "-stands, or write the cells to a .tif")
    if not gpkg and (plots or stands):
        raise InputError("-plots/-stands: their metrics go to a GeoPackage; give OUTPUT.gpkg "
                         "(the cells go to a .tif)")
    if output is not None:
        check_outputs([(output, "OUTPUT")], (), out.overwrite)
    area = open_points(input, read)
    zones, names = [], []
    if plots:
        p = load_plots(plots, area.crs, plot_id=plot_id, plot_radius=plot_radius)
        check_inside(p, area.extent, area.label())
        zones.append(p.zones)
        names.append(("plot_metrics", "plot_id", p.ids, p.geoms, p.attrs))
    if stands:
        from ..plantation.stands import check_overlap, load_stands

        st = load_stands(stands, area.crs, stand_id)
        check_overlap(st, area.extent, area.label())
        zones.append(Zones.of_polygons(st.geoms))
        import pandas as pd

        attrs = pd.DataFrame(list(st.attributes)) if st.attributes else None
        names.append(("stand_metrics", "stand_id", st.ids, st.geoms, attrs))
    r = area_metrics(area, cells_res=None if gpkg else res, zones=zones, options=options,
                     surface=surface, tiling=tiling, progress=SubProgress(prog, 0.0, 0.95))
    options = options or MetricOptions()
    meta = {"min_height": options.min_height, "returns": options.returns,
            "dtm_res": r["res"], "points": r["points"]}
    result = {"output": str(output), "points": r["points"], "tiles": r["tiles"]}
    if gpkg:
        from ..io.vector import describe_columns, write_gpkg

        layers = {}
        for (layer, idn, ids, geoms, attrs), m in zip(names, r["zones"]):
            layers[layer] = metric_frame(m, ids, geoms, area.crs, idn, attrs)
            empty = [ids[i] for i in np.flatnonzero(m["n"] == 0)]
            result[layer] = len(ids)
            if empty:
                result[f"{layer}_without_returns"] = empty
        result["layers"] = layers
        if output is not None:
            write_gpkg(output, layers, overwrite=out.overwrite, layer_options=out.layer_options,
                       metadata=meta, owned=("plot_metrics", "stand_metrics"))
            for layer in layers:
                describe_columns(output, layer, METRIC_DOCS)
    else:
        from ..io.provenance import raster_tags
        from ..io.raster import write_geotiff

        spec, grid = r["cells"]
        result["grid"] = (spec, grid)
        if output is not None:
            write_geotiff(output, grid, spec, overwrite=out.overwrite,
                          creation_options=out.creation_options,
                          description=list(METRICS),
                          tags=raster_tags("metrics", area, {"res": spec.res, **meta}, input))
        result.update({"res": spec.res, "shape": spec.shape, "bands": len(METRICS),
                       "cells_with_returns": int(np.isfinite(grid[0]).sum())})
    prog.update(1.0, "done")
    return result
