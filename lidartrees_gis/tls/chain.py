"""File-level chains of the terrestrial-scan methods: a tree's points in, the method's outputs
written (seed 004's stem, seed 002's profile)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.options import ReadOptions
from ..io.provenance import repro_report
from ..progress import SubProgress, as_progress, check_cancel
from ..report.plots import plot_png


#: one tree's points span at most this many metres in z and across (the tallest trees stand
#: about 115 m; a scan cropped to one tree holds some ground around it)
MAX_TREE_SPAN = 300.0


def check_one_tree(pts, path) -> None:
    """Refuse points that cannot be one tree (a span of kilometres: a wrong digit, or another
    unit), before slicing them into thousands of sections or bins."""
    if not len(pts):
        from ..errors import InputError

        raise InputError(f"{path}: no points")
    for name, v in (("z", pts.z), ("x", pts.x), ("y", pts.y)):
        lo, hi = float(np.min(v)), float(np.max(v))
        if not hi - lo <= MAX_TREE_SPAN:
            from ..errors import InputError

            raise InputError(f"{path}: the points span {hi - lo:,.0f} m in {name} ({lo:,.2f} .. "
                             f"{hi:,.2f}); one tree spans at most {MAX_TREE_SPAN:g} m: check the "
                             "coordinates (a wrong digit, another unit) or crop the scan to one "
                             "tree")


def stem_file(input, prefix, *, params=None, read: ReadOptions | None = None, overwrite=False,
              progress=None) -> dict:
    """Dmax trunk filter (seed 004) on one tree: ``PREFIX_trunk.laz`` (trunk points with a
    ``section`` extra dimension), ``PREFIX_sections.csv`` and ``.gpkg`` (circles),
    ``PREFIX_summary.json`` (DBH at 1.30 m, heights) and ``PREFIX_taper.png``."""
    import json

    import geopandas as gpd
    from shapely.geometry import Point

    from ..io.lasout import write_points
    from ..io.output import atomic_output, check_outputs
    from ..io.vector import write_gpkg
    from ..tls.stem import dmax_filter

    pre = str(prefix)
    paths = {k: Path(pre + suffix) for k, suffix in (
        ("trunk", "_trunk.laz"), ("csv", "_sections.csv"), ("gpkg", "_sections.gpkg"),
        ("summary", "_summary.json"), ("png", "_taper.png"))}
    check_outputs([(pth, "OUTPUT_PREFIX") for pth in paths.values()], (input,), overwrite)
    prog = as_progress(progress)
    src = (read or ReadOptions()).open(input, filtered=False)
    pts = src.read_all(SubProgress(prog, 0, 0.2))
    check_one_tree(pts, input)
    r = dmax_filter(pts.x, pts.y, pts.z, params, progress=SubProgress(prog, 0.2, 0.8))
    check_cancel(prog)
    ti = r["trunk_index"]
    write_points(paths["trunk"], pts.x[ti], pts.y[ti], pts.z[ti], crs=src.crs,
                 extra={"section": r["trunk_section"].astype(np.uint32)}, overwrite=overwrite)
    cols = ["section", "z", "xc", "yc", "r", "diameter", "s", "points_in", "points_kept",
            "selected", "repeated", "coverage", "expected_points", "completeness", "converged"]
    with atomic_output(paths["csv"], overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(",".join(cols) + "\n")
            for row in r["sections"]:
                fh.write(",".join("" if row.get(c) is None else (f"{row[c]:.5f}" if isinstance(row[c], float)
                                                                  else str(row[c])) for c in cols) + "\n")
    conv = [row for row in r["sections"] if row["converged"]]
    import pandas as pd

    df = pd.DataFrame([{c: row.get(c) for c in cols} for row in conv], columns=cols)
    df["z_abs"] = df["z"] + r["base"] if len(df) else []
    geom = [Point(row["xc"], row["yc"]).buffer(row["r"], 32) for row in conv]
    crs = src.crs.to_wkt() if src.crs is not None else None
    write_gpkg(paths["gpkg"], {"sections": gpd.GeoDataFrame(df, geometry=geom, crs=crs)},
               overwrite=overwrite, metadata={"input": str(input), **r["params"]})
    summary = {"input": str(input), "points": len(pts), "trunk_points": int(ti.size),
               "base": r["base"], "tree_height": r["tree_height"],
               "reached_height": r["reached_height"], "reached_percent": r["reached_percent"],
               "dbh_m": None if np.isnan(r["dbh"]) else r["dbh"],
               "dbh_cm": None if np.isnan(r["dbh"]) else 100 * r["dbh"],
               "dbh_outline_cm": None if np.isnan(r["dbh_outline"]) else 100 * r["dbh_outline"],
               "sections_converged": len(conv), "message": r["message"],
               "warning": r["warning"], "params": r["params"]}
    with atomic_output(paths["summary"], overwrite) as tmp:
        tmp.write_text(json.dumps(summary, indent=2))

    def draw(ax):
        if conv:
            ax.plot([100 * c["diameter"] for c in conv], [c["z"] for c in conv], "o", ms=2,
                    label="section diameter")
        if summary["dbh_cm"]:
            ax.axhline(1.3, color="grey", lw=0.8, ls="--")
            ax.plot([summary["dbh_cm"]], [1.3], "r*", ms=10, label=f"DBH {summary['dbh_cm']:.1f} cm")
        if summary["dbh_outline_cm"]:
            ax.plot([summary["dbh_outline_cm"]], [1.3], "k^", ms=6,
                    label=f"outline (tape) {summary['dbh_outline_cm']:.1f} cm")
        ax.set_xlabel("diameter (cm)")
        ax.set_ylabel("height above base (m)")
        ax.set_ylim(0, max(r["tree_height"], 1.5))
        ax.set_title(f"Taper (Dmax filter): trunk to {r['reached_height']:.1f} m "
                     f"({r['reached_percent']:.0f} % of {r['tree_height']:.1f} m)", fontsize=9)
        ax.legend(fontsize=8)

    plot_png(paths["png"], draw, size=(5, 7), overwrite=overwrite)
    prog.update(1.0, "done")
    return {**{k: str(v) for k, v in paths.items()},
            **{k: summary[k] for k in ("dbh_cm", "dbh_outline_cm", "tree_height",
                                       "reached_height", "reached_percent", "sections_converged",
                                       "trunk_points", "message", "warning")},
            "reprojection": repro_report(src)}


def profile_file(input, output, *, bin=0.05, sigma=0.3, rule="spread",  # noqa: A002
                 read: ReadOptions | None = None, overwrite=False, progress=None) -> dict:
    """Roots / stem / canopy segmentation (seed 002; ``rule`` see
    :func:`lidartrees_gis.tls.profile.segment_profile`): OUTPUT LAS/LAZ with an extra dimension
    ``part`` (1 roots, 2 stem, 3 canopy) and classification 1, plus ``OUTPUT_boundaries.json``,
    ``OUTPUT_boundaries.csv`` and ``OUTPUT_profile.png``."""
    import json

    from ..io.lasout import write_points
    from ..io.output import atomic_output, check_outputs
    from ..tls.profile import segment_profile

    out = Path(output)
    stem = out.with_suffix("")
    paths = {"json": Path(str(stem) + "_boundaries.json"), "csv": Path(str(stem) + "_boundaries.csv"),
             "png": Path(str(stem) + "_profile.png")}
    check_outputs([(out, "OUTPUT")] + [(pth, "OUTPUT") for pth in paths.values()], (input,),
                  overwrite)
    prog = as_progress(progress)
    src = (read or ReadOptions()).open(input, filtered=False)
    pts = src.read_all(SubProgress(prog, 0, 0.5))
    check_one_tree(pts, input)
    r = segment_profile(pts.z, bin=bin, sigma=sigma, rule=rule, x=pts.x, y=pts.y)
    check_cancel(prog)
    write_points(out, pts.x, pts.y, pts.z, crs=src.crs, classification=np.ones(len(pts), np.uint8),
                 extra={"part": r["labels"]}, overwrite=overwrite)
    info = {k: r[k] for k in ("tree_start", "stem_start", "canopy_start", "top", "has_roots",
                              "notes", "counts")}
    info.update({"z_min": float(pts.z.min()), "bin": bin, "sigma": sigma, "rule": rule,
                 "crossings": [{"z": z, "direction": "-to+" if d > 0 else "+to-"} for z, d in r["crossings"]]})
    with atomic_output(paths["json"], overwrite) as tmp:
        tmp.write_text(json.dumps(info, indent=2))
    with atomic_output(paths["csv"], overwrite) as tmp:
        tmp.write_text("boundary,height_above_zmin_m\n" + "".join(
            f"{k},{'' if info[k] is None else round(info[k], 4)}\n"
            for k in ("tree_start", "stem_start", "canopy_start", "top")))
    prof = r["profile"]

    def draw(ax):
        ax.barh(prof["z"], prof["counts"], height=bin, color="0.8", label="points per slice")
        ax.plot(prof["smooth"], prof["z"], "r-", lw=1.2, label=f"smoothed (sigma {sigma} m)")
        ax.plot(10 * prof["d2"] * bin * bin, prof["z"], "b-", lw=0.8, label="second derivative x 10")
        for k, col in (("stem_start", "green"), ("canopy_start", "darkgreen")):
            if info[k] is not None:
                ax.axhline(info[k], color=col, ls="--", lw=1, label=f"{k.replace('_', ' ')} {info[k]:.2f} m")
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel("points")
        ax.set_ylabel("height above lowest point (m)")
        ax.set_title("Vertical profile (Queiroz 2017)" + ("" if r["has_roots"] else ": no root zone"),
                     fontsize=9)
        ax.legend(fontsize=7, loc="upper right")

    plot_png(paths["png"], draw, size=(6, 8), overwrite=overwrite)
    prog.update(1.0, "done")
    return {"output": str(out), **{k: str(v) for k, v in paths.items()},
            **{k: info[k] for k in ("stem_start", "canopy_start", "top", "has_roots")},
            "notes": "; ".join(r["notes"]), "reprojection": repro_report(src)}
