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
