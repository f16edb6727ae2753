"""TLS benchmark (issue 6): DBH of the real single trees from this tool's Dmax filter and from
dendromatics (3DFin's library), side by side, with run times and how far up the trunk the
filter got. dendromatics pins an older laspy, so it runs in its own venv:

    python3 -m venv .venv-dendro && .venv-dendro/bin/pip install dendromatics lazrs
    .venv/bin/python benchmarks/bench_tls.py [--out benchmarks/results/tls.json]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

from lidartrees_gis.io.points import open_points  # noqa: E402
from lidartrees_gis.tls.stem import dmax_filter  # noqa: E402

TREES = ["TreeLS_tls/pine.laz", "TreeLS_tls/spruce.laz", "arbor_tls/tree_qsm.laz",
         "xyz_text/ITSMe_tree_1_pc.txt", "xyz_text/ITSMe_tree_2_pc.txt", "xyz_text/rTLS_pc_tree.txt"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "tls.json"))
    ap.add_argument("--dendro-python", default=str(ROOT / ".venv-dendro" / "bin" / "python"))
    a = ap.parse_args()
    rows = []
    for name in TREES:
        f = DATA / name
        if not f.exists():
            continue
        t = time.perf_counter()
        p = open_points(f).read_all()
        r = dmax_filter(p.x, p.y, p.z)
        ours_s = time.perf_counter() - t
        row = {"tree": name, "points": len(p), "tree_height_m": round(r["tree_height"], 2),
               "dbh_cm": None if r["dbh"] != r["dbh"] else round(100 * r["dbh"], 2),
               "reached_height_m": round(r["reached_height"], 2),
               "reached_percent": round(r["reached_percent"], 1), "seconds": round(ours_s, 2),
               "message": r["message"]}
        if Path(a.dendro_python).exists():
            t = time.perf_counter()
            out = subprocess.run([a.dendro_python, str(ROOT / "benchmarks" / "dendro_dbh.py"), str(f)],
                                 capture_output=True, text=True, timeout=1800)
            wall = time.perf_counter() - t
            try:
                d = json.loads(out.stdout.strip().splitlines()[-1])
            except (ValueError, IndexError):
                d = {"dbh_m": None, "error": out.stderr.strip()[-300:]}
            row["dendromatics_dbh_cm"] = None if d.get("dbh_m") is None else round(100 * d["dbh_m"], 2)
            row["dendromatics_seconds"] = round(d.get("seconds", wall), 2)
            if row["dbh_cm"] is not None and row["dendromatics_dbh_cm"] is not None:
                row["difference_cm"] = round(row["dbh_cm"] - row["dendromatics_dbh_cm"], 2)
        rows.append(row)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(rows, indent=2))
    print(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
