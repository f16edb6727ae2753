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

from .errors import InputError

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


def local_maxima(chm, *, min_height: float = 2.0):
    """Tree tops as regional maxima over the 8-neighbourhood (seed 000).

    A cell is a top when it is higher than all its 8 neighbours and at least ``min_height``.
    Flat tops: a plateau of equal cells whose every outside neighbour is lower counts as one
    maximum, represented by its cell nearest to the plateau's centroid (ties: smallest row, then
    column). Cells on the grid border compare only with neighbours inside the grid. NaN cells
    are never tops.

    Parameters
    ----------
    chm : (M, N) ndarray of float
    min_height : float
        Minimum tree height (m), 2 m in seed 000.

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
    reg = _lm(a, connectivity=2, allow_borders=True)
    reg &= np.isfinite(a) & (a >= min_height)
    return _one_per_component(reg, a)


def treex_maxima(chm, res: float, *, mean_crown_area: float, sd_crown_area: float,
                 min_height: float = 2.0):
    """TreeX tree tops (seed 001): a search window moved over the CHM.

    Reading of "a window with dimension equivalent to the mean crown area, moved by the crown-area
    standard deviation": the window is the square whose *area* equals ``mean_crown_area`` (side
    ``round(sqrt(mean_crown_area) / res)`` cells, at least 1), and it moves by the side of the
    square whose area equals ``sd_crown_area`` (``round(sqrt(sd_crown_area) / res)`` cells, at
    least 1). The highest cell of each window position is a candidate (first in row order on
    ties); a candidate is kept when it is at least ``min_height`` and also the highest cell of the
    same-size window centred on it (this rejects the slope cells that win windows cut across a
    crown's edge). One top per plateau as in :func:`local_maxima`.
    """
    if not (mean_crown_area > 0 and sd_crown_area > 0):
        raise InputError("-mean_crown_area and -sd_crown_area must be > 0 (m²)")
    a = _prep(chm)
    w = max(1, int(round(np.sqrt(mean_crown_area) / res)))
    step = max(1, int(round(np.sqrt(sd_crown_area) / res)))
    H, W = a.shape
    pad = np.pad(a, ((0, w), (0, w)), constant_values=-np.inf)
    cand = np.zeros(a.shape, bool)
    from numpy.lib.stride_tricks import sliding_window_view

    view = sliding_window_view(pad, (w, w))  # (H+1, W+1, w, w)
    for r0 in range(0, H, step):
        block = view[r0, 0:W:step].reshape(-1, w * w)
        k = np.argmax(block, axis=1)
        ok = np.isfinite(block[np.arange(block.shape[0]), k])
        rr = r0 + k // w
        cc = np.arange(0, W, step) + k % w
        cand[rr[ok], cc[ok]] = True
    centred = ndimage.maximum_filter(a, size=w, mode="constant", cval=-np.inf)
    keep = cand & (a >= centred) & (a >= min_height) & np.isfinite(a)
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
