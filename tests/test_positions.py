"""What stands at an empty planting position (issue 23): missing, suppressed, or uncertain
when the returns there are too few or too mixed to tell (plantation/status.position_status)."""
import numpy as np
import pytest

from lidartrees_gis.plantation.status import (MISSING, OVERLAP_HEIGHT, SUPPRESSED, SUPPRESSED_SHARE,
                                              UNCERTAIN, classify_gaps,
                                              position_status, wilson_interval)
from lidartrees_gis.plantation.table import Positions


def test_wilson_interval_matches_its_formula():
    # 7 of 10 at one standard error: centre (0.7 + 1/20) / 1.1, half-width sqrt(.021 + .0025) / 1.1
    lo, hi = wilson_interval(7, 10, z=1.0)
    c, h = (0.7 + 0.05) / 1.1, np.sqrt(0.7 * 0.3 / 10 + 1 / 400) / 1.1
    assert lo == pytest.approx(c - h) and hi == pytest.approx(c + h)
    lo, hi = wilson_interval(np.array([0, 5]), np.array([0, 5]))
    assert lo[0] == 0.0 and hi[0] == 1.0  # no return: no knowledge
    assert hi[1] == pytest.approx(1.0) and lo[1] > SUPPRESSED_SHARE  # 5 of 5


def _disc(k_high, n, cx=0.0, cy=0.0, high=14.0, r=0.4, seed=0):
    """``n`` returns within ``r`` of (cx, cy), ``k_high`` of them ``high`` m above ground."""
    rng = np.random.default_rng(seed)
    a, d = rng.uniform(0, 2 * np.pi, n), r * np.sqrt(rng.uniform(0, 1, n))
    h = np.r_[np.full(k_high, high), np.zeros(n - k_high)]
    return cx + d * np.cos(a), cy + d * np.sin(a), h


@pytest.mark.parametrize("k, n, expected", [
    (0, 12, MISSING), (11, 12, SUPPRESSED), (12, 12, SUPPRESSED), (16, 20, SUPPRESSED),
    (3, 6, UNCERTAIN), (2, 5, UNCERTAIN), (4, 6, UNCERTAIN),  # a handful: cannot tell
    (10, 20, UNCERTAIN),
    # one crown return, or a few, at 0.61 of the dominant height: a neighbour's crown or a
    # tree, not told apart; no longer a missing tree
    (1, 12, UNCERTAIN), (4, 20, UNCERTAIN)])
def test_position_status_decides_only_when_the_interval_is_clear(k, n, expected):
    """Crown returns at 14 m under a 23 m stand (under OVERLAP_HEIGHT of it): a suppressed tree
    only when the share's Wilson interval lies above one half; a crown return there is never
    a missing tree."""
    x, y, h = _disc(k, n)
    assert 14.0 < OVERLAP_HEIGHT * 23.0
    out = position_status([0.0], [0.0], (x, y, h), (3.0, 2.0), dominant_height=23.0)
    assert out["status"][0] == expected
    assert out["returns"][0] == n and out["share"][0] == pytest.approx(k / n)
    if k / n >= SUPPRESSED_SHARE and expected != MISSING:  # a tree, or the likelier answer
        assert out["height"][0] == pytest.approx(14.0)  # at its highest return
    else:
        assert np.isnan(out["height"][0]) and out["x"][0] == 0.0


@pytest.mark.parametrize("k, n, expected", [(1, 8, UNCERTAIN), (3, 8, UNCERTAIN),
                                           (5, 8, UNCERTAIN), (8, 8, SUPPRESSED)])
def test_a_small_crown_under_the_canopy_is_uncertain_not_missing(k, n, expected):
    """A suppressed tree's small crown under a 23 m canopy (8 m) lets most pulses through to
    the ground (the independent generator's suppressed trees: shares of 0.29-0.75 of 4-8
    returns, called missing by the share alone), and a neighbour's crown flank reaching over a
    missing tree's position gives shares as low: uncertain, a field check, unless clear."""
    x, y, h = _disc(k, n, high=8.0)
    out = position_status([0.0], [0.0], (x, y, h), (3.0, 2.0), dominant_height=23.0)
    assert out["status"][0] == expected


def test_a_crown_at_the_canopy_s_height_over_an_empty_position_is_uncertain():
    x, y, h = _disc(12, 12, high=0.9 * 23.0)
    out = position_status([0.0], [0.0], (x, y, h), (3.0, 2.0), dominant_height=23.0)
    assert out["status"][0] == UNCERTAIN


def test_position_with_too_few_returns_is_uncertain_and_low_returns_do_not_count():
    # no return within 0.4 spacings: a data void, nothing seen either way
    out = position_status([0.0, 10.0], [0.0, 0.0], _disc(0, 8, cx=10.0), (3.0, 2.0), 23.0)
    assert list(out["status"]) == [UNCERTAIN, MISSING] and out["returns"][0] == 0
    # one ground return close and one farther: too few; with two farther, the ground is seen
    few = (np.array([0.1, 0.7]), np.zeros(2), np.zeros(2))
    more = (np.array([0.1, 0.7, -0.7]), np.zeros(3), np.zeros(3))
    assert position_status([0.0], [0.0], few, (3.0, 2.0), 23.0)["status"][0] == UNCERTAIN
    assert position_status([0.0], [0.0], more, (3.0, 2.0), 23.0)["status"][0] == MISSING
    # returns of 5 m under a 23 m stand: below 30 % of the dominant height (a shrub)
    out = position_status([0.0], [0.0], _disc(10, 10, high=5.0), (3.0, 2.0), 23.0)
    assert out["status"][0] == MISSING


def test_classify_gaps_counts_each_status_and_stocks_uncertain_by_their_share():
    parts = [_disc(12, 12, cx=0.0), _disc(0, 12, cx=10.0), _disc(3, 6, cx=20.0),
             _disc(4, 6, cx=30.0)]
    pts = tuple(np.concatenate([p[i] for p in parts]) for i in range(3))
    gx = np.array([0.0, 10.0, 20.0, 30.0])
    st = {"expected": 100, "stocked": 96, "missing": 4,
          "gaps": Positions(gx, np.zeros(4), zone=[0, 0, 1, 1]),
          "zones": {0: {"expected": 50, "stocked": 48, "missing": 2},
                    1: {"expected": 50, "stocked": 48, "missing": 2}}}
    out = classify_gaps(st, pts, (3.0, 2.0), 23.0)
    assert list(out["gaps"].status) == [SUPPRESSED, MISSING, UNCERTAIN, UNCERTAIN]
    assert (out["missing"], out["suppressed"], out["uncertain"]) == (1, 1, 2)
    assert out["uncertain_stocked"] == pytest.approx(3 / 6 + 4 / 6)
    assert out["stocking_pct"] == pytest.approx(96 + 1 + 3 / 6 + 4 / 6)
    # the interval's variance: each uncertain position a Bernoulli of its share; a call on 12
    # returns all one way is all but sure
    var0 = out["zones"][0].pop("stocked_var")
    assert 0.0 < var0 < 1e-3
    # the resolved calls' spread alone: zone 0's, none of zone 1's uncertain positions
    assert out["zones"][0].pop("resolved_var") == pytest.approx(var0, abs=1e-12)
    assert out["zones"][0] | {} == {"expected": 50, "stocked": 48, "missing": 1,
                                    "missing_crowned": 0, "suppressed": 1, "uncertain": 0,
                                    "uncertain_stocked": 0.0, "edge_unresolved": 0}
    assert out["zones"][1]["uncertain"] == 2 and out["zones"][1]["missing"] == 0
    # a missing call (two ground returns close) with a crown return farther out, among the
    # five its share is read from: still missing, counted crowned
    ring = (10.0 + np.array([0.2, -0.2, 0.7, -0.7, 0.0]), np.array([0, 0, 0, 0, 0.7]),
            np.array([0.0, 0.0, 0.0, 0.0, 14.0]))
    one = classify_gaps({**st, "gaps": Positions(gx[:2], np.zeros(2), zone=[0, 0]),
                         "missing": 2, "zones": {0: st["zones"][0]}},
                        tuple(np.concatenate([p[i] for p in (parts[0], ring)])
                              for i in range(3)), (3.0, 2.0), 23.0)
    assert list(one["gaps"].status) == [SUPPRESSED, MISSING] and one["missing_crowned"] == 1
    assert out["zones"][1]["stocked_var"] == pytest.approx(0.25 + 2 / 9, abs=1e-8)
    assert out["zones"][1]["resolved_var"] == 0.0
    assert out["stocked_var"] == pytest.approx(var0 + 0.25 + 2 / 9, abs=1e-8)
    assert out["resolved_var"] == pytest.approx(var0, abs=1e-12)
    assert out["edge_unresolved"] == 0


def test_each_stand_s_positions_are_read_at_its_own_spacing():
    """A tile holding stands of 3 x 2 m and 3.5 x 2.5 m reads each position within a quarter
    of its own stand's smaller spacing (the tile's commonest spacing gave a tiled run other
    counts than the whole file)."""
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 2 * np.pi, 12)
    r = np.r_[rng.uniform(0.52, 0.6, 6), rng.uniform(0.0, 0.3, 6)]  # crown returns farther out
    h = np.r_[np.full(6, 14.0), np.zeros(6)]
    pts = (r * np.cos(a), r * np.sin(a), h)
    st = {"expected": 10, "stocked": 9, "missing": 1,
          "gaps": Positions(np.zeros(1), np.zeros(1), zone=[1]),
          "zones": {0: {"expected": 5, "stocked": 5, "missing": 0, "spacing": (3.0, 2.0)},
                    1: {"expected": 5, "stocked": 4, "missing": 1, "spacing": (3.5, 2.5)}}}
    own = classify_gaps(st, pts, (3.0, 2.0), 23.0)
    assert own["gaps"].returns[0] == 12 and own["gaps"].share[0] == pytest.approx(0.5)
    assert own["gaps"].status[0] == UNCERTAIN
    tile_wide = position_status([0.0], [0.0], pts, (3.0, 2.0), 23.0)
    assert tile_wide["returns"][0] == 6 and tile_wide["status"][0] == MISSING


def _lattice_in(poly, grid):
    """Every lattice position of ``grid`` inside the shapely polygon ``poly``: (x, y, i, j)."""
    import shapely

    x0, y0, x1, y1 = poly.bounds
    ci, cj = grid.to_lattice(np.array([x0, x0, x1, x1]), np.array([y0, y1, y0, y1]))
    ii, jj = np.meshgrid(np.arange(np.floor(ci.min()) - 1, np.ceil(ci.max()) + 2),
                         np.arange(np.floor(cj.min()) - 1, np.ceil(cj.max()) + 2))
    x, y = grid.to_map(ii.ravel(), jj.ravel())
    keep = shapely.contains_xy(poly, x, y)
    return x[keep], y[keep], ii.ravel()[keep].astype(int), jj.ravel()[keep].astype(int)


@pytest.mark.parametrize("azimuth", [7.0, 33.0, 61.0, 118.0, 152.0])
@pytest.mark.parametrize("shape", ["convex", "notched"])
def test_a_row_whose_end_trees_are_missing_runs_as_far_as_its_neighbours(azimuth, shape):
    # a planted area (convex, or an L with a corner bent inwards) at an angle to the rows;
    # the end trees of some rows are missing: the spans come back toward the true ends and
    # never pass them
    from shapely.geometry import Polygon

    from lidartrees_gis.plantation.positions import row_spans
    from lidartrees_gis.plantation.stocking import PlantingGrid

    grid = PlantingGrid(3.0, 2.0, azimuth, 500000.3, 7500000.7, 1.0)
    pts = [(0, 0), (120, 8), (128, 90), (20, 110), (-6, 50)] if shape == "convex" else \
        [(0, 0), (120, 0), (120, 50), (60, 50), (60, 110), (0, 110)]
    poly = Polygon([(500000 + a, 7500000 + b) for a, b in pts])
    x, y, i, j = _lattice_in(poly, grid)
    rows = np.unique(j)
    t_first = np.array([i[j == r].min() for r in rows])
    t_last = np.array([i[j == r].max() for r in rows])
    rng = np.random.default_rng(int(azimuth))
    keep = np.ones(x.size, bool)
    cut = rng.choice(np.arange(3, rows.size - 3), size=rows.size // 5, replace=False)
    n_cut = {}
    for k in cut:  # 1-3 end trees missing at one end of the row
        m = int(rng.integers(1, 4))
        at_end = t_last[k] - np.arange(m) if k % 2 else t_first[k] + np.arange(m)
        keep &= ~((j == rows[k]) & np.isin(i, at_end))
        n_cut[k] = m
    r, first, last, first_out, last_out = row_spans(grid, x[keep], y[keep])
    assert np.array_equal(r, rows)
    assert (first >= t_first).all() and (last <= t_last).all()  # nothing beyond the planting
    # the reach, where an empty position is either a missing tree or no planting: one or two
    # positions beyond each end, out to the true end on the straight parts of the edge
    assert ((first - first_out >= 1) & (first - first_out <= 2)).all()
    assert ((last_out - last >= 1) & (last_out - last <= 2)).all()
    held = (first_out <= t_first) & (last_out >= t_last)
    assert held.mean() >= 0.7
    short = (first - t_first) + (t_last - last)
    assert short.max() <= 3 and short.sum() < sum(n_cut.values())
    recovered = sum(n_cut.values()) - short.sum()
    assert recovered >= 0.3 * sum(n_cut.values())


def test_row_ends_from_neighbours_adds_nothing_to_an_intact_edge():
    from lidartrees_gis.plantation.positions import row_ends_from_neighbours

    rows = np.arange(40)
    for slope in (0.0, 0.37, 1.0, 1.7, 4.2):
        for bend in (1.0, -1.0):  # a straight edge, bent outwards or inwards at row 20
            e = 50.0 + slope * rows + bend * 0.8 * np.abs(rows - 20)
            last = np.floor(e).astype(np.int64)
            assert np.array_equal(row_ends_from_neighbours(rows, last), last)
            gone = last.copy()
            gone[[9, 30]] -= 3  # three end trees missing in two rows: some come back
            ends = row_ends_from_neighbours(rows, gone)
            assert (ends <= last).all() and (ends[[9, 30]] > gone[[9, 30]]).all()


def test_the_stocking_interval_spans_every_way_the_unresolved_positions_could_go():
    from lidartrees_gis.plantation.stockreport import STOCKING_Z, stocking_fields

    st = {"expected": 100, "stocked": 90, "suppressed": 2, "missing": 4, "uncertain": 4,
          "uncertain_stocked": 2.0, "resolved_var": 0.0, "edge_unresolved": 2, "extra": 0,
          "planted_area_ha": 0.06}
    f = stocking_fields((3, 2), 10.0, st)
    # every uncertain position empty and of the 2 empty positions beyond rows' ends as many
    # missing trees as a 95 % binomial count at the stand's 8 % missing or uncertain allows
    # (1): 92 of 101; every uncertain position stocked: 96 of 100; the point counts each by
    # its share
    assert f["stocking_pct"] == pytest.approx(94.0)
    assert f["stocking_pct_low"] == pytest.approx(100 * 92 / 101)
    assert f["stocking_pct_high"] == pytest.approx(96.0)
    # many row ends: about their 8 %, not all of them
    f = stocking_fields((3, 2), 10.0, {**st, "edge_unresolved": 200})
    assert 100 * 92 / 130 < f["stocking_pct_low"] < 100 * 92 / 115
    # the resolved calls' spread widens both ends, within what the positions allow
    f = stocking_fields((3, 2), 10.0, {**st, "resolved_var": 1.0, "edge_unresolved": 0})
    assert f["stocking_pct_low"] == pytest.approx(92 - STOCKING_Z)
    assert f["stocking_pct_high"] == pytest.approx(96 + STOCKING_Z)
    f = stocking_fields((3, 2), 10.0, {**st, "stocked": 96, "missing": 0, "resolved_var": 4.0})
    assert f["stocking_pct_high"] == 100.0
    # a missing call with a return at crown height near it may be a small tree under its
    # neighbours' crowns: the upper end counts it stocked, the point and the lower end do not
    f = stocking_fields((3, 2), 10.0, {**st, "missing_crowned": 3, "edge_unresolved": 0})
    assert f["stocking_pct_high"] == pytest.approx(99.0)
    assert (f["stocking_pct"], f["stocking_pct_low"]) == pytest.approx((94.0, 92.0))
    # 4 tops sharing a position with a nearer one: crowns with a second top, which beside a
    # missing tree stands on its position; the lower end counts as many such positions empty
    # as a 95 % Poisson count of 4 allows (8), the point and the upper end are unchanged
    from scipy.stats import poisson

    f = stocking_fields((3, 2), 10.0, {**st, "extra": 4, "edge_unresolved": 0})
    assert poisson.ppf(0.975, 4) == 8
    assert (f["stocking_pct"], f["stocking_pct_high"]) == pytest.approx((94.0, 96.0))
    assert f["stocking_pct_low"] == pytest.approx(92.0 - 8.0)


def test_row_spans_of_tops_on_no_position_are_empty_in_every_part():
    # tops that lie on no position (a stand's few tops, all off its lattice): no row, in each
    # of the five parts the stocking reads (a run failed on three)
    from lidartrees_gis.plantation.positions import row_spans
    from lidartrees_gis.plantation.stocking import PlantingGrid

    g = PlantingGrid(3.0, 2.0, 0.0, 0.0, 0.0, 1.0)
    span = row_spans(g, np.array([0.9, 2.1]), np.array([0.7, 3.1]))
    assert len(span) == 5 and all(a.size == 0 for a in span)


def test_an_empty_position_is_looked_at_with_its_own_stands_spacing():
    # two stands of other spacings in one tile: an apex 0.65 m from an empty position of the
    # 3.5 x 2.5 m stand is within its reach (0.3 x 2.5 m) but not within the 3 x 2 m one's
    # (0.3 x 2 m); which lattice holds most of the tile must not decide it
    from lidartrees_gis.grid import GridSpec
    from lidartrees_gis.plantation.gap_look import gap_tops

    spec = GridSpec.from_bounds(0.0, 0.0, 20.0, 20.0, 0.1)
    returns = np.full(spec.shape, np.nan)
    r, c = spec.cell_index(np.array([10.66]), np.array([10.0]))  # a cell 0.65 m away
    returns[r[0], c[0]] = 15.0
    chm = np.where(np.isfinite(returns), returns, 3.0)
    args = (np.array([10.0]), np.array([10.0]), returns, chm, spec, (3.0, 2.0))
    kw = dict(top_x=np.array([2.0]), top_y=np.array([2.0]))
    assert gap_tops(*args, **kw)[0].size == 0
    rows, cols = gap_tops(*args, **kw, smaller=np.array([2.5]))
    assert (rows.tolist(), cols.tolist()) == ([r[0]], [c[0]])


def test_positions_are_one_table_whose_columns_keep_one_length():
    """The planting positions travel as one table: a selection or a concatenation keeps every
    column's rows together, and a column of another length is refused by name."""
    t = Positions([0.0, 1.0, 2.0], [5.0, 6.0, 7.0], row=[1, 1, 2], zone=[0, 0, 1])
    assert len(t) == 3 and t.columns() == ["x", "y", "row", "zone"]
    sub = t.take(t.zone == 0)
    assert list(sub.x) == [0.0, 1.0] and list(sub.row) == [1, 1] and sub.plant is None
    both = Positions.concat([t, Positions([9.0], [9.0], row=[4])])
    assert list(both.row) == [1, 1, 2, 4] and both.zone is None  # not in every part
    assert list(t.column("plant", 0)) == [0, 0, 0] and t.row.dtype == np.int64
    with pytest.raises(ValueError, match="'row' has 2 rows, not 3"):
        Positions([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], row=[1, 2])


def test_positions_are_kept_for_resume(tmp_path):
    """A tile's result holding a Positions table is stored and read back (``-resume``)."""
    from lidartrees_gis.io.store import load, save

    t = Positions([0.5, 1.5], [2.0, 3.0], row=[3, 4], status=[0, 2], share=[0.0, 0.4])
    save(tmp_path / "t.npz", {"stocking": {"gaps": t}}, {"tile": 0})
    back = load(tmp_path / "t.npz")[0]["stocking"]["gaps"]
    assert isinstance(back, Positions) and back.columns() == t.columns()
    assert list(back.row) == [3, 4] and list(back.share) == [0.0, 0.4] and back.zone is None


def test_the_canopy_over_a_position_is_its_neighbours_so_a_young_stand_keeps_its_trees():
    """A 6 m suppressed tree in a 14 m stand beside a 25 m one: under the area's dominant
    height (25 m) its crown is below a crown's height and the position is called missing; its
    neighbours' tops give the canopy's height over it, and it is a suppressed tree (the third
    family's 14.7 m stand on a farm of taller ones: 138 such trees called missing)."""
    from lidartrees_gis.plantation.status import canopy_over

    ii, jj = np.meshgrid(np.arange(-1, 2), np.arange(-1, 2))
    keep = (ii != 0) | (jj != 0)
    tops = (2.0 * ii[keep], 3.0 * jj[keep], np.full(8, 14.0))  # the 8 neighbours, 3 x 2 m
    far = (np.array([40.0, 41.0, 42.0]), np.zeros(3), np.full(3, 25.0))
    both = tuple(np.r_[a, b] for a, b in zip(tops, far))
    over = canopy_over([0.0, 41.0], [0.0, 0.0], both, (3.0, 2.0), 25.0)
    assert over[0] == 14.0 and over[1] == 25.0  # only 3 tops near the second, all 25 m
    alone = canopy_over([100.0], [0.0], both, (3.0, 2.0), 25.0)
    assert alone[0] == 25.0  # no neighbour: the dominant height
    x, y, h = _disc(8, 8, high=6.0)
    st = {"expected": 9, "stocked": 8, "missing": 1, "gaps": Positions(np.zeros(1), np.zeros(1))}
    assert classify_gaps(st, (x, y, h), (3.0, 2.0), 25.0)["gaps"].status[0] == MISSING
    out = classify_gaps(st, (x, y, h), (3.0, 2.0), 25.0, tops=both)
    assert out["gaps"].status[0] == SUPPRESSED and out["suppressed"] == 1


def test_canopy_over_is_the_median_of_every_top_within_reach():
    """The nearest tops read at once, and a position with more of them within reach than
    that read again in full: the median of every top within 1.5 x the larger spacing."""
    from scipy.spatial import cKDTree

    from lidartrees_gis.plantation.status import NEIGHBOUR_K, canopy_over

    rng = np.random.default_rng(4)
    tx, ty, th = rng.uniform(0, 20, 3000), rng.uniform(0, 20, 3000), rng.uniform(5, 25, 3000)
    qx, qy = rng.uniform(0, 20, 300), rng.uniform(0, 20, 300)
    larger = rng.choice([0.2, 3.0], 300)  # a handful of tops within reach, or hundreds
    near = cKDTree(np.c_[tx, ty]).query_ball_point(np.c_[qx, qy], 1.5 * larger)
    want = np.array([np.median(th[k]) if len(k) >= 3 else 30.0 for k in near])
    assert max(len(k) for k in near) > NEIGHBOUR_K and min(len(k) for k in near) < 3
    got = canopy_over(qx, qy, (tx, ty, th), (3.0, 2.0), 30.0, larger=larger)
    np.testing.assert_array_equal(got, want)
