"""Issue 27: deliverables a manager opens without help: styles inside the GeoPackage (QGIS's
layer_styles, the default per layer), GeoPackage 1.2, GeoTIFF overviews."""
import sqlite3
from pathlib import Path

import pytest
import rasterio

from lidartrees_gis.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.realdata
def test_trees_geopackage_carries_its_styles_and_version(data, tmp_path):
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-nln", "a_",
                 "-q"]) == 0
    con = sqlite3.connect(out)
    rows = con.execute("SELECT f_table_name, f_geometry_column, useAsDefault, styleQML "
                       "FROM layer_styles").fetchall()
    assert con.execute("PRAGMA user_version").fetchone()[0] == 10200  # GeoPackage 1.2
    assert con.execute("SELECT data_type FROM gpkg_contents WHERE table_name = 'layer_styles'"
                       ).fetchone() == ("attributes",)
    con.close()
    styles = {r[0]: r for r in rows}
    assert set(styles) == {"a_tree_tops", "a_crowns"}
    for name, qml in (("a_tree_tops", "tree_tops.qml"), ("a_crowns", "crowns.qml")):
        assert styles[name][1] == "geom" and styles[name][2] == 1
        assert styles[name][3] == (ROOT / "styles" / qml).read_text(encoding="utf-8")
    # -overwrite writes the styles again, once per layer
    assert main(["trees", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-nln", "a_",
                 "-overwrite", "-q"]) == 0
    con = sqlite3.connect(out)
    assert con.execute("SELECT count(*) FROM layer_styles WHERE useAsDefault = 1").fetchone()[0] == 2


@pytest.mark.realdata
def test_large_rasters_get_overviews(data, tmp_path):
    """A CHM of more than 2048 cells a side gets internal overviews (QGIS opens it at once);
    -co OVERVIEWS=NONE leaves them out, FORCE adds them to a small one."""
    folder = data("lasR_bcts/bcts_1.laz").parent
    big = tmp_path / "big.tif"
    assert main(["chm", str(folder), str(big), "-q"]) == 0
    with rasterio.open(big) as ds:
        assert ds.height > 2048 and ds.overviews(1) == [2, 4, 8, 16]
        assert ds.tags(ns="rio_overview")["resampling"] == "average"
    none = tmp_path / "none.tif"
    assert main(["chm", str(folder), str(none), "-co", "OVERVIEWS=NONE", "-q"]) == 0
    with rasterio.open(none) as ds:
        assert ds.overviews(1) == []
    small = tmp_path / "small.tif"
    f = data("lidR_extdata/MixedConifer.laz")
    assert main(["chm", str(f), str(small), "-q"]) == 0
    forced = tmp_path / "forced.tif"
    assert main(["chm", str(f), str(forced), "-co", "OVERVIEWS=FORCE", "-q"]) == 0
    with rasterio.open(small) as a, rasterio.open(forced) as b:
        assert a.overviews(1) == [] and b.overviews(1) == [2]
        assert (a.read(1) == b.read(1)).all()
    assert main(["chm", str(f), str(tmp_path / "bad.tif"), "-co", "OVERVIEWS=MAYBE", "-q"]) != 0
    assert not (tmp_path / "bad.tif").exists()


@pytest.mark.parametrize("turn", [0, 90])
def test_plantation_rows_and_plants_numbered_as_a_crew_counts(tmp_path, turn):
    """Gaps and trees carry row and plant numbers as a crew counts them: row 1 the outermost
    row on the west (north-south rows) or north (east-west rows) side, plant 1 at the row's
    south (west) end, gaps included; the summary says so. The library once wrote signed
    lattice offsets (-9...10). The demo stand's layout is known: rows 3 m apart from 1.5 m,
    plants 2 m apart from 1 m."""
    import numpy as np
    import pyogrio
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    sp = StandParams()
    pts, truth = make_stand(sp)
    ox, oy = sp.origin_x, sp.origin_y

    def turned(x, y):  # a quarter turn clockwise about the stand's corner: rows run E-W
        return (ox + (y - oy), oy + sp.width - (x - ox)) if turn else (x, y)

    x, y = turned(pts.x, pts.y)
    f = tmp_path / "s.las"
    write_points(f, x, y, pts.z, crs=CRS.from_epsg(29194), classification=pts.classification)
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out), "-spacing", "3x2", "-q"]) == 0
    # the truth's numbers: row k at 1.5 + 3 (k - 1) m from the first row's side, plant m at
    # 1 + 2 (m - 1) m from the row's start
    def crew(mx, my):
        return (np.round((mx - ox - 1.5) / 3).astype(int) + 1,
                np.round((my - oy - 1.0) / 2).astype(int) + 1)

    gx, gy = turned(np.asarray(truth["_missing_x"]), np.asarray(truth["_missing_y"]))
    gaps = pyogrio.read_dataframe(out, layer="gaps")
    from scipy.spatial import cKDTree

    d, k = cKDTree(np.c_[gaps.geometry.x, gaps.geometry.y]).query(np.c_[gx, gy])
    assert (d < 0.5).sum() >= len(gx) - 1  # the true gaps are found
    want_r, want_p = crew(np.asarray(truth["_missing_x"]), np.asarray(truth["_missing_y"]))
    ok = d < 0.5
    assert (gaps["row_number"].to_numpy()[k[ok]] == want_r[ok]).all()
    assert (gaps["plant_number"].to_numpy()[k[ok]] == want_p[ok]).all()
    tops = pyogrio.read_dataframe(out, layer="tree_tops", read_geometry=False)
    tx, ty = turned(np.asarray(truth["x"]), np.asarray(truth["y"]))
    d2, k2 = cKDTree(np.c_[tops["x"], tops["y"]]).query(np.c_[tx, ty])
    r2, p2 = crew(np.asarray(truth["x"]), np.asarray(truth["y"]))
    m = d2 < 0.5
    assert m.sum() > 550
    assert (tops["row_number"].to_numpy()[k2[m]] == r2[m]).mean() > 0.99
    assert (tops["plant_number"].to_numpy()[k2[m]] == p2[m]).mean() > 0.99
    s = pyogrio.read_dataframe(out, layer="summary").iloc[0]
    side = "N" if turn else "W"
    assert f"row 1 on the {side} side" in s["numbering"]


def test_quicklook_draws_the_missing_trees(stand_las_small, tmp_path):
    """In plantation mode the quick look marks every missing tree (its legend and the PNG's
    Comment give the count, the same as the gaps layer's)."""
    import pyogrio
    from PIL import Image

    out, png = tmp_path / "t.gpkg", tmp_path / "t.png"
    assert main(["trees", str(stand_las_small), str(out), "-spacing", "3x2", "-png", str(png),
                 "-q"]) == 0
    gaps = pyogrio.read_dataframe(out, layer="gaps", read_geometry=False)
    n = int((gaps.status == "missing").sum())  # the suppressed trees are not marked missing
    assert n > 0 and Image.open(png).text["Comment"].endswith(f"missing trees {n}")


@pytest.fixture
def stand_las_small(tmp_path):
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=40, height=40, missing_fraction=0.05))
    f = tmp_path / "s.las"
    write_points(f, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    return f


def test_small_crowns_are_flagged(tmp_path):
    """Crowns under 1 m² or 4 cells carry small_crown = 1 and the summary counts them."""
    import numpy as np
    import pyogrio

    from lidartrees_gis.als.sinks import SMALL_CROWN_CELLS, SMALL_CROWN_M2

    f = ROOT.parent / "shared" / "data" / "lasR_bcts" / "bcts_1.laz"
    if not f.exists():
        pytest.skip("no shared data")
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(f), str(out), "-q"]) == 0
    c = pyogrio.read_dataframe(out, layer="crowns", read_geometry=False)
    want = (c["crown_area"] < SMALL_CROWN_M2) | (c["n_cells"] < SMALL_CROWN_CELLS)
    assert want.sum() > 0 and (c["small_crown"].to_numpy() == want.to_numpy().astype(int)).all()
    s = pyogrio.read_dataframe(out, layer="summary").iloc[0]
    assert int(s["small_crowns"]) == int(want.sum())
    assert np.all(c.loc[c["small_crown"] == 0, "crown_area"] >= SMALL_CROWN_M2)
