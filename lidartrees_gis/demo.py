"""``lidartrees demo``: the embedded default job on a synthetic stand with known trees."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import OutputExistsError
from .io.raster import read_raster
from .pipeline import chm_file, trees_file
from .trees import accuracy
from .progress import SubProgress, as_progress
from .synthetic import CRS, make_stand, write_truth_csv, write_xyz_seed_dialect


def run_demo(outdir="lidartrees_demo", *, overwrite=False, res=0.5, progress=None) -> dict:
    """Write a synthetic stand (XYZ in seed 000's dialect + truth CSV) and its CHM GeoTIFF.

    Then runs the default tree detection on the CHM (GeoPackage + quick-look PNG) and reports its
    accuracy against the truth (matches within 1 m, omission, commission, F-score, RMSE of height
    and crown diameter).
    """
    prog = as_progress(progress)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    xyz, truth_csv, chm = out / "stand.xyz", out / "truth.csv", out / "chm.tif"
    gpkg, png = out / "trees.gpkg", out / "trees.png"
    for p in (xyz, truth_csv, chm, gpkg, png):
        if p.exists() and not overwrite:
            raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it")
    prog.update(0.02, "generating the stand")
    pts, truth = make_stand()
    write_xyz_seed_dialect(xyz, pts)
    write_truth_csv(truth_csv, truth)
    prog.update(0.2, "canopy height model")
    r = chm_file(xyz, chm, res=res, dtm="lowest:5", fill="mean8", a_srs=CRS, overwrite=overwrite,
                 progress=SubProgress(prog, 0.2, 0.6))
    t = trees_file(chm, gpkg, png=png, overwrite=overwrite, progress=SubProgress(prog, 0.6, 0.95))
    acc = accuracy(t["result"]["table"], truth, max_dist=1.0)
    arr, spec, _ = read_raster(chm)
    row, col = spec.cell_index(truth["x"], truth["y"])
    ok = (row >= 1) & (col >= 1) & (row < spec.height - 1) & (col < spec.width - 1)
    prog.update(1.0, "done")
    return {"points": len(pts), "trees_truth": int(len(truth["tree_id"])), "xyz": str(xyz),
            "truth": str(truth_csv), "chm": str(chm), "trees": str(gpkg), "quicklook": str(png),
            "crs": r["crs"], "res": res,
            "accuracy": {k: round(v, 3) if isinstance(v, float) else v for k, v in acc.items()},
            "chm_max": float(np.nanmax(arr)),
            "chm_at_trees_mean": float(np.nanmean(arr[row[ok], col[ok]]))}
