"""Wood volume per stand against the truth of generated farms with stems (issue 40).

Each configuration is a farm of 3 x 2 square stands of 280 m (47 ha; ``lidartrees_gis.synthetic
.make_farm``: clonal stands of different heights, DAP from height with clone-like scatter,
Schumacher-Hall volume, heights above a flat ground) at 8 and 4 points/m², with circular 400 m²
plots at 1 per 6 ha (8 plots: one per stand and two more, not overlapping), their trees measured
as a crew does (DAP to 0.1 cm, HT on 40 % of the trees, the others from the hypsometric
relation; plot volume by the generator's Schumacher-Hall equation).

The points are read and their metrics computed once per configuration by the command's own
chain (``inventory.tiles.area_metrics``: 20 m cells and the plots of every draw in one pass),
the trees detected once (``trees`` chain); then for each of ``--draws`` plot draws the volume
command's estimators run on that draw's plots (``models.select_model`` / ``aba_stands`` for the
area-based approach, ``fit_dap_height`` / ``ratio_stands`` for the tree approach). Per
configuration: stand volume error % against the truth (mean, mean |error|, max |error|, share of
stands within ±5 %), the 95 % intervals' coverage of the true stand volume over stands x draws,
their mean half-width %, the plots' leave-one-out RMSE (the chosen model's and, with the
choice redone without each plot, the procedure's), and the same for the farm's total m³
(``models.total_interval``: error %, coverage over draws, half-width %).

Usage: python benchmarks/bench_volume.py [--configs 0 1 ...] [--densities 8 4] [--draws 20]
Results are merged into benchmarks/results/volume.json (one key per configuration and density),
so the configurations can be run in several short invocations.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lidartrees_gis.synthetic import (CRS, SCHUMACHER, FarmParams, farm_plots,  # noqa: E402
                                      make_farm, plot_trees)

BASE = FarmParams(cols=3, rows=2, side=280.0)
CONFIGS = [
    ("base 3x2, heights 14-30 m", BASE),
    ("3x3 spacing", replace(BASE, tree_spacing=3.0, seed=1)),
    ("site effect: DAP-height 8 % per stand", replace(BASE, site_cv=0.08, seed=2)),
    ("young 8-16 m", replace(BASE, heights=(8.0, 16.0), seed=3)),
    ("10 % missing, 12 % suppressed", replace(BASE, missing=0.10, suppressed=0.12, seed=4)),
    ("tall 22-34 m, 3.5x2.5", replace(BASE, heights=(22.0, 34.0), row_spacing=3.5,
                                      tree_spacing=2.5, seed=5)),
]
RADIUS = 11.28
PER_HA = 1 / 6.0


def _write(d, pts, truth):
    import geopandas as gpd
    import pyproj
    import shapely

    from lidartrees_gis.io.lasout import write_points

    write_points(d / "farm.laz", pts.x, pts.y, pts.z, crs=pyproj.CRS(CRS),
                 classification=pts.classification)
    boxes = truth["stands"]["box"]
    gpd.GeoDataFrame({"talhao": [f"T{k + 1}" for k in range(len(boxes))]},
                     geometry=[shapely.box(*b) for b in boxes], crs=CRS).to_file(d / "stands.gpkg")


def _summary(est, low, high, true):
    err = 100 * (est / true - 1)
    cov = (low <= true) & (true <= high)
    half = 100 * (high - low) / 2 / true
    return {"error_pct_by_stand": [round(float(v), 2) for v in np.mean(err, axis=0)],
            "error_pct_sd_by_stand": [round(float(v), 2) for v in np.std(err, axis=0)],
            "error_pct_mean": round(float(np.mean(err)), 2),
            "error_pct_mean_abs": round(float(np.mean(np.abs(err))), 2),
            "error_pct_max_abs": round(float(np.max(np.abs(err))), 2),
            "within_5pct": round(float(np.mean(np.abs(err) <= 5)), 3),
            "coverage_95": round(float(np.mean(cov)), 3),
            "half_width_pct_mean": round(float(np.mean(half)), 2)}


def _total_summary(rows, true):
    t, lo, hi = np.asarray(rows, float).T
    err = 100 * (t / true - 1)
    return {"true_m3": round(true, 1), "error_pct_mean": round(float(np.mean(err)), 2),
            "error_pct_max_abs": round(float(np.max(np.abs(err))), 2),
            "coverage_95": round(float(np.mean((lo <= true) & (true <= hi))), 3),
            "half_width_pct_mean": round(float(np.mean(100 * (hi - lo) / 2 / true)), 2)}


def run_config(name, p, density, draws, resamples):
    import pyproj

    from lidartrees_gis.als.chain import trees_run
    from lidartrees_gis.plantation.stands import load_stands
    from lidartrees_gis.catalog.catalog import Catalog, TilingOptions
    from lidartrees_gis.inventory.field import Equation, complete_trees, plot_figures
    from lidartrees_gis.inventory.models import (aba_stands, fit_dap_height, ratio_stands,
                                                 select_model, total_interval)
    from lidartrees_gis.inventory.plots import Zones
    from lidartrees_gis.inventory.tiles import area_metrics
    from lidartrees_gis.inventory.volume import stand_cells, unit_metrics
    from lidartrees_gis.io.options import ReadOptions

    t0 = time.time()
    p = replace(p, density=density)
    pts, truth = make_farm(p)
    true_v = truth["stands"]["volume_m3_ha"]
    eq = Equation(*SCHUMACHER)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _write(d, pts, truth)
        area = Catalog.open(d / "farm.laz", ReadOptions())
        st = load_stands(d / "stands.gpkg", area.crs)
        plot_sets = [farm_plots(p, PER_HA, RADIUS, seed=k) for k in range(draws)]
        zones = [Zones(np.asarray([None] * len(x), dtype=object), x, y, np.full(len(x), RADIUS))
                 for x, y, _ in plot_sets]
        import shapely

        zones = [replace(z, geoms=np.asarray(shapely.buffer(shapely.points(z.x, z.y), RADIUS,
                                                            quad_segs=16)))
                 for z in zones]
        one = TilingOptions(workers=1)  # one core: the machine is shared
        _, cell_stand, pieces, _ = stand_cells(area, 20.0, st.geoms)
        r = area_metrics(area, cells_res=20.0, zones=[*zones, pieces], tiling=one)
        stand_zones = Zones.of_polygons(st.geoms)
        _, cm, _ = unit_metrics(r, pieces)
        t_metrics = time.time() - t0
        tr = trees_run(d / "farm.laz", None, stands=d / "stands.gpkg", tiling=one)
        tops = tr["layers"]["tree_tops"]
    t_trees = time.time() - t0 - t_metrics
    h = tops["height"].to_numpy(float)
    tx, ty = tops.geometry.x.to_numpy(), tops.geometry.y.to_numpy()
    sid = stand_zones.members(tx, ty)
    area_m2 = np.pi * RADIUS ** 2
    aba, trees, loo = {"est": [], "low": [], "high": []}, {"est": [], "low": [], "high": []}, []
    loo_trees, loo_proc, chosen = [], [], {}
    totals = {"aba": [], "trees": []}  # (total, low, high) of each draw
    for k, ((x, y, _), z, pm) in enumerate(zip(plot_sets, zones, r["zones"])):
        rows = plot_trees(truth, x, y, RADIUS, ht_share=0.4, seed=k)
        ft = {"plot": rows["parcela"].astype(int).astype(str).astype(object),
              "tree": rows["arvore"].astype(str), "dap": rows["dap"].astype(float),
              "ht": rows["ht"].astype(float), "volume": np.full(rows["dap"].size, np.nan),
              "path": "generated"}
        ft = complete_trees(ft, eq)
        ids = [str(i + 1) for i in range(len(x))]
        figs = plot_figures(ft, ids, np.full(len(x), area_m2))
        y_v, noise = figs["volume_m3_ha"], figs["sampling_var_m3_ha"]
        plot_stand = stand_zones.members(x, y)
        model, _ = select_model(pm, y_v)
        key = f"{model.form}: {' + '.join(model.predictors)}"
        chosen[key] = chosen.get(key, 0) + 1
        e = aba_stands(model, pm, y_v, cm, cell_stand, len(st), plot_stand, plot_noise=noise,
                       resamples=resamples, seed=k)
        for a in ("est", "low", "high"):
            aba[a].append(e["estimate" if a == "est" else a])
        t = total_interval(e, st.area_ha)
        totals["aba"].append((t["total"], t["low"], t["high"]))
        loo.append(model.stats["loo_rmse_pct"])
        loo_proc.append(e["procedure_loo_rmse_pct"])
        # tree approach
        measured = ~ft["ht_estimated"]
        a_, b_, s2, _ = fit_dap_height(ft["dap"][measured], ft["ht"][measured])
        vol = eq(np.exp(a_ + b_ * np.log(np.maximum(h, 1.3)) + s2 / 2), h)
        det = z.counts(tx, ty, vol) / (area_m2 / 1e4)
        ok = sid >= 0
        sdet = np.bincount(sid[ok], weights=vol[ok], minlength=len(st)) / st.area_ha
        rt = ratio_stands(y_v, det, sdet, plot_stand, plot_noise=noise, resamples=resamples,
                          seed=k)
        for a in ("est", "low", "high"):
            trees[a].append(rt["estimate" if a == "est" else a])
        t = total_interval(rt, st.area_ha)
        totals["trees"].append((t["total"], t["low"], t["high"]))
        loo_trees.append(rt["plot_loo_rmse_pct"])
    tv = np.tile(true_v, (draws, 1))
    true_total = float(np.sum(true_v * st.area_ha))
    out = {"config": name, "density": density, "points": int(len(pts.x)),
           "stands": len(st), "area_ha": round(float(np.sum(st.area_ha)), 2),
           "plots_per_draw": len(plot_sets[0][0]), "draws": draws,
           "bootstrap_resamples": resamples,
           "true_volume_m3_ha": [round(float(v), 1) for v in true_v],
           "aba": {**_summary(np.array(aba["est"]), np.array(aba["low"]),
                              np.array(aba["high"]), tv),
                   "loo_rmse_pct_mean": round(float(np.mean(loo)), 2),
                   "loo_rmse_pct_max": round(float(np.max(loo)), 2),
                   "procedure_loo_rmse_pct_mean": round(float(np.mean(loo_proc)), 2),
                   "procedure_loo_rmse_pct_max": round(float(np.max(loo_proc)), 2),
                   "models_chosen": chosen,
                   "total": _total_summary(totals["aba"], true_total)},
           "trees": {**_summary(np.array(trees["est"]), np.array(trees["low"]),
                                np.array(trees["high"]), tv),
                     "loo_rmse_pct_mean": round(float(np.mean(loo_trees)), 2),
                     "total": _total_summary(totals["trees"], true_total),
                     "detected_trees": int(len(tops)),
                     "true_trees": int(truth["trees"]["x"].size)},
           "seconds": {"metrics": round(t_metrics, 1), "trees": round(t_trees, 1),
                       "total": round(time.time() - t0, 1)}}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", type=int, nargs="*", default=list(range(len(CONFIGS))))
    ap.add_argument("--densities", type=float, nargs="*", default=[8.0, 4.0])
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--resamples", type=int, default=400)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "volume.json"))
    a = ap.parse_args(argv)
    path = Path(a.out)
    res = json.loads(path.read_text()) if path.exists() else {}
    res["method"] = __doc__.split("\n\n")[1].replace("\n", " ")
    res.setdefault("results", {})
    for c in a.configs:
        for dens in a.densities:
            name, p = CONFIGS[c]
            r = run_config(name, p, dens, a.draws, a.resamples)
            res["results"][f"{c}:{name} @ {dens:g} pts/m2"] = r
            print(json.dumps({k: r[k] for k in ("config", "density", "aba", "trees",
                                                "seconds")}), flush=True)
            path.write_text(json.dumps(res, indent=1, sort_keys=False))
    rs = list(res["results"].values())
    if rs:
        res["summary"] = {
            "configurations": len(rs),
            "aba_within_5pct": round(float(np.mean([r["aba"]["within_5pct"] for r in rs])), 3),
            "aba_coverage_95": round(float(np.mean([r["aba"]["coverage_95"] for r in rs])), 3),
            "aba_loo_rmse_pct_mean": round(float(np.mean([r["aba"]["loo_rmse_pct_mean"]
                                                          for r in rs])), 2),
            "aba_procedure_loo_rmse_pct_mean": round(float(np.mean(
                [r["aba"].get("procedure_loo_rmse_pct_mean", np.nan) for r in rs])), 2),
            "trees_within_5pct": round(float(np.mean([r["trees"]["within_5pct"] for r in rs])),
                                       3),
            "trees_coverage_95": round(float(np.mean([r["trees"]["coverage_95"] for r in rs])),
                                       3),
            **{f"{a}_total_{k}": round(float(np.mean([r[a]["total"][k] for r in rs
                                                       if "total" in r[a]])), 3)
               for a in ("aba", "trees") for k in ("coverage_95", "half_width_pct_mean")
               if any("total" in r[a] for r in rs)}}
        path.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
