"""Wood volume per stand on the second, independent farm generator (issue 40), one row per stand.

``_volume_gen2.py`` was written by a session that never saw this project's code: eucalyptus
stands as rotated quadrilaterals on sloped ground, heights from Chapman-Richards site curves,
DAP from height with clone and density effects, stem volume by integrating a taper function
(not Schumacher-Hall), narrow ellipsoid crowns, scan lines with a beam footprint and multiple
returns; the crew's table in CAP with HT on part of the trees and a volume on the few trees
of a "cubagem" (so the command fits its own Schumacher-Hall on them). Each configuration's
LAZ is written once; its plots and trees are drawn ``--draws`` times.

For each configuration and draw the CLI runs as a user runs it (the defaults, plus the tree
method)::

    python -m lidartrees_gis.cli volume voo.laz parcelas_K.gpkg OUT.gpkg -stands talhoes.gpkg \
        -trees_table arvores_K.csv -plot_radius 11.28 -approach both -overwrite -q

and each stand's m³/ha (area-based and tree method) is compared with the generator's truth:
error %, within ±5 %, the 95 % interval holding the truth; and the farm's total m³ and its
interval. Results: ``benchmarks/results/volume2.json`` (one row per configuration, draw and
stand; no means across configurations).
Usage: ``python benchmarks/bench_volume2.py [--work /tmp/bench_volume2] [--draws 3]
[--configs NAME ...]``.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
CONFIGS = ("c1_base", "c2_young", "c3_dense_sparse", "c4_slope", "c5_missing", "c6_clones")


def _generate(work: Path, name: str, draws: int) -> Path:
    d = work / name
    for k in range(draws):
        if not (d / f"arvores_{k}.csv").exists():
            subprocess.run([sys.executable, str(HERE / "_volume_gen2.py"), "--config", name,
                            "--out", str(d), "--draw", str(k)], check=True,
                           stdout=subprocess.DEVNULL)
    return d


def _score(d: Path, k: int, out: Path, rc: int, err: str, seconds: float) -> list:
    import geopandas as gpd

    truth = json.loads((d / "truth.json").read_text(encoding="utf-8"))
    stands_truth = {str(s["talhao"]): s for s in truth["stands"]}
    rows = []
    if rc != 0:
        return [{"draw": k, "exit": rc, "error": err.strip().splitlines()[-1:]}]
    st = gpd.read_file(out, layer="stands")
    rep = json.loads(out.with_name(out.stem + "_report.json").read_text())
    warnings = [ln for ln in err.splitlines() if ": warning: " in ln]
    for _, s in st.iterrows():
        t = stands_truth[str(s["stand_id"])]
        true = float(t["vol_m3_ha"])
        row = {"draw": k, "stand": str(s["stand_id"]), "true_m3_ha": round(true, 1),
               "n_plots": int(s["n_plots"])}
        for pre, key in (("volume", "aba"), ("volume_trees", "trees")):
            v, lo, hi = (float(s[f"{pre}_m3_ha{x}"]) for x in ("", "_low", "_high"))
            row[key] = {"m3_ha": round(v, 1), "error_pct": round(100 * (v / true - 1), 2),
                        "within_5pct": bool(abs(v / true - 1) <= 0.05),
                        "holds_truth": bool(lo <= true <= hi),
                        "half_width_pct": round(100 * (hi - lo) / 2 / v, 2) if v > 0 else None,
                        "plots_weight": round(float(s[f"{pre}_plots_weight"]), 3)}
        rows.append(row)
    true_total = sum(float(t["vol_total_m3"]) for t in stands_truth.values())
    tot = {"draw": k, "farm_total": True, "true_m3": round(true_total, 1), "seconds": seconds,
           "warnings": warnings, "model": rep["volume_model"]["equation"],
           "loo_rmse_pct": rep["volume_model"]["loo_rmse_pct"],
           "trees_loo_rmse_pct": rep["tree_approach"].get("loo_rmse_pct")}
    for key, part in (("aba", rep), ("trees", rep["tree_approach"])):
        t, lo, hi = part["total_m3"], part["total_m3_low"], part["total_m3_high"]
        tot[key] = {"m3": round(t, 1), "error_pct": round(100 * (t / true_total - 1), 2),
                    "holds_truth": bool(lo <= true_total <= hi),
                    "half_width_pct": round(100 * (hi - lo) / 2 / t, 2)}
    return rows + [tot]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/bench_volume2")
    ap.add_argument("--draws", type=int, default=3)
    ap.add_argument("--configs", nargs="*", default=list(CONFIGS))
    ap.add_argument("--out", default=str(HERE / "results" / "volume2.json"))
    a = ap.parse_args(argv)
    work = Path(a.work)
    path = Path(a.out)
    res = json.loads(path.read_text()) if path.exists() else {}
    res["method"] = __doc__.split("\n\n")[1].replace("\n", " ")
    res.setdefault("results", {})
    for name in a.configs:
        d = _generate(work, name, a.draws)
        rows = []
        for k in range(a.draws):
            out = d / f"vol_{k}.gpkg"
            t0 = time.time()
            p = subprocess.run([sys.executable, "-m", "lidartrees_gis.cli", "volume",
                                str(d / "voo.laz"), str(d / f"parcelas_{k}.gpkg"), str(out),
                                "-stands", str(d / "talhoes.gpkg"), "-trees_table",
                                str(d / f"arvores_{k}.csv"), "-plot_radius", "11.28",
                                "-approach", "both", "-overwrite", "-q"],
                               capture_output=True, text=True)
            rows += _score(d, k, out, p.returncode, p.stderr, round(time.time() - t0, 1))
        stand_rows = [r for r in rows if "stand" in r]
        summary = {}
        for key in ("aba", "trees"):
            if stand_rows:
                summary[key] = {
                    "within_5pct": round(float(np.mean([r[key]["within_5pct"]
                                                        for r in stand_rows])), 3),
                    "coverage_95": round(float(np.mean([r[key]["holds_truth"]
                                                        for r in stand_rows])), 3),
                    "error_pct_mean_abs": round(float(np.mean([abs(r[key]["error_pct"])
                                                               for r in stand_rows])), 2)}
        res["results"][name] = {"rows": rows, "summary": summary}
        print(json.dumps({name: summary}), flush=True)
        path.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
