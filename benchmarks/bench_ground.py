"""Ground-filter benchmark (issues 5 and 12), one run, defaults first:

1. ISPRS filter test, 8 dev samples: type I, type II, total error and kappa per sample for
   - the project's default filter (hierarchical Kraus & Pfeifer robust interpolation + TIN
     densification),
   - the plain robust interpolation (``refine=0``: seed 003 / FUSION's band v <= g + w),
   - the cloth simulation filter (PyPI ``cloth-simulation-filter``, two configurations, with and
     without the same low-point removal), PDAL's SMRF when the ``pdal`` Python package is there;
2. the sweep the defaults were chosen from (dev samples only; 108 configurations) and, for the same configurations,
   DTMs on real forest files against the vendor's ground (share of 1 m cells more than 1 m off);
3. seed 003 on the demo stand (eucalyptus): the g = -w filters' share of the true ground, and
   ``dtm-quality`` (roles, recommended (g, w));
4. points/s on the lasR_bcts tiles (one core, filter alone) and the wall time of
   ``dtm-quality`` on bcts_1;
5. side by side on one core (``peers_one_core``): our filter and whole ``ground`` command,
   the ``cloth-simulation-filter`` package and lasR's ``classify_with_csf`` (when Rscript finds
   lasR, e.g. built by ../shared/peers/build.sh), time and agreement on the bcts tiles, ISPRS
   dev total error;
6. ``ground FOLDER OUTDIR`` on 64 M points (copies of the bcts tiles), two workers: time and
   peak RSS (``ground_folder_two_workers``).

Usage: python benchmarks/bench_ground.py [--out benchmarks/results/ground.json] [--quick]
       [--folder-points 64] [--only peers,folder,speed]  (--only adds sections to the results)
"""
from __future__ import annotations

import argparse
import itertools
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

from lidartrees_gis.errors import InputError  # noqa: E402
from lidartrees_gis.grid import GridSpec  # noqa: E402
from lidartrees_gis.tin import interpolate_tin  # noqa: E402
from lidartrees_gis.ground.filter import KrausPfeifer, filter_errors, kraus_pfeifer, low_points  # noqa: E402
from lidartrees_gis.io.points import open_points  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
from _peers import has_r_package, r_env  # noqa: E402

SAMPLES = ["samp11", "samp21", "samp23", "samp31", "samp41", "samp51", "samp53", "samp61"]
FOREST = ["lidR_extdata/Topography.laz", "lasR_bcts/bcts_1.laz", "neon_teak_dev/TEAK_043.laz",
          "neon_teak_dev/TEAK_046.laz"]
PUBLISHED = {"robust_interpolation_pfeifer_same_8": 7.99, "smrf_pingel_2013_15_samples": 2.97,
             "csf_zhang_2016_15_samples_tuned": 4.58}


def rounded(e):
    return {k: round(v, 2) if k != "kappa" else round(v, 3) for k, v in e.items()}


def ours(p, params=None):
    try:
        return kraus_pfeifer(p.x, p.y, p.z, params)[0]
    except InputError:  # every weight became 0: nothing is ground
        return np.zeros(len(p), bool)


def csf_ground(x, y, z, resolution=1.0, rigidness=1, low=False):
    import CSF

    keep = ~low_points(x, y, z) if low else np.ones(x.size, bool)
    idx = np.nonzero(keep)[0]
    c = CSF.CSF()
    c.params.bSloopSmooth = True
    c.params.cloth_resolution = resolution
    c.params.rigidness = rigidness
    c.params.class_threshold = 0.5
    c.setPointCloud(np.c_[x[idx], y[idx], z[idx]])
    g, o = CSF.VecInt(), CSF.VecInt()
    c.do_filtering(g, o, exportCloth=False)
    out = np.zeros(x.size, bool)
    out[idx[np.asarray(list(g), dtype=np.int64)]] = True
    return out


def smrf_ground(path):
    import pdal  # noqa: F401  (only when the Python bindings and libpdal are installed)

    pipe = pdal.Pipeline(json.dumps([str(path), {"type": "filters.smrf"}]))
    pipe.execute()
    return pipe.arrays[0]["Classification"] == 2


#: lasR's CSF stage on one file, one thread: classified copy written (point order kept)
R_LASR_CSF = r"""
args <- commandArgs(trailingOnly = TRUE)
suppressMessages(library(lasR))
try(set_parallel_strategy(sequential()), silent = TRUE)
t0 <- Sys.time()
ans <- exec(classify_with_csf() + write_las(args[2]), on = args[1])
cat("SECONDS", as.numeric(difftime(Sys.time(), t0, units = "secs")), "\n")
"""


def have_lasr() -> bool:
    return has_r_package("lasR")


def lasr_csf(path: Path, tmp: Path):
    """lasR's classify_with_csf on ``path`` (its classes reset to 1 first, so no vendor ground
    survives): (seconds as lasR measures them, ground mask in the file's point order)."""
    import shutil
    import subprocess

    import laspy

    las = laspy.read(path)
    las.classification = np.ones(len(las.points), np.uint8)
    src, out = tmp / f"{path.stem}_unclassified.laz", tmp / f"{path.stem}_csf.laz"
    las.write(src)
    script = tmp / "csf.R"
    script.write_text(R_LASR_CSF)
    p = subprocess.run(["taskset", "-c", "0", shutil.which("Rscript"), str(script), str(src),
                        str(out)], capture_output=True, text=True, env=r_env())
    secs = [ln.split()[1] for ln in p.stdout.splitlines() if ln.startswith("SECONDS")]
    if p.returncode != 0 or not secs:
        raise RuntimeError((p.stderr or p.stdout).strip().splitlines()[-1])
    got = laspy.read(out)
    if len(got.points) != len(las.points) or not np.array_equal(np.asarray(got.X),
                                                                 np.asarray(las.X)):
        raise RuntimeError("lasR wrote the points in another order")
    return float(secs[0]), np.asarray(got.classification) == 2


def ground_command(path: Path, tmp: Path) -> float:
    """Our whole ``ground`` on one file in this process (read, filter, write the LAZ): seconds."""
    from lidartrees_gis.catalog.catalog import TilingOptions
    from lidartrees_gis.ground.tiled import ground_run
    from lidartrees_gis.io.output import OutputOptions

    t = time.perf_counter()
    ground_run(path, tmp / f"{path.stem}_ours.laz", tiling=TilingOptions(workers=1),
               out=OutputOptions(overwrite=True))
    return time.perf_counter() - t


def peers_side_by_side(pts) -> dict:
    """One core each, the same files: ours (filter alone and the whole command), the
    ``cloth-simulation-filter`` package and lasR's CSF stage; on the four bcts tiles the time
    and the DTM (linear TIN, 1 m cells) against the vendor's (its class 2 is a thinned ground,
    so the points' agreement says little): cells more than 0.5 m off and the median absolute
    difference; the total error on the ISPRS dev samples."""
    import os

    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    lasr = have_lasr()
    out = {"lasR": "lasR 0.21.1 (../shared/peers/build.sh)" if lasr else "not found",
           "cloth_simulation_filter": "installed"}
    try:
        import CSF  # noqa: F401
    except ImportError:
        out["cloth_simulation_filter"] = "not installed"
    rows = {}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for i in (1, 2, 3, 4):
            f = DATA / "lasR_bcts" / f"bcts_{i}.laz"
            p = open_points(f).read_all()
            ref = p.classification == 2
            spec = GridSpec.from_bounds(p.x.min(), p.y.min(), p.x.max(), p.y.max(), 1.0)
            vendor = interpolate_tin(p.x[ref], p.y[ref], p.z[ref], spec)

            def vs_vendor(g):
                d = np.abs(interpolate_tin(p.x[g], p.y[g], p.z[g], spec) - vendor)
                return {"cells_off_0.5m_pct": round(100 * float(np.mean(d > 0.5)), 2),
                        "median_abs_m": round(float(np.median(d)), 3)}

            row = {"points": len(p)}
            t = time.perf_counter()
            g = ours(p)
            row["ours_filter_s"] = round(time.perf_counter() - t, 2)
            row["ours_command_s"] = round(ground_command(f, tmp), 2)
            row["ours_dtm_vs_vendor"] = vs_vendor(g)
            if out["cloth_simulation_filter"] == "installed":
                t = time.perf_counter()
                g = csf_ground(p.x, p.y, p.z, 0.5, 1)  # lasR's defaults: 0.5 m cloth
                row["csf_package_s"] = round(time.perf_counter() - t, 2)
                row["csf_package_dtm_vs_vendor"] = vs_vendor(g)
            if lasr:
                secs, g = lasr_csf(f, tmp)
                row["lasR_csf_s"] = round(secs, 2)
                row["lasR_csf_dtm_vs_vendor"] = vs_vendor(g)
                row["ours_command_over_lasR_csf"] = round(row["ours_command_s"] / secs, 3)
            rows[f.name] = row
        out["bcts"] = rows
        tot = {"ours": [], "csf_package": [], "lasR_csf": []}
        for s in SAMPLES:
            p = pts[s]
            ref = p.classification == 2
            tot["ours"].append(filter_errors(ours(p), ref)["total"])
            if out["cloth_simulation_filter"] == "installed":
                tot["csf_package"].append(filter_errors(csf_ground(p.x, p.y, p.z, 0.5, 1),
                                                        ref)["total"])
            if lasr:
                tot["lasR_csf"].append(filter_errors(
                    lasr_csf(DATA / "isprs_filtertest_dev" / f"{s}-utm.laz", tmp)[1], ref)["total"])
        out["isprs_dev_mean_total"] = {k: round(float(np.mean(v)), 2) for k, v in tot.items() if v}
    os.sched_setaffinity(0, set(range(os.cpu_count())))
    return out


def folder_memory(points_m: float) -> dict:
    """``ground FOLDER OUTDIR`` on copies of the four bcts tiles (separate LAZ files, shifted
    side by side) up to ``points_m`` million points, two workers: wall time and the peak RSS of
    the largest process and of all together (sampled every 0.2 s)."""
    import shutil
    import subprocess
    import threading

    import laspy
    import psutil

    with tempfile.TemporaryDirectory() as d:
        folder, outdir = Path(d) / "in", Path(d) / "out"
        folder.mkdir()
        tiles = [DATA / "lasR_bcts" / f"bcts_{i}.laz" for i in (1, 2, 3, 4)]
        n, k = 0, 0
        while n < points_m * 1e6:
            for f in tiles:
                las = laspy.read(f)
                las.X = las.X + int(round(250.0 * k / las.header.scales[0]))
                las.write(folder / f"c{k:03d}_{f.name}")
                n += len(las.points)
            k += 1
        proc = subprocess.Popen([sys.executable, "-m", "lidartrees_gis.cli", "ground", str(folder),
                                 str(outdir), "-workers", "2", "-q"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, cwd=str(ROOT))
        peak = {"largest": 0, "sum": 0}
        stop = threading.Event()

        def sample():
            root = psutil.Process(proc.pid)
            while not stop.is_set():
                try:
                    rss = [q.memory_info().rss for q in [root, *root.children(recursive=True)]]
                except psutil.Error:
                    rss = []
                if rss:
                    peak["largest"] = max(peak["largest"], max(rss))
                    peak["sum"] = max(peak["sum"], sum(rss))
                time.sleep(0.2)

        th = threading.Thread(target=sample, daemon=True)
        t = time.perf_counter()
        th.start()
        so, se = proc.communicate()
        wall = time.perf_counter() - t
        stop.set()
        th.join()
        if proc.returncode != 0:
            return {"error": se.strip().splitlines()[-1] if se.strip() else "failed"}
        lines = dict(ln.split(": ", 1) for ln in so.splitlines() if ": " in ln)
        shutil.rmtree(folder)
        return {"points": n, "files": 4 * k, "seconds": round(wall, 1),
                "points_per_s": round(n / wall), "ground": int(lines.get("ground", 0)),
                "peak_rss_mb_largest_process": round(peak["largest"] / 2 ** 20, 1),
                "peak_rss_mb_all_processes": round(peak["sum"] / 2 ** 20, 1),
                "largest_file_points": max(laspy.open(f).header.point_count for f in tiles)}


def speed_rows() -> list:
    """The filter alone on each bcts tile, one core, kernels warm: the median of 3 runs."""
    import os

    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    speed = []
    for i in (1, 2, 3, 4):
        f = DATA / "lasR_bcts" / f"bcts_{i}.laz"
        p = open_points(f).read_all()
        kraus_pfeifer(p.x[:2000], p.y[:2000], p.z[:2000])  # compiled kernels loaded
        runs = []
        for _ in range(3):
            t = time.perf_counter()
            kraus_pfeifer(p.x, p.y, p.z)
            runs.append(time.perf_counter() - t)
        dt = float(np.median(runs))
        speed.append({"file": f.name, "points": len(p), "seconds": round(dt, 2),
                      "points_per_s": round(len(p) / dt)})
    os.sched_setaffinity(0, set(range(os.cpu_count())))
    return speed


def isprs(pts):
    table, means = {}, {}
    methods = {
        "default": lambda s, p: ours(p),
        "plain_robust_interpolation": lambda s, p: ours(p, KrausPfeifer(refine=0)),
        "default_with_gshift": lambda s, p: ours(p, KrausPfeifer(gshift=True)),
        "csf_r1_res1": lambda s, p: csf_ground(p.x, p.y, p.z, 1.0, 1),
        "csf_r1_res1_low_removed": lambda s, p: csf_ground(p.x, p.y, p.z, 1.0, 1, low=True),
        "csf_r2_res1_low_removed": lambda s, p: csf_ground(p.x, p.y, p.z, 1.0, 2, low=True),
        "smrf_pdal": lambda s, p: smrf_ground(DATA / "isprs_filtertest_dev" / f"{s}-utm.laz"),
    }
    skipped = {}
    for name, fn in methods.items():
        rows = {}
        try:
            for s in SAMPLES:
                p = pts[s]
                t = time.perf_counter()
                g = fn(s, p)
                rows[s] = {**rounded(filter_errors(g, p.classification == 2)),
                           "seconds": round(time.perf_counter() - t, 2)}
        except ImportError as e:
            skipped[name] = f"not installed here ({e.name})"
            continue
        table[name] = rows
        tot = [rows[s]["total"] for s in SAMPLES]
        means[name] = {"mean_total": round(float(np.mean(tot)), 2), "max_total": max(tot)}
    return table, means, skipped


def forest_dtm_error(cache, params):
    out = {}
    for f, (x, y, z, spec, vendor) in cache.items():
        g, _ = kraus_pfeifer(x, y, z, params)
        d = interpolate_tin(x[g], y[g], z[g], spec) - vendor
        out[Path(f).stem] = {"cells_off_1m_pct": round(100 * float(np.mean(np.abs(d) > 1)), 2),
                             "p5": round(float(np.percentile(d, 5)), 2),
                             "median": round(float(np.median(d)), 2),
                             "p95": round(float(np.percentile(d, 95)), 2)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "ground.json"))
    ap.add_argument("--quick", action="store_true", help="skip the sweep and dtm-quality timing")
    ap.add_argument("--folder-points", type=float, default=64.0,
                    help="millions of points of the folder run (peak memory); 0 skips it")
    ap.add_argument("--only", default="", help="comma list of sections to run and add to the "
                    "existing results: peers, folder, speed")
    a = ap.parse_args()
    only = {x.strip() for x in a.only.split(",") if x.strip()}
    if only:
        res = json.loads(Path(a.out).read_text()) if Path(a.out).exists() else {}
        pts = {s: open_points(DATA / "isprs_filtertest_dev" / f"{s}-utm.laz").read_all()
               for s in SAMPLES}
        if "peers" in only:
            res["peers_one_core"] = peers_side_by_side(pts)
            print(json.dumps(res["peers_one_core"], indent=1), flush=True)
        if "folder" in only and a.folder_points:
            res["ground_folder_two_workers"] = folder_memory(a.folder_points)
            print(json.dumps(res["ground_folder_two_workers"], indent=1), flush=True)
        if "speed" in only:
            res["points_per_s"] = speed_rows()
            print(json.dumps(res["points_per_s"], indent=1), flush=True)
        Path(a.out).write_text(json.dumps(res, indent=2, default=str))
        return
    res = {"defaults": KrausPfeifer().as_dict(), "published_mean_total": PUBLISHED}
    pts = {s: open_points(DATA / "isprs_filtertest_dev" / f"{s}-utm.laz").read_all()
           for s in SAMPLES}
    table, means, skipped = isprs(pts)
    res.update(isprs=table, isprs_means=means, skipped=skipped)
    print(json.dumps(means, indent=1), flush=True)

    cache = {}
    for f in FOREST:
        p = open_points(DATA / f).read_all()
        k = ~np.isin(p.classification, (7, 18))
        x, y, z, ref = p.x[k], p.y[k], p.z[k], p.classification[k] == 2
        spec = GridSpec.from_bounds(x.min(), y.min(), x.max(), y.max(), 1.0)
        cache[f] = (x, y, z, spec, interpolate_tin(x[ref], y[ref], z[ref], spec))
    res["forest_dtm_vs_vendor"] = {"default": forest_dtm_error(cache, KrausPfeifer()),
                                   "plain_robust_interpolation":
                                       forest_dtm_error(cache, KrausPfeifer(refine=0))}

    if not a.quick:
        sweep = []
        base = KrausPfeifer()
        grid = itertools.product((4, 5), (1.5, 2.0), (0.0, 0.1, 0.2), (0.2, 0.3, 0.4), (1.0, 1.25, 1.5))
        for levels, cell, wg, tol, slope in grid:
            kp = replace(base, levels=levels, cell=cell, w_growth=wg, tolerance=tol, slope=slope)
            tot = [filter_errors(ours(pts[s], kp), pts[s].classification == 2)["total"]
                   for s in SAMPLES]
            sweep.append({"levels": levels, "cell": cell, "w_growth": wg, "tolerance": tol,
                          "slope": slope, "mean_total": round(float(np.mean(tot)), 2),
                          "max_total": round(max(tot), 2)})
        sweep.sort(key=lambda r: r["mean_total"])
        res["sweep_isprs_dev"] = sweep
        res["forest_dtm_vs_vendor"]["best_of_sweep"] = forest_dtm_error(
            cache, replace(base, **{k: sweep[0][k] for k in
                                    ("levels", "cell", "w_growth", "tolerance", "slope")}))

    # seed 003 on the demo stand
    from lidartrees_gis.synthetic import make_stand

    stand, _ = make_stand()
    ref = stand.classification == 2
    gw = {}
    for g, w in [(-1, 1), (-1.5, 1.5), (-2, 2), (-2.5, 2.5), (-3, 3), (-3.5, 3.5), (-4, 4),
                 (-2, 2.5), (0, 1), (1, 4)]:
        row = {}
        for name, kp in (("default", KrausPfeifer(g=g, w=w)),
                         ("plain", KrausPfeifer(g=g, w=w, refine=0))):
            gr = ours(stand, kp)
            row[name] = {"true_ground_kept_pct": round(100 * float((gr & ref).sum() / ref.sum()), 1),
                         "canopy_as_ground_pct": round(100 * float((gr & ~ref).sum() / (~ref).sum()), 2)}
        gw[f"{g:g},{w:g}"] = row
    res["demo_stand_g_w"] = gw
    from lidartrees_gis.ground.quality import dtm_quality_file
    from lidartrees_gis.synthetic import CRS

    with tempfile.TemporaryDirectory() as d:
        import laspy
        import pyproj

        f = Path(d) / "stand.las"
        h = laspy.LasHeader(point_format=6, version="1.4")
        h.scales = np.array([0.001] * 3)
        h.offsets = np.array([stand.x.min(), stand.y.min(), stand.z.min()])
        h.add_crs(pyproj.CRS.from_user_input(CRS))
        las = laspy.LasData(h)
        las.x, las.y, las.z = stand.x, stand.y, stand.z
        las.classification = stand.classification  # the true ground: dtm-quality's reference
        las.write(str(f))
        t = time.perf_counter()
        q = dtm_quality_file(f, Path(d) / "q")
        import csv

        rows = list(csv.DictReader(open(q["output"])))
        res["demo_stand_dtm_quality"] = {
            "seconds": round(time.perf_counter() - t, 1), "roles": q["roles"],
            "clusters": q["clusters"], "recommended": [q["recommended_g"], q["recommended_w"]],
            "g_equals_minus_w_in_good": q["g_equals_minus_w_in_good"],
            **{k: q.get(k) for k in ("filter", "reference", "recommended_by", "recommended_rmse",
                                     "closest_3", "texture_recommended", "median_rmse_by_role",
                                     "g_equals_minus_w_rmse")},
            "ground_points_by_role": {r: sorted({int(x["ground_points"]) for x in rows
                                                 if x["role"] == r}) for r in set(q["roles"].values())}}

    res["points_per_s"] = speed_rows()
    res["peers_one_core"] = peers_side_by_side(pts)
    if not a.quick and a.folder_points:
        res["ground_folder_two_workers"] = folder_memory(a.folder_points)
    if not a.quick:
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            r = dtm_quality_file(DATA / "lasR_bcts" / "bcts_1.laz", Path(d) / "q")
            res["dtm_quality_bcts_1"] = {"seconds": round(time.perf_counter() - t, 1),
                                         **{k: v for k, v in r.items()
                                            if k not in ("output", "pngs", "dtm")}}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2, default=str))
    print(json.dumps({k: v for k, v in res.items() if k not in ("isprs", "sweep_isprs_dev")},
                     indent=1, default=str))


if __name__ == "__main__":
    main()
