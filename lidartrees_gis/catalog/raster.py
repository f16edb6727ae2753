"""A CHM GeoTIFF as an area to find trees in: read window by window, like the points of a
catalog (``lidartrees trees CHM.tif``)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..grid import GridSpec

#: raster suffixes taken as a CHM by ``trees`` and ``compare``
RASTER_SUFFIXES = (".tif", ".tiff", ".vrt", ".img")


def is_raster(path) -> bool:
    return str(path).lower().endswith(RASTER_SUFFIXES)


@dataclass
class RasterArea:
    """A north-up CHM raster: its grid (``spec``, with the CRS, or ``a_srs`` assigned)."""

    path: Path
    spec: GridSpec

    @classmethod
    def open(cls, path, a_srs=None) -> "RasterArea":
        from ..crs import parse_crs
        from ..io.raster import read_raster_spec, warn_unset_nodata

        spec = read_raster_spec(path)
        warn_unset_nodata(path)
        if a_srs:
            spec = spec.with_crs(parse_crs(a_srs))
        return cls(Path(path), spec)

    @property
    def files(self) -> list:
        return [self.path]

    @property
    def crs(self):
        return self.spec.crs

    @property
    def extent(self) -> tuple:
        return self.spec.bounds

    @property
    def count(self) -> int:
        """Cells (the raster's size, as a catalog's point count sizes its tiles)."""
        return self.spec.width * self.spec.height

    def label(self) -> str:
        return str(self.path)

    def window(self, box) -> GridSpec:
        """The raster cells that overlap ``box`` (left, bottom, right, top)."""
        s = self.spec
        c0 = max(0, math.floor((box[0] - s.left) / s.res + 1e-9))
        c1 = min(s.width, math.ceil((box[2] - s.left) / s.res - 1e-9))
        r0 = max(0, math.floor((s.top - box[3]) / s.res + 1e-9))
        r1 = min(s.height, math.ceil((s.top - box[1]) / s.res - 1e-9))
        return GridSpec(s.left + c0 * s.res, s.top - r0 * s.res, s.res, max(c1 - c0, 0),
                        max(r1 - r0, 0), s.crs)

    def surfaces(self, box) -> dict | None:
        """The CHM window of ``box`` as surfaces (the CHM is its own tree-height grid); None
        outside the raster."""
        from ..io.raster import read_raster_window

        w = self.window(box)
        if w.width == 0 or w.height == 0:
            return None
        arr = read_raster_window(self.path, w)
        if not np.isfinite(arr).any():
            return None
        return {"chm": arr, "heights": arr, "returns": None, "spec": w, "res": w.res,
                "points": 0, "dropped": {}, "outlier_points": 0, "outlier_cells": 0,
                "stats": None, "dtm_method": None, "chm_method": "input raster",
                "density": float("nan")}
