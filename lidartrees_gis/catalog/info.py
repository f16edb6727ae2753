"""``lidartrees info``: what a point source holds (points, bounds, density, CRS, classes)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import math

from ..crs import crs_label
from ..io.provenance import repro_report

if TYPE_CHECKING:
    from ..io.points import PointSource


def info(src: PointSource, progress=None) -> dict:
    """Points, bounds, density (pts/m²), CRS, classes and returns of a point source."""
    st = src.scan(progress)
    out = {
        "file": str(src.path),
        "format": src.format,
        "points": st.count,
        "skipped": st.skipped,
        "bounds": list(st.bounds),
        "z_range": list(st.zrange),
        "area_m2": round(st.area, 1),
        "density_pts_m2": None if math.isnan(st.density) else round(st.density, 3),
        "crs": crs_label(src.crs),
        "crs_wkt": src.crs.to_wkt() if src.crs is not None else None,
        "classes": st.classes,
        "returns": st.returns,
        "reprojection": repro_report(src),
    }
    if src.format == "las":
        out["las_version"] = src.header_info.get("version")
        out["point_format"] = src.header_info.get("point_format")
    else:
        out["dialect"] = src.dialect.describe()
    return out
