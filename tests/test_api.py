"""The Python API: in-memory results equal to the CLI's files."""
import geopandas as gpd
import numpy as np
import rasterio

import lidartrees_gis as lt
from lidartrees_gis.cli import main
from lidartrees_gis.synthetic import make_stand, write_xyz_seed_dialect


def test_api_matches_the_cli(tmp_path):
    pts, truth = make_stand()
    f = tmp_path / "stand.xyz"
    write_xyz_seed_dialect(f, pts)
    crs = "EPSG:29194"
    chm, profile = lt.canopy_height(f, a_srs=crs)
    assert chm.dtype == np.float32 and profile["crs"].to_epsg() == 29194
    out = tmp_path / "api.tif"
    with rasterio.open(out, "w", **profile) as ds:  # rasterio-ready
        ds.write(chm, 1)
    assert main(["chm", str(f), str(tmp_path / "cli.tif"), "-a_srs", crs, "-q"]) == 0
    with rasterio.open(out) as a, rasterio.open(tmp_path / "cli.tif") as b:
        assert a.transform == b.transform and a.crs == b.crs
        np.testing.assert_allclose(a.read(1), b.read(1), atol=1e-4, equal_nan=True)
    tops, crowns, summary = lt.find_trees(f, a_srs=crs)
    assert isinstance(tops, gpd.GeoDataFrame) and isinstance(crowns, gpd.GeoDataFrame)
    assert tops.crs.to_epsg() == 29194 and (tops.geom_type == "Point").all()
    assert set(crowns.geom_type) <= {"Polygon", "MultiPolygon"}
    # a suppressed tree (an empty planting position with a tree under its neighbours) has no
    # crown polygon
    assert set(tops.loc[tops.suppressed == 0, "tree_id"]) == set(crowns["tree_id"])
    assert (tops.suppressed == 1).sum() == summary["suppressed_trees"]
    assert abs(len(tops) - len(truth["x"])) <= 0.03 * len(truth["x"])
    assert summary["trees"] == len(tops)
    assert main(["trees", str(f), str(tmp_path / "t.gpkg"), "-a_srs", crs, "-q"]) == 0
    cli = gpd.read_file(tmp_path / "t.gpkg", layer="tree_tops")
    assert sorted(cli["tree_id"]) == sorted(tops["tree_id"])
    pts2, ground = lt.classify_ground(f, a_srs=crs)
    ref = pts.classification == 2
    assert len(pts2) == len(pts) and (ground & ref).sum() / ref.sum() > 0.95
