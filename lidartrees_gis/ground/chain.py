"""The ground filter on a point source's points (Kraus & Pfeifer robust interpolation, seed
003), the classes it writes and the DTMs made from ground points; the command's file-level chain
over one file or many is :mod:`lidartrees_gis.ground.tiled`."""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..grid import GridAccumulator, GridSpec, fill_gaps
from ..io.options import NOISE_CLASSES
from ..progress import SubProgress, as_progress
from ..tin import interpolate_tin
from .filter import kraus_pfeifer


def filtered_points(pts, path) -> np.ndarray:
    """The points the filter takes: all but the noise classes (7, 18); an error naming
    ``path`` when there are none."""
    if len(pts) == 0:
        raise InputError(f"{path}: no points")
    use = (~np.isin(pts.classification, NOISE_CLASSES) if pts.classification is not None
           else np.ones(len(pts), bool))
    if use.sum() == 0:
        raise InputError(f"{path}: every point is classified as noise (7 or 18)")
    return use


def ground_points(src, params=None, progress=None, *, refine_res=None, extent=None):
    """Run the ground filter on the points of ``src``: (points, ground mask). Points of the noise
    classes (7, 18) take no part and are never ground. ``refine_res``, ``extent``: those of
    :func:`~lidartrees_gis.ground.filter.kraus_pfeifer` (a tile takes its area's cell)."""

    prog = as_progress(progress)
    pts = src.read_all(SubProgress(prog, 0.0, 0.2))
    use = filtered_points(pts, src.path)
    ground = np.zeros(len(pts), bool)
    ground[use], _ = kraus_pfeifer(pts.x[use], pts.y[use], pts.z[use], params,
                                   progress=SubProgress(prog, 0.2, 0.8),
                                   refine_res=refine_res, extent=extent)
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
