"""numba kernels for measured hot loops, with numpy twins.

numba is a dependency of the package, so every install compiles these. ``HAVE_NUMBA`` says
whether they are used (``LIDARTREES_NO_NUMBA=1`` turns them off, as where numba cannot be
imported); every kernel has a numpy twin with the same results (tests/test_fallback.py compares
the rasters and trees of both on real files).
"""
from __future__ import annotations

import os

import numpy as np

try:  # pragma: no cover - depends on the environment
    if os.environ.get("LIDARTREES_NO_NUMBA"):
        raise ImportError
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    numba = None
    HAVE_NUMBA = False


def kernels_cached() -> bool:
    """Whether numba's on-disk cache of these kernels exists (False before the first run after
    an install: the kernels are compiled then, once, and cached beside the package)."""
    import glob

    here = os.path.dirname(os.path.abspath(__file__))
    places = [os.path.join(here, "__pycache__")]
    if os.environ.get("NUMBA_CACHE_DIR"):  # numba's cache elsewhere, by the source's path
        places.append(os.path.join(os.environ["NUMBA_CACHE_DIR"], "**"))
    places.append(os.path.join(os.path.expanduser("~"), ".cache", "numba", "**"))  # read-only
    return any(glob.glob(os.path.join(p, "_accel.*.nbi"), recursive=True) for p in places)


def _jit(fn):
    if HAVE_NUMBA:
        return numba.njit(cache=True, nogil=True)(fn)
    return None


def _accumulate_py(x, y, z, col0, row0, res, height, width, eps, count, mx, mn, sm):
    """One pass: cell index of every point, then count / max / min / sum per cell.

    A point's cell is ``floor(x / res + eps) - col0`` (and the same for rows from ``row0``, the
    grid's lower-left cell in the global grid), as :meth:`GridSpec.cell_index`. Arrays
    ``count``, ``mx``, ``mn``, ``sm`` of length 0 are skipped. Returns the number of points that
    fall outside the grid.
    """
    outside = 0
    do_max = mx.shape[0] > 0
    do_min = mn.shape[0] > 0
    do_sum = sm.shape[0] > 0
    do_count = count.shape[0] > 0
    inv = 1.0 / res
    for i in range(x.shape[0]):
        # x * inv + eps rounds the same way in every grid; less the grid's first column, an
        # integer, exactly (the cells of the global grid, as GridSpec.cell_index)
        fc = (x[i] * inv + eps) - col0
        fr = (y[i] * inv + eps) - row0
        # compared as floats before any int conversion: NaN, inf and 1e300 never become an index
        if not (fc >= 0.0 and fr >= 0.0 and fc < width and fr < height):
            outside += 1
            continue
        c = int(fc)
        r = height - 1 - int(fr)
        if c >= width or r < 0 or c < 0 or r >= height:
            outside += 1
            continue
        k = r * width + c
        v = z[i]
        if do_count:
            count[k] += 1
        if do_max and v > mx[k]:  # mx starts at -inf
            mx[k] = v
        if do_min and v < mn[k]:  # mn starts at +inf
            mn[k] = v
        if do_sum:
            sm[k] += v
    return outside


_accumulate_nb = _jit(_accumulate_py)


def accumulate(x, y, z, col0, row0, res, height, width, eps, count, mx, mn, sm) -> int:
    """Fused gridding kernel (numba only; callers use the numpy path when it is missing)."""
    n = height * width
    if not (x.shape[0] == y.shape[0] == z.shape[0]) or any(
            a.shape[0] not in (0, n) for a in (count, mx, mn, sm)) or not res > 0:
        raise ValueError("accumulate: arrays do not match the grid")
    return _accumulate_nb(x, y, z, col0, row0, res, height, width, eps, count, mx, mn, sm)


def _lowest_py(idx, x, y, z, cz, cx, cy, count):
    """Lowest point of each cell ``idx[i]``: counts, and ``(cz, cx, cy)`` replaced where a point
    is lower, ties in z going to the lowest x, then y (order-independent)."""
    for i in range(idx.shape[0]):
        k = idx[i]
        count[k] += 1
        zi, xi = z[i], x[i]
        if zi < cz[k] or (zi == cz[k] and (xi < cx[k] or (xi == cx[k] and y[i] < cy[k]))):
            cz[k] = zi
            cx[k] = xi
            cy[k] = y[i]


_lowest_nb = _jit(_lowest_py)


def lowest(idx, x, y, z, cz, cx, cy, count) -> None:
    """Compiled :func:`_lowest_py` (numba only; callers use the numpy path when missing)."""
    if idx.size and (idx.min() < 0 or idx.max() >= min(cz.size, cx.size, cy.size, count.size)):
        raise ValueError("lowest: a cell index is outside the grid")
    _lowest_nb(idx, x, y, z, cz, cx, cy, count)


def _fill_mean8_py(out, empty, max_passes):
    """Jacobi passes of :func:`lidartrees_gis.grid.fill_mean8` over the empty cells only (the
    list, in row-major order, shrinks as they fill): each takes the mean of its 8 neighbours
    that were not empty before the pass. ``out`` and ``empty`` are updated in place; returns
    the number of passes."""
    h, w = out.shape
    n = 0
    for r in range(h):
        for c in range(w):
            if empty[r, c]:
                n += 1
    rows = np.empty(n, np.int64)
    cols = np.empty(n, np.int64)
    n = 0
    for r in range(h):
        for c in range(w):
            if empty[r, c]:
                rows[n] = r
                cols[n] = c
                n += 1
    vals = np.empty(n)
    take = np.zeros(n, np.bool_)
    passes = 0
    while n > 0:
        took = False
        for i in range(n):
            r, c = rows[i], cols[i]
            s = 0.0
            cnt = 0
            for rr in range(max(r - 1, 0), min(r + 2, h)):
                for cc in range(max(c - 1, 0), min(c + 2, w)):
                    if (rr != r or cc != c) and not empty[rr, cc]:
                        s += out[rr, cc]
                        cnt += 1
            take[i] = cnt > 0
            if cnt > 0:
                vals[i] = s / cnt
                took = True
        if not took:  # the rest cannot be reached
            break
        m = 0
        for i in range(n):
            if take[i]:
                out[rows[i], cols[i]] = vals[i]
                empty[rows[i], cols[i]] = False
            else:
                rows[m], cols[m] = rows[i], cols[i]
                m += 1
        n = m
        passes += 1
        if max_passes > 0 and passes >= max_passes:
            break
    return passes


_fill_mean8_nb = _jit(_fill_mean8_py)


def _draw_triangle_py(ax, ay, az, bx, by, bz, cx, cy, cz, max_edge, max_radius, left, top, res,
                      height, width, out):
    """Linear interpolation of one triangle at the cell centres it covers, kept where higher
    than ``out`` (NaN in ``out`` counts as lowest). Skipped (returns 0) when an edge is longer
    than ``max_edge`` (> 0) or the circumradius larger than ``max_radius`` (> 0)."""
    if max_edge > 0.0:
        me2 = max_edge * max_edge
        if ((ax - bx) ** 2 + (ay - by) ** 2 > me2 or (bx - cx) ** 2 + (by - cy) ** 2 > me2
                or (cx - ax) ** 2 + (cy - ay) ** 2 > me2):
            return 0
    det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
    if det == 0.0 or not (abs(det) < np.inf):  # degenerate, or a coordinate not a number
        return 0
    if max_radius > 0.0:
        # circumradius R = |ab| |bc| |ca| / (2 |det|): kept when R <= max_radius
        e2 = (((ax - bx) ** 2 + (ay - by) ** 2) * ((bx - cx) ** 2 + (by - cy) ** 2)
              * ((cx - ax) ** 2 + (cy - ay) ** 2))
        if not (e2 <= 4.0 * max_radius * max_radius * det * det):
            return 0
    xmin = min(ax, bx, cx)
    xmax = max(ax, bx, cx)
    ymin = min(ay, by, cy)
    ymax = max(ay, by, cy)
    # columns whose centre x = left + (j + 0.5) res lies in [xmin, xmax]; clamped as floats
    # first, so NaN, inf or 1e300 coordinates never become an index outside ``out``
    fj0 = np.ceil((xmin - left) / res - 0.5)
    fj1 = np.floor((xmax - left) / res - 0.5)
    fi0 = np.ceil((top - ymax) / res - 0.5)
    fi1 = np.floor((top - ymin) / res - 0.5)
    if not (fj0 <= fj1 and fi0 <= fi1 and fj1 >= 0.0 and fi1 >= 0.0
            and fj0 <= width - 1.0 and fi0 <= height - 1.0):
        return 0  # no cell centre inside, or not a number
    j0 = int(max(fj0, 0.0))
    i0 = int(max(fi0, 0.0))
    j1 = int(min(fj1, width - 1.0))
    i1 = int(min(fi1, height - 1.0))
    eps = -1e-9 * abs(det)
    for i in range(i0, i1 + 1):
        yc = top - (i + 0.5) * res
        for j in range(j0, j1 + 1):
            xc = left + (j + 0.5) * res
            l1 = (by - cy) * (xc - cx) + (cx - bx) * (yc - cy)
            l2 = (cy - ay) * (xc - cx) + (ax - cx) * (yc - cy)
            if det < 0:
                l1, l2, d = -l1, -l2, -det
            else:
                d = det
            l3 = d - l1 - l2
            if l1 < eps or l2 < eps or l3 < eps:
                continue
            v = (l1 * az + l2 * bz + l3 * cz) / d
            cur = out[i, j]
            if v == v and not (cur >= v):  # also when cur is NaN; never write a NaN
                out[i, j] = v
    return 1


_draw_triangle = _jit(_draw_triangle_py) or _draw_triangle_py


def _raster_triangles_py(px, py, pz, tri, max_edge, left, top, res, height, width, out,
                         max_radius=0.0):
    """:func:`_draw_triangle_py` for each triangle ``tri[t]`` (indices into ``px, py, pz``).
    Returns the number of triangles drawn."""
    drawn = 0
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        drawn += _draw_triangle(px[a], py[a], pz[a], px[b], py[b], pz[b], px[c], py[c], pz[c],
                                max_edge, max_radius, left, top, res, height, width, out)
    return drawn


_raster_triangles_nb = _jit(_raster_triangles_py)


def _raster_triangles_np(px, py, pz, tri, max_edge, left, top, res, height, width, out,
                         max_radius=0.0, batch=200_000) -> int:
    """:func:`_raster_triangles_py` vectorised with numpy (the twin used without numba): the
    same tests in the same arithmetic, so the same cells and values; "kept where higher" is a
    maximum, which does not depend on the order the triangles are drawn in."""
    drawn = 0
    for s in range(0, tri.shape[0], batch):
        t = tri[s:s + batch]
        ax, ay, az = px[t[:, 0]], py[t[:, 0]], pz[t[:, 0]]
        bx, by, bz = px[t[:, 1]], py[t[:, 1]], pz[t[:, 1]]
        cx, cy, cz = px[t[:, 2]], py[t[:, 2]], pz[t[:, 2]]
        with np.errstate(invalid="ignore", over="ignore"):
            ok = np.ones(t.shape[0], bool)
            if max_edge > 0.0:
                me2 = max_edge * max_edge
                ok &= ~(((ax - bx) ** 2 + (ay - by) ** 2 > me2) | ((bx - cx) ** 2 + (by - cy) ** 2 > me2)
                        | ((cx - ax) ** 2 + (cy - ay) ** 2 > me2))
            det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
            ok &= (det != 0.0) & (np.abs(det) < np.inf)
            if max_radius > 0.0:
                e2 = (((ax - bx) ** 2 + (ay - by) ** 2) * ((bx - cx) ** 2 + (by - cy) ** 2)
                      * ((cx - ax) ** 2 + (cy - ay) ** 2))
                ok &= e2 <= 4.0 * max_radius * max_radius * det * det
            fj0 = np.ceil((np.minimum(np.minimum(ax, bx), cx) - left) / res - 0.5)
            fj1 = np.floor((np.maximum(np.maximum(ax, bx), cx) - left) / res - 0.5)
            fi0 = np.ceil((top - np.maximum(np.maximum(ay, by), cy)) / res - 0.5)
            fi1 = np.floor((top - np.minimum(np.minimum(ay, by), cy)) / res - 0.5)
            ok &= ((fj0 <= fj1) & (fi0 <= fi1) & (fj1 >= 0.0) & (fi1 >= 0.0)
                   & (fj0 <= width - 1.0) & (fi0 <= height - 1.0))
        drawn += int(ok.sum())
        k = np.nonzero(ok)[0]
        if k.size == 0:
            continue
        j0 = np.maximum(fj0[k], 0.0).astype(np.int64)
        i0 = np.maximum(fi0[k], 0.0).astype(np.int64)
        j1 = np.minimum(fj1[k], width - 1.0).astype(np.int64)
        i1 = np.minimum(fi1[k], height - 1.0).astype(np.int64)
        nw, nh = j1 - j0 + 1, i1 - i0 + 1
        n = nw * nh
        owner = np.repeat(np.arange(k.size), n)  # one row per (triangle, cell of its box)
        off = np.arange(owner.size) - np.repeat(np.cumsum(n) - n, n)
        ii = i0[owner] + off // nw[owner]
        jj = j0[owner] + off % nw[owner]
        tk = k[owner]
        yc = top - (ii + 0.5) * res
        xc = left + (jj + 0.5) * res
        A = (ax[tk], ay[tk], az[tk])
        B = (bx[tk], by[tk], bz[tk])
        C = (cx[tk], cy[tk], cz[tk])
        d0 = det[tk]
        l1 = (B[1] - C[1]) * (xc - C[0]) + (C[0] - B[0]) * (yc - C[1])
        l2 = (C[1] - A[1]) * (xc - C[0]) + (A[0] - C[0]) * (yc - C[1])
        neg = d0 < 0
        l1 = np.where(neg, -l1, l1)
        l2 = np.where(neg, -l2, l2)
        d = np.where(neg, -d0, d0)
        l3 = d - l1 - l2
        eps = -1e-9 * np.abs(d0)
        inside = (l1 >= eps) & (l2 >= eps) & (l3 >= eps)
        v = (l1 * A[2] + l2 * B[2] + l3 * C[2]) / d
        inside &= v == v
        # the highest value per cell (sorted by cell, then value: the last of each run)
        lin, v = ii[inside] * width + jj[inside], v[inside]
        o = np.lexsort((v, lin))
        lin, v = lin[o], v[o]
        last = np.r_[lin[1:] != lin[:-1], True] if lin.size else np.zeros(0, bool)
        r, c, v = lin[last] // width, lin[last] % width, v[last]
        old = out[r, c]
        out[r, c] = np.where(np.isnan(old) | (v > old), v, old)
    return drawn


def raster_triangles(px, py, pz, tri, max_edge, left, top, res, height, width, out,
                     max_radius=0.0) -> int:
    """Triangle rasteriser: each triangle's linear surface at the cell centres it covers, kept
    where higher (:func:`_raster_triangles_py`); compiled, or its vectorised numpy twin
    without numba (the same cells and values)."""
    if tri.size and (tri.min() < 0 or tri.max() >= min(px.shape[0], py.shape[0], pz.shape[0])):
        raise ValueError("raster_triangles: a triangle refers to a point that does not exist")
    if out.shape != (height, width):
        raise ValueError(f"raster_triangles: out is {out.shape}, expected {(height, width)}")
    fn = _raster_triangles_nb if HAVE_NUMBA else _raster_triangles_np
    return fn(px, py, pz, tri, float(max_edge), float(left), float(top), float(res),
              int(height), int(width), out, float(max_radius))


# One function on purpose (192 lines): a numba kernel whose triangulation lives in local arrays;
# split, the innermost loop would pass a dozen arrays per call and numba would not inline them.
def _layered_tin_py(px, py, pz, band_end, band_edge, max_radius, left, top, res, height,
                    width, out):
    """Incremental Delaunay triangulation (Bowyer-Watson, walking point location) of points
    given band by band, each band's layer drawn into ``out`` as soon as it is in.

    ``px, py, pz`` are the points in insertion order (local coordinates, in general position:
    see ``chm.tiebreak``), band ``k`` being ``[band_end[k-1], band_end[k])``. After band ``k``
    the triangles of the points inserted so far are drawn with :func:`_draw_triangle_py`, edge
    limit ``band_edge[k]`` and circumradius limit ``max_radius`` (> 0); a triangle drawn for an
    earlier band is not drawn again, and one left out by an earlier band's edge limit is tried
    again only when the limit changes (the surface keeps the highest value, so drawing a
    triangle twice changes nothing). Coincident points keep the highest z.

    Starts from a super-triangle ~1e4 extents away: a triangle of the points can only differ
    from their Delaunay triangulation if its circumcircle reaches a super vertex, far beyond
    ``max_radius``. Returns the number of points inserted, or -1 (point location did not end),
    -2 (a cavity that is not star-shaped: the floating-point predicates failed), -3 (a
    coordinate that is not a number), -4 (a cavity of over 65,536 triangles); the caller then
    uses another triangulator.
    """
    n = px.shape[0]
    X = np.empty(n + 3)
    Y = np.empty(n + 3)
    Z = np.empty(n + 3)
    xmin = ymin = np.inf
    xmax = ymax = -np.inf
    for i in range(n):
        X[i] = px[i]
        Y[i] = py[i]
        Z[i] = pz[i]
        xmin = min(xmin, px[i])
        xmax = max(xmax, px[i])
        ymin = min(ymin, py[i])
        ymax = max(ymax, py[i])
    if n == 0:
        return 0
    ext = max(xmax - xmin, ymax - ymin, 1.0) * 1e4
    mx = 0.5 * (xmin + xmax)
    my = 0.5 * (ymin + ymax)
    X[n], Y[n] = mx - 2.0 * ext, my - ext
    X[n + 1], Y[n + 1] = mx + 2.0 * ext, my - ext
    X[n + 2], Y[n + 2] = mx, my + 2.0 * ext
    Z[n] = Z[n + 1] = Z[n + 2] = 0.0
    cap = 2 * n + 8  # triangles: 2 per point and the super-triangle (int32: 130 B per point)
    tv = np.empty((cap, 3), np.int32)
    tn = np.full((cap, 3), -1, np.int32)
    born = np.full(cap, -1, np.int32)  # band that made the triangle; -1 = free slot
    stamp = np.zeros(cap, np.int32)
    painted = np.zeros(cap, np.uint8)  # drawn already: never drawn again unless a z changed
    big = 1 << 16  # the largest cavity (a few triangles in practice; -4 beyond)
    free = np.empty(big + 8, np.int64)  # a cavity's slots, reused at once by its new triangles
    nfree = 0
    used = 1
    tv[0, 0], tv[0, 1], tv[0, 2] = n, n + 1, n + 2
    born[0] = 0
    zmod = np.full(n + 3, -1, np.int32)  # band in which a coincident point raised the z
    start_of = np.empty(n + 3, np.int32)
    end_of = np.empty(n + 3, np.int32)
    cav = np.empty(big + 8, np.int64)
    ea = np.empty(big + 8, np.int64)
    eb = np.empty(big + 8, np.int64)
    enb = np.empty(big + 8, np.int64)
    eold = np.empty(big + 8, np.int64)  # side of the outside triangle
    newt = np.empty(big + 8, np.int64)
    last = 0
    inserted = 0
    v = 0
    prev_edge = -1.0
    for k in range(band_end.shape[0]):
        while v < band_end[k]:
            qx, qy = X[v], Y[v]
            # walk to the triangle holding the point (rotating the first edge tried)
            t = last
            steps = 0
            while True:
                moved = False
                for j in range(3):
                    e = (j + steps) % 3
                    a = tv[t, (e + 1) % 3]
                    b = tv[t, (e + 2) % 3]
                    if (X[a] - qx) * (Y[b] - qy) - (Y[a] - qy) * (X[b] - qx) < 0.0:
                        t = tn[t, e]
                        moved = True
                        break
                if not moved:
                    break
                steps += 1
                if t < 0 or steps > 4 * n + 1000:
                    return -1
            dup = -1
            for j in range(3):
                u = tv[t, j]
                if X[u] == qx and Y[u] == qy:
                    dup = u
            if dup >= 0:
                if Z[v] > Z[dup] and dup < n:
                    Z[dup] = Z[v]
                    zmod[dup] = k
                v += 1
                continue
            # cavity: triangles whose circumcircle holds the point
            stamp_id = v + 1
            stamp[t] = stamp_id
            cav[0] = t
            ncav = 1
            h = 0
            while h < ncav:
                c = cav[h]
                h += 1
                for j in range(3):
                    nb = tn[c, j]
                    if nb < 0 or stamp[nb] == stamp_id:
                        continue
                    a, b, d = tv[nb, 0], tv[nb, 1], tv[nb, 2]
                    adx, ady = X[a] - qx, Y[a] - qy
                    bdx, bdy = X[b] - qx, Y[b] - qy
                    cdx, cdy = X[d] - qx, Y[d] - qy
                    al = adx * adx + ady * ady
                    bl = bdx * bdx + bdy * bdy
                    cl = cdx * cdx + cdy * cdy
                    det = (adx * (bdy * cl - cdy * bl) - ady * (bdx * cl - cdx * bl)
                           + al * (bdx * cdy - bdy * cdx))
                    if det > 0.0:
                        if ncav >= big:
                            return -4
                        stamp[nb] = stamp_id
                        cav[ncav] = nb
                        ncav += 1
            # its boundary edges, each seen from inside the cavity (counter-clockwise)
            ne = 0
            for h in range(ncav):
                c = cav[h]
                for j in range(3):
                    nb = tn[c, j]
                    if nb >= 0 and stamp[nb] == stamp_id:
                        continue
                    a = tv[c, (j + 1) % 3]
                    b = tv[c, (j + 2) % 3]
                    if (X[a] - qx) * (Y[b] - qy) - (Y[a] - qy) * (X[b] - qx) <= 0.0:
                        return -2
                    if ne >= big + 8:
                        return -4
                    ea[ne] = a
                    eb[ne] = b
                    enb[ne] = nb
                    eold[ne] = 0
                    if nb >= 0:  # which of the outside triangle's sides is this edge
                        for i in range(3):
                            if tn[nb, i] == c:
                                eold[ne] = i
                    ne += 1
            for h in range(ncav):
                born[cav[h]] = -1
                free[nfree] = cav[h]
                nfree += 1
            for h in range(ne):
                if nfree > 0:
                    nfree -= 1
                    nt = free[nfree]
                else:
                    nt = used
                    used += 1
                a, b, nb = ea[h], eb[h], enb[h]
                tv[nt, 0], tv[nt, 1], tv[nt, 2] = a, b, v
                tn[nt, 2] = nb
                born[nt] = k
                stamp[nt] = 0
                painted[nt] = 0
                if nb >= 0:
                    tn[nb, eold[h]] = nt
                start_of[a] = nt
                end_of[b] = nt
                newt[h] = nt
            for h in range(ne):
                nt = newt[h]
                tn[nt, 0] = start_of[tv[nt, 1]]  # across (b, v): the triangle starting at b
                tn[nt, 1] = end_of[tv[nt, 0]]    # across (v, a): the triangle ending at a
            last = newt[0]
            inserted += 1
            v += 1
        # draw this layer: the new triangles, or all of them when the edge limit changed
        edge = band_edge[k]
        redraw = edge != prev_edge
        prev_edge = edge
        for t in range(used):
            if born[t] < 0:
                continue
            a, b, c = tv[t, 0], tv[t, 1], tv[t, 2]
            if a >= n or b >= n or c >= n:
                continue
            if not (born[t] == k or zmod[a] == k or zmod[b] == k or zmod[c] == k):
                # an older triangle: drawn again only when the edge limit changed and it was
                # not drawn yet (its values are the same; the surface keeps the highest)
                if not redraw or painted[t]:
                    continue
            if _draw_triangle(X[a], Y[a], Z[a], X[b], Y[b], Z[b], X[c], Y[c], Z[c], edge,
                              max_radius, left, top, res, height, width, out):
                painted[t] = 1
    return inserted


_layered_tin_nb = _jit(_layered_tin_py)


def layered_tin(px, py, pz, band_end, band_edge, max_radius, left, top, res, height, width,
                out) -> int:
    """Compiled :func:`_layered_tin_py` (numba only; callers use another triangulator when it
    is missing or returns a negative code)."""
    band_end = np.asarray(band_end, np.int64)
    band_edge = np.asarray(band_edge, np.float64)
    if band_end.shape != band_edge.shape or (band_end.size and (
            np.any(np.diff(band_end) < 0) or band_end[-1] != px.shape[0])):
        raise ValueError("layered_tin: bands do not cover the points")
    if not max_radius > 0:
        raise ValueError("layered_tin: needs a circumradius limit > 0")
    if out.shape != (height, width):
        raise ValueError(f"layered_tin: out is {out.shape}, expected {(height, width)}")
    if not (np.isfinite(px).all() and np.isfinite(py).all() and np.isfinite(pz).all()):
        return -3  # the walk and the predicates need numbers
    return _layered_tin_nb(np.ascontiguousarray(px, np.float64),
                           np.ascontiguousarray(py, np.float64),
                           np.ascontiguousarray(pz, np.float64), band_end, band_edge,
                           float(max_radius), float(left), float(top), float(res), int(height),
                           int(width), out)
