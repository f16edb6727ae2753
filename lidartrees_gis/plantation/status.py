"""What stands at each empty planting position: missing, a suppressed tree under or beside its
neighbours' crowns, or uncertain (a field check), from the returns near it
(:func:`position_status`, :func:`classify_gaps`), and the counts the stocking and its interval
are made of (:func:`counts`)."""
from __future__ import annotations

import numpy as np

from .positions import own_spacings


#: an empty planting position holds a suppressed tree when at least :data:`SUPPRESSED_SHARE`
#: of the returns within :data:`SUPPRESSED_REACH` x the smaller spacing of it lie at or above
#: :data:`SUPPRESSED_HEIGHT` x the dominant height: a crown stands at the position, under or
#: beside its neighbours' (the ground or a shrub of a missing tree's position does not reach
#: that height)
SUPPRESSED_HEIGHT = 0.3
#: an empty position whose highest return near it reaches this x the dominant height holds a
#: crown at the canopy's height and no top: a neighbour's crown over a missing tree, or a tree
#: whose top merged with a neighbour's; not told apart, it is *uncertain*, not suppressed
#: (independent farm generator: the suppressed calls at missing positions of a closed 3 x 2 m
#: stand stood at 0.86-1.0 of the canopy's height)
OVERLAP_HEIGHT = 0.85
SUPPRESSED_SHARE = 0.5
SUPPRESSED_REACH = 0.25
#: fewer returns than this within the reach: it grows to :data:`SUPPRESSED_WIDE` spacings
SUPPRESSED_MIN_RETURNS = 4
SUPPRESSED_WIDE = 0.4
#: a position is called suppressed or missing only when the share's Wilson interval at this
#: many standard errors lies wholly on one side of :data:`SUPPRESSED_SHARE`; else it is
#: *uncertain* (a field check). The share of a handful of returns is noisy, and a neighbour's
#: crown reaching over a missing tree's position gives the same share as a suppressed tree's
#: (benchmarks/_family.py: the errors of a plain ``share >= 0.5`` were such positions, with
#: 5-13 returns and shares of 0.25-0.6)
UNCERTAIN_Z = 1.0

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
    """What stands at each empty planting position (see :data:`SUPPRESSED_SHARE` and
    :data:`UNCERTAIN_Z`).

    Parameters
    ----------
    gaps_x, gaps_y : (N,) array_like
        Planting positions with no top.
    points : tuple of arrays
        ``(x, y, height above ground)`` of every return near them (all returns: a suppressed
        crown is seen by the pulses that pass the canopy).
    spacing : (float, float)
    dominant_height : float
        The stand's dominant height (m); a suppressed tree reaches at least
        ``SUPPRESSED_HEIGHT`` of it (and ``min_height``).
    smaller : (N,) array_like, optional
        The smaller spacing of each position's own lattice, where stands of other spacings
        share a tile (instead of ``spacing``'s).

    Returns
    -------
    dict
        ``status`` (int8: :data:`MISSING`, :data:`SUPPRESSED` or :data:`UNCERTAIN`),
        ``share`` (the share of the returns near the position at the suppressed height),
        ``returns`` (how many returns the share is of), and ``height, x, y``: the highest
        return near each position whose share reaches :data:`SUPPRESSED_SHARE` (a suppressed
        tree, or an uncertain position that leans to one; NaN and the position for the
        others; a tiled run, whose tiles each fit the lattice, finds the same return).
    """
    from scipy.spatial import cKDTree

    gx, gy = np.asarray(gaps_x, float), np.asarray(gaps_y, float)
    k_hi = np.zeros(gx.size, np.int64)
    n_all = np.zeros(gx.size, np.int64)
    hts = np.full(gx.size, np.nan)
    xs, ys = gx.copy(), gy.copy()
    if gx.size and points is not None and len(points[0]):
        px, py, ph = (np.asarray(a) for a in points)
        thr = max(float(min_height), SUPPRESSED_HEIGHT * float(dominant_height))
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
            d2 = (px[idx] - gx[k]) ** 2 + (py[idx] - gy[k]) ** 2
            close = idx[d2 <= r2[k]]
            use = close if close.size >= SUPPRESSED_MIN_RETURNS else idx
            k_hi[k], n_all[k] = int((ph[use] >= thr).sum()), use.size
            if k_hi[k]:  # the highest return near the position: the same whichever tile's
                top = use[int(np.argmax(ph[use]))]
                hts[k], xs[k], ys[k] = float(ph[top]), px[top], py[top]
    low, high = wilson_interval(k_hi, n_all)
    status = np.where(low >= SUPPRESSED_SHARE, SUPPRESSED,
                      np.where(high < SUPPRESSED_SHARE, MISSING, UNCERTAIN)).astype(np.int8)
    status[n_all == 0] = MISSING  # no return at all: nothing stands there
    # a crown at the canopy's height over the position, and no top: a neighbour's crown
    # reaching over a missing tree looks as a tree there does (a field check)
    over = (status == SUPPRESSED) & (hts >= OVERLAP_HEIGHT * float(dominant_height))
    status[over] = UNCERTAIN
    share = np.where(n_all > 0, k_hi / np.maximum(n_all, 1), 0.0)
    tree = (status == SUPPRESSED) | ((status == UNCERTAIN) & (share >= SUPPRESSED_SHARE))
    hts[~tree] = np.nan
    xs[~tree], ys[~tree] = gx[~tree], gy[~tree]
    return {"status": status, "share": share, "returns": n_all, "height": hts, "x": xs, "y": ys}


def classify_gaps(st: dict, points, spacing, dominant_height: float,
                  min_height: float = 2.0) -> dict:
    """:func:`~lidartrees_gis.plantation.stocking.stocking`'s (or :func:`~lidartrees_gis.plantation.positions.stocking_by_stand`'s) result with each empty position
    classified (:func:`position_status`: the ``gaps`` table's ``status, share, returns``,
    and ``height, tree_x, tree_y`` of the trees that stand there, NaN at the others):
    ``missing`` counts only the missing
    ones, ``suppressed`` and ``uncertain`` the others, per zone too; ``uncertain_stocked`` is
    the sum of the uncertain positions' shares, and ``stocking_pct`` counts the suppressed
    trees as stocking their positions and each uncertain position by its share."""
    gaps = st["gaps"]
    smaller = own_spacings({**st, "spacing": spacing}, gaps.zone)  # each stand's own
    c = position_status(gaps.x, gaps.y, points, spacing, dominant_height, min_height,
                        smaller=smaller)
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
    its share, each missing or suppressed one a Bernoulli of the chance that its call is wrong,
    :func:`stocked_probability`); ``resolved_var``: that variance over the missing and
    suppressed ones alone, the spread of the calls the stocking's interval adds to its
    unresolved positions (:func:`~lidartrees_gis.plantation.stockreport.stocking_fields`)."""
    status = np.asarray(status)
    share = np.asarray(share, float)
    unc = status == UNCERTAIN
    if returns is None:
        returns = np.zeros(status.size)
    n = np.asarray(returns, float)
    p = np.where(unc, share, stocked_probability(np.round(share * n), n))
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
