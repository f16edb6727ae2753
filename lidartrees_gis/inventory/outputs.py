"""What the ``volume`` command writes: the plots, stands and tree layers, the volume raster
(m³/ha per cell), and the model report (JSON, and a PNG of the plots' measured against
predicted volume beside each stand's figure and interval)."""
from __future__ import annotations

import json

import numpy as np

from ..errors import listing
from .models import CANDIDATES, total_interval

FIELD_DOCS = {
    "volume_m3_ha": "wood volume (m³/ha): measured (plots) or estimated (stands)",
    "volume_m3_ha_low": "lower end of the 95 % interval of volume_m3_ha",
    "volume_m3_ha_high": "upper end of the 95 % interval of volume_m3_ha",
    "volume_m3": "wood volume in the stand (m³) = volume_m3_ha x area_ha",
    "volume_m3_low": "lower end of the 95 % interval of volume_m3",
    "volume_m3_high": "upper end of the 95 % interval of volume_m3",
    "basal_area_m2_ha": "basal area (m²/ha)",
    "n_plots": "field plots in the stand", "n_plots_model": "field plots the model was fitted on",
    "volume_model_m3_ha": "the model's figure alone (m³/ha), before the stand's own plots "
                          "correct it",
    "volume_plots_weight": "weight (0-1) of the stand's own plots' departure from the model in "
                           "volume_m3_ha (0: the model's figure)",
    "predicted_m3_ha": "volume the model predicts for the plot (m³/ha)",
    "residual_m3_ha": "measured - predicted (m³/ha)",
    "loo_predicted_m3_ha": "volume predicted by the model fitted without this plot (m³/ha)",
    "data_cover_pct": "% of the stand the points cover (its m³/ha is that of this part)",
    "dap_cm": "DAP (cm) from the tree's height", "volume_m3": "tree volume (m³)",
}


#: every layer ``volume`` writes (``tree_tops`` with the tree approach only)
VOLUME_LAYERS = ("plots", "stands", "tree_tops")


def _stand_fields(prefix, est, area_ha):
    out = {}
    for key, suffix in (("estimate", ""), ("low", "_low"), ("high", "_high")):
        v = np.asarray(est[key], float)
        out[f"{prefix}_m3_ha{suffix}"] = np.round(v, 3)
        out[f"{prefix}_m3{suffix}"] = np.round(v * area_ha, 2)
    if "synthetic" in est:
        out[f"{prefix}_model_m3_ha"] = np.round(np.asarray(est["synthetic"], float), 3)
        out[f"{prefix}_plots_weight"] = np.round(np.asarray(est["plots_weight"], float), 3)
    return out


def _with_attributes(sdf, attributes, key="stand_id"):
    """The stands' (plots') own attributes (clone, age, the id field) after ``key``, as the
    trees command's stands layer has them; a name the layer uses for a figure gets
    ``_input``."""
    import pandas as pd

    if attributes is None or len(attributes) == 0:
        return sdf
    att = pd.DataFrame(list(attributes)) if not isinstance(attributes, pd.DataFrame) else \
        attributes.reset_index(drop=True)
    from ..plantation.stands import free_names

    att = att.rename(columns=free_names(att.columns, sdf.columns))
    return pd.concat([sdf[[key]], att, sdf.drop(columns=key)], axis=1)


def build(area, plots, stands, meas, pm, plot_stand, res_aba, res_trees, spec, cm, options,
          metric, r):
    """``(layers, report, volume grid or None)``."""
    import geopandas as gpd
    import pandas as pd

    figs = meas["figures"]
    ids = list(stands.ids)
    pdf = pd.DataFrame({"plot_id": list(plots.ids),
                        "stand_id": [ids[k] if k >= 0 else None for k in plot_stand],
                        "area_m2": np.round(plots.area_m2, 2)})
    for k in ("volume_m3_ha", "basal_area_m2_ha", "trees_ha", "n_trees", "mean_ht"):
        if k in figs:
            pdf[k] = np.round(figs[k], 4) if k != "n_trees" else \
                np.asarray(figs[k]).astype(np.int64)
    report = {"approach": options.approach, "plots": len(plots), "stands": len(stands),
              "plot_area_m2": float(np.mean(plots.area_m2)), "cell_res_m": spec.res,
              "metrics": {"min_height": metric.min_height, "returns": metric.returns,
                          "points": r["points"]}, "bootstrap_resamples": options.resamples,
              "estimate": "the model's stand mean plus the stand's own plots' mean residual "
                          "times its weight (stand-level EBLUP: between-stand variance / "
                          "(between-stand variance + the mean residual's variance))",
              "interval": "95 %: estimate ± t(0.975, n-p-1)·sqrt(bootstrap variance over the "
                          "plots (model chosen again and refitted) + the corrected stand's "
                          "departure variance + residual variance / cells), the departure "
                          "and residual from each plot predicted by the model chosen and "
                          "fitted without it"}
    if meas["trees"] is not None:
        t = meas["trees"]
        eq = t["equation"]
        report["field"] = {"trees": int(t["dap"].size), "heights_estimated":
                           int(t["ht_estimated"].sum()), "hypsometric": t["hypsometric"],
                           "volume_equation": None if eq is None else
                           {"form": "V = b0·DAP^b1·HT^b2", "b0": eq.b0, "b1": eq.b1,
                            "b2": eq.b2, "source": eq.source}}
    else:
        report["field"] = {"plot_volume_field": meas.get("volume_field")}
    sdf = pd.DataFrame({"stand_id": ids, "area_ha": np.round(stands.area_ha, 4),
                        "n_plots": np.bincount(plot_stand[plot_stand >= 0],
                                               minlength=len(ids)),
                        "n_plots_model": len(plots)})
    if r.get("stand_cover") is not None:  # each stand's share the points cover
        sdf["data_cover_pct"] = np.round(100 * np.asarray(r["stand_cover"], float), 1)
    if r.get("coverage") is not None:
        report["metrics"]["cells_left_out"] = int(r["cells_left_out"])
    vol_grid = None
    for m in CANDIDATES:
        pdf[m] = np.round(pm[m], 4)
    if "volume" in res_aba:
        model, table, est = res_aba["volume"]
        pdf["predicted_m3_ha"] = np.round(model.stats["fitted"], 3)
        pdf["residual_m3_ha"] = np.round(figs["volume_m3_ha"] - model.stats["fitted"], 3)
        pdf["loo_predicted_m3_ha"] = np.round(model.stats["loo"], 3)
        for k, v in _stand_fields("volume", est, stands.area_ha).items():
            sdf[k] = v
        sdf["cells"] = np.round(est["cells"], 2)  # area in cells (pieces by area)
        vol_grid = np.maximum(model.predict(cm), 0.0).reshape(spec.shape)
        report["volume_model"] = _model_report(model, table, est)
    if "basal_area" in res_aba:
        model, table, est = res_aba["basal_area"]
        sdf["basal_area_m2_ha"] = np.round(est["estimate"], 3)
        sdf["basal_area_m2_ha_low"] = np.round(est["low"], 3)
        sdf["basal_area_m2_ha_high"] = np.round(est["high"], 3)
        report["basal_area_model"] = _model_report(model, table, est)
        tot = total_interval(est, stands.area_ha)  # m² of basal area in the stands
        report["basal_area_model"].update({"total_m2": tot["total"], "total_m2_low": tot["low"],
                                           "total_m2_high": tot["high"]})
    layers = {}
    if res_trees is not None:
        ts = res_trees["stands"]
        pdf["detected_m3_ha"] = np.round(res_trees["detected_m3_ha"], 3)
        pdf["detected_trees_ha"] = np.round(res_trees["detected_trees_ha"], 1)
        pdf["trees_loo_predicted_m3_ha"] = np.round(ts["loo"], 3)
        prefix = "volume" if "volume" not in res_aba else "volume_trees"
        for k, v in _stand_fields(prefix, ts, stands.area_ha).items():
            sdf[k] = v
        eq = res_trees["equation"]
        report["tree_approach"] = {
            "dap_height": res_trees["dap_height"],
            "volume_equation": {"b0": eq.b0, "b1": eq.b1, "b2": eq.b2, "source": eq.source},
            "ratio_field_to_detected": ts["ratio"], "sigma2_stand": ts["sigma2_stand"],
            "stands_differ_test": ts.get("stand_test"),
            **{k[5:]: v for k, v in ts.items() if k.startswith("plot_")}}
        tops = res_trees["tops"]
        layers["tree_tops"] = tops
    sdf = _with_attributes(sdf, stands.attributes)
    pdf = _with_attributes(pdf, plots.attrs, "plot_id")
    layers = {"plots": gpd.GeoDataFrame(pdf, geometry=list(plots.geoms), crs=area.crs),
              "stands": gpd.GeoDataFrame(sdf, geometry=list(stands.geoms), crs=area.crs),
              **layers}
    # the stands' total with its interval: the area-based figure's, else the trees'
    for part, est in ((report, res_aba.get("volume", (None, None, None))[2]),
                      (report.get("tree_approach"), None if res_trees is None
                       else res_trees["stands"])):
        if part is not None and est is not None:
            tot = total_interval(est, stands.area_ha)
            part.update({"total_m3": tot["total"], "total_m3_low": tot["low"],
                         "total_m3_high": tot["high"]})
            if "total_m3" not in report:
                report.update({k: part[k] for k in ("total_m3", "total_m3_low",
                                                    "total_m3_high")})
    if "total_m3" in report:  # the stands the total leaves out (no figure: not flown)
        report["total_left_out"] = [str(s) for s, v in zip(sdf["stand_id"], sdf["volume_m3"])
                                    if not np.isfinite(v)]
    return layers, report, vol_grid


def total_line(report) -> str:
    """The stands' total on one line: ``5321 m³ ±6.1 % (4996-5646)`` (the area-based figure's;
    with both approaches the tree method's after it)."""
    def one(r):
        t, lo, hi = r["total_m3"], r.get("total_m3_low"), r.get("total_m3_high")
        if lo is None or not (np.isfinite(lo) and np.isfinite(hi)) or t <= 0:
            return f"{t:.0f} m³ (no interval)"
        return f"{t:.0f} m³ ±{100 * (hi - lo) / 2 / t:.1f} % ({lo:.0f}-{hi:.0f})"

    text = one(report)
    tr = report.get("tree_approach") or {}
    if "volume_model" in report and "total_m3" in tr:
        text = f"area-based {text}; tree method {one(tr)}"
    out = report.get("total_left_out")
    if out:
        text += f"; without {listing(out, 8)} (no figure)"
    return text


def stand_lines(stands, approach: str = "aba") -> dict:
    """Each stand's figures on one line (the CLI's ``stand ID: ...``): volume per ha (with
    the interval's half-width in %, the sampling error a report gives) and in the stand with
    their 95 % intervals, by the area-based model and/or the tree method, the model's figure
    and the plots' weight where the stand's own plots moved it, the basal area, the plots."""
    def num(v, places=1):
        return "-" if v is None or not np.isfinite(v) else f"{v:.{places}f}"

    def span(lo, hi, places=1, extra=""):  # never a nan on the page
        if not (np.isfinite(lo) and np.isfinite(hi)):
            return f"(no interval{extra})"
        return f"({lo:.{places}f}-{hi:.{places}f}{extra})"

    out = {}
    for _, r in stands.iterrows():
        parts = []
        for pre in ("volume", "volume_trees"):
            if f"{pre}_m3_ha" not in r:
                continue
            what = "tree method" if pre == "volume_trees" or approach == "trees" \
                else "area-based"
            est, lo, hi = r[f"{pre}_m3_ha"], r[f"{pre}_m3_ha_low"], r[f"{pre}_m3_ha_high"]
            if not np.isfinite(est):
                parts.append(f"{what}: no figure (no cell of the plots' size in the stand)")
                continue
            # the half-width in % of the figure: the sampling error a report gives
            half = 100 * (hi - lo) / 2 / est if est > 0 else np.nan
            err = f" ±{half:.1f} %" if np.isfinite(half) else ""
            w = r.get(f"{pre}_plots_weight")
            moved = (f"; model {num(r[f'{pre}_model_m3_ha'])}, its plots' weight {w:.2f}"
                     if w is not None and w > 0 else "")
            parts.append(f"{what} {est:.1f} m³/ha{err} {span(lo, hi, 1, moved)}, "
                         f"{num(r[f'{pre}_m3'], 0)} m³ "
                         f"{span(r[f'{pre}_m3_low'], r[f'{pre}_m3_high'], 0)}")
        if "basal_area_m2_ha" in r:
            parts.append(f"basal area {num(r['basal_area_m2_ha'])} m²/ha")
        parts.append(f"{r['area_ha']:.2f} ha, {int(r['n_plots'])} plot"
                     f"{'' if int(r['n_plots']) == 1 else 's'}")
        out[f"stand {r['stand_id']}"] = "; ".join(parts)
    return out


def _model_report(model, table, est) -> dict:
    s = model.stats
    keep = ("r2", "adj_r2", "rmse", "rmse_pct", "bias", "bias_pct", "loo_rmse", "loo_rmse_pct",
            "loo_bias", "loo_r2")
    return {"form": model.form, "predictors": list(model.predictors),
            "equation": model.equation(), "coefficients": [float(c) for c in model.coef],
            "residual_variance": model.s2, "plots": model.n,
            **{k: round(float(s[k]), 4) for k in keep},
            "selection": {"criterion": "leave-one-out RMSE", "candidates": list(CANDIDATES),
                          "best_by_size": table},
            "procedure_loo_rmse_pct": round(float(est["procedure_loo_rmse_pct"]), 4),
            "sigma2_stand": est["sigma2_stand"], "departures": est["departures"],
            "bootstrap_refits": est["resamples"],
            "stands_differ_test": est.get("stand_test")}


def _draw(report, y, fit, loo, trees_loo=None):
    """The measured plots against the model's fitted and leave-one-out predictions (and the
    tree method's leave-one-out figures)."""
    m = report.get("volume_model")

    def draw(ax):
        pts = [np.asarray(v, float) for v in (y, fit, loo, trees_loo) if v is not None]
        lo, hi = 0.0, float(max(np.nanmax(v) for v in pts)) * 1.08
        ax.plot([lo, hi], [lo, hi], color="0.5", lw=1, label="1:1")
        if m is not None:
            ax.scatter(y, fit, s=28, color="tab:green", label="area-based, fitted")
            ax.scatter(y, loo, s=18, facecolors="none", edgecolors="tab:red",
                       label="area-based, leave-one-out")
        if trees_loo is not None:
            ax.scatter(y, trees_loo, s=22, marker="^", color="tab:blue",
                       label="tree method, leave-one-out")
        ax.set_xlim(lo, hi), ax.set_ylim(lo, hi)
        ax.set_xlabel("measured volume (m³/ha)")
        ax.set_ylabel("predicted volume (m³/ha)")
        if m is not None:
            ax.set_title(f"{m['form']}: {', '.join(m['predictors'])} ({m['plots']} plots)",
                         fontsize=9)
            ax.text(0.03, 0.97, f"R² {m['r2']:.3f} (adj. {m['adj_r2']:.3f})\n"
                    f"RMSE {m['rmse_pct']:.1f} %  bias {round(m['bias_pct'], 2) + 0.0:+.2f} %\n"
                    f"LOO R² {m['loo_r2']:.3f}\n"
                    f"LOO RMSE {m['loo_rmse_pct']:.1f} %, {m['procedure_loo_rmse_pct']:.1f} % "
                    "with the choice redone",
                    transform=ax.transAxes, va="top", fontsize=9)
        else:
            t = report.get("tree_approach", {})
            ax.set_title(f"tree method ({report['plots']} plots)", fontsize=9)
            if t.get("loo_rmse_pct") is not None:
                ax.text(0.03, 0.97, f"LOO RMSE {t['loo_rmse_pct']:.1f} %",
                        transform=ax.transAxes, va="top", fontsize=9)
        ax.legend(loc="lower right", fontsize=8)
    return draw


#: the stands panel writes each stand's figures beside its interval up to this many stands
STAND_LABELS = 30


def _draw_stands(stands):
    """Each stand's m³/ha and its 95 % interval, area-based and tree method side by side, with
    the figures written beside them (up to :data:`STAND_LABELS` stands)."""
    keys = [(p, lab, c) for p, lab, c in (("volume", "area-based", "tab:red"),
                                          ("volume_trees", "tree method", "tab:blue"))
            if f"{p}_m3_ha" in stands.columns]
    names = [str(s) for s in stands["stand_id"]]
    n = len(names)

    def draw(ax):
        pos = np.arange(n)
        off = np.linspace(-0.15, 0.15, len(keys)) if len(keys) > 1 else [0.0]
        top = 0.0
        for (p, lab, c), d in zip(keys, off):
            v = stands[f"{p}_m3_ha"].to_numpy(float)
            lo = stands[f"{p}_m3_ha_low"].to_numpy(float)
            hi = stands[f"{p}_m3_ha_high"].to_numpy(float)
            ok = np.isfinite(v)
            if len(keys) == 1:
                lab = "estimate and 95 % interval"
            ax.errorbar(v[ok], pos[ok] + d, xerr=[v[ok] - lo[ok], hi[ok] - v[ok]], fmt="o",
                        ms=4, color=c, capsize=2, lw=1, label=lab)
            top = max(top, float(np.nanmax(hi[ok]))) if ok.any() else top
            if n <= STAND_LABELS:  # the figures beside each interval, as the table has them
                for k in np.nonzero(ok)[0]:
                    ax.text(hi[k], pos[k] + d, f"  {v[k]:.0f} ({lo[k]:.0f}-{hi[k]:.0f})",
                            va="center", fontsize=6, color=c)
        ax.set_yticks(pos)
        ax.set_yticklabels(names, fontsize=max(5, min(9, int(400 / max(n, 1)))))
        ax.set_ylim(n - 0.5, -0.5)
        ax.set_xlim(0, top * (1.45 if n <= STAND_LABELS else 1.05) if top > 0 else None)
        ax.set_xlabel("volume (m³/ha), 95 % interval")
        ax.set_title(f"stands ({n})", fontsize=9)
        ax.grid(axis="x", color="0.9")
        ax.legend(loc="lower right", fontsize=8)
    return draw


def _total_row(stands, report) -> dict:
    """The table's last row, ``stand_id`` ``total``: the stands with a figure, their area, plots
    and total m³ with its 95 % interval (:func:`models.total_interval`, not the sum of the
    stands' ends), and the m³/ha those make over that area; the basal area per ha over it the
    same way."""
    left = set(report.get("total_left_out", []))
    keep = ~stands["stand_id"].astype(str).isin(left).to_numpy()
    area = float(stands["area_ha"].to_numpy(float)[keep].sum())
    row = {"stand_id": "total", "area_ha": round(area, 4),
           "n_plots": int(stands["n_plots"].sum())}
    # the first figure's total is the report's own (area-based, else the tree method's)
    parts = [("volume", report)]
    if "volume_trees_m3" in stands.columns:
        parts.append(("volume_trees", report["tree_approach"]))
    for prefix, part in parts:
        if "total_m3" not in part:
            continue
        for end in ("", "_low", "_high"):
            v = float(part[f"total_m3{end}"])
            row[f"{prefix}_m3{end}"] = round(v, 1)
            row[f"{prefix}_m3_ha{end}"] = round(v / area, 3) if area > 0 else None
    ba = report.get("basal_area_model", {})
    if "total_m2" in ba and area > 0:  # the stands' basal area per ha, with its interval
        for end in ("", "_low", "_high"):
            row[f"basal_area_m2_ha{end}"] = round(float(ba[f"total_m2{end}"]) / area, 3)
    return row


def write(output, side, layers, report, spec, vol_grid, res_aba, out, input, area,
          stand_csv=None) -> dict:
    """Every output, each atomically; the side files are removed again when a later one
    fails (no half set of outputs). Returns the side files written, by their key in
    ``side`` (and ``stand_csv``)."""
    import contextlib
    import os

    from ..io.output import atomic_output
    from ..io.provenance import raster_tags
    from ..io.raster import write_geotiff
    from ..io.vector import describe_columns, write_gpkg
    from ..report.plots import plot_png

    done = {}
    try:
        if vol_grid is not None:
            write_geotiff(side["raster"], vol_grid, spec, overwrite=out.overwrite,
                          creation_options=out.creation_options, description="volume (m³/ha)",
                          tags=raster_tags("volume", area, {"res": spec.res}, input))
            done["raster"] = side["raster"]
        with atomic_output(side["json"], out.overwrite, param="report") as tmp:
            tmp.write_text(json.dumps(report, indent=1, default=float), encoding="utf-8")
        done["json"] = side["json"]
        pl = layers["plots"]
        if "volume" in res_aba or "trees_loo_predicted_m3_ha" in pl.columns:
            model = res_aba["volume"][0] if "volume" in res_aba else None
            y = pl["volume_m3_ha"].to_numpy(float)
            tl = pl["trees_loo_predicted_m3_ha"].to_numpy(float) \
                if "trees_loo_predicted_m3_ha" in pl.columns else None
            fit = _draw(report, y, None if model is None else model.stats["fitted"],
                        None if model is None else model.stats["loo"], tl)
            n = len(layers["stands"])
            plot_png(side["png"], [fit, _draw_stands(layers["stands"])], widths=[1, 1],
                     size=(12, max(6.0, min(40.0, 1.0 + 0.22 * n))), dpi=150,
                     overwrite=out.overwrite)  # 1800 px wide: a report's page width
            done["png"] = side["png"]
        if stand_csv is not None:
            from ..io.tables import write_table

            rows = layers["stands"].drop(columns="geometry").to_dict("records")
            rows.append(_total_row(layers["stands"], report))
            with atomic_output(stand_csv, out.overwrite, param="-stand_csv") as tmp:
                write_table(tmp, rows, text=("stand_id",), options=out.table, name="stands")
            done["stand_csv"] = stand_csv
        write_gpkg(output, layers, overwrite=out.overwrite, layer_options=out.layer_options,
                   metadata={"volume_report": report},
                   styles={"stands": "volume_stands.qml", "tree_tops": "tree_tops.qml",
                           "plots": "volume_plots.qml"}, owned=VOLUME_LAYERS)
        for layer in ("plots", "stands"):
            describe_columns(output, layer, FIELD_DOCS)
    except BaseException:
        for p in done.values():
            with contextlib.suppress(OSError):
                os.unlink(p)
        raise
    return done
