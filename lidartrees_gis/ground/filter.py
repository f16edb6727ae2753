"""Ground filtering by robust interpolation (Kraus & Pfeifer 1998, as in FUSION's GroundFilter,
tuned for eucalyptus by Leite et al., seed 003) and the DTM texture-quality sweep of seed 003.

The filter has two stages.

1. **Robust interpolation** (the seed's method). Surface: a grid of ``cell`` metres; each cell
   holds the weighted least-squares plane of its points evaluated at the cell centre (the
   weighted mean, FUSION's intermediate surface, where fewer than 3 points or a line; weights from
   the previous iteration, all 1 at the start), empty cells are filled by
   :func:`lidartrees_gis.grid.fill_mean8`, and the surface at a point is the bilinear
   interpolation of the cell centres (a cell mean alone sags on slopes and at the borders). It runs
   hierarchically (Pfeifer et al. 2001): ``levels`` grids from ``cell * 2**(levels-1)`` down to
   ``cell``, ``iterations`` each, every level starting from the weights of the coarser one, so
   buildings and dense crowns are rejected at the coarse levels and terrain detail comes back at
   the fine ones. The coarsest cell (24 m by default) bounds the objects rejected (roofs of
   35 x 30 m go); its surfaces cannot follow hills and sharp ridges, so at a coarser level of cell
   c the band is widened to w + ``w_growth`` (c - cell), 0.2 m per metre (4.5 m more at 24 m; the
   finest level uses w itself) and hilltops and crests are not thrown away. Residual v = z - surface. Weights (seed 003, eq. 1)::

       p = 1                          v <= g
       p = 1 / (1 + (a (v - g))^b)    g < v <= g + w
       p = 0                          v > g + w

   g is fixed (what seed 003 sweeps) unless ``gshift``: then, as in Kraus & Pfeifer's automatic
   shift, each iteration takes g = max(g, -2 s) with s the RMS of the negative residuals of the
   points weighted >= 0.5 in the previous iteration (the ground branch of the histogram).
   Points of the ground band (v <= g + w; with ``refine``, v <= max(g + w, tolerance) so that
   g = -w, whose surface settles on the lowest points, still seeds the ground) are the
   robust-interpolation ground.

2. **Densification against a real surface** (at most ``refine`` passes, default 10, until no
   point changes): a linear TIN of the lowest current ground point in each ``tin_cell`` cell
   (1.5 m; all of them with 0; taking the lowest keeps the TIN from creeping up into shrubs),
   sampled on a grid of sqrt(area / n) metres (0.5-2 m); a point is ground when ``-(1 + slope * S) <= v <= tolerance + slope * S``, S being
   the terrain slope (m/m) of the TIN at the point. The tolerance is one-sided upwards as FUSION's
   ``/tolerance``; the slope term (as in SMRF) keeps steep ground. ``refine=0`` gives the plain
   filter: v <= g + w, or v <= ``tolerance`` when set (FUSION).

Isolated low points (more than ``low`` metres below the second lowest of their 10 nearest
neighbours, multipath echoes) are left out of every surface; they are ground only if they fall in
the final band.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..bounds import check_fields
from ..errors import InputError
from ..grid import GridSpec, check_sparse, fill_mean8
from ..progress import as_progress, check_cancel
from ._kernels import (bilinear, isolated_low, kp_weights_fast, kp_weights_np, lowest_index,
                       plane_surface, residuals)


@dataclass(frozen=True)
class KrausPfeifer:
    """Parameters of the ground filter (defaults from the sweep on the ISPRS dev samples,
    ``benchmarks/bench_ground.py``)."""

    g: float = -2.0
    w: float = 2.5
    a: float = 1.0
    b: float = 4.0
    iterations: int = 5
    cell: float = 1.5
    levels: int = 5
    w_growth: float = 0.2
    tolerance: float | None = None
    refine: int = 10
    slope: float = 1.25
    tin_cell: float = 1.5
    low: float = 2.0
    gshift: bool = False

    def __post_init__(self):
        check_fields(self, dict.fromkeys(("g", "w", "cell", "tolerance", "tin_cell", "low"), "m"))
        if not self.w > 0:
            raise InputError(f"-w must be > 0, got {self.w}")
        if not (self.a > 0 and self.b > 0):
            raise InputError("-a and -b must be > 0")
        if not 1 <= int(self.iterations) <= 100:  # the robust weights settle in a few
            raise InputError(f"-iterations must be 1 to 100, got {self.iterations}")
        if not self.cell > 0:
            raise InputError(f"-cell must be > 0 m, got {self.cell}")
        if not 1 <= int(self.levels) <= 12:
            raise InputError(f"-levels must be 1 to 12, got {self.levels}")
        if self.tolerance is not None and not self.tolerance > 0:
            raise InputError(f"-tolerance must be > 0 m, got {self.tolerance}")
        if not 0 <= int(self.refine) <= 100:
            raise InputError(f"-refine must be 0 to 100, got {self.refine}")
        if not self.w_growth >= 0:
            raise InputError(f"-w_growth must be >= 0, got {self.w_growth}")
        if not self.tin_cell >= 0:
            raise InputError(f"-tin_cell must be >= 0 m (0 = every ground point), got {self.tin_cell}")
        if not self.slope >= 0:
            raise InputError(f"-slope must be >= 0, got {self.slope}")
        if not self.low >= 0:
            raise InputError(f"-low must be >= 0 m (0 = keep low points), got {self.low}")

    def as_dict(self):
        return asdict(self)

    @property
    def refine_tolerance(self) -> float:
        """Upper tolerance of the densification passes (0.3 m unless ``tolerance`` is set)."""
        return 0.3 if self.tolerance is None else float(self.tolerance)


def kp_weights(v, g=-2.0, w=2.5, a=1.0, b=4.0):
    """Kraus & Pfeifer weight of residuals ``v`` (seed 003, eq. 1).

    >>> kp_weights(np.array([-3.0, -1.0, 1.0]), g=-2, w=2.5).round(4).tolist()
    [1.0, 0.5, 0.0]
    """
    return kp_weights_np(v, g, w, a, b)


def shifted_g(v, weights, g):
    """Automatic shift of g (option ``gshift``): max(g, -2 s), s = RMS of the negative residuals
    of the points weighted >= 0.5."""
    neg = v[(v < 0) & (weights >= 0.5)]
    if neg.size == 0:
        return g
    return max(g, -2.0 * float(np.sqrt(np.mean(neg ** 2))))


def low_points(x, y, z, depth=2.0, k=10):
    """Isolated low points: more than ``depth`` metres below the second lowest of their ``k``
    nearest neighbours (in plan)."""
    if depth <= 0 or x.size <= k:
        return np.zeros(x.size, bool)
    return isolated_low(x, y, z, depth, k)


def _level_cells(x, y, spec: GridSpec):
    """Flat cell of each point and its offset from the cell centre in cells (fixed per level)."""
    row, col = spec.cell_index(x, y)
    cx = spec.left + (col + 0.5) * spec.res
    cy = spec.top - (row + 0.5) * spec.res
    return row * spec.width + col, (x - cx) / spec.res, (y - cy) / spec.res


def _surface(x, y, z, wts, spec: GridSpec, cells=None):
    """Filter surface at the cell centres: per cell the weighted least-squares plane of its points
    evaluated at the centre (the weighted mean where a plane is not determined: fewer than 3
    points or all on a line), empty cells filled by mean8. ``cells``: :func:`_level_cells`."""
    idx, dx, dy = cells if cells is not None else _level_cells(x, y, spec)
    grid = plane_surface(idx, dx, dy, z, wts, spec.width * spec.height, spec.res)
    return fill_mean8(grid.reshape(spec.shape))


def _bilinear(grid, spec: GridSpec, x, y):
    """Bilinear interpolation of cell-centre values at points (edges clamped)."""
    return bilinear(grid, spec.left, spec.top, spec.res, x, y)


def _residuals(grid, spec: GridSpec, x, y, z):
    """z minus the bilinear surface at the points."""
    return residuals(grid, spec.left, spec.top, spec.res, x, y, z)


def refine_cell_for(area: float, count: int) -> float:
    """Cell of the densification DTM for ``count`` points over ``area`` m²: sqrt(area / n),
    clipped to 0.5-2 m, rounded to 0.1 m."""
    return round(min(2.0, max(0.5, float(np.sqrt(max(area, 1.0) / max(count, 1))))), 1)


def refine_cell(x, y) -> float:
    """:func:`refine_cell_for` the points' bounding box."""
    return refine_cell_for(float(np.ptp(x)) * float(np.ptp(y)), x.size)


def lowest_per_cell(x, y, z, sel, res):
    """Mask of the lowest selected point in each ``res``-metre cell."""
    idx = np.nonzero(sel)[0]
    m = np.zeros(x.size, bool)
    if idx.size == 0:
        return m
    spec = GridSpec.from_bounds(x.min(), y.min(), x.max(), y.max(), res)
    r, c = spec.cell_index(x[idx], y[idx])
    best = lowest_index(idx, r * spec.width + c, z, spec.width * spec.height)
    m[best[best >= 0]] = True
    return m


def _slope(dtm, res):
    """Gradient magnitude of a grid; 0 along an axis only one cell wide (a strip of points)."""
    g = [np.gradient(dtm, res, axis=a) if dtm.shape[a] > 1 else np.zeros_like(dtm)
         for a in (0, 1)]
    return np.hypot(g[0], g[1])


#: triangles of the densification TIN with a wider circumcircle (m) are not used (cells there
#: take the nearest ground point): the slivers along the hull joined points far apart, so a
#: tile's hull (and its ground near the area's edge) differed from the whole area's
DENSIFY_RADIUS = 20.0


def densify(x, y, z, ground, usable, params: KrausPfeifer, progress=None, res=None,
            extent=None):
    """Densification passes against the TIN of the current ground points (stage 2), sampled
    on a grid of ``res`` metres (default :func:`refine_cell` of the points)."""
    from ..tin import interpolate_tin

    p = params
    res = res or refine_cell(x, y)
    spec = GridSpec.from_bounds(*(extent or (x.min(), y.min(), x.max(), y.max())), res)
    for _ in range(int(p.refine)):
        check_cancel(progress)
        seed = ground & usable
        if p.tin_cell > 0:  # vertices: the lowest ground point per cell (no creep into shrubs)
            seed = lowest_per_cell(x, y, z, seed, p.tin_cell)
        if seed.sum() < 3:
            break
        dtm = interpolate_tin(x[seed], y[seed], z[seed], spec, max_radius=DENSIFY_RADIUS)
        slope = _bilinear(_slope(dtm, res), spec, x, y)
        v = _residuals(dtm, spec, x, y, z)
        new = (v <= p.refine_tolerance + p.slope * slope) & (v >= -1.0 - p.slope * slope)
        if np.array_equal(new, ground):
            break
        ground = new
    return ground


def kraus_pfeifer(x, y, z, params: KrausPfeifer | None = None, progress=None, low=None,
                  refine_res=None, extent=None):
    """Ground filter: hierarchical robust interpolation, then densification (see module doc).

    Parameters
    ----------
    x, y, z : (N,) ndarray of float
    params : KrausPfeifer
    low : (N,) ndarray of bool, optional
        The isolated low points (:func:`low_points` with ``params.low``), when the caller has
        them already (a sweep over g and w computes them once).
    refine_res : float, optional
        Cell of the densification's DTM; default :func:`refine_cell` of the points (a tile
        takes its area's, so that every tile samples the same grid).

    Returns
    -------
    ground : (N,) ndarray of bool
    weights : (N,) ndarray of float
        Final weights of the robust interpolation.
    """
    p = params or KrausPfeifer()
    x, y, z = (np.asarray(a, dtype=np.float64) for a in (x, y, z))
    if x.size == 0:
        raise InputError("ground filter: no points")
    prog = as_progress(progress)
    b = (x.min(), y.min(), x.max(), y.max())
    if extent is not None:  # the grids' extent, holding every point
        b = (min(b[0], extent[0]), min(b[1], extent[1]), max(b[2], extent[2]),
             max(b[3], extent[3]))
    refine_res = refine_res or refine_cell(x, y)
    for res in (p.cell, refine_res):
        check_sparse((b[2] - b[0] + res) * (b[3] - b[1] + res) / res ** 2, x.size, b, res,
                     "ground filter", limit=1000)  # ALS has < 20 cells of 1.5 m per point
    usable = ~(low_points(x, y, z, p.low) if low is None else np.asarray(low, bool))
    if usable.sum() < 3:
        usable[:] = True
    ux, uy, uz = x[usable], y[usable], z[usable]
    wts = np.ones(ux.size)
    levels = int(p.levels)
    total = levels * int(p.iterations) + int(p.refine)
    step = 0
    g = p.g
    for lev in range(levels):
        spec = GridSpec.from_bounds(*(b if extent is not None else
                                      (ux.min(), uy.min(), ux.max(), uy.max())),
                                    p.cell * 2 ** (levels - 1 - lev))
        cells = _level_cells(ux, uy, spec)
        for it in range(int(p.iterations)):
            check_cancel(progress)
            surf = _surface(ux, uy, uz, wts, spec, cells)
            v = _residuals(surf, spec, ux, uy, uz)
            if p.gshift and (lev or it):
                g = shifted_g(v, wts, p.g)
            wts = kp_weights_fast(v, g, p.w + p.w_growth * (spec.res - p.cell), p.a, p.b)
            if wts.sum() == 0:
                raise InputError(f"ground filter: every weight became 0 at iteration {it + 1}; "
                                 "lower -g or raise -w")
            step += 1
            prog.update(step / total, f"level {lev + 1}/{levels}, iteration {it + 1}")
    surf = _surface(ux, uy, uz, wts, spec, cells)
    v = _residuals(surf, spec, x, y, z)
    if p.refine == 0:
        ground = v <= (p.tolerance if p.tolerance is not None else g + p.w)
    else:  # seed of the densification: the ground band, at least the tolerance above the surface
        ground = v <= max(g + p.w, p.refine_tolerance)
    weights = kp_weights_fast(v, g, p.w, p.a, p.b)
    if p.refine:
        ground = densify(x, y, z, ground, usable, p, progress, refine_res,
                         b if extent is not None else None)
    prog.update(1.0, "ground filter done")
    return ground, weights


# ---------------------------------------------------------------------------------------------
# Accuracy against reference labels (ISPRS filter test)
def filter_errors(pred_ground, ref_ground) -> dict:
    """Type I (ground rejected), type II (object accepted as ground), total error and Cohen's
    kappa, in % (kappa as a fraction), as Sithole & Vosselman (2004) report them."""
    pg = np.asarray(pred_ground, bool)
    rg = np.asarray(ref_ground, bool)
    a = int((rg & pg).sum())      # ground -> ground
    b = int((rg & ~pg).sum())     # ground -> object (type I)
    c = int((~rg & pg).sum())     # object -> ground (type II)
    d = int((~rg & ~pg).sum())    # object -> object
    n = a + b + c + d
    po = (a + d) / n
    pe = ((a + b) * (a + c) + (c + d) * (b + d)) / n ** 2
    return {"type1": 100 * b / max(a + b, 1), "type2": 100 * c / max(c + d, 1),
            "total": 100 * (b + c) / n, "kappa": (po - pe) / (1 - pe) if pe < 1 else 1.0}


# ---------------------------------------------------------------------------------------------


