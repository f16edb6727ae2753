"""Plantation stands the project's own generator did not make (benchmarks/_family.py, issue 23):
tree detection with the DEFAULT options first, then plantation mode (-spacing RxC), and the
stocking beside the truth's, per variation; and a two-stand file with -stands.

For each stand: F, recall, precision (Eysn et al. 2015 matching, all trees and dominant ones),
the suppressed trees found, and in plantation mode the stocking (stocked positions / positions:
a suppressed tree stocks its position, an uncertain one counts by its share of crown returns)
against the truth's, the share of the reported gaps (status missing) that are true gaps (within
half the smaller spacing of a missing position), the reported gaps that hold a suppressed tree,
and what the truth has at the positions left uncertain.

Usage: python benchmarks/bench_stands.py [--out benchmarks/results/stands.json] [--quick]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _family import family, make_stand, two_stands  # noqa: E402
from _trees import trees  # noqa: E402
from lidartrees_gis.als.trees import TreeParams  # noqa: E402
from lidartrees_gis.report.evaluate import evaluate_trees, match_trees  # noqa: E402

CRS = "EPSG:31983"  # SIRGAS 2000 / UTM 23S


def write_las(path, pts):
    from pyproj import CRS as PCRS

    from lidartrees_gis.io.lasout import write_points

    write_points(path, pts["x"], pts["y"], pts["z"], crs=PCRS.from_user_input(CRS),
                 classification=pts["classification"], overwrite=True)


def _acc(table, truth) -> dict:
    e = evaluate_trees(table["x"], table["y"], table["height"], truth["x"], truth["y"],
                       truth["height"])
    sup = truth["status"] == 2
    from lidartrees_gis.report.evaluate import match_eysn

    m = match_eysn(table["x"], table["y"], table["height"], truth["x"], truth["y"],
                   truth["height"])
    ref_idx = np.asarray(m["ref_index"] if isinstance(m, dict) else m[1])
    found_sup = int(sup[ref_idx].sum()) if ref_idx.size else 0
    return {"f": round(e["all"]["f_score"], 4), "recall": round(e["all"]["recall"], 4),
            "precision": round(e["all"]["precision"], 4),
            "detected": int(e["all"]["detected"]), "reference": int(e["all"]["reference"]),
            "suppressed": int(sup.sum()), "suppressed_found": found_sup}


def _stocking(r: dict, truth, gpkg) -> dict:
    import pyogrio

    pos = truth["positions"]
    inside = np.ones(pos["x"].size, bool)
    true_pct = 100.0 * (pos["status"] > 0).sum() / pos["x"].size
    if r.get("stocking_pct") is None:  # -spacing auto found no lattice
        return {"lattice": r.get("lattice"), "truth_stocking_pct": round(true_pct, 2)}
    low, high = float(r["stocking_pct_low"]), float(r["stocking_pct_high"])
    out = {"lattice": r.get("lattice"), "spacing_found": r.get("spacing"),
           "azimuth_found": r.get("row_azimuth"),
           "stocking_pct": round(float(r["stocking_pct"]), 2), "truth_stocking_pct":
           round(true_pct, 2), "stocking_error": round(float(r["stocking_pct"]) - true_pct, 2),
           "stocking_pct_low": round(low, 2), "stocking_pct_high": round(high, 2),
           # the interval is reported to 0.01 points: the truth within it at that rounding
           "truth_in_interval": bool(round(low, 2) <= round(true_pct, 2) <= round(high, 2)),
           "missing": int(r["missing_trees"]), "truth_missing": int((pos["status"] == 0).sum())}
    gaps = pyogrio.read_dataframe(gpkg, layer="gaps", read_geometry=False)
    out["suppressed"] = int(r.get("suppressed_trees") or 0)
    out["uncertain"] = int(r.get("uncertain_positions") or 0)
    tol = 0.5 * min(truth["spacing"])
    unc = gaps[gaps["status"] == "uncertain"]
    if len(unc):  # what the truth has at the positions left to a field check
        _, p_k = match_trees(unc["x"].to_numpy(), unc["y"].to_numpy(), pos["x"], pos["y"],
                             max_dist=tol)
        st = pos["status"][p_k]
        out["uncertain_truth"] = {"missing": int((st == 0).sum()),
                                  "suppressed": int((st == 2).sum()),
                                  "dominant": int((st == 1).sum())}
    gaps = gaps[gaps["status"] == "missing"] if "status" in gaps.columns else gaps
    found = (out.get("uncertain_truth") or {}).get("missing", 0)
    if len(gaps):
        miss = pos["status"] == 0
        g_k, p_k = match_trees(gaps["x"].to_numpy(), gaps["y"].to_numpy(), pos["x"][inside],
                               pos["y"][inside], max_dist=tol)
        st = pos["status"][p_k]
        out["gaps_true_share"] = round(float((st == 0).sum()) / len(gaps), 3)
        out["gaps_on_suppressed"] = int((st == 2).sum())
        out["true_gaps_found"] = round(float((st == 0).sum()) / max(int(miss.sum()), 1), 3)
        found += int((st == 0).sum())
    else:
        out["gaps_true_share"] = None
        out["gaps_on_suppressed"] = 0
    # true missing positions reported missing or uncertain (issue 41's recall; the gaps above
    # are the missing calls alone, as bench_stands2.py counts them too)
    tm = out["truth_missing"]
    out["missing_found"] = round(found / tm, 3) if tm else None
    return out


def stand_runs(tmp: Path, specs) -> list:
    rows = []
    for s in specs:
        pts, truth = make_stand(s)
        las = tmp / "stand.las"
        write_las(las, pts)
        row = {"stand": s.name, "density": s.density,
               "spacing": f"{s.row_spacing:g}x{s.tree_spacing:g}", "azimuth": s.azimuth}
        t0 = time.perf_counter()
        d = trees(las, tmp / "d.gpkg")
        row["defaults"] = {**_acc(d["table"], truth), "seconds": round(time.perf_counter() - t0, 2)}
        p = trees(las, tmp / "p.gpkg", params=TreeParams(spacing=row["spacing"]))
        row["plantation"] = {**_acc(p["table"], truth), **_stocking(p, truth, tmp / "p.gpkg")}
        a = trees(las, tmp / "a.gpkg", params=TreeParams(spacing="auto"))
        row["auto"] = {**_acc(a["table"], truth), **_stocking(a, truth, tmp / "a.gpkg")}
        rows.append(row)
        print(f"{s.name:32s} defaults F {row['defaults']['f']:.3f}  plantation F "
              f"{row['plantation']['f']:.3f}  stocking {row['plantation']['stocking_pct']:.2f} "
              f"(truth {row['plantation']['truth_stocking_pct']:.2f})  true gaps "
              f"{row['plantation']['gaps_true_share']}  uncertain "
              f"{row['plantation']['uncertain']} {row['plantation'].get('uncertain_truth', '')}"
              f"  auto: {row['auto'].get('spacing_found')} stocking "
              f"{row['auto'].get('stocking_pct')} ({row['auto'].get('stocking_pct_low')}-"
              f"{row['auto'].get('stocking_pct_high')})", flush=True)
    return rows


def two_stand_run(tmp: Path, density: float = 12.0) -> dict:
    import geopandas as gpd
    import pyogrio
    import shapely

    pts, truths, boxes = two_stands(density)
    las = tmp / "two.las"
    write_las(las, pts)
    gpd.GeoDataFrame({"talhao": ["A", "B"]}, geometry=[shapely.box(*b) for b in boxes],
                     crs=CRS).to_file(tmp / "stands.gpkg")
    out = {}
    for name, extra in (("one tile", {}), ("tiled", {"tile_size": 60, "workers": 1})):
        r = trees(las, tmp / "two.gpkg", params=TreeParams(spacing="auto"),
                  stands=str(tmp / "stands.gpkg"), **extra)
        st = pyogrio.read_dataframe(tmp / "two.gpkg", layer="stands", read_geometry=False)
        out[name] = {row["stand_id"]: {k: (round(float(row[k]), 2) if isinstance(row[k], float)
                                           else int(row[k]))
                                       for k in ("trees", "planting_positions", "missing_trees",
                                                 "suppressed_trees", "uncertain_positions",
                                                 "stocking_pct", "stocking_pct_low",
                                                 "stocking_pct_high", "row_azimuth")}
                     for _, row in st.iterrows()}
        for _, row in st.iterrows():
            out[name][row["stand_id"]]["spacing"] = row["spacing"]
        del r
    for sid, t in zip(("A", "B"), truths):
        pos = t["positions"]
        out["truth " + sid] = {"azimuth": t["azimuth"], "spacing": "{:g}x{:g}".format(*t["spacing"]),
                               "positions": int(pos["x"].size),
                               "missing": int((pos["status"] == 0).sum()),
                               "stocking_pct": round(100 * (pos["status"] > 0).mean(), 2)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "stands.json"))
    ap.add_argument("--quick", action="store_true", help="the first four stands only")
    a = ap.parse_args()
    specs = family()
    if a.quick:
        specs = specs[:4]
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        res = {"stands": stand_runs(tmp, specs)}
        res["two_stands"] = two_stand_run(tmp)
    Path(a.out).write_text(json.dumps(res, indent=1, default=str))
    print(json.dumps(res["two_stands"], indent=1))


if __name__ == "__main__":
    main()
