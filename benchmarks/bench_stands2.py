"""Plantation mode on the second, independent stand family (issue 41), one row per stand.

For each configuration of ``_family2.CONFIGS`` this writes the LAS file and its stands
(GeoPackage, field ``talhao``), runs the CLI as a user would::

    python -m lidartrees_gis.cli trees STAND.las OUT.gpkg -spacing auto \
        -stands STANDS.gpkg -stand_csv OUT.csv -overwrite

and compares each stand of the output with the generator's truth:

* lattice: found (spacing within 0.05 m, row azimuth within 1 degree, modulo 180);
* stocking error (points) and the planting positions counted against the truth's;
* gaps: share of the positions reported missing within 0.5 m of a true missing position
  (precision, as ``bench_stands.py``), the same share of the uncertain ones (a field check,
  not a reported gap), and the share of true missing positions reported missing or
  uncertain (recall);
* trees: F-score of the tree tops (suppressed ones included) against the truth's tops
  (one-to-one, within min(1.5 m, half the plant spacing)); the same of the defaults without
  the stands (``trees STAND.las OUT.gpkg``: each tile's own lattice look), on the tops inside
  each stand's polygon (``no_stands_tree_f``). With the stands and no ``-spacing`` the
  defaults give ``-spacing auto``'s trees.

Results: ``benchmarks/results/stands2.json`` (one row per configuration stand, no means).
Usage: ``python benchmarks/bench_stands2.py [--density 8] [--configs NAME ...]``.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import _family2 as fam  # noqa: E402


def _match(ax, ay, bx, by, radius):
    """Greedy one-to-one matches of a to b within radius (closest pairs first)."""
    from scipy.spatial import cKDTree

    if len(ax) == 0 or len(bx) == 0:
        return 0
    pairs = cKDTree(np.c_[ax, ay]).sparse_distance_matrix(cKDTree(np.c_[bx, by]), radius,
                                                          output_type="ndarray")
    order = np.argsort(pairs["v"])
    used_a, used_b, n = set(), set(), 0
    for i, j in zip(pairs["i"][order], pairs["j"][order]):
        if i not in used_a and j not in used_b:
            used_a.add(i), used_b.add(j)
            n += 1
    return n


def _near(ax, ay, bx, by, radius):
    """For each a: is some b within radius."""
    from scipy.spatial import cKDTree

    if len(ax) == 0:
        return np.zeros(0, bool)
    if len(bx) == 0:
        return np.zeros(len(ax), bool)
    d, _ = cKDTree(np.c_[bx, by]).query(np.c_[ax, ay])
    return d <= radius


def _num(v):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return None if not np.isfinite(v) else v


def _parse_spacing(s):
    try:
        a, b = str(s).lower().split("x")
        a, b = float(a), float(b)
    except ValueError:
        return None
    return (a, b) if np.isfinite(a) and np.isfinite(b) else None


def score_stand(st, stands, gaps, tops):
    """One row: the output's stand ``st['talhao']`` against its truth."""
    tid = st["talhao"]
    lat = st["lattice"]
    pos = st["positions"]
    row = {"talhao": tid,
           "design": f"{lat['row_spacing']:g}x{lat['plant_spacing']:g}",
           "azimuth_true": lat["azimuth"], "positions_true": int(pos.size),
           "stocking_true": round(st["stocking_pct"], 2),
           "missing_true": int((pos["status"] == "missing").sum())}
    s = stands[stands["stand_id"].astype(str) == tid]
    rec = s.iloc[0] if len(s) else {}
    spacing = _parse_spacing(rec.get("spacing")) if len(s) else None
    az = _num(rec.get("row_azimuth")) if len(s) else None
    row["spacing_found"] = None if spacing is None else f"{spacing[0]:g}x{spacing[1]:g}"
    row["azimuth_found"] = az
    ok = spacing is not None and az is not None
    if ok:
        ds = max(abs(spacing[0] - lat["row_spacing"]), abs(spacing[1] - lat["plant_spacing"]))
        da = abs((az - lat["azimuth"] + 90.0) % 180.0 - 90.0)
        if lat["row_spacing"] == lat["plant_spacing"]:   # a square design has two row axes
            da = min(da, abs((az - lat["azimuth"]) % 180.0 - 90.0))
            ds = min(ds, max(abs(spacing[1] - lat["row_spacing"]),
                             abs(spacing[0] - lat["plant_spacing"])))
        row["spacing_err_m"], row["azimuth_err_deg"] = round(ds, 3), round(da, 2)
        ok = ds <= 0.05 and da <= 1.0
    row["lattice_ok"] = bool(ok)
    stock = _num(rec.get("stocking_pct")) if len(s) else None
    row["stocking_found"] = None if stock is None else round(stock, 2)
    row["stocking_err_pts"] = None if stock is None else round(stock - st["stocking_pct"], 2)
    lo = _num(rec.get("stocking_pct_low")) if len(s) else None
    hi = _num(rec.get("stocking_pct_high")) if len(s) else None
    row["stocking_low"] = None if lo is None else round(lo, 2)
    row["stocking_high"] = None if hi is None else round(hi, 2)
    # the truth inside the stand's 95 % interval (None without one)
    row["truth_in_interval"] = (None if lo is None or hi is None
                                else bool(lo - 0.005 <= st["stocking_pct"] <= hi + 0.005))
    row["lattice_field"] = rec.get("lattice") if len(s) else None
    row["positions_found"] = int(_num(rec.get("planting_positions")) or 0) if len(s) else 0
    for key in ("missing_trees", "uncertain_positions", "suppressed_trees"):
        row[key] = int(_num(rec.get(key)) or 0) if len(s) else 0
    g = gaps[(gaps["stand_id"].astype(str) == tid)
             & gaps["status"].isin(["missing", "uncertain"])] if len(gaps) else gaps
    miss = pos["status"] == "missing"
    gx, gy = (g.geometry.x.to_numpy(), g.geometry.y.to_numpy()) if len(g) else ([], [])
    true_rep = _near(gx, gy, pos["x"][miss], pos["y"][miss], 0.5)
    found = _near(pos["x"][miss], pos["y"][miss], gx, gy, 0.5)
    called = (g["status"] == "missing").to_numpy() if len(g) else np.zeros(0, bool)
    row["gaps_reported"] = int(called.sum())
    # reported gaps: the positions called missing (as bench_stands.py counts them); an
    # uncertain position is a field check, not a reported gap, but counts as found below
    row["gap_precision"] = round(float(true_rep[called].mean()), 3) if called.any() else None
    row["unresolved_true_share"] = round(float(true_rep[~called].mean()), 3) \
        if (~called).any() else None
    row["missing_recall"] = round(float(found.mean()), 3) if miss.any() else None
    t = tops[tops["stand_id"].astype(str) == tid] if len(tops) else tops
    radius = min(1.5, 0.5 * lat["plant_spacing"])
    has = ~miss
    m = _match(pos["top_x"][has], pos["top_y"][has], t.geometry.x.to_numpy(),
               t.geometry.y.to_numpy(), radius) if len(t) else 0
    p = m / max(len(t), 1)
    r = m / max(int(has.sum()), 1)
    row["trees_true"], row["trees_found"] = int(has.sum()), int(len(t))
    row["tree_f"] = round(2 * p * r / (p + r), 3) if p + r > 0 else 0.0
    return row


def run_config(cfg, work, seed, timeout, python, explicit=False):
    """Generate (or reuse) one configuration's files, run the CLI, score every stand.

    ``explicit``: also run with the true ``-spacing RxC`` (files of one design) and add its
    scores as ``explicit_*`` fields."""
    name = cfg["name"]
    las, stands_path = work / f"{name}.las", work / f"{name}_stands.gpkg"
    truth_path = work / f"{name}.truth.pkl"
    t0 = time.time()
    if not (las.exists() and stands_path.exists() and truth_path.exists()):
        pts, truth = fam.make_stand(cfg, seed)
        fam.write_las(pts, las)
        fam.write_stands(truth, stands_path)
        with open(truth_path, "wb") as f:
            pickle.dump(truth, f)
    with open(truth_path, "rb") as f:
        truth = pickle.load(f)
    gen_s = time.time() - t0
    rows = _run_score(cfg, truth, work, "auto", las, stands_path, timeout, python)
    plain = _run_plain(cfg, truth, work, las, stands_path, timeout, python)
    for r in rows:
        r.update(plain.get(r["talhao"], {}))
    designs = {st["spacing"] for st in cfg["stands"]}
    if explicit and len(designs) == 1:
        rs, ps = designs.pop()
        rows2 = _run_score(cfg, truth, work, f"{rs:g}x{ps:g}", las, stands_path, timeout,
                           python)
        keys = ("exit", "run_s", "lattice_ok", "azimuth_found", "stocking_err_pts",
                "positions_found", "gap_precision", "missing_recall", "tree_f")
        for r, r2 in zip(rows, rows2):
            r.update({f"explicit_{k}": r2.get(k) for k in keys})
    for r in rows:
        r["gen_s"] = round(gen_s, 1)
    return rows


def _run_score(cfg, truth, work, spacing, las, stands_path, timeout, python):
    import geopandas as gpd

    name = cfg["name"]
    tag = "auto" if spacing == "auto" else "explicit"
    out, csv = work / f"{name}_{tag}.gpkg", work / f"{name}_{tag}.csv"
    cmd = [python, "-m", "lidartrees_gis.cli", "trees", str(las), str(out), "-spacing", spacing,
           "-stands", str(stands_path), "-stand_csv", str(csv), "-overwrite"]
    side = work / f"{name}_{tag}.run.json"
    if RESCORE and side.exists():
        with open(side) as f:
            rc, log, run_s = (lambda d: (d["exit"], d["log"], d["run_s"]))(json.load(f))
    else:
        t1 = time.time()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                  cwd=str(HERE.parent), env=dict(os.environ))
            rc, log = proc.returncode, proc.stdout + proc.stderr
        except subprocess.TimeoutExpired:
            rc, log = "timeout", ""
        run_s = time.time() - t1
        with open(side, "w") as f:
            json.dump({"exit": rc, "log": log, "run_s": run_s, "cmd": cmd}, f)
    base = {"config": name, "density": cfg["density"], "slope_pct": round(100 * cfg["slope"]),
            "density_true": round(truth["density"], 2), "run_s": round(run_s, 1), "exit": rc}
    if rc != 0:
        base["error"] = log.strip().splitlines()[-1] if log.strip() else str(rc)
        return [dict(base, talhao=s["talhao"]) for s in truth["stands"]]
    stands = gpd.read_file(out, layer="stands")
    layers = {n for n, _ in __import__("pyogrio").list_layers(out)}
    gaps = gpd.read_file(out, layer="gaps") if "gaps" in layers else gpd.GeoDataFrame()
    tops = gpd.read_file(out, layer="tree_tops")
    stand_lines = [ln.strip() for ln in log.splitlines() if ln.strip().startswith("stand ")]
    rows = []
    for st in truth["stands"]:
        row = dict(base, **score_stand(st, stands, gaps, tops))
        row["printed"] = next((ln for ln in stand_lines if ln.startswith(f"stand {st['talhao']}:")),
                              None)
        rows.append(row)
    return rows


def _run_plain(cfg, truth, work, las, stands_path, timeout, python) -> dict:
    """The defaults without -stands (each tile's own lattice look: the trees the defaults gave
    with the stands too, before they looked for each stand's lattice): per stand, the tree F
    of the tops inside its polygon, as ``no_stands_*`` fields."""
    import geopandas as gpd

    out = work / f"{cfg['name']}_plain.gpkg"
    cmd = [python, "-m", "lidartrees_gis.cli", "trees", str(las), str(out), "-overwrite", "-q"]
    side = work / f"{cfg['name']}_plain.run.json"
    if RESCORE and side.exists() and out.exists():
        rc = json.loads(side.read_text())["exit"]
    else:
        try:
            rc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                cwd=str(HERE.parent)).returncode
        except subprocess.TimeoutExpired:
            rc = "timeout"
        side.write_text(json.dumps({"exit": rc, "cmd": cmd}))
    if rc != 0:
        return {s["talhao"]: {"no_stands_exit": rc} for s in truth["stands"]}
    tops = gpd.read_file(out, layer="tree_tops")
    pol = gpd.read_file(stands_path)
    j = gpd.sjoin(tops, pol[["talhao", "geometry"]], how="left", predicate="within")
    tops["stand_id"] = j["talhao"].astype(str).to_numpy()
    empty = gpd.GeoDataFrame({"stand_id": pol["talhao"].astype(str)}, geometry=pol.geometry)
    res = {}
    for st in truth["stands"]:
        r = score_stand(st, empty, gpd.GeoDataFrame(), tops)
        res[st["talhao"]] = {"no_stands_trees_found": r["trees_found"],
                             "no_stands_tree_f": r["tree_f"]}
    return res


RESCORE = False  # --rescore: score the outputs kept in --work (runs without them rerun)

COLUMNS = ("config", "talhao", "design", "azimuth_true", "density", "slope_pct", "lattice_ok",
           "spacing_found", "azimuth_found", "positions_true", "positions_found",
           "stocking_true", "stocking_err_pts", "truth_in_interval", "gap_precision",
           "missing_recall", "tree_f", "no_stands_tree_f")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", nargs="*", help="configuration names (default: all)")
    ap.add_argument("--density", type=float, help="only configurations of this density")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--work", default="/tmp/bench_stands2", help="folder for the files")
    ap.add_argument("--timeout", type=float, default=600.0, help="per CLI run, s")
    ap.add_argument("--out", default=str(HERE / "results" / "stands2.json"))
    ap.add_argument("--explicit", action="store_true",
                    help="also run with the true -spacing RxC (files of one design)")
    ap.add_argument("--diagnostics", action="store_true",
                    help="run _family2.DIAGNOSTICS (controls) instead of CONFIGS")
    ap.add_argument("--rescore", action="store_true",
                    help="score the CLI outputs kept in --work instead of running it again")
    a = ap.parse_args(argv)
    global RESCORE
    RESCORE = a.rescore
    pool = fam.DIAGNOSTICS if a.diagnostics else fam.CONFIGS
    configs = [c for c in pool if (not a.configs or c["name"] in a.configs)
               and (a.density is None or c["density"] == a.density)]
    configs.sort(key=lambda c: (c["density"] != 8.0, c["density"]))  # 8 pts/m2 first
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for cfg in configs:
        got = run_config(cfg, work, a.seed, a.timeout, sys.executable, a.explicit)
        rows.extend(got)
        for r in got:
            print(" | ".join(str(r.get(c)) for c in COLUMNS), flush=True)
        _write(a, rows)
    return 0


def _write(a, rows):
    result = {"benchmark": "bench_stands2", "family": "benchmarks/_family2.py",
              "seed": a.seed, "command": "lidartrees trees STAND.las OUT.gpkg -spacing auto "
              "-stands STANDS.gpkg -stand_csv OUT.csv -overwrite", "rows": rows}
    write_json(a.out, result)


def write_json(path, result: dict) -> None:
    """A results file, written whole or not at all (numpy numbers as numbers)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    tmp = str(path) + ".tmp"
    with open(tmp, "w") as f:
        json.dump(result, f, indent=1, default=lambda o: o.item() if hasattr(o, "item")
                  else str(o))
    os.replace(tmp, path)


if __name__ == "__main__":
    sys.exit(main())
