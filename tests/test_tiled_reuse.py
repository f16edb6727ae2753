"""Plantation mode over tiles computes each tile's surfaces once: its first pass (the tops the
lattices are fitted on) leaves them in the run's shared folder for the second (the trees)."""
import numpy as np
import pyogrio
import pytest
from pyproj import CRS as PCRS

from lidartrees_gis.als.chain import trees_run
from lidartrees_gis.als.trees import TreeParams
from lidartrees_gis.catalog.catalog import TilingOptions
from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.synthetic import CRS, StandParams, make_stand


def test_kept_values_go_after_decompressed_files_and_are_taken_once(tmp_path):
    import os
    import time

    from lidartrees_gis.catalog.source import SharedReadCache

    big = np.zeros(20_000)  # 160 kB each
    c = SharedReadCache(tmp_path, budget=10 ** 9)
    c.put(("file", 1), [big], {})
    for k in (1, 2):
        time.sleep(0.01)
        c.put_value(("tile", k), {"chm": big}, keep=True)
    time.sleep(0.01)
    c.put(("file", 2), [big], {})
    sizes = {p.name: p.stat().st_size for p in tmp_path.glob("*.npz")}
    assert len(sizes) == 4 and sum(n.startswith("keep-") for n in sizes) == 2
    # over budget by one file: the oldest decompressed file goes, not the older kept value
    c.budget = sum(sizes.values()) - 1
    c._trim()
    assert c.get(("file", 1)) is None and c.get(("file", 2)) is not None
    assert c.get(("tile", 1), keep=True) is not None
    # then the other decompressed file, then the newest kept value: the first pass's first
    # tiles stay for a second pass in the same order
    c.budget = max(sizes.values()) + 10
    c._trim()
    assert c.get(("file", 2)) is None and c.get(("tile", 2), keep=True) is None
    got = c.take(("tile", 1))
    assert np.array_equal(got["chm"], big) and c.take(("tile", 1)) is None
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".npz")]


@pytest.fixture(scope="module")
def plantation(tmp_path_factory):
    d = tmp_path_factory.mktemp("reuse")
    pts, _ = make_stand(StandParams(seed=3, density=8.0))
    f = d / "stand.laz"
    write_points(f, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(CRS),
                 classification=pts.classification)
    return f


# every plantation tile's result is kept for -resume (a value the store cannot hold loses it)
@pytest.mark.filterwarnings("error:.*cannot keep tile")
def test_plantation_tiles_compute_their_surfaces_once(plantation, tmp_path, monkeypatch):
    import lidartrees_gis.als.tile as tile_mod
    from lidartrees_gis.catalog import source

    calls = []
    real = tile_mod.box_surfaces
    monkeypatch.setattr(tile_mod, "box_surfaces",
                        lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    p = TreeParams(spacing=(3.0, 2.0))
    tiling = TilingOptions(40, None, 1)
    kept = trees_run(plantation, tmp_path / "kept.gpkg", params=p, tiling=tiling)
    n_kept = len(calls)
    monkeypatch.setattr(source, "SHARED_CACHE_BYTES", 0)  # no shared folder: computed twice
    calls.clear()
    again = trees_run(plantation, tmp_path / "again.gpkg", params=p, tiling=tiling)
    assert kept["tiles"] == again["tiles"] >= 4
    assert n_kept == kept["tiles"] and len(calls) == 2 * again["tiles"]
    for k in ("trees", "planting_positions", "missing_trees", "uncertain_positions",
              "suppressed_trees", "stocking_pct"):
        assert kept[k] == again[k], k
    for layer in ("tree_tops", "crowns", "gaps"):
        a = pyogrio.read_dataframe(tmp_path / "kept.gpkg", layer=layer)
        b = pyogrio.read_dataframe(tmp_path / "again.gpkg", layer=layer)
        assert len(a) == len(b) > 0
        assert a.drop(columns="geometry").equals(b.drop(columns="geometry"))
        assert (a.geometry.to_wkb() == b.geometry.to_wkb()).all()
