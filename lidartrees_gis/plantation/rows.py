"""Rows planted each from the stand's edge: a planting lattice whose rows keep their spacing
across the stand but whose plants need not face their neighbours' in the next row.

A crew (or a planting machine) plants a row from the stand's edge, and the edge is oblique to
the rows, so where a row's first plant stands along it is the row's own: the rows are periodic
across the stand (``row_spacing``) and each row is periodic along itself (``tree_spacing``),
with a phase of its own. An aligned lattice (:func:`~.stocking.fit_planting_grid`) sees no
period along such rows: the positions' phases along them cancel over the stand. Here each
row's positions are summed on their own (:func:`pooled_resultant`), and
:class:`~.lattice.PlantingGrid` keeps a phase per row (``phases``).
"""
from __future__ import annotations

import numpy as np

from .lattice import FIT_MAX_TREES, PlantingGrid, _sample, _spacing_along

#: the rows' own phases replace an aligned lattice when their fit (:func:`fit_rows`) is at
#: least this many times the aligned lattice's: an aligned lattice's own rows fit about as
#: well one by one, so a stand that fits aligned keeps its lattice
ROWWISE_GAIN = 2.0
#: :func:`find_rows` looks for rows this far apart (m): rows 2.5-4 m apart, with room
ROW_PERIODS = (2.2, 4.8)
#: ... and for plants this far apart along them (m), at least two CHM cells
TREE_PERIODS = (1.0, 4.8)
#: ... in relative steps of this (a 200 m row of 2 m spacing: a 1 % wide peak)
PERIOD_STEP = 0.002
#: :func:`tree_period` takes twice the strongest period when the positions concentrate on it
#: by this share of that (plants at period ``C`` give about 0 at ``2C``; tops at 3 x 2 m
#: plants and midway between them, independent generator: 0.53-0.67)
HARMONIC_SHARE = 0.3
#: rows with their own phases are accepted when their fit times the root of the number of
#: positions reaches this (natural forests' tops: 0.35-2.0, the NEON plots' 26-61 tops the
#: highest; noisy tops of 3 x 2 m stands, independent generator: 9-18)
ROWS_MIN_EVIDENCE = 5.0


def row_sums(pu, rows, period):
    """Each row's sum of the unit phasors ``exp(2 pi i pu / period)``: ``(re, im, n)``, arrays
    ``(A, M)`` for ``pu, rows`` of shape ``(A, N)`` (A sets of N positions along their rows and
    their row indices) and M rows from each set's first; ``period`` a scalar or ``(A, 1)``."""
    pu = np.atleast_2d(pu)
    rows = np.atleast_2d(rows)
    a = pu.shape[0]
    rows = rows - rows.min(axis=1, keepdims=True)
    m = int(rows.max()) + 1
    key = (np.arange(a)[:, None] * m + rows).ravel()
    ph = (2.0 * np.pi / period) * pu
    re = np.bincount(key, np.cos(ph).ravel(), minlength=a * m).reshape(a, m)
    im = np.bincount(key, np.sin(ph).ravel(), minlength=a * m).reshape(a, m)
    n = np.bincount(key, minlength=a * m).reshape(a, m)
    return re, im, n


def pooled_resultant(re, im, n):
    """The positions' concentration on their rows' own phases, pooled over the rows: the
    root of ``(sum |S_j|² - N) / sum n_j (n_j - 1)``, ``S_j`` the sum of row ``j``'s ``n_j``
    phasors. 1 when every row's positions share a phase, 0 on average (not biased upwards by
    short rows) for positions at random; per set, shape ``(A,)``."""
    num = (re * re + im * im).sum(axis=-1) - n.sum(axis=-1)
    den = (n * (n - 1.0)).sum(axis=-1)
    return np.sqrt(np.clip(num / np.maximum(den, 1.0), 0.0, None))


def _across(dx, dy, a, row_spacing):
    """Positions across the rows of azimuths ``a`` (radians, ``(A, 1)``): their projection,
    the rows' concentration ``rv`` and offset (m), each position's row index."""
    pv = dx[None, :] * np.cos(a) - dy[None, :] * np.sin(a)
    z = np.exp(2j * np.pi * pv / row_spacing).mean(axis=-1, keepdims=True)
    ov = np.angle(z) / (2.0 * np.pi) * row_spacing
    rows = np.rint((pv - ov) / row_spacing).astype(np.int64)
    return np.abs(z[:, 0]), ov[:, 0], rows


def rows_score(dx, dy, az_deg, row_spacing, tree_spacing):
    """The fit of rows with their own phases at each azimuth (degrees): the rows'
    concentration across (mean resultant length) times the positions' along their own rows
    (:func:`pooled_resultant`)."""
    out = []
    az = np.atleast_1d(np.asarray(az_deg, float))
    for block in np.array_split(np.radians(az), max(1, az.size // 24)):
        a = block[:, None]
        rv, _, rows = _across(dx, dy, a, row_spacing)
        pu = dx[None, :] * np.sin(a) + dy[None, :] * np.cos(a)
        out.append(rv * pooled_resultant(*row_sums(pu, rows, tree_spacing)))
    return np.concatenate(out)


def fit_rows(x, y, row_spacing: float, tree_spacing: float, *, azimuths=None, fit_x=None,
             fit_y=None):
    """The lattice of rows with their own phases that best fits the positions ``x, y``:
    every azimuth of ``azimuths`` (default 0 to 180° by 0.5°), then 0.05° around the best,
    scored by :func:`rows_score` on ``fit_x, fit_y`` (default ``x, y``: a sample of them keeps
    a large stand's search short); each row's phase from all the positions in it (a row with
    none: 0). Returns a :class:`~.lattice.PlantingGrid`."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    sx = x if fit_x is None else np.asarray(fit_x, float)
    sy = y if fit_y is None else np.asarray(fit_y, float)
    x0, y0 = float(np.mean(sx)), float(np.mean(sy))
    dx, dy = sx - x0, sy - y0
    coarse = np.arange(0.0, 180.0, 0.5) if azimuths is None else np.asarray(azimuths, float)
    s = rows_score(dx, dy, coarse, row_spacing, tree_spacing)
    fine = float(coarse[int(np.argmax(s))]) + np.arange(-0.5, 0.5001, 0.05)
    s = rows_score(dx, dy, fine, row_spacing, tree_spacing)
    k = int(np.argmax(s))
    a = np.radians(float(fine[k]))
    _, ov, _ = _across(dx, dy, np.array([[a]]), row_spacing)
    v = np.array([np.cos(a), -np.sin(a)])
    ox, oy = x0 + ov[0] * v[0], y0 + ov[0] * v[1]
    # the phases from every position, rows counted from the origin
    ax, ay = x - ox, y - oy
    pv = ax * v[0] + ay * v[1]
    rows = np.rint(pv / row_spacing).astype(np.int64)
    pu = ax * np.sin(a) + ay * np.cos(a)
    re, im, _ = row_sums(pu, rows, tree_spacing)
    phases = np.angle(re[0] + 1j * im[0]) / (2.0 * np.pi)
    az = round(float(fine[k]) % 180.0, 2) % 180.0
    if az != round(float(fine[k]), 2):  # reported in [0, 180): the opposite directions
        phases, first = -phases[::-1], -int(rows.max())
    else:
        first = int(rows.min())
    phases = np.where(phases >= 0.5, phases - 1.0, phases)
    return PlantingGrid(float(row_spacing), float(tree_spacing), az, float(ox), float(oy),
                        float(s[k]), tuple(float(p) for p in np.round(phases, 6)), first)


def tree_period(dx, dy, azimuth: float, row_spacing: float, lo: float, hi: float,
                scan=None) -> tuple:
    """The plants' spacing along rows of ``azimuth`` (degrees) ``row_spacing`` apart: the
    period between ``lo`` and ``hi`` (m, :data:`PERIOD_STEP` relative steps) on which the
    positions concentrate most on their own rows' phases, or twice it when the positions
    concentrate on that too by :data:`HARMONIC_SHARE` (plants at period ``C`` cancel at
    ``2C``; tops at the plants and midway between them, as crowns closed along the row
    give, concentrate at ``C / 2`` most). ``scan``: the returns' scan waves
    (:func:`~.scan.scan_waves`); a period that is theirs along these rows
    (:func:`~.scan.scan_free`) is not a candidate. Returns ``(period, resultant)``."""
    from .scan import scan_free

    a = np.radians(azimuth)
    _, _, rows = _across(dx, dy, np.array([[a]]), row_spacing)
    pu = dx * np.sin(a) + dy * np.cos(a)

    def peak(cand):
        best, r = float(cand[0]), -1.0
        for block in np.array_split(cand, max(1, cand.size // 32)):
            rr = pooled_resultant(*row_sums(np.broadcast_to(pu, (block.size, pu.size)),
                                            np.broadcast_to(rows[0], (block.size, pu.size)),
                                            block[:, None]))
            k = int(np.argmax(rr))
            if rr[k] > r:
                best, r = float(block[k]), float(rr[k])
        return best, r

    def periods(a, b):
        c = np.exp(np.arange(np.log(a), np.log(b), PERIOD_STEP))
        if scan is not None and len(scan):
            c = c[scan_free(c, azimuth, scan)]
        return c if c.size else np.array([a])

    best, r = peak(periods(lo, hi))
    while 2.0 * best <= hi:
        two = peak(periods(1.97 * best, 2.03 * best))
        if two[1] < HARMONIC_SHARE * r:
            break
        best, r = two
    return best, r


def find_rows(x, y, dx, dy, cell: float = 0.0, scan=None):
    """Rows with their own phases under positions whose lattice shows no period along the
    rows: the direction across which the positions are most periodic at a row spacing
    (:data:`ROW_PERIODS`) gives the rows, :func:`tree_period` the plants' spacing along
    them (:data:`TREE_PERIODS`, at least ``MIN_PERIOD_CELLS`` CHM cells ``cell``; not the
    ``scan`` lines'), and :func:`fit_rows` the lattice. ``dx, dy``: a sample of the
    positions about their mean, for the periods. Returns a :class:`~.lattice.PlantingGrid`
    or None."""
    from .spectrum import MIN_PERIOD_CELLS, projection_peak

    if dx.size < 10:
        return None
    thetas = np.radians(np.arange(0.0, 180.0, 0.5))
    found = [projection_peak(dx, dy, t, 1.0 / ROW_PERIODS[1], 1.0 / ROW_PERIODS[0])
             for t in thetas]
    k = int(np.argmax([r for r, _ in found]))
    az = (float(np.degrees(thetas[k])) - 90.0) % 180.0  # the rows run across that direction
    b = np.radians(az)
    row = _spacing_along(dx * np.cos(b) - dy * np.sin(b), found[k][1], 0.04)
    lo = max(TREE_PERIODS[0], MIN_PERIOD_CELLS * cell)
    tree, _ = tree_period(dx, dy, az, row, lo, TREE_PERIODS[1], scan)
    sx, sy = _sample(x, y, FIT_MAX_TREES)
    return fit_rows(x, y, row, tree, azimuths=(az + np.arange(-2.0, 2.001, 0.25)) % 180.0,
                    fit_x=sx, fit_y=sy)


#: :func:`choose`: the canopy's plant spacing times k is the tops' within this share of it
#: (k = 1: the same spacing; 2, 3: a harmonic; the independent generator's 3 x 2 m stands of
#: rows with their own phases: the canopy read 2.047 and 1.021 where the tops gave 2.002)
SAME_SPACING = {1: 0.05, 2: 0.04, 3: 0.04}
#: :func:`choose` keeps the canopy's plant spacing over the tops' rows only where its lattice
#: fits the tops at least this share as well (the volume generator's c1 004-A: rows 3 x 2 m
#: fitting at 0.098, the canopy's 3 x 1.80 m at 0.006)
CANOPY_FIT_SHARE = 0.25


def same_rows(a, b) -> bool:
    """Whether two lattices have the same rows: azimuths within 1°, row spacings within 2 %."""
    turn = abs((a.azimuth - b.azimuth + 90.0) % 180.0 - 90.0)
    return turn <= 1.0 and abs(a.row_spacing - b.row_spacing) <= 0.02 * a.row_spacing


def choose(rows, canopy, x, y):
    """Of a stand's lattice of rows with their own phases under its tops ``x, y``
    (:func:`find_rows`) and the aligned lattice of its canopy's spectrum
    (:func:`~.canopy_lattice.canopy_planting`), the one to keep. Where the two agree on the
    rows (within 1° and 2 % of the spacing), the canopy's plants along them, unless its spacing
    is the tops' (within :data:`SAME_SPACING`: the tops' rows then give the phases and a finer
    spacing; the canopy's spectrum reads rows of their own phases a few % off) or a half or a
    third of it (a harmonic of the crowns' heights along the row), or its lattice fits the
    tops under :data:`CANOPY_FIT_SHARE` of the rows' fit: tops merged along a closed
    row may lie at the detection window's reach, not at the plants' (the second family's
    7-year 3 x 2 m stand: tops at 1.56 m along the rows), where the canopy's heights still
    rise at each plant. Where they disagree on the rows, the lattice across whose rows the
    tops concentrate more."""
    if canopy is None:
        return rows
    if same_rows(rows, canopy):
        same = any(abs(k * canopy.tree_spacing - rows.tree_spacing)
                   <= SAME_SPACING[k] * rows.tree_spacing for k in SAME_SPACING)
        # ... and the canopy's plants are kept only where the tops do not belie them
        return rows if same or canopy.fit < CANOPY_FIT_SHARE * rows.fit else canopy

    dx, dy = np.asarray(x, float) - np.mean(x), np.asarray(y, float) - np.mean(y)

    def across(g):
        return _across(dx, dy, np.array([[np.radians(g.azimuth)]]), g.row_spacing)[0][0]

    return rows if across(rows) >= across(canopy) else canopy
