"""Seed 000's Table 1 (``lidartrees compare``): ten smoothing and segmentation configurations of
Castro (2006) run on one CHM, with the trees, mean height and mean crown diameter of each.

By default on seed 000's surface (:data:`SEED000_SURFACE`): the highest point of each 0.2 m
cell (the laser footprint, §2.3) minus the ground, gaps filled by ``mean8``, and tops strictly
higher than their 8 neighbours (§4.5.1), so that the table reproduces Table 1's ordering:
watershed without smoothing finds more trees than region growing without smoothing, and the
more smoothing, the fewer trees."""
from __future__ import annotations

import numpy as np

from ..io.options import ReadOptions
from ..io.output import atomic_output, check_outputs
from ..io.provenance import repro_report
from ..progress import SubProgress, as_progress, check_cancel
from .chain import area_surfaces
from .surfaces import SurfaceOptions
from .trees import TreeParams, detect_trees

#: seed 000's surface: highest point per 0.2 m cell (the footprint, §2.3) minus the ground
#: (the seed's MDT "holds only the terrain's points": the class-2 points, else the lowest point
#: per 5 m; the lowest point per 0.2 m cell, ``-dtm min``, is the canopy under a closed crown)
SEED000_SURFACE = SurfaceOptions(res=0.2, chm="max")

#: seed 000, Table 1: the ten configurations compared
TABLE1 = (
    ("region growing, no smoothing", "rg", "none"),
    ("region growing, fine Gaussian", "rg", "gauss3"),
    ("region growing, coarse Gaussian", "rg", "gauss5"),
    ("watershed, no smoothing", "watershed", "none"),
    ("watershed, opening, cross", "watershed", "open:cross"),
    ("watershed, abefec, cross", "watershed", "abefec:cross"),
    ("watershed, opening, square", "watershed", "open:square"),
    ("watershed, abefec, square", "watershed", "abefec:square"),
    ("watershed, opening, rhombus", "watershed", "open:rhombus"),
    ("watershed, abefec, rhombus", "watershed", "abefec:rhombus"),
)


def compare_rows(chm, spec, heights=None, *, min_height=2.0, step=0.1, strict=False,
                 progress=None) -> list:
    """The ten configurations of :data:`TABLE1` on one CHM: a row each (``configuration``,
    ``method``, ``smooth``, ``trees``, ``mean_height``, ``mean_crown_diameter``)."""
    prog = as_progress(progress)
    rows = []
    for i, (label, method, sm) in enumerate(TABLE1):
        r = detect_trees(chm, spec, TreeParams(method=method, smooth=sm, min_height=min_height,
                                               step=step, tops="strict" if strict else "lm"),
                         heights=heights)
        t = r["table"]
        n = len(t["tree_id"])
        rows.append({"configuration": label, "method": method, "smooth": sm, "trees": n,
                     "mean_height": float(np.mean(t["height"])) if n else float("nan"),
                     "mean_crown_diameter": float(np.mean(t["crown_diameter"])) if n
                     else float("nan")})
        prog.update((i + 1) / len(TABLE1), label)
        check_cancel(prog)
    return rows


def compare_run(input, output, *, surface: SurfaceOptions | None = None,
                read: ReadOptions | None = None, min_height=2.0, step=0.1, strict=True,
                overwrite=False, progress=None) -> dict:
    """Seed 000's Table 1 on one input (points or a CHM GeoTIFF): a CSV and a Markdown table.

    ``surface`` defaults to :data:`SEED000_SURFACE`. Tops are strictly higher than all 8
    neighbours, the seed's literal rule (``strict=False``: one top per plateau of 8-neighbour
    maxima, which makes region growing's tops the watershed's basins)."""
    check_outputs([(output, "OUTPUT")], (input,), overwrite)
    surface = SEED000_SURFACE if surface is None else surface
    prog = as_progress(progress)
    s, plan, area = area_surfaces(input, surface=surface, read=read,
                                  progress=SubProgress(prog, 0, 0.3))
    rows = compare_rows(s["chm"], s["spec"], s["heights"], min_height=min_height, step=step,
                        strict=strict, progress=SubProgress(prog, 0.3, 1.0))
    prov = provenance(s, surface, plan.res, strict)
    with atomic_output(output, overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("configuration,method,smooth,trees,mean_height,mean_crown_diameter,"
                     "surface,ground,res,tops\n")
            tail = f"\"{prov['surface']}\",\"{prov['ground']}\",{prov['res']:g},{prov['tops']}"
            for r in rows:
                fh.write(f"\"{r['configuration']}\",{r['method']},{r['smooth']},{r['trees']},"
                         f"{r['mean_height']:.2f},{r['mean_crown_diameter']:.2f},{tail}\n")
    md = ["| method | trees | mean height (m) | mean diameter (m) |", "|---|---|---|---|"]
    md += [f"| {r['configuration']} | {r['trees']} | {r['mean_height']:.2f} | "
           f"{r['mean_crown_diameter']:.2f} |" for r in rows]
    md.append(f"\nSurface: {prov['surface']}; ground: {prov['ground']}; cell {prov['res']:g} m; "
              f"tops: {prov['tops']}.")
    return {"output": str(output), "rows": rows, "table": "\n".join(md), "res": plan.res,
            **{k: prov[k] for k in ("surface", "ground", "tops")},
            "reprojection": repro_report(area)}


#: the surfaces ``compare`` can run on, as its output names them
SURFACE_NAMES = {"max": "highest point per cell minus the ground (seed 000)",
                 "pitfree": "pit-free CHM (Khosravipour et al. 2014)",
                 "tin": "TIN of the first returns minus the ground"}


def provenance(s: dict, surface: SurfaceOptions, res: float, strict: bool) -> dict:
    """Which surface, ground and cell a ``compare`` run used (a CHM GeoTIFF is its own
    surface: its ground is whatever made it)."""
    if not s.get("dtm_method"):  # a CHM raster
        return {"surface": "the input CHM raster", "ground": "that of the input CHM",
                "res": float(res), "tops": "strict" if strict else "lm"}
    return {"surface": SURFACE_NAMES.get(s.get("chm_method", surface.chm), surface.chm),
            "ground": s["dtm_method"], "res": float(res), "tops": "strict" if strict else "lm"}
