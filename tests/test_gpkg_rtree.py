"""Issue 39: the trees run's GeoPackage layers are written without GDAL's feature-by-feature
R-tree and indexed at the end in one pass (io/gpkg_rtree.py). The index must be the one GDAL
would make: SQLite's rtreecheck passes, every box holds its geometry, GDAL sees a fast
spatial filter and answers bounding-box queries as on a file it indexed itself, and features
added later (QGIS, GDAL) go into the index through the same triggers."""
import sqlite3

import numpy as np
import pyogrio
import pytest
import shapely
from pyproj import CRS

from lidartrees_gis.cli import main
from lidartrees_gis.io.gpkg_rtree import float32_box, rtree_tables
from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.synthetic import StandParams, make_stand

LAYERS = ("tree_tops", "crowns", "gaps", "stands")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("rtree")
    sp = StandParams(width=60, height=60, density=10, missing_fraction=0.05, seed=5)
    pts, _ = make_stand(sp)
    las = d / "s.las"
    write_points(las, pts.x, pts.y, pts.z, crs=CRS.from_epsg(31984),
                 classification=pts.classification)
    import geopandas as gpd

    ox, oy = sp.origin_x, sp.origin_y
    gpd.GeoDataFrame({"talhao": ["A", "B"]},
                     geometry=[shapely.box(ox, oy, ox + 30, oy + 60),
                               shapely.box(ox + 30, oy, ox + 60, oy + 60)],
                     crs="EPSG:31984").to_file(d / "t.gpkg")
    out = {}
    for name, extra in (("ours", []), ("gdal", ["-lco", "SPATIAL_INDEX=YES"])):
        out[name] = d / f"{name}.gpkg"
        assert main(["trees", str(las), str(out[name]), "-q", "-spacing", "3x2", "-stands",
                     str(d / "t.gpkg"), *extra]) == 0
    return out


def test_rtree_tables_answer_box_queries_as_brute_force(tmp_path):
    rng = np.random.default_rng(0)
    n = 5000  # three levels of 51-cell nodes
    lo = rng.uniform(0, 1000, (n, 2)) + [600_000.0, 7_400_000.0]
    b = np.c_[lo, lo + rng.uniform(0, 4, (n, 2))]
    b[7] = np.nan  # an empty geometry: not indexed
    fids = np.arange(1, n + 1)
    con = sqlite3.connect(tmp_path / "r.db")
    con.execute("CREATE VIRTUAL TABLE r USING rtree(id, minx, maxx, miny, maxy)")
    nodes, rowid, parent = rtree_tables(fids, b)
    root = dict(nodes)[1]
    assert int.from_bytes(root[:2], "big") == 2 and len(root) == 4 + 24 * 51  # depth 2
    con.execute("DELETE FROM r_node")
    con.executemany("INSERT INTO r_node VALUES (?, ?)", nodes)
    con.executemany("INSERT INTO r_rowid VALUES (?, ?)", rowid)
    con.executemany("INSERT INTO r_parent VALUES (?, ?)", parent)
    con.commit()
    assert con.execute("SELECT rtreecheck('r')").fetchone()[0] == "ok"
    assert con.execute("SELECT count(*) FROM r").fetchone()[0] == n - 1
    box = float32_box(b[~np.isnan(b).any(axis=1)])
    held = np.c_[box[:, 0] <= b[~np.isnan(b).any(axis=1), 0],
                 box[:, 1] >= b[~np.isnan(b).any(axis=1), 2]]
    assert held.all()  # float32 rounded outwards: every box holds its feature
    for x0, y0 in rng.uniform(0, 900, (20, 2)) + [600_000.0, 7_400_000.0]:
        got = {r[0] for r in con.execute("SELECT id FROM r WHERE maxx >= ? AND minx <= ? AND "
                                         "maxy >= ? AND miny <= ?", (x0, x0 + 60, y0, y0 + 60))}
        ok = ~np.isnan(b).any(axis=1)
        want = set(fids[ok & (b[:, 2] >= x0) & (b[:, 0] <= x0 + 60) & (b[:, 3] >= y0)
                        & (b[:, 1] <= y0 + 60)].tolist())
        # float32 boxes are a little larger: a few more candidates, never one fewer
        assert want <= got and len(got - want) <= 3
    con.close()


def test_trees_layers_carry_an_index_gdal_reads_and_updates(runs):
    ours, gdal = runs["ours"], runs["gdal"]
    con = sqlite3.connect(ours)
    for layer in LAYERS:
        assert con.execute(f"SELECT rtreecheck('rtree_{layer}_geom')").fetchone()[0] == "ok"
        n = con.execute(f'SELECT count(*) FROM "{layer}" WHERE geom IS NOT NULL').fetchone()[0]
        assert con.execute(f"SELECT count(*) FROM rtree_{layer}_geom").fetchone()[0] == n > 0
        assert pyogrio.read_info(ours, layer=layer)["capabilities"]["fast_spatial_filter"]
        # every box holds its geometry
        df = pyogrio.read_dataframe(ours, layer=layer, fid_as_index=True)
        b = shapely.bounds(df.geometry.values)
        r = np.array(con.execute(f"SELECT id, minx, miny, maxx, maxy FROM rtree_{layer}_geom "
                                 "ORDER BY id").fetchall())
        assert (r[:, 0] == df.index.to_numpy()).all()
        assert (r[:, 1:3] <= b[:, :2]).all() and (r[:, 3:] >= b[:, 2:]).all()
        # the triggers are GDAL's for this file's version
        trig = lambda db: sorted(row[0] for row in sqlite3.connect(db).execute(  # noqa: E731
            "SELECT sql FROM sqlite_master WHERE type = 'trigger' AND tbl_name = ?", (layer,)))
        assert trig(ours) == trig(gdal)
        # box queries give what GDAL's own index gives
        x0, y0 = b[:, 0].min(), b[:, 1].min()
        for dx, dy in ((5, 5), (20, 35), (40, 10)):
            q = (x0 + dx, y0 + dy, x0 + dx + 12, y0 + dy + 12)
            assert len(pyogrio.read_dataframe(ours, layer=layer, bbox=q)) == \
                len(pyogrio.read_dataframe(gdal, layer=layer, bbox=q))
    con.close()
    # a point added later (as QGIS or GDAL would) goes into the index through the triggers
    tops = pyogrio.read_dataframe(ours, layer="tree_tops")
    extra = tops.iloc[:1].copy()
    extra["geometry"] = shapely.points([tops.geometry.x.min() - 100.0],
                                       [tops.geometry.y.min() - 100.0])
    pyogrio.write_dataframe(extra, ours, layer="tree_tops", append=True)
    con = sqlite3.connect(ours)
    assert con.execute("SELECT rtreecheck('rtree_tree_tops_geom')").fetchone()[0] == "ok"
    assert con.execute("SELECT count(*) FROM rtree_tree_tops_geom").fetchone()[0] == len(tops) + 1
    con.close()
    far = (extra.geometry.x.iloc[0] - 1, extra.geometry.y.iloc[0] - 1,
           extra.geometry.x.iloc[0] + 1, extra.geometry.y.iloc[0] + 1)
    assert len(pyogrio.read_dataframe(ours, layer="tree_tops", bbox=far)) == 1
