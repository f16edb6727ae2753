"""Plantation mode's second look at the empty planting positions: the apex of a tree the tops
finder missed (sparse returns, a lower tree beside a taller one)."""
from __future__ import annotations

import numpy as np
from scipy import ndimage

#: plantation mode's second look at an empty planting position (:func:`gap_tops`): the apex may
#: lie this share of the smaller spacing from the position ...
GAP_REACH = 0.3
#: ... and must be the highest return within this radius (m) ...
GAP_APEX_RADIUS = 0.5
#: ... and at least this share of the smaller spacing from every detected top
GAP_CLEARANCE = 0.5


def gap_tops(gaps_x, gaps_y, returns, chm_s, spec, spacing, *, top_x, top_y,
             min_height=2.0, reach: float = GAP_REACH,
             apex_radius: float = GAP_APEX_RADIUS, clearance: float = GAP_CLEARANCE,
             smaller=None):
    """Tops of trees at empty planting positions that the tops finder missed.

    In sparse data (a few points per m²) a tree lower than its in-row neighbour often has no
    local maximum on the CHM: the narrow valley between the two crowns holds no return, and the
    CHM rises straight from its apex to the neighbour. Its apex return is still the highest
    return around it. At each empty position, the highest cell of ``returns`` within ``reach``
    x the smaller spacing is taken when it is the highest return within ``apex_radius`` m, lies
    at least ``clearance`` x the smaller spacing from every detected top, and both it and the
    smoothed CHM there reach ``min_height``.

    Parameters
    ----------
    gaps_x, gaps_y : array_like
        The empty planting positions (``x, y`` of :func:`stocking`'s ``looks`` table).
    returns : (M, N) ndarray of float
        Highest return above ground of each cell, NaN where a cell has none.
    chm_s : (M, N) ndarray of float
        The smoothed CHM the crowns grow on.
    spec : GridSpec
    spacing : (float, float)
        Row and tree spacing (m).
    top_x, top_y : array_like
        The detected tops.
    min_height : float or array_like
        The height an apex must reach, one for all positions or one per position (the
        understorey's share of each one's own canopy).
    smaller : array_like, optional
        The smaller spacing of each position's own lattice, where stands of other spacings
        share a tile (instead of ``spacing``'s): a stand's positions are looked at alike
        whichever stand's lattice holds most of the tile.

    Returns
    -------
    rows, cols : ndarray of int
        Cells of the added tops, at most one per position.
    """
    from scipy.spatial import cKDTree

    none = (np.empty(0, np.int64), np.empty(0, np.int64))
    gx, gy = np.asarray(gaps_x, float), np.asarray(gaps_y, float)
    if gx.size == 0:
        return none
    own = np.full(gx.size, float(min(spacing))) if smaller is None else \
        np.broadcast_to(np.asarray(smaller, float), gx.shape)
    need = np.broadcast_to(np.asarray(min_height, float), gx.shape)
    min_height = float(need.min())  # the apexes of all; each position's own below
    a = np.asarray(returns, np.float64)
    finite = np.isfinite(a)
    a = np.where(finite, a, -np.inf)
    size = 2 * int(round(apex_radius / spec.res)) + 1
    apex = (a >= ndimage.maximum_filter(a, size=size, mode="constant", cval=-np.inf)) & finite
    apex &= (a >= min_height) & (np.nan_to_num(np.asarray(chm_s, float), nan=-np.inf) >= min_height)
    rows, cols = np.nonzero(apex)
    if rows.size == 0:
        return none
    cx, cy = spec.xy(rows, cols)
    tx, ty = np.asarray(top_x, float), np.asarray(top_y, float)
    d = cKDTree(np.c_[tx, ty]).query(np.c_[cx, cy])[0] if tx.size else np.full(cx.size, np.inf)
    h = np.minimum(a[rows, cols], np.asarray(chm_s, float)[rows, cols])
    h_top = a[rows, cols]
    pick = set()
    for s in np.unique(own):  # each lattice's positions at their own spacing
        keep = np.nonzero(d >= clearance * s)[0]
        at = own == s
        if not keep.size:
            continue
        # per position, the highest candidate within reach
        near = cKDTree(np.c_[cx[keep], cy[keep]]).query_ball_point(np.c_[gx[at], gy[at]],
                                                                   reach * s)
        for k, m in zip(near, need[at]):
            if k:  # the highest candidate within reach, when it and the CHM there reach m
                best = int(keep[max(k, key=lambda i: (h_top[keep[i]], -keep[i]))])
                if h[best] >= m:
                    pick.add(best)
    pick = np.asarray(sorted(pick), np.int64)
    return rows[pick], cols[pick]
