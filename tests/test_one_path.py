"""Issue 22: one code path for one file and for a whole flight. A file processed in tiles gives
the trees and the CHM of the same file processed as one tile, on every real LAS/LAZ file in
../shared/data."""
import math

import numpy as np
import pyogrio
import pytest
import rasterio

from lidartrees_gis.als.chain import trees_run
from lidartrees_gis.catalog.catalog import Catalog, TilingOptions
from lidartrees_gis.io.output import OutputOptions

from conftest import DATA

FILES = sorted(str(p.relative_to(DATA)) for p in DATA.rglob("*.la[sz]")) if DATA.exists() else []


def _run(f, out, tile_size):
    return trees_run(f, out / "t.gpkg", chm_out=out / "chm.tif",
                     tiling=TilingOptions(tile_size=tile_size, workers=1),
                     out=OutputOptions(overwrite=True))


@pytest.mark.realdata
@pytest.mark.parametrize("name", FILES or ["(no shared data)"])
def test_tiled_equals_untiled_on_every_real_file(name, tmp_path):
    """Tiles of 1/2.5 of the file's larger side (4 to 20 tiles, each with its buffer) against
    the file as one tile: the same tree ids, heights and crown areas, and the same CHM to 1e-4 m
    except within one buffer of the acquisition's outer edge, where the DTM is extrapolated
    from the nearest ground point and that point may lie beyond a tile's buffer (Topography's
    lake shore: 38 cells up to 0.1 m)."""
    if not FILES:
        pytest.skip(f"no shared data under {DATA}")
    f = DATA / name
    x0, y0, x1, y1 = Catalog.open(f).extent
    (tmp_path / "one").mkdir()
    (tmp_path / "tiles").mkdir()
    one = _run(f, tmp_path / "one", math.inf)
    tiled = _run(f, tmp_path / "tiles", max(x1 - x0, y1 - y0) / 2.5)
    assert one["tiles"] == 1 and tiled["tiles"] >= 4
    assert one["trees"] == tiled["trees"]
    assert np.array_equal(np.sort(one["tree_ids"]), np.sort(tiled["tree_ids"]))
    if one["trees"]:
        a, b = (pyogrio.read_dataframe(tmp_path / d / "t.gpkg", layer="crowns",
                                       read_geometry=False).set_index("tree_id").sort_index()
                for d in ("one", "tiles"))
        np.testing.assert_allclose(a.height, b.height, atol=1e-9)
        np.testing.assert_allclose(a.crown_area, b.crown_area, atol=1e-9)
    with rasterio.open(tmp_path / "one" / "chm.tif") as da, \
            rasterio.open(tmp_path / "tiles" / "chm.tif") as db:
        assert da.transform == db.transform and da.shape == db.shape and da.crs == db.crs
        A = da.read(1, masked=True).filled(np.nan)
        B = db.read(1, masked=True).filled(np.nan)
        rows, cols = np.mgrid[0:A.shape[0], 0:A.shape[1]]
        tr = da.transform
        cx, cy = tr.c + (cols + 0.5) * tr.a, tr.f + (rows + 0.5) * tr.e
    edge = np.minimum.reduce([cx - x0, x1 - cx, cy - y0, y1 - cy])
    inner = edge > tiled["buffer"] + 2 * one["res"]
    assert np.array_equal(np.isnan(A[inner]), np.isnan(B[inner]))
    ok = inner & np.isfinite(A)
    assert np.abs(A[ok] - B[ok]).max(initial=0.0) <= 1e-4
