import numpy as np
import pytest
import rasterio

from lidartrees_gis.cli import main
from lidartrees_gis.grid import GridSpec, rasterize
from lidartrees_gis.io.points import open_points
from lidartrees_gis.als.surfaces import SurfaceOptions, compute_surfaces

pytestmark = pytest.mark.realdata


def test_bcts_chm_is_max_minus_min_per_cell(tmp_path, data):
    f = data("lasR_bcts/bcts_1.laz")
    out = tmp_path / "chm.tif"
    # seed 000's CHM: highest minus lowest point per cell, nothing dropped
    assert main(["chm", str(f), str(out), "-tr", "0.5", "-dtm", "min", "-chm", "max",
                 "-drop_class", "none", "-keep_outliers", "-q"]) == 0
    pts = open_points(f).read_all()
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 3005
        chm = ds.read(1)
        spec = GridSpec(ds.transform.c, ds.transform.f, 0.5, ds.width, ds.height)
    row, col = spec.cell_index(pts.x, pts.y)
    idx = row * spec.width + col
    n = spec.width * spec.height
    mx = np.full(n, -np.inf)
    mn = np.full(n, np.inf)
    np.maximum.at(mx, idx, pts.z)
    np.minimum.at(mn, idx, pts.z)
    filled = np.isfinite(mx)
    np.testing.assert_allclose(chm.ravel()[filled], (mx - mn)[filled], atol=1e-3)


def test_bcts_count_sums_to_point_count(tmp_path, data):
    f = data("lasR_bcts/bcts_2.laz")
    out = tmp_path / "n.tif"
    assert main(["grid", str(f), str(out), "-tr", "0.5", "-stat", "count", "-q"]) == 0
    with rasterio.open(out) as ds:
        assert int(ds.read(1).sum()) == 823945


def test_bcts_tiles_line_up(tmp_path, data):
    specs = []
    for i in (1, 2, 3, 4):
        out = tmp_path / f"t{i}.tif"
        assert main(["grid", str(data(f"lasR_bcts/bcts_{i}.laz")), str(out), "-tr", "2", "-q"]) == 0
        with rasterio.open(out) as ds:
            specs.append(ds.transform)
    for t in specs:
        assert t.c % 2 == 0 and t.f % 2 == 0 and t.a == 2


def test_topography_min_grid_matches_ground_class(data):
    pts = open_points(data("lidR_extdata/Topography.laz")).read_all()
    spec = GridSpec.from_bounds(pts.x.min(), pts.y.min(), pts.x.max(), pts.y.max(), 10.0)
    mn = rasterize(pts.x, pts.y, pts.z, spec, "min")
    g = pts.classification == 2
    gm = rasterize(pts.x[g], pts.y[g], pts.z[g], spec, "min")
    ok = ~np.isnan(gm)
    d = gm[ok] - mn[ok]
    assert ok.sum() > 500
    assert (d >= 0).all()  # the lowest point is never above the lowest ground point
    assert np.median(d) < 0.05 and np.mean(d < 0.5) > 0.85


def test_pycrown_chm_correlates_with_shipped_chm(data):
    src = open_points(data("pycrown_example/POINTS.laz"))
    s = compute_surfaces(src, 1.0, SurfaceOptions(dtm="ground", chm="max"))
    with rasterio.open(data("pycrown_example/CHM.tif")) as ref:
        R = ref.read(1)
        rows, cols = np.mgrid[0:s["spec"].height, 0:s["spec"].width]
        x, y = s["spec"].xy(rows.ravel(), cols.ravel())
        rr, cc = rasterio.transform.rowcol(ref.transform, x, y)
    rr, cc = np.asarray(rr), np.asarray(cc)
    ok = (rr >= 0) & (rr < R.shape[0]) & (cc >= 0) & (cc < R.shape[1])
    a, b = s["chm"].ravel()[ok], R[rr[ok], cc[ok]]
    m = np.isfinite(a) & np.isfinite(b)
    assert m.sum() > 50_000
    assert np.corrcoef(a[m], b[m])[0, 1] >= 0.95
