"""Compiled passes over rasters for the chain's cell-by-cell steps, with numpy twins.

Measured on 16 M points at 0.5 m cells (benchmarks/bench_chain.py, one core), two scipy calls
were 4.7 s of the chain: the data footprint (a Euclidean distance transform of the whole grid
to answer "is a point within 2 m") and the bilinear DTM sample at every point
(``map_coordinates``). Each is one pass here (a compiled NaN-aware Gaussian smoothing was
tried too: no faster than scipy's two convolutions).
"""
from __future__ import annotations

import math

import numpy as np

from ._accel import HAVE_NUMBA, _jit


def _near_py(occ, reach, out):
    """``out[i, j]`` = some ``occ`` cell at row offset ``a`` has a column offset of at most
    ``reach[|a|]`` (``reach[a] < 0``: none at that row offset)."""
    h, w = occ.shape
    r = reach.shape[0] - 1
    big = 1 << 40  # no occupied cell in the row (beyond any reach)
    gap = np.empty((h, w), np.int64)  # column distance to the nearest occupied cell of the row
    for i in range(h):
        d = big
        for j in range(w):
            d = 0 if occ[i, j] else min(d + 1, big)
            gap[i, j] = d
        d = big
        for j in range(w - 1, -1, -1):
            d = 0 if occ[i, j] else min(d + 1, big)
            if d < gap[i, j]:
                gap[i, j] = d
    for i in range(h):
        for j in range(w):
            hit = False
            for a in range(-r, r + 1):
                ii = i + a
                if ii < 0 or ii >= h:
                    continue
                m = reach[abs(a)]
                if m >= 0 and gap[ii, j] <= m:
                    hit = True
                    break
            out[i, j] = hit


_near_nb = _jit(_near_py)


def within_distance(occupied, res: float, distance: float) -> np.ndarray:
    """Cells whose centre is within ``distance`` (m) of the centre of an ``occupied`` cell:
    scipy's ``distance_transform_edt(~occupied) * res <= distance``, the same cells (the
    offsets allowed are decided with the same expression), in one compiled pass."""
    occ = np.ascontiguousarray(occupied, dtype=bool)
    if not HAVE_NUMBA:
        from scipy import ndimage

        return ndimage.distance_transform_edt(~occ) * res <= distance
    r = int(math.floor(distance / res)) + 1
    reach = np.full(r + 1, -1, np.int64)
    for a in range(r + 1):
        b = np.arange(r + 2)
        ok = np.sqrt((a * a + b * b).astype(np.float64)) * res <= distance
        reach[a] = int(b[ok].max()) if ok.any() else -1
    out = np.empty(occ.shape, bool)
    _near_nb(occ, reach, out)
    return out


def _bilinear_at_py(grid, fr, fc):
    """Bilinear value of cell-centre ``grid`` at fractional row ``fr`` and column ``fc`` (0 =
    the first cell's centre), edges clamped. The ground filter's residuals use it too."""
    h, w = grid.shape
    r0 = min(max(int(math.floor(fr)), 0), h - 1)
    c0 = min(max(int(math.floor(fc)), 0), w - 1)
    r1 = min(r0 + 1, h - 1)
    c1 = min(c0 + 1, w - 1)
    ty = min(max(fr - r0, 0.0), 1.0)
    tx = min(max(fc - c0, 0.0), 1.0)
    t = grid[r0, c0] * (1.0 - tx) + grid[r0, c1] * tx
    b = grid[r1, c0] * (1.0 - tx) + grid[r1, c1] * tx
    return t * (1.0 - ty) + b * ty


bilinear_at = _jit(_bilinear_at_py) or _bilinear_at_py


def _sample_py(grid, row, col, out):
    """:func:`bilinear_at` at every (row, col)."""
    for i in range(row.shape[0]):
        out[i] = bilinear_at(grid, row[i], col[i])


_sample_nb = _jit(_sample_py)


def sample_bilinear(grid, row, col) -> np.ndarray:
    """Bilinear sample of a cell-centre grid at fractional (row, col) positions (0 = the first
    cell's centre), edges clamped (scipy's ``map_coordinates(order=1, mode="nearest")``)."""
    g = np.ascontiguousarray(grid, np.float64)
    row = np.ascontiguousarray(row, np.float64)
    col = np.ascontiguousarray(col, np.float64)
    if g.ndim != 2 or not g.size:
        raise ValueError(f"sample_bilinear: needs a 2-D grid with cells, got shape {g.shape}")
    if HAVE_NUMBA:
        out = np.empty(row.shape[0])
        _sample_nb(g, row, col, out)
        return out
    return bilinear_np(g, row, col)


def bilinear_np(g, row, col) -> np.ndarray:
    """:func:`bilinear_at` at every (row, col), numpy (the same operations)."""
    h, w = g.shape
    r0 = np.clip(np.floor(row), 0, h - 1).astype(np.int64)
    c0 = np.clip(np.floor(col), 0, w - 1).astype(np.int64)
    r1 = np.minimum(r0 + 1, h - 1)
    c1 = np.minimum(c0 + 1, w - 1)
    ty = np.clip(row - r0, 0.0, 1.0)
    tx = np.clip(col - c0, 0.0, 1.0)
    t = g[r0, c0] * (1.0 - tx) + g[r0, c1] * tx
    b = g[r1, c0] * (1.0 - tx) + g[r1, c1] * tx
    return t * (1.0 - ty) + b * ty
