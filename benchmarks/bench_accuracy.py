"""Tree-detection accuracy with the DEFAULT options (issue 9), then tuned and seed configurations.

Datasets
* three synthetic plantations with known trees (3 x 2 m clonal eucalyptus, ~23 m): the demo
  stand (seed 42, 25 pts/m², XYZ text in the seeds' dialect), another seed (7, 25 pts/m²) and a
  sparse one (seed 3, 4 pts/m²): recall, precision, F and height bias / RMSE after Eysn et al.
  (2015), for all and dominant trees;
* lidR's MixedConifer: tree count against lidR's 205 (the file's treeID segmentation), and the
  agreement of our tops with the highest point of each lidR tree (Eysn matching);
* neon_teak_dev: share of the 295 hand-drawn crown boxes holding exactly one top, and share of
  tops outside every box (lidR, as measured by the issue's author: 41 % / 41 %);
* lasR_bcts tiles: trees and trees per ha, for the record.
* with the defaults also: a density sweep (2-12 pts/m², two seeds) and the seed 11 stand with
  its rows turned 0, 20 and 45° from the grid axes (4 and 25 pts/m²; at 4 also with -tr 0.4).

Usage: python benchmarks/bench_accuracy.py [--out benchmarks/results/accuracy.json] [--quick]
[--configs "NAME,..."] (only those configurations again, the others kept from --out)
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"

from lidartrees_gis.report.evaluate import evaluate_trees  # noqa: E402
from lidartrees_gis.io.points import PointChunk  # noqa: E402
from _trees import trees  # noqa: E402
from lidartrees_gis.synthetic import CRS, StandParams, make_stand, write_xyz_seed_dialect  # noqa: E402
from lidartrees_gis.als.trees import TreeParams  # noqa: E402

#: what the issue reports for lidR on the same data
LIDR = {"mixedconifer_trees": 205, "neon_one_top_share": 0.41, "neon_outside_share": 0.41}
#: the acceptance targets of issue 9
TARGETS = {"synthetic_f": 0.97, "mixedconifer_range": (0.75 * 205, 1.25 * 205),
           "neon_one_top_share_min": 0.45, "neon_outside_share_max": 0.35}

#: configurations: defaults first, then tuned / seed ones (keyword arguments of _trees.trees); the
#: others without the planting-lattice look (-planting none), so that each measures its own tops
CONFIGS = {
    "defaults": {},
    "plantation mode (-spacing 3x2)": {"params": TreeParams(spacing="3x2")},
    "before issue 9 (-chm max -tr 0.5 -smooth none -tops lm)":
        {"chm": "max", "res": 0.5, "params": TreeParams(smooth="none", tops="lm", planting="none")},
    "seed 000 rg + gauss5 (-chm max -tr 0.5)":
        {"chm": "max", "res": 0.5, "params": TreeParams(smooth="gauss5", tops="lm", planting="none")},
    "pitfree + gauss3 + lm": {"params": TreeParams(smooth="gauss3", tops="lm", planting="none")},
    "height-only window (-tops vwf: 0.1 h + 0.5 m, lidR-style)":
        {"params": TreeParams(smooth="none", tops="vwf", planting="none")},
    "TreeX (-method treex)": {"params": TreeParams(method="treex", planting="none")},
    "defaults without the planting-lattice look (-planting none)":
        {"params": TreeParams(planting="none")},
}


def write_las(path, pts):
    from pyproj import CRS as PCRS

    from lidartrees_gis.io.lasout import write_points

    write_points(path, pts.x, pts.y, pts.z, crs=PCRS.from_user_input(CRS),
                 classification=pts.classification)


def run(input_, out, **kw):
    t = time.perf_counter()
    r = trees(input_, out, **kw)
    r["seconds"] = time.perf_counter() - t
    return r


def synthetic(tmp: Path, cfg: dict) -> dict:
    stands = {"demo (seed 42, 25 pts/m², XYZ)": StandParams(),
              "seed 7, 25 pts/m²": StandParams(seed=7),
              "seed 3, 4 pts/m²": StandParams(seed=3, density=4.0)}
    out = {}
    for name, sp in stands.items():
        pts, truth = make_stand(sp)
        if name.startswith("demo"):
            f = tmp / "demo.xyz"
            if not f.exists():
                write_xyz_seed_dialect(f, pts)
            kw = {"a_srs": CRS}
        else:
            f = tmp / f"stand_{sp.seed}_{sp.density:g}.las"
            if not f.exists():
                write_las(f, pts)
            kw = {}
        r = run(f, tmp / "t.gpkg", **kw, **cfg)
        t = r["table"]
        e = evaluate_trees(t["x"], t["y"], t["height"], truth["x"], truth["y"], truth["height"])
        e.pop("pairs")
        out[name] = {"trees": r["trees"], "truth": int(len(truth["x"])), "res": r["res"],
                     "crown_scale": r["crown_scale"], "seconds": round(r["seconds"], 2),
                     "all": {k: round(v, 4) if isinstance(v, float) else v for k, v in e["all"].items()},
                     "dominant": {k: round(v, 4) if isinstance(v, float) else v
                                  for k, v in e["dominant"].items()}}
        if "stocking_pct" in r:
            out[name]["stocking_pct"] = round(r["stocking_pct"], 2)
            out[name]["true_stocking_pct"] = round(100 * len(truth["x"]) / (len(truth["x"]) + len(truth["_missing_x"])), 2)
    return out


def density_sweep(tmp: Path) -> dict:
    """Defaults on the 3 x 2 m stand at 2-12 pts/m² (two seeds each)."""
    out = {}
    for dens in (2.0, 3.0, 4.0, 6.0, 8.0, 12.0):
        for seed in (3, 11):
            pts, truth = make_stand(StandParams(seed=seed, density=dens))
            f = tmp / f"sweep_{seed}_{dens:g}.las"
            write_las(f, pts)
            r = run(f, tmp / "s.gpkg")
            t = r["table"]
            e = evaluate_trees(t["x"], t["y"], t["height"], truth["x"], truth["y"], truth["height"])
            out[f"{dens:g} pts/m², seed {seed}"] = {
                "res": r["res"], "f_score": round(e["all"]["f_score"], 4),
                "recall": round(e["all"]["recall"], 4), "precision": round(e["all"]["precision"], 4)}
    return out


def orientation(tmp: Path) -> dict:
    """Defaults on the 3 x 2 m stand (seed 11) with its rows turned 0, 20 and 45° from the grid
    axes, at 4 and 25 pts/m², and at 4 pts/m² with 0.4 m cells (-tr 0.4): real plantations
    are planted at any azimuth, the other synthetic stands run north-south."""
    out = {}
    for dens in (4.0, 25.0):
        pts, truth = make_stand(StandParams(seed=11, density=dens))
        cx, cy = float(np.mean(truth["x"])), float(np.mean(truth["y"]))
        for deg in (0.0, 20.0, 45.0):
            a = np.radians(deg)

            def turn(x, y):
                return (cx + (x - cx) * np.cos(a) - (y - cy) * np.sin(a),
                        cy + (x - cx) * np.sin(a) + (y - cy) * np.cos(a))

            px, py = turn(pts.x, pts.y)
            tx, ty = turn(truth["x"], truth["y"])
            f = tmp / f"turned_{dens:g}_{deg:g}.las"
            write_las(f, PointChunk(px, py, pts.z, classification=pts.classification))
            for res in (("auto", 0.4) if dens == 4.0 else ("auto",)):
                r = run(f, tmp / "o.gpkg", res=res)
                t = r["table"]
                e = evaluate_trees(t["x"], t["y"], t["height"], tx, ty, truth["height"])["all"]
                key = f"{dens:g} pts/m², rows at {deg:g}°" + ("" if res == "auto" else f", -tr {res:g}")
                out[key] = {"res": r["res"], "f_score": round(e["f_score"], 4),
                            "recall": round(e["recall"], 4), "precision": round(e["precision"], 4),
                            "planting_detected": r.get("planting_detected"),
                            "gap_trees": r.get("gap_trees")}
    return out


def mixedconifer(tmp: Path, cfg: dict) -> dict:
    import laspy

    f = DATA / "lidR_extdata" / "MixedConifer.laz"
    if not f.exists():
        return {}
    r = run(f, tmp / "mc.gpkg", **cfg)
    las = laspy.read(f)
    tid = np.asarray(las["treeID"], float)
    ok = np.isfinite(tid) & (tid < 1e300)
    x, y, z, tid = np.asarray(las.x)[ok], np.asarray(las.y)[ok], np.asarray(las.z)[ok], tid[ok]
    order = np.lexsort((-z, tid))
    first = np.r_[True, tid[order][1:] != tid[order][:-1]]
    top = order[first]
    t = r["table"]
    e = evaluate_trees(t["x"], t["y"], t["height"], x[top], y[top], z[top])
    e.pop("pairs")
    return {"trees": r["trees"], "lidR_trees": LIDR["mixedconifer_trees"],
            "ratio_to_lidR": round(r["trees"] / LIDR["mixedconifer_trees"], 3),
            "within_25pct": bool(TARGETS["mixedconifer_range"][0] <= r["trees"] <= TARGETS["mixedconifer_range"][1]),
            "res": r["res"], "crown_scale": r["crown_scale"], "seconds": round(r["seconds"], 2),
            "agreement_with_lidR_tops": {k: round(v, 4) if isinstance(v, float) else v
                                         for k, v in e["all"].items()}}


def neon(tmp: Path, cfg: dict) -> dict:
    boxes_f = DATA / "neon_teak_dev" / "teak_crowns_utm11n.csv"
    if not boxes_f.exists():
        return {}
    rows = list(csv.DictReader(open(boxes_f)))
    per, total, one, tops, outside, secs = {}, 0, 0, 0, 0, 0.0
    tall, tall_out = 0, 0
    for laz in sorted((DATA / "neon_teak_dev").glob("TEAK_*.laz")):
        b = [r for r in rows if r["plot_id"] == laz.stem]
        if not b:
            continue
        r = run(laz, tmp / "n.gpkg", a_srs="EPSG:32611", **cfg)
        secs += r["seconds"]
        x, y = r["table"]["x"], r["table"]["y"]
        inany = np.zeros(len(x), bool)
        k = 0
        for bb in b:
            ins = ((x >= float(bb["xmin"])) & (x <= float(bb["xmax"])) & (y >= float(bb["ymin"]))
                   & (y <= float(bb["ymax"])))
            k += int(ins.sum() == 1)
            inany |= ins
        h = r["table"]["height"]
        tall += int((h >= 10).sum())
        tall_out += int(((h >= 10) & ~inany).sum())
        per[laz.stem] = {"boxes": len(b), "one_top": k, "tops": int(len(x)),
                         "tops_outside": int((~inany).sum()), "res": r["res"],
                         "crown_scale": r["crown_scale"]}
        total += len(b)
        one += k
        tops += len(x)
        outside += int((~inany).sum())
    return {"boxes": total, "boxes_with_one_top": one, "one_top_share": round(one / total, 4),
            "tops": tops, "tops_outside_every_box": outside,
            "outside_share": round(outside / max(tops, 1), 4),
            "lidR_one_top_share": LIDR["neon_one_top_share"],
            "lidR_outside_share": LIDR["neon_outside_share"], "seconds": round(secs, 2),
            # for the record, not the acceptance: the three plots with 5-20 boxes for 26-55 tops
            # (045, 047, 050) left out, and tops of 10 m or more only
            "outside_share_without_045_047_050": _share_without(per, ("TEAK_045", "TEAK_047", "TEAK_050")),
            "outside_share_tops_10m_or_more": round(tall_out / max(tall, 1), 4),
            "plots": per}


def _share_without(per: dict, left_out) -> float:
    kept = [v for k, v in per.items() if k not in left_out]
    return round(sum(v["tops_outside"] for v in kept) / max(sum(v["tops"] for v in kept), 1), 4)


def bcts(tmp: Path, cfg: dict) -> dict:
    out = {}
    for i in range(1, 5):
        f = DATA / "lasR_bcts" / f"bcts_{i}.laz"
        if not f.exists():
            continue
        r = run(f, tmp / "b.gpkg", **cfg)
        out[f.stem] = {"trees": r["trees"], "trees_per_ha": round(r["trees_per_ha"], 1),
                       "res": r["res"], "crown_scale": r["crown_scale"],
                       "seconds": round(r["seconds"], 2)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "accuracy.json"))
    ap.add_argument("--quick", action="store_true", help="defaults only, no bcts")
    ap.add_argument("--configs", default="", help="comma list of configurations to run again; "
                    "the others are kept from --out")
    a = ap.parse_args()
    res = {"targets": {k: list(v) if isinstance(v, tuple) else v for k, v in TARGETS.items()},
           "lidR_reported": LIDR, "configurations": {}}
    names = ["defaults"] if a.quick else list(CONFIGS)
    if a.configs:
        names = [n for n in a.configs.split(",") if n]
        unknown = [n for n in names if n not in CONFIGS]
        if unknown:
            raise SystemExit(f"--configs: unknown {unknown}; known: {list(CONFIGS)}")
        old = json.loads(Path(a.out).read_text())["configurations"]
        res["configurations"] = {k: old[k] for k in CONFIGS if k in old}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name in names:
            cfg = CONFIGS[name]
            print(f"== {name}", file=sys.stderr, flush=True)
            plantation_only = "spacing" in name  # a planting spacing means nothing elsewhere
            c = {"synthetic": synthetic(tmp, cfg),
                 "mixedconifer": {} if plantation_only else mixedconifer(tmp, cfg),
                 "neon_teak": {} if plantation_only else neon(tmp, cfg)}
            if name == "defaults" and not a.quick:
                c["bcts"] = bcts(tmp, cfg)
                c["synthetic_density_sweep"] = density_sweep(tmp)
                c["synthetic_orientation"] = orientation(tmp)
            res["configurations"][name] = c
            syn = "  ".join(f"F={v['all']['f_score']:.3f}" for v in c["synthetic"].values())
            print(f"   synthetic {syn} | MixedConifer {c['mixedconifer'].get('trees')} trees | NEON "
                  f"one-top {c['neon_teak'].get('one_top_share')} outside "
                  f"{c['neon_teak'].get('outside_share')}", file=sys.stderr, flush=True)
    d = res["configurations"]["defaults"]
    res["acceptance"] = {
        "synthetic_f_ge_0.97": {k: v["all"]["f_score"] >= TARGETS["synthetic_f"]
                                for k, v in d["synthetic"].items()},
        "mixedconifer_within_25pct_of_205": d["mixedconifer"].get("within_25pct"),
        "neon_one_top_share_ge_0.45": d["neon_teak"].get("one_top_share", 0) >= TARGETS["neon_one_top_share_min"],
        "neon_outside_share_le_0.35": d["neon_teak"].get("outside_share", 1) <= TARGETS["neon_outside_share_max"],
    }
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=2, default=float))
    print(json.dumps(res["acceptance"], indent=2))


if __name__ == "__main__":
    main()
