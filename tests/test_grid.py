import numpy as np
import pytest

from lidartrees_gis import _accel
from lidartrees_gis.errors import InputError
from lidartrees_gis.grid import GridAccumulator, GridSpec, auto_resolution, fill_mean8, rasterize


def test_grid_aligned_to_resolution_multiples():
    s = GridSpec.from_bounds(10.3, 20.7, 12.1, 22.2, 0.5)
    assert (s.left, s.top) == (10.0, 22.5)
    assert s.shape == (4, 5)  # y 20.5..22.5, x 10.0..12.5
    assert s.left % 0.5 == 0 and s.top % 0.5 == 0


def test_points_on_cell_edges_go_east_and_north():
    s = GridSpec.from_bounds(0.0, 0.0, 2.0, 2.0, 1.0)
    # far edge x=2 / y=2 extends the grid by one cell so nothing is dropped
    assert s.shape == (3, 3)
    row, col = s.cell_index(np.array([0.0, 1.0, 2.0, 0.999]), np.array([0.0, 1.0, 2.0, 0.999]))
    assert col.tolist() == [0, 1, 2, 0]
    assert row.tolist() == [2, 1, 0, 2]


def test_rasterize_exact_values_per_cell():
    x = np.array([0.1, 0.2, 0.9, 1.5, 1.0, 0.5])
    y = np.array([0.1, 0.8, 0.5, 1.5, 0.0, 1.5])
    z = np.array([1.0, 3.0, 2.0, 7.0, 5.0, 4.0])
    s = GridSpec.from_bounds(x.min(), y.min(), x.max(), y.max(), 1.0)
    assert s.shape == (2, 2)
    mx = rasterize(x, y, z, s, "max")
    mn = rasterize(x, y, z, s, "min")
    me = rasterize(x, y, z, s, "mean")
    ct = rasterize(x, y, z, s, "count")
    # bottom-left cell (row 1, col 0): z 1, 3, 2
    assert mx[1, 0] == 3.0 and mn[1, 0] == 1.0 and me[1, 0] == pytest.approx(2.0) and ct[1, 0] == 3
    # bottom-right (x=1.0 on the edge -> col 1): z 5
    assert mx[1, 1] == 5.0 and ct[1, 1] == 1
    # top row: (1.5,1.5)->col1 z7 ; (0.5,1.5)->col0 z4
    assert mx[0, 1] == 7.0 and mx[0, 0] == 4.0
    assert ct.sum() == x.size


def test_empty_cells_are_nan_and_count_zero():
    s = GridSpec.from_bounds(0, 0, 2.5, 0.5, 1.0)
    g = rasterize([0.5, 2.5], [0.5, 0.5], [1.0, 2.0], s, "max")
    assert np.isnan(g[0, 1]) and g[0, 0] == 1.0 and g[0, 2] == 2.0
    assert rasterize([0.5, 2.5], [0.5, 0.5], [1.0, 2.0], s, "count")[0, 1] == 0


def test_accumulator_chunked_equals_one_shot():
    rng = np.random.default_rng(1)
    x, y, z = rng.random(5000) * 10, rng.random(5000) * 10, rng.random(5000)
    s = GridSpec.from_bounds(0, 0, 10, 10, 0.7)
    acc = GridAccumulator(s, ("max", "min", "mean"))
    for i in range(0, 5000, 333):
        acc.add(x[i:i + 333], y[i:i + 333], z[i:i + 333])
    np.testing.assert_array_equal(acc.result("max"), rasterize(x, y, z, s, "max"))
    np.testing.assert_allclose(acc.result("mean"), rasterize(x, y, z, s, "mean"))


def test_fill_mean8_is_simultaneous_per_pass():
    # 1 x 5 row: pass 1 fills cells 1 and 3 from the original values only; pass 2 fills cell 2
    # from the values filled in pass 1. An in-place (Gauss-Seidel) sweep would give 1, 1, 1, 3, 5.
    g = np.array([[1.0, np.nan, np.nan, np.nan, 5.0]])
    np.testing.assert_allclose(fill_mean8(g), [[1.0, 1.0, 3.0, 5.0, 5.0]])
    np.testing.assert_allclose(fill_mean8(g, max_passes=1)[0, [1, 3]], [1.0, 5.0])
    assert np.isnan(fill_mean8(g, max_passes=1)[0, 2])


def test_fill_mean8_uses_all_eight_neighbours():
    g = np.arange(9, dtype=float).reshape(3, 3)
    g[1, 1] = np.nan
    assert fill_mean8(g)[1, 1] == pytest.approx((0 + 1 + 2 + 3 + 5 + 6 + 7 + 8) / 8)
    # corner: only 3 neighbours inside the grid
    h = np.array([[np.nan, 2.0], [4.0, 6.0]])
    assert fill_mean8(h)[0, 0] == pytest.approx(4.0)


def test_fill_mean8_all_empty_stays_empty_and_full_unchanged():
    assert np.isnan(fill_mean8(np.full((2, 2), np.nan))).all()
    g = np.ones((2, 2))
    np.testing.assert_array_equal(fill_mean8(g), g)


def test_auto_resolution_seed003_rule():
    # seed 003: 5 pts/m2 -> 0.45 m
    assert auto_resolution(5 * 1000, 1000.0) == pytest.approx(0.447, abs=1e-3)
    with pytest.raises(InputError, match="-tr"):
        auto_resolution(10, 0.0)


@pytest.mark.parametrize("bad", [0, -1, "abc", float("nan")])
def test_bad_resolution_names_parameter(bad):
    with pytest.raises(InputError, match="-tr"):
        GridSpec.from_bounds(0, 0, 1, 1, bad)


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not installed")
def test_fused_kernel_equals_numpy_path(monkeypatch):
    rng = np.random.default_rng(3)
    x, y, z = rng.random(20000) * 50, rng.random(20000) * 50, rng.random(20000)
    x[:10] = np.round(x[:10])  # points on cell edges
    s = GridSpec.from_bounds(1, 1, 49, 49, 0.5)  # some points fall outside
    a = GridAccumulator(s, ("max", "min", "mean"))
    a.add(x, y, z)
    monkeypatch.setattr(_accel, "HAVE_NUMBA", False)
    b = GridAccumulator(s, ("max", "min", "mean"))
    b.add(x, y, z)
    assert a.outside == b.outside > 0
    np.testing.assert_array_equal(a.count, b.count)
    for st in ("max", "min"):
        np.testing.assert_array_equal(a.result(st), b.result(st))
    np.testing.assert_allclose(a.result("mean"), b.result("mean"))


def test_a_point_on_a_cell_edge_gets_the_same_cell_in_every_grid():
    """A tile's grid and the whole area's put a point on a cell edge in the same global cell
    (the grid's bottom edge computed from its top once put points of NEON's 1 cm lattice on
    0.4 m edges into the cell below in some grids and not others)."""
    res = 0.4
    y = np.array([4097136.8, 4097134.8, 4097126.8, 4097490.4])  # on 0.4 m edges
    x = np.array([321150.45, 321159.3, 321135.88, 321346.99])
    whole = GridSpec.from_bounds(321132.8, 4097097.2, 321400.0, 4097500.0, res)
    tile = GridSpec.from_bounds(321134.0, 4097120.0, 321360.0, 4097495.2, res)
    rw, cw = whole.cell_index(x, y)
    rt, ct = tile.cell_index(x, y)
    gx_w, gy_w = whole.xy(rw, cw)
    gx_t, gy_t = tile.xy(rt, ct)
    np.testing.assert_allclose(gx_w, gx_t, atol=1e-6)
    np.testing.assert_allclose(gy_w, gy_t, atol=1e-6)
    # the cell whose bottom edge the point lies on (half-open cells: [bottom, top))
    np.testing.assert_allclose(gy_w - res / 2, y, atol=1e-6)
    acc_w, acc_t = GridAccumulator(whole, ("count",)), GridAccumulator(tile, ("count",))
    acc_w.add(x, y, np.ones(4))
    acc_t.add(x, y, np.ones(4))
    assert acc_w.outside == acc_t.outside == 0
    assert np.array_equal(np.argwhere(acc_w.count.reshape(whole.shape) > 0) - [
        int(round((whole.top - tile.top) / res)), int(round((tile.left - whole.left) / res))],
        np.argwhere(acc_t.count.reshape(tile.shape) > 0))


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba kernels not in use")
@pytest.mark.parametrize("frac,passes", [(0.3, None), (0.05, 3), (0.9, None)])
def test_fill_mean8_compiled_equals_the_numpy_passes(frac, passes, monkeypatch):
    rng = np.random.default_rng(1)
    g = rng.normal(20, 3, (120, 150))
    g[rng.random(g.shape) < frac] = np.nan
    g[10:40, 10:50] = np.nan  # a wide hole: several passes
    mask = np.ones(g.shape, bool)
    mask[:, -5:] = False  # cells outside the mask stay empty, and block the fill
    for m in (None, mask):
        a = fill_mean8(g, mask=m, max_passes=passes)
        monkeypatch.setattr(_accel, "HAVE_NUMBA", False)
        b = fill_mean8(g, mask=m, max_passes=passes)
        monkeypatch.setattr(_accel, "HAVE_NUMBA", True)
        assert np.isnan(a).sum() < np.isnan(g).sum()
        np.testing.assert_array_equal(a, b)


def test_compiled_footprint_and_bilinear_equal_scipy():
    """The compiled data footprint is scipy's distance transform test, cell for cell, and the
    compiled bilinear sample is map_coordinates(order=1, mode="nearest") and its numpy twin."""
    from scipy import ndimage

    from lidartrees_gis import _raster

    rng = np.random.default_rng(3)
    for _ in range(300):
        shape = (int(rng.integers(1, 30)), int(rng.integers(1, 30)))
        occ = rng.random(shape) < rng.random()
        occ.flat[0] = True
        res, dist = rng.uniform(0.2, 1.5), rng.uniform(0.1, 3.0)
        want = ndimage.distance_transform_edt(~occ) * res <= dist
        assert np.array_equal(_raster.within_distance(occ, res, dist), want)
    g = rng.random((20, 30)) * 50
    row, col = rng.uniform(-2, 22, 5000), rng.uniform(-2, 32, 5000)
    got = _raster.sample_bilinear(g, row, col)
    np.testing.assert_allclose(got, ndimage.map_coordinates(g, [row, col], order=1, mode="nearest"),
                               rtol=0, atol=1e-12)
    assert got.min() >= g.min() and got.max() <= g.max()
    compiled = _raster.HAVE_NUMBA
    try:
        _raster.HAVE_NUMBA = False
        assert np.array_equal(_raster.sample_bilinear(g, row, col), got)
        assert np.array_equal(_raster.within_distance(occ, 0.5, 2.0),
                              ndimage.distance_transform_edt(~occ) * 0.5 <= 2.0)
    finally:
        _raster.HAVE_NUMBA = compiled
