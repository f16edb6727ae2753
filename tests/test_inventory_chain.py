"""The metrics command on real data: Megaplot (height-normalised, -dtm none) and the efi
plots (centres, 11.28 m radius, lidR's example) against the lidR definitions computed one
group at a time from the file's points (tests/test_inventory_metrics.py)."""
import numpy as np
import pytest

from test_inventory_metrics import STD_Z, _close, lidr_stdmetrics_z

MP = "lidR_extdata/Megaplot.laz"
EFI = "lidR_extdata/efi_plot.shp"


def _xyz(path):
    import laspy

    las = laspy.read(path)
    return np.asarray(las.x), np.asarray(las.y), np.asarray(las.z), np.asarray(las.return_number)


def _run(data, tmp_path, out, **kw):
    from lidartrees_gis import api as lt

    return lt.metrics(data(MP), tmp_path / out, dtm="none", min_height=None, **kw)


def test_megaplot_cells_equal_lidr_definitions(data, tmp_path):
    import rasterio

    r = _run(data, tmp_path, "m.tif", res=20)
    x, y, z, _ = _xyz(data(MP))
    with rasterio.open(tmp_path / "m.tif") as ds:
        assert ds.count == r["bands"] and ds.descriptions[0] == "zmax"
        names = list(ds.descriptions)
        arr = ds.read()
        arr = np.where(arr == ds.nodata, np.nan, arr)
        t = ds.transform
        assert ds.crs.to_epsg() == 26917
    # lidR's pixel_metrics grid: cells on multiples of 20 m, rows counted from the top
    assert t.c % 20 == 0 and t.f % 20 == 0
    col = np.floor(x / 20).astype(int) - int(t.c // 20)
    row = int(t.f // 20) - np.ceil(y / 20).astype(int)  # a return on a row edge: the row below
    checked = 0
    for (rr, cc) in {(int(a), int(b)) for a, b in zip(row[::997], col[::997])}:
        sel = (row == rr) & (col == cc)
        ref = lidr_stdmetrics_z(z[sel])
        for name in STD_Z:
            v = float(arr[names.index(name), rr, cc])
            assert _close(v, ref[name]) or abs(v - ref[name]) < 1e-4 * max(1, abs(ref[name])), \
                (rr, cc, name, v, ref[name])  # float32 band
        assert arr[names.index("n"), rr, cc] == sel.sum()
        checked += 1
    assert checked >= 40
    assert float(arr[0].max()) == pytest.approx(z.max(), abs=1e-5)


def test_efi_plots_equal_lidr_definitions(data, tmp_path):
    import geopandas as gpd

    r = _run(data, tmp_path, "p.gpkg", plots=data(EFI), plot_radius=11.28)
    assert r["plot_metrics"] == 5
    g = gpd.read_file(tmp_path / "p.gpkg", layer="plot_metrics")
    assert g.crs.to_epsg() == 26917 and list(g["plot_id"]) == [f"PEPQ{i}" for i in range(1, 6)]
    assert "VOI" in g.columns  # the plots' own fields kept
    x, y, z, _ = _xyz(data(MP))
    efi = gpd.read_file(data(EFI))
    for k, p in enumerate(efi.geometry):
        sel = (x - p.x) ** 2 + (y - p.y) ** 2 <= 11.28 ** 2  # lidR clip_circle
        ref = lidr_stdmetrics_z(z[sel])
        for name in STD_Z:
            assert _close(float(g[name][k]), ref[name]), (k, name)
        assert g["n"][k] == sel.sum() and g["zmax"][k] <= z.max()
    # the area of each plot polygon is that of the circle to 0.5 %
    assert np.allclose(g.geometry.area, np.pi * 11.28 ** 2, rtol=5e-3)


def test_first_returns_min_height_and_tiles_agree(data, tmp_path):
    import rasterio

    a = _run(data, tmp_path, "a.tif", res=20, returns="first")
    b = _run(data, tmp_path, "b.tif", res=20, returns="first", tile_size=60)
    assert b["tiles"] > 1 and a["tiles"] == 1
    with rasterio.open(tmp_path / "a.tif") as da, rasterio.open(tmp_path / "b.tif") as db:
        assert np.array_equal(da.read(), db.read())
        n = da.read(da.descriptions.index("n") + 1)
    _, _, _, rn = _xyz(data(MP))
    assert n[n > -1e30].sum() == (rn == 1).sum()


def test_bad_inputs_one_line(data, tmp_path):
    from lidartrees_gis import api as lt
    from lidartrees_gis.errors import InputError

    with pytest.raises(InputError, match="-plot_radius"):
        lt.metrics(data(MP), tmp_path / "x.gpkg", plots=data(EFI), dtm="none")
    with pytest.raises(InputError, match="GeoPackage"):
        lt.metrics(data(MP), tmp_path / "x.tif", plots=data(EFI), plot_radius=11.28)
    assert not list(tmp_path.iterdir())


def test_stand_metrics_and_python_in_memory(data, tmp_path):
    import geopandas as gpd
    import shapely

    from lidartrees_gis import api as lt

    x, y, z, _ = _xyz(data(MP))
    boxes = [(684770, 5017780, 684880, 5017900), (684880, 5017780, 684990, 5018000)]
    gpd.GeoDataFrame({"talhao": ["A", "B"], "clone": ["I144", "AEC144"]},
                     geometry=[shapely.box(*b) for b in boxes],
                     crs="EPSG:26917").to_file(tmp_path / "st.gpkg")
    r = lt.metrics(data(MP), stands=tmp_path / "st.gpkg", dtm="none", min_height=2.0)
    s = r["layers"]["stand_metrics"]
    assert list(s["stand_id"]) == ["A", "B"]
    assert list(s["clone"]) == ["I144", "AEC144"]  # the stands' own fields kept, as volume
    for k, (x0, y0, x1, y1) in enumerate(boxes):
        sel = (x > x0) & (x < x1) & (y > y0) & (y < y1) & (z > 2.0)
        assert s["n"][k] == sel.sum()
        assert s["zmean"][k] == pytest.approx(z[sel].mean())
    assert s.crs.to_epsg() == 26917


def test_a_return_on_a_row_edge_is_in_the_row_below_as_in_lidr(tmp_path):
    """lidR's pixel_metrics (terra's cellFromXY) counts rows from the top: a return exactly on a
    row edge (y a multiple of -tr) is in the row below; on a column edge, in the column to the
    right. Before, such returns went to the row above (106 of Megaplot's 156 cells off lidR's
    own output by up to 27 %); now one tile and 40 m tiles both place them as lidR does."""
    from pyproj import CRS

    from lidartrees_gis import api as lt
    from lidartrees_gis.io.lasout import write_points

    rng = np.random.default_rng(5)
    gx, gy = np.meshgrid(np.arange(0.5, 120, 1.0), np.arange(0.5, 120, 1.0))
    x = np.r_[gx.ravel(), np.full(30, 30.0), np.full(30, 50.0)] + 500_000.0
    y = np.r_[gy.ravel(), np.full(30, 40.0), np.full(30, 60.0)] + 7_000_000.0  # on edges
    z = np.r_[rng.uniform(3, 20, gx.size), np.full(60, 25.0)]
    f = tmp_path / "e.las"
    write_points(f, x, y, z, crs=CRS.from_epsg(31983))
    a = lt.metrics(f, res=20, dtm="none", min_height=None)
    b = lt.metrics(f, res=20, dtm="none", min_height=None, tile_size=40)
    (sa, ga), (sb, gb) = a["grid"], b["grid"]
    assert b["tiles"] > 1 and sa == sb and np.array_equal(ga, gb, equal_nan=True)
    from lidartrees_gis.inventory.metrics import METRICS

    n, zmax = ga[list(METRICS).index("n")], ga[list(METRICS).index("zmax")]
    col = np.floor((x - sa.left) / 20).astype(int)
    row = np.floor((sa.top - y) / 20).astype(int)  # lidR: rows from the top
    expect = np.zeros(n.shape, int)
    np.add.at(expect, (row, col), 1)
    assert np.array_equal(n, expect)
    # the 30 returns at (500030, 7000040) are in the cell (500020-500040, 7000020-7000040)
    r, c = int((sa.top - 7_000_030.0) // 20), int((500_030.0 - sa.left) // 20)
    assert zmax[r, c] == 25.0 and zmax[r - 1, c] < 25.0 and n[r, c] == 400 + 30
