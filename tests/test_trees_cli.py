import csv

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import rasterio
from rasterio.features import geometry_mask

from lidartrees_gis.cli import main

pytestmark = pytest.mark.realdata
FIELDS = ["tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells", "row_number",
          "plant_number", "suppressed", "method", "small_crown"]


@pytest.fixture(scope="module")
def mixed(tmp_path_factory, data):
    f = data("lidR_extdata/MixedConifer.laz")
    d = tmp_path_factory.mktemp("mc")
    out, chm = d / "out.gpkg", d / "chm.tif"
    rc = main(["trees", str(f), str(out), "-tr", "0.5", "-method", "watershed", "-smooth",
               "abefec:rhombus", "-chm_out", str(chm), "-png", str(d / "q.png"), "-q"])
    assert rc == 0
    return f, out, chm, d


def test_mixedconifer_acceptance(mixed):
    f, out, chm, d = mixed
    tops = gpd.read_file(out, layer="tree_tops")
    crowns = gpd.read_file(out, layer="crowns")
    assert tops.crs.to_epsg() == 26912 and crowns.crs.to_epsg() == 26912
    assert list(tops.columns[:-1]) == FIELDS and list(crowns.columns[:-1]) == FIELDS
    assert set(tops.tree_id) == set(crowns.tree_id) and tops.tree_id.is_unique
    assert len(tops) > 50
    assert crowns.is_valid.all() and (crowns.geom_type == "Polygon").all()
    m = crowns.merge(tops[["tree_id", "geometry"]], on="tree_id", suffixes=("", "_top"))
    assert all(c.contains(t) for c, t in zip(m.geometry, m.geometry_top))
    np.testing.assert_allclose(crowns.crown_diameter, np.sqrt(4 * crowns.crown_area / np.pi), atol=1e-6)
    np.testing.assert_allclose(crowns.crown_area, crowns.geometry.area, rtol=1e-9)
    # height = the highest return above ground in the crown (the CHM where that is higher):
    # never below the CHM's maximum in the crown, never above the crown's highest point
    import shapely

    from lidartrees_gis.io.points import open_points

    pts = open_points(f).read_all()
    with rasterio.open(chm) as ds:
        a = ds.read(1, masked=True).filled(np.nan)
        for _, row in crowns.sample(25, random_state=0).iterrows():
            inside = ~geometry_mask([row.geometry], a.shape, ds.transform)
            assert row.height >= np.nanmax(a[inside]) - 1e-4
            zin = pts.z[shapely.contains_xy(row.geometry, pts.x, pts.y)]
            assert row.height <= zin.max() + 0.05
    summ = pyogrio.read_dataframe(out, layer="summary")
    assert int(summ.trees[0]) == len(tops)
    # the quick look: coloured CHM with legend, outlines, tops, coordinates, title with summary
    from PIL import Image

    png = Image.open(d / "q.png")
    assert png.text["Title"] == "MixedConifer.laz"
    assert f"{len(tops):,} trees" in png.text["Description"]
    assert f"mean height {summ.mean_height[0]:.1f} m" in png.text["Description"]
    rgb = np.asarray(png.convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    green = (g > r + 40) & (g > b + 20)  # the CHM classes (YlGn)
    magenta = (r > 150) & (b > 90) & (g < 60)  # crown outlines
    red = (r > 180) & (g < 70) & (b < 70)  # tree tops
    assert green.mean() > 0.15 and magenta.sum() > 2000 and red.sum() > 3 * len(tops)


def test_existing_gpkg_refused_then_append_and_nln(mixed, tmp_path):
    f, out, _, _ = mixed
    n = len(gpd.read_file(out, layer="tree_tops"))
    assert main(["trees", str(f), str(out), "-tr", "0.5", "-q"]) == 1
    assert len(gpd.read_file(out, layer="tree_tops")) == n
    o2 = tmp_path / "two.gpkg"
    assert main(["trees", str(f), str(o2), "-tr", "0.5", "-smooth", "gauss5", "-q"]) == 0
    assert main(["trees", str(f), str(o2), "-tr", "0.5", "-smooth", "gauss5", "-q", "-append",
                 "-nln", "b_"]) == 0
    layers = {name for name, _ in pyogrio.list_layers(o2)}
    assert {"tree_tops", "crowns", "summary", "b_tree_tops", "b_crowns", "b_summary"} <= layers
    # the same trees appended to the same layers again: refused, the file unchanged
    n2 = len(gpd.read_file(o2, layer="tree_tops"))
    assert main(["trees", str(f), str(o2), "-tr", "0.5", "-smooth", "gauss5", "-q", "-append"]) == 1
    assert len(gpd.read_file(o2, layer="tree_tops")) == n2


def test_mixedconifer_count_agrees_with_lidr_segmentation(tmp_path, data):
    # MixedConifer's treeID holds 205 trees (lidR's segmentation): agreement within +-20 %
    out = tmp_path / "t.gpkg"
    assert main(["trees", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-tr", "0.5",
                 "-smooth", "gauss5", "-q"]) == 0
    n = len(gpd.read_file(out, layer="tree_tops"))
    assert 0.8 * 205 <= n <= 1.2 * 205


def test_compare_ten_rows_and_table1_ordering(tmp_path, data):
    out = tmp_path / "cmp.csv"
    assert main(["compare", str(data("lidR_extdata/MixedConifer.laz")), str(out), "-tr", "0.5",
                 "-q"]) == 0
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 10
    rg = [r for r in rows if r["method"] == "rg"]
    n = [int(r["trees"]) for r in rg]
    d = [float(r["mean_crown_diameter"]) for r in rg]
    assert n[0] >= n[1] >= n[2] and d[0] <= d[1] <= d[2]
    ws = {r["smooth"]: int(r["trees"]) for r in rows if r["method"] == "watershed"}
    for el in ("cross", "square", "rhombus"):  # Table 1: abefec smooths more than opening
        assert ws["none"] > ws[f"open:{el}"] >= ws[f"abefec:{el}"]
    for op in ("open", "abefec"):  # and cross < square < rhombus in strength
        assert ws[f"{op}:cross"] >= ws[f"{op}:square"] >= ws[f"{op}:rhombus"]


def test_trees_from_chm_geotiff_and_treex_csv(tmp_path, data):
    f = data("pycrown_example/CHM.tif")
    out = tmp_path / "t.gpkg"
    c = tmp_path / "t.csv"
    assert main(["trees", str(f), str(out), "-method", "treex", "-smooth", "gauss3",
                 "-mean_crown_area", "20", "-sd_crown_area", "5", "-max_crown_area", "80",
                 "-csv", str(c), "-lco", "SEPARATOR=COMMA", "-lco", "WRITE_BOM=NO", "-q"]) == 0
    tops = gpd.read_file(out, layer="tree_tops")
    assert tops.crs.to_epsg() == 2193 and len(tops) > 20
    rows = list(csv.DictReader(open(c)))
    assert list(rows[0])[:6] == ["tree_id", "row_number", "plant_number", "x", "y", "height"]
    assert list(rows[0])[-2:] == ["chm_row", "chm_col"]
    assert len(rows) == len(tops)


def test_mixedconifer_with_no_option_is_close_to_lidr(data, tmp_path):
    """Issue 9: the bare command works and gives a lidR-like count (lidR: 205 trees)."""
    f = data("lidR_extdata/MixedConifer.laz")
    out = tmp_path / "out.gpkg"
    assert main(["trees", str(f), str(out), "-q"]) == 0
    tops = gpd.read_file(out, layer="tree_tops")
    assert 0.75 * 205 <= len(tops) <= 1.25 * 205
    assert tops.crs.to_epsg() == 26912 and tops.height.max() < 40
    meta = pyogrio.read_info(out, layer="tree_tops")
    summ = pyogrio.read_dataframe(out, layer="summary")
    assert summ.res[0] == 0.45 and summ.tops[0] == "aw" and 1.0 < summ.crown_scale[0] < 4.0
    assert meta["features"] == len(tops)


def test_chm_defaults_on_bcts_give_canopy_heights(data, tmp_path):
    """Issue 9: `chm` with no option normalises by the ground (not the near-zero -dtm min)."""
    f = data("lasR_bcts/bcts_1.laz")
    out = tmp_path / "chm.tif"
    assert main(["chm", str(f), str(out), "-q"]) == 0
    with rasterio.open(out) as ds:
        a = ds.read(1, masked=True).compressed()
        tags = ds.tags()
        assert ds.res == (0.3, 0.3) and ds.crs.to_epsg() == 3005
    assert np.median(a[a > 2]) > 5
    assert '"chm": "pitfree"' in tags["LIDARTREES_PARAMETERS"]
    assert '"dtm": "auto (ground)"' in tags["LIDARTREES_PARAMETERS"]
