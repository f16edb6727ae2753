"""Tree-detection benchmark (issue 3): every method on a 250 x 250 grid (seed 000's size) and on
a 5000 x 5000 grid (1 km² at 0.2 m): time and peak memory; NEON TEAK reference boxes holding
exactly one detected top.

Usage: python benchmarks/bench_trees.py [--big 5000] [--out benchmarks/results/trees.json]
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

from lidartrees_gis.grid import GridSpec  # noqa: E402
from lidartrees_gis.als.trees import METHODS, TreeParams, detect_trees  # noqa: E402


def synthetic_chm(n: int, res: float = 0.2, seed: int = 0) -> np.ndarray:
    """Plantation-like CHM: paraboloid crowns on a 3 x 2 m lattice."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n] * res
    ty = (np.floor(yy / 2.0) + 0.5) * 2.0
    tx = (np.floor(xx / 3.0) + 0.5) * 3.0
    h = 23 + rng.normal(0, 1.5, (int(n * res / 2.0) + 2, int(n * res / 3.0) + 2))
    top = h[(ty / 2.0).astype(int), (tx / 3.0).astype(int)]
    d2 = (yy - ty) ** 2 + (xx - tx) ** 2
    return (top - 9.0 * d2 / 1.5 ** 2 + rng.normal(0, 0.05, d2.shape)).clip(0)


def time_methods(n: int, repeat: int) -> dict:
    chm = synthetic_chm(n)
    spec = GridSpec(0.0, n * 0.2, 0.2, n, n)
    out = {}
    for m in METHODS:
        p = TreeParams(method=m, smooth="gauss3")
        detect_trees(chm[:50, :50], GridSpec(0.0, 10.0, 0.2, 50, 50), p)  # JIT warm-up
        tracemalloc.start()
        ts = []
        for _ in range(repeat):
            t = time.perf_counter()
            r = detect_trees(chm, spec, p)
            ts.append(time.perf_counter() - t)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        out[m] = {"seconds": min(ts), "trees": int(len(r["table"]["tree_id"])),
                  "peak_python_mb": peak / 2 ** 20}
    return out


def neon_boxes() -> dict:
    from lidartrees_gis.als.surfaces import SurfaceOptions, compute_surfaces
    from lidartrees_gis.io.options import ReadOptions

    boxes_f = DATA / "neon_teak_dev" / "teak_crowns_utm11n.csv"
    if not boxes_f.exists():
        return {}
    rows = list(csv.DictReader(open(boxes_f)))
    res = {}
    total = one = 0
    for laz in sorted((DATA / "neon_teak_dev").glob("TEAK_*.laz")):
        b = [r for r in rows if r["plot_id"] == laz.stem]
        if not b:
            continue
        s = compute_surfaces(ReadOptions(a_srs="EPSG:32611").open(laz), 0.5,
                             SurfaceOptions(dtm="ground", chm="max"))
        r = detect_trees(s["chm"], s["spec"], TreeParams(smooth="gauss3", min_height=3))
        x, y = r["table"]["x"], r["table"]["y"]
        k = 0
        for bb in b:
            inside = ((x >= float(bb["xmin"])) & (x <= float(bb["xmax"])) & (y >= float(bb["ymin"]))
                      & (y <= float(bb["ymax"])))
            k += int(inside.sum() == 1)
        res[laz.stem] = {"boxes": len(b), "exactly_one_top": k, "tops": int(len(x))}
        total += len(b)
        one += k
    res["all"] = {"boxes": total, "exactly_one_top": one, "share": one / total if total else None}
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--big", type=int, default=5000)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "trees.json"))
    a = ap.parse_args()
    res = {"grid_250": time_methods(250, 5), f"grid_{a.big}": time_methods(a.big, 1),
           "neon_teak_boxes": neon_boxes()}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2))
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
