"""Issue 42: checkpoints that cannot run code, and a resume fingerprint that reads the inputs.

`-resume` loaded each kept tile with pickle.load from `.<output>.tiles/` (and the processes of a
run read each other's decompressed files as pickles): anyone who could write to the output's
folder could plant a file that ran code at the next `-resume`. And an input replaced by a file
of the same size and time stamp gave the old result on `-resume`, without a word."""
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyogrio
import pytest
from pyproj import CRS

from lidartrees_gis.io.lasout import write_points
from lidartrees_gis.synthetic import StandParams, make_stand

CLI = [sys.executable, "-m", "lidartrees_gis.cli"]
ENV = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
TILED = ["-tile_size", "40", "-buffer", "10", "-workers", "1"]


class Planted:
    """A pickle that creates ``marker`` when it is loaded."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def plant(path: Path, marker: Path) -> None:
    path.write_bytes(pickle.dumps(Planted(marker)))


def _stand(path: Path, seed=5, mirror=False):
    """A 60 m stand; ``mirror``: the points between 1 and 19 m from its west edge mirrored
    east-west (the same header, the same size, other points in the first tile)."""
    p = StandParams(width=60, height=60, density=6.0, seed=seed)
    pts, _ = make_stand(p)
    x = pts.x.copy()
    if mirror:
        west = (x > p.origin_x + 1) & (x < p.origin_x + 19)
        x[west] = 2 * (p.origin_x + 10) - x[west]
    write_points(path, x, pts.y, pts.z, crs=CRS.from_epsg(29194))
    return path


def _layers(path: Path) -> dict:
    out = {}
    for layer in ("tree_tops", "crowns"):
        df = pyogrio.read_dataframe(path, layer=layer).sort_values("tree_id")
        df = df.reset_index(drop=True)
        out[layer] = (df.drop(columns="geometry"), df.geometry.to_wkb().tolist())
    return out


def _same(a: Path, b: Path) -> bool:
    la, lb = _layers(a), _layers(b)
    return all(la[k][0].equals(lb[k][0]) and la[k][1] == lb[k][1] for k in la)


def _cli(*args):
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, env=ENV,
                          timeout=600)


def _interrupted(cmd, input, output: Path, after: int, *options) -> Path:
    """A ``trees`` or ``grid`` run on ``input`` killed after ``after`` tiles were kept: its
    checkpoint folder."""
    target = "lidartrees_gis.als.sinks.GpkgTreeLayers.add" if cmd == "trees" else \
        "lidartrees_gis.catalog.mosaic.MosaicWriter.write"
    module, cls, name = target.rsplit(".", 2)
    code = ("import importlib, sys\n"
            f"cls = getattr(importlib.import_module('{module}'), '{cls}')\n"
            f"real, n = cls.{name}, [0]\n"
            "def patched(self, *a, **k):\n"
            "    n[0] += 1\n"
            f"    if n[0] > {after}: raise KeyboardInterrupt\n"
            "    return real(self, *a, **k)\n"
            f"cls.{name} = patched\n"
            "from lidartrees_gis.cli import main\n"
            "sys.exit(main(sys.argv[1:]))\n")
    r = subprocess.run([sys.executable, "-c", code, cmd, str(input), str(output), *options,
                        "-q"], capture_output=True, text=True, env=ENV, timeout=600)
    assert r.returncode != 0 and not output.exists(), r.stderr
    folder = output.parent / f".{output.name}.tiles"
    assert len(list(folder.glob("tile_*"))) == after + 1  # the tile that was being written too
    return folder


@pytest.fixture(scope="module")
def stand(tmp_path_factory):
    d = tmp_path_factory.mktemp("ck")
    f = _stand(d / "stand.las")
    ref = d / "ref.gpkg"
    r = _cli("trees", f, ref, *TILED, "-q")
    assert r.returncode == 0, r.stderr
    return f, ref


def test_a_planted_pickle_in_the_checkpoint_is_never_run_and_resume_gives_the_same(stand,
                                                                                   tmp_path):
    f, ref = stand
    out = tmp_path / "out.gpkg"
    folder = _interrupted("trees", f, out, 2, *TILED)
    kept = sorted(folder.glob("tile_*"))
    markers = [tmp_path / f"ran_{k}" for k in range(4)]
    plant(kept[0], markers[0])  # a kept tile replaced by a pickle (whatever its name says)
    plant(folder / "tile_1.pkl", markers[1])  # the name the old checkpoints had
    plant(folder / "tile_3.npz", markers[2])
    np.savez(folder / "tile_2.npz", x=np.array([Planted(markers[3])], dtype=object))
    r = _cli("trees", f, out, *TILED, "-resume")
    assert r.returncode == 0, r.stderr
    assert not [m for m in markers if m.exists()]
    warns = [s for s in r.stderr.splitlines() if "ignored" in s]
    assert len(warns) == 1 and "4 file(s)" in warns[0] and "run again" in warns[0]
    assert "-resume: 1 of 4 tiles were taken from the killed run" in r.stderr  # tile_1
    assert _same(out, ref)
    assert not folder.exists()


def test_a_planted_pickle_in_the_shared_read_cache_is_never_run(tmp_path):
    from lidartrees_gis.catalog.source import SharedReadCache, TileSource
    from lidartrees_gis.catalog.catalog import Catalog
    from lidartrees_gis.io.options import ReadOptions
    from lidartrees_gis.catalog import source

    f = _stand(tmp_path / "s.las", seed=2)
    cache_dir = tmp_path / "shared"
    cache_dir.mkdir()
    cache = SharedReadCache(cache_dir)
    cat = Catalog.open(f, ReadOptions())
    key = source.READ_CACHE.key(f, cat.read)
    marker = tmp_path / "ran"
    plant(Path(cache._path(key)), marker)
    assert cache.get(key) is None and not marker.exists()
    plant(Path(cache._path(("tile surfaces", 1), keep=True)), marker)
    assert cache.take(("tile surfaces", 1)) is None and not marker.exists()
    # a tile reading through the folder with the planted file: read from the file, not it
    os.environ[source.SHARED_CACHE_ENV] = str(cache_dir)
    os.environ[source.SHARED_POINTS_ENV] = "1"  # a run of several processes
    try:
        source.READ_CACHE.clear()
        plant(Path(cache._path(key)), marker)
        pts = TileSource(cat, cat.extent).read_all()
        assert not marker.exists() and len(pts) == cat.count
        # the file is then shared as data, which the next reader takes
        source.READ_CACHE.clear()
        chunks, dropped = cache.get(key)
        assert sum(len(c) for c in chunks) == cat.count and np.array_equal(
            np.concatenate([c.z for c in chunks]), pts.z)
    finally:
        os.environ.pop(source.SHARED_CACHE_ENV)
        os.environ.pop(source.SHARED_POINTS_ENV)
        source.READ_CACHE.clear()


def test_resume_after_an_input_is_replaced_by_one_of_the_same_size_and_time(tmp_path):
    """``grid -tr 1``: the plan (cell size, tiles) does not follow the points, so only the
    inputs' content tells the two files apart."""
    f = _stand(tmp_path / "stand.las")
    st = f.stat()
    out = tmp_path / "out.tif"
    grid = ["-tr", "1", "-tile_size", "30", "-workers", "1"]
    _interrupted("grid", f, out, 2, *grid)
    before = tmp_path / "before.tif"
    assert _cli("grid", f, before, *grid, "-q").returncode == 0
    other = _stand(tmp_path / "other.las", mirror=True)
    assert other.stat().st_size == st.st_size and other.read_bytes() != f.read_bytes()
    assert other.read_bytes()[:227] == f.read_bytes()[:227]  # the same LAS header
    os.replace(other, f)
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert f.stat().st_mtime_ns == st.st_mtime_ns
    r = _cli("grid", f, out, *grid, "-resume")
    assert r.returncode == 0, r.stderr
    assert "-resume: the input files changed" in r.stderr and "taken from" not in r.stderr
    fresh = tmp_path / "fresh.tif"
    assert _cli("grid", f, fresh, *grid, "-q").returncode == 0
    import rasterio

    with rasterio.open(out) as a, rasterio.open(fresh) as b, rasterio.open(before) as c:
        x, y, old = a.read(1), b.read(1), c.read(1)
    assert not np.array_equal(old, y, equal_nan=True)  # the two files' grids differ
    assert np.array_equal(x, y, equal_nan=True)


def test_a_large_input_is_told_apart_by_its_ends_and_samples(tmp_path, monkeypatch):
    from lidartrees_gis.catalog import checkpoint

    monkeypatch.setattr(checkpoint, "WHOLE_BYTES", 1000)  # every file here is "large"
    rng = np.random.default_rng(1)
    data = rng.integers(0, 256, 1_000_000, dtype=np.uint8).tobytes()
    f = tmp_path / "a.laz"
    f.write_bytes(data)
    d0 = checkpoint.file_digest(f)
    assert checkpoint.file_digest(f) == d0
    for at in (10, len(data) - 10):  # the header, the chunk table
        f.write_bytes(data[:at] + bytes([data[at] ^ 1]) + data[at + 1:])
        assert checkpoint.file_digest(f) != d0


def test_stored_values_come_back_exactly_and_foreign_ones_are_refused(tmp_path):
    from lidartrees_gis.grid import GridSpec
    from lidartrees_gis.io.chunk import PointChunk
    from lidartrees_gis.io.store import StoreError, load, save

    value = {"n": 3, "h": float("nan"), "s": "talhão", "none": None, "flag": True,
             "i64": np.int64(7), "f32": np.float32(1.5), 2: "int key", "t": (1, 2.0),
             "wkb": np.array([b"\x01\x02", None, b""], dtype=object),
             "names": np.array(["a", "bé"], dtype=object), "x": np.arange(5.0),
             "spec": GridSpec(1.0, 2.0, 0.5, 3, 4, CRS.from_epsg(29194)),
             "chunk": PointChunk(np.ones(2), np.zeros(2), np.ones(2), extra={"k": np.ones(2)})}
    save(tmp_path / "v.npz", value, {"tile": 1})
    back, meta = load(tmp_path / "v.npz")
    assert meta == {"tile": 1} and list(back) == list(value)
    assert back["n"] == 3 and np.isnan(back["h"]) and back["s"] == "talhão" and back[2]
    assert type(back["i64"]) is np.int64 and type(back["f32"]) is np.float32
    assert back["t"] == (1, 2.0) and back["wkb"].tolist() == [b"\x01\x02", None, b""]
    assert back["names"].dtype == object and back["names"].tolist() == ["a", "bé"]
    assert back["spec"].crs == CRS.from_epsg(29194) and back["spec"].shape == (4, 3)
    assert np.array_equal(back["chunk"].extra["k"], np.ones(2))
    with pytest.raises(TypeError):
        save(tmp_path / "w.npz", {"f": open})  # anything else is refused when written
    # an array whose dtype is not the one described: refused
    with np.load(tmp_path / "v.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    key = next(k for k in arrays if k != "__meta__" and arrays[k].dtype == np.float64)
    arrays[key] = arrays[key].astype(np.float32)
    np.savez(tmp_path / "t.npz", **arrays)
    with pytest.raises(StoreError):
        load(tmp_path / "t.npz")
    plant(tmp_path / "p.npz", tmp_path / "ran")
    with pytest.raises(StoreError):
        load(tmp_path / "p.npz")
    assert not (tmp_path / "ran").exists()
