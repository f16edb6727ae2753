"""Per-tree measures and crown polygons (seed 000 §4.6): height = highest CHM value in the crown,
crown area A = cells x cell area, crown diameter D = sqrt(4A/π)."""
from __future__ import annotations

import numpy as np

from .._accel import HAVE_NUMBA, _jit
from ..grid import GridSpec


def tree_ids(x, y, res: float) -> np.ndarray:
    """Tree ids that stay unique across tiles: from the top's cell in the global grid of cell
    size ``res`` (``floor(y/res) * 10**8 + floor(x/res)``)."""
    gx = np.floor(np.asarray(x) / res + 1e-9).astype(np.int64)
    gy = np.floor(np.asarray(y) / res + 1e-9).astype(np.int64)
    return gy * 100_000_000 + gx


def tree_table(labels, rows, cols, chm, spec: GridSpec) -> dict:
    """Per-tree table for crowns ``labels`` (crown ``i + 1`` grown from top ``rows[i], cols[i]``).

    Returns a dict of equal-length arrays: ``tree_id, x, y, row, col, height, crown_area,
    crown_diameter, n_cells``. ``height`` is the highest ``chm`` value inside the crown.
    """
    rows = np.asarray(rows, np.int64)
    cols = np.asarray(cols, np.int64)
    n = rows.size
    lab = np.asarray(labels).ravel()
    n_cells = np.bincount(lab, minlength=n + 1)[1:n + 1]
    h = np.full(n + 1, -np.inf)
    vals = np.asarray(chm, dtype=np.float64).ravel()
    m = (lab > 0) & np.isfinite(vals)
    np.maximum.at(h, lab[m], vals[m])
    height = h[1:n + 1]
    x, y = spec.xy(rows, cols)
    area = n_cells * spec.cell_area
    return {
        "tree_id": tree_ids(x, y, spec.res), "x": x, "y": y, "row": rows, "col": cols,
        "height": np.where(np.isfinite(height), height, np.nan), "crown_area": area,
        "crown_diameter": np.sqrt(4.0 * area / np.pi), "n_cells": n_cells,
    }


# ---------------------------------------------------------------------------------------------
# crown outlines: the boundaries of the label grid's 4-connected regions, traced in one pass
# Directed boundary edges keep their crown on the left (outer rings counter-clockwise in map
# coordinates, holes clockwise). An edge starts at a cell corner (r, c) and goes in direction
# 0: -x (column - 1), 1: +x, 2: -y (row + 1), 3: +y (row - 1).
_DR = (0, 0, 1, -1)
_DC = (-1, 1, 0, 0)
_LEFT = (2, 3, 1, 0)   # the direction after a left turn
_RIGHT = (3, 2, 0, 1)  # and after a right turn


def _lab_at(lab, r, c):
    h, w = lab.shape
    if r < 0 or r >= h or c < 0 or c >= w:
        return 0
    return lab[r, c]


def _is_edge(lab, r, c, d, k):
    """Whether the edge from corner (r, c) in direction ``d`` has crown ``k`` on its left and
    another label on its right."""
    if d == 0:
        return _lab_at(lab, r, c - 1) == k and _lab_at(lab, r - 1, c - 1) != k
    if d == 1:
        return _lab_at(lab, r - 1, c) == k and _lab_at(lab, r, c) != k
    if d == 2:
        return _lab_at(lab, r, c) == k and _lab_at(lab, r, c - 1) != k
    return _lab_at(lab, r - 1, c - 1) == k and _lab_at(lab, r - 1, c) != k


def _trace_py(lab, n, vr, vc, ring_lab, ring_end, ring_area, ring_pinch):
    """Every boundary ring of labels 1..n: its vertices (corners where it turns; ``vr, vc``,
    the first repeated at the end), label, end offset and signed area (cells; > 0 an outer
    ring). Rings start at the top side of the first cell of a run along a row; at a corner
    where two cells of one crown touch diagonally the ring turns left (round its own cell), so
    the pieces are 4-connected, as GDAL's polygonize with connectivity 4, and ``ring_pinch``
    says the ring passed such a corner (elsewhere a crown's rings share no vertex, so its
    polygon is valid). Returns the number of rings, or -1 when the buffers are too small."""
    h, w = lab.shape
    used = np.zeros((h + 1) * (w + 1) * 4, np.uint8)
    nv = 0
    nring = 0
    cap = vr.shape[0]
    wr = np.empty(16, np.int64)  # one ring's edges, grown on demand
    wc = np.empty(16, np.int64)
    wd = np.empty(16, np.int64)
    for i in range(h):
        for j in range(w):
            k = lab[i, j]
            if k < 1 or k > n or _lab_at(lab, i - 1, j) == k:
                continue
            e = ((i * (w + 1)) + j + 1) * 4  # the top side: from corner (i, j + 1), -x
            if used[e]:
                continue
            r, c, d = i, j + 1, 0
            m = 0
            pinch = False
            while True:
                used[((r * (w + 1)) + c) * 4 + d] = 1
                if m == wr.shape[0]:
                    wr2 = np.empty(2 * m, np.int64)
                    wc2 = np.empty(2 * m, np.int64)
                    wd2 = np.empty(2 * m, np.int64)
                    wr2[:m] = wr
                    wc2[:m] = wc
                    wd2[:m] = wd
                    wr, wc, wd = wr2, wc2, wd2
                wr[m] = r
                wc[m] = c
                wd[m] = d
                m += 1
                r += _DR[d]
                c += _DC[d]
                if _is_edge(lab, r, c, _LEFT[d], k):
                    if _is_edge(lab, r, c, _RIGHT[d], k):
                        pinch = True  # the crown's cells touch diagonally here
                    d = _LEFT[d]
                elif not _is_edge(lab, r, c, d, k):
                    d = _RIGHT[d]
                if r == i and c == j + 1 and d == 0:
                    break
            # the corners where the direction changes, and the shoelace area (in cells)
            area2 = 0
            first = nv
            for q in range(m):
                p = q - 1 if q > 0 else m - 1
                nq = q + 1 if q + 1 < m else 0
                area2 += wc[q] * (-wr[nq]) - wc[nq] * (-wr[q])
                if wd[q] != wd[p]:
                    if nv >= cap - 1:
                        return -1
                    vr[nv] = wr[q]
                    vc[nv] = wc[q]
                    nv += 1
            vr[nv] = vr[first]
            vc[nv] = vc[first]
            nv += 1
            if nring >= ring_lab.shape[0]:
                return -1
            ring_lab[nring] = k
            ring_end[nring] = nv
            ring_area[nring] = area2 // 2
            ring_pinch[nring] = pinch
            nring += 1
    return nring


def _wkb_py(xb, yb, ring_start, ring_size, rid, pstart, poff, out):
    """Polygons as little-endian WKB into ``out`` (what ``shapely.to_wkb`` writes): polygon
    ``k`` has the rings ``rid[pstart[k]:pstart[k + 1]]`` (outer first), ring ``r`` the vertices
    ``ring_start[r]`` .. ``+ ring_size[r]`` of ``xb, yb`` (the coordinates' float64 bits as
    uint64), and takes ``out[poff[k]:poff[k + 1]]``."""
    m = np.uint64(255)
    for k in range(pstart.shape[0] - 1):
        o = poff[k]
        nr = pstart[k + 1] - pstart[k]
        out[o] = 1  # little endian
        out[o + 1] = 3  # polygon
        out[o + 2] = out[o + 3] = out[o + 4] = 0
        for i in range(4):
            out[o + 5 + i] = (nr >> (8 * i)) & 255
        o += 9
        for j in range(pstart[k], pstart[k + 1]):
            r = rid[j]
            n = ring_size[r]
            for i in range(4):
                out[o + i] = (n >> (8 * i)) & 255
            o += 4
            for v in range(ring_start[r], ring_start[r] + n):
                bx, by = xb[v], yb[v]
                for i in range(8):
                    out[o + i] = (bx >> np.uint64(8 * i)) & m
                    out[o + 8 + i] = (by >> np.uint64(8 * i)) & m
                o += 16
    return 0


if HAVE_NUMBA:
    _lab_at = _jit(_lab_at)
    _is_edge = _jit(_is_edge)
    _trace_nb = _jit(_trace_py)
    _wkb_nb = _jit(_wkb_py)
else:  # pragma: no cover - crown_polygons uses GDAL's polygonize then
    _trace_nb = _trace_py
    _wkb_nb = _wkb_py


def polygons_wkb(x, y, ring_start, ring_size, rid, pstart) -> np.ndarray:
    """WKB (bytes) of polygons given as rings of vertices (see :func:`_wkb_py`), one compiled
    pass instead of building shapely polygons to write them: the same bytes as
    ``shapely.to_wkb`` (tests/test_trees.py)."""
    rid = np.asarray(rid, np.int64)
    pstart = np.asarray(pstart, np.int64)
    size = np.asarray(ring_size, np.int64)
    nb = 4 + 16 * size[rid]  # each ring: its count, then x, y of every vertex
    per = 9 + (np.add.reduceat(nb, pstart[:-1]) if rid.size else np.zeros(0, np.int64))
    per[pstart[1:] == pstart[:-1]] = 9  # (reduceat of an empty group is not 0)
    poff = np.r_[0, np.cumsum(per)].astype(np.int64)
    out = np.empty(int(poff[-1]), np.uint8)
    xb = np.ascontiguousarray(x, np.float64).view(np.uint64)
    yb = np.ascontiguousarray(y, np.float64).view(np.uint64)
    _wkb_nb(xb, yb, np.asarray(ring_start, np.int64), size, rid, pstart, poff, out)
    mv = out.tobytes()
    return np.array([mv[a:b] for a, b in zip(poff[:-1].tolist(), poff[1:].tolist())]
                    + [None], dtype=object)[:-1]


def outline_rings(labels, n: int):
    """The boundary rings of crowns 1..n of a label grid: ``(rows, cols, ring_label,
    ring_end, ring_area, ring_pinch)`` (corner coordinates, rings closed; area in cells, > 0
    outer; whether the ring passes a corner where the crown's cells touch diagonally)."""
    lab = np.ascontiguousarray(labels)
    if lab.dtype.kind not in "iu":
        lab = lab.astype(np.int64)
    h, w = lab.shape
    # a boundary edge lies on a side between two labels (two edges, one per side) or on the
    # grid's border; a ring has at least four edges and one closing vertex
    inner = int((lab[:, 1:] != lab[:, :-1]).sum() + (lab[1:, :] != lab[:-1, :]).sum())
    cap = 3 * (inner + h + w) + 16
    nr = int(min(np.count_nonzero(lab), cap)) + 1
    vr, vc = np.empty(cap, np.int64), np.empty(cap, np.int64)
    ring_lab, ring_end, ring_area = (np.empty(nr, np.int64) for _ in range(3))
    ring_pinch = np.zeros(nr, np.bool_)
    k = _trace_nb(lab, int(n), vr, vc, ring_lab, ring_end, ring_area, ring_pinch)
    if k < 0:  # pragma: no cover - the buffers are sized for the worst case
        raise RuntimeError("crown outlines: buffers too small")
    nv = int(ring_end[k - 1]) if k else 0
    return vr[:nv], vc[:nv], ring_lab[:k], ring_end[:k], ring_area[:k], ring_pinch[:k]


def crown_polygons(labels, spec: GridSpec, n: int, *, wkb: bool = False, boxes: bool = False):
    """One shapely polygon per crown label 1..n (None for an empty crown), from the label grid
    (4-connected outlines, valid geometries; a crown in several pieces gives its largest).
    ``wkb``: each polygon's WKB instead (an object array; what the GeoPackage gets).

    The outlines are traced in one compiled pass (:func:`outline_rings`; GDAL's polygonize
    through rasterio was 5 s of a 16 M point chain at 0.5 m cells, most of it building
    GeoJSON-like lists) and built in one vectorised shapely call; with ``wkb``, the crowns in
    one piece without a diagonal touch (nearly all) go straight from their rings to WKB
    (:func:`polygons_wkb`: building the polygons and writing them was 0.6 s of that chain).
    ``boxes``: also each polygon's bounds, ``(n, 4)`` minx, miny, maxx, maxy (NaN for none):
    what a GeoPackage's spatial index is made of (:mod:`lidartrees_gis.io.gpkg_rtree`);
    returns ``(polygons, bounds)``."""
    import sys

    import shapely

    box = np.full((n, 4), np.nan)
    if not HAVE_NUMBA:
        out = _crown_polygons_gdal(labels, spec, n)
        arr = np.array(out + [None], dtype=object)[:-1]
        if boxes:
            box[:] = shapely.bounds(arr)
        res = shapely.to_wkb(np.r_[arr, [None]])[:-1] if wkb else out
        return (res, box) if boxes else res
    out = np.array([None] * n, dtype=object)
    vr, vc, ring_lab, ring_end, ring_area, ring_pinch = outline_rings(labels, n)
    if ring_lab.size == 0:
        res = out if wkb else out.tolist()
        return (res, box) if boxes else res
    x = spec.left + vc * spec.res
    y = spec.top - vr * spec.res
    starts = np.r_[0, ring_end[:-1]]
    sizes = ring_end - starts
    shells = np.flatnonzero(ring_area > 0)
    n_shells = np.bincount(ring_lab[shells], minlength=n + 1)
    # crowns in one piece: the outer ring first, then the holes (every hole of a crown in one
    # piece lies in that piece)
    one = n_shells[ring_lab] == 1
    order = np.lexsort((ring_area <= 0, ring_lab))
    order = order[one[order]]
    labs = ring_lab[order]
    keys = np.unique(labs)
    # only a crown with a diagonal touch can be invalid (a ring touching itself there)
    pinched = np.isin(keys, ring_lab[ring_pinch])
    direct = ~pinched if wkb and sys.byteorder == "little" else np.zeros(keys.size, bool)
    sel = direct[np.searchsorted(keys, labs)]  # each ring of ``order``: its crown goes direct
    rest = ~sel
    if direct.any():
        dl = labs[sel]
        first = np.flatnonzero(np.r_[True, dl[1:] != dl[:-1]])
        out[keys[direct] - 1] = polygons_wkb(x, y, starts, sizes, order[sel],
                                             np.r_[first, dl.size])
        if boxes:  # a crown in one piece: the bounds of its outer ring (first in ``order``)
            shell = order[sel][first]
            box[keys[direct] - 1] = np.column_stack([
                np.minimum.reduceat(x, starts)[shell], np.minimum.reduceat(y, starts)[shell],
                np.maximum.reduceat(x, starts)[shell], np.maximum.reduceat(y, starts)[shell]])
    # the others as shapely polygons: their rings only
    need = np.zeros(ring_lab.size, bool)
    need[order[rest]] = True
    need |= n_shells[ring_lab] > 1
    rings = np.empty(ring_lab.size, dtype=object)
    if need.any():
        vi = np.repeat(np.arange(ring_lab.size), sizes)
        vsel = need[vi]
        rings[need] = shapely.linearrings(np.column_stack([x[vsel], y[vsel]]),
                                          indices=np.repeat(np.arange(int(need.sum())),
                                                            sizes[need]))
    rkeys = keys[~direct]
    polys = shapely.polygons(rings[order[rest]], indices=np.searchsorted(rkeys, labs[rest])) \
        if rkeys.size else np.empty(0, dtype=object)
    check = np.flatnonzero(pinched[~direct])
    bad = set((rkeys[check[~shapely.is_valid(polys[check])]] - 1).tolist())
    for g, k in zip(polys.tolist(), rkeys.tolist()):
        out[k - 1] = g
    for k in np.flatnonzero(n_shells > 1):  # several pieces: the largest, with its holes
        out[k - 1] = _largest_piece(rings, ring_lab == k, ring_area)
        if not out[k - 1].is_valid:  # pragma: no cover
            bad.add(k - 1)
    bad = sorted(bad)
    fixed = shapely.make_valid(np.array([out[i] for i in bad], dtype=object)) if bad else []
    for i, g in zip(bad, fixed):  # a ring that touches itself: split where it touches
        out[i] = _largest_polygon(g)
    geom = np.array([isinstance(g, shapely.Geometry) for g in out], bool)
    if boxes and geom.any():
        box[geom] = shapely.bounds(out[geom])
    if not wkb:
        return (out.tolist(), box) if boxes else out.tolist()
    if geom.any():
        out[geom] = shapely.to_wkb(out[geom])
    return (out, box) if boxes else out


def _largest_polygon(g):
    """``g`` if a polygon, else the largest polygon in it (a repaired or united crown)."""
    if g.geom_type == "Polygon":
        return g
    return max((p for p in getattr(g, "geoms", [g]) if p.geom_type == "Polygon"),
               key=lambda p: p.area)


def _largest_piece(rings, mine, ring_area):
    """The largest polygon of a crown's rings (several outer rings): each hole goes to the
    smallest outer ring around it."""
    import shapely

    idx = np.flatnonzero(mine)
    shells = [i for i in idx if ring_area[i] > 0]
    holes = [i for i in idx if ring_area[i] < 0]
    parts = {i: [] for i in shells}
    shell_polys = {i: shapely.Polygon(rings[i]) for i in shells}
    for h in holes:
        p = shapely.Polygon(rings[h]).representative_point()
        around = [i for i in shells if shell_polys[i].contains(p)]
        if around:
            parts[min(around, key=lambda i: ring_area[i])].append(rings[h])
    polys = [shapely.Polygon(rings[i], holes=parts[i]) for i in shells]
    return max(polys, key=lambda p: p.area)  # ties: the first traced (raster order)


def _crown_polygons_gdal(labels, spec: GridSpec, n: int) -> list:
    """:func:`crown_polygons` by GDAL's polygonize (rasterio), where numba is not in use (the
    same polygons; tests/test_trees.py compares them)."""
    import shapely
    from rasterio.features import shapes
    from shapely.geometry import shape

    lab = np.asarray(labels).astype(np.int32)
    rings, ring_poly, poly_label, multi = [], [], [], {}
    for geom, val in shapes(lab, mask=lab > 0, connectivity=4, transform=spec.transform):
        k = int(val)
        if k in multi:
            multi[k] = (multi[k] or []) + [shape(geom)]
            continue
        multi[k] = None
        # the polygons are built in one vectorised call below: building each from its
        # GeoJSON-like coordinate lists in Python was a third of the whole chain's polygon time
        for ring in geom["coordinates"]:
            rings.append(np.asarray(ring, dtype=np.float64))
            ring_poly.append(len(poly_label))
        poly_label.append(k)
    out = [None] * n
    if poly_label:
        sizes = np.fromiter((len(r) for r in rings), np.int64, len(rings))
        lr = shapely.linearrings(np.concatenate(rings), indices=np.repeat(np.arange(len(rings)), sizes))
        polys = shapely.polygons(lr, indices=np.asarray(ring_poly))
        bad = ~shapely.is_valid(polys)
        if bad.any():
            polys[bad] = shapely.make_valid(polys[bad])
        for g, k in zip(polys, poly_label):
            if 1 <= k <= n:
                out[k - 1] = g
        check = {k for k, b in zip(poly_label, bad) if b}
    else:
        check = set()
    for k, extra in multi.items():  # a crown in several parts: the union of its parts
        if extra is not None and 1 <= k <= n:
            out[k - 1] = shapely.union_all([out[k - 1]] + extra)
            check.add(k)
    for k in check:  # and of a crown that is not one polygon, its largest polygon
        g = out[k - 1] if 1 <= k <= n else None
        if g is not None and g.geom_type != "Polygon" and hasattr(g, "geoms"):
            out[k - 1] = _largest_polygon(g if g.is_valid else shapely.make_valid(g))
    return out
