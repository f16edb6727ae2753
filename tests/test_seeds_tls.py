"""Issue 24, the TLS seeds: Queiroz (2017, seed 002) roots / stem / canopy and Buck et al.
(2014, seed 004) Dmax stem, against transcriptions of the papers and real trees."""
import json

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from lidartrees_gis.cli import main
from lidartrees_gis.io.points import open_points
from lidartrees_gis.tls.profile import segment_profile


def queiroz_crossings(z, fatia=0.05, sigma=0.3):
    """Seed 002 as written: z_n = z - z_min; a histogram of the points per horizontal slice;
    Gaussian smoothing (sigma in metres); the second derivative by finite differences, forward
    at the first slice, central inside, backward at the last; the heights where it changes sign,
    going up (interpolated between slice centres)."""
    zn = np.asarray(z) - np.min(z)
    n = int(zn.max() // fatia) + 1
    h = np.bincount(np.minimum((zn // fatia).astype(int), n - 1), minlength=n).astype(float)
    f = gaussian_filter1d(h, sigma / fatia, mode="constant")
    d2 = np.empty(n)
    d2[0] = f[2] - 2 * f[1] + f[0]
    d2[1:-1] = f[2:] - 2 * f[1:-1] + f[:-2]
    d2[-1] = f[-1] - 2 * f[-2] + f[-3]
    centres = (np.arange(n) + 0.5) * fatia
    out = []
    for i in range(n - 1):
        a, b = d2[i], d2[i + 1]
        if a != 0 and b != 0 and np.sign(a) != np.sign(b):
            out.append(centres[i] + a / (a - b) * fatia)
    return out


def crown_begins(x, y, z):
    """Where the crown begins, measured on the points independently of the library: 1 m
    slices; the 95th percentile of the horizontal distances to the slice's median position;
    the lowest slice above 2 m wider than 3 x the stem's (the median of the slices 1-4 m) and
    followed by at least 2 of 3 such slices."""
    zn = np.asarray(z) - np.min(z)
    tops = np.arange(0, zn.max(), 1.0)
    sp = []
    for h in tops:
        m = (zn >= h) & (zn < h + 1)
        if m.sum() < 5:
            sp.append(0.0)
            continue
        sp.append(np.percentile(np.hypot(x[m] - np.median(x[m]), y[m] - np.median(y[m])), 95))
    sp = np.array(sp)
    wide = sp > 3 * np.median(sp[1:4])
    return next(h for i, h in enumerate(tops) if h >= 2 and wide[i] and wide[i + 1:i + 4].sum() >= 2)


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["xyz_text/ITSMe_tree_1_pc.txt", "xyz_text/ITSMe_tree_2_pc.txt",
                                  "TreeLS_tls/pine.laz"])
def test_profile_canopy_start_where_the_crown_begins(data, name, tmp_path):
    """`lidartrees profile` with its defaults on real trees (two tropical broadleaves whose
    crowns start at about 19 and 13 m, a pine at about 8 m): the canopy start within 2 m of
    where the branches begin. The library once put it at 0.9-2.0 m on all of them."""
    p = open_points(data(name)).read_all()
    want = crown_begins(p.x, p.y, p.z)
    assert want > 5
    out = tmp_path / "parts.laz"
    args = ["profile", str(data(name)), str(out), "--allow-no-crs", "-q"]
    if name.endswith(".txt"):
        args += ["-a_srs", "EPSG:32631"]
    assert main(args) == 0
    b = json.loads((tmp_path / "parts_boundaries.json").read_text())
    assert abs(b["canopy_start"] - want) <= 2.0, (b["canopy_start"], want)


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["xyz_text/ITSMe_tree_2_pc.txt", "arbor_tls/tree_qsm.laz"])
def test_profile_queiroz_rule_is_the_ordinal_rule(data, name, tmp_path):
    """-rule queiroz: the 1st, 2nd and 3rd inflections going up are the tree start, the stem
    start and the canopy start, whatever their direction (seed 002 §3)."""
    p = open_points(data(name)).read_all()
    want = queiroz_crossings(p.z)[:3]
    r = segment_profile(p.z, rule="queiroz")
    got = [r["tree_start"], r["stem_start"], r["canopy_start"]]
    np.testing.assert_allclose(got, want, atol=0.01)  # well within a 0.05 m slice
    zn = p.z - p.z.min()
    assert np.all(r["labels"][zn >= got[2]] == 3) and np.all(r["labels"][zn < got[1]] == 1)


def sapling(rng, height=6.0, base=1.6, reach=0.6, radius=0.04):
    """A ``height`` m sapling: a stem of ``radius`` m tapering to the top, scanned every ~1 cm,
    and whorls of five branches every 0.35 m from ``base`` up, each ``reach`` m long at the
    lowest whorl and shorter going up (a cone), rising at 30 degrees, with leaves around them.
    Its branches begin at ``base``."""
    pts = []
    for z in np.arange(0.0, height, 0.01):
        a = rng.uniform(0, 2 * np.pi, 25)
        r = radius * (1 - z / height) + 0.004 + rng.normal(0, 0.002, a.size)
        pts.append(np.c_[r * np.cos(a), r * np.sin(a), np.full(a.size, z)])
    for zw in np.arange(base, height - 0.3, 0.35):
        length = reach * (height - zw) / (height - base)
        for az in rng.uniform(0, 2 * np.pi, 5):
            t = rng.uniform(0, 1, int(400 * length) + 20)
            d = t * length
            leaf = rng.normal(0, 0.05 + 0.1 * length, (t.size, 3)) * t[:, None]
            pts.append(np.c_[d * np.cos(az) + leaf[:, 0], d * np.sin(az) + leaf[:, 1],
                             zw + d * np.tan(np.radians(30)) + leaf[:, 2]])
    p = np.concatenate(pts)
    return p[p[:, 2] >= 0]


def branches_begin(x, y, z, reach=0.5, share=0.1, step=0.25):
    """Where the branches begin, measured on the points without the library: 0.25 m slices;
    in each, the share of the points farther than ``reach`` m (wider than any stem here) from
    the slice's median position; the lowest slice from 1 m up where that share is over
    ``share`` in at least half of the slices of the next metre."""
    zn = np.asarray(z) - np.min(z)
    hs = np.arange(0, zn.max(), step)
    wide = np.zeros(hs.size, bool)
    for i, h in enumerate(hs):
        m = (zn >= h) & (zn < h + step)
        if m.sum() >= 5:
            d = np.hypot(x[m] - np.median(x[m]), y[m] - np.median(y[m]))
            wide[i] = np.mean(d > reach) > share
    run = int(round(1 / step))
    return next(h for i, h in enumerate(hs)
                if h >= 1.0 and wide[i] and wide[i:i + run].sum() * 2 >= run)


#: every single TLS tree in ../shared/data (pine_plot.laz is a plot, dbh.laz one slice)
TLS_TREES = ["xyz_text/ITSMe_tree_1_pc.txt", "xyz_text/ITSMe_tree_2_pc.txt", "TreeLS_tls/pine.laz",
             "TreeLS_tls/spruce.laz", "arbor_tls/tree_qsm.laz", "xyz_text/rTLS_pc_tree.txt",
             "xyz_text/rTwig_cloud.txt"]


@pytest.mark.realdata
@pytest.mark.parametrize("name", TLS_TREES)
def test_profile_canopy_start_within_1_5_m_on_every_real_tree(data, name):
    """Issue 38: the spread rule's canopy start within 1.5 m of where the branches begin on
    every real TLS tree (23 m down to a 3.7 m tree whose branches begin at about 1.5 m; the
    spruce branches from its base). The library once found no canopy on the 3.7 m tree: the
    stem's spread was measured between 1 and 3 m, in its crown."""
    p = open_points(data(name)).read_all()
    want = branches_begin(p.x, p.y, p.z)
    r = segment_profile(p.z, x=p.x, y=p.y)
    assert abs(r["canopy_start"] - want) <= 1.5, (r["canopy_start"], want)
    assert r["counts"]["canopy"] > 0.2 * p.z.size


@pytest.mark.parametrize("base,reach", [(1.6, 0.6), (1.9, 0.6), (1.6, 1.2), (2.0, 1.2)])
def test_profile_canopy_start_on_a_6_m_sapling(base, reach):
    """Issue 38: a generated 6 m sapling whose branches begin at 1.6-2.0 m gets its canopy start
    within 1.5 m of that (in fact within one 0.25 m slice); the library once found no canopy
    and labelled every point stem."""
    p = sapling(np.random.default_rng(4), base=base, reach=reach)
    r = segment_profile(p[:, 2], x=p[:, 0], y=p[:, 1])
    assert abs(r["canopy_start"] - base) <= 0.3, r["canopy_start"]
    zn = p[:, 2] - p[:, 2].min()
    assert np.all(r["labels"][zn < base - 0.3] != 3)
    assert np.mean(r["labels"][zn > base + 0.5] == 3) > 0.95


def buttressed_tree(rng, core=0.18, flange=0.45):
    """A 12 m stem of radius ``core`` with four buttress flanges reaching ``flange`` m from its
    axis at the ground and fading out at 2.5 m; points on the outer surface every ~1 cm."""
    pts = []
    for z in np.arange(0.0, 12.0, 0.01):
        a = rng.uniform(0, 2 * np.pi, 140)
        reach = max(0.0, (flange - core) * (1 - z / 2.5))  # the flanges' length at this height
        # the outline in polar form: the core circle, and narrow ridges every 90 degrees
        ridge = np.maximum(0.0, 1 - np.abs(((a + np.pi / 4) % (np.pi / 2)) - np.pi / 4) / 0.12)
        r = core * (1 - 0.01 * z) + reach * ridge + rng.normal(0, 0.003, a.size)
        pts.append(np.c_[r * np.cos(a), r * np.sin(a), np.full(a.size, z)])
    return np.concatenate(pts)


def test_stem_warns_on_a_buttressed_section_and_gives_its_outline(tmp_path):
    """At 1.30 m the Dmax circle fits the inner core of a buttressed stem; the outline (tape)
    diameter is reported beside it with a warning. The library once said nothing."""
    from lidartrees_gis.tls.stem import dmax_filter

    p = buttressed_tree(np.random.default_rng(1))
    r = dmax_filter(p[:, 0], p[:, 1], p[:, 2])
    assert r["dbh"] == pytest.approx(2 * 0.18 * (1 - 0.013), abs=0.02)  # the core
    assert r["dbh_outline"] > 1.15 * r["dbh"] and "not round" in r["warning"]
    # a round stem: no warning, the two diameters agree
    q = buttressed_tree(np.random.default_rng(2), flange=0.18)
    r2 = dmax_filter(q[:, 0], q[:, 1], q[:, 2])
    assert r2["warning"] == "" and r2["dbh_outline"] == pytest.approx(r2["dbh"], rel=0.05)


def test_stem_says_when_the_breast_height_slice_is_too_sparse_for_the_outline():
    """Issue 38: the buttressed stem thinned to about 45 points in its 1.30 m slice still gets its
    Dmax DBH (the inner core) but no outline, and the warning says the roundness was not checked
    (the library once gave no outline and no word, so a sparse buttressed tree went unwarned)."""
    from lidartrees_gis.tls.stem import dmax_filter

    rng = np.random.default_rng(5)
    p = buttressed_tree(np.random.default_rng(1))
    p = p[rng.uniform(size=len(p)) < 0.036]
    r = dmax_filter(p[:, 0], p[:, 1], p[:, 2])
    n = int((np.abs(p[:, 2] - r["base"] - 1.30) <= 0.05).sum())
    assert 35 <= n <= 55
    assert r["dbh"] == pytest.approx(2 * 0.18 * (1 - 0.013), abs=0.02)
    assert np.isnan(r["dbh_outline"]) and "too sparse for its outline" in r["warning"]
    assert f"({n} points" in r["warning"] and "\n" not in r["warning"]


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["xyz_text/ITSMe_tree_1_pc.txt", "xyz_text/ITSMe_tree_2_pc.txt",
                                  "TreeLS_tls/pine.laz", "arbor_tls/tree_qsm.laz"])
def test_stem_real_round_trees_no_buttress_warning(data, name):
    from lidartrees_gis.tls.stem import dmax_filter

    p = open_points(data(name)).read_all()
    r = dmax_filter(p.x, p.y, p.z)
    assert r["warning"] == "" and abs(r["dbh_outline"] / r["dbh"] - 1) < 0.1


def test_stem_vspacing_sets_the_expected_points_and_bounds_the_section(tmp_path):
    import csv

    f = tmp_path / "tree.xyz"
    p = buttressed_tree(np.random.default_rng(3), flange=0.18)[::3]
    np.savetxt(f, p, fmt="%.4f")
    base = ["stem", str(f), "-a_srs", "EPSG:32723", "-q"]
    assert main(base + [str(tmp_path / "a")]) == 0
    assert main(base + [str(tmp_path / "b"), "-vspacing", "0.005"]) == 0
    ea = [int(r["expected_points"]) for r in csv.DictReader(open(tmp_path / "a_sections.csv"))
          if r["expected_points"]]
    eb = [int(r["expected_points"]) for r in csv.DictReader(open(tmp_path / "b_sections.csv"))
          if r["expected_points"]]
    assert len(ea) > 100 and np.median(eb) == pytest.approx(2 * np.median(ea), rel=0.05)
    assert main(base + [str(tmp_path / "c"), "-section", "0.005"]) != 0
    assert not list(tmp_path.glob("c_*"))
