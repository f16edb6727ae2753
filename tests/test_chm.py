"""Pit-free / TIN CHMs, the noise guard and the automatic cell size (issue 9)."""
import numpy as np
import pytest

from lidartrees_gis import _accel
from lidartrees_gis.als.chm import canopy_outliers, chm_resolution, crown_scale, pitfree_chm
from lidartrees_gis.tin import tin_surface
from lidartrees_gis.grid import GridSpec


def test_chm_resolution_rule():
    assert chm_resolution(47_000, 10_000.0) == 0.45     # 4.7 pts/m2 -> sqrt(1/n) = 0.461
    assert chm_resolution(40_000, 10_000.0) == 0.5      # 4 pts/m2
    assert chm_resolution(250_000, 10_000.0) == 0.25    # 25 pts/m2: the 0.25 m floor
    assert chm_resolution(15_000, 10_000.0) == 0.8      # 1.5 pts/m2 -> 0.816


def test_tin_of_a_plane_is_the_plane_and_long_edges_leave_holes():
    rng = np.random.default_rng(1)
    x = 500_000 + rng.random(4000) * 20
    y = 7_000_000 + rng.random(4000) * 20
    x[(x > 500_008) & (x < 500_012)] += 10.0  # a 4 m wide strip without points
    keep = x < 500_020
    x, y = x[keep], y[keep]
    z = 2.0 * (x - 500_000) + 3.0 * (y - 7_000_000) + 1.0
    spec = GridSpec.from_bounds(500_000, 7_000_000, 500_020, 7_000_020, 0.5)
    full = tin_surface(x, y, z, spec)
    r, c = np.nonzero(np.isfinite(full))
    cx, cy = spec.xy(r, c)
    np.testing.assert_allclose(full[r, c], 2.0 * (cx - 500_000) + 3.0 * (cy - 7_000_000) + 1.0,
                               atol=1e-4)
    cut = tin_surface(x, y, z, spec, max_edge=1.0)
    col = int((500_010 - spec.left) / 0.5)
    assert np.isnan(cut[:, col]).all() and np.isfinite(full[5:-5, col]).all()


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_compiled_and_numpy_tin_agree(monkeypatch):
    rng = np.random.default_rng(2)
    x, y = rng.random(3000) * 30, rng.random(3000) * 30
    z = np.sin(x) * 3 + y * 0.2 + rng.random(3000)
    spec = GridSpec.from_bounds(0, 0, 30, 30, 0.3)
    a = tin_surface(x, y, z, spec, max_edge=0.8)
    monkeypatch.setattr(_accel, "HAVE_NUMBA", False)
    b = tin_surface(x, y, z, spec, max_edge=0.8)
    # the compiled path offsets points by < 5 µm (tie-break), so edges and values agree to that
    assert (np.isnan(a) != np.isnan(b)).mean() < 1e-3
    both = np.isfinite(a) & np.isfinite(b)
    np.testing.assert_allclose(a[both], b[both], atol=1e-3)


def _cone_points(rng, n=6000, top=20.0, radius=3.0, ground_share=0.2):
    """First returns on a cone crown; ``ground_share`` of them fall through to the ground."""
    x = rng.uniform(-4, 4, n)
    y = rng.uniform(-4, 4, n)
    d = np.hypot(x, y)
    z = np.clip(top * (1 - d / radius), 0, None)
    through = rng.random(n) < ground_share
    z[through] = 0.0
    return x, y, z


def test_pitfree_fills_the_pits_that_the_max_chm_keeps():
    from lidartrees_gis.grid import GridAccumulator, fill_gaps

    rng = np.random.default_rng(3)
    x, y, z = _cone_points(rng, n=900, ground_share=0.25)  # ~14 returns per m2
    spec = GridSpec.from_bounds(-4, -4, 4, 4, 0.25)
    acc = GridAccumulator(spec, ("max",))
    acc.add(x, y, z)
    mx = fill_gaps(acc.result("max"), "mean8")
    pf = pitfree_chm(x, y, z, spec, max_edge=(0.0, 1.5))
    r, c = np.mgrid[0:spec.height, 0:spec.width]
    cx, cy = spec.xy(r.ravel(), c.ravel())
    cone = np.clip(20 * (1 - np.hypot(cx, cy) / 3.0), 0, None).reshape(spec.shape)
    inner = cone > 5  # inside the crown, away from its edge
    pits_max = (mx < cone - 3) & inner
    pits_pf = (pf < cone - 3) & inner
    assert pits_max.sum() > 10 and pits_pf.sum() == 0
    # and it never invents height: at most the highest return near the cell
    assert np.nanmax(pf) <= z.max() + 1e-9


def test_canopy_outliers_flag_noise_but_keep_a_tall_tree():
    res = 0.5
    chm = np.full((120, 120), 20.0) + np.random.default_rng(4).normal(0, 0.5, (120, 120))
    yy, xx = np.mgrid[0:120, 0:120]
    cone = 45.0 - np.hypot(yy - 60, xx - 60) * res * 6.0  # an emergent tree 25 m above the canopy
    chm = np.maximum(chm, cone)
    noise = [(10, 10), (10, 11), (100, 30), (30, 100)]
    for r, c in noise:
        chm[r, c] = 150.0
    mask, ceiling = canopy_outliers(chm, res)
    assert {tuple(p) for p in np.argwhere(mask)} == set(noise)
    assert not mask[60, 60] and (ceiling < 150).all()


def test_crown_scale_grows_with_the_crowns():
    def stand(radius, spacing, res=0.25, n=240):
        yy, xx = np.mgrid[0:n, 0:n] * res
        ty = (np.floor(yy / spacing) + 0.5) * spacing
        tx = (np.floor(xx / spacing) + 0.5) * spacing
        d = np.hypot(yy - ty, xx - tx)
        return np.clip(20 - 10 * (d / radius) ** 2, 2, None)

    small = crown_scale(stand(1.2, 2.0), 0.25)
    big = crown_scale(stand(3.6, 6.0), 0.25)
    assert 0.2 < small < 1.2 and 2.0 < big / small < 4.5
    assert np.isnan(crown_scale(np.zeros((50, 50)), 0.25))


def test_crown_scale_leaves_roads_and_clearings_out():
    """Stands of 1.2 m crowns 2 m apart cut by 8 m roads every 60 m and a 40 x 40 m clearing:
    the roads' edges no longer set the scale (they made it 3-4 times the crowns'), and a gap
    of one missing tree (4 m², under 500 m²) is still part of the canopy."""
    res, n = 0.25, 1200
    yy, xx = np.mgrid[0:n, 0:n] * res
    ty, tx = (np.floor(yy / 2.0) + 0.5) * 2.0, (np.floor(xx / 2.0) + 0.5) * 2.0
    chm = np.clip(20 - 10 * (np.hypot(yy - ty, xx - tx) / 1.2) ** 2, 2, None)
    chm += np.random.default_rng(5).normal(0, 0.3, chm.shape)
    inside = crown_scale(chm, res)
    roads = chm.copy()
    roads[(yy % 60.0) < 8.0] = 0.1
    roads[(xx % 60.0) < 8.0] = 0.1
    roads[(yy > 150) & (yy < 190) & (xx > 150) & (xx < 190)] = 0.1
    kept = crown_scale(roads, res, open_area=np.inf)
    assert kept > 2.0 * inside, (kept, inside)
    assert abs(crown_scale(roads, res) / inside - 1) < 0.15, (crown_scale(roads, res), inside)


def test_surfaces_do_not_depend_on_the_order_of_the_points(tmp_path):
    """Ground returns on a 1 cm lattice often tie in height within a cell; the DTM (and so the
    CHM) once took whichever came first in the file (bcts_1 shuffled: 796 CHM cells up to 3.2 m
    apart). Now the same points in any order give the same rasters."""
    import rasterio
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.als.rasters import chm_run

    rng = np.random.default_rng(3)
    n_g, n_v = 6000, 12000
    gx, gy = rng.random(n_g) * 40, rng.random(n_g) * 40
    gz = np.round(100 + 0.05 * gx + rng.integers(0, 3, n_g) * 0.01, 2)  # many ties per cell
    vx, vy = rng.random(n_v) * 40, rng.random(n_v) * 40
    vz = np.round(100 + 0.05 * vx + 5 + 15 * rng.random(n_v), 2)
    x, y, z = np.r_[gx, vx] + 500_000, np.r_[gy, vy] + 7_000_000, np.r_[gz, vz]
    cls = np.r_[np.full(n_g, 2), np.full(n_v, 1)].astype(np.uint8)
    outs = []
    for k, order in enumerate((np.arange(x.size), rng.permutation(x.size), np.arange(x.size)[::-1])):
        f = tmp_path / f"p{k}.las"
        write_points(f, x[order], y[order], z[order], crs=CRS.from_epsg(31984),
                     classification=cls[order])
        chm_run(f, tmp_path / f"c{k}.tif", dtm_out=tmp_path / f"d{k}.tif")
        with rasterio.open(tmp_path / f"c{k}.tif") as c, rasterio.open(tmp_path / f"d{k}.tif") as d:
            outs.append((c.read(1), d.read(1)))
    for c, d in outs[1:]:
        assert np.array_equal(c, outs[0][0]) and np.array_equal(d, outs[0][1])
    assert np.isfinite(outs[0][1]).all() and outs[0][0].max() > 10


def test_nanpercentile_last_is_numpys_nanpercentile():
    import warnings

    from lidartrees_gis.als.chm import nanpercentile_last

    rng = np.random.default_rng(0)
    a = rng.random((40, 30, 25)) * 30
    a[rng.random(a.shape) < 0.4] = np.nan
    a[0, 0] = np.nan  # an empty block
    a[1, 1, :24] = np.nan  # one value
    for q in (0, 37.5, 90, 100):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            ref = np.nanpercentile(a, q, axis=2)
        np.testing.assert_array_equal(nanpercentile_last(a, q), ref)


def _spy_layered_tin(monkeypatch):
    """Record what each call of the compiled triangulation returns."""
    calls = []
    real = _accel.layered_tin

    def spy(*args, **kw):
        calls.append(real(*args, **kw))
        return calls[-1]

    monkeypatch.setattr(_accel, "layered_tin", spy)
    return calls


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_compiled_triangulation_on_a_lattice_with_rows_and_coincident_points(monkeypatch):
    """Points on an exact 0.5 m lattice (every four neighbours cocircular, long collinear
    rows), some repeated with another height: the compiled Bowyer-Watson triangulation must
    give the surface startinpy's (coincident points keep the highest) and Qhull's give."""
    from lidartrees_gis import tin as tin_mod
    from lidartrees_gis.als import chm as chm_mod

    rng = np.random.default_rng(21)
    gx, gy = np.meshgrid(np.arange(0, 30, 0.5), np.arange(0, 20, 0.5))
    x, y = gx.ravel() + 600_000.0, gy.ravel() + 7_400_000.0
    z = np.round(rng.uniform(0, 25, x.size), 2)
    rep = rng.choice(x.size, 300, replace=False)
    x = np.concatenate([x, x[rep]])
    y = np.concatenate([y, y[rep]])
    z = np.concatenate([z, z[rep] + np.where(rng.random(300) < 0.5, 3.0, -3.0)])
    shuffle = rng.permutation(x.size)
    x, y, z = x[shuffle], y[shuffle], z[shuffle]
    spec = GridSpec.from_bounds(600_000 - 1, 7_400_000 - 1, 600_031, 7_400_021, 0.2)
    inserted = _spy_layered_tin(monkeypatch)
    ours = tin_surface(x, y, z, spec, max_radius=chm_mod.LOCAL_RADIUS)
    assert inserted == [x.size - 300]  # each coincident pair became one vertex
    monkeypatch.setattr(_accel, "layered_tin", lambda *a, **k: -2)
    startin = tin_surface(x, y, z, spec, max_radius=chm_mod.LOCAL_RADIUS)
    assert np.array_equal(np.isnan(ours), np.isnan(startin))
    np.testing.assert_allclose(ours, startin, atol=1e-9)
    # the highest of two coincident points is used: equal to Qhull on the deduplicated points
    key = np.round(x * 100).astype(np.int64) * 10**10 + np.round(y * 100).astype(np.int64)
    order = np.lexsort((-z, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    u = order[first]
    monkeypatch.setattr(tin_mod, "_startinpy", lambda: None)
    qhull = tin_surface(x[u], y[u], z[u], spec, max_radius=chm_mod.LOCAL_RADIUS)
    np.testing.assert_allclose(ours, qhull, atol=1e-9)
    rows, cols = np.mgrid[0:spec.height, 0:spec.width]
    cx, cy = spec.xy(rows, cols)
    dx, dy = np.minimum(cx - 600_000, 600_029.5 - cx), np.minimum(cy - 7_400_000, 7_400_019.5 - cy)
    inside, outside = (dx > 0.01) & (dy > 0.01), (dx < -0.01) | (dy < -0.01)
    assert np.isfinite(ours[inside]).all() and np.isnan(ours[outside]).all()


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_compiled_triangulation_refuses_what_it_cannot_triangulate():
    x = np.array([0.0, 1.0, 0.0, 1.0])
    y = np.array([0.0, 0.0, 1.0, 1.0])
    z = np.array([1.0, 2.0, 3.0, 4.0])
    out = np.full((4, 4), np.nan)
    grid = (0.0, 1.0, 0.25, 4, 4)
    assert _accel.layered_tin(x, y, z, [4], [0.0], 10.0, *grid, out) == 4
    assert np.isfinite(out).sum() >= 9 and np.nanmax(out) <= 4.0
    y_nan = y.copy()
    y_nan[2] = np.nan  # left to the fallback triangulators
    assert _accel.layered_tin(x, y_nan, z, [4], [0.0], 10.0, *grid, np.full((4, 4), np.nan)) == -3
    with pytest.raises(ValueError, match="bands"):
        _accel.layered_tin(x, y, z, [3], [0.0], 10.0, *grid, out)
    with pytest.raises(ValueError, match="circumradius"):
        _accel.layered_tin(x, y, z, [4], [0.0], 0.0, *grid, out)


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_pitfree_from_one_triangulation_equals_one_triangulation_per_layer(monkeypatch):
    """The layers are built from the top down in one triangulation (each point inserted once);
    the CHM must equal the one from a separate triangulation of every layer."""
    from lidartrees_gis import tin as tin_mod
    from lidartrees_gis.als import chm as chm_mod

    rng = np.random.default_rng(8)
    parts = []
    for cx, cy, top in ((3, 3, 22.0), (9, 4, 14.0), (5, 10, 8.0), (11, 11, 3.5)):
        x, y, z = _cone_points(rng, n=1500, top=top, radius=2.5, ground_share=0.2)
        inside = rng.random(z.size) < 0.3  # returns from inside the crown, at any depth
        z[inside] *= rng.uniform(0.1, 1.0, inside.sum())
        parts.append((x + cx, y + cy, z))
    x, y, z = (np.concatenate(p) for p in zip(*parts))
    x, y = x + 500_000, y + 7_000_000
    spec = GridSpec.from_bounds(500_000 - 1, 7_000_000 - 1, 500_015, 7_000_015, 0.25)
    inserted = _spy_layered_tin(monkeypatch)
    one = pitfree_chm(x, y, z, spec, max_edge=(0.0, 0.6))
    assert inserted == [x.size]  # the compiled triangulation ran, every point inserted once
    # startinpy's triangulation (the fallback when the compiled predicates fail) ...
    monkeypatch.setattr(_accel, "layered_tin", lambda *a, **k: -2)
    fallback = pitfree_chm(x, y, z, spec, max_edge=(0.0, 0.6))
    # ... and Qhull, one triangulation per layer
    monkeypatch.setattr(tin_mod, "_startinpy", lambda: None)
    per_layer = pitfree_chm(x, y, z, spec, max_edge=(0.0, 0.6))
    for other in (fallback, per_layer):
        assert np.array_equal(np.isnan(one), np.isnan(other))
        np.testing.assert_allclose(one, other, atol=1e-9)
    # and the upper layers did fill something the first (all points) layer alone leaves low
    first = tin_surface(x, y, z, spec, max_radius=chm_mod.LOCAL_RADIUS)
    assert (one > first + 1.0).sum() > 20


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_compiled_lowest_points_equal_numpy(monkeypatch):
    from lidartrees_gis.grid import LowestPoints

    rng = np.random.default_rng(9)
    x = np.round(rng.random(20_000) * 10, 2)
    y = np.round(rng.random(20_000) * 10, 2)
    z = np.round(rng.integers(0, 4, 20_000) * 0.01, 2)  # many ties in z within a cell
    spec = GridSpec.from_bounds(0, 0, 10, 10, 1.0)
    got = []
    for numba_on in (True, False):
        monkeypatch.setattr(_accel, "HAVE_NUMBA", numba_on)
        lp = LowestPoints(spec)
        for part in np.array_split(rng.permutation(x.size), 3):  # chunk by chunk
            lp.add(x[part], y[part], z[part])
        got.append((lp.z.copy(), lp.x.copy(), lp.y.copy(), lp.count.copy()))
    for a, b in zip(*got):
        assert np.array_equal(a, b)
    full = got[0][3] > 100  # the 100 cells inside the points' square
    assert full.sum() == 100 and (got[0][0][full] == 0).all()


def test_crown_scale_of_a_grid_smaller_than_its_lag_window():
    """A CHM a few cells wide (a TLS tree, a slice) has fewer lags than the 15 m the crown
    scale looks at: it is measured over the lags the grid holds (this raised a ValueError)."""
    rng = np.random.default_rng(0)
    for shape in ((6, 6), (8, 60), (60, 8), (4, 200)):
        a = 10.0 + rng.random(shape) * 5.0
        v = crown_scale(a, 0.25)
        assert np.isnan(v) or 0.25 <= v <= 10.0


def test_a_sub_box_has_the_chm_of_the_whole_away_from_its_edges(tmp_path):
    """Ground on a slope, points on a 1 cm lattice (as LAS files store them): the pit-free CHM
    of a box with 20 m around a core equals the whole area's in the core. The heights above the
    DTM of the ground points it was made from are 0 in any grid (their sign, left to the
    rounding of the interpolation, once decided whether the first layer took them)."""
    from pyproj import CRS

    from lidartrees_gis.als.surfaces import SurfaceOptions, compute_surfaces
    from lidartrees_gis.catalog.catalog import Catalog
    from lidartrees_gis.catalog.source import TileSource
    from lidartrees_gis.io.lasout import write_points

    rng = np.random.default_rng(5)
    n = 60_000
    x, y = 885_000 + rng.random(n) * 90, 629_100 + rng.random(n) * 90
    ground = rng.random(n) < 0.3
    z = 300 + 0.1 * (x - 885_000) + np.where(ground, 0.0, 2 + 18 * rng.random(n))
    x, y, z = np.round(x, 2), np.round(y, 2), np.round(z, 2)
    f = tmp_path / "g.laz"
    write_points(f, x, y, z, crs=CRS.from_epsg(3005), classification=np.where(ground, 2, 1))
    cat = Catalog.open(f)
    core = (885_030.0, 629_130.0, 885_060.0, 629_160.0)
    box = (core[0] - 20, core[1] - 20, core[2] + 20, core[3] + 20)
    whole = compute_surfaces(TileSource(cat, cat.extent), 0.3, SurfaceOptions())
    part = compute_surfaces(TileSource(cat, box), 0.3, SurfaceOptions(),
                            stats=whole["stats"])
    ws, ps = whole["spec"], part["spec"]
    r0, c0 = int(round((ws.top - ps.top) / 0.3)), int(round((ps.left - ws.left) / 0.3))
    a = whole["chm"][r0:r0 + ps.height, c0:c0 + ps.width]
    b = part["chm"]
    rows, cols = np.mgrid[0:ps.height, 0:ps.width]
    cx, cy = ps.xy(rows, cols)
    inner = (cx > core[0]) & (cx < core[2]) & (cy > core[1]) & (cy < core[3])
    assert inner.sum() > 9000 and np.array_equal(np.isnan(a[inner]), np.isnan(b[inner]))
    assert np.nanmax(np.abs(a[inner] - b[inner])) <= 1e-4


@pytest.mark.parametrize("res", [0.5, 2.0])
def test_the_trees_dtm_is_the_whole_dtm_within_the_data(tmp_path, res):
    """``whole_dtm=False`` (the trees chain) leaves the terrain NaN only beyond the data: every
    other surface, and the DTM within reach of the data, are those of the whole DTM; the DSM,
    which the trees do not read, is not filled (None) unless the CHM is made from it."""
    from pyproj import CRS

    from lidartrees_gis.als.surfaces import SurfaceOptions, compute_surfaces
    from lidartrees_gis.catalog.catalog import Catalog
    from lidartrees_gis.catalog.source import TileSource
    from lidartrees_gis.io.lasout import write_points

    rng = np.random.default_rng(9)
    n = 40_000
    x, y = 600_000 + rng.random(n) * 120, 7_500_000 + rng.random(n) * 120
    keep = ~((x > 600_050) & (y > 7_500_050))  # a 70 x 70 m corner without points
    x, y = x[keep], y[keep]
    ground = rng.random(x.size) < 0.3
    z = 500 + 0.2 * (y - 7_500_000) + np.where(ground, 0.0, 3 + 15 * rng.random(x.size))
    f = tmp_path / "corner.laz"
    write_points(f, np.round(x, 2), np.round(y, 2), np.round(z, 2), crs=CRS.from_epsg(31983),
                 classification=np.where(ground, 2, 1))
    cat = Catalog.open(f)
    kw = dict(keep_points=True)
    a = compute_surfaces(TileSource(cat, cat.extent), res, SurfaceOptions(), **kw)
    b = compute_surfaces(TileSource(cat, cat.extent), res, SurfaceOptions(), whole_dtm=False,
                         **kw)
    for k in ("chm", "heights", "returns"):
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    assert a["dsm"] is not None and b["dsm"] is None
    m = compute_surfaces(TileSource(cat, cat.extent), res, SurfaceOptions(chm="max"),
                         whole_dtm=False)
    assert np.array_equal(m["dsm"], a["dsm"], equal_nan=True)  # -chm max: the CHM is DSM - DTM
    for i in range(3):
        assert np.array_equal(a["points_above_ground"][i], b["points_above_ground"][i])
    assert np.isfinite(a["dtm"]).all()
    empty = np.isnan(b["dtm"])
    assert empty.sum() > 0.15 * empty.size  # most of the empty corner
    assert np.array_equal(a["dtm"][~empty], b["dtm"][~empty])
