"""Crowns: region growing (Hyyppä/Castro, seed 000 Annex 2), TreeX priority growing (seed 001),
Vincent–Soille watershed (seed 000 Annex 1) and a marker-controlled watershed.

Every function returns an int64 label image (0 = no crown). Crowns grown from tops carry the
index (1-based) of their top in the given ``rows, cols`` order. The loops are plain Python
compiled by numba when it is installed (the same code runs uncompiled otherwise, slowly).
"""
from __future__ import annotations

import heapq

import numpy as np

from .._accel import HAVE_NUMBA, numba
from ..errors import InputError


def _jit(fn):
    # nogil: a process's worker threads grow crowns at the same time
    return numba.njit(cache=True, nogil=True)(fn) if HAVE_NUMBA else fn


def _prepare(chm, rows, cols):
    """CHM with NaN as -inf, an empty label grid, and the seed cells as int64 arrays."""
    a = np.where(np.isnan(chm), -np.inf, np.asarray(chm, dtype=np.float64))
    rows = np.asarray(rows, np.int64).ravel()
    cols = np.asarray(cols, np.int64).ravel()
    if rows.shape != cols.shape:
        raise InputError(f"tree tops: {rows.size} rows but {cols.size} columns")
    # the compiled kernels index without bounds checks: every seed must be a cell of the CHM
    bad = (rows < 0) | (rows >= a.shape[0]) | (cols < 0) | (cols >= a.shape[1])
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"tree tops: {int(bad.sum())} top(s) outside the {a.shape[0]} x "
                         f"{a.shape[1]} CHM (first: row {rows[k]}, column {cols[k]})")
    return a, np.zeros(a.shape, np.int64), rows, cols


# ---------------------------------------------------------------------------------------------
# Seed 000, Annex 2: region growing after Hyyppä et al. (2001)
def _rg_pass(v, top, step):
    """The first pass that can label a cell of height ``v``: the smallest ``k >= 1`` with
    ``top - k * step < v`` (computed as the passes compute their thresholds)."""
    k = max(1, int(np.floor((top - v) / step)) + 1)
    while k > 1 and top - (k - 1) * step < v:
        k -= 1
    while top - k * step >= v:
        k += 1
    return k


_rg_pass_c = _jit(_rg_pass)


def _rg_kernel(chm, seeds_r, seeds_c, top, hmin, step, labels, q, nxt, buf):
    """Annex 2's passes over a FIFO queue, visiting in each pass only the queued cells that can
    act in it. Pass ``k`` has the threshold ``top - k step``. A queued cell acts in a pass when
    an unlabelled 4-neighbour is higher than the pass's threshold; after its visit its
    unlabelled neighbours are all at or below it, so it waits in the bucket of the pass that
    first goes below the highest of them (a neighbour labelled meanwhile only makes that visit
    idle). The cells of a pass are visited in queue order and the cells labelled in it join the
    end of the queue, as in Annex 2, so the labels are those of visiting every queued cell in
    every pass. ``q`` (the flat cell of each queue position), ``nxt`` (the waiting positions of
    a pass, as linked lists) and ``buf`` are work arrays of ``H W + n + 1`` integers (int32
    where that fits: half the memory traffic of the visits)."""
    H, W = chm.shape
    n = seeds_r.shape[0]
    lab = labels.ravel()
    z = chm.ravel()
    last = 0  # the last pass: the lowest threshold above hmin
    while top - (last + 1) * step > hmin:
        last += 1
    for i in range(n):  # every seed is visited in the first pass (any order: sorted there)
        cell = seeds_r[i] * W + seeds_c[i]
        lab[cell] = i + 1
        q[i] = cell
        nxt[i] = i - 1
    tail = n
    if last < 1:
        return labels
    head = np.full(last + 1, -1, np.int64)
    head[1] = n - 1
    for k in range(1, last + 1):
        thr = top - k * step
        cnt = 0
        p = head[k]
        while p >= 0:
            buf[cnt] = p
            cnt += 1
            p = nxt[p]
        head[k] = -1
        if cnt > 1:
            buf[:cnt] = np.sort(buf[:cnt])
        start = tail
        j = 0
        while True:
            if j < cnt:
                p = buf[j]
            elif start + (j - cnt) < tail:  # cells labelled in this pass, in queue order
                p = start + (j - cnt)
            else:
                break
            j += 1
            cell = q[p]
            r = cell // W
            c = cell - r * W
            lb = lab[cell]
            wake = -np.inf
            for d in range(4):  # up, down, left, right
                if d == 0:
                    if r == 0:
                        continue
                    nb = cell - W
                elif d == 1:
                    if r == H - 1:
                        continue
                    nb = cell + W
                elif d == 2:
                    if c == 0:
                        continue
                    nb = cell - 1
                else:
                    if c == W - 1:
                        continue
                    nb = cell + 1
                if lab[nb] != 0:
                    continue
                v = z[nb]
                if v > thr:
                    lab[nb] = lb
                    q[tail] = nb
                    tail += 1
                elif v > wake:
                    wake = v
            if wake > hmin:  # can still be labelled, by a later pass
                w = _rg_pass_c(wake, top, step)
                if w <= last:
                    nxt[p] = head[w]
                    head[w] = p
    return labels


_rg_nb = _jit(_rg_kernel)


def region_growing(chm, rows, cols, *, step: float = 0.1, min_height: float = 2.0, top=None):
    """Seeded region growing of seed 000 (Annex 2, after Hyyppä et al. 2001).

    A FIFO queue starts with the seeds (in the given order). A threshold starts at the highest
    height ``top`` minus ``step`` and falls by ``step`` after each pass while it is above
    ``min_height``: the thresholds are ``top - k step`` (Annex 2's ``altura_max - ajuste``,
    ``altura_max`` the highest value of the grid). In a pass every queued cell gives its label
    to its unlabelled 4-neighbours higher than the threshold, which join the end of the queue
    (and are visited in the same pass); a cell with no unlabelled neighbour that could still be
    labelled leaves the queue. A small step (0.1 m) gives round crowns, a large one (2 m) ragged
    crowns.

    Parameters
    ----------
    chm : (M, N) ndarray of float
        Usually the smoothed CHM; NaN cells are never labelled.
    rows, cols : ndarray of int
        Seed cells (tree tops); seed ``i`` gives label ``i + 1``.
    step : float
        ``ajuste`` of Annex 2 (m).
    min_height : float
        Lowest height a crown may reach (m).
    top : float, optional
        ``altura_max`` (m): default the highest value of ``chm``; the tiles of an area take the
        area's, so that a tile and the whole area grow the same crowns.
    """
    if not step > 0:
        raise InputError(f"-step must be > 0, got {step}")
    a, labels, rows, cols = _prepare(chm, rows, cols)
    if rows.size == 0:
        return labels
    hmax = float(np.max(a[np.isfinite(a)])) if top is None else float(top)
    passes = (hmax - float(min_height)) / step
    if passes > 20_000:  # each pass scans the crowns' borders: bound the work
        raise InputError(f"-step: {step:g} m from the highest cell ({hmax:.1f} m) down to "
                         f"{min_height:g} m is {passes:.3g} passes (limit 20,000); use a step of "
                         f"at least {(hmax - min_height) / 20_000:.3g} m (seed 000: 0.1 m), or check "
                         "the heights (a CHM in centimetres?)")
    fn = _rg_nb if HAVE_NUMBA else _rg_kernel
    cap = a.size + rows.size + 1
    it = np.int32 if cap < 2 ** 31 - 1 else np.int64
    work = (np.empty(cap, it), np.empty(cap, it), np.empty(cap, it))
    return fn(a, rows, cols, hmax, float(min_height), float(step), labels, *work)


# ---------------------------------------------------------------------------------------------
# Seed 001: TreeX priority region growing
def _treex_kernel(chm, seeds_r, seeds_c, max_cells, min_crown_height, conn8, labels):
    H, W = chm.shape
    n = seeds_r.shape[0]
    size = np.zeros(n + 1, np.int64)
    heap = [(0.0, np.int64(0), np.int64(0), np.int64(0), np.int64(0))]
    heap.pop()
    counter = 0
    nk = 8 if conn8 else 4
    dr = np.array([-1, 1, 0, 0, -1, -1, 1, 1])
    dc = np.array([0, 0, -1, 1, -1, 1, -1, 1])
    for i in range(n):
        labels[seeds_r[i], seeds_c[i]] = i + 1
        size[i + 1] = 1
    for i in range(n):
        r = seeds_r[i]
        c = seeds_c[i]
        for k in range(nk):
            rr = r + dr[k]
            cc = c + dc[k]
            if 0 <= rr < H and 0 <= cc < W and labels[rr, cc] == 0 and chm[rr, cc] >= min_crown_height:
                heapq.heappush(heap, (-chm[rr, cc], np.int64(counter), rr, cc, np.int64(i + 1)))
                counter += 1
    while len(heap) > 0:
        item = heapq.heappop(heap)
        r = item[2]
        c = item[3]
        lab = item[4]
        if labels[r, c] != 0 or size[lab] >= max_cells:
            continue
        labels[r, c] = lab
        size[lab] += 1
        for k in range(nk):
            rr = r + dr[k]
            cc = c + dc[k]
            if 0 <= rr < H and 0 <= cc < W and labels[rr, cc] == 0 and chm[rr, cc] >= min_crown_height:
                heapq.heappush(heap, (-chm[rr, cc], np.int64(counter), rr, cc, lab))
                counter += 1
    return labels


_treex_nb = _jit(_treex_kernel)


def treex_growing(chm, rows, cols, res: float, *, max_crown_area: float = 15.0,
                  min_crown_height: float = 2.0, connectivity: int = 4):
    """TreeX priority region growing (seed 001).

    Neighbours of the growing crowns join in decreasing order of height (a priority queue; ties in
    order of arrival). A cell joins the first crown that reaches it, so growth stops where a crown
    meets its neighbour; a crown stops at ``max_crown_area`` (m², converted to cells) and never
    takes cells lower than ``min_crown_height`` (gaps with shrubs between trees).

    Parameters
    ----------
    connectivity : {4, 8}
        Neighbourhood of growth (the authors suggest trying 4).
    """
    if connectivity not in (4, 8):
        raise InputError(f"-connectivity must be 4 or 8, got {connectivity}")
    if not max_crown_area > 0:
        raise InputError(f"-max_crown_area must be > 0 m², got {max_crown_area}")
    a, labels, rows, cols = _prepare(chm, rows, cols)
    if rows.size == 0:
        return labels
    max_cells = max(1, int(round(max_crown_area / (res * res))))
    fn = _treex_nb if HAVE_NUMBA else _treex_kernel
    return fn(a, rows, cols, max_cells, float(min_crown_height), connectivity == 8, labels)


# ---------------------------------------------------------------------------------------------
# Seed 000, Annex 1: Vincent & Soille (1991) immersion watershed
def _fifo_push_py(fifo, tail, cap, value):
    """Put ``value`` at the end of the circular FIFO; returns the new tail."""
    fifo[tail] = value
    return (tail + 1) % cap


_fifo_push = _jit(_fifo_push_py)


# One function on purpose (108 lines): the numba kernel of the immersion, whose FIFO and label
# arrays are local; split, its per-pixel loop would pass them on every call.
def _vs_kernel(levels, valid):
    MASK, WSHED, INIT = -2, 0, -1
    H, W = levels.shape
    N = H * W
    flat = levels.ravel()
    vflat = valid.ravel()
    order = np.argsort(flat, kind="mergesort")
    lab = np.full(N, INIT, np.int64)
    dist = np.zeros(N, np.int64)
    fifo = np.empty(N + 2, np.int64)
    cap = N + 2
    head = 0
    tail = 0
    count = 0
    FICT = -3
    current = 0
    dr = np.array([-1, -1, -1, 0, 0, 1, 1, 1])
    dc = np.array([-1, 0, 1, -1, 1, -1, 0, 1])
    i = 0
    # skip invalid cells (sorted last because their level is the largest)
    nvalid = 0
    for k in range(N):
        if vflat[k]:
            nvalid += 1
    while i < nvalid:
        h = flat[order[i]]
        j = i
        while j < nvalid and flat[order[j]] == h:
            j += 1
        for t in range(i, j):
            p = order[t]
            lab[p] = MASK
            pr = p // W
            pc = p % W
            for k in range(8):
                rr = pr + dr[k]
                cc = pc + dc[k]
                if 0 <= rr < H and 0 <= cc < W:
                    q = rr * W + cc
                    if lab[q] > 0 or lab[q] == WSHED:
                        dist[p] = 1
                        tail = _fifo_push(fifo, tail, cap, p)
                        count += 1
                        break
        curdist = 1
        tail = _fifo_push(fifo, tail, cap, FICT)
        count += 1
        while True:
            p = fifo[head]
            head = (head + 1) % cap
            count -= 1
            if p == FICT:
                if count == 0:
                    break
                tail = _fifo_push(fifo, tail, cap, FICT)
                count += 1
                curdist += 1
                p = fifo[head]
                head = (head + 1) % cap
                count -= 1
            pr = p // W
            pc = p % W
            for k in range(8):
                rr = pr + dr[k]
                cc = pc + dc[k]
                if not (0 <= rr < H and 0 <= cc < W):
                    continue
                q = rr * W + cc
                if dist[q] < curdist and (lab[q] > 0 or lab[q] == WSHED):
                    if lab[q] > 0:
                        if lab[p] == MASK or lab[p] == WSHED:
                            lab[p] = lab[q]
                        elif lab[p] != lab[q]:
                            lab[p] = WSHED
                    elif lab[p] == MASK:
                        lab[p] = WSHED
                elif lab[q] == MASK and dist[q] == 0:
                    dist[q] = curdist + 1
                    tail = _fifo_push(fifo, tail, cap, q)
                    count += 1
        for t in range(i, j):
            p = order[t]
            dist[p] = 0
            if lab[p] == MASK:
                current += 1
                tail = _fifo_push(fifo, tail, cap, p)
                count += 1
                lab[p] = current
                while count > 0:
                    q = fifo[head]
                    head = (head + 1) % cap
                    count -= 1
                    qr = q // W
                    qc = q % W
                    for k in range(8):
                        rr = qr + dr[k]
                        cc = qc + dc[k]
                        if 0 <= rr < H and 0 <= cc < W:
                            s = rr * W + cc
                            if lab[s] == MASK:
                                tail = _fifo_push(fifo, tail, cap, s)
                                count += 1
                                lab[s] = current
        i = j
    for k in range(N):
        if lab[k] < 0:
            lab[k] = 0
    return lab.reshape(H, W)


_vs_nb = _jit(_vs_kernel)


def rank_levels(chm):
    """Seed 000's inversion: heights sorted in decreasing order and replaced by integer ranks
    1, 2, ... (equal heights share a rank), so the highest cell is level 1. NaN cells get the
    largest level + 1 and are marked invalid. Returns ``(levels, valid)``."""
    a = np.asarray(chm, dtype=np.float64)
    valid = ~np.isnan(a)
    levels = np.zeros(a.shape, np.int64)
    if valid.any():
        u, inv = np.unique(-a[valid], return_inverse=True)
        levels[valid] = inv.ravel() + 1
        levels[~valid] = u.size + 1
    return levels, valid


def vincent_soille(chm):
    """Vincent & Soille (1991) immersion watershed of the *inverted* CHM (seed 000, Annex 1).

    The CHM is inverted by ranking (:func:`rank_levels`) so crowns become basins; flooding uses
    the 8-neighbourhood and a FIFO queue. Returns basin labels 1..n with watershed lines 0
    (WSHED); NaN cells get 0.
    """
    levels, valid = rank_levels(chm)
    fn = _vs_nb if HAVE_NUMBA else _vs_kernel
    return fn(levels, valid)


def marker_watershed(chm, rows, cols, *, min_height: float = 2.0):
    """Marker-controlled watershed of the inverted CHM from the tree tops, restricted to
    CHM >= ``min_height`` (scikit-image, 8-connectivity); top ``i`` gives label ``i + 1``."""
    from skimage.segmentation import watershed

    a = np.asarray(chm, dtype=np.float64)
    markers = np.zeros(a.shape, np.int64)
    markers[np.asarray(rows, np.int64), np.asarray(cols, np.int64)] = np.arange(1, len(rows) + 1)
    mask = np.isfinite(a) & (a >= min_height)
    mask[markers > 0] = True
    return watershed(-np.where(np.isnan(a), -np.inf, a), markers=markers, mask=mask, connectivity=2)


def keep_top_components(labels, rows, cols):
    """Keep, for crown ``i + 1``, only the 4-connected part holding its top (``rows[i], cols[i]``);
    everything else becomes 0. Makes every crown one polygon that contains its top."""
    from skimage.measure import label as cc_label

    comp = cc_label(labels, connectivity=1, background=0)
    good = np.zeros(comp.max() + 1, bool)
    tops = comp[np.asarray(rows, np.int64), np.asarray(cols, np.int64)]
    good[tops[tops > 0]] = True
    good[0] = False
    return np.where(good[comp], labels, 0)
