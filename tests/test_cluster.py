"""Issue 26: tiled runs that survive lost workers, a tile that always fails, and -resume after
the calling process is killed. Real separate processes: `dask scheduler`, `dask worker` and
`lidartrees` itself, as a user runs them on a cluster."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyogrio
import pytest

from _paths import DATA

BCTS = DATA / "lasR_bcts" / "bcts_1.laz"
DASK = Path(sys.executable).parent / "dask"
CLI = [sys.executable, "-m", "lidartrees_gis.cli"]

pytestmark = pytest.mark.skipif(not BCTS.exists(), reason="shared data missing")


class Cluster:
    """A `dask scheduler` and `dask worker` processes started here (no nanny unless asked)."""

    def __init__(self, folder: Path):
        self.folder, self.workers = folder, []
        self.file = folder / "scheduler.json"
        self.scheduler = subprocess.Popen(
            [str(DASK), "scheduler", "--scheduler-file", str(self.file), "--port", "0",
             "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for _ in range(300):
            if self.file.exists() and self.file.stat().st_size:
                break
            time.sleep(0.1)
        self.address = json.loads(self.file.read_text())["address"]

    def start_workers(self, n=2, *extra, nanny=False):
        for _ in range(n):
            self.workers.append(subprocess.Popen(
                [str(DASK), "worker", "--scheduler-file", str(self.file), "--nthreads", "1",
                 "--no-dashboard", *(() if nanny else ("--no-nanny",)), *extra],
                cwd=self.folder, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                start_new_session=True))
        from dask.distributed import Client

        with Client(self.address, timeout=60) as c:
            c.wait_for_workers(len([w for w in self.workers if w.poll() is None]), timeout=120)

    def kill_workers(self):
        for w in self.workers:
            if w.poll() is None:
                os.killpg(w.pid, signal.SIGKILL)
                w.wait()
        self.workers = []

    def close(self):
        self.kill_workers()
        self.scheduler.kill()
        self.scheduler.wait()


@pytest.fixture
def cluster(tmp_path):
    if not DASK.exists():
        pytest.skip("no dask command beside this Python")
    c = Cluster(tmp_path)
    yield c
    c.close()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """trees on bcts_1 (531,662 points) in 40 m tiles, in this process: the undisturbed run."""
    out = tmp_path_factory.mktemp("ref") / "ref.gpkg"
    r = subprocess.run([*CLI, "trees", str(BCTS), str(out), "-tile_size", "40", "-workers", "1",
                        "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


def layers(path):
    """The tree tops and crowns of a GeoPackage, by tree id, geometries as WKB."""
    got = {}
    for layer in ("tree_tops", "crowns"):
        df = pyogrio.read_dataframe(path, layer=layer).sort_values("tree_id").reset_index(drop=True)
        got[layer] = (df.drop(columns="geometry"), df.geometry.to_wkb())
    return got


def same_trees(a, b):
    la, lb = layers(a), layers(b)
    for layer in la:
        assert la[layer][0].equals(lb[layer][0]), layer
        assert (la[layer][1] == lb[layer][1]).all(), layer
    return len(la["tree_tops"][0])


def wait_for_tiles(folder: Path, n: int, proc, timeout=180):
    """Wait until ``n`` tiles are kept in ``folder`` (the run's checkpoint) or the run ends."""
    t0 = time.time()
    while time.time() - t0 < timeout and proc.poll() is None:
        if folder.exists() and len(list(folder.glob("tile_*.npz"))) >= n:
            return True
        time.sleep(0.05)
    return False


def test_all_workers_killed_and_new_ones_started_give_the_same_trees(cluster, reference,
                                                                     tmp_path):
    """Killing every worker mid-run ended in a traceback (the scattered catalog was lost with
    them: "FutureCancelledError ... already forgotten"). Now the catalog is a task's result,
    computed again; the lost tiles run again on the new workers; the trees are those of an
    undisturbed run, and one line says what happened. The input is given as a relative path
    from a folder the workers do not run in."""
    cluster.start_workers(2)
    out = tmp_path / "out.gpkg"
    run = subprocess.Popen([*CLI, "trees", os.path.relpath(BCTS, tmp_path.parent), str(out),
                            "-tile_size", "40", "--scheduler", cluster.address],
                           cwd=tmp_path.parent, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)
    assert wait_for_tiles(tmp_path / ".out.gpkg.tiles", 3, run), run.communicate()
    cluster.kill_workers()
    time.sleep(1.0)
    cluster.start_workers(2)
    stdout, stderr = run.communicate(timeout=300)
    assert run.returncode == 0, stderr
    assert "Traceback" not in stderr
    assert "2 worker(s) lost and 2 joined" in stderr
    n = same_trees(out, reference)
    assert n > 1000 and f"trees: {n}" in stdout
    assert not (tmp_path / ".out.gpkg.tiles").exists()  # kept tiles go once the output is written


def test_a_worker_killed_by_its_memory_limit_stops_the_run_naming_the_task(cluster, tmp_path):
    """A worker whose nanny kills it at its memory limit (here below what any task needs) on
    every attempt: the run stops with one line naming the task and why, and leaves no output."""
    cluster.start_workers(1, "--memory-limit", "150MB", nanny=True)
    out = tmp_path / "out.gpkg"
    r = subprocess.run([*CLI, "trees", str(BCTS), str(out), "-tile_size", "40", "--scheduler",
                        cluster.address], capture_output=True, text=True, timeout=600)
    assert r.returncode == 1
    err = [line for line in r.stderr.splitlines() if "error:" in line]
    assert len(err) == 1 and "Traceback" not in r.stderr
    assert "failed: the workers running it died each time (killed, out of memory" in err[0]
    assert err[0].split("error: ")[1].startswith(("window (x ", "tile "))
    assert not list(tmp_path.glob("*.gpkg")) and not list(tmp_path.glob(".out*"))


@pytest.fixture(scope="module")
def bad_folder(tmp_path_factory):
    """bcts_1 and a copy of bcts_2 whose compressed points are overwritten in the middle (the
    header and chunk table are sound: the file opens, its points cannot be read)."""
    d = tmp_path_factory.mktemp("bad")
    (d / "bcts_1.laz").symlink_to(BCTS)
    data = bytearray((DATA / "lasR_bcts" / "bcts_2.laz").read_bytes())
    rng = np.random.default_rng(3)
    mid = len(data) // 2
    data[mid:mid + 200_000] = rng.integers(0, 256, 200_000, dtype=np.uint8).tobytes()
    (d / "bcts_2.laz").write_bytes(bytes(data))
    return d


def test_a_tile_that_always_fails_is_named_and_no_output_is_left(cluster, bad_folder, tmp_path):
    cluster.start_workers(2)
    out = tmp_path / "out.gpkg"
    r = subprocess.run([*CLI, "trees", str(bad_folder), str(out), "-tile_size", "60",
                        "--scheduler", cluster.address], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    err = [line for line in r.stderr.splitlines() if "error:" in line]
    assert len(err) == 1, r.stderr
    assert "bcts_2.laz: cannot read LAZ points" in err[0] and " failed: " in err[0]
    assert not out.exists() and not list(tmp_path.glob(".out.*.gpkg"))


def test_on_error_skip_writes_the_other_tiles_and_fails_naming_the_missing(cluster, bad_folder,
                                                                           tmp_path):
    """-on_error skip: the good file's tiles are written, the run exits 1 naming the failed
    tiles and their error in one line; the same command with -resume -overwrite (the file
    mended) runs only the failed tiles and gives the trees of a run on the sound files."""
    cluster.start_workers(2)
    out = tmp_path / "out.gpkg"
    cmd = [*CLI, "trees", str(bad_folder), str(out), "-tile_size", "60", "--scheduler",
           cluster.address, "-on_error", "skip"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    err = [line for line in r.stderr.splitlines() if "error:" in line]
    assert len(err) == 1 and "tiles failed and are missing from the outputs" in err[0]
    assert "bcts_2.laz: cannot read LAZ points" in err[0]
    failed, total = (int(v) for v in err[0].split("error: ")[1].split(" tiles")[0].split(" of "))
    assert 0 < failed < total
    tops = pyogrio.read_dataframe(out, layer="tree_tops", read_geometry=False)
    assert len(tops) > 500 and f"trees: {len(tops)}" in r.stdout
    kept = tmp_path / ".out.gpkg.tiles"
    assert len(list(kept.glob("tile_*.npz"))) == total - failed


def test_resume_after_the_calling_process_is_killed_gives_the_same_geopackage(reference,
                                                                              tmp_path):
    """SIGKILL of `lidartrees trees` half way: the tiles it finished are kept beside the output;
    the same command with -resume runs only the others, and the GeoPackage is that of one run.
    Without -resume the kept tiles are not used; with other options -resume is refused."""
    out = tmp_path / "out.gpkg"
    cmd = [*CLI, "trees", str(BCTS), str(out), "-tile_size", "40", "-workers", "1", "-q"]
    total = int(pyogrio.read_dataframe(reference, layer="summary").tiles[0])
    run = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    kept = tmp_path / ".out.gpkg.tiles"
    assert wait_for_tiles(kept, total // 2, run)
    run.send_signal(signal.SIGKILL)
    run.wait()
    done = len(list(kept.glob("tile_*.npz")))
    assert total // 2 <= done < total and not out.exists()
    other = subprocess.run([*cmd, "-min_height", "3", "-resume"], capture_output=True, text=True)
    assert other.returncode == 1 and "are of another run" in other.stderr
    r = subprocess.run([*cmd, "-resume"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert f"-resume: {done} of {total} tiles were taken from the killed run" in r.stderr
    same_trees(out, reference)
    a = pyogrio.read_dataframe(out, layer="summary").drop(columns="geometry", errors="ignore")
    b = pyogrio.read_dataframe(reference, layer="summary").drop(columns="geometry",
                                                                errors="ignore")
    assert a.trees[0] == b.trees[0] and a.mean_height[0] == pytest.approx(b.mean_height[0])
    assert not kept.exists() and not list(tmp_path.glob(".out.*"))  # nothing left behind


def test_workers_that_cannot_read_an_input_are_named(cluster, tmp_path):
    """An input a worker cannot open (here deleted after the catalog was read; on a cluster, a
    path not shared with the worker's machine): an error naming the worker and the file."""
    from dask.distributed import Client

    from lidartrees_gis.catalog.runner import TileRunner
    from lidartrees_gis.errors import ReadError

    cluster.start_workers(1)
    gone = tmp_path / "gone.laz"
    with TileRunner(scheduler=cluster.address) as runner:
        runner.check_readable([BCTS])  # readable: no error
        with pytest.raises(ReadError, match=r"worker tcp://\S+ cannot read .*gone.laz"):
            runner.check_readable([BCTS, gone])
    with Client(cluster.address) as c:
        assert len(c.scheduler_info()["workers"]) == 1
