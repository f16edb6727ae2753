"""``lidartrees demo``: the embedded default job on a synthetic stand with known trees."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import OutputExistsError
from .io.raster import read_raster
from .als.chain import trees_run
from .als.rasters import chm_run
from .io.options import ReadOptions
from .io.output import OutputOptions
from .progress import SubProgress, as_progress
from .synthetic import CRS, StandParams, make_stand, write_truth_csv, write_xyz_seed_dialect


def write_demo_stands(path, *, overwrite=False) -> None:
    """The demo stand's two talhões, as a farm's stands layer: its southern half ``001-A`` and
    northern half ``001-B`` (layer ``talhoes``, id field ``talhao``, the stand's CRS), for the
    per-stand inventory (``lidartrees trees ... -stands talhoes.gpkg``)."""
    import geopandas as gpd
    import shapely

    from .io.vector import write_gpkg

    p = StandParams()
    x0, y0, ym = p.origin_x, p.origin_y, p.origin_y + p.height / 2
    frame = gpd.GeoDataFrame(
        {"talhao": ["001-A", "001-B"]},
        geometry=[shapely.box(x0, y0, x0 + p.width, ym),
                  shapely.box(x0, ym, x0 + p.width, y0 + p.height)], crs=CRS)
    write_gpkg(path, {"talhoes": frame}, overwrite=overwrite)


def run_demo(outdir="lidartrees_demo", *, overwrite=False, progress=None) -> dict:
    """The main job with its defaults on a synthetic stand with known trees.

    Writes the stand as XYZ text in seed 000's dialect (tab, decimal comma, SAD-69 / UTM 24S),
    its truth table and its two talhões (``talhoes.gpkg``), then runs ``chm`` and ``trees`` on the points with their default
    options (GeoTIFF CHM, GeoPackage of tops and crowns, quick-look PNG) and evaluates the tops
    against the truth as ``lidartrees evaluate`` does (Eysn et al. 2015 matching), plus the RMSE
    of the crown diameters against each tree's visible crown.
    """
    from .report.evaluate import evaluate_trees

    prog = as_progress(progress)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    xyz, truth_csv, chm = out / "stand.xyz", out / "truth.csv", out / "chm.tif"
    gpkg, png, stands = out / "trees.gpkg", out / "trees.png", out / "talhoes.gpkg"
    for p in (xyz, truth_csv, chm, gpkg, png, stands):
        if p.exists() and not overwrite:
            raise OutputExistsError(f"{p}: output exists; use -overwrite to replace it")
    prog.update(0.02, "generating the stand")
    pts, truth = make_stand()
    write_xyz_seed_dialect(xyz, pts)
    write_truth_csv(truth_csv, truth)
    write_demo_stands(stands, overwrite=overwrite)
    prog.update(0.2, "canopy height model")
    read, out_opts = ReadOptions(a_srs=CRS), OutputOptions(overwrite=overwrite)
    r = chm_run(xyz, chm, read=read, out=out_opts, progress=SubProgress(prog, 0.2, 0.5))
    t = trees_run(xyz, gpkg, read=read, out=out_opts, png=png,
                  progress=SubProgress(prog, 0.5, 0.95))
    import pyogrio

    tab = pyogrio.read_dataframe(gpkg, layer="tree_tops", read_geometry=False)
    tab = {k: tab[k].to_numpy() for k in ("x", "y", "height", "crown_diameter", "suppressed")}
    ev = evaluate_trees(tab["x"], tab["y"], tab["height"], truth["x"], truth["y"], truth["height"])
    d, rr = ev.pop("pairs")
    crowned = tab["suppressed"][d] == 0  # a suppressed tree has no crown to measure
    d, rr = d[crowned], rr[crowned]
    cd_rmse = float(np.sqrt(np.mean((tab["crown_diameter"][d] - truth["visible_crown_diameter"][rr]) ** 2))) \
        if len(d) else float("nan")
    arr, spec, _ = read_raster(chm)
    prog.update(1.0, "done")

    def rnd(dct):
        return {k: round(v, 3) if isinstance(v, float) else v for k, v in dct.items()}

    return {"points": len(pts), "trees_truth": int(len(truth["tree_id"])), "xyz": str(xyz),
            "truth": str(truth_csv), "stands": str(stands), "chm": str(chm), "trees": str(gpkg), "quicklook": str(png),
            "crs": r["crs"], "res": t["res"], "trees_found": t["trees"],
            "accuracy": rnd(ev["all"]), "accuracy_dominant": rnd(ev["dominant"]),
            "crown_diameter_rmse": round(cd_rmse, 3), "chm_max": round(float(np.nanmax(arr)), 2)}
