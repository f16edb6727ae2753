"""Issue 10: many inputs, tiles with buffers, seamless trees whatever the tiling, Dask."""
import json
from pathlib import Path

import geopandas as gpd
import numpy as np
import pyogrio
import pytest
import rasterio
from pyproj import CRS

from lidartrees_gis.catalog.catalog import Catalog, make_tiles
from lidartrees_gis.catalog.inputs import expand_inputs
from lidartrees_gis.cli import main
from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.als.chain import trees_run
from lidartrees_gis.catalog.catalog import TilingOptions
from lidartrees_gis.io.output import OutputOptions


def trees_tiled(input, output, *, params=None, tile_size=None, buffer=None, workers=None,
                scheduler=None, overwrite=False, append=False, nln="", **kw):
    """``trees`` through the one chain with the tiling given."""
    return trees_run(input, output, params=params,
                     tiling=TilingOptions(tile_size, buffer, workers, scheduler, any_size=True),
                     out=OutputOptions(overwrite=overwrite, append=append, nln=nln), **kw)


@pytest.fixture(scope="module")
def split_stand(tmp_path_factory, stand):
    """The synthetic stand written as three LAS files (west, middle, east strips)."""
    pts, truth = stand
    d = tmp_path_factory.mktemp("split")
    x0 = pts.x.min()
    edges = [x0 - 1, x0 + 20.3, x0 + 41.7, pts.x.max() + 1]
    files = []
    for k in range(3):
        m = (pts.x >= edges[k]) & (pts.x < edges[k + 1])
        f = d / f"part{k}.laz"
        write_points(f, pts.x[m], pts.y[m], pts.z[m], crs=CRS.from_epsg(29194),
                     classification=pts.classification[m])
        files.append(f)
    (d / "notes.gpkg").write_bytes(b"not a point file")
    return d, files, truth


def test_inputs_from_folder_glob_list_and_vpc(split_stand, tmp_path):
    d, files, _ = split_stand
    assert expand_inputs(d) == files  # the .gpkg beside them is not a point file
    assert expand_inputs(str(d / "part*.laz")) == files
    lst = tmp_path / "list.txt"
    lst.write_text("\n".join(str(f) for f in files[::-1]) + "\n")
    assert expand_inputs(lst) == files[::-1]
    vpc = tmp_path / "all.vpc"
    vpc.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "assets": {"data": {"href": str(f)}}} for f in files]}))
    assert expand_inputs(vpc) == files
    cat = Catalog.open(d)
    assert cat.crs.to_epsg() == 29194 and len(cat.files) == 3
    with pytest.raises(OSError, match="matches no file"):
        expand_inputs(str(d / "nothing*.laz"))


def test_default_tile_side_follows_the_point_density(split_stand, tmp_path, monkeypatch):
    from lidartrees_gis.als import area as tiled

    assert tiled.auto_tile_size(1.9) == 500.0  # Megaplot copies: 1.9 points per occupied m²
    assert tiled.auto_tile_size(4.0) == 350.0
    assert tiled.auto_tile_size(25.0) == tiled.TILE_SIZE == 250.0  # dense: memory per worker
    assert tiled.auto_tile_size(0.01) == tiled.MAX_TILE_SIZE
    assert tiled.auto_tile_size(float("nan")) == tiled.TILE_SIZE
    d, _, _ = split_stand  # the synthetic stand: 25 points per m², 90,000 points
    one = trees_tiled(d, tmp_path / "one.gpkg", workers=1)
    assert one["tiles"] == 1  # an area of at most ONE_TILE_POINTS is one tile
    summ = pyogrio.read_dataframe(tmp_path / "one.gpkg", layer="summary")
    assert summ.tiles[0] == 1 and np.isnan(summ.tile_size[0])
    monkeypatch.setattr(tiled, "ONE_TILE_POINTS", 10_000)  # a larger area: 250 m tiles
    trees_tiled(d, tmp_path / "a.gpkg", workers=1)
    summ = pyogrio.read_dataframe(tmp_path / "a.gpkg", layer="summary")
    assert summ.tile_size[0] == pytest.approx(250.0, abs=0.5)
    assert main(["trees", str(d), str(tmp_path / "b.gpkg"), "-tile_size", "auto", "-workers",
                 "1", "-q"]) == 0  # the default, by name
    summ = pyogrio.read_dataframe(tmp_path / "b.gpkg", layer="summary")
    assert summ.tile_size[0] == pytest.approx(250.0, abs=0.5)
    assert main(["trees", str(d), str(tmp_path / "c.gpkg"), "-tile_size", "big", "-q"]) == 1


def test_tiles_are_aligned_and_cores_partition_the_area():
    tiles = make_tiles((1010.0, 2020.0, 1290.0, 2230.0), 100.0, 15.0)
    assert {t.index for t in tiles} == {(i, j) for i in (10, 11, 12) for j in (20, 21, 22)}
    rng = np.random.default_rng(0)
    x = np.r_[rng.uniform(1010, 1290, 5000), 1100.0, 1290.0]
    y = np.r_[rng.uniform(2020, 2230, 5000), 2100.0, 2230.0]
    owners = sum(t.in_core(x, y).astype(int) for t in tiles)
    assert (owners == 1).all()  # every point, on an edge or on the far corner, in one core
    t = [t for t in tiles if t.index == (11, 21)][0]
    assert t.core == (1100.0, 2100.0, 1200.0, 2200.0) and t.box == (1085.0, 2085.0, 1215.0, 2215.0)


def test_tiled_equals_untiled_on_a_stand_split_in_files(split_stand, tmp_path):
    d, files, truth = split_stand
    a = trees_tiled(d, tmp_path / "a.gpkg", tile_size=25, workers=1)
    b = trees_tiled(d, tmp_path / "b.gpkg", tile_size=float("inf"), workers=1)
    assert a["tiles"] > 4 and b["tiles"] == 1
    assert a["trees"] == b["trees"] and set(a["tree_ids"]) == set(b["tree_ids"])
    ca = gpd.read_file(tmp_path / "a.gpkg", layer="crowns").set_index("tree_id").sort_index()
    cb = gpd.read_file(tmp_path / "b.gpkg", layer="crowns").set_index("tree_id").sort_index()
    # no crown is cut at a tile edge: every crown is the same polygon in both runs
    np.testing.assert_allclose(ca.crown_area, cb.crown_area, rtol=1e-12)
    assert ca.geometry.geom_equals(cb.geometry).all()
    tops = gpd.read_file(tmp_path / "a.gpkg", layer="tree_tops").set_index("tree_id")
    crowned = tops.index[tops.suppressed == 0]  # a suppressed tree has no crown polygon
    assert set(crowned) == set(ca.index)
    assert all(ca.geometry[i].contains(tops.geometry[i]) for i in crowned)
    assert tops.crs.to_epsg() == 29194 and tops.index.is_unique
    # and the trees are the stand's (the files' seams do not split or double them)
    from lidartrees_gis.report.evaluate import evaluate_trees

    e = evaluate_trees(tops.x, tops.y, tops.height, truth["x"], truth["y"], truth["height"])
    assert e["all"]["f_score"] >= 0.97


def test_tiles_look_for_a_planting_lattice_as_one_file_does(tmp_path, monkeypatch):
    """The 4 pts/m² stand in 6 tiles: the defaults read its planted block as the whole file
    does (one lattice, the same trees to 2, F >= 0.97); where no block is made (the fallback
    without stands), each tile finds the 3 x 2 m lattice under its tops and looks again at
    its empty positions, as the whole file does (F >= 0.97)."""
    from pyproj import CRS as PCRS

    import lidartrees_gis.als.chain as chain
    from lidartrees_gis.report.evaluate import evaluate_trees
    from lidartrees_gis.synthetic import CRS as SCRS
    from lidartrees_gis.synthetic import StandParams, make_stand
    from lidartrees_gis.als.trees import TreeParams

    pts, truth = make_stand(StandParams(seed=3, density=4.0))
    f = tmp_path / "stand.laz"
    write_points(f, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(SCRS),
                 classification=pts.classification)
    whole = trees_run(f, tmp_path / "b1.gpkg")
    tiled = trees_tiled(f, tmp_path / "b6.gpkg", tile_size=30, workers=1)
    assert whole["stands"] == tiled["stands"] == 1 and tiled["lattice"] == "found"
    assert len(set(whole["tree_ids"]) ^ set(tiled["tree_ids"])) <= 2
    tops = pyogrio.read_dataframe(tmp_path / "b6.gpkg", layer="tree_tops")
    e = evaluate_trees(tops.x, tops.y, tops.height, truth["x"], truth["y"], truth["height"])
    assert e["all"]["f_score"] >= 0.97
    monkeypatch.setattr(chain, "wants_blocks", lambda *a: False)  # the tiles' own look
    whole = trees_run(f, tmp_path / "one.gpkg")
    tiled = trees_tiled(f, tmp_path / "tiled.gpkg", tile_size=30, workers=1)
    off = trees_tiled(f, tmp_path / "off.gpkg", tile_size=30, workers=1,
                      params=TreeParams(planting="none"))
    assert tiled["tiles"] == tiled["planting_tiles"] == 6 and off["planting_tiles"] == 0
    assert tiled["planting_detected"] == "3.00x2.00" and off["gap_trees"] == 0
    assert tiled["gap_trees"] >= 10 and off["suppressed_trees"] == 0
    assert tiled["trees"] == (off["trees"] + tiled["gap_trees"] + tiled["suppressed_trees"]
                              + tiled["uncertain_trees"])
    ids = set(whole["tree_ids"])
    assert len(ids ^ set(tiled["tree_ids"])) <= 2
    tops = pyogrio.read_dataframe(tmp_path / "tiled.gpkg", layer="tree_tops")
    e = evaluate_trees(tops.x, tops.y, tops.height, truth["x"], truth["y"], truth["height"])
    assert e["all"]["f_score"] >= 0.97
    summary = pyogrio.read_dataframe(tmp_path / "tiled.gpkg", layer="summary")
    assert summary.gap_trees[0] == tiled["gap_trees"] and summary.planting_tiles[0] == 6


def test_plantation_mode_in_tiles_reports_the_stocking_of_one_file(tmp_path):
    """-spacing in 4 tiles: each tile fits the lattice with its buffer and counts the planting
    positions of its core, so the stand's positions, missing trees, stocking and gaps are those
    of the whole file."""
    from pyproj import CRS as PCRS

    from lidartrees_gis.synthetic import CRS as SCRS
    from lidartrees_gis.synthetic import StandParams, make_stand
    from lidartrees_gis.als.trees import TreeParams

    pts, truth = make_stand(StandParams(seed=3, density=4.0))
    f = tmp_path / "stand.laz"
    write_points(f, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(SCRS),
                 classification=pts.classification)
    p = TreeParams(spacing=(3.0, 2.0))
    whole = trees_run(f, tmp_path / "one.gpkg", params=p)
    out = tmp_path / "tiled.gpkg"
    assert main(["trees", str(f), str(out), "-spacing", "3x2", "-tile_size", "40", "-q"]) == 0
    s = pyogrio.read_dataframe(out, layer="summary").iloc[0]
    assert s.tiles == 4 and s.spacing == "3x2"
    # 600 positions planted; the last position of one row, at the data's edge, is empty and its
    # 7 returns hold no crown (2 of 7 at crown height): the row is taken to end before it
    assert s.planting_positions == whole["planting_positions"] == 599
    assert s.missing_trees == whole["missing_trees"]
    assert s.stocking_pct == pytest.approx(whole["stocking_pct"], abs=0.01)
    assert s.trees == whole["trees"] and s.gap_trees > 0
    assert abs(s.row_azimuth - whole["row_azimuth"]) < 0.5
    gaps = pyogrio.read_dataframe(out, layer="gaps")
    one = pyogrio.read_dataframe(tmp_path / "one.gpkg", layer="gaps")
    assert gaps.gap_id.is_unique and (gaps.status == "suppressed").sum() == s.suppressed_trees
    assert (gaps.status == "uncertain").sum() == s.uncertain_positions == \
        whole["uncertain_positions"]
    gaps, one = gaps[gaps.status == "missing"], one[one.status == "missing"]
    assert len(gaps) == len(one) == s.missing_trees
    d = np.hypot(gaps.x.to_numpy()[:, None] - one.x.to_numpy()[None, :],
                 gaps.y.to_numpy()[:, None] - one.y.to_numpy()[None, :]).min(axis=1)
    assert (d < 0.5).all()  # the same empty positions
    assert pyogrio.read_info(out, layer="gaps")["crs"] == "EPSG:29194"
    # sparse points: the stocking is under-reported, as for one file
    pts, _ = make_stand(StandParams(seed=3, density=2.0))
    sparse = tmp_path / "sparse.laz"
    write_points(sparse, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(SCRS),
                 classification=pts.classification)
    with pytest.warns(Warning, match="stocking and the gaps are unreliable"):
        trees_tiled(sparse, tmp_path / "sparse.gpkg", params=p, tile_size=30, workers=1)


def test_tiles_choose_the_cell_size_of_one_file_in_sparse_data(tmp_path):
    """-tr auto of a tiled run measures the density over the same 3 m cells as one file: over
    1 m cells a 2 pts/m² stand looked like 2.3 pts/m² (13 % of 1 m cells are empty) and got
    0.65 m cells instead of 0.7 m."""
    from pyproj import CRS as PCRS

    from lidartrees_gis.als.chain import area_surfaces
    from lidartrees_gis.synthetic import CRS as SCRS
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(seed=3, density=2.0))
    f = tmp_path / "sparse.laz"
    write_points(f, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(SCRS),
                 classification=pts.classification)
    built, plan, _ = area_surfaces(f)
    r = trees_tiled(f, tmp_path / "t.gpkg", tile_size=30, workers=1)
    assert r["res"] == built["spec"].res == plan.res == 0.7
    assert built["density"] == pytest.approx(1.94, abs=0.03)
    assert plan.density == pytest.approx(1.94, abs=0.06)


def test_dask_cluster_gives_the_same_trees(split_stand, tmp_path):
    pytest.importorskip("dask.distributed")
    d, _, _ = split_stand
    one = trees_tiled(d, tmp_path / "one.gpkg", tile_size=30, workers=1)
    two = trees_tiled(d, tmp_path / "two.gpkg", tile_size=30, workers=2)
    assert set(one["tree_ids"]) == set(two["tree_ids"]) and one["tiles"] == two["tiles"] > 1


def test_existing_cluster_with_threaded_workers_gives_the_same_trees(split_stand, tmp_path):
    """--scheduler: the tiles go to a cluster we did not start, here one worker with two
    threads (what `dask worker` starts on a 2-core machine), so the tiles share the worker's
    read cache and run at the same time."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import LocalCluster

    from lidartrees_gis.catalog.source import READ_CACHE

    d, _, _ = split_stand
    one = trees_tiled(d, tmp_path / "one.gpkg", tile_size=30, workers=1)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        READ_CACHE.clear()
        READ_CACHE.hits = READ_CACHE.misses = 0
        out = tmp_path / "sched.gpkg"
        assert main(["trees", str(d), str(out), "-tile_size", "30", "-buffer", "15", "--scheduler",
                     cluster.scheduler_address, "-q"]) == 0
        assert READ_CACHE.hits > 0  # the worker (this process) kept the files it read
    got = pyogrio.read_dataframe(out, layer="tree_tops", read_geometry=False)
    assert set(got["tree_id"]) == set(one["tree_ids"]) and len(got) == one["trees"]
    assert pyogrio.read_dataframe(out, layer="summary").tiles[0] == one["tiles"] > 1


def test_small_runs_stay_in_this_process_unless_workers_are_asked(split_stand, tmp_path,
                                                                    monkeypatch):
    from lidartrees_gis.catalog import runner as tiled

    def no_cluster(*a):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(tiled, "_client", no_cluster)
    monkeypatch.delenv("LIDARTREES_WORKERS", raising=False)
    d, _, _ = split_stand
    r = trees_tiled(d, tmp_path / "a.gpkg", tile_size=30)  # default workers, few points
    assert r["tiles"] > 1 and r["points"] < tiled.LOCAL_BELOW_POINTS
    with pytest.raises(AssertionError, match="cluster"):  # asked for: a cluster
        trees_tiled(d, tmp_path / "b.gpkg", tile_size=30, workers=2)
    monkeypatch.setattr(tiled, "LOCAL_BELOW_POINTS", 1000)  # many points: all cores
    with pytest.raises(AssertionError, match="cluster"):
        trees_tiled(d, tmp_path / "c.gpkg", tile_size=30)
    assert tiled.default_workers(None, "tcp://x:8786", 10) is None  # a scheduler: its workers


_START_CHECK = """
import sys, threading
import lidartrees_gis.catalog.runner as tiled
if __name__ == "__main__":
    if sys.argv[1] == "thread":  # another thread running: forking could deadlock the workers
        ev = threading.Event()
        threading.Thread(target=ev.wait, daemon=True).start()
    tiled.SENTINEL = 42  # set at run time: only a forked worker sees it
    method = tiled.worker_start_method()
    with tiled.TileRunner(2) as r:
        seen = list(r.map(lambda _: getattr(__import__("lidartrees_gis.catalog.runner").catalog.runner,
                                            "SENTINEL", None), [0, 1], ordered=True))
    print(method, seen)
    if sys.argv[1] == "thread":
        ev.set()
"""


@pytest.mark.parametrize("case, method, seen", [("plain", "fork", [42, 42]),
                                                 ("thread", "spawn", [None, None])])
def test_local_workers_are_forked_when_it_is_safe(case, method, seen, tmp_path):
    """The workers of a local cluster inherit this process's imported library (fork) instead
    of starting Python again, unless another thread runs here (or Qt is loaded)."""
    pytest.importorskip("dask.distributed")
    import subprocess
    import sys

    script = tmp_path / "start_check.py"
    script.write_text(_START_CHECK)
    p = subprocess.run([sys.executable, str(script), case], capture_output=True, text=True,
                       timeout=300, cwd=str(Path(__file__).resolve().parents[1]))
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.split()[0] == method
    assert p.stdout.strip().endswith(str(seen))


def test_the_cli_progress_bar_starts_no_thread():
    """A thread in the calling process would make the local workers spawn instead of fork."""
    import threading

    from lidartrees_gis.progress import TqdmProgress

    before = threading.active_count()
    bar = TqdmProgress("trees")
    bar.update(0.5, "tile 1/2")
    assert threading.active_count() == before
    bar.close()


def test_worker_start_method_keeps_a_configured_one_and_spawns_from_a_large_process(
        monkeypatch):
    import dask

    from lidartrees_gis.catalog import runner as tiled

    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        assert tiled.worker_start_method() == "forkserver"
    # a process holding much memory: forked workers would look as large to Dask's monitor
    monkeypatch.setattr(tiled, "FORK_MAX_RSS", 1)
    assert tiled.worker_start_method() == "spawn"


def test_laz_is_decompressed_on_one_thread_inside_a_dask_worker():
    """A worker's siblings already use the other cores: the parallel LAZ decompressor there
    only oversubscribes them (a single process keeps it)."""
    pytest.importorskip("dask.distributed")
    import os

    import dask
    import laspy

    from lidartrees_gis.io.points import laz_backend
    from lidartrees_gis.catalog.runner import TileRunner

    assert laz_backend() is None  # laspy's default, parallel
    with TileRunner(2) as runner:
        got = list(runner.map(lambda _: laz_backend(), [0, 1], ordered=True))
        # and glibc's malloc as in one process: the nanny's MALLOC_TRIM_THRESHOLD_ fixed the
        # mmap threshold (every array of a task a fresh mapping: 5x the page faults, tasks a
        # third slower); no profiler sampling the task every 10 ms
        env = list(runner.map(lambda _: (os.environ.get("MALLOC_TRIM_THRESHOLD_"),
                                         dask.config.get("distributed.worker.profile.enabled")),
                              [0, 1], ordered=True))
    assert got == [laspy.LazBackend.Lazrs] * 2
    assert env == [(None, False)] * 2


def test_chm_mosaic_is_seamless(split_stand, tmp_path):
    d, _, _ = split_stand
    assert main(["chm", str(d), str(tmp_path / "m.tif"), "-tile_size", "20", "-buffer", "10", "-workers", "1",
                 "-dtm_out", str(tmp_path / "d.tif"), "-dsm_out", str(tmp_path / "s.tif"),
                 "-q"]) == 0
    assert main(["chm", str(d), str(tmp_path / "one.tif"), "-tile_size", "none", "-workers", "1",
                 "-dsm_out", str(tmp_path / "one_s.tif"), "-q"]) == 0
    for tiled, whole in (("m.tif", "one.tif"), ("s.tif", "one_s.tif")):  # CHM, DSM
        with rasterio.open(tmp_path / tiled) as a, rasterio.open(tmp_path / whole) as b:
            assert a.crs.to_epsg() == 29194 and a.transform == b.transform and a.shape == b.shape
            x, y = a.read(1, masked=True), b.read(1, masked=True)
            assert (x.mask == y.mask).all() and x.count() > 1000
            np.testing.assert_allclose(x.compressed(), y.compressed(), atol=1e-4)
            assert a.profile["tiled"]
    assert (tmp_path / "d.tif").exists()


def test_cli_runs_a_folder_in_tiles(split_stand, tmp_path):
    d, _, _ = split_stand
    out = tmp_path / "t.gpkg"
    rj = tmp_path / "r.json"
    assert main(["trees", str(d), str(out), "-workers", "1", "-q", "--result-json", str(rj)]) == 0
    r = json.loads(rj.read_text())
    assert r["files"] == 3 and r["tiles"] >= 1 and r["trees"] > 560
    summ = pyogrio.read_dataframe(out, layer="summary")
    assert int(summ.trees[0]) == r["trees"] and summ.buffer[0] >= 20
    # the quick look and the TreeX CSV of a folder, as of one file (issue 22)
    assert main(["trees", str(d), str(tmp_path / "p.gpkg"), "-png", str(tmp_path / "q.png"),
                 "-csv", str(tmp_path / "t.csv"), "-tile_size", "30", "-buffer", "15", "-workers", "1", "-q",
                 "-lco", "SEPARATOR=COMMA", "-lco", "WRITE_BOM=NO"]) == 0
    from PIL import Image

    png = Image.open(tmp_path / "q.png")
    assert f"{r['trees']:,} trees" in png.text["Description"]
    rows = (tmp_path / "t.csv").read_text().splitlines()
    # the stand's planted block (no stands given) is each tree's stand
    assert rows[0].startswith("tree_id,stand_id,row_number,plant_number,x,y,height,") and \
        len(rows) == r["trees"] + 1
    assert {line.split(",")[1].strip('"') for line in rows[1:]} == {"B01"}
    tops = pyogrio.read_dataframe(tmp_path / "p.gpkg", layer="tree_tops")
    assert {int(line.split(",")[0].strip('"')) for line in rows[1:]} == set(tops.tree_id)


@pytest.mark.realdata
def test_bcts_tiled_equals_untiled(data, tmp_path):
    """Issue 10 acceptance: two lasR_bcts tiles as files vs one tile (count and ids), no crown
    cut; benchmarks/bench_chain.py runs all four."""
    f1, f2 = data("lasR_bcts/bcts_1.laz"), data("lasR_bcts/bcts_2.laz")
    lst = tmp_path / "two.txt"
    lst.write_text(f"{f1}\n{f2}\n")
    a = trees_tiled(lst, tmp_path / "a.gpkg", tile_size=100, workers=1)
    b = trees_tiled(lst, tmp_path / "b.gpkg", tile_size=float("inf"), workers=1)
    assert a["tiles"] >= 8 and a["trees"] == b["trees"] > 2000
    assert set(a["tree_ids"]) == set(b["tree_ids"])
    ca = pyogrio.read_dataframe(tmp_path / "a.gpkg", layer="crowns").set_index("tree_id").sort_index()
    cb = pyogrio.read_dataframe(tmp_path / "b.gpkg", layer="crowns").set_index("tree_id").sort_index()
    np.testing.assert_allclose(ca.crown_area, cb.crown_area, rtol=1e-12)


def test_empty_tiles_between_files_are_skipped(split_stand, tmp_path):
    d, files, _ = split_stand
    lst = tmp_path / "two.txt"
    lst.write_text(f"{files[0]}\n{files[2]}\n")  # a 21 m strip without points between them
    r = trees_tiled(lst, tmp_path / "t.gpkg", tile_size=20, workers=1,
                    chm_out=tmp_path / "c.tif")
    both = trees_tiled(d, tmp_path / "all.gpkg", tile_size=20, workers=1)
    assert 0 < r["trees"] < both["trees"] and r["tiles"] == both["tiles"]
    with rasterio.open(tmp_path / "c.tif") as ds:
        a = ds.read(1, masked=True)
        col = ds.width // 2
        assert a.mask[:, col].all()  # nodata in the gap, not a smeared canopy


def test_sparse_chm_mosaic_is_seamless(tmp_path):
    """Below ~4 first returns per m² the pit-free edge limit grows with the point spacing; it is
    measured once for the area, not per tile (a denser tile once got shorter edges)."""
    from lidartrees_gis.synthetic import StandParams, make_stand

    pts, _ = make_stand(StandParams(width=60, height=40, density=3.0, seed=5))
    rng = np.random.default_rng(5)
    keep = (pts.x < pts.x.min() + 30) | (rng.random(len(pts)) < 0.35)  # east half sparser
    f = tmp_path / "sparse.laz"
    write_points(f, pts.x[keep], pts.y[keep], pts.z[keep], crs=CRS.from_epsg(29194),
                 classification=pts.classification[keep])
    for name, ts in (("m.tif", "40"), ("one.tif", "none")):
        assert main(["chm", str(f), str(tmp_path / name), "-tile_size", ts, "-workers", "1",
                     "-q"]) == 0
    with rasterio.open(tmp_path / "m.tif") as a, rasterio.open(tmp_path / "one.tif") as b:
        x, y = a.read(1, masked=True), b.read(1, masked=True)
        assert (x.mask == y.mask).all()
        np.testing.assert_allclose(x.compressed(), y.compressed(), atol=1e-4)


def test_neighbouring_tiles_read_a_file_once(split_stand, tmp_path, monkeypatch):
    """Decompressed files are kept (bounded) so the tiles whose buffers reach into a file do not
    decompress it again; what a tile gets is a copy, a changed file is read again, and a file
    over half the budget is never kept."""
    import shutil

    from lidartrees_gis.catalog import source as cat_mod
    from lidartrees_gis.catalog.source import ReadCache, TileSource

    d, files, _ = split_stand
    f = tmp_path / "a.laz"
    shutil.copy(files[1], f)
    cache = ReadCache()
    monkeypatch.setattr(cat_mod, "READ_CACHE", cache)
    catalog = Catalog.open([f])
    x0, y0, x1, y1 = catalog.extent
    west = TileSource(catalog, (x0, y0, (x0 + x1) / 2, y1))
    east = TileSource(catalog, ((x0 + x1) / 2, y0, x1, y1))
    whole = TileSource(catalog, catalog.extent)
    a = west.read_all()
    assert (cache.misses, cache.hits, len(cache.items)) == (1, 0, 1)
    a.z[:] = -999.0  # a consumer writing into its points does not reach the cache
    b = east.read_all()
    c = whole.read_all()
    assert (cache.misses, cache.hits) == (1, 2)
    assert len(c) == catalog.count and (c.z > -999).all()
    assert len(a) + len(b) >= len(c) > max(len(a), len(b))
    # the same points as a fresh read
    fresh = ReadCache()
    monkeypatch.setattr(cat_mod, "READ_CACHE", fresh)
    c2 = TileSource(catalog, catalog.extent).read_all()
    assert np.array_equal(np.sort(c.z), np.sort(c2.z)) and fresh.misses == 1
    # a changed file is read again
    monkeypatch.setattr(cat_mod, "READ_CACHE", cache)
    shutil.copy(files[0], f)
    TileSource(catalog, catalog.extent).read_all()
    assert cache.misses == 2
    # too big for the budget: read every time, never kept
    small = ReadCache(budget=1000)
    monkeypatch.setattr(cat_mod, "READ_CACHE", small)
    for _ in range(2):
        TileSource(catalog, catalog.extent).read_all()
    assert small.misses == 2 and not small.items and small.nbytes == 0


def test_a_runs_processes_share_what_they_decompress(split_stand, tmp_path, monkeypatch):
    """A run's local processes share decompressed files through a temporary folder (two
    workers each decompressed the files along the line between their tiles): a process with
    nothing in its own cache takes another's file from there instead of decompressing it; the
    folder is bounded (oldest first), a failure is a miss, and the run removes it."""
    import os

    from lidartrees_gis.catalog import runner as run_mod
    from lidartrees_gis.catalog import source as cat_mod
    from lidartrees_gis.catalog.source import (SHARED_CACHE_ENV, ReadCache, SharedReadCache,
                                               TileSource)

    d, files, _ = split_stand
    catalog = Catalog.open(files[:2])
    opened = []
    real_open = type(catalog.read).open
    monkeypatch.setattr(type(catalog.read), "open",
                        lambda self, f, **kw: opened.append(Path(f).name) or real_open(self, f, **kw))
    monkeypatch.delenv(SHARED_CACHE_ENV, raising=False)
    folder = tmp_path / "shared"
    folder.mkdir()
    monkeypatch.setenv(SHARED_CACHE_ENV, str(folder))
    monkeypatch.setenv(cat_mod.SHARED_POINTS_ENV, "1")  # a run of several processes
    monkeypatch.setattr(cat_mod, "READ_CACHE", ReadCache())  # a first worker
    a = TileSource(catalog, catalog.extent).read_all()
    assert len(opened) == 2 and len(list(folder.glob("*.npz"))) == 2
    monkeypatch.setattr(cat_mod, "READ_CACHE", ReadCache())  # another: nothing of its own
    b = TileSource(catalog, catalog.extent).read_all()
    assert len(opened) == 2  # nothing decompressed again
    assert np.array_equal(a.z, b.z) and np.array_equal(a.classification, b.classification)
    # bounded: the oldest file goes first
    by_age = sorted(folder.glob("*.npz"), key=lambda p: p.stat().st_mtime_ns)
    shared = SharedReadCache(folder, budget=max(p.stat().st_size for p in by_age) + 1000)
    shared.put(("k",), [], {})
    assert sorted(p.name for p in folder.glob("*.npz")) == sorted(
        [by_age[1].name, Path(shared._path(("k",))).name])
    # the folder gone: misses, never errors
    gone = SharedReadCache(tmp_path / "nowhere")
    assert gone.get(("k",)) is None
    gone.put(("k",), [], {})
    # a run with more than one task makes its folder, names it for its workers and removes it
    monkeypatch.delenv(SHARED_CACHE_ENV)
    seen = []
    monkeypatch.delenv(cat_mod.SHARED_POINTS_ENV)
    with run_mod.TileRunner(1) as runner:
        list(runner.map(lambda k: seen.append((os.environ.get(SHARED_CACHE_ENV),
                                               os.environ.get(cat_mod.SHARED_POINTS_ENV))),
                        [1, 2]))
    assert seen[0][0] and seen[0] == seen[1] and not Path(seen[0][0]).exists()
    assert SHARED_CACHE_ENV not in os.environ and cat_mod.SHARED_POINTS_ENV not in os.environ
    # one process (one worker) leaves no decompressed file there: it has them in memory (at
    # 16 M points the folder took 470 MB of writes and saved no time)
    assert seen[0][1] == "0"
    monkeypatch.setenv(SHARED_CACHE_ENV, str(folder))
    monkeypatch.setenv(cat_mod.SHARED_POINTS_ENV, "0")
    for f in folder.glob("*.npz"):
        f.unlink()
    monkeypatch.setattr(cat_mod, "READ_CACHE", ReadCache())
    TileSource(catalog, catalog.extent).read_all()
    assert not list(folder.glob("*.npz"))
    monkeypatch.delenv(SHARED_CACHE_ENV)
    # a killed run's folder (its process gone) goes when the next run starts; a live one stays
    import subprocess
    import sys
    import tempfile

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    orphan = Path(tempfile.gettempdir()) / f"{run_mod.SHARED_PREFIX}{dead}-x"
    live = Path(tempfile.gettempdir()) / f"{run_mod.SHARED_PREFIX}{os.getpid()}-y"
    for p in (orphan, live):
        p.mkdir(exist_ok=True)
        (p / "a.pkl").write_bytes(b"x")
    with run_mod.TileRunner(1) as runner:
        list(runner.map(lambda k: k, [1, 2]))
    assert not orphan.exists() and live.exists()
    import shutil
    shutil.rmtree(live)


def test_workers_get_runs_of_equal_points(split_stand):
    """Each Dask worker takes a contiguous run of the tiles holding about the same number of
    points (the edge tiles hold fewer), estimated from the files' headers."""
    from lidartrees_gis.catalog.runner import worker_runs

    d, files, _ = split_stand
    catalog = Catalog.open(files)
    assert catalog.points_in(catalog.extent) == pytest.approx(catalog.count)
    x0, y0, x1, y1 = catalog.extent
    halves = [(x0, y0, (x0 + x1) / 2, y1), ((x0 + x1) / 2, y0, x1, y1)]
    assert sum(catalog.points_in(b) for b in halves) == pytest.approx(catalog.count)
    assert catalog.points_in((x1 + 10, y1 + 10, x1 + 20, y1 + 20)) == 0
    assert worker_runs([1, 1, 1, 1], 2) == [0, 0, 1, 1]
    assert worker_runs([9, 1, 1, 1, 1, 1, 1, 1, 1, 1], 2) == [0] + [1] * 9  # not 5 and 5
    assert worker_runs([5, 5, 1, 1, 1, 1, 1, 1, 1, 1], 3) == [0, 1, 1, 1, 2, 2, 2, 2, 2, 2]
    assert worker_runs([0, 0, 0], 2) == [0, 1, 1]  # no weights: by count


def test_tiled_layers_are_complete_and_indexed(split_stand, tmp_path):
    """Tiled runs append their trees batch by batch: the output has every tree in the layers'
    spatial index, the layers in order and no stray file; -append with -nln adds layers the same
    way."""
    import sqlite3

    d, _, _ = split_stand
    out = tmp_path / "t.gpkg"
    a = trees_tiled(d, out, tile_size=30, workers=1)
    b = trees_tiled(d, out, tile_size=30, workers=1, append=True, nln="b_")
    assert a["trees"] == b["trees"] > 500
    layers = [n for n, g in pyogrio.list_layers(out) if n != "layer_styles"]
    assert "layer_styles" in [n for n, g in pyogrio.list_layers(out)]  # QGIS styles inside
    # the stand's planted block (no stands given): its gaps and the block as a stand too
    assert sorted(layers) == sorted(["tree_tops", "crowns", "gaps", "stands", "summary",
                                     "b_tree_tops", "b_crowns", "b_gaps", "b_stands",
                                     "b_summary"])
    assert [n for n in layers if n.split("_")[-1] in ("tops", "crowns")] == [
        "tree_tops", "crowns", "b_tree_tops", "b_crowns"]
    con = sqlite3.connect(out)
    try:
        for t in ("tree_tops", "crowns", "b_tree_tops", "b_crowns"):
            n = con.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0]
            # a suppressed tree (no top, under its neighbours) has no crown polygon
            assert n == a["trees"] - (a["suppressed_trees"] + a["uncertain_trees"]
                                      if "crowns" in t else 0)
            assert con.execute(f'SELECT count(*) FROM "rtree_{t}_geom"').fetchone()[0] == n
            assert pyogrio.read_info(out, layer=t)["capabilities"]["fast_spatial_filter"]
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    finally:
        con.close()
    info = pyogrio.read_info(out, layer="crowns")
    assert list(info["fields"]) == ["tree_id", "x", "y", "height", "crown_area", "crown_diameter",
                                    "n_cells", "row_number", "plant_number", "suppressed",
                                    "stand_id", "method", "small_crown"]
    assert info["geometry_type"] == "Polygon" and "29194" in info["crs"]
    assert json.loads(info["layer_metadata"]["tiles"]) > 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.gpkg"]


def test_row_azimuths_of_tiles_average_as_an_axis():
    """Tiles reporting rows at 179.95 and 0.0 degrees (the same rows) gave a stand azimuth of
    90 (their median): azimuths of rows are axes, averaged on the doubled angle."""
    from lidartrees_gis.plantation.stocking import axial_mean

    a = axial_mean([179.95, 179.95, 0.0, 0.0], [150, 150, 150, 150])
    assert min(a, 180 - a) < 0.05
    assert axial_mean([10.0, 20.0], [1, 1]) == pytest.approx(15.0)
    assert axial_mean([10.0, 20.0], [3, 1]) == pytest.approx(12.5, abs=0.1)
