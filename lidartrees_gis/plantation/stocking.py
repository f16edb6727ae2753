"""Plantation mode: the planting grid behind the detected trees, missing trees (falhas) and
stocking.

A plantation is planted on a lattice: rows ``row_spacing`` apart, trees ``tree_spacing`` apart
along a row (3 x 2 m in the seeds' clonal eucalyptus). :func:`fit_planting_grid` finds the row
direction and the lattice offset that best explain the detected tops (the direction and
phases that concentrate the tops' positions modulo the spacings, a circular-statistics fit);
:func:`stocking` lays the lattice over the stand, gives each planting position the top nearest
to it, and reports the positions left empty (missing trees) and the stocking percentage
(:mod:`.gap_look` looks once more at them for a tree the tops finder missed).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError
from .lattice import (FIT_MAX_TREES, PlantingGrid, _concentration, _sample,  # noqa: F401
                      _spacing_along)
from .rows import ROWS_MIN_EVIDENCE, ROWWISE_GAIN, find_rows, fit_rows
from .spectrum import MIN_PERIOD_CELLS, _spectral_guess  # noqa: F401
from .table import Positions
from .stockreport import (PLANTING_MIN_TREES, STOCK_COUNTS, axial_mean,  # noqa: F401
                          axial_round, fitted_spacing, stocking_fields)


#: :func:`detect_planting` first fits the lattice on this many of the tops and gives up when
#: that fit is below half the acceptance threshold (natural forests: a tenth of the time of the
#: full fit, which matters when every tile of a large area looks)
PRE_FIT_TREES = 256
#: :func:`detect_planting` gives up at once when fewer than this share of the directions to
#: each top's two nearest neighbours lie within 12 degrees of the commonest one (uniform
#: directions: 0.13). Measured with the defaults' tops: natural forests 0.13-0.16 (Megaplot in
#: 250 m windows, bcts_1); the plantation family 0.35-0.81 from 4 points/m² (3 x 3 and 2.5 x
#: 2.5 m: 0.42-0.46, the two-stand file 0.46), 0.16 at 2 points/m² (no lattice found there
#: before either). Before this look every natural-forest tile paid the direction and period
#: search (3.4 s of a 19 s chain on 4 M Megaplot points; now 0.35 s)
PLANTING_MIN_SHARE = 0.25
#: :func:`detect_planting` measures the row direction and the spacings on this many tops
PERIOD_TREES = 5000


def fit_planting_grid(x, y, row_spacing: float, tree_spacing: float, *,
                      azimuths=None) -> PlantingGrid:
    """Row direction and lattice offset that best fit the tree positions ``x, y``.

    Every azimuth from 0 to 180° (0.5° steps, then 0.05° around the best) is scored by the
    product of the mean resultant lengths of the positions across the rows modulo
    ``row_spacing`` and along the rows modulo ``tree_spacing``; the phases of the best azimuth
    give the offset. Stands of more than :data:`FIT_MAX_TREES` tops are fitted on a fixed sample
    of them.

    Parameters
    ----------
    x, y : (N,) array_like
        Tree positions (map units, m); at least 10.
    row_spacing, tree_spacing : float
        Distance between rows and between trees in a row (m).
    azimuths : array_like, optional
        The coarse azimuths (degrees) to score, when the row direction is known roughly
        (default: 0 to 180° in 0.5° steps).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 10:
        raise InputError(f"-spacing: {x.size} trees are too few to find the planting grid "
                         "(at least 10)")
    if not (row_spacing > 0 and tree_spacing > 0):
        raise InputError("-spacing: spacings must be > 0")
    all_x, all_y = x, y
    x, y = _sample(x, y)
    x0, y0 = float(np.mean(x)), float(np.mean(y))
    dx, dy = x - x0, y - y0

    def score(az_deg):
        # angles in blocks: an (angles x trees) array of a large stand would not fit in memory
        out = [[], [], []]
        for a in np.array_split(np.radians(np.atleast_1d(az_deg)), max(1, len(az_deg) // 24)):
            a = a[:, None]
            pu = dx[None, :] * np.sin(a) + dy[None, :] * np.cos(a)
            pv = dx[None, :] * np.cos(a) - dy[None, :] * np.sin(a)
            ru, phu = _concentration(pu, tree_spacing)
            rv, phv = _concentration(pv, row_spacing)
            for o, v in zip(out, (ru * rv, phu, phv)):
                o.append(v)
        return tuple(np.concatenate(o) for o in out)

    coarse = np.arange(0.0, 180.0, 0.5) if azimuths is None else np.asarray(azimuths, float)
    s, _, _ = score(coarse)
    best = float(coarse[int(np.argmax(s))])
    fine = best + np.arange(-0.5, 0.5001, 0.05)
    s, phu, phv = score(fine)
    k = int(np.argmax(s))
    # the offset in the directions of the angle the phases were measured at (a best angle just
    # under 0° is reported as just under 180°, whose directions are the opposite ones)
    a = np.radians(float(fine[k]))
    az = round(float(fine[k]) % 180.0, 2) % 180.0
    u = np.array([np.sin(a), np.cos(a)])
    v = np.array([np.cos(a), -np.sin(a)])
    ou = phu[k] / (2 * np.pi) * tree_spacing
    ov = phv[k] / (2 * np.pi) * row_spacing
    ox, oy = x0 + ou * u[0] + ov * v[0], y0 + ou * u[1] + ov * v[1]
    g = PlantingGrid(float(row_spacing), float(tree_spacing), az, float(ox), float(oy),
                     float(s[k]))
    if g.fit * ROWWISE_GAIN < 1.0:  # the rows each with their own phase, when they fit better
        rw = fit_rows(all_x, all_y, row_spacing, tree_spacing, azimuths=coarse, fit_x=x,
                      fit_y=y)
        if rw.fit > ROWWISE_GAIN * g.fit:
            return rw
    return g


def stand_mask(chm, res: float, row_spacing: float, tree_spacing: float, *,
               min_height: float = 2.0):
    """The planted area: canopy cells (>= ``min_height``) closed over gaps up to about two
    spacings wide, holes filled, so a missing tree inside the stand is still inside it."""
    a = np.asarray(chm, float)
    canopy = np.isfinite(a) & (a >= min_height)
    r = mask_radius(res, row_spacing, tree_spacing)
    padded = np.pad(canopy, r + 1)
    # ndimage.binary_closing by the disc of radius r, as distances (whole squared numbers: the
    # same cells, in a time that does not grow with r): within r of canopy, then farther than r
    # from any cell outside that
    far = ndimage.distance_transform_edt(~padded) ** 2 > r * r + 0.5
    closed = ndimage.distance_transform_edt(~far) ** 2 > r * r + 0.5
    return ndimage.binary_fill_holes(closed[r + 1:-(r + 1), r + 1:-(r + 1)] | canopy)


def mask_radius(res: float, row_spacing: float, tree_spacing: float) -> int:
    """:func:`stand_mask`'s closing radius in cells: the larger spacing, at least one cell
    (the lattices of stands fitted at 3.00 x 2.00 and 3.01 x 2.00 m share one mask)."""
    return max(1, int(np.ceil(max(row_spacing, tree_spacing) / res)))


_COMPASS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")


def _compass(azimuth: float) -> str:
    return _COMPASS[int(((azimuth % 360.0) + 22.5) // 45.0) % 8]


def row_heading(grid: PlantingGrid) -> tuple:
    """``(s, run)``: the sign that turns the lattice's ``u`` towards the northern half (or
    east), and the rows' bearing in [-90, 90]."""
    a = grid.azimuth % 180.0
    s = 1.0 if a <= 90.0 else -1.0
    return s, (a if s > 0 else a - 180.0)


#: a lattice is square, its rows' direction a choice the returns cannot make, when its two
#: spacings differ by at most this share
SQUARE_SHARE = 0.05


def is_square(row_spacing: float, tree_spacing: float) -> bool:
    """Whether a lattice of these spacings is square (:data:`SQUARE_SHARE`)."""
    return abs(row_spacing - tree_spacing) <= SQUARE_SHARE * tree_spacing


def crew_numbers(grid: PlantingGrid, i, j, anchor=None) -> tuple:
    """Row and plant numbers of planting positions ``(i, j)`` as a field crew counts them, and
    the rule in words. The rows are taken to run towards the northern half (bearing in
    (-90, 90], east for east-west rows); row 1 is the outermost row on the left of that
    direction (the west side of north-south rows, the north side of east-west ones) and the
    rows count across the stand; in each row, plant 1 is the row's first position from its
    southern (western) end, counted along the row with the gaps. ``anchor``: the stand's
    first row and rows' first positions (:func:`lidartrees_gis.plantation.positions.span_anchor`:
    its outermost planted row and each row's first planted position, so that a position before
    a row's first tree is plant 0 or below), so that the numbers are the
    stand's whichever tile counts them; without it, those of the positions given. Returns
    ``(row, plant, text)``."""
    i = np.asarray(i, float)
    j = np.asarray(j, float)
    s, run = row_heading(grid)
    ii, jj = np.round(s * i).astype(np.int64), np.round(s * j).astype(np.int64)
    if ii.size == 0:
        return ii, ii, ""
    own = np.full(ii.size, True)
    if anchor is not None and len(anchor[1]):
        j0, first = anchor
        k = jj - j0
        own = (k < 0) | (k >= first.size)
        own[~own] = first[k[~own]] == np.iinfo(np.int64).max
        row = k + 1
        plant = np.zeros(ii.size, np.int64)
        plant[~own] = ii[~own] - first[k[~own]] + 1  # 0 or below: before the row's first
        # planted position (its end, where the returns must settle whether a tree stands)
    else:
        row = np.zeros(ii.size, np.int64)
        plant = np.zeros(ii.size, np.int64)
    if own.any():  # no anchor (or a position outside it): the positions' own first ones
        r = jj[own] - jj[own].min() + 1
        first = np.full(int(r.max()) + 1, np.iinfo(np.int64).max)
        np.minimum.at(first, r, ii[own])  # each row's first position
        row[own], plant[own] = r, ii[own] - first[r] + 1
    text = (f"row 1 on the {_compass(run - 90.0)} side (rows run {_compass(run + 180.0)} to "
            f"{_compass(run)}, row azimuth {axial_round(grid.azimuth):.1f}°), plant 1 at the "
            f"{_compass(run + 180.0)} end of each row"
            + (", within each stand" if anchor is not None else ""))
    if is_square(grid.row_spacing, grid.tree_spacing):
        text += "; a square lattice, whose rows could run either way"
    return row, plant, text


def stocking(top_x, top_y, chm, spec, spacing, *, min_height: float = 2.0,
             grid: PlantingGrid | None = None, within=None, planted=None, own=None,
             anchor=None, span=None, area=None) -> dict:
    """Planting positions, missing trees and stocking of a plantation.

    Each planting position of the fitted lattice (:func:`fit_planting_grid`) that lies in the
    planted area (:func:`stand_mask`, at least half a spacing inside the data) takes the
    detected top nearest to it, if that top rounds to it on the lattice. Positions with no top
    are missing trees (falhas).

    Returns
    -------
    dict with ``grid`` (:class:`PlantingGrid`), ``expected`` (positions), ``stocked``,
    ``missing``, ``extra`` (tops sharing a position with another, e.g. forks or weeds),
    ``stocking_pct``, ``planted_per_ha`` (10,000 / (R x C)), ``gaps`` (the positions with
    no top, :class:`~lidartrees_gis.plantation.table.Positions`: ``x, y``, lattice indices
    ``i, j``, row and plant numbers ``row, plant`` as :func:`crew_numbers` gives them, and
    ``edge``), ``tops_row``,
    ``tops_plant`` (those of the position each top takes, 0 for none), ``edge_cut`` (a
    row's positions within its reach in the band along the data's edge, not counted: the
    data cannot tell whether a tree stands there), ``numbering`` (the
    rule in words) and ``shares`` (per top: it took no position, and the position it rounds to
    was taken by a nearer top). ``grid``: a lattice already
    fitted to these tops (e.g. by :func:`detect_planting`), not fitted again. ``within``
    (left, bottom, right, top): the tops are matched to every position, but only the
    positions, tops and planted cells inside this box are counted and reported (a tile's core).
    ``planted``: the planted cells when already known (:func:`stand_mask`, e.g. cut to one
    stand); ``own``: the tops counted as extra when they take no position (default all).
    ``span``: the planted rows, each one's first and last tree and how far it may reach
    (:func:`lidartrees_gis.plantation.positions.row_spans`): positions beyond its trees are counted
    out to its reach only where a tree stands (the gaps' ``edge``); ``area``: the cells those
    may lie in (the stand's cells with data: a row's reach may pass the planted area's
    canopy; default the planted area).
    ``looks``: every empty position, inside the box or not (a tree looked for at an
    empty position beyond a tile's core may stand inside it). ``anchor``: where the stand's
    numbers start (:func:`lidartrees_gis.plantation.positions.lattice_anchor`).
    """
    R, C = spacing
    tx = np.asarray(top_x, float)
    ty = np.asarray(top_y, float)
    g = grid if grid is not None else fit_planting_grid(tx, ty, R, C)
    mask = planted if planted is not None else stand_mask(chm, spec.res, R, C,
                                                          min_height=min_height)
    # lattice nodes covering the grid
    left, bottom, right, top = spec.bounds
    ci, cj = g.to_lattice(np.array([left, left, right, right]), np.array([bottom, top, bottom, top]))
    ii, jj = np.meshgrid(np.arange(np.floor(ci.min()) - 1, np.ceil(ci.max()) + 2),
                         np.arange(np.floor(cj.min()) - 1, np.ceil(cj.max()) + 2))
    ii, jj = ii.ravel(), jj.ravel()
    nx, ny = g.to_map(ii, jj)
    margin = 0.25 * min(R, C)
    inside = (nx >= left + margin) & (nx <= right - margin) & (ny >= bottom + margin) & (ny <= top - margin)
    r, c = spec.cell_index(nx, ny)
    ok = inside & (r >= 0) & (r < spec.height) & (c >= 0) & (c < spec.width)
    near = ok.copy()  # in the stand's data, planted or not (a row's reach beyond its trees)
    ok[ok] &= mask[r[ok], c[ok]]
    if area is not None:
        near[near] &= area[r[near], c[near]]
    edge = np.zeros(ok.size, bool)
    cut = np.zeros(ok.size, bool)
    if span is not None:  # the planted rows, each from its first to its last tree, and the
        rows, first, last, first_out, last_out = span  # positions out to each row's reach
        if rows.size:  # (kept only where a tree stands; the canopy may end before them)
            k = np.clip(np.searchsorted(rows, jj.astype(np.int64)), 0, rows.size - 1)
            inrow = rows[k] == jj
            reach = inrow & (ii >= first_out[k]) & (ii <= last_out[k])
            edge = inrow & (((ii < first[k]) & (ii >= first_out[k]))
                            | ((ii > last[k]) & (ii <= last_out[k])))
            edge &= near if area is not None else ok
            ok &= inrow & (ii >= first[k]) & (ii <= last[k])
            ok |= edge
            # a row's positions in the band along the data's edge, where the data cannot tell
            # whether a tree stands (its crown half cut): not counted, but not ruled out
            grid = (r >= 0) & (r < spec.height) & (c >= 0) & (c < spec.width)
            cut = reach & grid & ~inside
            if area is not None:
                cut[cut] &= area[r[cut], c[cut]]
        else:
            ok[:] = False
    cx0, cy0 = nx[cut], ny[cut]
    ii, jj, nx, ny, edge = ii[ok], jj[ok], nx[ok], ny[ok], edge[ok]
    # one top per position: closest pairs first, in the position's cell (half a spacing along
    # the row and half across it, distances in spacings): a crown's apex leaning 1 m across a
    # 3 m row is still its row's tree (within half the smaller spacing, 9 % of a 3 x 2 m
    # stand's tops took no position on the independent farm generator and stayed extra trees)
    from ..report.evaluate import match_trees

    m = min(R, C)
    ti, tj = g.to_lattice(tx, ty)
    node_k, top_k = match_trees(ii * m, jj * m, ti * m, tj * m, max_dist=0.5 * m)
    stocked_mask = np.zeros(ii.size, bool)
    stocked_mask[node_k] = True
    row_no, plant_no, numbering = crew_numbers(g, ii, jj, anchor)
    tops_row = np.zeros(tx.size, np.int64)
    tops_plant = np.zeros(tx.size, np.int64)
    tops_row[top_k], tops_plant[top_k] = row_no[node_k], plant_no[node_k]
    expected = int(ii.size)
    stocked = int(stocked_mask.sum())
    gaps = ~stocked_mask
    # tops that took no position although their nearest position is in the stand (forks,
    # weeds, trees off the grid)
    free = np.ones(tx.size, bool) if own is None else np.asarray(own, bool).copy()
    free[top_k] = False
    # the free tops whose position a nearer top took (a second top on one crown, a flank)
    shares = np.zeros(tx.size, bool)
    if free.any() and node_k.size:
        taken = set(zip(ii[node_k].astype(int).tolist(), jj[node_k].astype(int).tolist()))
        fi0, fj0 = g.to_lattice(tx[free], ty[free])
        shares[np.nonzero(free)[0]] = [(a, b) in taken for a, b in
                                       zip(np.round(fi0).astype(int).tolist(),
                                           np.round(fj0).astype(int).tolist())]
    planted_cells = float(mask.sum())
    look_x, look_y = nx[gaps], ny[gaps]  # every empty position, the box's or not
    if within is not None:  # count only what lies in the box
        x0, y0, x1, y1 = within
        cut_in = (cx0 >= x0) & (cx0 < x1) & (cy0 >= y0) & (cy0 < y1)
        cx0 = cx0[cut_in]
        inb = (nx >= x0) & (nx < x1) & (ny >= y0) & (ny < y1)
        ii, jj, nx, ny, stocked_mask = ii[inb], jj[inb], nx[inb], ny[inb], stocked_mask[inb]
        row_no, plant_no, edge = row_no[inb], plant_no[inb], edge[inb]
        expected, stocked = int(ii.size), int(stocked_mask.sum())
        gaps = ~stocked_mask
        free &= (tx >= x0) & (tx < x1) & (ty >= y0) & (ty < y1)
        cx, _ = spec.xy(0, np.arange(spec.width))
        _, cy = spec.xy(np.arange(spec.height), 0)
        planted_cells = float((mask & ((cx >= x0) & (cx < x1))[None, :]
                               & ((cy >= y0) & (cy < y1))[:, None]).sum())
    fi, fj = g.to_lattice(tx[free], ty[free])
    nodes = set(zip(ii.astype(int).tolist(), jj.astype(int).tolist()))
    extra = sum((a, b) in nodes for a, b in zip(np.round(fi).astype(int).tolist(),
                                                 np.round(fj).astype(int).tolist()))
    return {"grid": g, "expected": expected, "stocked": stocked, "missing": int(gaps.sum()),
            "extra": max(extra, 0), "edge_cut": int(cx0.size),
            "stocking_pct": 100.0 * stocked / expected if expected else float("nan"),
            "planted_per_ha": 1e4 / (R * C), "planted_area_ha": planted_cells * spec.cell_area / 1e4,
            "gaps": Positions(nx[gaps], ny[gaps], i=ii[gaps], j=jj[gaps], row=row_no[gaps],
                              plant=plant_no[gaps], edge=edge[gaps]),
            "tops_row": tops_row, "tops_plant": tops_plant,
            "numbering": numbering, "shares": shares, "looks": Positions(look_x, look_y)}


#: a planting lattice is recognised under at least :data:`PLANTING_MIN_TREES` tops (defined with
#: the summary fields, :mod:`lidartrees_gis.plantation.stockreport`) ...
#: ... when the lattice fit (:attr:`PlantingGrid.fit`) reaches this (measured on the detected
#: tops: synthetic 3 x 2 m stands 0.38-0.84 from 2 to 25 pts/m²; MixedConifer, Megaplot,
#: Topography, the four bcts tiles, pycrown and the three rLiDAR plots 0.002-0.051, the eleven
#: NEON plots, of 21-59 trees, 0.068-0.106)
PLANTING_MIN_FIT = 0.25


#: :func:`detect_planting` recentres its ±12° window of neighbour directions at most this often
MEAN_SHIFT_STEPS = 20
#: :func:`_refine_direction` looks this many degrees either side of the neighbour histogram's
#: row direction
DIRECTION_REACH = 6.0


def _refine_direction(dx, dy, a, row0, tree0, n: int = 3000) -> float:
    """The row direction (radians) within :data:`DIRECTION_REACH` of ``a`` (the first guess) on
    which the positions concentrate most along and across the rows, each at its best period within
    ±15 % of ``tree0`` and ``row0``: half a degree off, 90 m of rows drift 0.8 m across, and
    the periods measured there are a few percent off (a 3.5 x 2.5 m stand read as 3.61 x 2.61,
    whose lattice then fits nothing)."""
    if dx.size > n:
        k = np.linspace(0, dx.size - 1, n).astype(np.int64)
        dx, dy = dx[k], dy[k]
    cand_r = row0 * np.linspace(0.85, 1.15, 61)[:, None]
    cand_t = tree0 * np.linspace(0.85, 1.15, 61)[:, None]

    def best_of(angles, start):
        best, out = -1.0, start
        for b in angles:
            ru, _ = _concentration((dx * np.sin(b) + dy * np.cos(b))[None, :], cand_t)
            rv, _ = _concentration((dx * np.cos(b) - dy * np.sin(b))[None, :], cand_r)
            score = float(ru.max() * rv.max())
            if score > best:
                best, out = score, float(b)
        return out

    # coarse over the histogram's reach (its peak may sit a few degrees off on a direction the
    # CHM grid favours: 3 x 1.5 m tops on 0.3 m cells read 133° for rows at 130°), then fine
    b = best_of(a + np.radians(np.arange(-DIRECTION_REACH, DIRECTION_REACH + 1e-9, 0.5)), a)
    return best_of(b + np.radians(np.arange(-0.5, 0.5001, 0.1)), b)


def detect_planting(x, y, *, min_trees: int = PLANTING_MIN_TREES,
                    min_fit: float = PLANTING_MIN_FIT, cell: float = 0.0,
                    spectral: bool = True, scan=None, notes: dict | None = None):
    """The planting lattice under tree tops, if they lie on one, else None.

    The row direction is the commonest direction to the two nearest neighbours (1° bins);
    the spacing in the row and between rows are the medians of each top's nearest neighbour
    along (within 8°) and across (beyond 70°) that direction, refined to the periods on which
    the positions concentrate most; :func:`fit_planting_grid` then fits the lattice. It is
    accepted when at least ``min_trees`` tops give a fit of at least ``min_fit`` and its
    spacings span :data:`MIN_PERIOD_CELLS` of the CHM's cells ``cell`` (m; 0: any).
    Where the neighbours' directions mislead, it looks at the positions' spectrum
    (:func:`~lidartrees_gis.plantation.spectrum._spectral_guess`, about 0.25 s on 5,000 tops):
    always where the directions concentrate (:data:`PLANTING_MIN_SHARE`: rows the neighbour
    fit missed, as where closed crowns merged a share of the tops along the rows); where they
    are spread only with ``spectral`` (False gives up there at once: the defaults' look in
    every tile of a natural forest).

    ``scan``: the returns' scan waves (:func:`~.scan.scan_waves`): a lattice whose plant
    spacing is their period along its rows (:func:`~.scan.scan_period`) is the scanner's, not
    the planting's: the rows with their own phases are looked for without that period, and
    ``notes["scan"]`` says ``(plant spacing, scan period, azimuth)`` and ``notes["scan_grid"]``
    gives that lattice when nothing else was found.

    Returns
    -------
    PlantingGrid or None
    """
    from scipy.spatial import cKDTree

    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < max(min_trees, 10):
        return None
    xy = np.column_stack([x, y])
    d, k = cKDTree(xy).query(xy, k=7)
    v = xy[k[:, 1:]] - xy[:, None, :]
    ang = np.degrees(np.arctan2(v[..., 0], v[..., 1])) % 180.0
    # the row: the commonest direction to the two nearest neighbours (trees stand closer in
    # the row than across rows)
    h, edges = np.histogram(ang[:, :2].ravel(), bins=180, range=(0.0, 180.0))
    a0 = float(edges[int(np.argmax(h + np.roll(h, 1) + np.roll(h, -1)))] + 0.5)
    # the peak of a histogram of directions between tops on a CHM grid sits on a direction the
    # grid favours (0.3 m cells: 2.5 m apart, 7° steps), up to 6° off; the mean direction of the
    # neighbours around it is not
    near = ang[:, :2].ravel()
    in_peak = np.abs((near - a0 + 90.0) % 180.0 - 90.0) < 12.0
    # the neighbours' directions are spread: no rows (a natural forest), or rows the CHM grid
    # or extra tops hide from the neighbours (the positions' spectrum looks)
    spread = x.size > 2 * PRE_FIT_TREES and in_peak.mean() < PLANTING_MIN_SHARE
    if spread and not spectral:
        return None
    # ... and the window recentred on that mean until it settles: a peak 8° off (3 x 2 m tops
    # on 0.3 m cells: 11.5° for rows at 20°) leaves the window's mean biased after one step
    for _ in range(MEAN_SHIFT_STEPS):
        sel = near[np.abs((near - a0 + 90.0) % 180.0 - 90.0) < 12.0]
        if not sel.size:
            break
        a1 = float(np.degrees(np.angle(np.exp(2j * np.radians(sel)).mean())) / 2.0) % 180.0
        settled = abs((a1 - a0 + 90.0) % 180.0 - 90.0) < 0.01
        a0 = a1
        if settled:
            break
    off = np.abs((ang - a0 + 90.0) % 180.0 - 90.0)
    along = np.where(off < 8.0, d[:, 1:], np.inf).min(axis=1)
    across = np.where(off > 70.0, d[:, 1:], np.inf).min(axis=1)
    # the direction and periods on up to PERIOD_TREES tops (cheap, and a sparse sample of one
    # tree in five reads them wrong); the lattice fit on fewer (its angle search is the cost)
    px, py = _sample(x, y, PERIOD_TREES)
    dx, dy = px - px.mean(), py - py.mean()
    g = None
    if not spread and np.isfinite(along).any() and np.isfinite(across).any():
        g = _detect_from(x, y, dx, dy, np.radians(a0),
                         float(np.median(across[np.isfinite(across)])),
                         float(np.median(along[np.isfinite(along)])), min_fit)
    if g is None or g.fit < min_fit:
        # the neighbours' directions misled (a CHM grid's favoured directions, extra tops
        # between the trees, tops merged along the rows): the positions' spectrum instead
        guess = _spectral_guess(dx, dy, cell)
        if guess is not None:
            g2 = _detect_from(x, y, dx, dy, *guess, min_fit)
            if g2 is not None and (g is None or g2.fit > g.fit):
                g = g2
    if g is not None and g.fit >= min_fit:
        g = _not_scan(g, scan, notes)
    if (g is None or g.fit < min_fit) and spectral:
        # no period along the rows: rows planted each from the stand's edge (their own phases;
        # plantation mode's search only: the defaults' look in a tile of two stands would
        # take one stand's rows for the tile's)
        g2 = find_rows(x, y, dx, dy, cell)
        if g2 is not None and _not_scan(g2, scan, notes) is None:  # again, without that period
            g2 = find_rows(x, y, dx, dy, cell, scan)
        if g2 is not None and g2.fit * np.sqrt(x.size) >= ROWS_MIN_EVIDENCE:
            if min(g2.row_spacing, g2.tree_spacing) < MIN_PERIOD_CELLS * cell:
                return None
            g2 = _not_scan(g2, scan, notes)
            if g2 is not None and notes is not None:
                notes.pop("scan", None)
                notes.pop("scan_grid", None)
            return g2
    if g is None or g.fit < min_fit or \
            min(g.row_spacing, g.tree_spacing) < MIN_PERIOD_CELLS * cell:
        return None
    return g


def _not_scan(g, scan, notes):
    """``g``, or None where its plant spacing is the ``scan`` lines' period along its rows
    (:func:`~.scan.scan_period`; ``notes["scan"]`` then says so)."""
    from .scan import scan_period

    p = scan_period(g.tree_spacing, g.azimuth, scan)
    if p is None:
        return g
    if notes is not None:
        notes["scan"] = (float(g.tree_spacing), p, float(g.azimuth))
        notes["scan_grid"] = g
    return None


def _detect_from(x, y, dx, dy, a, row0, tree0, min_fit):
    """:func:`detect_planting`'s lattice from a first guess of the row direction ``a``
    (radians) and the periods ``row0, tree0``: the direction and periods refined on the
    sample ``dx, dy``, then the lattice fitted; None when a quick fit on
    :data:`PRE_FIT_TREES` tops already falls below half ``min_fit``."""
    b = _refine_direction(dx, dy, a, row0, tree0)
    tree = _spacing_along(dx * np.sin(b) + dy * np.cos(b), tree0)
    row = _spacing_along(dx * np.cos(b) - dy * np.sin(b), row0)

    def fit(n):
        sx, sy = _sample(x, y, n)
        g = fit_planting_grid(sx, sy, row, tree)
        # the periods again along the fitted direction (0.05°): a period 2 % off drifts a
        # whole tree over 40 trees, and the lattice then fits nothing
        b = np.radians(g.azimuth)
        tree2 = _spacing_along(dx * np.sin(b) + dy * np.cos(b), tree, 0.04)
        row2 = _spacing_along(dx * np.cos(b) - dy * np.sin(b), row, 0.04)
        g2 = fit_planting_grid(sx, sy, row2, tree2)
        return g2 if g2.fit > g.fit else g

    if x.size > 2 * PRE_FIT_TREES and fit(PRE_FIT_TREES).fit < min_fit / 2:
        return None
    return fit(FIT_MAX_TREES)
