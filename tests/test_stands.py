"""Stands (talhões): -stands on the CLI and the Python API, each stand's own planting lattice,
the stands layer, its CSV, field descriptions and style, tiled = untiled per stand, bad stand
files. The two-stand file: stand T-01 3 x 2 m with rows north-south, stand T-02 3 x 2 m with
rows at 145° (the generator's stand turned by 35°), 5 % missing trees, 12 points/m²."""
import re
import sqlite3
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from pyproj import CRS

from lidartrees_gis.cli import main
from lidartrees_gis.errors import DataWarning, InputError
from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.synthetic import StandParams, make_stand

OX, OY = 412300.0, 7952400.0
TURN = 35.0  # degrees, counter-clockwise: rows at 0° become rows at 145°


def _turn(x, y, cx, cy, deg):
    a = np.radians(deg)
    dx, dy = np.asarray(x) - cx, np.asarray(y) - cy
    return cx + dx * np.cos(a) - dy * np.sin(a), cy + dx * np.sin(a) + dy * np.cos(a)


@pytest.fixture(scope="module")
def two_stands(tmp_path_factory):
    """A LAS file of two 80 x 80 m stands side by side, their polygons and the truth."""
    d = tmp_path_factory.mktemp("stands")
    common = dict(density=12, slope_x=0, slope_y=0, missing_fraction=0.05)
    a_pts, a = make_stand(StandParams(width=80, height=80, seed=1, origin_x=OX, origin_y=OY,
                                      **common))
    b_pts, b = make_stand(StandParams(width=120, height=120, seed=2, origin_x=OX + 60,
                                      origin_y=OY - 20, mean_crown_radius=1.7, **common))
    cx, cy = OX + 120, OY + 40
    bx, by = _turn(b_pts.x, b_pts.y, cx, cy, TURN)
    ka = a_pts.x < OX + 80
    kb = (bx >= OX + 80) & (bx < OX + 160) & (by >= OY) & (by < OY + 80)
    write_points(d / "two.las", np.r_[a_pts.x[ka], bx[kb]], np.r_[a_pts.y[ka], by[kb]],
                 np.r_[a_pts.z[ka], b_pts.z[kb]], crs=CRS.from_epsg(31984),
                 classification=np.r_[a_pts.classification[ka], b_pts.classification[kb]])

    def inside_b(x, y):
        x, y = _turn(x, y, cx, cy, TURN)
        return x, y, (x >= OX + 80) & (x < OX + 160) & (y >= OY) & (y < OY + 80)

    tbx, tby, kt = inside_b(b["x"], b["y"])
    _, _, km = inside_b(b["_missing_x"], b["_missing_y"])
    stands = gpd.GeoDataFrame({"Talhão": ["T-01", "T-02"]},
                              geometry=[shapely.box(OX, OY, OX + 80, OY + 80),
                                        shapely.box(OX + 80, OY, OX + 160, OY + 80)],
                              crs="EPSG:31984")
    stands.to_file(d / "stands.gpkg", layer="talhoes")
    truth = {"T-01": {"trees": len(a["x"]), "missing": len(a["_missing_x"])},
             "T-02": {"trees": int(kt.sum()), "missing": int(km.sum())}}
    trees = pd.DataFrame({"x": np.r_[a["x"], tbx[kt]], "y": np.r_[a["y"], tby[kt]],
                          "height": np.r_[a["height"], b["height"][kt]]})
    return {"dir": d, "las": d / "two.las", "stands": d / "stands.gpkg", "truth": truth,
            "trees": trees, "frame": stands}


def _run(argv):
    assert main(argv + ["-q"]) == 0, argv


def test_each_stand_gets_its_own_lattice_and_stocking(two_stands, capsys):
    d = two_stands["dir"]
    out, csv = d / "p.gpkg", d / "p.csv"
    _run(["trees", str(two_stands["las"]), str(out), "-stands", str(two_stands["stands"]),
          "-spacing", "3x2", "-stand_csv", str(csv)])
    printed = capsys.readouterr().out
    assert "stand_id_field: Talhão" in printed and "stand T-02:" in printed
    stands = gpd.read_file(out, layer="stands")
    assert list(stands["stand_id"]) == ["T-01", "T-02"]
    assert stands.crs.to_epsg() == 31984
    az = dict(zip(stands["stand_id"], stands["row_azimuth"]))
    assert min(az["T-01"], 180 - az["T-01"]) < 1.0  # north-south rows
    assert abs(az["T-02"] - (180 - TURN)) < 1.0  # turned by 35°
    for _, s in stands.iterrows():
        t = two_stands["truth"][s["stand_id"]]
        true_pct = 100 * (s["planting_positions"] - t["missing"]) / s["planting_positions"]
        # T-02's crowns (radius 1.7 m on 2 m in the row) overlap: a missing tree under its
        # neighbours' crowns may be taken for a suppressed one (docs/LIMITS.md)
        tol = 1.0 if s["stand_id"] == "T-01" else 1.5
        assert abs(s["stocking_pct"] - true_pct) <= tol, (s["stand_id"], s["stocking_pct"],
                                                          true_pct)
        # the missing trees counted, and those plus the positions left to a field check,
        # bracket the truth's
        slack = 3 if s["stand_id"] == "T-01" else 15
        assert s["missing_trees"] - slack <= t["missing"] <= (
            s["missing_trees"] + s["uncertain_positions"] + slack), (s, t)
        assert abs(s["area_ha"] - 0.64) < 1e-6
        assert s["data_cover_pct"] > 99
        assert s["dominant_height"] > s["mean_height"]
        hist = [c for c in stands.columns if c.startswith("trees_") and c.endswith("m")]
        assert sum(s[c] for c in hist) == s["trees"]
    gaps = gpd.read_file(out, layer="gaps")
    gaps = gaps[gaps.status == "missing"]
    assert gaps["stand_id"].value_counts().to_dict() == dict(zip(stands["stand_id"],
                                                                 stands["missing_trees"]))
    tops = gpd.read_file(out, layer="tree_tops")
    crowns = gpd.read_file(out, layer="crowns")
    crowned = tops[tops.suppressed == 0].set_index("tree_id")
    assert (crowned["stand_id"] == crowns.set_index("tree_id").loc[crowned.index, "stand_id"]).all()
    assert len(crowns) == len(crowned)  # a suppressed tree has no crown polygon
    counts = tops["stand_id"].value_counts().to_dict()
    assert counts == dict(zip(stands["stand_id"], stands["trees"]))
    # the CSV holds the layer's figures
    table = pd.read_csv(csv)
    assert list(table["stand_id"]) == ["T-01", "T-02"]
    assert list(table["missing_trees"]) == list(stands["missing_trees"])
    # rounded to the cm (issue 37: figures rounded to what they mean)
    assert np.allclose(table["dominant_height"], stands["dominant_height"], atol=0.0051)
    # described fields and a default style
    con = sqlite3.connect(out)
    docs = dict(con.execute("SELECT column_name, description FROM gpkg_data_columns "
                            "WHERE table_name = 'stands'"))
    styled = [r[0] for r in con.execute("SELECT f_table_name FROM layer_styles")]
    con.close()
    assert "Assmann" in docs["dominant_height"] and "100 tallest" in docs["dominant_height"]
    assert "stands" in styled


def test_stands_figures_do_not_depend_on_the_tiling(two_stands):
    d = two_stands["dir"]
    figs = []
    for name, extra in (("one", []), ("tiled", ["-tile_size", "60", "-workers", "1"])):
        out = d / f"{name}.gpkg"
        _run(["trees", str(two_stands["las"]), str(out), "-stands", str(two_stands["stands"]),
              "-spacing", "3x2", *extra])
        figs.append(gpd.read_file(out, layer="stands").set_index("stand_id"))
    one, tiled = figs
    # issue 37: every tree and gap has the same row and plant numbers in both runs, in the
    # turned stand (rows at 145°) too: each stand numbered from its own first row and plant
    import pyogrio

    for layer, key in (("tree_tops", "tree_id"), ("gaps", "gap_id")):
        a, b = (pyogrio.read_dataframe(d / f"{n}.gpkg", layer=layer, read_geometry=False)
                .set_index(key) for n in ("one", "tiled"))
        common = a.index.intersection(b.index)
        assert len(common) >= 0.95 * len(a), layer
        for c in ("row_number", "plant_number", "stand_id"):
            assert (a.loc[common, c] == b.loc[common, c]).all(), (layer, c)
        if layer == "tree_tops":  # counted from the stand's own edge, not the tile's
            for sid in ("T-01", "T-02"):
                own = a[(a["stand_id"] == sid) & (a["row_number"] > 0)]
                assert own["row_number"].min() <= 2 and own["plant_number"].min() == 1, sid
    # each stand's lattice is fitted once, on every tile's tops (a lattice per tile, a few
    # centimetres apart, counted positions along the tiles' edges twice or not at all)
    for k in ("trees", "planting_positions", "missing_trees", "suppressed_trees",
              "uncertain_positions"):
        assert (one[k] == tiled[k]).all(), (k, one[k].tolist(), tiled[k].tolist())
    assert np.allclose(one["row_azimuth"], tiled["row_azimuth"], atol=1e-6)
    assert np.allclose(one["stocking_pct"], tiled["stocking_pct"], atol=1e-9)
    assert np.allclose(one["mean_height"], tiled["mean_height"], atol=0.01)
    # the CHM of a tile equals the whole one beyond a buffer from the outer edge
    assert np.allclose(one["canopy_cover_pct"], tiled["canopy_cover_pct"], atol=0.05)


def test_stands_from_python_and_trees_outside_every_stand(two_stands):
    from lidartrees_gis import find_trees

    half = two_stands["frame"].iloc[[0]].copy()  # only T-01 given
    half["talhao"] = ["A"]
    tops, crowns, summary = find_trees(str(two_stands["las"]), stands=half, stand_id="talhao")
    st = summary["stands"]
    assert list(st["stand_id"]) == ["A"]
    inside = (tops["stand_id"] == "A")
    assert inside.sum() == st["trees"].iloc[0]
    assert (tops.loc[~inside, "stand_id"] == "").all() and (~inside).sum() > 900
    # the trees in A are those whose top lies in its polygon
    assert (tops.loc[inside, "x"] < OX + 80).all() and (tops.loc[~inside, "x"] >= OX + 80).all()


def test_stands_in_another_crs_are_reprojected_and_said_so(two_stands, capsys):
    d = two_stands["dir"]
    sad = two_stands["frame"].to_crs("EPSG:29194")  # SAD69 / UTM 24S
    sad.to_file(d / "sad69.gpkg")
    out = d / "sad.gpkg"
    _run(["trees", str(two_stands["las"]), str(out), "-stands", str(d / "sad69.gpkg")])
    printed = capsys.readouterr().out
    line = [ln for ln in printed.splitlines() if ln.startswith("stands_reprojection:")]
    assert line and "EPSG:29194" in line[0] and "accuracy" in line[0]
    stands = gpd.read_file(out, layer="stands")
    assert abs(stands["area_ha"].iloc[0] - 0.64) < 0.001


def test_bad_stand_files_are_named(two_stands, tmp_path, capsys):
    from lidartrees_gis.plantation.stands import load_stands

    crs = CRS.from_epsg(31984)
    bow = shapely.Polygon([(OX, OY), (OX + 80, OY + 80), (OX + 80, OY), (OX, OY + 80)])
    g = gpd.GeoDataFrame({"id": [1, 2, 3]}, geometry=[shapely.box(OX, OY, OX + 40, OY + 40),
                                                      bow, shapely.Polygon()], crs="EPSG:31984")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        st = load_stands(g, crs)
    text = [str(x.message) for x in w if issubclass(x.category, DataWarning)]
    assert any("feature 2 is not a valid polygon" in t and "Self-intersection" in t
               for t in text), text
    assert any("feature 3 has no geometry" in t for t in text), text
    assert st.ids == ("1", "2") and all(shapely.is_valid(st.geoms))
    pts = gpd.GeoDataFrame({"id": [1]}, geometry=[shapely.Point(OX, OY)], crs="EPSG:31984")
    with pytest.raises(InputError, match="feature 1 is a Point, not a polygon"):
        load_stands(pts, crs)
    with pytest.raises(InputError, match="has no field 'lote'.*fields: id"):
        load_stands(g.iloc[[0]], crs, "lote")
    # one id on two parts: a stand in two parts when they agree, two stands given one id
    # (said) when another attribute differs
    parts = gpd.GeoDataFrame({"talhao": ["A", "A", "B", "B"], "clone": ["x", "y", "z", "z"]},
                             geometry=[shapely.box(OX + 50 * k, OY, OX + 50 * k + 40, OY + 40)
                                       for k in range(4)], crs="EPSG:31984")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        st = load_stands(parts, crs)
    said = [str(x.message) for x in w if issubclass(x.category, DataWarning)]
    assert st.ids == ("A", "B") and len(said) == 1 and "A (clone)" in said[0], said
    assert "B (" not in said[0]
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(two_stands["las"]), str(out), "-stands",
                 str(tmp_path / "none.gpkg"), "-q"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "-stands:" in err[0] and "none.gpkg" in err[0]
    assert not out.exists()
    assert main(["trees", str(two_stands["las"]), str(out), "-stand_csv",
                 str(tmp_path / "s.csv"), "-q"]) == 1
    assert "-stand_csv: needs -stands" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_spacing_auto_finds_each_stands_spacing_and_rows(two_stands):
    d = two_stands["dir"]
    out = d / "auto.gpkg"
    _run(["trees", str(two_stands["las"]), str(out), "-stands", str(two_stands["stands"]),
          "-spacing", "auto"])
    stands = gpd.read_file(out, layer="stands").set_index("stand_id")
    assert list(stands["spacing"]) == ["3x2", "3x2"]
    az = stands["row_azimuth"]
    assert min(az["T-01"], 180 - az["T-01"]) < 1.0 and abs(az["T-02"] - (180 - TURN)) < 1.0
    for sid, s in stands.iterrows():
        t = two_stands["truth"][sid]
        true_pct = 100 * (s["planting_positions"] - t["missing"]) / s["planting_positions"]
        assert abs(s["stocking_pct"] - true_pct) <= (1.0 if sid == "T-01" else 1.5)


@pytest.mark.parametrize("rows,trees,azimuth", [(3.5, 2.5, 115.0), (3.0, 2.0, 20.0),
                                                (3.0, 3.0, 67.0)])
def test_planting_lattice_found_from_tops_on_a_chm_grid(rows, trees, azimuth):
    """Tops sit on CHM cells (0.3 m): the directions between neighbours 2.5 m apart come in
    7° steps, and the histogram's peak was 5.5° off the rows (a 3.5 x 2.5 m stand at 115° was
    read as 3.61 x 2.61 m and no lattice was found)."""
    from lidartrees_gis.plantation.stocking import detect_planting

    rng = np.random.default_rng(5)
    a = np.radians(azimuth)
    u, v = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    i, j = np.meshgrid(np.arange(-25, 26), np.arange(-20, 21))
    x = i.ravel() * trees * u[0] + j.ravel() * rows * v[0] + rng.normal(0, 0.12, i.size)
    y = i.ravel() * trees * u[1] + j.ravel() * rows * v[1] + rng.normal(0, 0.12, i.size)
    keep = (np.abs(x) < 45) & (np.abs(y) < 45) & (rng.random(x.size) > 0.05)
    x, y = (np.floor(x[keep] / 0.3) + 0.5) * 0.3, (np.floor(y[keep] / 0.3) + 0.5) * 0.3
    g = detect_planting(x + 500000.0, y + 7500000.0)
    assert g is not None and g.fit > 0.5
    got = sorted([g.row_spacing, g.tree_spacing])
    assert np.allclose(got, sorted([rows, trees]), rtol=0.02)
    d = abs((g.azimuth - azimuth + 90) % 180 - 90)
    assert d < 0.5 or (rows == trees and abs(d - 90) < 0.5)


def test_evaluate_per_stand_when_the_reference_has_a_stand_id(two_stands, tmp_path):
    from lidartrees_gis.report.evaluate import evaluate_file

    t = two_stands["trees"].copy()
    t["talhao"] = np.where(t["x"] < OX + 80, "T-01", "T-02")
    ref = tmp_path / "ref.csv"
    t.to_csv(ref, sep=";", decimal=",", index=False)  # a pt-BR spreadsheet
    out = two_stands["dir"] / "e.gpkg"
    _run(["trees", str(two_stands["las"]), str(out), "-stands", str(two_stands["stands"])])
    r = evaluate_file(out, ref)
    st = r["stands"]
    assert set(st) == {"T-01", "T-02"}
    assert st["T-01"]["reference"] == two_stands["truth"]["T-01"]["trees"]
    assert st["T-02"]["reference"] == two_stands["truth"]["T-02"]["trees"]
    assert sum(s["matched"] for s in st.values()) == r["all"]["matched"]
    # every detection counts in a stand: the stands' precision is not the matched ones' alone
    assert sum(s["detected"] for s in st.values()) == r["all"]["detected"]
    assert all(s["f_score"] > 0.95 for s in st.values())
    assert "| stand T-02 |" in r["table"]
    # a run without -stands: its trees carry the planted blocks' ids (B01, ...), another set
    # than the reference's; its false tops still count in the reference's stands
    out2 = two_stands["dir"] / "e2.gpkg"
    _run(["trees", str(two_stands["las"]), str(out2), "-overwrite"])
    r2 = evaluate_file(out2, ref)
    assert sum(s["detected"] for s in r2["stands"].values()) == r2["all"]["detected"]
    assert sum(s["matched"] for s in r2["stands"].values()) == r2["all"]["matched"]


def test_plantation_mode_one_tree_per_position_and_no_shrubs(tmp_path):
    """Shrubs of 3-4 m at missing planting positions under a 23 m stand: the tops alone
    (-planting none) take them for trees; plantation mode leaves them out (below 30 % of the
    dominant height), so their positions are missing trees in the gaps layer, and no
    position holds two tops; so do the defaults, which read the stand's planted block."""
    import pyogrio

    from lidartrees_gis.als.chain import trees_run
    from lidartrees_gis.als.trees import TreeParams

    # crowns of 0.9 m on 3 x 2 m: a missing tree leaves the sky open over a shrub
    pts, truth = make_stand(StandParams(seed=5, missing_fraction=0.06, mean_crown_radius=0.9,
                                        sd_crown_radius=0.1))
    mx, my = np.asarray(truth["_missing_x"]), np.asarray(truth["_missing_y"])
    rng = np.random.default_rng(0)
    sx, sy, sz = [pts.x], [pts.y], [pts.z]
    from lidartrees_gis.synthetic import ground_height

    for x0, y0 in zip(mx, my):  # a 3-4 m paraboloid shrub of 0.8 m radius, 25 returns/m²
        n = 50
        r = 0.8 * np.sqrt(rng.random(n))
        t = rng.random(n) * 2 * np.pi
        h = rng.uniform(3.0, 4.0)
        sx.append(x0 + r * np.cos(t))
        sy.append(y0 + r * np.sin(t))
        sz.append(ground_height(x0, y0) + h * (1 - (r / 0.8) ** 2))
    x, y, z = (np.concatenate(a) for a in (sx, sy, sz))
    cls = np.r_[pts.classification, np.ones(x.size - pts.x.size, np.uint8)]
    f = tmp_path / "shrubs.las"
    write_points(f, x, y, z, crs=CRS.from_user_input("EPSG:29194"), classification=cls)
    assert mx.size >= 10

    def tops(name, **kw):
        trees_run(f, tmp_path / f"{name}.gpkg", params=TreeParams(**kw))
        t = pyogrio.read_dataframe(tmp_path / f"{name}.gpkg", layer="tree_tops",
                                   read_geometry=False)
        return t["x"].to_numpy(), t["y"].to_numpy(), t["height"].to_numpy()

    def at_shrubs(tx, ty):
        d = np.hypot(tx[:, None] - mx[None, :], ty[:, None] - my[None, :])
        return int((d.min(axis=0) < 0.6).sum())

    dx, dy, _ = tops("alone", planting="none")
    px, py, ph = tops("plantation", spacing="3x2")
    assert at_shrubs(dx, dy) >= 0.5 * mx.size  # the tops alone count the shrubs as trees
    assert at_shrubs(*tops("defaults")[:2]) == 0
    assert at_shrubs(px, py) == 0 and ph.min() >= 0.3 * np.percentile(ph, 95) - 1.0
    gaps = pyogrio.read_dataframe(tmp_path / "plantation.gpkg", layer="gaps",
                                  read_geometry=False)
    miss = gaps[gaps["status"] == "missing"]
    d = np.hypot(miss["x"].to_numpy()[:, None] - mx[None, :],
                 miss["y"].to_numpy()[:, None] - my[None, :])
    assert (d.min(axis=0) < 1.0).sum() >= 0.9 * mx.size  # the shrubs' positions are gaps
    # one top per planting position: no two tops nearer than half the in-row spacing
    from scipy.spatial import cKDTree

    dd, _ = cKDTree(np.c_[px, py]).query(np.c_[px, py], k=2)
    assert dd[:, 1].min() >= 1.0


def test_understorey_floor_is_the_suppressed_trees_floor():
    """Plantation mode drops tops below the share of the dominant height that a suppressed tree
    must reach: one threshold, so a tree is never too low to be a tree yet high enough to be a
    suppressed one."""
    from lidartrees_gis.plantation.status import SUPPRESSED_HEIGHT
    from lidartrees_gis.als.tile import UNDERSTOREY_HEIGHT

    assert UNDERSTOREY_HEIGHT == SUPPRESSED_HEIGHT


def test_a_stand_beyond_the_points_is_said_in_words_never_nan(two_stands, tmp_path, capsys):
    # a farm's stands file covers more than one delivery: a stand with no return prints why
    # it has no figures, and its stands-layer row holds no tree
    frame = two_stands["frame"]
    far = gpd.GeoDataFrame({"Talhão": ["T-09"]}, geometry=[shapely.box(OX, OY + 200, OX + 80,
                                                                      OY + 280)],
                           crs="EPSG:31984")
    path = tmp_path / "three.gpkg"
    pd.concat([frame, far]).to_file(path, layer="talhoes")
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(two_stands["las"]), str(out), "-stands", str(path),
                 "-spacing", "3x2"]) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("stand T-09:"))
    assert line == "stand T-09: no tree, 0.64 ha, outside the points"
    assert not re.search(r"\bnan\b", text, re.I)
    s = gpd.read_file(out, layer="stands").set_index("stand_id")
    assert s.loc["T-09", "trees"] == 0 and s.loc["T-01", "trees"] > 900


def test_a_young_stand_beside_an_old_one_keeps_its_trees(tmp_path):
    """A farm holds stands of every age: a 6 m stand beside a 23 m one. Plantation mode drops
    tops under 30 % of the canopy as understorey; read against the area's one dominant height
    (23 m) that dropped the young stand's trees (its stocking read 20 % of a 95 % truth). Each
    top is read against its own neighbours' canopy."""
    import pyogrio

    common = dict(width=60, height=60, density=8, slope_x=0, slope_y=0, missing_fraction=0.05)
    a_pts, a = make_stand(StandParams(seed=11, origin_x=OX, origin_y=OY, **common))
    b_pts, b = make_stand(StandParams(seed=12, origin_x=OX + 60, origin_y=OY, mean_height=6.0,
                                      sd_height=0.5, mean_crown_radius=0.8, crown_depth=3.0,
                                      **common))
    keep_b = b_pts.x >= OX + 60
    write_points(tmp_path / "farm.las", np.r_[a_pts.x, b_pts.x[keep_b]],
                 np.r_[a_pts.y, b_pts.y[keep_b]], np.r_[a_pts.z, b_pts.z[keep_b]],
                 crs=CRS.from_epsg(31984),
                 classification=np.r_[a_pts.classification, b_pts.classification[keep_b]])
    gpd.GeoDataFrame({"talhao": ["OLD", "YOUNG"]},
                     geometry=[shapely.box(OX, OY, OX + 60, OY + 60),
                               shapely.box(OX + 60, OY, OX + 120, OY + 60)],
                     crs="EPSG:31984").to_file(tmp_path / "stands.gpkg")
    _run(["trees", str(tmp_path / "farm.las"), str(tmp_path / "farm.gpkg"), "-spacing", "3x2",
          "-stands", str(tmp_path / "stands.gpkg")])
    st = pyogrio.read_dataframe(tmp_path / "farm.gpkg", layer="stands", read_geometry=False)
    st = st.set_index("stand_id")
    for sid, truth in (("OLD", a), ("YOUNG", b)):
        true_pct = 100 * len(truth["x"]) / (len(truth["x"]) + len(truth["_missing_x"]))
        assert st.loc[sid, "dominant_height"] > (15 if sid == "OLD" else 4)
        assert abs(st.loc[sid, "stocking_pct"] - true_pct) < 2.0, (sid, true_pct)
    assert st.loc["YOUNG", "trees"] > 0.9 * len(b["x"][b["x"] >= OX + 60])
    # each top's and position's canopy read from its neighbours: the same in 40 m tiles
    _run(["trees", str(tmp_path / "farm.las"), str(tmp_path / "tiled.gpkg"), "-spacing", "3x2",
          "-stands", str(tmp_path / "stands.gpkg"), "-tile_size", "40", "-workers", "1"])
    tiled = pyogrio.read_dataframe(tmp_path / "tiled.gpkg", layer="stands",
                                   read_geometry=False).set_index("stand_id")
    cols = ["trees", "planting_positions", "missing_trees", "uncertain_positions",
            "suppressed_trees", "stocking_pct", "stocking_pct_low", "stocking_pct_high"]
    pd.testing.assert_frame_equal(st[cols], tiled[cols])


def test_a_spacing_the_stands_were_not_planted_on_is_said(two_stands, capsys):
    """Both stands are planted 3 x 2 m: ``-spacing 3x3`` names each with the lattice its tops
    lie on (its trees and stocking would be read on the wrong one, exit 0); ``-spacing 3x2``
    says nothing."""
    d = two_stands["dir"]
    base = ["trees", str(two_stands["las"]), str(d / "s.gpkg"), "-stands",
            str(two_stands["stands"]), "-overwrite"]
    capsys.readouterr()
    assert main([*base, "-spacing", "3x3"]) == 0
    said = [ln for ln in capsys.readouterr().err.splitlines() if "another lattice" in ln]
    assert len(said) == 1, said
    assert "-spacing 3x3:" in said[0] and "-spacing auto" in said[0]
    for k in ("T-01", "T-02"):
        assert f"stand {k}'s on 3.00 x 2.00 m" in said[0], said
    assert main([*base, "-spacing", "3x2"]) == 0
    assert "another lattice" not in capsys.readouterr().err


def test_plantation_mode_on_a_canopy_height_model_is_refused(two_stands, tmp_path, capsys):
    """A CHM holds no returns at the empty positions (every one would be uncertain, the
    stocking far below the truth): -spacing refused in one line, nothing written; with
    -stands alone the stands get the defaults' trees and a warning says so."""
    import geopandas as gpd

    chm = tmp_path / "chm.tif"
    _run(["chm", str(two_stands["las"]), str(chm)])
    out = tmp_path / "t.gpkg"
    capsys.readouterr()
    assert main(["trees", str(chm), str(out), "-stands", str(two_stands["stands"]),
                 "-spacing", "auto"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "-spacing: " in err[0] and "canopy height model" in err[0] and \
        "give the point files" in err[0], err
    assert not out.exists()
    assert main(["trees", str(chm), str(out), "-stands", str(two_stands["stands"])]) == 0
    err = capsys.readouterr().err
    assert "-stands: " in err and "without their planting lattice or stocking" in err
    assert len(gpd.read_file(out, layer="stands")) == 2


def test_stands_off_the_points_with_most_trees_outside_them_hint_at_the_crs(two_stands,
                                                                              tmp_path, capsys):
    """Stands 100 m east and 30 m north of where the points put them (a datum or zone
    mix-up): the cover warning adds that most trees lie outside every stand; stands where
    they belong say neither."""
    st = two_stands["frame"].copy()
    st.geometry = st.geometry.translate(100, 30)
    st.to_file(tmp_path / "off.gpkg")
    capsys.readouterr()
    assert main(["trees", str(two_stands["las"]), str(tmp_path / "t.gpkg"), "-stands",
                 str(tmp_path / "off.gpkg")]) == 0
    said = [ln for ln in capsys.readouterr().err.splitlines() if "covered by the points" in ln]
    assert len(said) == 1 and "trees lie outside every stand" in said[0] and \
        "same datum and zone" in said[0], said
    n_out, n_all = (int(v.replace(",", "")) for v in
                    re.search(r"and ([\d,]+) of ([\d,]+) trees", said[0]).groups())
    assert n_out > n_all / 2
    assert main(["trees", str(two_stands["las"]), str(tmp_path / "u.gpkg"), "-stands",
                 str(two_stands["stands"])]) == 0
    assert "outside every stand" not in capsys.readouterr().err


def test_stands_with_a_crs_on_points_without_one_are_refused(two_stands, tmp_path):
    """Python, an XYZ without a_srs (no CRS) and stands in EPSG:31984: refused naming the
    stands, their CRS and a_srs, rather than trees placed on the stands by chance with no CRS;
    with a_srs the same points run."""
    import laspy

    import lidartrees_gis as lt
    from lidartrees_gis.errors import InputError

    las = laspy.read(two_stands["las"])
    xyz = tmp_path / "voo.xyz"
    np.savetxt(xyz, np.column_stack([las.x, las.y, las.z, las.classification]), fmt="%.2f")
    with pytest.raises(InputError, match=r"-stands: .*stands.gpkg.* is in EPSG:31984 .* the "
                       r"points have no CRS .*a_srs"):
        lt.find_trees(xyz, stands=two_stands["stands"])
    tops = lt.find_trees(xyz, stands=two_stands["stands"], a_srs="EPSG:31984")[0]
    assert tops.crs.to_epsg() == 31984 and len(tops) > 1000


def test_the_summary_with_stands_gives_their_trees_per_ha_and_spacings(two_stands):
    """With -stands the run's trees per ha are also given over the stands' covered area (the
    points' extent holds roads and clearings), and one spacing is not claimed for stands of
    several."""
    import lidartrees_gis as lt
    from lidartrees_gis.als.chain import stands_summary

    summary = lt.find_trees(two_stands["las"], stands=two_stands["stands"])[2]
    # the empty planting positions come back too, as the gaps layer, each in its stand
    gaps = summary["gaps"]
    status = gaps["status"].value_counts()
    assert status.get("missing", 0) == summary["missing_trees"] > 0
    assert len(gaps) == summary["missing_trees"] + summary["uncertain_positions"] \
        + summary["suppressed_trees"]
    assert set(gaps["stand_id"]) <= {"T-01", "T-02"} and gaps.crs.to_epsg() == 31984
    assert set(gaps["status"]) <= {"missing", "suppressed", "uncertain"}
    # two stands of 0.64 ha covering the points, every tree inside one
    assert summary["stands_trees_per_ha"] == pytest.approx(summary["trees"] / 1.28, rel=0.01)
    row = {"spacing": "3x2", "row_azimuth": 35.0, "numbering": "row 1 ..."}
    stands_summary(row, [{"trees": 10, "area_ha": 1.0, "data_cover_pct": 100.0,
                          "lattice": "found", "spacing": "3x2"},
                         {"trees": 5, "area_ha": 1.0, "data_cover_pct": 50.0,
                          "lattice": "found", "spacing": "3x3"}])
    assert row["stands_trees_per_ha"] == pytest.approx(10.0)
    assert row["spacing"] == "per stand (3x2, 3x3)" and row["row_azimuth"] is None


def test_stand_words_for_no_tops_and_a_square_lattice():
    """A stand with no tree top says so (not "0 tops, fewer than the 100 needed"); a square
    lattice's printed rows say they could run across, and the numbering rule says why."""
    from lidartrees_gis.als.chain import _square
    from lidartrees_gis.plantation.lattice import PlantingGrid
    from lidartrees_gis.plantation.stockreport import stocking_fields
    from lidartrees_gis.plantation.stocking import crew_numbers

    r = stocking_fields(None, 0.0, {"expected": 0, "stocked": 0, "missing": 0, "extra": 0,
                                    "planted_area_ha": 0.0}, tops=0)
    assert r["lattice"] == "no planting lattice: no tree top in it"
    assert r["stocking_pct"] is None
    assert _square("3x3") == ", or across: a square lattice" and _square("3x2") == ""
    sq = PlantingGrid(3.0, 3.0, 112.0, 0.0, 0.0, 1.0)
    assert "square lattice" in crew_numbers(sq, [0, 1], [0, 0])[2]
    assert "square" not in crew_numbers(PlantingGrid(3.0, 2.0, 35.0, 0.0, 0.0, 1.0), [0], [0])[2]


def test_windows_shapefile_without_cpg_keeps_its_dashes_and_quotes(tmp_path):
    """A cp1252 shapefile without its .cpg (GDAL reads it as Latin-1): the dash and quotes of
    "T–01 “Açaí”" come back as written, not as control characters; with a .cpg it is GDAL's."""
    import os

    from lidartrees_gis.plantation.stands import load_stands

    g = gpd.GeoDataFrame({"TALHÃO": ["T–01 “Açaí”", "T-02 São João"]},
                         geometry=[shapely.box(0, 0, 50, 50), shapely.box(50, 0, 100, 50)],
                         crs="EPSG:31983")
    g.to_file(tmp_path / "w.shp", encoding="cp1252")
    os.remove(tmp_path / "w.cpg")
    assert gpd.read_file(tmp_path / "w.shp").iloc[0, 0] == "T\x9601 \x93Açaí\x94"  # GDAL's
    st = load_stands(tmp_path / "w.shp", crs=CRS.from_epsg(31983))
    assert list(st.ids) == ["T–01 “Açaí”", "T-02 São João"]
