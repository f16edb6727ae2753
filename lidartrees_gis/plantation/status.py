"""What stands at each empty planting position: missing, a suppressed tree under or beside its
neighbours' crowns, or uncertain (a field check), from the returns near it
(:func:`position_status`, :func:`classify_gaps`), and the counts the stocking and its interval
are made of (:func:`counts`)."""
from __future__ import annotations

import numpy as np

from .positions import own_spacings


#: returns at or above :data:`SUPPRESSED_HEIGHT` x the canopy's height over a position
#: (:func:`canopy_over`) are a crown's (the ground or a shrub of a missing tree's position does
#: not reach that height)
SUPPRESSED_HEIGHT = 0.3
#: the returns within :data:`SUPPRESSED_REACH` x the smaller spacing of an empty position tell
#: what stands there; the share of them at a crown's height is read within
#: :data:`SUPPRESSED_WIDE` spacings when fewer than :data:`SUPPRESSED_MIN_RETURNS` lie that close
SUPPRESSED_REACH = 0.25
SUPPRESSED_MIN_RETURNS = 4
SUPPRESSED_WIDE = 0.4
#: an empty position whose highest return that close reaches this x the canopy's height holds
#: a crown at the canopy's height and no top: a neighbour's crown over a missing tree, or a tree
#: whose top merged with a neighbour's; not told apart, it is *uncertain*
OVERLAP_HEIGHT = 0.85
#: under it, a position with a crown return that close is called suppressed only when the
#: Wilson interval (at :data:`UNCERTAIN_Z` standard errors) of the share of its close returns
#: at a crown's height lies wholly above :data:`SUPPRESSED_SHARE`; else it is *uncertain* (a
#: field check: a small suppressed crown lets most pulses through to the ground, and a
#: neighbour's crown flank reaching over a missing tree's position gives a share as low; on the
#: three stand families 19-99 % of such positions held a tree), never missing
SUPPRESSED_SHARE = 0.5
UNCERTAIN_Z = 1.0
#: an empty position with no crown return that close is missing when at least this many returns
#: lie that close (the ground seen there), or when none of at least :data:`WIDE_MIN_RETURNS`
#: within :data:`SUPPRESSED_WIDE` spacings is at a crown's height; with fewer returns it is
#: uncertain (a data void: a tree stood at 50-89 % of such positions on the three families)
MISSING_MIN_RETURNS = 2
WIDE_MIN_RETURNS = 3

MISSING, SUPPRESSED, UNCERTAIN = 0, 1, 2
#: the gaps layer's ``status`` of each code
STATUS_NAMES = ("missing", "suppressed", "uncertain")


def wilson_interval(k, n, z: float = UNCERTAIN_Z):
    """The Wilson score interval ``(low, high)`` of the share ``k / n`` at ``z`` standard
    errors (``n`` = 0 gives ``(0, 1)``)."""
    k, n = np.asarray(k, float), np.asarray(n, float)
    m = np.maximum(n, 1.0)
    p = k / m
    den = 1.0 + z * z / m
    centre = (p + z * z / (2 * m)) / den
    half = z * np.sqrt(p * (1 - p) / m + z * z / (4 * m * m)) / den
    empty = n <= 0
    return np.where(empty, 0.0, centre - half), np.where(empty, 1.0, centre + half)


def position_status(gaps_x, gaps_y, points, spacing, dominant_height: float,
                    min_height: float = 2.0, *, smaller=None) -> dict:
    """What stands at each empty planting position, from its returns within a quarter of the
    smaller spacing: crown returns there under :data:`OVERLAP_HEIGHT` x the canopy's height
    are a suppressed tree when most of those returns are a crown's (:data:`SUPPRESSED_SHARE`,
    :data:`UNCERTAIN_Z`); no crown return among enough of them (:data:`MISSING_MIN_RETURNS`,
    :data:`WIDE_MIN_RETURNS`) is a missing tree; anything else is *uncertain*, a field check.

    Parameters
    ----------
    gaps_x, gaps_y : (N,) array_like
        Planting positions with no top.
    points : tuple of arrays
        ``(x, y, height above ground)`` of every return near them (all returns: a suppressed
        crown is seen by the pulses that pass the canopy).
    spacing : (float, float)
    dominant_height : float or (N,) array_like
        The canopy's height over each position (m): the stand's dominant height, or the
        median of its neighbours' tops (:func:`canopy_over`); a suppressed tree reaches at
        least ``SUPPRESSED_HEIGHT`` of it (and ``min_height``).
    smaller : (N,) array_like, optional
        The smaller spacing of each position's own lattice, where stands of other spacings
        share a tile (instead of ``spacing``'s).

    Returns
    -------
    dict
        ``status`` (int8: :data:`MISSING`, :data:`SUPPRESSED` or :data:`UNCERTAIN`),
        ``share`` (the share of the returns near the position at the suppressed height),
        ``returns`` (how many returns the share is of), and ``height, x, y``: the highest
        crown return near each suppressed tree, or uncertain position whose share reaches
        :data:`SUPPRESSED_SHARE` (that leans to one; NaN and the position for the others; a
        tiled run, whose tiles each fit the lattice, finds the same return).
    """
    from scipy.spatial import cKDTree

    gx, gy = np.asarray(gaps_x, float), np.asarray(gaps_y, float)
    k_hi = np.zeros(gx.size, np.int64)
    n_all = np.zeros(gx.size, np.int64)
    # within the quarter spacing: all returns, those at a crown's height, the highest; within
    # the wide reach: all returns and those at a crown's height
    n_close = np.zeros(gx.size, np.int64)
    k_close = np.zeros(gx.size, np.int64)
    top_close = np.zeros(gx.size)
    n_wide = np.zeros(gx.size, np.int64)
    k_wide = np.zeros(gx.size, np.int64)
    hts = np.full(gx.size, np.nan)
    xs, ys = gx.copy(), gy.copy()
    h_dom = np.broadcast_to(np.asarray(dominant_height, float), gx.shape)
    if gx.size and points is not None and len(points[0]):
        px, py, ph = (np.asarray(a) for a in points)
        thrs = np.maximum(float(min_height), SUPPRESSED_HEIGHT * h_dom)
        # only the points near a position matter: the tree of a tile's points is built once
        tree = cKDTree(np.c_[px, py])
        small = np.full(gx.size, float(min(spacing))) if smaller is None else \
            np.broadcast_to(np.asarray(smaller, float), gx.shape)
        near = tree.query_ball_point(np.c_[gx, gy], SUPPRESSED_WIDE * small)
        r2 = (SUPPRESSED_REACH * small) ** 2
        for k, idx in enumerate(near):
            if not idx:
                continue
            idx = np.asarray(idx)
            thr = thrs[k]
            d2 = (px[idx] - gx[k]) ** 2 + (py[idx] - gy[k]) ** 2
            close = idx[d2 <= r2[k]]
            high = ph[idx] >= thr
            n_wide[k], k_wide[k] = idx.size, int(high.sum())
            n_close[k] = close.size
            k_close[k] = int((ph[close] >= thr).sum())
            if close.size:
                top_close[k] = float(ph[close].max())
            use = close if close.size >= SUPPRESSED_MIN_RETURNS else idx
            k_hi[k], n_all[k] = int((ph[use] >= thr).sum()), use.size
            pick = close if k_close[k] else use
            if k_hi[k]:  # the highest return near the position: the same whichever tile's
                top = pick[int(np.argmax(ph[pick]))]
                hts[k], xs[k], ys[k] = float(ph[top]), px[top], py[top]
    low, _ = wilson_interval(k_close, n_close)
    crown = k_close > 0
    status = np.full(gx.size, UNCERTAIN, np.int8)
    under = crown & (top_close < OVERLAP_HEIGHT * h_dom)
    status[under & (low >= SUPPRESSED_SHARE)] = SUPPRESSED
    # (a crown at the canopy's height over the position, and no top: uncertain)
    seen = ~crown & ((n_close >= MISSING_MIN_RETURNS)
                     | ((k_wide == 0) & (n_wide >= WIDE_MIN_RETURNS)))
    status[seen] = MISSING
    share = np.where(n_all > 0, k_hi / np.maximum(n_all, 1), 0.0)
    tree = (status == SUPPRESSED) | ((status == UNCERTAIN) & (share >= SUPPRESSED_SHARE))
    hts[~tree] = np.nan
    xs[~tree], ys[~tree] = gx[~tree], gy[~tree]
    return {"status": status, "share": share, "returns": n_all, "height": hts, "x": xs, "y": ys}


#: the tops within this x the larger spacing of an empty position are its neighbours'
NEIGHBOUR_REACH = 1.5
#: at least this many of them give the canopy's height over it (else the dominant height)
NEIGHBOUR_MIN = 3
#: the nearest tops :func:`canopy_over` reads at once (a position with more within reach is
#: read again in full)
NEIGHBOUR_K = 32


def canopy_over(x, y, tops, spacing, dominant_height: float, larger=None) -> np.ndarray:
    """The canopy's height over each position: the median height of the tops within
    :data:`NEIGHBOUR_REACH` x the larger spacing of it (its neighbours at the adjacent
    positions) when there are :data:`NEIGHBOUR_MIN` or more, else ``dominant_height``. A
    suppressed tree is under its own neighbours, and a neighbour's crown reaching over the
    position stands at its own height (their median: a tall neighbour does not lift it over
    the others' crowns): an area's one dominant height misreads a young stand beside an older
    one.

    ``tops``: ``(x, y, height)``; ``larger``: each position's own larger spacing (default
    ``max(spacing)``)."""
    from scipy.spatial import cKDTree

    x, y = np.asarray(x, float), np.asarray(y, float)
    out = np.full(x.size, float(dominant_height))
    if tops is None or not x.size or not len(tops[0]):
        return out
    tx, ty, th = (np.asarray(a, float) for a in tops)
    reach = NEIGHBOUR_REACH * (np.full(x.size, float(max(spacing))) if larger is None else
                               np.broadcast_to(np.asarray(larger, float), x.shape))
    tree = cKDTree(np.c_[tx, ty])
    k = min(NEIGHBOUR_K, tx.size)  # the nearest tops at once; a fuller neighbourhood below
    d, idx = tree.query(np.c_[x, y], k=k, distance_upper_bound=float(reach.max()) * 1.000001)
    d, idx = d.reshape(x.size, k), idx.reshape(x.size, k)
    inside = d <= reach[:, None]
    h = np.where(inside, th[np.minimum(idx, tx.size - 1)], np.nan)
    n = inside.sum(axis=1)
    some = n >= NEIGHBOUR_MIN
    out[some] = np.nanmedian(h[some], axis=1)
    for j in np.nonzero(n == k)[0] if k < tx.size else ():  # more tops than k that near
        near = tree.query_ball_point([x[j], y[j]], reach[j])
        out[j] = float(np.median(th[near]))
    return out


def classify_gaps(st: dict, points, spacing, dominant_height: float,
                  min_height: float = 2.0, *, tops=None) -> dict:
    """:func:`~lidartrees_gis.plantation.stocking.stocking`'s (or :func:`~lidartrees_gis.plantation.positions.stocking_by_stand`'s) result with each empty position
    classified (:func:`position_status`: the ``gaps`` table's ``status, share, returns``,
    and ``height, tree_x, tree_y`` of the trees that stand there, NaN at the others):
    ``missing`` counts only the missing
    ones, ``suppressed`` and ``uncertain`` the others, per zone too; ``uncertain_stocked`` is
    the sum of the uncertain positions' shares, and ``stocking_pct`` counts the suppressed
    trees as stocking their positions and each uncertain position by its share. ``tops``:
    ``(x, y, height)`` of the trees found, whose heights around each position are the canopy's
    there (:func:`canopy_over`; without, ``dominant_height`` everywhere)."""
    gaps = st["gaps"]
    smaller = own_spacings({**st, "spacing": spacing}, gaps.zone)  # each stand's own
    over = canopy_over(gaps.x, gaps.y, tops, spacing, dominant_height,
                       larger=own_spacings({**st, "spacing": spacing}, gaps.zone, larger=True))
    c = position_status(gaps.x, gaps.y, points, spacing, over, min_height, smaller=smaller)
    st = dict(st)
    # the row's positions along the data's edge (``edge_cut``), and below
    # those just beyond the rows' ends with nothing there
    st["edge_unresolved"] = st.get("edge_cut", 0)
    if "zones" in st:
        st["zones"] = {k: {**z, "edge_unresolved": z.get("edge_cut", 0)}
                       for k, z in st["zones"].items()}
    gaps = gaps.with_columns(status=c["status"], share=c["share"], returns=c["returns"],
                             height=c["height"], tree_x=c["x"], tree_y=c["y"])
    # a position just beyond a row's first or last tree (see :func:`~lidartrees_gis.plantation.positions.row_spans`) is one only
    # where a tree stands: with nothing there, the row ends before it
    drop = gaps.column("edge", False) & (gaps.status == MISSING)
    if drop.any():
        gz = gaps.column("zone", -1)
        gaps = gaps.take(~drop)
        n = int(drop.sum())
        st["expected"], st["missing"] = st["expected"] - n, st["missing"] - n
        st["edge_unresolved"] += n
        if "zones" in st:  # (their missing counts are counted again below)
            st["zones"] = {k: {**z, "expected": z["expected"] - int((drop & (gz == k)).sum()),
                               "edge_unresolved": z["edge_unresolved"]
                               + int((drop & (gz == k)).sum())}
                           for k, z in st["zones"].items()}
    st["gaps"] = gaps
    status, share = gaps.status, gaps.share
    total = int(st["missing"])
    st.update(counts(status, share, gaps.returns))
    if total != status.size:
        raise ValueError(f"{total} missing positions but {status.size} gaps")
    e = st["expected"]
    st["stocking_pct"] = (100.0 * (st["stocked"] + st["suppressed"] + st["uncertain_stocked"])
                          / e if e else float("nan"))
    if "zones" in st:
        gz = gaps.column("zone", -1)
        st["zones"] = {k: {**z, **counts(status[gz == k], share[gz == k],
                                          gaps.returns[gz == k])}
                       for k, z in st["zones"].items()}
    return st


def stocked_probability(k, n):
    """The chance that the crown-return share behind ``k`` of ``n`` returns is at least
    :data:`SUPPRESSED_SHARE` (a tree stands there): the Jeffreys posterior Beta(k + 1/2,
    n - k + 1/2) above the threshold; 0 with no return."""
    from scipy.special import betainc

    k, n = np.asarray(k, float), np.asarray(n, float)
    p = 1.0 - betainc(k + 0.5, np.maximum(n - k, 0.0) + 0.5, SUPPRESSED_SHARE)
    return np.where(n > 0, p, 0.0)


def counts(status, share, returns=None) -> dict:
    """The empty positions' counts by status: ``missing, suppressed, uncertain``,
    ``missing_crowned`` (the missing calls with a return at crown height near them: a small
    tree under its neighbours' crowns is not ruled out there),
    ``uncertain_stocked`` (the uncertain positions' shares summed) and ``stocked_var``: the
    variance of the number of stocked positions among them (each uncertain one a Bernoulli of
    its share, each missing or suppressed one a Bernoulli of the chance that its call is wrong:
    that a share of no crown return among its ``returns`` is :data:`SUPPRESSED_SHARE` or more,
    :func:`stocked_probability`); ``resolved_var``: that variance over the missing and
    suppressed ones alone, the spread of the calls the stocking's interval adds to its
    unresolved positions (:func:`~lidartrees_gis.plantation.stockreport.stocking_fields`)."""
    status = np.asarray(status)
    share = np.asarray(share, float)
    unc = status == UNCERTAIN
    if returns is None:
        returns = np.zeros(status.size)
    n = np.asarray(returns, float)
    wrong = stocked_probability(np.zeros_like(n), n)  # a call on n returns, either way
    p = np.where(unc, share, np.where(status == SUPPRESSED, 1.0 - wrong, wrong))
    # each term on a binary grid (2^-30): every partial sum is then exact, and a stand's
    # figures summed over its tiles in any order are those of one run
    q = np.round(share * EXACT) / EXACT
    v = np.round(p * (1.0 - p) * EXACT) / EXACT
    return {"missing": int((status == MISSING).sum()),
            "missing_crowned": int(((status == MISSING) & (share > 0)).sum()),
            "suppressed": int((status == SUPPRESSED).sum()), "uncertain": int(unc.sum()),
            "uncertain_stocked": float(q[unc].sum()),
            "stocked_var": float(v.sum()),
            "resolved_var": float(v[~unc].sum())}


#: :func:`counts` rounds each position's share and variance to multiples of 1 / EXACT
EXACT = float(2 ** 30)
