"""``lidartrees info``: what a point source holds (points, bounds, density, CRS, classes); for
a folder, glob, list or ``.vpc``: each file's figures and the whole's."""
from __future__ import annotations

from typing import TYPE_CHECKING

import math

from ..crs import check_coordinates, crs_label
from ..io.provenance import repro_report

if TYPE_CHECKING:
    from ..io.points import PointSource


def info(src: PointSource, progress=None) -> dict:
    """Points, bounds, density (pts/m²), CRS, classes and returns of a point source."""
    st = src.scan(progress)
    if src.format != "las" and src.repro is None:  # LAS: checked on its header when opened
        check_coordinates(src.crs, st.bounds, src.path, given=src.file_crs is None)
    if src.file_crs is not None and src.src_crs is not None \
            and not src.file_crs.equals(src.src_crs, ignore_axis_order=True):
        from .catalog import warn_overridden

        warn_overridden([crs_label(src.file_crs)], 1, src.src_crs)
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


def info_many(files: list, open_one, progress=None) -> dict:
    """:func:`info` of each file (``open_one(path)`` opens it) and the whole: files, points,
    bounds, area of the files' boxes, density, CRS (or the CRSs when they differ), classes."""
    from ..progress import SubProgress, as_progress

    prog = as_progress(progress)
    each = []
    for i, f in enumerate(files):
        each.append(info(open_one(f), SubProgress(prog, i / len(files), (i + 1) / len(files))))
    b = [r["bounds"] for r in each]
    bounds = [min(x[0] for x in b), min(x[1] for x in b), max(x[2] for x in b), max(x[3] for x in b)]
    points = sum(r["points"] for r in each)
    area = sum(r["area_m2"] for r in each)
    classes = {}
    for r in each:
        for k, v in (r["classes"] or {}).items():
            classes[k] = classes.get(k, 0) + v
    crss = sorted({str(r["crs"]) for r in each})
    return {"files": len(each), "points": points, "bounds": bounds,
            "z_range": [min(r["z_range"][0] for r in each), max(r["z_range"][1] for r in each)],
            "area_m2": round(area, 1),
            "density_pts_m2": round(points / area, 3) if area > 0 else None,
            "crs": crss[0] if len(crss) == 1 else "several: " + "; ".join(crss),
            "classes": dict(sorted(classes.items())),
            "per_file": [{k: r[k] for k in ("file", "format", "points", "bounds",
                                            "density_pts_m2", "crs")} for r in each]}


def describe_input(input, read, progress=None) -> dict:
    """``lidartrees info`` on what a user names (a file, folder, glob, list or ``.vpc``):
    :func:`info` of one file, :func:`info_many` of several. ``read``: a
    :class:`~lidartrees_gis.io.options.ReadOptions`."""
    from .inputs import expand_inputs

    files = expand_inputs(input)
    if len(files) == 1:
        return info(read.open(files[0], filtered=False), progress)
    return info_many(files, lambda f: read.open(f, filtered=False), progress)
