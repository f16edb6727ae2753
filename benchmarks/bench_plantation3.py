"""Plantation mode on the third, independent family: the farms of ``_volume_gen2.py`` (issue 41),
one row per stand.

``_volume_gen2.py`` was written by a session that never saw this project's code (see
``bench_volume2.py``). Its farms plant each row from the stand's edge, so a row's plants do not
face those of the next row; crowns are narrow ellipsoids offset from the stem, scanned in lines
with a beam footprint; 5-8 returns/m²; 3 x 1.5 to 3.5 x 2.5 m; missing trees alone and in runs.
For each farm the CLI runs as a user runs it, the defaults first (with the stands: since they
look for each stand's lattice, the same trees as ``-spacing auto``), then plantation mode, then
the defaults without the stands (each tile's own lattice look; the defaults with the stands
before they looked for each stand's lattice gave these trees)::

    python -m lidartrees_gis.cli trees voo.laz OUT.gpkg -stands talhoes.gpkg -overwrite -q
    python -m lidartrees_gis.cli trees voo.laz OUT.gpkg -spacing auto -stands talhoes.gpkg \
        -overwrite -q
    python -m lidartrees_gis.cli trees voo.laz OUT.gpkg -overwrite -q

and every stand is scored as ``bench_stands2.score_stand`` scores the second family (lattice
within 0.05 m and 1°, stocking error and interval, gaps, tree F) against the farm's truth
(``truth_arvores.csv``: every planting position, ``viva`` 0 where a tree is missing; the tree
top at the crown's centre). The defaults' and no_stands rows carry the tree F only; a run
without stands is scored on the tops inside each stand's polygon.
Results: ``benchmarks/results/plantation3.json`` (``plantation3_before.json``: the stop before
rows with their own phases, 0151209). Usage:
``python benchmarks/bench_plantation3.py [--work /tmp/bench_volume2] [--configs NAME ...]``.
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
sys.path.insert(0, str(HERE))
from bench_stands2 import score_stand  # noqa: E402
from bench_volume2 import CONFIGS, _generate  # noqa: E402


def farm_truth(d: Path) -> list:
    """The farm's stands as ``bench_stands2.score_stand`` reads a truth: lattice, stocking and
    every planting position (status ``missing`` or ``tree``, the top at the crown's centre)."""
    import pandas as pd

    t = pd.read_csv(d / "truth_arvores.csv")
    meta = json.loads((d / "truth.json").read_text(encoding="utf-8"))
    out = []
    for s in meta["stands"]:
        p = t[t["talhao"].astype(str) == str(s["talhao"])]
        rs, ps = (float(v) for v in str(s["espacamento"]).split("x"))
        pos = np.zeros(len(p), dtype=[("x", float), ("y", float), ("status", "U8"),
                                      ("top_x", float), ("top_y", float)])
        pos["x"], pos["y"] = p["x"], p["y"]
        pos["status"] = np.where(p["viva"].to_numpy() == 1, "tree", "missing")
        pos["top_x"], pos["top_y"] = p["copa_x"], p["copa_y"]
        out.append({"talhao": str(s["talhao"]), "positions": pos,
                    "stocking_pct": 100.0 * float((p["viva"] == 1).mean()),
                    "lattice": {"row_spacing": rs, "plant_spacing": ps,
                                "azimuth": float(s["row_azimuth_deg"]) % 180.0}})
    return out


def run_farm(d: Path, name: str, python: str) -> list:
    import geopandas as gpd
    import pyogrio

    truth = farm_truth(d)
    rows = []
    for mode, extra in (("defaults", []), ("auto", ["-spacing", "auto"]), ("no_stands", None)):
        out = d / f"plantation3_{mode}.gpkg"
        where = [] if extra is None else ["-stands", str(d / "talhoes.gpkg")]
        cmd = [python, "-m", "lidartrees_gis.cli", "trees", str(d / "voo.laz"), str(out),
               *where, "-overwrite", "-q", *(extra or [])]
        if mode == "auto":
            cmd += ["-stand_csv", str(d / "plantation3_auto.csv")]
        t0 = time.time()
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=str(HERE.parent))
        run_s = round(time.time() - t0, 1)
        base = {"config": name, "mode": mode, "run_s": run_s, "exit": proc.returncode}
        if proc.returncode != 0:
            rows += [dict(base, talhao=s["talhao"], error=proc.stderr.strip()[-300:])
                     for s in truth]
            continue
        layers = {n for n, _ in pyogrio.list_layers(out)}
        tops = gpd.read_file(out, layer="tree_tops")
        # without -stands the output's stands are its planted blocks: scored by the farm's
        stands = gpd.read_file(out, layer="stands") if extra is not None else \
            _stands_of(tops, d)
        gaps = gpd.read_file(out, layer="gaps") if "gaps" in layers else gpd.GeoDataFrame()
        for s in truth:
            r = dict(base, **score_stand(s, stands, gaps, tops))
            if mode != "auto":
                r = {k: r[k] for k in ("config", "mode", "run_s", "exit", "talhao", "design",
                                       "trees_true", "trees_found", "tree_f")}
            rows.append(r)
    return rows


def _stands_of(tops, d: Path):
    """A run without -stands: its tops given each stand's id (the farm's polygons) and a
    stands table of the ids alone, as ``score_stand`` reads them."""
    import geopandas as gpd

    pol = gpd.read_file(d / "talhoes.gpkg")
    j = gpd.sjoin(tops, pol[["talhao", "geometry"]], how="left", predicate="within")
    tops["stand_id"] = j["talhao"].astype(str).to_numpy()
    return gpd.GeoDataFrame({"stand_id": pol["talhao"].astype(str)}, geometry=pol.geometry)


COLUMNS = ("config", "talhao", "mode", "design", "azimuth_true", "lattice_ok", "spacing_found",
           "azimuth_found", "positions_true", "positions_found", "stocking_true",
           "stocking_err_pts", "truth_in_interval", "gap_precision", "missing_recall",
           "trees_true", "trees_found", "tree_f")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_volume2"))
    ap.add_argument("--configs", nargs="*", default=list(CONFIGS))
    ap.add_argument("--out", type=Path, default=HERE / "results" / "plantation3.json")
    a = ap.parse_args(argv)
    rows = []
    for name in a.configs:
        farm = run_farm(_generate(a.work, name, 1), name, sys.executable)
        for r in farm:
            print(" | ".join(str(r.get(c, "")) for c in COLUMNS), flush=True)
        rows += farm
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps({"benchmark": "plantation mode on the volume generator's farms",
                                 "generator": "benchmarks/_volume_gen2.py",
                                 "command": "trees voo.laz OUT.gpkg [-spacing auto] -stands "
                                            "talhoes.gpkg", "rows": rows}, indent=1,
                                default=lambda o: o.item() if hasattr(o, "item") else str(o)))


if __name__ == "__main__":
    main()
