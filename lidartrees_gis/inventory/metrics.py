"""The standard height metrics of a group of returns, for many groups at once.

:func:`group_metrics` computes, for every group (a cell, a plot, a stand), the metric set of
lidR's ``.stdmetrics_z`` (``stdmetrics_z(Z, dz = 1, th = 2, zmin = 0)``, lidR 4.x,
``R/metrics_stdmetrics.R``) with lidR's own definitions, plus FUSION's L-moments of the heights
and its canopy cover. One sort of the returns by group then height, and sums over runs
(``np.add.reduceat``): no Python loop over groups.

Definitions (``z`` the heights of a group's returns, ``n`` their number):

* ``zmax``, ``zmean``; ``zsd`` the sample standard deviation (``n - 1``; NaN for one return);
* ``zskew = (Σd³/n) / (Σd²/n)^1.5`` and ``zkurt = n Σd⁴ / (Σd²)²`` with ``d = z - zmean``
  (lidR's moment estimators, not bias-corrected; NaN when every return has one height);
* ``zentropy``: Shannon entropy of the heights in 1 m bins from 0 to ``ceiling(zmax)``,
  normalised by ``log(bins)``; a return exactly at ``ceiling(zmax)`` falls in no bin (R's
  ``findInterval``); NaN when ``zmax < 2`` or a height is below 0;
* ``pzabovezmean``, ``pzabove2``: % of the returns strictly above ``zmean`` and 2 m;
* ``zq5`` .. ``zq95``: quantiles of R's type 7 (numpy's ``linear``);
* ``zpcum1`` .. ``zpcum9``: cumulative % of the returns above 0 in the first 1..9 of ten equal
  height layers from 0 to ``zmax`` (the returns at ``zmax`` itself fall in no layer and are not
  counted, as in lidR); 0 when ``zmax <= 0``;
* ``zL1`` .. ``zL4``, ``zLcv = L2/L1``, ``zLskew = L3/L2``, ``zLkurt = L4/L2``: the sample
  L-moments from the unbiased probability-weighted moments (Hosking 1990; FUSION's "Elev L1"
  .. "Elev L kurtosis"); NaN below 4 returns for L4 (below 2, 3 for L2, L3);
* ``cover``: % of the first returns above the minimum height among all first returns of the
  group (FUSION's "percentage first returns above heightbreak"), counted before the
  ``min_height`` and ``returns`` selection;
* ``n``: the number of returns the metrics were computed on.
"""
from __future__ import annotations

import numpy as np

#: the quantile probabilities of ``zq5`` .. ``zq95`` as R's ``seq(0.05, 0.95, 0.05)`` makes them
PROBS = 0.05 + np.arange(19) * 0.05
#: lidR's ``.stdmetrics_z`` metrics, in its order
STD_Z = ("zmax", "zmean", "zsd", "zskew", "zkurt", "zentropy", "pzabovezmean", "pzabove2",
         *(f"zq{5 * (k + 1)}" for k in range(19)), *(f"zpcum{k}" for k in range(1, 10)))
#: FUSION's L-moments of the heights
L_MOMENTS = ("zL1", "zL2", "zL3", "zL4", "zLcv", "zLskew", "zLkurt")
#: every metric :func:`group_metrics` returns, in order (the bands of a metrics raster)
METRICS = STD_Z + L_MOMENTS + ("cover", "n")
RETURNS = ("all", "first")


def _runs(gs, n_groups):
    """``(groups with returns, their first index, their size)`` of sorted group ids."""
    counts = np.bincount(gs, minlength=n_groups)
    has = np.flatnonzero(counts)
    starts = (np.cumsum(counts) - counts)[has]
    return has, starts, counts[has]


def _quantiles(zs, starts, n):
    """R's type-7 quantiles at :data:`PROBS` of each run of the sorted heights ``zs``
    (``stats:::quantile.default``: ``index = 1 + (n - 1) p``, ``(1 - h) x[lo] + h x[hi]`` where
    ``h > 0`` and the two differ)."""
    out = []
    for p in PROBS:
        index = 1.0 + (n - 1) * p
        lo = np.floor(index)
        hi = np.ceil(index)
        qs = zs[starts + lo.astype(np.int64) - 1]
        xh = zs[starts + hi.astype(np.int64) - 1]
        h = index - lo
        mix = (index > lo) & (xh != qs)
        out.append(np.where(mix, (1 - h) * qs + h * xh, qs))
    return out


def _zpcum(zs, gi, zmax, k_groups):
    """lidR's ``zpcum1..9`` (see the module doc): ``(k_groups, 9)``."""
    out = np.zeros((k_groups, 9))
    ok = zmax > 0
    sel = (zs > 0) & ok[gi]
    z, g = zs[sel], gi[sel]
    by = zmax / 10.0
    b_g, top = by[g], zmax[g]

    def brk(j):  # R: seq(0, zmax, by) = pmin(0 + (0:10) * by, zmax)
        return np.minimum(j * b_g, top)

    j = np.clip(np.floor(z / b_g), 0, 10)
    for _ in range(2):  # the last break at or below z (rounding of z / by)
        j = np.where((j > 0) & (brk(j) > z), j - 1, j)
        j = np.where((j < 10) & (brk(j + 1) <= z), j + 1, j)
    k = j.astype(np.int64) + 1  # findInterval: 1..11; 11 (z == zmax) is in no layer
    counts = np.bincount(g * 12 + k, minlength=k_groups * 12).reshape(k_groups, 12)[:, 1:11]
    tot = counts.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        pct = counts / tot[:, None] * 100.0
    cum = np.cumsum(pct, axis=1)[:, :9]
    out[ok] = cum[ok]
    return out


def _entropy(zs, gi, zmin, zmax, k_groups):
    """lidR's ``entropy(z, by = 1)`` of each group (see the module doc)."""
    out = np.full(k_groups, np.nan)
    ok = (zmax >= 2.0) & (zmin >= 0.0)
    nb = np.ceil(zmax)  # bins [0, 1), ..., [N - 1, N)
    fl = np.floor(zs)
    sel = ok[gi] & (fl < nb[gi])
    fl, g = fl[sel], gi[sel]
    if g.size == 0:
        return out
    new = np.r_[True, (g[1:] != g[:-1]) | (fl[1:] != fl[:-1])]
    first = np.flatnonzero(new)
    size = np.diff(np.r_[first, g.size]).astype(np.float64)
    rg = g[first]
    tot = np.bincount(rg, weights=size, minlength=k_groups)
    p = size / tot[rg]
    s = -np.bincount(rg, weights=p * np.log(p), minlength=k_groups)
    with np.errstate(invalid="ignore", divide="ignore"):
        out[ok] = (s / np.log(nb))[ok]
    return out


def _l_moments(zs, gi, starts, n, mean):
    """Sample L-moments 1..4 from the unbiased probability-weighted moments."""
    i = (np.arange(zs.size) - starts[gi]).astype(np.float64)  # rank in the group, from 0
    nn = n.astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        w1 = i / (nn - 1)[gi]
        w2 = w1 * (i - 1) / (nn - 2)[gi]
        w3 = w2 * (i - 2) / (nn - 3)[gi]
        b1 = np.add.reduceat(np.nan_to_num(w1 * zs), starts) / nn
        b2 = np.add.reduceat(np.nan_to_num(w2 * zs), starts) / nn
        b3 = np.add.reduceat(np.nan_to_num(w3 * zs), starts) / nn
        l1 = mean
        l2 = np.where(nn >= 2, 2 * b1 - mean, np.nan)
        l3 = np.where(nn >= 3, 6 * b2 - 6 * b1 + mean, np.nan)
        l4 = np.where(nn >= 4, 20 * b3 - 30 * b2 + 12 * b1 - mean, np.nan)
        return {"zL1": l1, "zL2": l2, "zL3": l3, "zL4": l4, "zLcv": l2 / l1,
                "zLskew": l3 / l2, "zLkurt": l4 / l2}


def _cover(z, first, group, n_groups, min_height):
    firsts = np.ones(z.size, bool) if first is None else np.asarray(first, bool)
    tot = np.bincount(group[firsts], minlength=n_groups).astype(np.float64)
    hi = np.bincount(group[firsts & (z > min_height)], minlength=n_groups)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(tot > 0, hi / tot * 100.0, np.nan)


def group_metrics(z, group, n_groups: int, *, first=None, min_height=None,
                  returns: str = "all") -> dict:
    """The metric set (:data:`METRICS`) of each group of returns.

    Parameters
    ----------
    z : (N,) array
        Heights above ground (m).
    group : (N,) int array
        Each return's group, ``0 <= group < n_groups``; a negative group is left out.
    n_groups : int
    first : (N,) bool array, optional
        Whether each return is a first return (None: every return is).
    min_height : float, optional
        The metrics are computed on the returns above it (None: on every return, as lidR's
        ``pixel_metrics(las, .stdmetrics_z)``); ``cover`` counts the first returns above it
        (2 m when None).
    returns : {"all", "first"}
        The metrics of all returns or of the first returns only.

    Returns
    -------
    dict of name -> (n_groups,) float64 arrays, NaN for a group without returns (and where
    lidR gives NA).
    """
    if returns not in RETURNS:
        from ..errors import InputError

        raise InputError(f"-returns: expected all or first, got {returns!r}")
    z = np.asarray(z, np.float64)
    group = np.asarray(group, np.int64)
    inside = group >= 0
    if not inside.all():
        z, group = z[inside], group[inside]
        first = None if first is None else np.asarray(first, bool)[inside]
    out = {m: np.full(n_groups, np.nan) for m in METRICS}
    cover_h = 2.0 if min_height is None else float(min_height)
    out["cover"] = _cover(z, first, group, n_groups, cover_h)
    sel = np.ones(z.size, bool)
    if returns == "first" and first is not None:
        sel &= np.asarray(first, bool)
    if min_height is not None:
        sel &= z > float(min_height)
    z, group = z[sel], group[sel]
    out["n"] = np.bincount(group, minlength=n_groups).astype(np.float64)
    if z.size == 0:
        return out
    order = np.lexsort((z, group))
    zs, gs = z[order], group[order]
    has, starts, n = _runs(gs, n_groups)
    k = has.size
    gi = np.repeat(np.arange(k), n)
    nf = n.astype(np.float64)
    zmax = zs[starts + n - 1]
    zmin = zs[starts]
    mean = np.add.reduceat(zs, starts) / nf
    d = zs - mean[gi]
    d2 = d * d
    m2 = np.add.reduceat(d2, starts)
    m3 = np.add.reduceat(d2 * d, starts)
    m4 = np.add.reduceat(d2 * d2, starts)
    with np.errstate(invalid="ignore", divide="ignore"):
        vals = {"zmax": zmax, "zmean": mean,
                "zsd": np.where(n > 1, np.sqrt(m2 / (nf - 1)), np.nan),
                "zskew": (m3 / nf) / (m2 / nf) ** 1.5, "zkurt": nf * m4 / (m2 * m2)}
    vals["zentropy"] = _entropy(zs, gi, zmin, zmax, k)
    vals["pzabovezmean"] = np.add.reduceat((zs > mean[gi]).astype(np.float64), starts) / nf * 100
    vals["pzabove2"] = np.add.reduceat((zs > 2.0).astype(np.float64), starts) / nf * 100
    for p, q in zip(range(5, 100, 5), _quantiles(zs, starts, n)):
        vals[f"zq{p}"] = q
    cum = _zpcum(zs, gi, zmax, k)
    for j in range(9):
        vals[f"zpcum{j + 1}"] = cum[:, j]
    vals.update(_l_moments(zs, gi, starts, n, mean))
    for name, v in vals.items():
        out[name][has] = v
    return out
