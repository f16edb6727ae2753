import json

import laspy
import numpy as np

from lidartrees_gis.errors import InputError
import pytest
from scipy.stats import norm

from lidartrees_gis.cli import main
from lidartrees_gis.tls.circle import arc_coverage, fit_circle
from lidartrees_gis.tls.profile import second_derivative, segment_profile
from lidartrees_gis.tls.stem import DmaxParams, dmax_filter


def synthetic_stem(radius_at=lambda h: 0.12, height=8.0, noise=0.002, tilt=(0.0, 0.0),
                   arc=(0, 360), branches=0, ground=True, seed=0, density=40000):
    """Points on a (possibly tapered, tilted, one-sided) stem, with branches and ground."""
    rng = np.random.default_rng(seed)
    h = rng.random(density) * height
    ang = np.radians(rng.uniform(arc[0], arc[1], density))
    r = radius_at(h) + rng.normal(0, noise, density)
    x = tilt[0] * h + r * np.cos(ang)
    y = tilt[1] * h + r * np.sin(ang)
    pts = [np.c_[x, y, h]]
    for k in range(branches):  # branches: lines going out from the stem
        hb = 2.0 + k * (height - 3) / max(branches, 1)
        t = rng.random(600) * 1.0
        a = rng.uniform(0, 2 * np.pi)
        pts.append(np.c_[tilt[0] * hb + (radius_at(hb) + t) * np.cos(a) + rng.normal(0, 0.01, 600),
                         tilt[1] * hb + (radius_at(hb) + t) * np.sin(a) + rng.normal(0, 0.01, 600),
                         hb + 0.3 * t + rng.normal(0, 0.01, 600)])
    if ground:
        g = rng.uniform(-1.2, 1.2, (8000, 2))
        pts.append(np.c_[g, rng.normal(0, 0.02, 8000)])
    p = np.vstack(pts)
    return p[:, 0], p[:, 1], p[:, 2]


def test_circle_fit_on_partial_arc():
    rng = np.random.default_rng(1)
    a = np.radians(rng.uniform(0, 100, 300))
    x, y = 2 + 0.15 * np.cos(a) + rng.normal(0, 0.001, 300), -1 + 0.15 * np.sin(a) + rng.normal(0, 0.001, 300)
    c = fit_circle(x, y)
    assert c.r == pytest.approx(0.15, abs=0.002) and (c.xc, c.yc) == pytest.approx((2, -1), abs=0.003)
    assert 90 < c.coverage < 105
    assert fit_circle(x[:2], y[:2]) is None
    a = np.radians([0, 60, 120, 180, 240, 300])
    assert arc_coverage(np.cos(a), np.sin(a), 0, 0) == pytest.approx(300)
    assert arc_coverage(np.cos(a[:2]), np.sin(a[:2]), 0, 0) == pytest.approx(60)


@pytest.mark.parametrize("case", ["cylinder", "cone", "tilt", "one_sided", "branches"])
def test_dbh_within_2mm_on_synthetic_stems(case):
    kw = {"cylinder": {}, "cone": {"radius_at": lambda h: 0.15 - 0.012 * h},
          "tilt": {"tilt": (0.05, 0.03)}, "one_sided": {"arc": (0, 160)},
          "branches": {"branches": 6}}[case]
    x, y, z = synthetic_stem(**kw)
    r = dmax_filter(x, y, z, DmaxParams())
    true_dbh = 2 * kw.get("radius_at", lambda h: 0.12)(1.3)
    assert abs(r["dbh"] - true_dbh) <= 0.002, (case, r["dbh"], true_dbh)
    conv = [s for s in r["sections"] if s["converged"]]
    assert r["reached_height"] > 5.0
    if case == "cone":  # taper: section diameters follow the cone within 5 mm
        err = [abs(s["diameter"] - 2 * (0.15 - 0.012 * s["z"])) for s in conv]
        assert np.percentile(err, 95) < 0.005


def test_stem_reports_when_it_cannot_fit():
    rng = np.random.default_rng(0)
    x, y, z = rng.random(500), rng.random(500), rng.random(500) * 3  # a cloud, not a stem
    r = dmax_filter(x, y, z)
    assert np.isnan(r["dbh"]) and r["message"]


def test_second_derivative_differences():
    f = np.array([0.0, 1.0, 4.0, 9.0, 16.0])  # x^2 with h = 1 -> 2 everywhere
    np.testing.assert_allclose(second_derivative(f, 1.0), [2, 2, 2, 2, 2])
    np.testing.assert_allclose(second_derivative(f, 0.5), [8, 8, 8, 8, 8])


def _profile_cloud(with_roots=True):
    q = np.linspace(0.0005, 0.9995, 200000)
    parts = [q[::2] * 10, norm.ppf(q, 6, 1.0)]
    if with_roots:
        parts.insert(0, norm.ppf(q[::4], 0.5, 0.25))
    z = np.concatenate(parts)
    return z[(z > 0) & (z < 10)]


def test_profile_boundaries_within_one_bin():
    r = segment_profile(_profile_cloud(), bin=0.05, sigma=0.3, rule="queiroz")
    # inflections of the smoothed bumps: mu +- sqrt(sigma_bump^2 + sigma^2); the ordinal rule:
    # the root bump's lower and upper ones, then the canopy bump's lower one
    assert r["has_roots"]
    assert r["tree_start"] == pytest.approx(0.5 - np.hypot(0.25, 0.3), abs=0.05)
    assert r["stem_start"] == pytest.approx(0.5 + np.hypot(0.25, 0.3), abs=0.05)
    assert r["canopy_start"] == pytest.approx(6 - np.hypot(1.0, 0.3), abs=0.05)
    assert r["counts"]["roots"] > 0 and r["counts"]["canopy"] > r["counts"]["stem"]


def test_profile_without_root_zone_places_canopy_where_branches_begin():
    """The seed's Avicennia: no prop roots; the canopy starts where the branches do (5 m here),
    found by the spread rule without a root zone."""
    z = _profile_cloud(with_roots=False)
    z = np.concatenate([z, np.linspace(0, 0.4, 30000)])  # dense litter at the ground, no roots
    ang = np.random.default_rng(0).uniform(0, 2 * np.pi, z.size)
    rad = np.where(z > 5.0, 1.5 * np.sqrt((np.arange(z.size) % 97) / 96), 0.1)
    r = segment_profile(z, x=rad * np.cos(ang), y=rad * np.sin(ang))
    assert not r["has_roots"] and any("no root zone" in n for n in r["notes"])
    assert r["canopy_start"] == pytest.approx(5.0, abs=0.3)
    assert r["counts"]["roots"] == 0
    with pytest.raises(InputError, match="x and y"):
        segment_profile(z)


@pytest.mark.realdata
def test_stem_and_profile_on_treels_pine(tmp_path, data):
    f = data("TreeLS_tls/pine.laz")
    pre = tmp_path / "pine"
    assert main(["stem", str(f), str(pre), "-q"]) == 1  # TreeLS's pine has no CRS: refused
    assert main(["stem", str(f), str(pre), "--allow-no-crs", "-q"]) == 0
    s = json.loads((tmp_path / "pine_summary.json").read_text())
    assert 15 < s["dbh_cm"] < 40 and s["reached_percent"] > 50
    trunk = laspy.read(tmp_path / "pine_trunk.laz")
    assert len(trunk.points) == s["trunk_points"] and "section" in trunk.point_format.extra_dimension_names
    for suffix in ("_sections.csv", "_sections.gpkg", "_taper.png"):
        assert (tmp_path / f"pine{suffix}").stat().st_size > 0
    out = tmp_path / "parts.laz"
    assert main(["profile", str(f), str(out), "--allow-no-crs", "-q"]) == 0
    b = json.loads((tmp_path / "parts_boundaries.json").read_text())
    assert 0 <= b["stem_start"] < b["canopy_start"] < b["top"] <= 21
    part = np.asarray(laspy.read(out).part)
    assert set(np.unique(part)) <= {1, 2, 3} and len(part) == 73851
    assert (tmp_path / "parts_profile.png").exists()


@pytest.mark.realdata
def test_stem_and_profile_state_the_t_srs_operation(tmp_path, data, capsys):
    f = data("TreeLS_tls/pine.laz")
    crs = ["-a_srs", "EPSG:32632", "-t_srs", "EPSG:25832"]
    for args in (["stem", str(f), str(tmp_path / "pine")], ["profile", str(f), str(tmp_path / "p.laz")]):
        assert main(args + crs) == 0
        line = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("reprojection:")]
        assert len(line) == 1 and "ETRS89" in line[0] and "accuracy" in line[0], args[0]


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["TreeLS_tls/spruce.laz", "xyz_text/ITSMe_tree_1_pc.txt",
                                  "xyz_text/ITSMe_tree_2_pc.txt", "arbor_tls/tree_qsm.laz",
                                  "xyz_text/rTLS_pc_tree.txt"])
def test_real_trees_plausible(data, name):
    from lidartrees_gis.io.points import open_points

    p = open_points(data(name)).read_all()
    r = dmax_filter(p.x, p.y, p.z)
    if np.isfinite(r["dbh"]):
        assert 0.05 < r["dbh"] < 1.0
    else:
        assert r["message"]
    prof = segment_profile(p.z, x=p.x, y=p.y)
    assert prof["stem_start"] is None or 0 <= prof["stem_start"] < prof["canopy_start"] <= prof["top"]
