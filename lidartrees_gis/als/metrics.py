"""Per-tree measures and crown polygons (seed 000 §4.6): height = highest CHM value in the crown,
crown area A = cells x cell area, crown diameter D = sqrt(4A/π)."""
from __future__ import annotations

import numpy as np

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


def crown_polygons(labels, spec: GridSpec, n: int) -> list:
    """One shapely polygon per crown label 1..n (None for an empty crown), from the label grid
    (4-connected outlines, valid geometries)."""
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
            if not g.is_valid:
                g = shapely.make_valid(g)
            out[k - 1] = max((p for p in g.geoms if p.geom_type == "Polygon"), key=lambda p: p.area)
    return out
