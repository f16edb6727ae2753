"""Issue 23 item 4: `evaluate -area`: a reference plot inside a larger flight. Detections
outside the plot are not false positives (a 50 m plot in an 82 m file once got F 0.36 for
0.57)."""
import json

import geopandas as gpd
import numpy as np
import pytest
import shapely

from lidartrees_gis.cli import main


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    """The demo stand's trees (60 x 60 m) and a 30 x 30 m plot of its truth in the middle."""
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    sp = StandParams()
    pts, truth = make_stand(sp)
    d = tmp_path_factory.mktemp("flight")
    f = d / "s.las"
    write_points(f, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194),
                 classification=pts.classification)
    gpkg = d / "t.gpkg"
    assert main(["trees", str(f), str(gpkg), "-q"]) == 0
    box = (sp.origin_x + 15, sp.origin_y + 15, sp.origin_x + 45, sp.origin_y + 45)
    x, y, h = (np.asarray(truth[k]) for k in ("x", "y", "height"))
    inside = (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])
    ref = d / "plot.csv"
    with open(ref, "w", encoding="utf-8") as fh:
        fh.write("x,y,height\n")
        for a, b, c in zip(x[inside], y[inside], h[inside]):
            fh.write(f"{a:.3f},{b:.3f},{c:.2f}\n")
    poly = d / "plot.gpkg"
    gpd.GeoDataFrame({"plot": [1]}, geometry=[shapely.box(*box)], crs=29194).to_file(poly)
    return gpkg, ref, poly, box, int(inside.sum())


def _report(args, tmp_path):
    out = tmp_path / "r.json"
    assert main(["evaluate", *args, "-o", str(out), "-overwrite", "-q"]) == 0
    return json.loads(out.read_text())


def test_detections_outside_the_plot_are_not_false_positives(flight, tmp_path):
    gpkg, ref, poly, box, n = flight
    plain = _report([str(gpkg), str(ref)], tmp_path)["all"]
    assert plain["precision"] < 0.35  # every tree outside the plot counted as a false one
    for area in (",".join(f"{v:.3f}" for v in box), str(poly), f"{poly}:plot"):
        r = _report([str(gpkg), str(ref), "-area", area], tmp_path)
        a = r["all"]
        assert a["reference"] == n and a["precision"] > 0.97 and a["f_score"] > 0.97, area
        assert r["area"]["detections_left_out"] > 300
    assert main(["evaluate", str(gpkg), str(ref), "-area", "1,2,3", "-q"]) == 1
