"""Tree tops: local maxima of a (smoothed) CHM.

* :func:`local_maxima` — seed 000 (Castro 2006, §4.5.1): cells above the minimum tree height
  (2 m) higher than all 8 neighbours; flat tops handled deterministically (one top per plateau).
* :func:`treex_maxima` — seed 001 (TreeX, Pantaleão et al.): a rectangular search window sized
  from the mean crown area, moved by a step from the crown-area standard deviation.
* :func:`variable_window_maxima` — beyond the seeds: a circular window whose diameter grows with
  the height (as lidR's ``lmf(ws = f(h))``).

All return ``(rows, cols)`` int arrays sorted by row then column.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError

_S8 = np.ones((3, 3), dtype=bool)


def _prep(chm):
    a = np.asarray(chm, dtype=np.float64)
    if a.ndim != 2:
        raise InputError(f"chm must be 2-D, got shape {a.shape}")
    return np.where(np.isnan(a), -np.inf, a)


def _one_per_component(mask, values):
    """One cell per 8-connected component of ``mask``: the cell nearest the component's centroid;
    ties go to the smallest (row, col)."""
    lab, n = ndimage.label(mask, structure=_S8)
    if n == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    r, c = np.nonzero(lab)
    ids = lab[r, c]
    cnt = np.bincount(ids, minlength=n + 1)
    cr = np.bincount(ids, weights=r, minlength=n + 1) / np.maximum(cnt, 1)
    cc = np.bincount(ids, weights=c, minlength=n + 1) / np.maximum(cnt, 1)
    d = (r - cr[ids]) ** 2 + (c - cc[ids]) ** 2
    order = np.lexsort((c, r, d, ids))  # by component, then distance, then row, then col
    first = np.ones(order.size, bool)
    first[1:] = ids[order][1:] != ids[order][:-1]
    sel = order[first]
    rr, ccol = r[sel], c[sel]
    o = np.lexsort((ccol, rr))
    return rr[o].astype(np.int64), ccol[o].astype(np.int64)


def local_maxima(chm, *, min_height: float = 2.0, strict: bool = False):
    """Tree tops as regional maxima over the 8-neighbourhood (seed 000).

    A cell is a top when it is higher than all its 8 neighbours and at least ``min_height``.
    Flat tops: a plateau of equal cells whose every outside neighbour is lower counts as one
    maximum, represented by its cell nearest to the plateau's centroid (ties: smallest row, then
    column). Cells on the grid border compare only with neighbours inside the grid (but with
    ``strict``). NaN cells are never tops.

    Parameters
    ----------
    chm : (M, N) ndarray of float
    min_height : float
        Minimum tree height (m), 2 m in seed 000.
    strict : bool
        Castro's literal rule: a top must be strictly higher than all 8 neighbours, so a flat
        top (two or more equal highest cells) gives no top at all, and a cell on the grid's
        border, which lacks neighbours, is no top.

    Returns
    -------
    rows, cols : ndarray of int64

    Examples
    --------
    >>> chm = np.array([[0, 1, 0], [1, 5, 1], [0, 1, 0]], float)
    >>> local_maxima(chm)
    (array([1]), array([1]))
    """
    from skimage.morphology import local_maxima as _lm

    a = _prep(chm)
    if not np.isfinite(a).any():
        return np.empty(0, np.int64), np.empty(0, np.int64)
    if strict:
        fp = np.ones((3, 3), bool)
        fp[1, 1] = False
        nb = ndimage.maximum_filter(a, footprint=fp, mode="constant", cval=-np.inf)
        keep = np.isfinite(a) & (a > nb) & (a >= min_height)
        keep[0, :] = keep[-1, :] = keep[:, 0] = keep[:, -1] = False  # 8 neighbours to beat
        r, c = np.nonzero(keep)
        return r.astype(np.int64), c.astype(np.int64)
    reg = _lm(a, connectivity=2, allow_borders=True)
    reg &= np.isfinite(a) & (a >= min_height)
    return _one_per_component(reg, a)


def treex_maxima(chm, res: float, *, mean_crown_area: float, sd_crown_area: float,
                 min_height: float = 2.0, centred: bool = False, local: bool = False,
                 origin: tuple = (0, 0)):
    """TreeX tree tops (seed 001): a search window moved over the CHM.

    Reading of "a window with dimension equivalent to the mean crown area, moved by the crown-area
    standard deviation": the window is the square whose *area* equals ``mean_crown_area`` (side
    ``round(sqrt(mean_crown_area) / res)`` cells, at least 1), and it moves by the side of the
    square whose area equals ``sd_crown_area`` (``round(sqrt(sd_crown_area) / res)`` cells, at
    least 1). The highest cell of each window position (first in row order on ties) is a tree
    top when it is at least ``min_height``: the seed asks nothing else, so a window cut across a
    crown's flank is won by a flank cell, the source of TreeX's overestimate (about +7 % in the
    seed). Candidates that touch (8-connected) are one top, as one per plateau in
    :func:`local_maxima`.

    Two tests not in the seed are options: ``local=True`` keeps a candidate only when it is a
    local maximum of its 8 neighbours (drops the flank cells, and a tree that loses every window
    to a taller neighbour in its row); ``centred=True`` keeps it only when it is the highest of
    the same-size window centred on it (drops one of two close trees).

    ``origin``: the (row, column) of the grid's upper-left cell counted from the cell where the
    windows start (the area's first cell in a run, as seed 001 moves its window over the image:
    :attr:`lidartrees_gis.als.trees.TreeParams.window_corner`; else the global grid's cell 0);
    the window positions are multiples of the step from there, so that a tile and the whole
    area see the same windows.
    """
    if not (mean_crown_area > 0 and sd_crown_area > 0):
        raise InputError("-mean_crown_area and -sd_crown_area must be > 0 (m²)")
    a = _prep(chm)
    w = max(1, int(round(np.sqrt(mean_crown_area) / res)))
    step = max(1, int(round(np.sqrt(sd_crown_area) / res)))
    H, W = a.shape
    # windows start at global multiples of the step: pad so that the first starts at or before 0
    r_off, c_off = (-int(origin[0])) % step, (-int(origin[1])) % step
    pr, pc = (step - r_off) % step, (step - c_off) % step
    pad = np.pad(a, ((pr, w), (pc, w)), constant_values=-np.inf)
    cand = np.zeros(a.shape, bool)
    from numpy.lib.stride_tricks import sliding_window_view

    view = sliding_window_view(pad, (w, w))
    starts_c = np.arange(0, W + pc, step)
    for r0 in range(0, H + pr, step):
        block = view[r0, starts_c].reshape(-1, w * w)
        k = np.argmax(block, axis=1)
        ok = np.isfinite(block[np.arange(block.shape[0]), k])
        rr = r0 + k // w - pr
        cc = starts_c + k % w - pc
        cand[rr[ok], cc[ok]] = True
    keep = cand & (a >= min_height) & np.isfinite(a)
    for on, size in ((local, 3), (centred, w)):
        if on:
            keep &= a >= ndimage.maximum_filter(a, size=size, mode="constant", cval=-np.inf)
    return _one_per_component(keep, a)


def default_window(h):
    """Default crown window diameter (m) for a height ``h`` (m): 0.1 h + 0.5, within 1-8 m.

    Fitted to the seeds' clonal eucalyptus (about 2.8 m at 23 m, for 3 x 2 m spacing); give your
    own function for other stands.
    """
    return np.clip(0.1 * np.asarray(h, dtype=np.float64) + 0.5, 1.0, 8.0)


def variable_window_maxima(chm, res: float, *, min_height: float = 2.0, window=default_window):
    """Tree tops with a circular window whose diameter (m) is ``window(height)``.

    A cell is a top when it is the highest in the disc of diameter ``window(chm[cell])`` centred
    on it and at least ``min_height``; one top per plateau as in :func:`local_maxima`.
    """
    a = _prep(chm)
    valid = np.isfinite(a) & (a >= min_height)
    if not valid.any():
        return np.empty(0, np.int64), np.empty(0, np.int64)
    radius_cells = np.zeros(a.shape, dtype=np.int64)
    radius_cells[valid] = np.maximum(1, np.round(window(a[valid]) / 2.0 / res)).astype(np.int64)
    keep = np.zeros(a.shape, bool)
    for r in np.unique(radius_cells[valid]):
        yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
        disc = (xx ** 2 + yy ** 2) <= r * r + 1e-9
        mf = ndimage.maximum_filter(a, footprint=disc, mode="constant", cval=-np.inf)
        sel = valid & (radius_cells == r)
        keep |= sel & (a >= mf)
    return _one_per_component(keep, a)


def window_radius(h, res: float, *, crown_scale: float, dominant_height: float,
                  factor: float = 1.0):
    """Search radius in cells of :func:`adaptive_maxima` for heights ``h`` (m):
    ``factor · crown_scale · sqrt(h / dominant_height) / res``, at least one cell."""
    hd = max(float(dominant_height), 1e-6)
    rel = np.sqrt(np.clip(np.asarray(h, np.float64), 0.0, None) / hd)
    return np.maximum(1.0, factor * crown_scale * rel / res)


def adaptive_maxima(chm, res: float, *, crown_scale: float, dominant_height: float,
                    min_height: float = 2.0, factor: float = 1.0, min_separation: float = 0.0,
                    batch: int = 20000):
    """Tree tops with a circular window scaled by the stand's crown size and the tree's height.

    A cell is a top when it is at least ``min_height`` and the highest cell within
    ``r = factor · crown_scale · sqrt(h / dominant_height)`` metres (at least one cell), ``h`` being
    its own height: tall trees, whose crowns are wide, search further than the small trees
    between them, and the whole window follows the crown size measured on the stand
    (:func:`lidartrees_gis.als.chm.crown_scale`) rather than a fixed function of height, so a
    3 x 2 m eucalyptus stand and a conifer forest of the same height both come out right.
    One top per plateau as in :func:`local_maxima`. Tops closer than ``min_separation`` metres to
    a higher top are then dropped, highest first (the two sides of a crown apex that no return
    hit, in sparse data).

    Parameters
    ----------
    chm : (M, N) ndarray of float
    res : float
        Cell size (m).
    crown_scale : float
        Crown scale of the stand (m).
    dominant_height : float
        Dominant height of the stand (m), e.g. the 95th percentile of the canopy heights.
    min_height : float
    factor : float
        Radius in crown scales for a tree of the dominant height.
    min_separation : float
        Smallest distance (m) between two tops; 0 = no limit.
    batch : int
        Candidates tested at once (memory bound).
    """
    a = _prep(chm)
    if not np.isfinite(a).any():
        return np.empty(0, np.int64), np.empty(0, np.int64)
    from skimage.morphology import local_maxima as _lm

    cand = _lm(a, connectivity=2, allow_borders=True) & np.isfinite(a) & (a >= min_height)
    r, c = np.nonzero(cand)
    if r.size == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    rad = window_radius(a[r, c], res, crown_scale=crown_scale, dominant_height=dominant_height,
                        factor=factor)
    rq = np.round(rad * 2.0) / 2.0  # half-cell steps
    kmax = int(np.ceil(rq.max()))
    pad = np.pad(a, kmax, constant_values=-np.inf)
    keep = np.zeros(r.size, bool)
    for rv in np.unique(rq):
        k = int(np.ceil(rv))
        yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
        disc = ((xx ** 2 + yy ** 2) <= rv * rv + 1e-9).ravel()
        dy, dx = yy.ravel()[disc], xx.ravel()[disc]
        idx = np.nonzero(rq == rv)[0]
        for s0 in range(0, idx.size, batch):
            sel = idx[s0:s0 + batch]
            rr = r[sel][:, None] + kmax + dy[None, :]
            cc = c[sel][:, None] + kmax + dx[None, :]
            keep[sel] = a[r[sel], c[sel]] >= pad[rr, cc].max(axis=1)
    mask = np.zeros(a.shape, bool)
    mask[r[keep], c[keep]] = True
    rows, cols = _one_per_component(mask, a)
    if min_separation > 0 and rows.size > 1:
        rows, cols = separate_tops(rows, cols, a[rows, cols], min_separation / res)
    return rows, cols


def separate_tops(rows, cols, heights, distance: float):
    """Drop every top within ``distance`` cells of a higher kept top (greedy, highest first;
    equal heights: the first in row order wins). Returns ``(rows, cols)`` sorted by row, column.
    """
    from scipy.spatial import cKDTree

    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    xy = np.column_stack([rows, cols]).astype(np.float64)
    pairs = cKDTree(xy).query_pairs(distance + 1e-9, output_type="ndarray")
    keep = np.ones(rows.size, bool)
    if pairs.size:
        order = np.lexsort((cols, rows, -np.asarray(heights, np.float64)))
        rank = np.empty(rows.size, np.int64)
        rank[order] = np.arange(rows.size)
        # each pair as (higher-ranked, lower-ranked)
        first_higher = rank[pairs[:, 0]] < rank[pairs[:, 1]]
        hi = np.where(first_higher, pairs[:, 0], pairs[:, 1])
        lo = np.where(first_higher, pairs[:, 1], pairs[:, 0])
        o = np.argsort(rank[hi], kind="stable")
        hi, lo = hi[o], lo[o]
        start = np.searchsorted(rank[hi], rank[order])
        stop = np.searchsorted(rank[hi], rank[order], side="right")
        for k, i in enumerate(order):
            if keep[i] and start[k] < stop[k]:
                keep[lo[start[k]:stop[k]]] = False
    o = np.lexsort((cols[keep], rows[keep]))
    return rows[keep][o], cols[keep][o]
