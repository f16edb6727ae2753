"""Height metrics per group (lidartrees_gis.inventory.metrics) against lidR's definitions,
written out here one group at a time as lidR's R code states them, and against scipy."""
import math

import numpy as np
import pytest
from scipy import stats

from lidartrees_gis.inventory.metrics import METRICS, STD_Z, group_metrics


def _find_interval(z, breaks):
    """R's findInterval: the number of breaks <= z."""
    return np.searchsorted(breaks, z, side="right")


def _r_seq(a, b, by):
    """R's seq(a, b, by): a + (0:n) * by clipped at b."""
    n = int((b - a) / by + 1e-10)
    return np.minimum(a + np.arange(n + 1) * by, b)


def lidr_stdmetrics_z(z):
    """lidR 4.x stdmetrics_z(z, dz = 1, th = 2, zmin = 0), line by line."""
    z = np.asarray(z, float)
    n = z.size
    zmax, zmean = z.max(), z.mean()
    out = {"zmax": zmax, "zmean": zmean, "zsd": np.std(z, ddof=1) if n > 1 else np.nan}
    d = z - zmean
    with np.errstate(invalid="ignore", divide="ignore"):
        out["zskew"] = (np.sum(d ** 3) / n) / (np.sum(d ** 2) / n) ** 1.5
        out["zkurt"] = n * np.sum(d ** 4) / (np.sum(d ** 2) ** 2)
    # entropy(z, by = 1)
    if zmax < 2 or z.min() < 0:
        out["zentropy"] = np.nan
    else:
        bk = _r_seq(0, math.ceil(zmax), 1.0)
        h = _find_interval(z, bk)
        tbl = np.array([np.sum(h == k) for k in range(1, bk.size)], float)
        tbl = tbl / tbl.sum()
        p = tbl[tbl > 0]
        pref = np.full(bk.size - 1, 1.0 / (bk.size - 1))
        out["zentropy"] = -np.sum(p * np.log(p)) / -np.sum(pref * np.log(pref))
    out["pzabovezmean"] = np.sum(z > zmean) / n * 100
    out["pzabove2"] = np.sum(z > 2) / n * 100
    for p in range(5, 100, 5):
        out[f"zq{p}"] = np.quantile(z, p / 100, method="linear")
    if zmax <= 0:
        cum = np.zeros(9)
    else:
        breaks = _r_seq(0, zmax, zmax / 10)
        dd = _find_interval(z[z > 0], breaks)
        tbl = np.array([np.sum(dd == k) for k in range(1, 11)], float)
        cum = np.cumsum(tbl / tbl.sum() * 100)[:9]
    for k in range(9):
        out[f"zpcum{k + 1}"] = cum[k]
    return out


def _close(a, b):
    return (np.isnan(a) and np.isnan(b)) or abs(a - b) <= 1e-9 * max(1.0, abs(b))


def test_known_vector_by_hand():
    z = np.array([0.5, 1.0, 3.0, 4.0, 10.0])
    m = group_metrics(z, np.zeros(5, int), 1)
    assert m["zmax"][0] == 10.0 and m["zmean"][0] == pytest.approx(3.7)
    assert m["zsd"][0] == pytest.approx(np.sqrt(((z - 3.7) ** 2).sum() / 4))
    assert m["pzabove2"][0] == pytest.approx(60.0)
    assert m["pzabovezmean"][0] == pytest.approx(40.0)  # 4 and 10
    # type 7: zq50 = the middle one; zq25 at index 1 + 4 * 0.25 = 2 -> 1.0
    assert m["zq50"][0] == pytest.approx(3.0) and m["zq25"][0] == pytest.approx(1.0)
    # 10 layers of 1 m: 0.5 and 1.0 in layers 1, 2; 3 and 4 in 4, 5; 10 (= zmax) in none
    assert m["zpcum1"][0] == pytest.approx(25.0) and m["zpcum2"][0] == pytest.approx(50.0)
    assert m["zpcum3"][0] == pytest.approx(50.0) and m["zpcum5"][0] == pytest.approx(100.0)
    # entropy: bins [0,1) [1,2) [3,4) [4,5) once each, 10 in none: log 4 / log 10
    assert m["zentropy"][0] == pytest.approx(np.log(4) / np.log(10))
    assert m["zskew"][0] == pytest.approx(stats.skew(z, bias=True))
    assert m["zkurt"][0] == pytest.approx(stats.kurtosis(z, fisher=False, bias=True))
    # L2 is half the mean absolute difference of two returns
    pairs = np.abs(z[:, None] - z[None, :]).sum() / (5 * 4)
    assert m["zL2"][0] == pytest.approx(pairs / 2)
    assert m["n"][0] == 5 and m["cover"][0] == pytest.approx(60.0)


def test_many_groups_equal_lidr_one_at_a_time():
    rng = np.random.default_rng(4)
    groups, zs = [], []
    for g in range(60):
        n = int(rng.integers(1, 400))
        z = np.round(rng.gamma(3.0, 4.0, n) - rng.uniform(0, 1) * (g % 7 == 0), 2)
        if g % 11 == 0:
            z = np.abs(z)
        zs.append(z)
        groups.append(np.full(n, g))
    z, g = np.concatenate(zs), np.concatenate(groups)
    perm = rng.permutation(z.size)
    m = group_metrics(z[perm], g[perm], 62)  # groups 60, 61 empty
    for k in range(60):
        ref = lidr_stdmetrics_z(zs[k])
        for name in STD_Z:
            assert _close(m[name][k], ref[name]), (k, name, m[name][k], ref[name])
    assert all(np.isnan(m[name][60]) for name in STD_Z)
    assert m["n"][61] == 0


def test_l_moments_against_definition():
    rng = np.random.default_rng(1)
    z = rng.gamma(2.0, 5.0, 200)
    m = group_metrics(z, np.zeros(200, int), 1)
    x = np.sort(z)
    n = x.size
    i = np.arange(n)
    b = [x.mean()] + [np.sum(np.prod([(i - j) / (n - 1 - j) for j in range(r)], axis=0) * x) / n
                      for r in (1, 2, 3)]
    l4 = 20 * b[3] - 30 * b[2] + 12 * b[1] - b[0]
    l2 = 2 * b[1] - b[0]
    assert m["zL4"][0] == pytest.approx(l4) and m["zLkurt"][0] == pytest.approx(l4 / l2)
    assert m["zLcv"][0] == pytest.approx(l2 / x.mean())


def test_min_height_returns_and_cover():
    z = np.array([0.0, 0.1, 1.5, 5.0, 6.0, 7.0, 20.0])
    first = np.array([1, 1, 0, 1, 0, 1, 1], bool)
    m = group_metrics(z, np.zeros(7, int), 1, first=first, min_height=2.0)
    assert m["n"][0] == 4 and m["zmean"][0] == pytest.approx(9.5)
    assert m["cover"][0] == pytest.approx(60.0)  # 3 of the 5 first returns above 2 m
    f = group_metrics(z, np.zeros(7, int), 1, first=first, min_height=2.0, returns="first")
    assert f["n"][0] == 3 and f["zmax"][0] == 20.0 and f["zq50"][0] == pytest.approx(7.0)
    assert set(METRICS) >= set(m)


def test_na_rules():
    m = group_metrics(np.array([1.0, 1.5, -0.2]), np.zeros(3, int), 1)
    assert np.isnan(m["zentropy"][0])  # zmax < 2
    m = group_metrics(np.array([3.0, 3.0]), np.zeros(2, int), 1)
    assert np.isnan(m["zskew"][0]) and m["zsd"][0] == 0.0
    m = group_metrics(np.array([-1.0, -0.5]), np.zeros(2, int), 1)
    assert m["zpcum9"][0] == 0.0
