"""DSM, DTM and CHM of the points in one box, on one aligned grid: what every ALS chain (grid,
chm, trees) computes per tile.

* :class:`SurfaceOptions` — the ``-tr``, ``-dtm``, ``-chm``, ``-fill`` and outlier options;
* :func:`compute_surfaces` — the surfaces of a point source (a file, or a tile of a catalog);
* :func:`box_surfaces` — the surfaces of one box of an area (points or a CHM raster), None when
  the box holds nothing.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from ..errors import InputError
from ..grid import GridAccumulator, GridSpec, LowestPoints, check_resolution, data_footprint, \
    fill_gaps, grid_spec_for
from ..io.raster import read_raster, resample_to
from ..io.store import register
from ..progress import SubProgress, as_progress, check_cancel
from ..tin import LOCAL_RADIUS, interpolate_tin, tin_surface
from .chm import CHM_KINDS, canopy_outliers, pitfree_chm, pitfree_edge

#: heights above the DTM closer to 0 than this (m) are 0: the ground points the DTM was
#: interpolated from lie on it, and the rounding of the interpolation must not decide whether
#: they are above it (the pit-free CHM's first layer takes the points at or above 0)
ON_GROUND = 1e-6
DTM_CHOICES = "min, ground, lowest:R, kp[:G:W], none, auto or a DTM GeoTIFF path"
FILLS = ("mean8", "none")


@dataclass(frozen=True)
class DtmMethod:
    """A parsed ``-dtm`` value."""

    kind: str  # min | ground | lowest | none | auto | kp | file
    size: float | None = None
    path: str | None = None
    g: float | None = None
    w: float | None = None

    @classmethod
    def parse(cls, value) -> "DtmMethod":
        v = "min" if value is None else str(value).strip()
        low = v.lower()
        if low in ("min", "ground", "none", "auto"):
            return cls(low)
        m = re.fullmatch(r"kp(?::(-?[0-9.]+):([0-9.]+))?", low)
        if m:
            return cls("kp", g=float(m.group(1)) if m.group(1) else None,
                       w=float(m.group(2)) if m.group(2) else None)
        m = re.fullmatch(r"lowest(?::([0-9.]+))?", low)
        if m:
            size = float(m.group(1) or 5.0)
            if size <= 0:
                raise InputError(f"-dtm: lowest:R needs R > 0, got {value!r}")
            return cls("lowest", size=size)
        if low.endswith((".tif", ".tiff", ".vrt", ".img")) or Path(v).exists():
            if not Path(v).exists():
                raise InputError(f"-dtm: DTM file {v} does not exist")
            return cls("file", path=v)
        raise InputError(f"-dtm: unknown value {value!r}; use {DTM_CHOICES}")

    def describe(self) -> str:
        if self.kind == "kp" and self.g is not None:
            return f"kp:{self.g:g}:{self.w:g}"
        if self.kind == "lowest":
            return f"lowest:{(self.size or 5.0):g}"
        if self.kind == "file":
            return str(self.path)
        return self.kind

    def label(self, kind: str) -> str:
        """The ``-dtm`` value as given (``lowest:5``, ``kp:-1:1``, a path); ``auto`` with what
        it chose (``auto (ground)``, ``auto (lowest:5)``)."""
        if self.kind == "auto":
            return f"auto ({'lowest:5' if kind == 'lowest' else kind})"
        return self.describe()


@dataclass(frozen=True)
class SurfaceOptions:
    """How the surfaces are built from points (the ``chm`` command's options).

    Attributes
    ----------
    res : float or "auto"
        Cell size (m); ``auto`` from the point density of the area
        (:func:`lidartrees_gis.als.area.plan_area`).
    dtm : str
        ``auto`` (default) ``ground`` when the points hold class-2 points, else ``lowest:5``;
        ``ground`` lowest class-2 point per cell, linearly interpolated (TIN) over the grid;
        ``lowest:R`` the lowest point of each R-metre cell, at its own position, interpolated
        (TIN); ``kp`` or ``kp:G:W`` ground points of the Kraus & Pfeifer filter (seed 003;
        defaults g = -2, w = 2.5), interpolated (TIN); ``min`` lowest point per cell (seed 000's
        simple method, only meaningful where every cell holds a ground return); ``none``
        heights are already normalised (DTM = 0); or a DTM GeoTIFF path, resampled bilinearly.
    chm : {"pitfree", "max", "tin"}
        ``pitfree`` Khosravipour et al. (2014) pit-free CHM of the first returns' heights above
        the DTM; ``max`` highest point per cell minus the DTM (seed 000); ``tin`` one TIN of the
        first returns (lidR ``dsmtin``).
    fill : {"mean8", "none"}
        Gap filling of the DSM, CHM and of the ``min`` DTM (seed 000), within the data.
    outliers : bool
        Remove isolated returns far above the canopy (:func:`lidartrees_gis.als.chm.canopy_outliers`).
    """

    res: object = "auto"
    dtm: str = "auto"
    chm: str = "pitfree"
    fill: str = "mean8"
    outliers: bool = True

    def __post_init__(self):
        if self.chm not in CHM_KINDS:
            raise InputError(f"-chm: unknown CHM {self.chm!r}; use {', '.join(CHM_KINDS)}")
        if self.fill not in FILLS:
            raise InputError(f"-fill: expected one of {', '.join(FILLS)}, got {self.fill!r}")
        DtmMethod.parse(self.dtm)
        if not self.auto_res:
            object.__setattr__(self, "res", check_resolution(self.res))

    @property
    def auto_res(self) -> bool:
        return self.res is None or (isinstance(self.res, str) and self.res.strip().lower() == "auto")

    @property
    def dtm_method(self) -> DtmMethod:
        return DtmMethod.parse(self.dtm)


@register
@dataclass(frozen=True)
class SurfaceStats:
    """What the surfaces of a tile take from its whole area rather than from the tile's own
    points, so that a tile's surfaces are those of the whole area (measured once by
    :func:`lidartrees_gis.als.area.plan_area`; None: from the points at hand).

    Attributes
    ----------
    max_edge : float
        The pit-free CHM's edge limit (m, :func:`lidartrees_gis.als.chm.pitfree_edge`).
    footprint : float
        The data footprint's reach (m): cells within it of a cell holding points are filled.
    lowest_median : float
        ``-dtm lowest:R``: the median number of points per non-empty R-metre cell (cells with
        less than a quarter of it, cut by the data's edge, are left out of the DTM).
    dtm_kind : {"ground", "lowest"}
        What ``-dtm auto`` chose: ``ground`` when the points hold class-2 points.
    """

    max_edge: float | None = None
    footprint: float | None = None
    lowest_median: float | None = None
    dtm_kind: str | None = None


def bilinear(arr, spec: GridSpec, x, y):
    """Bilinear sample of a grid at map coordinates (edges clamped).

    A point's position in the grid is taken from the global grid (``x / res`` less the grid's
    own first column, an integer), so a tile's grid and the whole area's give the same weights
    to the last bit: the heights above ground of ground points, which lie on the DTM, keep
    their sign (the pit-free CHM's first layer takes the points at or above 0)."""
    from .._raster import sample_bilinear

    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    o = spec.origin_cells()
    if o is None:
        col = (x - spec.left) / spec.res - 0.5
        row = (spec.top - y) / spec.res - 0.5
    else:
        inv = 1.0 / spec.res
        col = (x * inv - o[0]) - 0.5
        row = ((o[1] + spec.height) - y * inv) - 0.5
    return sample_bilinear(arr, row, col)


class _Accumulators:
    """What one pass over the points keeps: the highest (and lowest) point per cell, the lowest
    ground point per cell, the lowest point per ``lowest:R`` cell and the first returns."""

    def __init__(self, spec: GridSpec, method: DtmMethod, keep_first: bool,
                 keep_all: bool = False):
        self.acc = GridAccumulator(spec, ("max", "min") if method.kind == "min" else ("max",))
        # the lowest ground (class 2) return of each cell, at its own position (a TIN through
        # cell centres would be ambiguous on the regular lattice)
        self.ground = LowestPoints(spec) if method.kind in ("ground", "auto") else None
        self.lowest = (LowestPoints(GridSpec.from_bounds(*spec.bounds, method.size or 5.0,
                                                         crs=spec.crs))
                       if method.kind in ("lowest", "auto") else None)
        self.first = [] if keep_first else None
        self.all = [] if keep_all else None
        self.n = 0

    def add(self, chunk) -> None:
        self.n += len(chunk)
        self.acc.add(chunk.x, chunk.y, chunk.z)
        if self.ground is not None and chunk.classification is not None:
            g = chunk.classification == 2
            if g.any():
                self.ground.add(chunk.x[g], chunk.y[g], chunk.z[g])
        if self.lowest is not None:
            self.lowest.add(chunk.x, chunk.y, chunk.z)
        if self.all is not None:
            self.all.append((chunk.x, chunk.y, chunk.z.astype(np.float32)))
        if self.first is not None:
            rn = chunk.return_number
            sel = slice(None) if rn is None else (rn <= 1)
            self.first.append((chunk.x[sel], chunk.y[sel], chunk.z[sel]))

    def first_returns(self):
        x, y, z = (np.concatenate([k[i] for k in self.first]) for i in range(3))
        self.first = None
        return x, y, z


#: the terrain points of -dtm ground / lowest:R more than this far below the second lowest
#: of their 10 nearest (multipath, a deep noise return left in class 2) are left out
LOW_DEPTH = 2.0


def _without_low(acc, x, y, z, drop: bool):
    """``(x, y, z)`` without the isolated low points (:data:`LOW_DEPTH`), counted in
    ``acc.low_points``."""
    if not drop:
        return x, y, z
    from ..ground.filter import low_points

    low = low_points(np.asarray(x), np.asarray(y), np.asarray(z), LOW_DEPTH)
    acc.low_points = int(low.sum())
    return (x, y, z) if not low.any() else (x[~low], y[~low], z[~low])


#: -dtm min: a cell whose lowest return lies more than this below the median lowest return of
#: its block of cells (:func:`_block_median`) is a stray low return (a typo, multipath), not terrain: no tree
#: is this tall and no ground drops this much within two cells
LOW_CELL_DEPTH = 150.0


def _without_low_cells(acc, zmin: np.ndarray) -> np.ndarray:
    """``zmin`` (each cell's lowest return) without the cells of a stray low return
    (:data:`LOW_CELL_DEPTH`), set to NaN and counted in ``acc.low_points``."""
    ok = np.isfinite(zmin)
    if ok.sum() < 2:
        return zmin
    ref = _block_median(zmin)
    with np.errstate(invalid="ignore"):
        low = ok & (zmin < ref - LOW_CELL_DEPTH)
    acc.low_points = int(low.sum())
    return np.where(low, np.nan, zmin) if low.any() else zmin


def _block_median(zmin: np.ndarray, block: int = 16) -> np.ndarray:
    """The median of each ``block`` x ``block`` block's finite values, on every cell of it (a
    cheap neighbourhood for large grids)."""
    h, w = zmin.shape
    H, W = -(-h // block) * block, -(-w // block) * block
    pad = np.full((H, W), np.nan)
    pad[:h, :w] = zmin
    b = pad.reshape(H // block, block, W // block, block).transpose(0, 2, 1, 3).reshape(
        H // block, W // block, -1)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an empty block: NaN
        med = np.nanmedian(b, axis=2)
    return np.repeat(np.repeat(med, block, 0), block, 1)[:h, :w]


def _terrain(src, method: DtmMethod, acc: _Accumulators, spec: GridSpec, dsm_raw, fill, prog,
             stats: SurfaceStats, drop_low: bool = True, where=None):
    """The DTM by ``method``: ``(dtm, kind)`` (``kind`` what ``auto`` chose: the area's choice
    when ``stats`` says, unless this box holds too few ground points). ``drop_low``: leave the
    isolated low terrain points out (:func:`_without_low`); ``where``: the cells a TIN DTM
    must fill (default all)."""
    kind = method.kind
    if kind == "auto":
        has_ground = int((acc.ground.count > 0).sum()) >= 3
        kind = stats.dtm_kind or ("ground" if has_ground else "lowest")
        if kind == "ground" and not has_ground:
            kind = "lowest"
    if kind == "min":
        zmin = acc.acc.result("min")
        if drop_low:
            zmin = _without_low_cells(acc, zmin)
        return fill_gaps(zmin, fill), kind
    if kind == "none":
        return np.zeros(spec.shape), kind
    if kind == "ground":
        gx, gy, gz = acc.ground.points(min_share=0.0)
        if gx.size == 0:
            raise InputError(f"{src.path}: -dtm ground: the file has no ground (class 2) points; "
                             "use -dtm auto, lowest:R, kp or a DTM GeoTIFF")
        return interpolate_tin(*_without_low(acc, gx, gy, gz, drop_low), spec, where=where), kind
    if kind == "lowest":
        pts = acc.lowest.points(reference=stats.lowest_median)
        return interpolate_tin(*_without_low(acc, *pts, drop_low), spec, where=where), kind
    if kind == "kp":
        from ..ground.chain import dtm_from_ground, ground_points
        from ..ground.filter import KrausPfeifer

        kp = KrausPfeifer() if method.g is None else KrausPfeifer(g=method.g, w=method.w)
        pts, ground = ground_points(src, kp, SubProgress(prog, 0.82, 0.88),
                                    **_tile_ground_grid(src))
        return dtm_from_ground(pts, ground, spec), kind
    return _dtm_from_file(method.path, spec, dsm_raw), kind


def _tile_ground_grid(src) -> dict:
    """The ground filter's grids for ``src``: a tile of a larger area takes the area's
    densification cell and lays its grids on the tile's box (as ``ground``'s tiles do), so that
    neighbouring tiles' DTMs agree (each tile's own density gave each its own cell); one file,
    or one tile holding the whole area, the points' own (``{}``)."""
    from ..ground.filter import refine_cell_for

    cat, b = getattr(src, "catalog", None), getattr(src, "box", None)
    if cat is None or b is None:
        return {}
    box = cat.clip(b)
    if box == cat.extent:  # the tile holds the whole area
        return {}
    return {"refine_res": refine_cell_for(cat.area, cat.count), "extent": box}


def _dtm_from_file(path, spec: GridSpec, dsm_raw):
    """A DTM GeoTIFF resampled onto ``spec``; refused when it leaves cells with points bare."""
    arr, dspec, _ = read_raster(path)
    dtm = resample_to(arr, dspec, spec)
    has = np.isfinite(dsm_raw)
    miss = int((has & ~np.isfinite(dtm)).sum())
    if miss > 0.01 * max(int(has.sum()), 1):
        b, db = spec.bounds, dspec.bounds
        raise InputError(
            f"-dtm {path}: the DTM does not cover the points ({miss:,} of "
            f"{int(has.sum()):,} cells with points have no terrain height; DTM x "
            f"{db[0]:.1f}..{db[2]:.1f}, y {db[1]:.1f}..{db[3]:.1f}; points x {b[0]:.1f}.."
            f"{b[2]:.1f}, y {b[1]:.1f}..{b[3]:.1f}); give a DTM of the whole area or -dtm auto")
    if miss:  # a few edge cells: the nearest terrain height
        dtm = fill_gaps(dtm, "mean8")
    return dtm


def _canopy(acc: _Accumulators, opts: SurfaceOptions, spec: GridSpec, dtm, dsm_raw, chm_raw,
            out_cells, ceiling, footprint, max_edge, returns, prog):
    """The CHM from the first returns (pit-free or TIN) and the tree-height grid:
    ``(chm, heights, outlier points, edge limit used)``."""
    x, y, z = acc.first_returns()
    zn = z - bilinear(dtm, spec, x, y)
    zn[np.abs(zn) < ON_GROUND] = 0.0  # on the DTM (the ground points it was made from)
    out_points = 0
    if out_cells.any():
        r, c = spec.cell_index(x, y)
        r = np.clip(r, 0, spec.height - 1)
        c = np.clip(c, 0, spec.width - 1)
        noise = out_cells[r, c] & (zn > ceiling[r, c])
        out_points = int(noise.sum())
        x, y, zn = x[~noise], y[~noise], zn[~noise]
    prog.update(0.9, f"{opts.chm} CHM")
    check_cancel(prog)
    if opts.chm == "tin":
        chm = tin_surface(x, y, zn, spec, max_radius=LOCAL_RADIUS)
    else:
        if max_edge is None:
            max_edge = pitfree_edge(x.size, float(np.isfinite(dsm_raw).sum()) * spec.cell_area)
        chm = pitfree_chm(x, y, zn, spec, max_edge=(0.0, max_edge),
                          coarse=np.where(out_cells, np.nan, chm_raw))
    chm = fill_gaps(chm, opts.fill, mask=footprint)
    # tree heights: the highest return of a cell is above the TIN at its centre
    return chm, np.fmax(chm, returns), out_points, max_edge


def compute_surfaces(src, res: float, opts: SurfaceOptions | None = None, *,
                     stats: SurfaceStats | None = None, keep_points: bool = False,
                     whole_dtm: bool = True, progress=None) -> dict:
    """DSM, DTM and CHM of a point source on one aligned grid.

    Parameters
    ----------
    src : PointSource or TileSource
        Points (its class filter, e.g. noise classes 7 and 18 dropped, applies).
    res : float
        Cell size (m).
    opts : SurfaceOptions
    stats : SurfaceStats, optional
        What to take from the whole area (tiles take the area's); by default each is measured
        on these points.

    Returns
    -------
    dict with ``dsm``, ``dtm``, ``chm`` (float64 arrays, NaN = nodata), ``heights`` (the CHM
    or, where higher, the highest return above ground in the cell: what tree heights are read
    from), ``returns`` (the highest return above ground per cell), ``spec``, ``res``,
    ``dtm_method``, ``chm_method``, ``points``, ``dropped`` (points per dropped class),
    ``outlier_cells``, ``outlier_points``, ``stats`` (the :class:`SurfaceStats` used) and
    ``density`` (points per m² over the data footprint); with ``keep_points``, ``points``:
    every point's ``(x, y, height above the DTM)`` (plantation mode looks under the canopy).
    ``whole_dtm=False`` (the trees): the DTM only within the data footprint (NaN beyond it,
    where the other surfaces are NaN anyway; the trees need no more), not extrapolated to every
    cell, and no gap-filled DSM (``dsm`` None) unless the CHM is made from it (``-chm max``):
    the trees do not read it (its filling was 0.45 s of a 16 M point chain at 0.5 m cells).
    """
    opts = opts or SurfaceOptions()
    stats = stats or SurfaceStats()
    prog = as_progress(progress)
    method = opts.dtm_method
    spec = grid_spec_for(src, res, SubProgress(prog, 0.0, 0.3))
    acc = _Accumulators(spec, method, keep_first=opts.chm != "max", keep_all=keep_points)
    for chunk in src.chunks(SubProgress(prog, 0.3, 0.8)):
        acc.add(chunk)
    if acc.n == 0:
        raise InputError(f"{src.path}: no points" + (
            f" left after dropping classes {sorted(src.dropped)}" if src.dropped else ""))
    check_cancel(prog)
    dsm_raw = acc.acc.result("max")
    # the data footprint: cells within 2 m (or 3 point spacings) of a cell with points
    occupied = np.isfinite(dsm_raw)
    reach = stats.footprint
    if reach is None:
        reach = max(2.0, 3.0 * math.sqrt(spec.cell_area * occupied.sum() / acc.n))
    footprint = data_footprint(occupied, spec.res, reach)
    prog.update(0.82, "terrain")
    acc.low_points = 0
    # the footprint and the cells around it (a point's bilinear terrain height reads the four
    # cell centres around it)
    near = None if whole_dtm else ndimage.binary_dilation(footprint, np.ones((3, 3), bool))
    dtm, kind = _terrain(src, method, acc, spec, dsm_raw, opts.fill, prog, stats,
                         drop_low=opts.outliers, where=near)
    check_cancel(prog)
    chm_raw = dsm_raw - dtm
    out_cells, ceiling = np.zeros(spec.shape, bool), None
    if opts.outliers:
        out_cells, ceiling = canopy_outliers(chm_raw, res, origin=(spec.left, spec.top))
    out_points = int(out_cells.sum())
    if out_points:
        dsm_raw = np.where(out_cells, np.nan, dsm_raw)
    # the highest return above ground of each cell (NaN: none); plantation mode looks at it
    returns = dsm_raw - dtm
    prog.update(0.88, "filling gaps")
    dsm = None if not whole_dtm and opts.chm != "max" else fill_gaps(
        dsm_raw, opts.fill, progress=SubProgress(prog, 0.88, 0.9), mask=footprint)
    max_edge = stats.max_edge
    if opts.chm == "max":
        chm = heights = dsm - dtm
    else:
        chm, heights, noise, max_edge = _canopy(acc, opts, spec, dtm, dsm_raw, chm_raw, out_cells,
                                                ceiling, footprint, max_edge, returns, prog)
        out_points = noise if out_cells.any() else out_points
    used = SurfaceStats(max_edge, reach, acc.lowest.median() if acc.lowest is not None else None,
                        kind if method.kind == "auto" else None)
    prog.update(0.95, "canopy height")
    kept = None
    if acc.all is not None:
        x, y, z = (np.concatenate([k[i] for k in acc.all]) for i in range(3))
        acc.all = None
        kept = (x, y, (z - bilinear(dtm, spec, x, y)).astype(np.float32))
    return {"points_above_ground": kept,
            "dsm": dsm, "dtm": dtm, "chm": chm, "heights": heights, "returns": returns,
            "spec": spec, "res": res, "dtm_method": method.label(kind), "chm_method": opts.chm,
            "points": acc.n, "outside": acc.acc.outside, "dropped": dict(src.dropped),
            "density": acc.n / max(float(footprint.sum()) * spec.cell_area, 1e-9),
            "outlier_cells": int(out_cells.sum()), "outlier_points": out_points + acc.low_points,
            "stats": used}


def box_surfaces(area, box, res: float, opts: SurfaceOptions, *, stats=None,
                 keep_points: bool = False, whole_dtm: bool = True,
                 progress=None) -> dict | None:
    """The surfaces of the part of ``area`` inside ``box``: a
    :class:`~lidartrees_gis.catalog.catalog.Catalog` (points, :func:`compute_surfaces`) or a
    :class:`~lidartrees_gis.catalog.raster.RasterArea` (a CHM GeoTIFF, its window). None when
    the box holds no point (a gap between files, a corner of the area)."""
    from ..catalog.raster import RasterArea
    from ..catalog.source import TileSource

    if isinstance(area, RasterArea):
        return area.surfaces(box)
    src = TileSource(area, box)
    if not src.files:
        return None
    try:
        return compute_surfaces(src, res, opts, stats=stats, keep_points=keep_points,
                                whole_dtm=whole_dtm, progress=progress)
    except InputError as exc:
        if "no points" in str(exc):
            return None
        raise
