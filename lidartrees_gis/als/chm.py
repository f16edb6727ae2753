"""Canopy height models from height-normalised points, and the noise guard.

* :func:`tin_surface` — a linear TIN of points sampled at cell centres, triangles with an edge
  longer than ``max_edge`` left out (lidR ``dsmtin``).
* :func:`pitfree_chm` — Khosravipour et al. (2014) pit-free CHM: one TIN per height threshold
  (points at or above it), long-edged triangles dropped in the upper layers, and the highest
  layer kept in each cell (lidR ``pitfree``).
* :func:`canopy_outliers` — isolated returns far above the local canopy (birds, clouds,
  unclassified noise): cells whose highest return stands far above the canopy around them and
  is not joined to it by a continuous surface.
* :func:`chm_resolution` — the ``-tr auto`` rule for CHMs used to find trees.

The triangulations are a compiled incremental Delaunay triangulation (:func:`_accel.layered_tin`,
Bowyer-Watson, drawing each layer as it is built; the pit-free CHM's share of the tiled chain fell
from 55 % to 25 %), with startinpy, then scipy's Qhull, as fallbacks that give the same surfaces.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from ..errors import InputError
from ..grid import GridSpec
from .. import tin
from ..tin import LOCAL_RADIUS, _morton_order, tiebreak, tin_surface

#: Khosravipour et al. 2014 / lidR ``pitfree`` height thresholds (m)
PITFREE_THRESHOLDS = (0.0, 2.0, 5.0, 10.0, 15.0)
CHM_KINDS = ("pitfree", "max", "tin")


def chm_resolution(count: int, area: float) -> float:
    """CHM cell size for crown detection from the point count and the area they cover.

    Rule: seed 003's ``C = sqrt(1 / n)`` (one return per cell, ``n`` points per m²), never
    finer than 0.25 m, rounded to the nearest 0.05 m. Measured against sqrt(2/n) and
    0.8 sqrt(1/n) on the synthetic stands, MixedConifer and the NEON plots
    (benchmarks/bench_accuracy.py): the same or better everywhere, and better at 4 pts/m².

    >>> chm_resolution(47_000, 10_000.0)   # 4.7 pts/m² -> 0.46 -> 0.45 m
    0.45
    >>> chm_resolution(250_000, 10_000.0)  # 25 pts/m² -> 0.2 -> 0.25 m
    0.25
    """
    if count <= 0 or not area > 0:
        raise InputError("-tr auto: needs a point density; the points cover no area "
                         "(all at one location or on a line); give -tr RES")
    c = max(math.sqrt(1.0 / (count / area)), 0.25)
    return round(round(c / 0.05) * 0.05, 2)


#: pit-free edge limit = EDGE_SPACINGS x the mean spacing of the first returns
EDGE_SPACINGS = 3.0


def pitfree_edge(count: int, area: float) -> float:
    """Edge limit (m) of the pit-free upper layers: 1.5 m (lidR's usual setting), or
    ``EDGE_SPACINGS`` times the mean spacing sqrt(1/n) of the first returns where the points
    are sparser than about 4 per m², at most 3 m."""
    if count <= 0 or not area > 0:
        return 1.5
    return float(np.clip(EDGE_SPACINGS * math.sqrt(area / count), 1.5, 3.0))


def pitfree_chm(x, y, zn, spec: GridSpec, *, thresholds=PITFREE_THRESHOLDS, max_edge=(0.0, 1.5),
                coarse=None) -> np.ndarray:
    """Pit-free CHM (Khosravipour et al. 2014; lidR ``pitfree``).

    For each height threshold ``t`` a TIN is built from the points with ``zn >= t`` (the first
    layer from all points); in every layer but the first, triangles with an edge longer than
    ``max_edge[1]`` are dropped (``max_edge[0]`` applies to the first layer, 0 = no limit). The
    CHM is the highest layer value in each cell, so the deep gaps between first returns inside a
    crown (pits) are bridged by the layers above them.

    Parameters
    ----------
    x, y, zn : (P,) ndarray of float
        Point coordinates and heights above ground (first returns, as Khosravipour).
    spec : GridSpec
    thresholds : sequence of float
        Height thresholds (m), default 0, 2, 5, 10, 15.
    max_edge : (float, float)
        Edge limits (m) for the first layer and for the others.
    coarse : (M, N) ndarray of float, optional
        Highest height per cell, used only to skip cells no upper layer can reach.

    Returns
    -------
    (M, N) ndarray of float, NaN where no triangle covers a cell.
    """
    x, y, zn = (np.asarray(a, np.float64) for a in (x, y, zn))
    if len(max_edge) != 2 or min(max_edge) < 0:
        raise InputError(f"max_edge: expected two lengths >= 0 (m), got {max_edge!r}")
    from .. import _accel

    ts = sorted(float(t) for t in thresholds)
    out = np.full(spec.shape, np.nan)
    done = _pitfree_incremental(x, y, zn, spec, ts, max_edge, out)
    if done is not None:
        return done
    reach = None
    for i, t in enumerate(ts):
        sel = zn >= t
        if sel.sum() < 3:
            break
        edge = max_edge[0] if i == 0 else max_edge[1]
        cells = None
        if i > 0 and edge > 0 and not _accel.HAVE_NUMBA:
            # only cells within one edge length of a point at or above t can be covered
            if reach is None:
                from ..grid import GridAccumulator

                acc = GridAccumulator(spec, ("max",))
                acc.add(x, y, zn)
                reach = np.nan_to_num(acc.result("max"), nan=-np.inf) if coarse is None else \
                    np.nan_to_num(np.asarray(coarse, np.float64), nan=-np.inf)
            k = int(math.ceil(edge / spec.res))
            yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
            near = ndimage.maximum_filter(reach, footprint=(xx ** 2 + yy ** 2) <= k * k + 1e-9,
                                          mode="constant", cval=-np.inf)
            cells = near >= t
        tin_surface(x[sel], y[sel], zn[sel], spec, max_edge=edge, cells=cells, out=out,
                    max_radius=LOCAL_RADIUS)
    return out


def _pitfree_incremental(x, y, zn, spec: GridSpec, ts, max_edge, out):
    """The layers of :func:`pitfree_chm` from one triangulation, built from the top layer down.

    Layer ``t``'s points are those of the layer above plus the points in ``[t, t_above)``, and a
    Delaunay triangulation does not depend on the order its points are inserted in (the
    :func:`tiebreak` offsets keep the points in general position), so inserting each band into
    the triangulation of the layers above gives every layer's triangulation with each point
    inserted once instead of once per layer (3-5x fewer insertions in a forest). Each layer's
    triangles are drawn as soon as its band is in.

    The compiled :func:`_accel.layered_tin` draws only the triangles a band made (the others
    were drawn with the layer above); where its floating-point predicates fail, startinpy
    builds the same triangulation. Returns None when neither can (the caller then triangulates
    every layer on its own).
    """
    from .. import _accel

    # the layers with at least 3 points (ts ascending: the counts only fall)
    layers = [i for i, t in enumerate(ts) if np.count_nonzero(zn >= t) >= 3]
    if not layers:
        return out
    x0, y0 = float(x.min()), float(y.min())
    jx, jy = tiebreak(x, y)
    lx, ly = x - x0 + jx, y - y0 + jy
    order = _morton_order(lx, ly)
    zo = zn[order]
    bands, edges = [], []
    upper = np.inf
    for i in reversed(layers):
        bands.append(order[(zo >= ts[i]) & (zo < upper)])  # still along the Morton curve
        edges.append(float(max_edge[0] if i == 0 else max_edge[1]))
        upper = ts[i]
    grid = (spec.left - x0, spec.top - y0, spec.res, spec.height, spec.width)
    idx = np.concatenate(bands)
    ends = np.cumsum([b.size for b in bands])
    if _accel.HAVE_NUMBA and _accel.layered_tin(lx[idx], ly[idx], zn[idx], ends, edges,
                                                LOCAL_RADIUS, *grid, out) >= 0:
        return out
    out[:] = np.nan  # bands drawn before the predicates failed: all drawn again below
    startinpy = tin._startinpy()
    if startinpy is None:
        return None
    dt = tin._highest_dt(startinpy)
    try:
        for band, edge in zip(bands, edges):
            if band.size:
                dt.insert(np.column_stack([lx[band], ly[band], zn[band]]))
            p = np.asarray(dt.points)
            tri = np.asarray(dt.triangles, dtype=np.int64)
            if len(tri):
                _accel.raster_triangles(p[:, 0], p[:, 1], p[:, 2], tri, edge, *grid, out,
                                        max_radius=LOCAL_RADIUS)
    except (ValueError, RuntimeError):  # a triangulation that cannot be built draws nothing
        return out
    finally:
        del dt  # see _highest_dt
    return out


def nanpercentile_last(a, q: float) -> np.ndarray:
    """``np.nanpercentile(a, q, axis=-1)`` (linear interpolation) in one sort: numpy's loops
    over rows with NaN one by one (4 s of a 30 s tiled run). All-NaN rows give NaN."""
    a = np.asarray(a, np.float64)
    s = np.sort(a, axis=-1)  # NaN last
    n = np.sum(~np.isnan(a), axis=-1)
    pos = np.maximum(n - 1, 0) * (q / 100.0)
    lo = np.floor(pos).astype(np.int64)
    hi = np.minimum(lo + 1, np.maximum(n - 1, 0))
    v_lo = np.take_along_axis(s, lo[..., None], axis=-1)[..., 0]
    v_hi = np.take_along_axis(s, hi[..., None], axis=-1)[..., 0]
    t = pos - lo
    out = np.where(t >= 0.5, v_hi - (v_hi - v_lo) * (1 - t), v_lo + (v_hi - v_lo) * t)
    return np.where(n > 0, out, np.nan)


def canopy_outliers(chm_raw, res: float, *, block: float = 5.0, gap: float = 10.0,
                    join: float = 3.0, origin=None):
    """Cells whose highest return is an isolated outlier far above the canopy.

    Rule: the canopy reference of a cell is the highest 90th percentile of the valid heights in
    the ``block``-metre blocks of its 3 x 3 block neighbourhood. A cell is an outlier when its
    height exceeds ``reference + max(gap, 0.3 · reference)``, unless it is joined to the canopy
    by a continuous surface: a path of 8-neighbours each at most ``join`` metres higher than the
    previous one, starting from a cell that is not an outlier (so a tall tree whose top rises
    above its neighbours keeps its top, and a bird or a cloud return does not).

    Parameters
    ----------
    chm_raw : (M, N) ndarray of float
        Highest return above ground per cell; NaN = empty.
    res : float
        Cell size (m).
    origin : (left, top), optional
        Map coordinates of the grid's upper-left corner: blocks are then aligned to multiples of
        ``block`` metres, so tiles of one area agree with the whole.

    Returns
    -------
    mask : (M, N) ndarray of bool
        Outlier cells.
    ceiling : (M, N) ndarray of float
        ``reference + max(gap, 0.3 · reference)`` per cell: returns above it in an outlier cell
        are noise.
    """
    a = np.asarray(chm_raw, dtype=np.float64)
    H, W = a.shape
    b = max(1, int(round(block / res)))
    r0 = c0 = 0
    if origin is not None:
        c0 = int(round(origin[0] / res)) % b
        r0 = int(round(-origin[1] / res)) % b
    nb_r, nb_c = -(-(H + r0) // b), -(-(W + c0) // b)
    pad = np.full((nb_r * b, nb_c * b), np.nan)
    pad[r0:r0 + H, c0:c0 + W] = a
    blocks = pad.reshape(nb_r, b, nb_c, b).transpose(0, 2, 1, 3).reshape(nb_r, nb_c, b * b)
    p90 = nanpercentile_last(blocks, 90.0)
    p90 = np.where(np.isfinite(p90), p90, -np.inf)
    ref_b = ndimage.maximum_filter(p90, size=3, mode="nearest")
    ref = np.repeat(np.repeat(ref_b, b, axis=0), b, axis=1)[r0:r0 + H, c0:c0 + W]
    ref = np.where(np.isfinite(ref), np.maximum(ref, 0.0), 0.0)
    ceiling = ref + np.maximum(gap, 0.3 * ref)
    valid = np.isfinite(a)
    cand = valid & (a > ceiling)
    if not cand.any():
        return cand, ceiling
    # rescue candidates joined to the canopy by steps of at most `join` metres
    ok = valid & ~cand
    vals = np.where(valid, a, -np.inf)
    shifts = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    while True:
        reach = np.full(a.shape, -np.inf)  # highest accepted neighbour
        acc = np.where(ok, vals, -np.inf)
        padded = np.pad(acc, 1, constant_values=-np.inf)
        for dr, dc in shifts:
            reach = np.maximum(reach, padded[1 + dr:1 + dr + H, 1 + dc:1 + dc + W])
        new = cand & ~ok & (vals <= reach + join)
        if not new.any():
            break
        ok |= new
    return cand & ~ok, ceiling


def _half_correlation_distance(a: np.ndarray, res: float, level: float = 0.5,
                               max_dist: float = 15.0) -> float:
    """Distance (m) at which the radially averaged autocorrelation of ``a`` falls to ``level``."""
    H, W = a.shape
    F = np.fft.rfft2(a, s=(2 * H, 2 * W))
    ac = np.fft.fftshift(np.fft.irfft2(np.abs(F) ** 2, s=(2 * H, 2 * W)))
    if not ac.max() > 0:
        return float("nan")
    ac /= ac.max()
    kmax = min(H - 1, W - 1, int(max_dist / res) + 2)  # the lags the padded grid holds
    if kmax < 1:
        return float("nan")
    sub = ac[H - kmax:H + kmax + 1, W - kmax:W + kmax + 1]
    yy, xx = np.mgrid[-kmax:kmax + 1, -kmax:kmax + 1]
    r = np.hypot(yy, xx)
    ring = np.round(r).astype(np.int64).ravel()
    prof = np.bincount(ring, weights=sub.ravel()) / np.maximum(np.bincount(ring), 1)
    below = np.nonzero(prof < level)[0]
    if below.size == 0 or below[0] == 0:
        return float("nan")
    k = int(below[0])
    frac = (prof[k - 1] - level) / (prof[k - 1] - prof[k])
    return (k - 1 + frac) * res


def crown_scale(chm, res: float, *, highpass: float = 10.0, window: float = 150.0,
                min_height: float = 2.0, open_area: float = 500.0) -> float:
    """Crown scale of a stand (m): the distance at which the autocorrelation of the canopy
    heights falls to one half.

    Heights vary over about one crown: narrow, steep crowns (a 3 x 2 m eucalyptus stand) give
    about 0.6 m, broad conifer crowns 2-3 m. Variations larger than ``highpass`` metres (stand
    edges, roads, terrain left in the CHM) are removed first (Gaussian high-pass). Open areas
    (connected cells below ``min_height``) larger than ``open_area`` m² -- roads, firebreaks,
    clearings between stands -- are left out as nodata: their edges would otherwise set the
    scale (a farm's roads made 3 m of 0.8 m crowns). Large grids are measured on up to nine
    ``window``-metre windows (the median is returned).

    Parameters
    ----------
    chm : (M, N) ndarray of float
        NaN = nodata.
    res : float
        Cell size (m).
    open_area : float
        Open areas larger than this (m²) are left out; ``inf`` keeps them.

    Returns
    -------
    float
        Crown scale (m), clipped to [res, 10 m]; NaN when the CHM holds no canopy.
    """
    a = np.asarray(chm, np.float64)
    valid = np.isfinite(a)
    if (valid & (a >= min_height)).sum() < 25:
        return float("nan")
    if np.isfinite(open_area):
        lab, n = ndimage.label(valid & (a < min_height))
        if n:
            big = np.bincount(lab.ravel()) * res * res > open_area
            big[0] = False
            valid &= ~big[lab]
    fill = np.where(valid, a, np.nanmedian(a[valid]))
    hp = fill - ndimage.gaussian_filter(fill, highpass / res, mode="nearest")
    hp[~valid] = 0.0
    H, W = a.shape
    n = max(8, int(round(window / res)))
    if H <= n and W <= n:
        ls = [_half_correlation_distance(hp - hp[valid].mean(), res)]
    else:
        canopy = (valid & (a >= min_height)).astype(np.float64)
        rows = np.linspace(0, max(H - n, 0), 3).astype(int)
        cols = np.linspace(0, max(W - n, 0), 3).astype(int)
        ls = []
        for r0 in np.unique(rows):
            for c0 in np.unique(cols):
                win = hp[r0:r0 + n, c0:c0 + n]
                if canopy[r0:r0 + n, c0:c0 + n].mean() < 0.2:
                    continue
                ls.append(_half_correlation_distance(win - win.mean(), res))
        if not ls:
            ls = [_half_correlation_distance(hp - hp[valid].mean(), res)]
    ls = [v for v in ls if np.isfinite(v)]
    if not ls:
        return float("nan")
    return float(np.clip(np.median(ls), res, 10.0))
