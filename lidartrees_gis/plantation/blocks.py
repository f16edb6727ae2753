"""Planted blocks from the tops, for an area given without its stands (talhões).

A plantation's stands are planted between roads and firebreaks (carreadores, aceiros: open
strips of 4-12 m): every top of a stand lies within about a row spacing of another, and the
tops across a road lie farther apart. :func:`planted_blocks` takes the tops' connected
canopy (a disc of :data:`BLOCK_REACH` row spacings around each top) as one block, on a global grid of :data:`BLOCK_CELL` metres (the same blocks from an area's tiles as
from the whole area). Each block then gets its own planting lattice, as a stand does
(``-spacing auto``). Two plantings with no road between them are one block: its lattice is
the one most of its tops lie on, or none.
"""
from __future__ import annotations

import numpy as np

#: the grid the blocks are drawn on (m)
BLOCK_CELL = 1.0
#: each top reaches this many row spacings: tops closer than twice that are one canopy (a
#: stand's neighbours across a row, and along a row over a missing tree or two), tops across
#: a road or firebreak are not
BLOCK_REACH = 0.75
#: a block reaches this many row spacings beyond its canopy (not into another block): the
#: planting positions of its outer rows whose trees the first tops missed
BLOCK_MARGIN = 0.5
#: a block holds at least this many tops (a planting lattice needs about as many) ...
BLOCK_MIN_TOPS = 150
#: ... and this area (m²)
BLOCK_MIN_AREA = 2500.0


def planted_blocks(x, y, row_spacing: float, *, cell: float = BLOCK_CELL,
                   min_tops: int = BLOCK_MIN_TOPS, min_area: float = BLOCK_MIN_AREA) -> list:
    """The planted blocks of tops ``x, y`` (m) whose rows lie ``row_spacing`` m apart:
    polygons (shapely), largest first.

    The tops mark cells of a grid of ``cell`` m aligned on multiples of ``cell``; a disc of
    :data:`BLOCK_REACH` row spacings around each (tops closer than twice that joined), the
    holes filled, is the canopy; each 8-connected part of it with ``min_tops`` tops and ``min_area``
    m² is a block, grown by :data:`BLOCK_MARGIN` row spacings into the cells no block holds.

    Examples
    --------
    >>> gx, gy = np.meshgrid(np.arange(0, 60, 2.0), np.arange(0, 60, 3.0))
    >>> x = np.r_[gx.ravel(), gx.ravel() + 70]; y = np.r_[gy.ravel(), gy.ravel()]
    >>> len(planted_blocks(x, y, 3.0, min_tops=100, min_area=1000))
    2
    """
    import rasterio.features
    import shapely
    from affine import Affine
    from scipy import ndimage

    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < min_tops:
        return []
    k = max(1, int(round(BLOCK_REACH * row_spacing / cell)))
    grow = BLOCK_MARGIN * row_spacing
    pad = 2 * k + int(np.ceil(grow / cell)) + 1
    c0 = np.floor(x.min() / cell) - pad
    r0 = np.floor(y.min() / cell) - pad
    cols = (np.floor(x / cell) - c0).astype(np.int64)
    rows = (np.floor(y / cell) - r0).astype(np.int64)
    shape = (int(rows.max()) + pad + 1, int(cols.max()) + pad + 1)
    occ = np.zeros(shape, bool)
    occ[rows, cols] = True
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    disc = xx ** 2 + yy ** 2 <= k * k
    canopy = ndimage.binary_fill_holes(ndimage.binary_dilation(occ, disc))
    lab, n = ndimage.label(canopy, structure=np.ones((3, 3), bool))
    if n == 0:
        return []
    tops = np.bincount(lab[rows, cols], minlength=n + 1)
    area = np.bincount(lab.ravel(), minlength=n + 1) * cell * cell
    keep = [i for i in range(1, n + 1) if tops[i] >= min_tops and area[i] >= min_area]
    if not keep:
        return []
    lab = np.where(np.isin(lab, keep), lab, 0)
    # each block grows by ``grow`` into the cells no block holds, the nearest block's
    dist, (ri, ci) = ndimage.distance_transform_edt(lab == 0, return_indices=True)
    lab = np.where((lab == 0) & (dist * cell <= grow), lab[ri, ci], lab)
    # rows of the grid grow northwards here: the transform's y step is +cell
    tr = Affine(cell, 0.0, c0 * cell, 0.0, cell, r0 * cell)
    polys = []
    for i in sorted(keep, key=lambda i: -area[i]):
        mask = lab == i
        parts = [shapely.geometry.shape(g) for g, _ in
                 rasterio.features.shapes(mask.astype(np.uint8), mask=mask, transform=tr,
                                          connectivity=8)]
        polys.append(shapely.make_valid(shapely.union_all(parts)))
    return polys


def block_ids(n: int) -> tuple:
    """The ids of ``n`` blocks: ``B01``, ``B02``, ... (as wide as ``n`` needs)."""
    width = max(2, len(str(n)))
    return tuple(f"B{i + 1:0{width}d}" for i in range(n))


#: :func:`off_rows_share` reads the tops on squares of this side (m), aligned on its multiples ...
OFF_ROWS_CELL = 30.0
#: ... those holding at least this many of them
OFF_ROWS_MIN_TOPS = 30
#: a square is off the rows when its tops' mean ``cos(2 pi j)`` (``j`` their row in row
#: spacings) is under this share of the squares' median: on the rows the mean is about the
#: same everywhere (0.2-0.6 with the tops' scatter), off them it is 0 +- 1/sqrt(2 n)
OFF_ROWS_LEVEL = 0.4
#: a stand (or block) whose squares off its lattice's rows hold more than this share of its
#: tops has no lattice: it holds more than one planting, or rows that bend
OFF_ROWS_MAX = 0.1


def off_rows_share(grid, x, y) -> float:
    """The share of the tops ``x, y`` of a stand that lie on squares off the rows of its
    lattice ``grid`` (a :class:`~lidartrees_gis.plantation.lattice.PlantingGrid`): the part of
    the stand another planting holds, with its own rows (two plantings with no road between
    them, one block), or where the rows bend (contour planting). Squares of
    :data:`OFF_ROWS_CELL` m with :data:`OFF_ROWS_MIN_TOPS` tops; 0 when fewer than three."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < 3 * OFF_ROWS_MIN_TOPS:
        return 0.0
    _, j = grid.to_lattice(x, y)
    c = np.cos(2.0 * np.pi * j)
    key = np.floor(x / OFF_ROWS_CELL).astype(np.int64) * 1_000_003 + \
        np.floor(y / OFF_ROWS_CELL).astype(np.int64)
    _, inv, n = np.unique(key, return_inverse=True, return_counts=True)
    mean = np.bincount(inv, weights=c) / n
    ok = n >= OFF_ROWS_MIN_TOPS
    if ok.sum() < 3:
        return 0.0
    level = OFF_ROWS_LEVEL * float(np.median(mean[ok]))
    return float(n[ok & (mean < level)].sum() / n[ok].sum())
