import numpy as np
import pytest
from scipy import ndimage

from lidartrees_gis.als.tops import local_maxima, treex_maxima, variable_window_maxima
from lidartrees_gis.grid import GridSpec
from lidartrees_gis.als.crowns import (marker_watershed, rank_levels, region_growing,
    treex_growing, vincent_soille)
from lidartrees_gis.als.trees import TreeParams, detect_trees
from lidartrees_gis.report.evaluate import accuracy


def paraboloids(shape, tops, radius=6.0):
    """CHM of paraboloid crowns: tops = [(row, col, height)], crown radius in cells."""
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    chm = np.zeros(shape)
    owner = np.zeros(shape, int)
    for k, (r, c, h) in enumerate(tops, 1):
        z = h - h * ((yy - r) ** 2 + (xx - c) ** 2) / radius ** 2 * 0.5
        better = z > chm
        chm[better] = z[better]
        owner[better] = k
    return chm, owner


TOPS = [(10, 10, 20.0), (10, 25, 18.0), (24, 12, 22.0), (25, 27, 15.0)]


def test_local_maxima_exact_tops():
    chm, _ = paraboloids((36, 38), TOPS)
    r, c = local_maxima(chm, min_height=2)
    assert sorted(zip(r.tolist(), c.tolist())) == sorted((t[0], t[1]) for t in TOPS)


def test_min_height_discards_low_tops():
    chm, _ = paraboloids((36, 38), TOPS)
    r, _ = local_maxima(chm, min_height=16)
    assert len(r) == 3


def test_flat_top_yields_single_treetop():
    chm = np.zeros((7, 8))
    chm[2:4, 2:6] = 10.0  # a 2 x 4 plateau
    r, c = local_maxima(chm)
    assert (r.tolist(), c.tolist()) == ([2], [3])  # nearest to centroid (2.5, 3.5), then row, col


def test_regions_hold_their_tops_and_follow_the_crowns():
    chm, owner = paraboloids((36, 38), TOPS)
    r, c = local_maxima(chm)
    for labels in (region_growing(chm, r, c, step=0.1, min_height=2),
                   treex_growing(chm, r, c, 1.0, max_crown_area=1000, min_crown_height=2),
                   marker_watershed(chm, r, c, min_height=2)):
        assert labels[r, c].tolist() == list(range(1, len(r) + 1))
        inside = (labels > 0) & (chm > 4)
        # crown membership equals the paraboloid that owns the cell (up to boundary cells)
        mapping = {i + 1: owner[r[i], c[i]] for i in range(len(r))}
        agree = np.mean([mapping[v] == o for v, o in zip(labels[inside], owner[inside])])
        assert agree > 0.97


def test_region_growing_step_and_floor():
    chm, _ = paraboloids((36, 38), TOPS)
    r, c = local_maxima(chm)
    lab = region_growing(chm, r, c, step=0.1, min_height=5)
    assert np.all(chm[lab > 0] > 5)
    assert lab.max() == len(r)


def test_treex_max_crown_area_in_cells():
    chm, _ = paraboloids((36, 38), TOPS)
    r, c = local_maxima(chm)
    lab = treex_growing(chm, r, c, 0.5, max_crown_area=10.0)  # 10 m2 = 40 cells of 0.25 m2
    assert np.bincount(lab.ravel())[1:].max() == 40


def test_treex_window_finds_tops():
    chm, _ = paraboloids((36, 38), TOPS)
    want = {(t[0], t[1]) for t in TOPS}
    r, c = treex_maxima(chm, 1.0, mean_crown_area=25.0, sd_crown_area=4.0, local=True)
    assert set(zip(r.tolist(), c.tolist())) == want
    # as the seed defines it (no local test) every top is found, and flank cells beside
    r, c = treex_maxima(chm, 1.0, mean_crown_area=25.0, sd_crown_area=4.0)
    got = set(zip(r.tolist(), c.tolist()))
    assert want < got
    r2, _ = variable_window_maxima(chm, 1.0)
    assert len(r2) == 4


def test_two_basin_watershed_with_line_matches_skimage():
    from skimage.segmentation import watershed

    chm, _ = paraboloids((20, 30), [(10, 8, 10.0), (10, 21, 12.0)])
    vs = vincent_soille(chm)
    assert set(np.unique(vs)) == {0, 1, 2}
    line = vs == 0
    assert line.any() and np.all(np.abs(np.nonzero(line)[1] - 14.5) <= 2)
    levels, _ = rank_levels(chm)
    sk = watershed(levels, connectivity=2, watershed_line=True)
    assert sk.max() == vs.max() == 2
    both = (vs > 0) & (sk > 0)
    # same partition up to label names, and nearly the same line
    pairs = set(zip(vs[both].tolist(), sk[both].tolist()))
    assert len(pairs) == 2
    assert abs(int((sk == 0).sum()) - int(line.sum())) <= 10


def test_rank_levels_inverts_heights():
    lv, valid = rank_levels(np.array([[3.0, 5.0], [5.0, np.nan]]))
    assert lv.tolist() == [[2, 1], [1, 3]] and valid.tolist() == [[True, True], [True, False]]


@pytest.mark.parametrize("method", ["rg", "treex", "watershed", "mcws"])
def test_every_crown_holds_exactly_its_top(method):
    chm, _ = paraboloids((36, 38), TOPS)
    spec = GridSpec(0.0, 36.0, 1.0, 38, 36)
    res = detect_trees(chm, spec, TreeParams(method=method, mean_crown_area=25, sd_crown_area=4,
                                             max_crown_area=500, treex_local=True))
    t, lab = res["table"], res["labels"]
    assert len(t["tree_id"]) == 4 and len(set(t["tree_id"].tolist())) == 4
    assert lab[t["row"], t["col"]].tolist() == [1, 2, 3, 4]
    np.testing.assert_allclose(t["crown_diameter"], np.sqrt(4 * t["crown_area"] / np.pi))
    for i in range(4):
        assert t["height"][i] == pytest.approx(chm[lab == i + 1].max())


def test_synthetic_stand_default_method_meets_targets(stand):
    from lidartrees_gis.als.surfaces import SurfaceOptions, compute_surfaces
    from lidartrees_gis.io.options import ReadOptions
    from lidartrees_gis.synthetic import write_xyz_seed_dialect

    pts, truth = stand
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.xyz"
        write_xyz_seed_dialect(p, pts)
        s = compute_surfaces(ReadOptions(a_srs="EPSG:29194").open(p), 0.5,
                             SurfaceOptions(dtm="auto", chm="max"))
    res = detect_trees(s["chm"], s["spec"], TreeParams())
    a = accuracy(res["table"], truth, max_dist=1.0)
    assert a["f_score"] >= 0.95
    assert a["height_rmse"] <= 0.3
    assert a["crown_diameter_rmse"] <= 0.5


def test_crown_polygons_outline_each_label_with_holes_and_one_piece():
    """Outlines of a label grid, built in one vectorised call: the exact cell outlines, a hole
    kept, a crown in two 4-connected pieces gives its larger piece, labels over n ignored."""
    from lidartrees_gis.grid import GridSpec
    from lidartrees_gis.als.metrics import crown_polygons

    lab = np.zeros((12, 12), np.int32)
    lab[1:3, 1:3] = 1
    lab[3:6, 3:6] = 1  # touches the first piece only at a corner: larger piece wins
    lab[6:11, 6:11] = 2
    lab[8, 8] = 0  # a hole
    lab[0, 10] = 5  # not one of the n = 3 crowns
    spec = GridSpec.from_bounds(0, 0, 12, 12, 1.0)
    p = crown_polygons(lab, spec, 3)
    assert p[2] is None and len(p) == 3
    t = spec.top
    assert p[0].geom_type == "Polygon" and p[0].area == 9 and p[0].bounds == (3, t - 6, 6, t - 3)
    assert p[1].area == 24 and len(p[1].interiors) == 1 and p[1].is_valid
    assert p[1].bounds == (6, t - 11, 11, t - 6)


def test_traced_crown_outlines_equal_gdal_polygonize():
    """The compiled outline tracer gives GDAL's polygons (rasterio ``shapes``, 4-connected) on
    random label grids full of holes, diagonal touches and crowns in several pieces."""
    from lidartrees_gis import _accel
    from lidartrees_gis.grid import GridSpec
    import shapely

    from lidartrees_gis.als.metrics import _crown_polygons_gdal, crown_polygons, outline_rings

    if not _accel.HAVE_NUMBA:
        pytest.skip("numba not in use: crown_polygons is GDAL's")
    rng = np.random.default_rng(7)
    spec = GridSpec.from_bounds(300_000.0, 7_400_000.0, 300_024.0, 7_400_018.0, 0.5)
    n_multi = n_holes = 0
    for t in range(40):
        n = int(rng.integers(1, 12))
        lab = rng.integers(0, n + 3, spec.shape)  # labels over n are not crowns
        if t % 2:  # blobs: smoother regions with holes
            lab = ndimage.median_filter(lab, size=3)
        a = crown_polygons(lab, spec, n)
        b = _crown_polygons_gdal(lab, spec, n)
        assert len(a) == len(b) == n
        # straight to WKB (the chain's path): the bytes shapely writes of the same polygons
        w = crown_polygons(lab, spec, n, wkb=True)
        assert list(w) == [None if p is None else shapely.to_wkb(p) for p in a]
        _, _, ring_lab, _, area, _ = outline_rings(lab, n)
        pieces = np.bincount(ring_lab[area > 0], minlength=n + 1)
        n_multi += int((pieces > 1).sum())
        for k, (p, q) in enumerate(zip(a, b), start=1):
            assert (p is None) == (q is None)
            if p is not None:
                assert p.geom_type == "Polygon" and p.is_valid
                n_holes += len(p.interiors)
                # pieces of equal area: either is the largest (the first traced is kept)
                assert p.equals(q) if pieces[k] == 1 else p.area == q.area
    assert n_multi > 50 and n_holes > 50  # the cases were there


def _annex2_reference(chm, seeds_r, seeds_c, hmax, hmin, step, labels):
    """Seed 000 Annex 2 as written: every pass visits every queued cell in queue order (the
    library visits only the cells that can act in a pass; the labels must be the same)."""
    H, W = chm.shape
    q = [(int(r), int(c)) for r, c in zip(seeds_r, seeds_c)]
    for i, (r, c) in enumerate(q):
        labels[r, c] = i + 1
    k = 1
    thr = hmax - k * step  # Annex 2: the grid's maximum minus k ajuste
    while thr > hmin and q:
        keep = []
        pos = 0
        while pos < len(q):
            r, c = q[pos]
            pos += 1
            open_nb = False
            for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                if rr < 0 or rr >= H or cc < 0 or cc >= W or labels[rr, cc] != 0:
                    continue
                if chm[rr, cc] > thr:
                    labels[rr, cc] = labels[r, c]
                    q.append((rr, cc))
                elif chm[rr, cc] > hmin:
                    open_nb = True
            if open_nb:
                keep.append((r, c))
        q = keep
        k += 1
        thr = hmax - k * step
    return labels


@pytest.mark.parametrize("step,min_height", [(0.1, 2.0), (0.5, 2.0), (2.0, 2.0), (0.1, -1.0),
                                             (0.25, 0.0)])
def test_region_growing_equals_annex2_visiting_every_cell(step, min_height):
    """Crowns that touch and compete for cells, NaN holes, plateaus (ties) and seeds in a
    given order: the same labels as visiting every queued cell in every pass."""
    rng = np.random.default_rng(int(step * 100) + 7)
    chm = ndimage.gaussian_filter(rng.random((90, 110)), 2.0)
    chm = (chm - chm.min()) / (chm.max() - chm.min()) * 28.0 - 0.5
    chm[rng.random(chm.shape) < 0.03] = np.nan
    chm[40:46, 50:58] = 12.0  # a plateau
    chm = np.round(chm, 1)  # heights on the thresholds themselves
    peaks = ndimage.maximum_filter(np.nan_to_num(chm, nan=-1), 7) == np.nan_to_num(chm, nan=-1)
    r, c = np.nonzero(peaks & (np.nan_to_num(chm, nan=-1) > 3))
    order = rng.permutation(r.size)
    r, c = r[order], c[order]
    got = region_growing(chm, r, c, step=step, min_height=min_height)
    a = np.where(np.isnan(chm), -np.inf, chm)
    ref = _annex2_reference(a, r, c, float(np.nanmax(chm)), min_height, step,
                            np.zeros(chm.shape, np.int64))
    assert r.size > 20 and (ref > 0).sum() > 2000
    np.testing.assert_array_equal(got, ref)
