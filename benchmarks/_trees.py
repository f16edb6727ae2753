"""The benchmarks' call of the trees chain: the command's options as keywords, and the trees
read back from the GeoPackage as arrays (``result["table"]``)."""
from __future__ import annotations

import numpy as np


def trees(input_, out, *, params=None, res="auto", dtm="auto", chm="pitfree", a_srs=None,
          tile_size=None, workers=None, **kw) -> dict:
    """``lidartrees trees INPUT OUT -overwrite`` with these options (library call)."""
    import pyogrio

    from lidartrees_gis.als.chain import trees_run
    from lidartrees_gis.als.surfaces import SurfaceOptions
    from lidartrees_gis.catalog.catalog import TilingOptions
    from lidartrees_gis.io.options import ReadOptions
    from lidartrees_gis.io.output import OutputOptions

    r = trees_run(input_, out, params=params, surface=SurfaceOptions(res=res, dtm=dtm, chm=chm),
                  read=ReadOptions(a_srs=a_srs), tiling=TilingOptions(tile_size, None, workers),
                  out=OutputOptions(overwrite=True), **kw)
    tops = pyogrio.read_dataframe(out, layer="tree_tops", read_geometry=False)
    r["table"] = {c: tops[c].to_numpy() for c in tops.columns if c != "method"}
    r["table"]["tree_id"] = np.asarray(r["table"]["tree_id"], np.int64)
    return r
