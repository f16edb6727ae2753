"""Optional numba acceleration for measured hot loops, with pure-numpy fallbacks.

``HAVE_NUMBA`` says whether the compiled kernels are used. Every kernel has a numpy twin with
the same results so the library also runs where numba is not installed (e.g. QGIS's Python).
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


def _jit(fn):
    if HAVE_NUMBA:
        return numba.njit(cache=True, nogil=True)(fn)
    return None


def _accumulate_py(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm):
    """One pass: cell index of every point, then count / max / min / sum per cell.

    Arrays ``count``, ``mx``, ``mn``, ``sm`` of length 0 are skipped. Returns the number of points that fall
    outside the grid.
    """
    outside = 0
    do_max = mx.shape[0] > 0
    do_min = mn.shape[0] > 0
    do_sum = sm.shape[0] > 0
    do_count = count.shape[0] > 0
    inv = 1.0 / res
    for i in range(x.shape[0]):
        fc = (x[i] - left) * inv + eps
        fr = (y[i] - bottom) * inv + eps
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


def accumulate(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm) -> int:
    """Fused gridding kernel (numba only; callers use the numpy path when it is missing)."""
    n = height * width
    if not (x.shape[0] == y.shape[0] == z.shape[0]) or any(
            a.shape[0] not in (0, n) for a in (count, mx, mn, sm)) or not res > 0:
        raise ValueError("accumulate: arrays do not match the grid")
    return _accumulate_nb(x, y, z, left, bottom, res, height, width, eps, count, mx, mn, sm)


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


def _raster_triangles_py(px, py, pz, tri, max_edge, left, top, res, height, width, out,
                         max_radius=0.0):
    """Linear interpolation of each triangle at the cell centres it covers, kept where higher
    than ``out`` (NaN in ``out`` counts as lowest). Triangles with an edge longer than
    ``max_edge`` (> 0) or a circumradius larger than ``max_radius`` (> 0) are skipped. Returns
    the number of triangles drawn."""
    drawn = 0
    me2 = max_edge * max_edge
    four_r2 = 4.0 * max_radius * max_radius
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ax, ay, az = px[a], py[a], pz[a]
        bx, by, bz = px[b], py[b], pz[b]
        cx, cy, cz = px[c], py[c], pz[c]
        if max_edge > 0.0:
            if ((ax - bx) ** 2 + (ay - by) ** 2 > me2 or (bx - cx) ** 2 + (by - cy) ** 2 > me2
                    or (cx - ax) ** 2 + (cy - ay) ** 2 > me2):
                continue
        det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if det == 0.0 or not (abs(det) < np.inf):  # degenerate, or a coordinate not a number
            continue
        if max_radius > 0.0:
            # circumradius R = |ab| |bc| |ca| / (2 |det|): kept when R <= max_radius
            e2 = (((ax - bx) ** 2 + (ay - by) ** 2) * ((bx - cx) ** 2 + (by - cy) ** 2)
                  * ((cx - ax) ** 2 + (cy - ay) ** 2))
            if not (e2 <= four_r2 * det * det):
                continue
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
            continue  # no cell centre inside, or not a number
        j0 = int(max(fj0, 0.0))
        i0 = int(max(fi0, 0.0))
        j1 = int(min(fj1, width - 1.0))
        i1 = int(min(fi1, height - 1.0))
        drawn += 1
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
    return drawn


_raster_triangles_nb = _jit(_raster_triangles_py)


def raster_triangles(px, py, pz, tri, max_edge, left, top, res, height, width, out,
                     max_radius=0.0) -> int:
    """Compiled triangle rasteriser (numba only; callers use the numpy path when missing)."""
    if tri.size and (tri.min() < 0 or tri.max() >= min(px.shape[0], py.shape[0], pz.shape[0])):
        raise ValueError("raster_triangles: a triangle refers to a point that does not exist")
    if out.shape != (height, width):
        raise ValueError(f"raster_triangles: out is {out.shape}, expected {(height, width)}")
    return _raster_triangles_nb(px, py, pz, tri, float(max_edge), float(left), float(top),
                                float(res), int(height), int(width), out, float(max_radius))
