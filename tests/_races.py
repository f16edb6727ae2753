"""Two ``lidartrees trees`` processes started together on one output (issue 42): shared by
tests/test_claims.py and benchmarks/bench_claims.py (the 20-trial run)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

CLI = [sys.executable, "-m", "lidartrees_gis.cli"]
#: the two stands' west edges: a tree's x tells which run wrote it
ORIGINS = (412300.0, 412400.0)


def make_inputs(folder: Path) -> list:
    """Two small synthetic stands 100 m apart (about 3,600 points each), as LAS files."""
    from pyproj import CRS

    from lidartrees_gis.io.lasout import write_points
    from lidartrees_gis.synthetic import StandParams, make_stand

    files = []
    for k, ox in enumerate(ORIGINS):
        pts, _ = make_stand(StandParams(width=30, height=30, density=4.0, origin_x=ox, seed=k))
        f = folder / f"stand_{k}.las"
        write_points(f, pts.x, pts.y, pts.z, crs=CRS.from_epsg(29194))
        files.append(f)
    return files


def _env() -> dict:
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _trees(stdout: str) -> int | None:
    for line in stdout.splitlines():
        if line.startswith("trees:"):
            return int(line.split(":")[1])
    return None


def race(inputs, output: Path, *extra) -> list:
    """Start ``trees INPUT_k OUTPUT *extra`` for both inputs at once; ``[(returncode, trees
    reported, stderr lines)]`` per process."""
    procs = [subprocess.Popen([*CLI, "trees", str(f), str(output), *extra],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=_env()) for f in inputs]
    out = []
    for p in procs:
        so, se = p.communicate(timeout=600)
        out.append((p.returncode, _trees(so), [s for s in se.splitlines() if s.strip()]))
    return out


def layer_x(output: Path):
    """The tree tops' x in ``output`` (empty when it is missing)."""
    import pyogrio

    if not output.exists():
        return np.empty(0)
    return pyogrio.read_dataframe(output, layer="tree_tops", columns=[])["geometry"].x.to_numpy()


def check_new_output(results, output: Path) -> str:
    """A race on a new output without -overwrite: one run wins, the other refuses in one line;
    the file holds the winner's trees. Returns a fault, or "" when all holds."""
    x = layer_x(output)
    won = [k for k, r in enumerate(results) if r[0] == 0]
    for k, (rc, _, err) in enumerate(results):
        if rc != 0 and len(err) != 1:
            return f"run {k} failed with {len(err)} lines on stderr: {err[-3:]}"
    if len(won) != 1:
        return f"{len(won)} runs exited 0"
    k = won[0]
    mine = (x >= ORIGINS[k]) & (x < ORIGINS[k] + 50)
    if x.size != results[k][1] or not mine.all():
        return f"run {k} exited 0 but the file holds {mine.sum()} of its {results[k][1]} trees"
    return ""


def check_appends(results, output: Path) -> str:
    """A race of two -append runs: each exit 0 has its trees in the layer (the layer's count is
    the sum of theirs), each failure is one line."""
    x = layer_x(output)
    expected = 0
    for k, (rc, n, err) in enumerate(results):
        if rc != 0:
            if len(err) != 1:
                return f"run {k} failed with {len(err)} lines on stderr: {err[-3:]}"
            continue
        mine = int(((x >= ORIGINS[k]) & (x < ORIGINS[k] + 50)).sum())
        if mine != n:
            return f"run {k} exited 0 with {n} trees, the layer holds {mine} of them"
        expected += n
    if x.size != expected:
        return f"the layer holds {x.size} trees, the runs that exited 0 wrote {expected}"
    return ""
