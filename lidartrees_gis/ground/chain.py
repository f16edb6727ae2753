"""File-level chain of the ground filter: a point file in, a classified LAS/LAZ and its DTM out
(Kraus & Pfeifer robust interpolation, seed 003)."""
from __future__ import annotations

import numpy as np

from .._version import __version__
from ..crs import crs_label
from ..errors import InputError
from ..grid import GridAccumulator, GridSpec, fill_gaps, resolve_resolution
from ..io.options import NOISE_CLASSES, ReadOptions
from ..io.output import OutputOptions
from ..io.provenance import raster_tags, repro_meta, repro_report
from ..io.raster import write_geotiff
from ..progress import SubProgress, as_progress, check_cancel
from ..tin import interpolate_tin
from .filter import KrausPfeifer, kraus_pfeifer


# ground filter and DTM quality (seed 003)
def ground_points(src, params=None, progress=None):
    """Run the ground filter on the points of ``src``: (points, ground mask). Points of the noise
    classes (7, 18) take no part and are never ground."""

    prog = as_progress(progress)
    pts = src.read_all(SubProgress(prog, 0.0, 0.2))
    if len(pts) == 0:
        raise InputError(f"{src.path}: no points")
    use = (~np.isin(pts.classification, NOISE_CLASSES) if pts.classification is not None
           else np.ones(len(pts), bool))
    if use.sum() == 0:
        raise InputError(f"{src.path}: every point is classified as noise (7 or 18)")
    ground = np.zeros(len(pts), bool)
    ground[use], _ = kraus_pfeifer(pts.x[use], pts.y[use], pts.z[use], params,
                                   progress=SubProgress(prog, 0.2, 0.8))
    if ground.sum() < 3:
        raise InputError(f"{src.path}: the ground filter kept {int(ground.sum())} points; "
                         "raise -w or lower -g")
    return pts, ground


def grid_surface(x, y, z, spec: GridSpec) -> np.ndarray:
    """Mean height of the points in each cell, empty cells filled by mean8 (as FUSION's
    GridSurfaceCreate, which seed 003 used for its DTMs)."""
    acc = GridAccumulator(spec, ("mean",))
    acc.add(x, y, z)
    return fill_gaps(acc.result("mean"), "mean8")


def dtm_from_ground(pts, ground, spec: GridSpec) -> np.ndarray:
    """Linear TIN of the ground points sampled at the cell centres of ``spec``."""
    return interpolate_tin(pts.x[ground], pts.y[ground], pts.z[ground], spec)


def ground_classes(classification, ground, reclassify=False) -> np.ndarray:
    """Classes written by ``ground``: the filter's decision (2 ground, 1 not) for points that were
    never classified, unclassified or ground (0, 1, 2); every other class (water, buildings,
    noise...) is kept unless ``reclassify``. Noise (7, 18) is never made ground."""
    ground = np.asarray(ground, bool)
    decided = np.where(ground, 2, 1).astype(np.uint8)
    if classification is None:
        return decided
    c = np.asarray(classification).astype(np.uint8)
    open_ = np.isin(c, (0, 1, 2))
    if reclassify:
        open_ = ~np.isin(c, NOISE_CLASSES)
    return np.where(open_, decided, c).astype(np.uint8)


def ground_file(input, output, *, dtm_out=None, res="auto", params=None,
                read: ReadOptions | None = None, out: OutputOptions | None = None,
                reclassify=False, progress=None) -> dict:
    """Classify ground (class 2) with Kraus & Pfeifer robust interpolation; write the classified
    LAS/LAZ and optionally the DTM GeoTIFF (linear TIN of the ground points, cell sqrt(1/n))."""
    from ..io.lasout import write_classified
    from ..io.output import check_outputs

    out = out or OutputOptions()
    overwrite, creation_options = out.overwrite, out.creation_options
    check_outputs([(output, "OUTPUT"), (dtm_out, "-dtm")], (input,), overwrite)
    src = (read or ReadOptions()).open(input, filtered=False)
    prog = as_progress(progress)
    pts, ground = ground_points(src, params, SubProgress(prog, 0, 0.7))
    check_cancel(prog)
    cls = ground_classes(pts.classification, ground, reclassify)

    meta = {"command": "ground", "tool": f"lidartrees_gis {__version__}", "input": str(src.path),
            "crs": crs_label(src.crs), "reclassify": reclassify,
            **(params or KrausPfeifer()).as_dict(), **repro_meta(src)}
    write_classified(output, src, cls, overwrite=overwrite, metadata=meta)
    out = {"output": str(output), "points": len(pts), "ground": int((cls == 2).sum()),
           "ground_share": float((cls == 2).mean()), "kept_classes": int((~np.isin(cls, (1, 2))).sum()),
           "crs": crs_label(src.crs), "reprojection": repro_report(src)}
    if dtm_out:
        r = resolve_resolution(src, res)
        spec = GridSpec.from_bounds(pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max(), r,
                                    crs=src.crs)
        prog.update(0.85, "DTM")
        dtm = dtm_from_ground(pts, cls == 2, spec)
        check_cancel(prog)
        write_geotiff(dtm_out, dtm, spec, overwrite=overwrite, creation_options=creation_options,
                      tags=raster_tags("ground", src, {"res": r, **(params or KrausPfeifer()).as_dict()}),
                      description="terrain height (m)")
        out.update({"dtm": str(dtm_out), "res": r})
    prog.update(1.0, "done")
    return out
