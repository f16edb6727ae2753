import csv

import laspy
import numpy as np
import pytest
import rasterio

from lidartrees_gis.cli import main
from lidartrees_gis.ground.filter import filter_errors


def _write_las(path, x, y, z, crs="EPSG:32632"):
    import pyproj

    h = laspy.LasHeader(point_format=6, version="1.4")
    h.scales = np.array([0.001] * 3)
    h.offsets = np.array([x.min(), y.min(), z.min()])
    h.add_crs(pyproj.CRS.from_user_input(crs))
    las = laspy.LasData(h)
    las.x, las.y, las.z = x, y, z
    las.write(str(path))


@pytest.mark.realdata
def test_ground_isprs_sample_classifies_and_writes_dtm(tmp_path, data):
    f = data("isprs_filtertest_dev/samp11-utm.laz")
    out, dtm = tmp_path / "g.laz", tmp_path / "dtm.tif"
    assert main(["ground", str(f), str(out), "-dtm", str(dtm), "-q"]) == 0
    ref = laspy.read(f).classification == 2
    got = laspy.read(out).classification == 2
    assert got.size == 38010
    e = filter_errors(got, ref)
    assert e["total"] < 30 and e["kappa"] > 0.4  # samp11 is the hardest urban sample
    with rasterio.open(dtm) as ds:
        assert ds.crs.to_epsg() == 32632
        n = 38010 / ((ds.bounds.right - ds.bounds.left) * (ds.bounds.top - ds.bounds.bottom))
        assert ds.res[0] == pytest.approx(np.sqrt(1 / n), rel=0.05)  # C = sqrt(1/n)



def test_sweep_deterministic_and_complete(tmp_path):
    from test_ground import synthetic_terrain

    x, y, z, _ = synthetic_terrain(1)
    keep = (x < 80) & (y < 80)
    f = tmp_path / "t.las"
    _write_las(f, x[keep], y[keep], z[keep])
    runs = []
    for k, workers in enumerate(("1", "2")):
        out = tmp_path / f"q{k}"
        import os

        os.environ["LIDARTREES_WORKERS"] = workers
        assert main(["dtm-quality", str(f), str(out), "-g", "-3:-1:0.5", "-w", "1:2:0.5", "-tr",
                     "1", "-q"]) == 0
        rows = list(csv.DictReader(open(out / "dtm_quality.csv")))
        runs.append([(r["g"], r["w"], r["cluster"], r["rank"]) for r in rows])
        assert len(rows) == 15
        # g + w <= -0.5 leaves no point within the band on this terrain: those DTMs are incomplete
        empty = [r for r in rows if int(r["ground_points"]) == 0]
        assert empty and all(r["role"] == "incomplete" for r in empty)
        good = [r for r in rows if r["role"] == "good"]
        assert good and all(int(r["ground_points"]) > 0 for r in good)
        n_clusters = len({r["cluster"] for r in rows if r["role"] != "incomplete"})
        assert len(list(out.glob("hillshade_cluster*.png"))) == n_clusters
        with rasterio.open(out / "recommended_dtm.tif") as ds:
            assert ds.crs.to_epsg() == 32632 and ds.res == (1.0, 1.0)
            dtm = ds.read(1)
        truth = 300 + 0.08 * 40 + 0.03 * 40 + 3 * np.sin(40 / 25) * np.cos(40 / 30)
        r_, c_ = ds.index(40.0, 40.0)
        assert abs(dtm[r_, c_] - truth) < 0.3  # the recommended DTM is the terrain
    os.environ.pop("LIDARTREES_WORKERS")
    assert runs[0] == runs[1]


def test_chm_with_kp_dtm_recovers_object_heights(tmp_path):
    from test_ground import synthetic_terrain

    x, y, z, truth = synthetic_terrain(2)
    f = tmp_path / "t.las"
    _write_las(f, x, y, z)
    out = tmp_path / "chm.tif"
    assert main(["chm", str(f), str(out), "-tr", "2", "-dtm", "kp", "-q"]) == 0
    with rasterio.open(out) as ds:
        chm = ds.read(1)
        # a building (8 m) at x 120-136, y 60-72: cells fully inside
        r0, c0 = ds.index(124, 69)
        r1, c1 = ds.index(132, 63)
        assert np.median(chm[r0:r1 + 1, c0:c1 + 1]) == pytest.approx(8, abs=0.6)
        # open terrain near 0
        rr, cc = ds.index(100, 100)
        assert abs(chm[rr, cc]) < 0.8


def test_dtm_quality_checks_each_dtm_against_a_reference_dtm(tmp_path):
    """-reference DTM.tif: each DTM's RMSE to it in the CSV, the closest complete one
    recommended; -reference none: the texture decides and no RMSE is given."""
    import json

    from rasterio.transform import from_origin
    from test_ground import synthetic_terrain

    x, y, z, _ = synthetic_terrain(3)
    keep = (x < 80) & (y < 80)
    f = tmp_path / "t.las"
    _write_las(f, x[keep], y[keep], z[keep])
    yy, xx = np.mgrid[0:80, 0:80] + 0.5
    truth = 300 + 0.08 * xx + 0.03 * (80 - yy) + 3 * np.sin(xx / 25) * np.cos((80 - yy) / 30)
    ref = tmp_path / "ref.tif"
    with rasterio.open(ref, "w", driver="GTiff", width=80, height=80, count=1, dtype="float64",
                       crs="EPSG:32632", transform=from_origin(0, 80, 1, 1)) as ds:
        ds.write(truth, 1)
    out = tmp_path / "q"
    assert main(["dtm-quality", str(f), str(out), "-g", "-3:0:1", "-w", "1:3:1", "-tr", "1",
                 "-reference", str(ref), "-q"]) == 0
    rows = [r for r in csv.DictReader(open(out / "dtm_quality.csv")) if r["role"] != "incomplete"]
    rm = {(float(r["g"]), float(r["w"])): float(r["ref_rmse"]) for r in rows}
    with rasterio.open(out / "recommended_dtm.tif") as ds:
        p = json.loads(ds.tags()["LIDARTREES_PARAMETERS"])
    assert rm[(p["g"], p["w"])] == min(rm.values()) < 0.3
    out2 = tmp_path / "q2"
    assert main(["dtm-quality", str(f), str(out2), "-g", "-3:0:1", "-w", "1:3:1", "-tr", "1",
                 "-reference", "none", "-q"]) == 0
    assert all(r["ref_rmse"] == "" for r in csv.DictReader(open(out2 / "dtm_quality.csv")))
    assert main(["dtm-quality", str(f), str(tmp_path / "q3"), "-reference",
                 str(tmp_path / "missing.tif"), "-q"]) != 0
