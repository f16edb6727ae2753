"""`metrics` beside lidR's own output (issue 40): lidR 4.1.2 ``pixel_metrics(las, .stdmetrics_z,
res = 20)`` on Megaplot and ``plot_metrics(las, .stdmetrics_z, efi_plot, radius = 11.28)``,
written by R, compared with ours value by value; and the time of each beside our CHM chain on
the same points (one core: lidR with ``set_lidr_threads(1)``, ours with one worker).

    python benchmarks/bench_metrics_lidr.py

writes ``benchmarks/results/metrics_lidr.json``. Needs Rscript and lidR
(../shared/peers/build.sh); without them it says so and exits 2.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))
from _peers import has_r_package, r_env  # noqa: E402

DATA = (HERE.parent / ".." / "shared" / "data").resolve()
MP = DATA / "lidR_extdata" / "Megaplot.laz"
EFI = DATA / "lidR_extdata" / "efi_plot.shp"
STD_Z = (["zmax", "zmean", "zsd", "zskew", "zkurt", "zentropy", "pzabovezmean", "pzabove2"]
         + [f"zq{q}" for q in range(5, 100, 5)] + [f"zpcum{k}" for k in range(1, 10)])

R_SCRIPT = r"""
suppressMessages({library(lidR); library(sf)})
set_lidr_threads(1)
a <- commandArgs(TRUE)
t0 <- Sys.time(); las <- readLAS(a[1]); t1 <- Sys.time()
m <- pixel_metrics(las, .stdmetrics_z, res = 20); t2 <- Sys.time()
write.csv(as.data.frame(m, xy = TRUE, na.rm = FALSE), a[3], row.names = FALSE)
p <- plot_metrics(las, .stdmetrics_z, st_read(a[2], quiet = TRUE), radius = 11.28)
write.csv(st_drop_geometry(p), a[4], row.names = FALSE)
cat(as.numeric(t1 - t0, units = "secs"), as.numeric(t2 - t1, units = "secs"), npoints(las), "\n")
"""

#: the larger timing: lidR's height normalisation (TIN of the class-2 returns) and cell
#: metrics on the four bcts files, as ``metrics DIR out.tif`` does with its defaults' DTM
R_LARGE = r"""
suppressMessages({library(lidR)})
set_lidr_threads(1)
a <- commandArgs(TRUE)
t0 <- Sys.time(); las <- readLAS(a[-1]); t1 <- Sys.time()
las <- normalize_height(las, tin()); t2 <- Sys.time()
m <- pixel_metrics(las, .stdmetrics_z, res = 20); t3 <- Sys.time()
cat(as.numeric(t1 - t0, units = "secs"), as.numeric(t2 - t1, units = "secs"),
    as.numeric(t3 - t2, units = "secs"), npoints(las), "\n")
"""
BCTS = sorted((DATA / "lasR_bcts").glob("bcts_*.laz"))


def _diff(ours: float, ref: float) -> float:
    """|ours - ref| relative to max(1, |ref|); 0 when both are NaN, inf when one is."""
    if np.isnan(ref) and np.isnan(ours):
        return 0.0
    if np.isnan(ref) or np.isnan(ours):
        return float("inf")
    return abs(ours - ref) / max(1.0, abs(ref))


def _large() -> dict:
    """Seconds per million points on the four bcts files (one core): lidR's readLAS +
    normalize_height(tin()) + pixel_metrics; ours ``metrics`` (-tr 20, defaults) and ``chm``
    (defaults), each with reading."""
    from lidartrees_gis import api as lt

    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "l.R"
        script.write_text(R_LARGE)
        r = subprocess.run(["Rscript", str(script), "x", *map(str, BCTS)], capture_output=True,
                           text=True, env=r_env())
    if r.returncode:
        return {"error": r.stderr.strip().splitlines()[-1:]}
    read_s, norm_s, met_s, npts = (float(v) for v in r.stdout.split())
    files = [str(f) for f in BCTS]
    t0 = time.perf_counter()
    lt.metrics(files, res=20, workers=1)
    ours_m = time.perf_counter() - t0
    t0 = time.perf_counter()
    lt.canopy_height(files)
    ours_c = time.perf_counter() - t0
    mp = npts / 1e6
    return {"points": int(npts),
            "lidR_s": {"readLAS": read_s, "normalize_height_tin": norm_s, "pixel_metrics": met_s},
            "ours_s": {"metrics": ours_m, "chm": ours_c},
            "s_per_million_points": {"lidR_total": (read_s + norm_s + met_s) / mp,
                                     "ours_metrics": ours_m / mp, "ours_chm": ours_c / mp},
            "ratio_ours_metrics_to_lidR": ours_m / (read_s + norm_s + met_s),
            "ratio_ours_metrics_to_ours_chm": ours_m / ours_c}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "results" / "metrics_lidr.json"))
    a = ap.parse_args(argv)
    if not has_r_package("lidR"):
        print("lidR is not installed: run ../shared/peers/build.sh", file=sys.stderr)
        return 2
    import pandas as pd

    from lidartrees_gis import api as lt

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "m.R").write_text(R_SCRIPT)
        t0 = time.perf_counter()
        r = subprocess.run(["Rscript", str(tmp / "m.R"), str(MP), str(EFI), str(tmp / "cells.csv"),
                           str(tmp / "plots.csv")], capture_output=True, text=True, env=r_env())
        wall_r = time.perf_counter() - t0
        if r.returncode:
            print(r.stderr, file=sys.stderr)
            return 1
        read_s, metrics_s, npts = (float(v) for v in r.stdout.split())
        cells = pd.read_csv(tmp / "cells.csv")
        plots = pd.read_csv(tmp / "plots.csv")

    kw = dict(dtm="none", min_height=None, drop_class=(), workers=1)
    t0 = time.perf_counter()
    res = lt.metrics(str(MP), res=20, **kw)
    ours_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    lt.canopy_height(str(MP), dtm="none", drop_class=())
    chm_s = time.perf_counter() - t0
    from lidartrees_gis.inventory.metrics import METRICS

    spec, arr = res["grid"]
    names = list(METRICS)
    worst, n_cells = {m: 0.0 for m in STD_Z}, 0
    for _, row in cells.iterrows():
        if np.isnan(row["zmax"]):
            continue
        c = int(np.floor((row["x"] - spec.left) / spec.res))
        rr = int(np.floor((spec.top - row["y"]) / spec.res))
        for m in STD_Z:
            worst[m] = max(worst[m], _diff(float(arr[names.index(m), rr, c]), float(row[m])))
        n_cells += 1
    pm = lt.metrics(str(MP), plots=str(EFI), plot_radius=11.28, **kw)["layers"]["plot_metrics"]
    worst_p = {m: 0.0 for m in STD_Z}
    for k in range(len(plots)):
        for m in STD_Z:
            worst_p[m] = max(worst_p[m], _diff(float(pm[m].iloc[k]), float(plots[m].iloc[k])))
    report = {
        "peer": "lidR 4.1.2 (set_lidr_threads(1)), R output written with 15 significant digits",
        "points": int(npts), "cells_compared": n_cells, "plots_compared": len(plots),
        "cells_max_rel_diff": max(worst.values()), "plots_max_rel_diff": max(worst_p.values()),
        "cells_worst_metric": max(worst, key=worst.get),
        "cells_within_1e-6": all(v <= 1e-6 for v in worst.values()),
        "plots_within_1e-6": all(v <= 1e-6 for v in worst_p.values()),
        "per_metric_cells": worst, "per_metric_plots": worst_p,
        "seconds": {"lidR_readLAS": read_s, "lidR_pixel_metrics": metrics_s,
                    "lidR_Rscript_wall": wall_r, "ours_metrics_read_included": ours_s,
                    "ours_chm_read_included": chm_s},
        "ratio_ours_metrics_to_lidR_read_plus_pixel_metrics": ours_s / (read_s + metrics_s),
        "ratio_ours_metrics_to_ours_chm": ours_s / chm_s,
    }
    report["bcts_4_files"] = _large()
    Path(a.out).write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps({k: v for k, v in report.items() if not k.startswith("per_")}, indent=1))
    return 0 if report["cells_within_1e-6"] and report["plots_within_1e-6"] else 1


if __name__ == "__main__":
    sys.exit(main())
