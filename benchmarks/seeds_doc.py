"""docs/SEEDS.md written from benchmarks/results/seeds.json (``bench_seeds.py`` calls it): every
figure on the page is the benchmark's; the words around them are fixed, and the sentences that
say whether a paper's finding holds are decided from the figures.

Usage: python benchmarks/seeds_doc.py [benchmarks/results/seeds.json] [docs/SEEDS.md]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _f(v, fmt="{:.2f}"):
    return "n/a" if v is None else fmt.format(v)


def _table1(res) -> list:
    t = res.get("castro_table1")
    if not t:
        return []
    paper = res["papers"]["castro_table1"]
    names = list(t)
    out = ["## Seed 000 (Castro 2006): Table 1, `lidartrees compare`", "",
           "`compare` with its defaults (seed 000's surface, strict tops). Trees per configuration:",
           "", "| configuration | paper (50 x 50 m) | " + " | ".join(names) + " |",
           "|---|---|" + "---|" * len(names)]
    for k, v in paper.items():
        out.append(f"| {k} | {v} | " + " | ".join(str(t[n]["trees"].get(k, "")) for n in names) + " |")
    out.append("")
    for n in names:
        miss = t[n]["orderings_not_holding"]
        prov = "; ".join(f"{k}: {t[n][k]}" for k in ("surface", "ground", "res") if k in t[n])
        out.append(f"- {n}: " + ("every ordering of Table 1 holds" if not miss
                                  else "orderings not holding: " + "; ".join(miss))
                   + (f" ({prov})" if prov else "") + ".")
    return out + [""]


def _treex(res) -> list:
    t, o = res.get("treex"), res.get("treex_offsets")
    if not t:
        return []
    paper = res["papers"]["treex_count_error_pct"]
    out = ["## Seed 001 (TreeX): `-method treex`", "",
           "The search window is the square whose area is the mean crown area (`-mean_crown_area`, "
           "6 m²), moved by the side of the square whose area is the crown-area standard deviation "
           "(`-sd_crown_area`, 2 m²); the highest cell of each window position at or above the "
           "minimum tree height is a top, as the paper writes (its Figure 1, the mask, is not in "
           "the text: the paper gives the window's area, not its sides). The windows start at the "
           "first cell of the area's height model, as the paper moves its window over the image, "
           "and every tile of an area sees the same windows. `-method treex` and `-method watershed` run on the raw height model, "
           "as their papers; `-smooth` smooths it when asked.", "",
           "| stand | truth | configuration | trees | count error | F-score |",
           "|---|---|---|---|---|---|"]
    for stand, row in t.items():
        for label, r in row.items():
            if label == "truth":
                continue
            out.append(f"| {stand} | {row['truth']} | {label} (smooth {r.get('smooth', '?')}, "
                       f"{r['res']} m) | {r['trees']} | {r['count_error_pct']:+.1f} % | "
                       f"{r['f_score']:.3f} |")
    auto = [r["-smooth auto"]["smooth"] for r in t.values() if "-smooth auto" in r]
    if auto and all(a == "none" for a in auto):
        out.append("\n`-smooth auto` chooses no smoothing on these stands (its Gaussian would be "
                   "under a third of a cell), so its rows are the raw surface's.")
    out.append("")
    if o:
        lo, hi = o["count_error_pct_min"], o["count_error_pct_max"]
        within = lo <= paper <= hi
        out += [f"**Sensitivity to the window layout.** On the demo stand ({o['truth']} trees, "
                f"{o['res']} m cells, a {o['window_cells']}-cell window moved by "
                f"{o['step_cells']} cells), shifting the windows by 0-5 cells in rows and columns "
                f"({o['layouts']} layouts, the same raw surface) gives a count error of "
                f"**{o['count_error_pct_mean']:+.1f} % ± {o['count_error_pct_sd']:.1f} %** (mean ± "
                f"standard deviation; range {lo:+.1f} % to {hi:+.1f} %); the layout a run uses "
                f"gives {o['count_error_pct_as_run']:+.1f} %. Along the diagonal (0, 0) ... (5, 5): "
                + ", ".join(f"{v:+.1f} %" for v in o["diagonal_0_5_pct"]) + ". "
                + (f"The paper's +{paper:g} % lies within that range: a single count by this "
                   "rule depends on where its windows fall by the spread above, so the paper's "
                   "figure and a run's are each one draw of it; compare means, not single counts."
                   if within else
                   f"The paper's +{paper:g} % lies outside that range: on this stand TreeX's rule "
                   "counts differently from the paper's plots whatever the layout."), ""]
    return out


def _quality(res) -> list:
    q = res.get("leite_dtm_quality")
    if not q:
        return []
    out = ["## Seed 003 (Leite et al.): `lidartrees dtm-quality`", "",
           "The paper's sweep (77 (g, w), robust interpolation, GLCM texture, PCA, k-means). A DTM "
           "is *incomplete* with fewer than 1 ground point per 10 m² of the data or under 90 % of "
           "its cells covered; a member of the smooth (good) texture cluster farther from the "
           "sweep's consensus (the per-cell median of the complete DTMs) than the cluster's median "
           "distance plus a margin (at least 0.25 m) is an *outlier*. `rank` orders good, noisy, "
           "then outliers; `why` says why. With a reference (the file's class-2 points), the "
           "recommended DTM is the closest complete one.", "",
           "| data | cell (m) | good / noisy / outlier / incomplete | g = -w in good | "
           "recommended: RMSE to the reference | worst good / recommended | good under 1 pt/10 m² "
           "| sweep's pick among the complete DTMs by RMSE |",
           "|---|---|---|---|---|---|---|---|"]
    for name, r in q.items():
        c = r["clusters"]
        out.append(f"| {name} | {r['res']} | {c.get('good', 0)} / {c.get('noisy', 0)} / "
                   f"{c.get('outlier', 0)} / {c.get('incomplete', 0)} | "
                   f"{r['g_equals_minus_w_in_good']} | {_f(r.get('recommended_rmse'), '{:.3f}')} m "
                   f"(g={r['recommended_g']:g}, w={r['recommended_w']:g}) | "
                   f"{_f(r.get('good_worst_over_recommended'))} | {r.get('good_under_1_per_10_m2', 'n/a')} | "
                   f"{r.get('sweep_pick_reference_rank', 'n/a')} |")
    out.append("")
    b = q.get("bcts_1")
    if b:
        ok = (b.get("good_worst_over_recommended") or 99) <= 2 and b.get("good_under_1_per_10_m2") == 0
        out.append(f"- bcts_1 (vendor ground = class 2 as reference): no good DTM more than 2x the "
                   f"recommended one's RMSE and none under 1 ground point per 10 m²: "
                   f"**{'holds' if ok else 'does not hold'}** (worst good / recommended = "
                   f"{_f(b.get('good_worst_over_recommended'))}; median RMSE by role: "
                   + ", ".join(f"{k} {v} m" for k, v in b.get("median_rmse_by_role", {}).items())
                   + "). The sweep's ranked list starts: " + " / ".join(b.get("ranked", [])[:2]) + ".")
    for name in ("demo", "demo at 5 pts/m²"):
        d = q.get(name)
        if not d:
            continue
        gw = d["g_equals_minus_w"]
        n_gw = sorted(g["ground_points"] for g in gw)
        holds = d["g_equals_minus_w_in_good"].split("/")[0] == d["g_equals_minus_w_in_good"].split("/")[1]
        rm = d.get("median_rmse_by_role", {})
        out.append(
            f"- {name}: the paper's finding (every g = -w DTM good) "
            f"**{'holds' if holds else 'does not hold'}**: {d['g_equals_minus_w_in_good']} g = -w "
            f"DTMs are good. The g = -w DTMs keep {n_gw[0]}-{n_gw[-1]} ground points, "
            f"{d['reference']} are the ground, and sit {d.get('g_equals_minus_w_rmse')} m from it "
            f"(the closest DTM: {d.get('recommended_rmse')} m; median RMSE by role: "
            + ", ".join(f"{k} {v} m" for k, v in rm.items()) + "). The stand has no understorey: "
            f"every return below the crowns is ground, with {100 * d.get('stand_noise_m', 0):.0f} "
            f"cm of noise, so keeping them all (g + w >= {d.get('most_ground_from_g_plus_w')}: "
            f"{d.get('most_ground_points')} points) gives the ground itself, while g = -w keeps "
            "only the lowest and a smoother surface a little below it; the texture rewards that "
            "smoothness. The paper's "
            "finding is about returns of the understorey under eucalyptus, which the synthetic "
            f"stand does not have. The sweep's own pick ranks {d['sweep_pick_reference_rank']} by "
            "RMSE to the ground, every complete DTM being within "
            f"{max(float(g['ref_rmse']) for g in gw if g['ref_rmse']):.2f} m of it.")
    return out + [""]


def _profile(res) -> list:
    p = res.get("queiroz_profile")
    if not p:
        return []
    out = ["## Seed 002 (Queiroz 2017): `lidartrees profile`", "",
           "Canopy start (m above the lowest point) by the default rule (`spread`: where the "
           "horizontal spread leaves the stem's, the stem measured on the narrowest metre between "
           "0.5 and 3 m) and by the paper's ordinal rule (`-rule queiroz`), beside where the "
           "branches begin (measured on the points: the lowest 0.25 m slice from 1 m up where more "
           "than 10 % of the points lie over 0.5 m from the slice's centre, in at least half of "
           "the next metre; the saplings': their lowest whorl).", "",
           "| tree | branches begin | spread | off by | queiroz |", "|---|---|---|---|---|"]
    for name, r in p.items():
        qz = r.get("queiroz", {}).get("canopy_start")
        out.append(f"| {name} | {r['branches_begin']:.2f} | {r['spread']['canopy_start']:.2f} | "
                   f"{r['spread_off_m']:.2f} | {_f(qz)} |")
    worst = max(r["spread_off_m"] for r in p.values())
    out += ["", f"Every tree within {worst:.2f} m (the aim: 1.5 m): "
            f"**{'holds' if worst <= 1.5 else 'does not hold'}**.", ""]
    return out


def _stem(res) -> list:
    s = res.get("buck_stem")
    if not s:
        return []
    out = ["## Seed 004 (Buck et al. 2014): `lidartrees stem`", "",
           "| tree | DBH (cm) | outline (cm) | warning |", "|---|---|---|---|"]
    for name, r in s.items():
        out.append(f"| {name} | {_f(r.get('dbh_cm'), '{:.1f}')} | "
                   f"{_f(r.get('outline_cm'), '{:.1f}')} | {r.get('warning') or ''} |")
    return out + [""]


def write_doc(res: dict, path: Path) -> None:
    """Write the page from the benchmark's results."""
    lines = ["# The seed methods against their papers", "",
             "Written by `python benchmarks/bench_seeds.py` from "
             "`benchmarks/results/seeds.json`; do not edit by hand (run the benchmark again). "
             "The methods as the papers describe them: `../shared/docs/METHODS.md`.", ""]
    for part in (_table1, _treex, _quality, _profile, _stem):
        lines += part(res)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")


if __name__ == "__main__":
    src = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "benchmarks" / "results" / "seeds.json"
    dst = Path(sys.argv[2]) if len(sys.argv) > 2 else ROOT / "docs" / "SEEDS.md"
    write_doc(json.loads(src.read_text()), dst)
