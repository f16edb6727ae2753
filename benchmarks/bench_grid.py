"""Gridding benchmark (issue 2): points/s of in-memory gridding, LAZ -> CHM on the lasR_bcts
tiles (time split between LAZ decompression and gridding), peak memory.

Usage: python benchmarks/bench_grid.py [--points 20000000] [--out benchmarks/results/grid.json]
"""
from __future__ import annotations

import argparse
import json
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

from lidartrees_gis import _accel  # noqa: E402
from lidartrees_gis.grid import GridAccumulator, GridSpec  # noqa: E402
from lidartrees_gis.als.rasters import chm_run  # noqa: E402
from lidartrees_gis.als.surfaces import SurfaceOptions  # noqa: E402


def best_of(fn, n=3):
    ts = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return min(ts)


def bench_memory_grid(npts: int) -> dict:
    rng = np.random.default_rng(0)
    side = 1000.0  # 1 km x 1 km at 0.5 m = 4 M cells
    x = rng.random(npts) * side
    y = rng.random(npts) * side
    z = rng.random(npts) * 30
    spec = GridSpec.from_bounds(0, 0, side, side, 0.5)
    out = {"points": npts, "cells": spec.width * spec.height, "numba": _accel.HAVE_NUMBA}
    for stat in ("max", "count", "mean"):
        acc = GridAccumulator(spec, (stat,))
        acc.add(x[:1000], y[:1000], z[:1000])  # JIT warm-up
        t = best_of(lambda: GridAccumulator(spec, (stat,)).add(x, y, z))
        out[f"{stat}_points_per_s"] = npts / t
        out[f"{stat}_seconds"] = t
    # the same points in acquisition-like order (scan lines: sorted by y, then x)
    order = np.lexsort((x, np.floor(y / 0.5)))
    xs, ys, zs = x[order], y[order], z[order]
    for stat in ("max", "count"):
        t = best_of(lambda: GridAccumulator(spec, (stat,)).add(xs, ys, zs))
        out[f"{stat}_ordered_points_per_s"] = npts / t
    del xs, ys, zs
    # kernels alone, for reference against the numbers
    row, col = spec.cell_index(x, y)
    idx = row * spec.width + col
    buf = np.full(spec.width * spec.height, np.nan)
    sub = slice(0, min(npts, 5_000_000))
    m = np.full(spec.width * spec.height, -np.inf)
    out["kernel_np_maximum_at_points_per_s"] = (sub.stop) / best_of(lambda: np.maximum.at(m, idx[sub], z[sub]), 1)
    out["kernel_np_bincount_points_per_s"] = npts / best_of(lambda: np.bincount(idx, minlength=buf.size))
    return out


def bench_laz_chm() -> list:
    import laspy

    rows = []
    for i in (1, 2, 3, 4):
        f = DATA / "lasR_bcts" / f"bcts_{i}.laz"
        if not f.exists():
            continue
        t = time.perf_counter()
        with laspy.open(f) as r:
            for pts in r.chunk_iterator(1_000_000):
                np.asarray(pts.x), np.asarray(pts.y), np.asarray(pts.z)
        t_read = time.perf_counter() - t
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            res = chm_run(f, Path(d) / "chm.tif", surface=SurfaceOptions(res=0.5))
            res["points"] = res["points_read"]
            t_chm = time.perf_counter() - t
        rows.append({"file": f.name, "points": res["points"], "decompress_s": t_read,
                     "chm_total_s": t_chm, "decompress_share": t_read / t_chm,
                     "points_per_s": res["points"] / t_chm})
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=20_000_000)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "grid.json"))
    a = ap.parse_args()
    res = {"machine": {"python": platform.python_version(), "numpy": np.__version__,
                       "cpu": platform.processor() or platform.machine()},
           "in_memory": bench_memory_grid(a.points), "laz_chm": bench_laz_chm()}
    res["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2))
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
