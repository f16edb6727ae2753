"""Compiled kernels of the ground filter (numba), each with its numpy twin.

The robust interpolation runs 25 surface iterations over every point; in numpy each one made
about twenty passes over the points (cell index, nine weighted ``bincount``s, a bilinear
interpolation, the weights). Here a level's iteration is two passes: the weighted plane sums per
cell (:func:`plane_surface`), then the residual and the Kraus & Pfeifer weight of every point
(:func:`residual_weights`). The isolated-low-point test (second lowest of the 10 nearest
neighbours) is a grid search (:func:`isolated_low`) instead of a k-d tree query.

The numpy twins give the same results (tests/test_ground_speed.py compares them); they are used
where numba is missing (``_accel.HAVE_NUMBA``).
"""
from __future__ import annotations

import numpy as np

from .._accel import HAVE_NUMBA, _jit
from .._raster import bilinear_at, bilinear_np as _raster_bilinear_np


# ---------------------------------------------------------------------------------------------
# weighted plane per cell
def _plane_sums_py(idx, dx, dy, z, w, n):
    """Per cell: sum of w, w z, w dx, w dy, w dx², w dx dy, w dy², w dx z, w dy z, count(w > 0)."""
    s = np.zeros((n, 10))
    for i in range(idx.shape[0]):
        wi = w[i]
        if wi == 0.0:
            continue
        k = idx[i]
        a, b, zi = dx[i], dy[i], z[i]
        s[k, 0] += wi
        s[k, 1] += wi * zi
        s[k, 2] += wi * a
        s[k, 3] += wi * b
        s[k, 4] += wi * a * a
        s[k, 5] += wi * a * b
        s[k, 6] += wi * b * b
        s[k, 7] += wi * a * zi
        s[k, 8] += wi * b * zi
        s[k, 9] += 1.0
    return s


def _solve_planes_py(s, res, grid):
    """Cell value: the plane's height at the centre (Cramer's rule), else the weighted mean."""
    for k in range(s.shape[0]):
        sw = s[k, 0]
        if not sw > 0.0:
            continue
        mean = s[k, 1] / sw
        grid[k] = mean
        if s[k, 9] < 3.0:
            continue
        m00, m01, m02 = sw, s[k, 2], s[k, 3]
        m11, m12, m22 = s[k, 4], s[k, 5], s[k, 6]
        r0, r1, r2 = s[k, 1], s[k, 7], s[k, 8]
        c0 = m11 * m22 - m12 * m12
        c1 = m01 * m22 - m12 * m02
        c2 = m01 * m12 - m11 * m02
        det = m00 * c0 - m01 * c1 + m02 * c2
        if not abs(det) > 1e-3 * max(sw, 1e-12) ** 3:
            continue
        num = r0 * c0 - m01 * (r1 * m22 - m12 * r2) + m02 * (r1 * m12 - m11 * r2)
        a = num / det
        if abs(a - mean) < 2.0 * res:  # a plane fitted to a corner is not trusted far off
            grid[k] = a


_plane_sums_nb = _jit(_plane_sums_py)
_solve_planes_nb = _jit(_solve_planes_py)


def _plane_surface_np(idx, dx, dy, z, w, n, res):
    sw = np.bincount(idx, weights=w, minlength=n)
    swz = np.bincount(idx, weights=w * z, minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        grid = np.where(sw > 0, swz / sw, np.nan)
    s = {k: np.bincount(idx, weights=w * v, minlength=n)
         for k, v in (("x", dx), ("y", dy), ("xx", dx * dx), ("xy", dx * dy), ("yy", dy * dy),
                      ("xz", dx * z), ("yz", dy * z))}
    M = np.stack([np.stack([sw, s["x"], s["y"]], -1), np.stack([s["x"], s["xx"], s["xy"]], -1),
                  np.stack([s["y"], s["xy"], s["yy"]], -1)], -2)
    rhs = np.stack([swz, s["xz"], s["yz"]], -1)
    cnt = np.bincount(idx, weights=(w > 0).astype(float), minlength=n)
    det = np.linalg.det(M)
    ok = (cnt >= 3) & (np.abs(det) > 1e-3 * np.maximum(sw, 1e-12) ** 3)
    if ok.any():
        sol = np.linalg.solve(M[ok], rhs[ok][..., None])[..., 0]
        a = sol[:, 0]
        grid[ok] = np.where(np.abs(a - grid[ok]) < 2.0 * res, a, grid[ok])
    return grid


def plane_surface(idx, dx, dy, z, w, n, res):
    """Flat grid of ``n`` cells: the weighted least-squares plane of each cell's points at the
    cell centre, the weighted mean where the plane is not determined, NaN where no weight.

    ``idx`` is each point's flat cell, ``dx``, ``dy`` its offset from the cell centre in cells.
    """
    if HAVE_NUMBA:
        grid = np.full(n, np.nan)
        _solve_planes_nb(_plane_sums_nb(idx, dx, dy, z, w, n), float(res), grid)
        return grid
    return _plane_surface_np(idx, dx, dy, z, w, n, res)


# ---------------------------------------------------------------------------------------------
# residuals to the bilinear surface, and the weights
def _residuals_py(grid, x, y, z, left, top, res, v):
    """v = z - bilinear interpolation of cell-centre values (edges clamped)."""
    for i in range(x.shape[0]):
        v[i] = z[i] - bilinear_at(grid, (top - y[i]) / res - 0.5, (x[i] - left) / res - 0.5)


def _weights_py(v, g, w, a, b, out):
    ib = int(b)
    whole = ib == b and 1 <= ib <= 8  # b = 4 (the default): products, not pow
    for i in range(v.shape[0]):
        vi = v[i]
        if vi <= g:
            out[i] = 1.0
        elif vi > g + w:
            out[i] = 0.0
        else:
            t = a * (vi - g)
            if whole:
                pw = t
                for _ in range(ib - 1):
                    pw *= t
            else:
                pw = t ** b
            out[i] = 1.0 / (1.0 + pw)


_residuals_nb = _jit(_residuals_py)
_weights_nb = _jit(_weights_py)


def bilinear_np(grid, left, top, res, x, y):
    """Bilinear interpolation of cell-centre values at points (edges clamped), numpy."""
    return _raster_bilinear_np(grid, (top - np.asarray(y)) / res - 0.5,
                               (np.asarray(x) - left) / res - 0.5)


def residuals(grid, left, top, res, x, y, z):
    """z minus the bilinear interpolation of the cell-centre grid at (x, y)."""
    if HAVE_NUMBA:
        v = np.empty(np.shape(x)[0])
        _residuals_nb(np.ascontiguousarray(grid, np.float64), x, y, z, float(left), float(top),
                      float(res), v)
        return v
    return z - bilinear_np(grid, left, top, res, x, y)


def bilinear(grid, left, top, res, x, y):
    """Bilinear interpolation of the cell-centre grid at (x, y), edges clamped."""
    x = np.ascontiguousarray(x, np.float64)
    return -residuals(grid, left, top, res, x, np.ascontiguousarray(y, np.float64),
                      np.zeros(x.shape[0]))


def kp_weights_fast(v, g, w, a, b):
    """Kraus & Pfeifer weights (see :func:`filter.kp_weights`), compiled where numba is."""
    if HAVE_NUMBA:
        out = np.empty(v.shape[0])
        _weights_nb(np.ascontiguousarray(v, np.float64), float(g), float(w), float(a), float(b),
                    out)
        return out
    return kp_weights_np(v, g, w, a, b)


def kp_weights_np(v, g, w, a, b):
    """Kraus & Pfeifer weights (seed 003, eq. 1): 1 at or below g, 1 / (1 + (a (v - g))^b)
    up to g + w, 0 above; numpy."""
    v = np.asarray(v, dtype=np.float64)
    p = 1.0 / (1.0 + (a * (v - g)) ** b)
    p = np.where(v <= g, 1.0, p)
    return np.where(v > g + w, 0.0, p)


# ---------------------------------------------------------------------------------------------
# lowest point per cell
def _lowest_index_py(idx, key, z, best):
    """``best[c]``: the point of ``idx`` with the lowest z in cell ``c`` (ties: the first)."""
    for j in range(idx.shape[0]):
        i = idx[j]
        c = key[j]
        b = best[c]
        if b < 0 or z[i] < z[b]:
            best[c] = i


_lowest_index_nb = _jit(_lowest_index_py)


def lowest_index(idx, key, z, ncells):
    """Index of the lowest point in each cell (-1 where none) of points ``idx`` (ascending)
    in cells ``key``; ties go to the first point, as a stable sort by (cell, z) would."""
    if HAVE_NUMBA:
        best = np.full(ncells, -1, np.int64)
        _lowest_index_nb(np.ascontiguousarray(idx, np.int64), np.ascontiguousarray(key, np.int64),
                         np.ascontiguousarray(z, np.float64), best)
        return best
    o = np.lexsort((z[idx], key))
    k = key[o]
    first = np.r_[True, k[1:] != k[:-1]]
    best = np.full(ncells, -1, np.int64)
    best[k[first]] = idx[o[first]]
    return best


# ---------------------------------------------------------------------------------------------
# second lowest height among the k nearest neighbours in plan
def _before(d1, p1, d2, p2, sx, sy, sz):
    """Whether candidate ``p1`` at squared distance ``d1`` comes before ``p2`` at ``d2``: the
    nearer, and at equal distances the lower x, then y, then z (the points' own coordinates,
    so a tile and the whole area order them alike)."""
    if d1 != d2:
        return d1 < d2
    if sx[p1] != sx[p2]:
        return sx[p1] < sx[p2]
    if sy[p1] != sy[p2]:
        return sy[p1] < sy[p2]
    return sz[p1] < sz[p2]


def _knn_insert(d, p, sx, sy, sz, dist, zz, ids, found, k):
    """Insert candidate ``p`` (squared distance ``d``) into the sorted k-nearest list."""
    if found == k and not _before(d, p, dist[k - 1], ids[k - 1], sx, sy, sz):
        return found
    m = found if found < k else k - 1
    while m > 0 and _before(d, p, dist[m - 1], ids[m - 1], sx, sy, sz):
        dist[m] = dist[m - 1]
        zz[m] = zz[m - 1]
        ids[m] = ids[m - 1]
        m -= 1
    dist[m] = d
    zz[m] = sz[p]
    ids[m] = p
    return found + 1 if found < k else k


def _knn_second_lowest(i, ri, ci, sx, sy, sz, start, cell, width, height, k, dist, zz, ids):
    """Second lowest z of the ``k`` nearest neighbours of point ``i`` (in cell ``ri, ci``),
    searched ring by ring of cells; ties in distance go by the coordinates (:func:`_before`)."""
    xi, yi = sx[i], sy[i]
    ex = min(xi - ci * cell, (ci + 1) * cell - xi)
    ey = min(yi - ri * cell, (ri + 1) * cell - yi)
    edge = max(min(ex, ey), 0.0)
    found = 0
    ring = 0
    while ring <= max(width, height):
        r0, r1 = ri - ring, ri + ring
        for r in range(max(r0, 0), min(r1, height - 1) + 1):
            full = r == r0 or r == r1
            c = ci - ring
            while c <= ci + ring:
                if 0 <= c < width:
                    kc = r * width + c
                    for p in range(start[kc], start[kc + 1]):
                        if p != i:
                            d = (sx[p] - xi) * (sx[p] - xi) + (sy[p] - yi) * (sy[p] - yi)
                            found = _knn_insert(d, p, sx, sy, sz, dist, zz, ids, found, k)
                if full or c != ci - ring:  # inner rows: the two edge columns only
                    c += 1
                else:
                    c = ci + ring
        reach = ring * cell + edge  # every point not visited yet is at least this far
        if found == k and dist[k - 1] <= reach * reach:
            break
        ring += 1
    lo1 = np.inf
    lo2 = np.inf
    for m in range(found):
        if zz[m] < lo1:
            lo2 = lo1
            lo1 = zz[m]
        elif zz[m] < lo2:
            lo2 = zz[m]
    return lo2


def _isolated_low_py(sx, sy, sz, start, cell, width, height, k, depth, out):
    """``out[i]``: point i is more than ``depth`` below the second lowest of its ``k`` nearest
    neighbours, i.e. at most one of them has ``z - depth <= z_i``. Points sorted by cell
    (CSR ``start``), local coordinates >= 0.

    Most points are decided exactly from two discs scanned in the 3 x 3 cells around them: a
    disc holding at most k other points lies inside the k nearest, so two low-enough points in
    it mean "not isolated"; a disc holding at least k contains the k nearest, so at most one
    low-enough point in it means "isolated". The rest are searched neighbour by neighbour."""
    dist = np.empty(k)
    zz = np.empty(k)
    ids = np.empty(k, np.int64)
    # nested discs of 1/4 to 1 cell: within the 3 x 3 cells wherever the point is in its cell
    q1, q2, q3, q4 = (cell / 4) ** 2, (cell / 2) ** 2, (3 * cell / 4) ** 2, cell * cell
    for ri in range(height):
        for ci in range(width):
            kc0 = ri * width + ci
            for i in range(start[kc0], start[kc0 + 1]):
                xi, yi, zi = sx[i], sy[i], sz[i]
                # points (n) and low-enough points (l) in each disc
                n1 = n2 = n3 = n4 = 0
                l1 = l2 = l3 = l4 = 0
                for r in range(max(ri - 1, 0), min(ri + 1, height - 1) + 1):
                    for p in range(start[r * width + max(ci - 1, 0)],
                                   start[r * width + min(ci + 1, width - 1) + 1]):
                        d = (sx[p] - xi) * (sx[p] - xi) + (sy[p] - yi) * (sy[p] - yi)
                        if d >= q4 or p == i:
                            continue
                        low = sz[p] - depth <= zi
                        c1 = d < q1
                        c2 = d < q2
                        c3 = d < q3
                        n1 += c1
                        n2 += c2
                        n3 += c3
                        n4 += 1
                        l1 += c1 & low
                        l2 += c2 & low
                        l3 += c3 & low
                        l4 += low
                if ((n1 <= k and l1 >= 2) or (n2 <= k and l2 >= 2) or (n3 <= k and l3 >= 2)
                        or (n4 <= k and l4 >= 2)):
                    out[i] = False
                    continue
                if ((n1 >= k and l1 <= 1) or (n2 >= k and l2 <= 1) or (n3 >= k and l3 <= 1)
                        or (n4 >= k and l4 <= 1)):
                    out[i] = True
                    continue
                lo2 = _knn_second_lowest(i, ri, ci, sx, sy, sz, start, cell, width, height, k,
                                         dist, zz, ids)
                out[i] = zi < lo2 - depth


if HAVE_NUMBA:  # the helpers are inlined into the compiled search
    import numba

    _before = numba.njit(inline="always", cache=True)(_before)
    _knn_insert = numba.njit(inline="always", cache=True)(_knn_insert)
    _knn_second_lowest = numba.njit(cache=True)(_knn_second_lowest)
_isolated_low_nb = _jit(_isolated_low_py)


#: points per cell of the neighbour search (bcts_1, one core: 2 -> 0.17 s, 3 -> 0.16 s, 6 -> 0.22 s)
KNN_CELL_POINTS = 3.0


def isolated_low(x, y, z, depth=2.0, k=10):
    """Points more than ``depth`` below the second lowest of their ``k`` nearest neighbours in
    plan (themselves excluded).

    Compiled: a grid of cells of about ``KNN_CELL_POINTS`` points (see :func:`_isolated_low_py`);
    numpy: scipy's k-d tree.
    """
    x, y, z = (np.ascontiguousarray(a, np.float64) for a in (x, y, z))
    if not HAVE_NUMBA:
        from scipy.spatial import cKDTree

        xy = np.column_stack([x - x.min(), y - y.min()])
        _, idx = cKDTree(xy).query(xy, k=k + 1)
        return z < np.partition(z[idx[:, 1:]], 1, axis=1)[:, 1] - depth
    lx, ly = x - x.min(), y - y.min()
    area = max(float(lx.max()) * float(ly.max()), 1e-6)
    cell = max(np.sqrt(KNN_CELL_POINTS * area / x.size), 1e-3)
    width = min(int(lx.max() / cell) + 1, 1 << 15)
    height = min(int(ly.max() / cell) + 1, 1 << 15)
    cell = max(float(lx.max()) / width, float(ly.max()) / height, cell) * (1 + 1e-12)
    col = np.minimum((lx / cell).astype(np.int64), width - 1)
    row = np.minimum((ly / cell).astype(np.int64), height - 1)
    key = row * width + col
    order = np.argsort(key, kind="stable")
    start = np.zeros(width * height + 1, np.int64)
    np.cumsum(np.bincount(key, minlength=width * height), out=start[1:])
    low = np.empty(x.size, np.bool_)
    _isolated_low_nb(lx[order], ly[order], z[order], start, float(cell), width, height, int(k),
                     float(depth), low)
    out = np.empty(x.size, bool)
    out[order] = low
    return out
