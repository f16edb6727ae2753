"""A GeoTIFF over a whole area written window by window as tiles finish."""
from __future__ import annotations

import json

import numpy as np


def window_of(spec, shape, left, top):
    """Where an array of ``shape`` whose upper-left corner is at ``(left, top)`` falls in the
    grid ``spec``, clipped to it: ``((r0, r1, c0, c1), (rows, cols))`` (the grid's window and
    the array's slices), or None when it falls outside."""
    c0 = int(round((left - spec.left) / spec.res))
    r0 = int(round((spec.top - top) / spec.res))
    rr0, cc0 = max(r0, 0), max(c0, 0)
    rr1, cc1 = min(r0 + shape[0], spec.height), min(c0 + shape[1], spec.width)
    if rr1 <= rr0 or cc1 <= cc0:
        return None
    return (rr0, rr1, cc0, cc1), (slice(rr0 - r0, rr1 - r0), slice(cc0 - c0, cc1 - c0))


class MosaicWriter:
    """A tiled GeoTIFF over the whole area (``spec``), written window by window as tiles finish
    (float32 with NaN written as ``nodata``, or an integer type)."""

    def __init__(self, tmp_path, spec, *, creation_options=None, tags=None, description=None,
                 dtype="float32", nodata="default"):
        import rasterio

        from ..io.raster import DEFAULT_CO, NODATA, rio_crs, split_overviews

        co = dict(DEFAULT_CO)
        co.update({k.upper(): v for k, v in (creation_options or {}).items()})
        co, self.overviews = split_overviews(co)
        co.setdefault("BIGTIFF", "IF_SAFER")
        if spec.width < 16 or spec.height < 16:
            co.pop("TILED", None), co.pop("BLOCKXSIZE", None), co.pop("BLOCKYSIZE", None)
        self.spec = spec
        self.dtype = np.dtype(dtype)
        self.nodata = NODATA if nodata == "default" else nodata
        if self.dtype.kind != "f" and co.get("PREDICTOR") == "3":
            co["PREDICTOR"] = "2"
        self.ds = rasterio.open(tmp_path, "w", driver="GTiff", width=spec.width,
                                height=spec.height, count=1, dtype=self.dtype.name,
                                crs=rio_crs(spec.crs), transform=spec.transform,
                                nodata=self.nodata, **co)
        self.set_tags(tags or {})
        self.max = float("-inf")  # the highest value written (a style's classes fit to it)
        if description:
            self.ds.set_band_description(1, description)

    def set_tags(self, tags: dict) -> None:
        """Provenance tags (values JSON-encoded when not strings), with the tool's version."""
        from .._version import __version__

        t = {"LIDARTREES_VERSION": __version__}
        t.update({str(k).upper(): v if isinstance(v, str) else json.dumps(v, default=str)
                  for k, v in tags.items()})
        self.ds.update_tags(**t)

    def write(self, arr, left, top):
        from rasterio.windows import Window

        win = window_of(self.spec, np.shape(arr), left, top)
        if win is None:
            return
        (rr0, rr1, cc0, cc1), (ar, ac) = win
        a = np.asarray(arr)[ar, ac]
        if a.size and np.isfinite(a).any():
            self.max = max(self.max, float(np.nanmax(np.where(np.isfinite(a), a, np.nan))))
        if self.dtype.kind == "f":
            a = np.where(np.isnan(a), self.nodata, a)
        self.ds.write(a.astype(self.dtype), 1, window=Window(cc0, rr0, cc1 - cc0, rr1 - rr0))

    def close(self):
        """Build the overviews (``-co OVERVIEWS``, see
        :func:`lidartrees_gis.io.raster.build_overviews`) and close."""
        from ..io.raster import build_overviews

        if not self.ds.closed:
            build_overviews(self.ds, self.overviews,
                            "average" if self.dtype.kind == "f" else "nearest")
        self.ds.close()
