"""Which metric cells lie in which stands, and by how much of their area.

A stand's area-based figure is the mean of the predictions of its cells and of the parts of
cells its border cuts off (pieces, their metrics from their own returns), each weighted by its
area: a border along the cells' centres (or a millimetre beside them) does not hand whole
cells to one stand or the other, and a cell across a border does not carry its neighbour's
trees into a stand.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CellShares:
    """Which units (cells, or pieces of cells a border cuts, :func:`cell_shares`) lie in which
    stands: one row per (unit, stand) pair.

    Attributes
    ----------
    cell, stand : ndarray of int
        The unit's index (a cell's flat, row-major index; a piece's after the cells) and the
        stand's.
    weight : ndarray of float
        The unit's area in the stand, in cells (0, 1].
    """

    cell: np.ndarray
    stand: np.ndarray
    weight: np.ndarray

    @classmethod
    def of(cls, cell_stand) -> "CellShares":
        """``cell_stand`` as shares: a :class:`CellShares` as it is, an array of each cell's
        stand index (-1: none) as whole cells."""
        if isinstance(cell_stand, cls):
            return cell_stand
        cs = np.asarray(cell_stand, np.int64).ravel()
        cell = np.flatnonzero(cs >= 0)
        return cls(cell, cs[cell], np.ones(cell.size))

    def means(self, v, n_stands: int) -> tuple:
        """``(area-weighted mean of the units' finite v per stand, their summed weight)``;
        ``v`` one value a unit (the cells', then the pieces')."""
        v = np.asarray(v, float).ravel()[self.cell]
        ok = np.isfinite(v)
        s = np.bincount(self.stand[ok], weights=self.weight[ok] * v[ok], minlength=n_stands)
        c = np.bincount(self.stand[ok], weights=self.weight[ok], minlength=n_stands)
        with np.errstate(invalid="ignore", divide="ignore"):
            return s / np.where(c > 0, c, np.nan), c


def cell_shares(spec, geoms) -> tuple:
    """Which cells of ``spec`` lie in which polygons: ``(CellShares, pieces, piece_cell)``.

    A cell wholly inside a polygon is the unit of its pair (``cell`` its flat index, weight
    1); a cell a border crosses is cut into its parts in each polygon, ``pieces`` (an array of
    polygons), and the pair's unit is ``spec.width * spec.height + j`` for piece ``j``, weight
    its share of the cell's area; ``piece_cell`` the flat index of each piece's cell. A
    piece's metrics are those of its own returns: a cell
    across a border holds two stands' trees, and its prediction is neither's."""
    import shapely

    res = float(spec.res)
    n_cells = spec.width * spec.height
    units, stands, weights, pieces, of_cell = [], [], [], [], []
    for k, g in enumerate(np.asarray(geoms, dtype=object)):
        if g is None or g.is_empty:
            continue
        x0, y0, x1, y1 = shapely.bounds(g)
        c0 = max(int(np.floor((x0 - spec.left) / res)), 0)
        c1 = min(int(np.floor((x1 - spec.left) / res)), spec.width - 1)
        r0 = max(int(np.floor((spec.top - y1) / res)), 0)
        r1 = min(int(np.floor((spec.top - y0) / res)), spec.height - 1)
        if c1 < c0 or r1 < r0:
            continue
        rr, cc = (a.ravel() for a in np.mgrid[r0:r1 + 1, c0:c1 + 1])
        left, top = spec.left + cc * res, spec.top - rr * res
        boxes = shapely.box(left, top - res, left + res, top)
        shapely.prepare(g)
        whole = shapely.contains(g, boxes)
        part = np.flatnonzero(~whole & shapely.intersects(g, boxes))
        cut = shapely.intersection(boxes[part], g)
        w = shapely.area(cut) / (res * res)
        on = w > 1e-9
        part, cut, w = part[on], cut[on], np.minimum(w[on], 1.0)
        start = n_cells + sum(len(p) for p in pieces)
        units += [rr[whole] * spec.width + cc[whole], start + np.arange(part.size)]
        stands.append(np.full(int(whole.sum()) + part.size, k, np.int64))
        weights += [np.ones(int(whole.sum())), w]
        pieces.append(cut)
        of_cell.append(rr[part] * spec.width + cc[part])
    if not stands:
        return (CellShares(np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0)),
                np.empty(0, dtype=object), np.empty(0, np.int64))
    return (CellShares(np.concatenate(units).astype(np.int64), np.concatenate(stands),
                       np.concatenate(weights)),
            np.concatenate(pieces), np.concatenate(of_cell).astype(np.int64))
