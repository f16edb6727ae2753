"""Issue 25: the ground filter's compiled kernels give what their numpy twins (and a brute-force
answer) give, on real points and on the edge cases (ties, duplicates, sparse corners)."""
import numpy as np
import pytest

from lidartrees_gis import _accel
from lidartrees_gis.ground import _kernels as K
from lidartrees_gis.ground.filter import KrausPfeifer, kraus_pfeifer, low_points

from _paths import DATA

needs_numba = pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba kernels not in use")


def _brute_low(x, y, z, depth=2.0, k=10):
    """The definition, by brute force: sort every other point by distance (ties: by x, y, z)."""
    out = np.zeros(x.size, bool)
    for i in range(x.size):
        d = (x - x[i]) ** 2 + (y - y[i]) ** 2
        d[i] = np.inf
        nn = np.lexsort((z, y, x, d))[:k]
        out[i] = z[i] < np.sort(z[nn])[1] - depth
    return out


@pytest.fixture(scope="module")
def bcts():
    from lidartrees_gis.io.points import open_points

    f = DATA / "lasR_bcts" / "bcts_1.laz"
    if not f.exists():
        pytest.skip("shared data missing")
    p = open_points(f).read_all()
    m = (p.x < p.x.min() + 60) & (p.y < p.y.min() + 60)
    return p.x[m], p.y[m], p.z[m]


@needs_numba
def test_isolated_low_matches_brute_force_with_ties_and_duplicates():
    rng = np.random.default_rng(3)
    # a 1 cm lattice (ties in distance everywhere), duplicates, a sparse corner, low points
    x = np.round(rng.uniform(0, 20, 1500), 2)
    y = np.round(rng.uniform(0, 20, 1500), 2)
    x[:50], y[:50] = x[50:100], y[50:100]  # 50 points at the same place as others
    x = np.r_[x, 60.0, 61.0, 63.5]  # three points far from the rest
    y = np.r_[y, 60.0, 60.5, 62.0]
    z = rng.normal(10, 0.5, x.size)
    z[rng.choice(x.size, 40, replace=False)] -= 5.0  # isolated low echoes
    z[100:102] = z[102] - 6.0  # two low points side by side
    x[100:102] = x[102] + np.array([0.01, 0.02])
    y[100:102] = y[102]
    want = _brute_low(x, y, z)
    got = K.isolated_low(x, y, z, 2.0, 10)
    assert want.sum() >= 30
    np.testing.assert_array_equal(got, want)


@needs_numba
def test_isolated_low_on_real_points_matches_the_kd_tree(bcts, monkeypatch):
    x, y, z = bcts
    fast = K.isolated_low(x, y, z, 2.0, 10)
    monkeypatch.setattr(K, "HAVE_NUMBA", False)
    tree = K.isolated_low(x, y, z, 2.0, 10)
    assert fast.sum() > 100
    # the k-d tree breaks ties in distance its own way: a handful of points may differ
    assert (fast != tree).sum() <= max(3, fast.sum() // 500)


@needs_numba
def test_surface_kernels_match_their_numpy_twins(bcts):
    x, y, z = bcts
    from lidartrees_gis.grid import GridSpec
    from lidartrees_gis.ground.filter import _level_cells

    rng = np.random.default_rng(0)
    w = np.where(rng.random(x.size) < 0.3, 0.0, rng.random(x.size))
    spec = GridSpec.from_bounds(x.min(), y.min(), x.max(), y.max(), 3.0)
    idx, dx, dy = _level_cells(x, y, spec)
    n = spec.width * spec.height
    a = K.plane_surface(idx, dx, dy, z, w, n, spec.res)
    b = K._plane_surface_np(idx, dx, dy, z, w, n, spec.res)
    assert np.isfinite(a).sum() > 0.9 * n
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], atol=1e-6)
    grid = np.nan_to_num(a.reshape(spec.shape), nan=float(np.nanmean(a)))
    v = K.residuals(grid, spec.left, spec.top, spec.res, x, y, z)
    np.testing.assert_allclose(v, z - K.bilinear_np(grid, spec.left, spec.top, spec.res, x, y),
                               atol=1e-9)
    for b_ in (4.0, 2.5):
        got = K.kp_weights_fast(v - np.median(v), -2.0, 2.5, 1.0, b_)
        vv = v - np.median(v)
        with np.errstate(invalid="ignore"):
            want = np.where(vv <= -2, 1.0, np.where(vv > 0.5, 0.0, 1 / (1 + (vv + 2.0) ** b_)))
        np.testing.assert_allclose(got, want, rtol=1e-12)
    key = rng.integers(0, 50, 2000)
    sel = np.sort(rng.choice(x.size, 2000, replace=False))
    zz = np.round(z, 0)  # ties in z
    fast = K.lowest_index(sel, key, zz, 50)
    monkey = K.HAVE_NUMBA
    try:
        K.HAVE_NUMBA = False
        slow = K.lowest_index(sel, key, zz, 50)
    finally:
        K.HAVE_NUMBA = monkey
    np.testing.assert_array_equal(fast, slow)


@needs_numba
def test_filter_same_ground_with_and_without_the_kernels(bcts, monkeypatch):
    x, y, z = bcts
    g1, w1 = kraus_pfeifer(x, y, z)
    low = low_points(x, y, z, KrausPfeifer().low)
    monkeypatch.setattr(K, "HAVE_NUMBA", False)
    g2, w2 = kraus_pfeifer(x, y, z, low=low)  # the same low points: only the kernels differ
    assert 0.3 < g1.mean() < 0.7
    assert (g1 != g2).sum() <= g1.size // 10000
    assert np.median(np.abs(w1 - w2)) < 1e-9
