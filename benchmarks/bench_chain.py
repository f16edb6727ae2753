"""The whole chain on many tiles (issue 10): LAZ files -> pit-free CHM -> tops -> crowns -> crown
polygons in a GeoPackage, with the default options, at 2, 4, 8 and 16 M points (copies of
lidR's Megaplot laid side by side as separate files, as the issue measured), on one worker (in
process, pinned to one core) and on a local Dask cluster of two; wall time and peak RSS of the
largest process.
Also tiled = untiled on the four lasR_bcts tiles. When Rscript with lasR and/or lidR is on the
PATH their chains (:data:`R_LASR`, :data:`R_LIDR`) run on the same files in the same run, one
thread each, and the ratios are written beside ours (skipped otherwise: lasR and lidR are not in
Debian and CRAN is unreachable from this machine, so those scripts have not run here).

Each configuration runs ``--repeat`` times (alternating one and two workers) and the median is
reported: this machine's times vary by 10-15 % from one minute to the next.

Usage: python benchmarks/bench_chain.py [--sizes 2,4,8,16] [--repeat 3] [--out benchmarks/results/chain.json]
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

#: the issue's measurements on the same machine kind (s at 2/4/8/16.3 M points)
REPORTED = {"ours_before": [33, 52, 130, 241], "lasR": [8.5, 12.5, 30, 55],
            "lidR": [20, 28, 62, 117], "peak_rss_before_gb_16M": 5.4, "lasR_peak_rss_gb": 1.5}


def make_copies(n_points: float, out: Path) -> list:
    """Copies of Megaplot.laz (81,590 points, 227 x 234 m) on a 230 m grid until n_points."""
    import laspy

    src = laspy.read(DATA / "lidR_extdata" / "Megaplot.laz")
    k = int(math.ceil(n_points / len(src.points)))
    side = int(math.ceil(math.sqrt(k)))
    files = []
    out.mkdir(parents=True, exist_ok=True)
    for i in range(k):
        f = out / f"mp_{i:04d}.laz"
        files.append(f)
        if f.exists():
            continue
        las = laspy.read(DATA / "lidR_extdata" / "Megaplot.laz")
        sx, sy = las.header.scales[0], las.header.scales[1]
        las.X = las.X + int(round(230.0 * (i % side) / sx))
        las.Y = las.Y + int(round(230.0 * (i // side) / sy))
        las.write(f)
    return files


def run_chain(folder: Path, out: Path, workers: int) -> dict:
    """One chain in a fresh process: wall time, trees, peak RSS of the largest process."""
    # one worker = one core, as the issue measured (one thread): the process is pinned to a
    # single CPU, so the parallel LAZ decompressor cannot borrow the second core
    code = ("import sys, json, time, os; sys.path.insert(0, %r)\n"
            + ("os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})\n" if workers == 1 else "")
            + "from lidartrees_gis.als.chain import trees_run\n"
            "from lidartrees_gis.catalog.catalog import TilingOptions\n"
            "from lidartrees_gis.io.output import OutputOptions\n"
            "t = time.perf_counter()\n"
            "r = trees_run(%r, %r, tiling=TilingOptions(workers=%d), "
            "out=OutputOptions(overwrite=True))\n"
            "import resource\n"
            "s = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024\n"
            "c = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024\n"
            "print(json.dumps({'seconds': time.perf_counter() - t, 'trees': r['trees'], "
            "'tiles': r['tiles'], 'points': r['points'], 'peak_rss_mb_main': s, "
            "'peak_rss_mb_worker': c}))\n") % (str(ROOT), str(folder), str(out), workers)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": p.stderr.strip().splitlines()[-1] if p.stderr else f"exit {p.returncode}"}
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r["peak_rss_mb"] = round(max(r.pop("peak_rss_mb_main"), r.pop("peak_rss_mb_worker")), 1)
    r["seconds"] = round(r["seconds"], 2)
    return r


#: lasR's chain as lasR's own benchmarks run it (ground TIN -> normalised heights -> CHM of the
#: highest point per cell -> local maxima in 3 m -> region growing), on one thread, no polygons
R_LASR = r"""
args <- commandArgs(trailingOnly = TRUE)
suppressMessages(library(lasR))
f <- list.files(args[1], pattern = "[.]laz$", full.names = TRUE)
try(set_parallel_strategy(sequential()), silent = TRUE)
t0 <- Sys.time()
del <- triangulate(filter = keep_ground())
norm <- transform_with(del)
chm <- rasterize(as.numeric(args[2]), "max")
seed <- local_maximum(3)
tree <- region_growing(chm, seed)
ans <- exec(del + norm + chm + seed + tree, on = f)
cat("SECONDS", as.numeric(difftime(Sys.time(), t0, units = "secs")), "\n")
"""
#: the same chain in lidR 4 (catalogue, normalised copies in a temporary folder, p2r CHM, lmf,
#: Dalponte 2016 crowns as a raster), one thread
R_LIDR = r"""
args <- commandArgs(trailingOnly = TRUE)
suppressMessages(library(lidR))
set_lidr_threads(1)
ctg <- readLAScatalog(args[1])
opt_progress(ctg) <- FALSE
t0 <- Sys.time()
opt_output_files(ctg) <- file.path(tempdir(), "{*}_norm")
nctg <- normalize_height(ctg, tin())
opt_output_files(nctg) <- ""
chm <- rasterize_canopy(nctg, as.numeric(args[2]), p2r())
ttops <- locate_trees(chm, lmf(3))
crowns <- dalponte2016(chm, ttops)()
cat("SECONDS", as.numeric(difftime(Sys.time(), t0, units = "secs")), "\n")
"""


def r_packages() -> list:
    """The R packages of the comparison that this machine has (``lasR``, ``lidR``)."""
    rs = shutil.which("Rscript")
    if not rs:
        return []
    have = []
    for pkg in ("lasR", "lidR"):
        p = subprocess.run([rs, "-e", f"quit(status = if (requireNamespace('{pkg}', quietly = TRUE)) 0 else 1)"],
                           capture_output=True)
        if p.returncode == 0:
            have.append(pkg)
    return have


def run_r_chain(pkg: str, folder: Path, res: float = 0.5) -> dict:
    """One lasR or lidR chain in a fresh Rscript: wall time (as R measures it) and peak RSS."""
    import resource

    script = folder.parent / f"chain_{pkg}.R"
    script.write_text(R_LASR if pkg == "lasR" else R_LIDR)
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t = time.perf_counter()
    p = subprocess.run([shutil.which("Rscript"), str(script), str(folder), str(res)],
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    secs = [ln.split()[1] for ln in p.stdout.splitlines() if ln.startswith("SECONDS")]
    if p.returncode != 0 or not secs:
        lines = (p.stderr or p.stdout).strip().splitlines()
        err = [ln for ln in lines if ln.startswith("Error")] or lines[-1:]
        return {"error": err[0] if err else f"exit {p.returncode}"}
    # the children's peak is a running maximum: it names this run only when it rose
    return {"seconds": round(float(secs[0]), 2), "wall_with_R_start": round(wall, 2),
            "res": res, "peak_rss_mb": round(after / 1024, 1) if after > before else None}


def bcts_equality(tmp: Path) -> dict:
    from _trees import trees

    files = sorted((DATA / "lasR_bcts").glob("bcts_*.laz"))
    if len(files) < 4:
        return {}
    lst = tmp / "bcts.txt"
    lst.write_text("\n".join(str(f) for f in files))
    t = time.perf_counter()
    a = trees(lst, tmp / "a.gpkg", workers=2)
    ta = time.perf_counter() - t
    t = time.perf_counter()
    b = trees(lst, tmp / "b.gpkg", tile_size=float("inf"), workers=1)
    tb = time.perf_counter() - t
    return {"tiled": {"trees": a["trees"], "tiles": a["tiles"], "seconds": round(ta, 1)},
            "untiled": {"trees": b["trees"], "tiles": b["tiles"], "seconds": round(tb, 1)},
            "same_count": a["trees"] == b["trees"],
            "same_ids": set(a["tree_ids"].tolist()) == set(b["tree_ids"].tolist())}


def _median_run(runs: list) -> dict:
    """The run with the median time (all times under ``seconds_all``, the highest peak RSS)."""
    ok = [r for r in runs if "seconds" in r]
    if not ok:
        return runs[0]
    ok.sort(key=lambda r: r["seconds"])
    out = dict(ok[(len(ok) - 1) // 2])
    out["seconds_all"] = [r["seconds"] for r in runs if "seconds" in r]
    out["peak_rss_mb"] = max(r["peak_rss_mb"] for r in ok)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="2,4,8,16")
    ap.add_argument("--rss-sizes", default="",
                    help="also run these sizes (M points) on two workers only, for peak memory "
                         "(e.g. 64); with --sizes '' the results are added to the existing file")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "chain.json"))
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs of each configuration; the median time is reported (default 3)")
    a = ap.parse_args()
    sizes = [float(s) for s in a.sizes.split(",") if s.strip()]
    rss_sizes = [float(s) for s in a.rss_sizes.split(",") if s.strip()]
    r_pkgs = r_packages()
    res = {"reported_in_issue": REPORTED,
           "R": (f"{shutil.which('Rscript')}: {', '.join(r_pkgs) or 'neither lasR nor lidR'}"
                 if shutil.which("Rscript") else "Rscript not found: lasR/lidR skipped"),
           "chain": {}}
    if not sizes and Path(a.out).exists():
        res = json.loads(Path(a.out).read_text())
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for m in rss_sizes:
            folder = tmp / f"mp_{m:g}M"
            files = make_copies(m * 1e6, folder)
            print(f"{m:g} M points, 2 workers (memory)", file=sys.stderr, flush=True)
            row = {"files": len(files), "workers_2": run_chain(folder, tmp / "out.gpkg", 2)}
            res.setdefault("memory", {})[f"{m:g}M"] = row
            print(json.dumps(row), file=sys.stderr, flush=True)
            shutil.rmtree(folder)
        if not sizes:
            Path(a.out).write_text(json.dumps(res, indent=2))
            print(json.dumps(res.get("memory"), indent=2))
            return
        for m in sizes:
            folder = tmp / f"mp_{m:g}M"
            files = make_copies(m * 1e6, folder)
            row = {"files": len(files)}
            runs = {1: [], 2: []}
            for k in range(a.repeat):  # alternated, so a noisy minute hits both alike
                for w in (1, 2):
                    print(f"{m:g} M points, {w} worker(s), run {k + 1}/{a.repeat}",
                          file=sys.stderr, flush=True)
                    runs[w].append(run_chain(folder, tmp / "out.gpkg", w))
            for w in (1, 2):
                row[f"workers_{w}"] = _median_run(runs[w])
            r1, r2 = row["workers_1"], row["workers_2"]
            if "seconds" in r1 and "seconds" in r2:
                row["two_workers_over_one"] = round(r2["seconds"] / r1["seconds"], 3)
            for pkg in r_pkgs:  # the peers' chains on the same files, one thread
                print(f"{m:g} M points, {pkg}", file=sys.stderr, flush=True)
                row[pkg] = run_r_chain(pkg, folder)
                if "seconds" in row[pkg] and "seconds" in r1:
                    row[f"one_core_over_{pkg}"] = round(r1["seconds"] / row[pkg]["seconds"], 3)
            res["chain"][f"{m:g}M"] = row
            print(json.dumps(row), file=sys.stderr, flush=True)
            shutil.rmtree(folder)
        print("bcts tiled vs untiled", file=sys.stderr, flush=True)
        res["bcts_tiled_vs_untiled"] = bcts_equality(tmp)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2))
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
