"""Grids: one aligned grid specification, points to per-cell statistics, gap filling, DSM/DTM/CHM.

Cell convention: cell ``(row, col)`` holds the points with
``left + col*res <= x < left + (col+1)*res`` and ``top - (row+1)*res <= y < top - row*res``
(half-open towards east and north): a point exactly on a cell edge goes to the cell east (x) or
north (y) of that edge, and the grid is extended by one cell when a point sits
on its far east/north edge, so no point is ever dropped. ``left`` and ``top`` are multiples of the
resolution, so grids from different runs and tiles line up cell for cell.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from . import _accel
from .errors import InputError
from .progress import as_progress, check_cancel

#: tolerance (in cells) for deciding that a coordinate sits on a cell edge: above the rounding
#: of x / res at map coordinates (northings of 10^7 m over 0.25 m cells: 4e-8), far below
#: the coordinates' own precision
EDGE_EPS = 1e-6
STATS = ("max", "min", "mean", "count")


@dataclass(frozen=True)
class GridSpec:
    """A north-up grid: upper-left corner, square cell size, shape and CRS.

    Attributes
    ----------
    left, top : float
        Map coordinates of the upper-left corner (multiples of ``res`` when made by
        :meth:`from_bounds`).
    res : float
        Cell size in map units (metres).
    width, height : int
        Columns and rows.
    crs : pyproj.CRS or None
    """

    left: float
    top: float
    res: float
    width: int
    height: int
    crs: object = None

    @classmethod
    def from_bounds(cls, xmin, ymin, xmax, ymax, res, crs=None, *,
                    closed_top: bool = False) -> "GridSpec":
        """Smallest grid aligned to multiples of ``res`` that holds every point in the bounds
        (``closed_top``: as :meth:`cell_index` with ``closed_top`` places them)."""
        res = check_resolution(res)
        vals = (xmin, ymin, xmax, ymax)
        if not all(np.isfinite(v) for v in vals) or xmax < xmin or ymax < ymin:
            raise InputError(f"bounds: invalid bounds {vals}")
        inv = 1.0 / res  # the arithmetic of cell_index and of the compiled kernel
        c0 = math.floor(xmin * inv + EDGE_EPS)
        c1 = math.floor(xmax * inv + EDGE_EPS)
        if closed_top:
            r0 = math.ceil(ymin * inv - EDGE_EPS) - 1
            r1 = math.ceil(ymax * inv - EDGE_EPS) - 1
        else:
            r0 = math.floor(ymin * inv + EDGE_EPS)
            r1 = math.floor(ymax * inv + EDGE_EPS)
        width, height = c1 - c0 + 1, r1 - r0 + 1
        if width * height > 2_000_000_000:
            raise InputError(f"-tr: {res} m gives a {width} x {height} grid; use a larger resolution")
        return cls(c0 * res, (r1 + 1) * res, float(res), int(width), int(height), crs)

    @property
    def shape(self) -> tuple:
        return (self.height, self.width)

    @property
    def bounds(self) -> tuple:
        return (self.left, self.top - self.height * self.res, self.left + self.width * self.res, self.top)

    @property
    def transform(self):
        """The affine transform (rasterio convention)."""
        from affine import Affine

        return Affine(self.res, 0.0, self.left, 0.0, -self.res, self.top)

    @property
    def cell_area(self) -> float:
        return self.res * self.res

    def origin_cells(self) -> tuple:
        """``(column, row)`` of the grid's lower-left cell in the global grid of cells of
        ``res`` (cell ``(i, j)`` holds ``i res <= x < (i + 1) res``), or None for a grid whose
        corner is not on a multiple of ``res`` (a raster from elsewhere)."""
        inv = 1.0 / self.res
        c = self.left * inv
        r = (self.top - self.height * self.res) * inv
        if abs(c - round(c)) < 1e-6 and abs(r - round(r)) < 1e-6:
            return float(round(c)), float(round(r))
        return None

    def cell_index(self, x, y, *, closed_top: bool = False):
        """Row and column of each point (may fall outside ``[0, height) x [0, width)``).

        A point's cell is that of the global grid (``floor(x / res)``), so a point gets the
        same cell in every grid that holds it: the grid of a tile and of the whole area agree
        even for points on cell edges (``floor(x * (1 / res))``, the arithmetic of
        :meth:`from_bounds` and of the compiled kernel). ``closed_top``: a point on a row
        edge belongs to the row below it (rows counted from the top, as lidR's and terra's
        ``cellFromXY`` count them) instead of the row above."""
        o = self.origin_cells()
        x, y = np.asarray(x), np.asarray(y)
        if o is None:  # a grid off the global lattice: from its own corner
            o = (0.0, 0.0)
            x = x - self.left
            y = y - (self.top - self.height * self.res)
        inv = 1.0 / self.res
        col = (np.floor(x * inv + EDGE_EPS) - o[0]).astype(np.int64)
        if closed_top:
            row = (self.height - 1) - (np.ceil(y * inv - EDGE_EPS) - 1 - o[1]).astype(np.int64)
        else:
            row = (self.height - 1) - (np.floor(y * inv + EDGE_EPS) - o[1]).astype(np.int64)
        return row, col

    def xy(self, row, col):
        """Map coordinates of cell centres."""
        x = self.left + (np.asarray(col) + 0.5) * self.res
        y = self.top - (np.asarray(row) + 0.5) * self.res
        return x, y

    def with_crs(self, crs) -> "GridSpec":
        return replace(self, crs=crs)


def check_resolution(res) -> float:
    """Validate a cell size in metres."""
    try:
        r = float(res)
    except (TypeError, ValueError):
        raise InputError(f"-tr: resolution must be a number or 'auto', got {res!r}") from None
    if not np.isfinite(r) or r <= 0:
        raise InputError(f"-tr: resolution must be > 0, got {res!r}")
    if r < 1e-4:
        raise InputError(f"-tr: resolution {res!r} m is below 0.1 mm; cells are in metres")
    if r > MAX_RES:
        raise InputError(f"-tr: resolution {res!r} m is over {MAX_RES:g} m; cells are in metres")
    return r


#: the largest cell size (m): a coarser grid says nothing of trees or terrain
MAX_RES = 1000.0
#: the most bytes the arrays of one grid accumulator may take (and at most half the memory
#: free when it is made)
MAX_GRID_BYTES = 2 * 2 ** 30


def check_grid_memory(cells: int, bytes_per_cell: int, spec=None) -> None:
    """Refuse, before allocating, a grid whose arrays would not fit in memory (a cell size
    far too fine for the extent, or an extent far too large for the cell)."""
    import os

    need = int(cells) * int(bytes_per_cell)
    try:
        free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        free = 2 * MAX_GRID_BYTES
    if need > min(MAX_GRID_BYTES, free // 2):
        shape = f"{spec.width:,} x {spec.height:,} cells of {spec.res:g} m" if spec is not None \
            else f"{int(cells):,} cells"
        raise InputError(f"a grid of {shape} needs {need / 2 ** 30:.1f} GB, more than fits in "
                         f"memory; give a coarser -tr, or process the area in tiles (-tile_size)")


#: more cells per point than this (on grids over a million cells) means points far apart
MAX_CELLS_PER_POINT = 10_000


def check_sparse(cells, n, bounds, res, path="", limit=None):
    """Refuse a grid with far more cells than points (a wrong digit in one coordinate, or files
    kilometres apart): it would take long to fill and mean nothing."""
    limit = MAX_CELLS_PER_POINT if limit is None else limit
    if n and cells > 1_000_000 and cells / n > limit:
        b = bounds
        raise InputError(
            f"{path}: {n:,} points spread over {b[2] - b[0]:.0f} x {b[3] - b[1]:.0f} m "
            f"(x {b[0]:.2f}..{b[2]:.2f}, y {b[1]:.2f}..{b[3]:.2f}) would need {cells:.3g} cells of "
            f"{res:g} m, {cells / n:.0f} per point; check for a wrong digit in a coordinate or "
            "points far from the others")


def auto_resolution(count: int, area: float) -> float:
    """Seed 003's rule: cell size C = sqrt(1 / n), n = points per m².

    >>> auto_resolution(500, 100.0)  # 5 pts/m² -> 0.447 m
    0.447
    """
    if count <= 0 or not area > 0:
        raise InputError("-tr auto: needs a point density; the points cover no area "
                         "(all at one location or on a line); give -tr RES")
    return round(math.sqrt(1.0 / (count / area)), 3)


class GridAccumulator:
    """Per-cell statistics built chunk by chunk: memory is the grids plus one chunk.

    Parameters
    ----------
    spec : GridSpec
    stats : iterable of {"max", "min", "mean", "count"}
    """

    def __init__(self, spec: GridSpec, stats=("max",)):
        self.spec = spec
        self.stats = tuple(stats)
        for s in self.stats:
            if s not in STATS:
                raise InputError(f"-stat: unknown statistic {s!r}; use one of {', '.join(STATS)}")
        n = spec.width * spec.height
        # counts are kept when asked for (count, mean); max/min alone mark empty cells with NaN
        need_count = "count" in self.stats or "mean" in self.stats
        check_grid_memory(n, 8 * (len(self.stats) + need_count), spec)
        self.count = np.zeros(n if need_count else 0, dtype=np.int64)
        # -inf / +inf mark empty cells while accumulating; results turn them into NaN
        self._max = np.full(n, -np.inf) if "max" in self.stats else None
        self._min = np.full(n, np.inf) if "min" in self.stats else None
        self._sum = np.zeros(n) if "mean" in self.stats else None
        self.outside = 0

    def add(self, x, y, z) -> None:
        """Add points (arrays of equal length) to the statistics."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.ascontiguousarray(y, dtype=np.float64)
        z = np.ascontiguousarray(z, dtype=np.float64)
        if _accel.HAVE_NUMBA:
            empty = np.empty(0)
            s = self.spec
            o = s.origin_cells()
            if o is None:  # a grid off the global lattice: from its own corner
                x, y, o = x - s.left, y - (s.top - s.height * s.res), (0.0, 0.0)
            self.outside += _accel.accumulate(
                x, y, z, o[0], o[1], s.res, s.height, s.width, EDGE_EPS,
                self.count, empty if self._max is None else self._max,
                empty if self._min is None else self._min, empty if self._sum is None else self._sum)
            return
        row, col = self.spec.cell_index(x, y)
        ok = (row >= 0) & (row < self.spec.height) & (col >= 0) & (col < self.spec.width)
        if not ok.all():
            self.outside += int((~ok).sum())
            row, col, z = row[ok], col[ok], z[ok]
        idx = row * self.spec.width + col
        if self.count.size:
            self.count += np.bincount(idx, minlength=self.count.size)
        if self._max is not None:
            np.maximum.at(self._max, idx, z)
        if self._min is not None:
            np.minimum.at(self._min, idx, z)
        if self._sum is not None:
            self._sum += np.bincount(idx, weights=z, minlength=self._sum.size)

    def result(self, stat: str) -> np.ndarray:
        """The (height, width) grid of one statistic; empty cells are NaN (count: 0)."""
        shape = self.spec.shape
        if stat == "count":
            if not self.count.size:
                raise InputError("count was not accumulated; ask for stats=('count', ...)")
            return self.count.reshape(shape).copy()
        if stat in ("max", "min"):
            a = (self._max if stat == "max" else self._min).reshape(shape).copy()
            a[np.isinf(a)] = np.nan
            return a
        if stat == "mean":
            with np.errstate(invalid="ignore", divide="ignore"):
                m = self._sum / self.count
            m[self.count == 0] = np.nan
            return m.reshape(shape)
        raise InputError(f"-stat: unknown statistic {stat!r}")


def rasterize(x, y, z, spec: GridSpec, stat: str = "max") -> np.ndarray:
    """Grid points with one statistic per cell (NaN for empty cells, 0 for count)."""
    acc = GridAccumulator(spec, (stat,))
    acc.add(np.asarray(x, float), np.asarray(y, float), np.asarray(z, float))
    return acc.result(stat)


_K8 = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], dtype=np.float64)


def fill_mean8(grid: np.ndarray, *, max_passes: int | None = None, mask=None,
               progress=None) -> np.ndarray:
    """Fill empty (NaN) cells with the mean of their filled 8-neighbours, until none is empty.

    Seed 000, §2.3.1. Each pass is *simultaneous* (Jacobi): every empty cell that has at least
    one filled neighbour takes the mean of the neighbours filled *before* the pass; values filled
    in a pass are used only from the next pass on. The result therefore does not depend on the
    order cells are visited. Cells outside the grid do not count as neighbours.

    Parameters
    ----------
    grid : (M, N) ndarray of float
        NaN marks empty cells.
    max_passes : int, optional
        Stop after this many passes (default: until no empty cell remains).
    mask : (M, N) ndarray of bool, optional
        Only these cells are filled (e.g. the data footprint); the others stay NaN.

    Returns
    -------
    (M, N) ndarray of float64
        A filled copy. A grid with no filled cell at all is returned unchanged (all NaN).

    Examples
    --------
    >>> g = np.array([[1.0, np.nan, 3.0]])
    >>> fill_mean8(g)
    array([[1., 2., 3.]])
    """
    out = np.array(grid, dtype=np.float64, copy=True)
    if mask is not None:
        out[~np.asarray(mask, bool)] = np.nan
    empty = np.isnan(out)
    if mask is not None:
        empty &= np.asarray(mask, bool)
    if not empty.any() or np.isnan(out).all():
        return out
    total = int(empty.sum())
    if _accel.HAVE_NUMBA:  # the same passes, visiting only the cells still empty
        _accel._fill_mean8_nb(out, empty, int(max_passes or 0))
        as_progress(progress).update(1.0, "filling gaps")
        return out
    passes = 0
    while empty.any():
        check_cancel(progress)
        filled = ~empty
        vals = np.where(filled, out, 0.0)
        s = ndimage.convolve(vals, _K8, mode="constant", cval=0.0)
        n = ndimage.convolve(filled.astype(np.float64), _K8, mode="constant", cval=0.0)
        take = empty & (n > 0)
        if not take.any():  # the rest cannot be reached (outside the mask)
            break
        out[take] = s[take] / n[take]
        empty &= ~take
        passes += 1
        as_progress(progress).update(1.0 - empty.sum() / total, "filling gaps")
        if max_passes is not None and passes >= max_passes:
            break
    return out


def fill_gaps(grid: np.ndarray, method: str = "mean8", progress=None, mask=None) -> np.ndarray:
    """Fill empty cells by ``method``: ``mean8`` (seed 000) or ``none``; with ``mask`` only
    those cells are filled and the others are set to NaN."""
    if method in (None, "none"):
        out = np.asarray(grid, dtype=np.float64)
        if mask is not None:
            out = np.where(mask, out, np.nan)
        return out
    if method == "mean8":
        return fill_mean8(grid, progress=progress, mask=mask)
    raise InputError(f"-fill: unknown method {method!r}; use mean8 or none")


def data_footprint(occupied, res: float, distance: float = 2.0) -> np.ndarray:
    """Cells within ``distance`` metres (at least one cell) of a cell that holds points: where
    surfaces are filled and trees looked for; beyond it there are no data (outside the survey,
    between files, water without returns) and the grids hold nodata."""
    occ = np.asarray(occupied, bool)
    if occ.all() or not occ.any():
        return occ.copy() if not occ.any() else np.ones(occ.shape, bool)
    from ._raster import within_distance

    return within_distance(occ, res, max(distance, res * 1.01))


class LowestPoints:
    """The lowest point (x, y, z) of every cell, built chunk by chunk (for ``-dtm lowest:R``)."""

    def __init__(self, spec: GridSpec):
        self.spec = spec
        n = spec.width * spec.height
        check_grid_memory(n, 32, spec)
        self.z = np.full(n, np.inf)
        self.x = np.zeros(n)
        self.y = np.zeros(n)
        self.count = np.zeros(n, np.int64)

    def add(self, x, y, z) -> None:
        row, col = self.spec.cell_index(x, y)
        ok = (row >= 0) & (row < self.spec.height) & (col >= 0) & (col < self.spec.width)
        idx = (row * self.spec.width + col)[ok]
        x, y, z = np.asarray(x)[ok], np.asarray(y)[ok], np.asarray(z)[ok]
        if not idx.size:
            return
        if _accel.HAVE_NUMBA:
            _accel.lowest(idx.astype(np.int64), x.astype(np.float64), y.astype(np.float64),
                          z.astype(np.float64), self.z, self.x, self.y, self.count)
            return
        self.count += np.bincount(idx, minlength=self.count.size)
        # ties in z go to the lowest x, then y: the same point whatever the order of the file
        order = np.lexsort((y, x, z, idx))
        first = np.ones(order.size, bool)
        first[1:] = idx[order][1:] != idx[order][:-1]
        sel = order[first]
        k = idx[sel]
        zs, xs, cz, cx = z[sel], x[sel], self.z[k], self.x[k]
        better = (zs < cz) | ((zs == cz) & ((xs < cx) | ((xs == cx) & (y[sel] < self.y[k]))))
        k, sel = k[better], sel[better]
        self.z[k], self.x[k], self.y[k] = z[sel], x[sel], y[sel]

    def median(self) -> float | None:
        """The median number of points per non-empty cell (None: no point)."""
        m = self.count > 0
        return float(np.median(self.count[m])) if m.any() else None

    def points(self, min_share: float = 0.25, reference: float | None = None):
        """``(x, y, z)`` of the lowest point of each cell holding at least ``min_share`` of
        ``reference`` points (default: the median number per non-empty cell): cells cut by the
        data's edge hold a few points that are often not ground."""
        m = self.count > 0
        if m.any():
            ref = self.median() if reference is None else reference
            m &= self.count >= min_share * ref
        return self.x[m], self.y[m], self.z[m]


#: largest grid (cells) made in memory; larger areas go through tiles (about 30 bytes a cell)
MAX_CELLS = 200_000_000


def grid_spec_for(src, res: float, progress=None) -> GridSpec:
    """The aligned grid that holds every point of ``src`` (a point source: its CRS, header
    bounds, count or a scan): refused when its CRS is geographic
    (cells must be metres) or when it would exceed :data:`MAX_CELLS`."""
    from .crs import crs_label
    from .errors import CRSError

    crs = src.crs
    if crs is not None and getattr(crs, "is_geographic", False):
        raise CRSError(f"{src.path}: the points are in a geographic CRS ({crs_label(crs)}, "
                       "degrees); grids need metres: give -t_srs with a projected CRS, e.g. "
                       "-t_srs EPSG:31984 (SIRGAS 2000 / UTM 24S)")
    b = src.header_bounds()
    if b is None:
        b = src.scan(progress).bounds
    w, h = (b[2] - b[0]) / res, (b[3] - b[1]) / res
    if w * h > MAX_CELLS:
        raise InputError(
            f"{src.path}: a {res:g} m grid over {b[2] - b[0]:.0f} x {b[3] - b[1]:.0f} m would hold "
            f"{w * h:.3g} cells (limit {MAX_CELLS:.0e}); check -tr, or the extent (a wrong digit "
            f"in a coordinate, or points far apart: x {b[0]:.2f}..{b[2]:.2f}, y {b[1]:.2f}.."
            f"{b[3]:.2f}); large areas are processed in tiles with -tile_size")
    n = src.count_hint
    check_sparse(w * h, n, b, res, src.path)
    return GridSpec.from_bounds(*b, res, crs=src.crs)


def resolve_resolution(src, res, progress=None) -> float:
    """A cell size in metres from ``res``: a number, or ``"auto"`` for seed 003's sqrt(1/n) from
    the point density of ``src`` (a point source: its header's count and bounds, else a scan)."""
    if res is None:
        raise InputError("-tr: a resolution is required (a number in metres, or auto)")
    if isinstance(res, str) and res.strip().lower() == "auto":
        hb = src.header_bounds()
        if hb is not None and src.count_hint:
            return auto_resolution(src.count_hint, (hb[2] - hb[0]) * (hb[3] - hb[1]))
        st = src.scan(progress)
        return auto_resolution(st.count, st.area)
    return check_resolution(res)
