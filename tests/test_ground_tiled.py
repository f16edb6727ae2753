"""Issue 25: ``ground`` over a folder of files, each with a buffer of its neighbours' points, on
the catalog runner: the same classes as the files merged into one, a seamless DTM mosaic, one
classified copy per file, and the output rules (no overwrite, no half-written outputs)."""
import subprocess
import sys

import numpy as np
import pytest

from lidartrees_gis.catalog.catalog import TilingOptions
from lidartrees_gis.errors import InputError, LidarTreesError, OutputExistsError
from lidartrees_gis.ground.tiled import ground_run as ground_file
from lidartrees_gis.io.output import OutputOptions

from _paths import DATA

laspy = pytest.importorskip("laspy")
BCTS = [DATA / "lasR_bcts" / f"bcts_{i}.laz" for i in (1, 2)]
pytestmark = pytest.mark.skipif(not all(f.exists() for f in BCTS), reason="shared data missing")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two adjacent bcts tiles as a folder and merged into one file, both classified."""
    d = tmp_path_factory.mktemp("ground_tiled")
    folder = d / "in"
    folder.mkdir()
    las = [laspy.read(f) for f in BCTS]
    for f, la in zip(BCTS, las):
        (folder / f.name).write_bytes(f.read_bytes())
    merged = laspy.LasData(las[0].header)
    merged.points = laspy.ScaleAwarePointRecord(
        np.concatenate([la.points.array for la in las]), las[0].header.point_format,
        las[0].header.scales, las[0].header.offsets)
    merged.write(d / "merged.laz")
    one = ground_file(d / "merged.laz", d / "merged_g.laz", dtm_out=d / "merged_dtm.tif", res=1.0,
                      tiling=TilingOptions(workers=1))
    many = ground_file(folder, d / "out", dtm_out=d / "tiles_dtm.tif", res=1.0,
                       tiling=TilingOptions(workers=1))
    return d, one, many, [len(la.points) for la in las]


def test_folder_gives_the_classes_of_the_merged_file(runs):
    d, one, many, counts = runs
    assert many["files"] == 2 and many["points"] == one["points"] == sum(counts)
    whole = np.asarray(laspy.read(d / "merged_g.laz").classification)
    parts = np.concatenate([np.asarray(laspy.read(d / "out" / f.name).classification) for f in BCTS])
    assert whole.size == parts.size
    differ = int((np.asarray(whole) != np.asarray(parts)).sum())
    assert 0.2 < (np.asarray(parts) == 2).mean() < 0.6
    assert differ == 0  # the same classes, point for point
    assert many["ground"] == one["ground"]


def test_dtm_mosaic_is_seamless_and_matches_the_merged_file(runs):
    import rasterio

    d, *_ = runs
    with rasterio.open(d / "merged_dtm.tif") as a, rasterio.open(d / "tiles_dtm.tif") as b:
        assert a.transform == b.transform and a.shape == b.shape
        assert b.crs.to_epsg() == 3005
        da, db = a.read(1, masked=True), b.read(1, masked=True)
    both = ~da.mask & ~db.mask
    assert both.mean() > 0.8
    diff = np.abs(da.data - db.data)[both]
    assert np.percentile(diff, 99.9) < 0.01 and diff.max() < 0.5
    # the files' seam (y = 629400) holds no step: rows either side differ as elsewhere
    assert np.nanmax(np.abs(np.diff(db.filled(np.nan), axis=0))) < 5.0


def test_one_classified_copy_per_file_with_every_attribute(runs):
    d, *_ = runs
    for f in BCTS:
        a, b = laspy.read(f), laspy.read(d / "out" / f.name)
        assert len(a.points) == len(b.points)
        np.testing.assert_array_equal(a.X, b.X)
        np.testing.assert_array_equal(a.intensity, b.intensity)
        assert b.header.parse_crs().to_epsg() == 3005
    assert not list((d / "out").glob(".*part*"))


def test_existing_outputs_are_kept_without_overwrite(runs, tmp_path):
    d, *_ = runs
    before = {p.name: p.stat().st_mtime_ns for p in (d / "out").iterdir()}
    with pytest.raises(OutputExistsError):
        ground_file(d / "in", d / "out", tiling=TilingOptions(workers=1))
    assert {p.name: p.stat().st_mtime_ns for p in (d / "out").iterdir()} == before
    with pytest.raises(InputError, match="give a folder"):
        ground_file(d / "in", tmp_path / "x.laz", tiling=TilingOptions(workers=1))


def test_a_bad_file_is_named_and_nothing_is_written(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / BCTS[0].name).write_bytes(BCTS[0].read_bytes())
    raw = BCTS[1].read_bytes()
    (folder / "broken.laz").write_bytes(raw[: len(raw) // 3])  # truncated: the chunks are gone
    with pytest.raises(LidarTreesError, match="broken.laz"):
        ground_file(folder, tmp_path / "out", tiling=TilingOptions(workers=1),
                    out=OutputOptions())
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())


def test_cli_folder_on_two_workers(runs, tmp_path):
    d, one, *_ = runs
    r = subprocess.run([sys.executable, "-m", "lidartrees_gis.cli", "ground", str(d / "in"),
                        str(tmp_path / "o"), "-workers", "2", "-q"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    lines = dict(ln.split(": ", 1) for ln in r.stdout.splitlines() if ": " in ln)
    assert lines["files"] == "2" and lines["buffer"] == "30.0"
    assert int(lines["ground"]) == one["ground"]
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == sorted(f.name for f in BCTS)


@pytest.fixture(scope="module")
def small_tiles(tmp_path_factory):
    """Four 40 x 40 m files cut from bcts_1, as a folder and merged back into one file."""
    d = tmp_path_factory.mktemp("quality_tiles")
    las = laspy.read(BCTS[0])
    x0, y0 = float(las.x.min()) + 20, float(las.y.min()) + 20
    folder = d / "in"
    folder.mkdir()
    keep = np.zeros(len(las.points), bool)
    for i, (ox, oy) in enumerate([(0, 0), (40, 0), (0, 40), (40, 40)]):
        m = ((las.x >= x0 + ox) & (las.x < x0 + ox + 40) & (las.y >= y0 + oy)
             & (las.y < y0 + oy + 40))
        part = laspy.LasData(las.header)
        part.points = las.points[np.asarray(m)]
        part.write(folder / f"part_{i}.laz")
        keep |= np.asarray(m)
    whole = laspy.LasData(las.header)
    whole.points = las.points[keep]
    whole.write(d / "whole.laz")
    return d


def test_dtm_quality_over_a_folder_matches_the_merged_file(small_tiles):
    import csv

    from lidartrees_gis.ground.quality import dtm_quality_file

    d = small_tiles
    one = dtm_quality_file(d / "whole.laz", d / "q_one", res=0.5, workers=1)
    many = dtm_quality_file(d / "in", d / "q_many", res=0.5, workers=1)
    assert many["dtms"] == one["dtms"] == 77
    assert many["reference"].startswith("the files' class-2 points")
    rows_one = list(csv.DictReader(open(one["output"])))
    rows_many = list(csv.DictReader(open(many["output"])))
    g1 = np.array([int(r["ground_points"]) for r in rows_one])
    g2 = np.array([int(r["ground_points"]) for r in rows_many])
    assert (g1 > 0).sum() >= 50
    # each (g, w) keeps the same ground points within 0.5 % (the filter's grids follow each
    # file's box inside the area; the merged file's follow the points)
    assert np.all(np.abs(g1 - g2) <= 0.005 * np.maximum(g1, 1) + 3)
    rm1 = np.array([float(r["ref_rmse"] or "nan") for r in rows_one])
    rm2 = np.array([float(r["ref_rmse"] or "nan") for r in rows_many])
    both = np.isfinite(rm1) & np.isfinite(rm2) & (g1 >= 1000)  # not a DTM of a few points
    assert both.sum() >= 40 and np.nanmax(np.abs(rm1[both] - rm2[both])) < 0.05
    assert (d / "q_many" / "recommended_dtm.tif").exists()
    assert not list((d / "q_many").glob(".lidartrees-dtms-*")) and not list(d.glob(".lidartrees-dtms-*"))


def test_chm_kp_dtm_in_tiles_equals_one_tile(tmp_path):
    """`chm -dtm kp` over two bcts files in 100 m tiles: each tile runs the ground filter with
    the area's densification cell and its grids on the tile's box (as `ground`'s tiles do), so
    the DTM is one tile's (each tile's own cell left 8 cells 0.1-1.04 m apart)."""
    import rasterio

    from lidartrees_gis.als.surfaces import _tile_ground_grid
    from lidartrees_gis.catalog.catalog import Catalog
    from lidartrees_gis.catalog.source import TileSource
    from lidartrees_gis.cli import main
    from lidartrees_gis.ground.filter import refine_cell_for

    files = [DATA / "lasR_bcts" / f"bcts_{k}.laz" for k in (1, 2)]
    lst = tmp_path / "list.txt"
    lst.write_text("\n".join(map(str, files)) + "\n")
    cat = Catalog.open(lst)
    e = cat.extent
    tile = (e[0] - 20, e[1] - 20, e[0] + 120, e[1] + 120)
    grid = _tile_ground_grid(TileSource(cat, tile))
    assert grid["refine_res"] == refine_cell_for(cat.area, cat.count)
    assert grid["extent"] == (e[0], e[1], e[0] + 120, e[1] + 120)  # clipped to the area
    assert _tile_ground_grid(TileSource(cat, (e[0] - 1, e[1] - 1, e[2] + 1, e[3] + 1))) == {}
    dtm = {}
    for name, ts in (("tiled", "100"), ("one", "100000")):
        out = tmp_path / f"dtm_{name}.tif"
        assert main(["chm", str(lst), str(tmp_path / f"chm_{name}.tif"), "-dtm", "kp", "-tr",
                     "1", "-tile_size", ts, "-dtm_out", str(out), "-workers", "1", "-q"]) == 0
        with rasterio.open(out) as ds:
            dtm[name] = ds.read(1, masked=True).astype(float).filled(np.nan)
    d = np.abs(dtm["tiled"] - dtm["one"])
    ok = np.isfinite(d)
    assert ok.sum() > 100_000 and np.isfinite(dtm["one"]).sum() == ok.sum()
    assert d[ok].max() < 0.01
