"""What one tile computes (a task: it knows nothing of where its tile came from or where its
results go): the trees whose top lies in its core, with their whole crowns grown inside its
buffer; or the core windows of its surfaces; or a per-cell statistic of its points."""
from __future__ import annotations

import math
import warnings

import numpy as np

from ..catalog.catalog import Tile
from ..catalog.source import TileSource
from ..errors import DataWarning
from ..grid import GridAccumulator, GridSpec, fill_gaps, grid_spec_for
from ..progress import as_progress, check_cancel
from .area import AreaPlan
from .metrics import crown_polygons
from .surfaces import SurfaceOptions, box_surfaces
from .trees import TreeParams, detect_trees

#: the per-tree fields every tile sends back (and every output carries)
TREE_FIELDS = ("tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells",
               "row_number", "plant_number", "stand", "suppressed")
#: the integer ones (row and plant numbers: plantation mode, 0 for a tree on no position;
#: stand: the index of the tree's stand with -stands, -1 for none, written as stand_id;
#: suppressed: 1 for a tree at a planting position with no top of its own, under or beside
#: its neighbours' crowns: no crown polygon, its height from the returns there; 2 for the
#: likelier answer at a position whose returns leave it uncertain (gaps layer status
#: uncertain, its share of crown returns at least half: a field check))
INT_FIELDS = ("tree_id", "n_cells", "row_number", "plant_number", "stand", "suppressed")

#: plantation mode warns below this point density (points/m² of the area): planted trees lower
#: than their in-row neighbours are often missed and empty positions misread (measured on
#: benchmarks/_family.py's stands: stocking 6.6 points under the truth and 56 % of the reported
#: gaps true at 2 points/m², with 40 % of the empty positions uncertain; -0.7 points and 96 % at
#: 4); a delivery of 4 pts/m² measures 3.9-4.0
PLANTATION_MIN_DENSITY = 3.5


def warn_sparse_plantation(density: float) -> None:
    """A :class:`DataWarning` in plantation mode below :data:`PLANTATION_MIN_DENSITY`."""
    if density < PLANTATION_MIN_DENSITY:
        warnings.warn(DataWarning(
            f"{density:.1f} points/m²: below {PLANTATION_MIN_DENSITY:g} points/m² planted "
            "trees lower than their neighbours are often missed and the empty positions "
            "misread, so the stocking and the gaps are unreliable (measured on synthetic "
            "stands: at 2 points/m² the stocking 6.6 points under the truth and 56 % of the "
            "reported gaps true, 40 % of the empty positions uncertain; at 4 points/m² -0.7 "
            "points and 96 %)"), stacklevel=3)


def core_window(spec: GridSpec, core) -> tuple:
    """``(r0, r1, c0, c1)``: the cells of ``spec`` inside the box ``core``."""
    x0, y0, x1, y1 = (float(np.clip(v, -1e15, 1e15)) for v in core)  # outer cores: infinite
    c0 = max(0, int(math.floor((x0 - spec.left) / spec.res + 1e-9)))
    c1 = min(spec.width, int(math.ceil((x1 - spec.left) / spec.res - 1e-9)))
    r0 = max(0, int(math.floor((spec.top - y1) / spec.res + 1e-9)))
    r1 = min(spec.height, int(math.ceil((spec.top - y0) / spec.res - 1e-9)))
    return r0, r1, c0, c1


def detect_with_stocking(arr, spec, params: TreeParams, heights=None, progress=None, *,
                         returns=None, within=None, zone=None, points=None,
                         grids=None, regions=None) -> dict:
    """:func:`lidartrees_gis.als.trees.detect_trees` on a CHM, plus the stocking of the fitted
    planting grid in plantation mode (``params.spacing``).

    In plantation mode, with ``returns`` (the highest return above ground of each cell, from
    points), the empty planting positions are searched once more for a tree the tops finder
    missed (:func:`lidartrees_gis.plantation.gap_look.gap_tops`); the crowns are then grown again from
    all tops and ``result["gap_trees"]`` says how many were added. Without a spacing
    (:attr:`TreeParams.looks_for_lattice`), when the tops lie on a planting lattice
    (:func:`lidartrees_gis.plantation.stocking.detect_planting`; ``result["planting_detected"]`` gives
    its spacings), its empty positions get the same second look, without a stocking report.
    The cells of the added tops are ``result["gap_tops"]`` (rows, cols). ``within``: the box
    (a tile's core) whose positions the stocking counts; ``zone``: the stand of each cell
    (:func:`lidartrees_gis.plantation.stands.zones`), each stand fitted its own lattice
    (:func:`lidartrees_gis.plantation.positions.stocking_by_stand`); ``points``: every return's
    ``(x, y, height above ground)``, to tell the empty positions holding a suppressed tree
    from the missing ones (:func:`lidartrees_gis.plantation.status.classify_gaps`); ``grids``:
    each stand's lattice (:func:`lidartrees_gis.plantation.positions.fit_stand_grids`) when fitted on
    the whole area's tops (a run in tiles), by default fitted on the tops found here.
    """
    from ..plantation.positions import own_spacings, stocking_by_stand
    from ..plantation.status import classify_gaps
    from ..plantation.gap_look import gap_tops
    from ..plantation.stocking import detect_planting

    result = detect_trees(arr, spec, params, heights=heights)
    check_cancel(progress)
    spacing, given, added, grid = params.spacing, params.spacing is not None, 0, None
    if not given and params.looks_for_lattice and returns is not None:
        t = result["table"]
        # the defaults' look, in every tile: no spectral search (natural forests' cost)
        grid = detect_planting(t["x"], t["y"], cell=spec.res, spectral=False)
        if grid is not None:
            spacing = (grid.row_spacing, grid.tree_spacing)
            result = _planted_separation(result, arr, spec, params, heights, spacing)
            result["planting_detected"] = (grid.row_spacing, grid.tree_spacing)
    if spacing is None:
        result["gap_trees"] = 0
        return result
    as_progress(progress).update(0.75, "planting grid")
    t = result["table"]
    # plantation mode: each stand's lattice fitted once, on the tops found first (or given:
    # the area's, fitted on every tile's tops), and kept while the tops change below
    st = stocking_by_stand(t["x"], t["y"], arr, spec, spacing, zone if given else None,
                           min_height=params.min_height, grid=grid, within=within,
                           grids=grids if given else None, regions=regions if given else None)
    lowest = params.min_height  # the lowest tree plantation mode adds
    if given:  # one tree per planting position, none in the understorey
        result, st = _one_per_position(result, st, arr, spec, params, heights, zone, within)
        t = result["table"]
    # the second look at every empty position of the tile, its core's or not: the apex of a
    # tree at a position just beyond the core may stand inside it
    looks = st["looks"]
    if returns is not None and len(looks) and st.get("spacing") is not None:
        if given:  # a planted tree reaches the understorey's share of its neighbours' canopy
            lowest = np.maximum(params.min_height, UNDERSTOREY_HEIGHT * _canopy_of(
                looks.x, looks.y, _tops_xyh(t), st, zone, spec,
                _dominant_height(result, arr, spec, params)))
        rows, cols = gap_tops(looks.x, looks.y, returns, result["smoothed"], spec,
                              st["spacing"], top_x=t["x"], top_y=t["y"], min_height=lowest,
                              smaller=own_spacings(st, looks.zone))
        added = int(rows.size)
        if added:
            check_cancel(progress)
            detected = result.get("planting_detected")
            result = detect_trees(arr, spec, params, heights=heights,
                                  tops=(np.r_[t["row"], rows], np.r_[t["col"], cols]))
            result["gap_tops"] = (rows, cols)
            if detected:
                result["planting_detected"] = detected
            if given:
                t = result["table"]
                st = stocking_by_stand(t["x"], t["y"], arr, spec, spacing, zone,
                                       min_height=params.min_height, within=within,
                                       grids=st["grids"], masks=st.get("masks"))
    hd = _dominant_height(result, arr, spec, params)
    if given:  # the stocking report (gaps layer) is for plantation mode only
        result["stocking"] = classify_gaps(st, points, st["spacing"], hd, params.min_height,
                                           tops=_tops_xyh(result["table"]))
    elif points is not None and st["missing"]:  # a lattice under the defaults' tops: its
        if added:  # empty positions holding a suppressed tree (no stocking report)
            t = result["table"]
            st = stocking_by_stand(t["x"], t["y"], arr, spec, spacing, None,
                                   min_height=params.min_height, grid=grid, within=within,
                                   masks=st.get("masks"))
        result["understorey"] = classify_gaps(st, points, st["spacing"], hd, params.min_height,
                                              tops=_tops_xyh(result["table"]))
    result["gap_trees"] = added
    return result


def _empty_trees(tile: Tile, res: float) -> dict:
    out = {c: np.empty(0, np.int64 if c in INT_FIELDS else np.float64) for c in TREE_FIELDS}
    out.update({"wkb": [], "top_wkb": [], "crown_box": np.empty((0, 4)), "gap_trees": 0,
                "planting": None, "stocking": None, "stand_stocking": None, "stand_cells": {},
                "chm": np.empty((0, 0), np.float32), "chm_left": tile.box[0],
                "chm_top": tile.box[3], "res": res, "canopy_cells": 0, "points": 0,
                "dropped": {}, "outlier_points": 0, "tile": tile.index})
    return out


def tile_first_tops(tile: Tile, area, params: TreeParams, plan: AreaPlan,
                    surface: SurfaceOptions, stands=None, progress=None) -> dict:
    """Plantation mode's first pass over an area in tiles: the tops the detection finds first
    in the tile's core (before plantation mode keeps one per position), with their stand
    index: ``{"x", "y", "zone"}``. Each stand's lattice is fitted on all of them
    (:func:`lidartrees_gis.plantation.positions.fit_stand_grids`), as one file's run fits it on its
    own, so the tiles count positions on one lattice per stand. With ``-spacing auto``,
    ``scan``: the scan lines' waves in the density of the core's returns
    (:func:`lidartrees_gis.plantation.scan.scan_waves`)."""
    from ..catalog.source import shared_cache
    from ..plantation.positions import top_zones
    from ..plantation.scan import scan_waves
    from ..plantation.stands import zones

    # the surfaces are left in the run's shared folder (a run of several tiles on this
    # machine) for :func:`tile_trees`, which then need not compute them again
    cache = shared_cache()
    auto = isinstance(params.spacing, str)
    s = box_surfaces(area, tile.box, plan.res, surface, stats=plan.stats, whole_dtm=False,
                     keep_points=auto or (cache is not None and params.looks_at_planting),
                     progress=progress)
    scan = None
    if auto and s is not None and s.get("points_above_ground") is not None:
        px, py = s["points_above_ground"][:2]
        c, b = tile.core, tile.box  # the core (unbounded at the area's edges) in the data
        scan = scan_waves(px, py, (max(c[0], b[0]), max(c[1], b[1]), min(c[2], b[2]),
                                   min(c[3], b[3])))
        if not (cache is not None and params.looks_at_planting):
            s = {k: v for k, v in s.items() if k != "points_above_ground"}
    if cache is not None and s is not None:
        cache.put_value(_surfaces_key(tile, plan, params), s, keep=True)
    if s is None:
        return {"x": np.empty(0), "y": np.empty(0), "zone": np.empty(0, np.int64)}
    t = detect_trees(s["chm"], s["spec"], params, heights=s["heights"])["table"]
    core = tile.in_core(t["x"], t["y"])
    x, y = np.asarray(t["x"])[core], np.asarray(t["y"])[core]
    zone = zones(stands, s["spec"]) if stands is not None else None
    z = top_zones(x, y, zone, s["spec"]) if zone is not None else np.full(x.size, -1, np.int64)
    return {"x": x, "y": y, "zone": z, "scan": scan}


def tile_canopy_spectra(tile: Tile, area, params: TreeParams, plan: AreaPlan,
                        surface: SurfaceOptions, stands=None, keys=(), progress=None) -> dict:
    """``-spacing auto``'s second look at the stands whose tops show no lattice: the tile's
    canopy over each stand of ``keys`` (stand indices; ``"all"``: the whole area) within the
    tile's core, and its local maxima there
    (:func:`lidartrees_gis.plantation.canopy_lattice.canopy_peaks`), ``{key: (part, (x,
    y))}``. The part is the canopy's cells
    (:func:`lidartrees_gis.plantation.canopy_lattice.canopy_crop`): a stand's spectrum is
    that of its whole canopy, the same in any tiling; for a stand (or area) over
    :data:`~lidartrees_gis.plantation.canopy_lattice.CANOPY_MAX_CELLS` cells, the spectrum of
    the tile's part (:func:`lidartrees_gis.plantation.canopy_lattice.canopy_spectrum`), summed
    over its tiles (:func:`lidartrees_gis.plantation.canopy_lattice.stand_spectrum`). Reads
    the surfaces :func:`tile_first_tops` kept, else makes them again."""
    from ..catalog.source import shared_cache
    from ..plantation.canopy_lattice import (CANOPY_MAX_CELLS, canopy_crop, canopy_peaks,
                                             canopy_spectrum)
    from ..plantation.stands import zones

    cache = shared_cache()
    s = None
    if cache is not None:
        s = cache.get(_surfaces_key(tile, plan, params), keep=True)
    if not (isinstance(s, dict) and "chm" in s):
        s = box_surfaces(area, tile.box, plan.res, surface, stats=plan.stats, whole_dtm=False,
                         progress=progress)
    if s is None:
        return {}
    spec = s["spec"]
    zone = zones(stands, spec) if stands is not None else None
    rows, cols = np.indices(spec.shape)
    core = tile.in_core(*spec.xy(rows, cols))  # the tiles' spectra cover disjoint cells
    out = {}
    for k in keys:
        mask = core if k == "all" or zone is None else core & (zone == k)
        if mask.any():
            x0, y0, x1, y1 = area.extent if k == "all" or zone is None else \
                stands.geoms[k].bounds
            whole = (x1 - x0) * (y1 - y0) / spec.res ** 2 <= CANOPY_MAX_CELLS
            part = canopy_crop(s["chm"], spec, mask) if whole else \
                canopy_spectrum(s["chm"], spec.res, mask)
            out[k] = (part, canopy_peaks(s["chm"], spec, mask, params.min_height))
    return out


def _surfaces_key(tile: Tile, plan: AreaPlan, params: TreeParams) -> tuple:
    return ("tile surfaces", tuple(map(float, tile.box)), float(plan.res),
            bool(params.looks_at_planting))


def _kept_surfaces(tile: Tile, plan: AreaPlan, params: TreeParams):
    """The surfaces :func:`tile_first_tops` left for this tile, or None (none kept, dropped
    for the cache's budget, or another process replacing them: a miss)."""
    from ..catalog.source import shared_cache

    cache = shared_cache()
    if cache is None:
        return None
    s = cache.take(_surfaces_key(tile, plan, params))
    return s if isinstance(s, dict) and "chm" in s else None


def tile_trees(tile: Tile, area, params: TreeParams, plan: AreaPlan, surface: SurfaceOptions,
               send_chm: bool = False, stands=None, grids=None, surfaces=None,
               progress=None) -> dict:
    """The trees of one tile: the tops in its core with their whole crowns (WKB), their
    measures, the plantation counts of its core and, with ``send_chm``, its core CHM.
    ``stands``: :class:`lidartrees_gis.plantation.stands.Stands`: each tree's stand, each stand's
    cells and (plantation mode) its own lattice's counts in the core; ``grids``: each stand's
    lattice fitted on the whole area (:func:`tile_first_tops`). ``surfaces``: the tile's
    surfaces when they are already computed."""
    import shapely

    from ..plantation.stands import locate, stand_cells, zones

    prog = as_progress(progress)
    if surfaces is None and grids is not None:  # plantation mode's first pass kept them
        surfaces = _kept_surfaces(tile, plan, params)
    s = surfaces if surfaces is not None else box_surfaces(
        area, tile.box, plan.res, surface, stats=plan.stats,
        keep_points=params.looks_at_planting, whole_dtm=False, progress=prog)
    if s is None:
        return _empty_trees(tile, plan.res)
    spec = s["spec"]
    check_cancel(prog)
    prog.update(0.85 if surfaces is None else 0.5, "detecting trees")
    whole = len(plan.tiles) == 1  # one tile: its core is the whole area
    zone = zones(stands, spec) if stands is not None else None
    if params.looks_at_planting:
        r = detect_with_stocking(s["chm"], spec, params, heights=s["heights"],
                                 returns=s["returns"], progress=prog, zone=zone,
                                 points=s.get("points_above_ground"), grids=grids,
                                 regions=number_regions(stands, area.extent),
                                 within=None if whole or params.spacing is None else tile.core)
    else:
        r = detect_trees(s["chm"], spec, params, heights=s["heights"])
    t = r["table"]
    idx = np.nonzero(tile.in_core(t["x"], t["y"]))[0]
    remap = np.zeros(len(t["x"]) + 1, np.int64)
    remap[idx + 1] = np.arange(1, idx.size + 1)
    wkb, box = crown_polygons(remap[r["labels"]], spec, idx.size, wkb=True, boxes=True)
    st = r.get("stocking")  # plantation mode: the core's positions
    if st is not None:
        t = {**t, "row_number": st["tops_row"], "plant_number": st["tops_plant"]}
    else:
        t = {**t, "row_number": np.zeros(len(t["x"]), np.int64),
             "plant_number": np.zeros(len(t["x"]), np.int64)}
    t["stand"] = locate(stands, t["x"], t["y"])
    t["suppressed"] = np.zeros(len(t["x"]), np.int64)
    out = {c: np.asarray(t[c])[idx] for c in TREE_FIELDS}
    out["gap_trees"] = _core_gap_trees(r, t, idx)
    # the method that grew this tile's crowns (mcws for watershed crowns grown again)
    out["crown_method"] = str(t["method"][0]) if len(t["method"]) else params.method
    under = _suppressed_trees(st if st is not None else r.get("understorey"), tile, spec.res,
                              stands)
    out["planting"] = r.get("planting_detected")
    out["stocking"] = None if st is None else {
        **{k: st[k] for k in ("expected", "stocked", "missing", "extra", "planted_area_ha",
                              "numbering", "suppressed", "uncertain", "uncertain_stocked",
                              "missing_crowned", "stocked_var", "resolved_var",
                              "edge_unresolved")},
        # what the gaps layer writes of the empty positions
        "gaps": st["gaps"].with_columns(i=None, j=None, edge=None, height=None, tree_x=None,
                                        tree_y=None),
        "azimuth": st["grid"].azimuth if st["grid"] is not None else float("nan"),
        "spacing": st["spacing"]}
    out["stand_stocking"] = None if st is None else st["zones"]
    # why a stand (or the area: "all") whose canopy shows rows has no lattice
    # and, with an explicit spacing, the stands whose tops lie on another lattice
    found = {} if st is None else (st.get("grids") or {})
    for kind in ("why", "other"):
        out[f"lattice_{kind}"] = {k[1]: v for k, v in found.items()
                                  if isinstance(k, tuple) and k[0] == kind}
    if under is not None:  # no crown of their own: a NULL crown polygon
        out = {c: np.r_[out[c], under[c]] for c in TREE_FIELDS} | {
            k: v for k, v in out.items() if k not in TREE_FIELDS}
        wkb = np.r_[wkb, np.array([None] * len(under["x"]), dtype=object)]
        box = np.r_[box, np.full((len(under["x"]), 4), np.nan)]
    n = len(out["x"])
    out["wkb"] = wkb if n else []
    out["crown_box"] = box if n else np.empty((0, 4))  # the crowns' bounds (spatial index)
    out["top_wkb"] = shapely.to_wkb(shapely.points(out["x"], out["y"])) if n else []
    r0, r1, c0, c1 = core_window(spec, tile.core)
    core = s["chm"][r0:r1, c0:c1]
    out.update({"chm": core.astype(np.float32) if send_chm else np.empty((0, 0), np.float32),
                "chm_left": spec.left + c0 * spec.res, "chm_top": spec.top - r0 * spec.res,
                "res": spec.res, "canopy_cells": int(np.isfinite(core).sum()),
                "points": s["points"], "dropped": s["dropped"],
                "outlier_points": s["outlier_points"], "tile": tile.index,
                "stand_cells": {} if zone is None else stand_cells(zone[r0:r1, c0:c1], core,
                                                                     params.min_height)})
    return out


def number_regions(stands, extent) -> dict:
    """Where plantation mode numbers each stand's rows and plants from
    (:func:`lidartrees_gis.plantation.positions.add_anchors`): each stand's polygon, and the area's
    extent for the positions outside every stand (or of an area without stands)."""
    import shapely

    out = {-1: shapely.box(*extent)}
    if stands is not None:
        out.update({k: g for k, g in enumerate(stands.geoms)})
    return out


def _canopy_of(x, y, tops, st, zone, spec, hd) -> np.ndarray:
    """The canopy's height over each point ``x, y``: the median of the ``tops`` around it
    within 1.5 x its own stand's larger spacing
    (:func:`lidartrees_gis.plantation.status.canopy_over`; ``hd`` where too few)."""
    from ..plantation.positions import own_spacings, top_zones
    from ..plantation.status import canopy_over

    if st.get("spacing") is None:
        return np.full(np.asarray(x).size, float(hd))
    larger = None
    if zone is not None and st.get("zones"):
        larger = own_spacings(st, top_zones(x, y, zone, spec), larger=True)
    return canopy_over(x, y, tops, st["spacing"], hd, larger=larger)


def _tops_xyh(t) -> tuple:
    """``(x, y, height)`` of a tops table."""
    return (np.asarray(t["x"], float), np.asarray(t["y"], float),
            np.asarray(t["height"], float))


def _dominant_height(result, arr, spec, params: TreeParams) -> float:
    """The dominant height the adaptive window used (the plan's, or the CHM's own)."""
    hd = (result.get("auto") or {}).get("dominant_height", params.dominant_height)
    if hd is None:
        from .trees import resolve_auto

        hd = resolve_auto(arr, spec.res, params)["dominant_height"]
    return float(hd)


#: plantation mode: a top lower than this share of its neighbours' canopy is the understorey
#: (shrubs, regrowth), not a planted tree; the same share a suppressed tree must reach
#: (:data:`lidartrees_gis.plantation.status.SUPPRESSED_HEIGHT`, kept equal by a test)
UNDERSTOREY_HEIGHT = 0.3


def _one_per_position(result, st, arr, spec, params: TreeParams, heights, zone, within):
    """Plantation mode's tops: those below :data:`UNDERSTOREY_HEIGHT` x their neighbours'
    canopy (:func:`_canopy_of`), and those whose planting position a nearer top took (a
    crown's second top, a flank between rows), are dropped and the crowns grown again from
    the others (their crowns take the dropped tops' cells). Returns the result and its stocking."""
    from ..plantation.positions import stocking_by_stand

    t = result["table"]
    hd = _dominant_height(result, arr, spec, params)
    # under its own neighbours' canopy: a young stand beside an older one keeps its trees
    # (the area's one dominant height dropped them all)
    canopy = _canopy_of(t["x"], t["y"], _tops_xyh(t), st, zone, spec, hd)
    low = np.asarray(t["height"], float) < np.maximum(params.min_height,
                                                      UNDERSTOREY_HEIGHT * canopy)
    # only where a lattice was found: a stand without one keeps the defaults' trees
    low &= _on_lattice(t, st, zone, spec)
    drop = low | np.asarray(st.get("shares", np.zeros(low.size, bool)), bool)
    if not drop.any() or drop.all():
        return result, st
    keep = ~drop
    auto = result.get("auto")
    result = detect_trees(arr, spec, params, heights=heights,
                          tops=(np.asarray(t["row"])[keep], np.asarray(t["col"])[keep]))
    if auto is not None and "auto" not in result:
        result["auto"] = auto
    result["dropped_tops"] = int(drop.sum())
    t = result["table"]
    st = stocking_by_stand(t["x"], t["y"], arr, spec, params.spacing, zone,
                           min_height=params.min_height, within=within, grids=st["grids"],
                           masks=st.get("masks"))
    return result, st


def _on_lattice(t, st, zone, spec) -> np.ndarray:
    """Whether each top of the table ``t`` lies in a zone (stand, or the cells outside every
    stand) whose planting positions ``st`` counts: one with a lattice."""
    from ..plantation.positions import top_zones

    x = np.asarray(t["x"], float)
    fitted = list((st.get("zones") or {}).keys())
    if not fitted:
        return np.zeros(x.size, bool)
    tz = np.full(x.size, -1) if zone is None else top_zones(x, np.asarray(t["y"], float),
                                                           zone, spec)
    return np.isin(tz, fitted)


def _planted_separation(result, arr, spec, params: TreeParams, heights, spacing) -> dict:
    """The defaults' tops again with plantation mode's separation (``SEPARATION_PLANTED`` x
    the smaller spacing of the lattice found under them), when it is wider than theirs and no
    ``-min_separation`` was given: small crowns a spacing apart measure a small crown scale,
    whose separation lets a crown keep two tops (precision 0.88 on 0.6-1.0 m crowns at 3 x 2 m,
    benchmarks/_family.py)."""
    from dataclasses import replace

    from .trees import SEPARATION_CELLS, SEPARATION_CROWNS, SEPARATION_PLANTED

    if params.min_separation is not None or params.tops_finder != "aw":
        return result
    cs = result.get("auto", {}).get("crown_scale")
    if cs is None:
        return result
    sep = min(SEPARATION_CELLS * spec.res, SEPARATION_CROWNS * cs)
    planted = SEPARATION_PLANTED * min(spacing)
    if planted <= sep:
        return result
    return detect_trees(arr, spec, replace(params, min_separation=planted), heights=heights)


def _suppressed_trees(st, tile: Tile, res: float, stands) -> dict | None:
    """The suppressed trees of a tile's core, as tree rows: the empty planting positions
    classified as holding one (:func:`lidartrees_gis.plantation.status.classify_gaps`;
    ``suppressed`` = 1), and the uncertain ones whose share of crown returns leans to a tree
    (``suppressed`` = 2: the likelier answer, for a field check)."""
    from .metrics import tree_ids
    from ..plantation.status import SUPPRESSED, SUPPRESSED_SHARE, UNCERTAIN
    from ..plantation.stands import locate

    if st is None or st["gaps"].status is None:
        return None
    gaps = st["gaps"]
    gx, gy = gaps.tree_x, gaps.tree_y
    status = gaps.status
    leans = (status == UNCERTAIN) & (gaps.share >= SUPPRESSED_SHARE)
    keep = ((status == SUPPRESSED) | leans) & tile.in_core(gx, gy)
    if not keep.any():
        return None
    n = int(keep.sum())
    zero = np.zeros(n)
    return {"tree_id": tree_ids(gx[keep], gy[keep], res), "x": gx[keep], "y": gy[keep],
            "height": gaps.height[keep], "crown_area": zero,
            "crown_diameter": zero, "n_cells": zero.astype(np.int64),
            "row_number": gaps.row[keep], "plant_number": gaps.plant[keep],
            "stand": locate(stands, gx[keep], gy[keep]),
            "suppressed": np.where(leans[keep], 2, 1).astype(np.int64)}


def _core_gap_trees(r: dict, t: dict, idx) -> int:
    """How many of the core's trees the second look at the planting positions added."""
    if "gap_tops" not in r:
        return 0
    added = set(zip(*(np.asarray(a).tolist() for a in r["gap_tops"])))
    return sum((a, b) in added for a, b in zip(np.asarray(t["row"])[idx].tolist(),
                                                np.asarray(t["col"])[idx].tolist()))


def tile_surfaces(tile: Tile, area, plan: AreaPlan, surface: SurfaceOptions, names: tuple,
                  surfaces=None, progress=None) -> dict:
    """The core window of the tile's surfaces named in ``names`` (``chm``, ``dtm``, ``dsm``)."""
    s = surfaces if surfaces is not None else box_surfaces(area, tile.box, plan.res, surface,
                                                           stats=plan.stats,
                                                           progress=progress)
    if s is None:
        e = np.empty((0, 0), np.float32)
        return {**{k: e for k in names}, "left": tile.box[0], "top": tile.box[3],
                "points": 0, "dropped": {}, "outlier_points": 0, "dtm_method": None}
    spec = s["spec"]
    r0, r1, c0, c1 = core_window(spec, tile.core)
    return {**{k: s[k][r0:r1, c0:c1].astype(np.float32) for k in names},
            "left": spec.left + c0 * spec.res, "top": spec.top - r0 * spec.res,
            "points": s["points"], "dropped": s["dropped"], "outlier_points": s["outlier_points"],
            "dtm_method": s["dtm_method"]}


def tile_grid(tile: Tile, catalog, plan: AreaPlan, stat: str, fill: str = "none",
              progress=None) -> dict:
    """One per-cell statistic (``max``, ``min``, ``mean``, ``count``) of the points in the tile,
    its empty cells filled by ``fill`` (``mean8``: over the buffer too) or left empty."""
    src = TileSource(catalog, tile.box)
    spec = grid_spec_for(src, plan.res)
    acc = GridAccumulator(spec, (stat,))
    n = 0
    for chunk in src.chunks(progress):
        n += len(chunk)
        acc.add(chunk.x, chunk.y, chunk.z)
    r0, r1, c0, c1 = core_window(spec, tile.core)
    arr = acc.result(stat)
    if stat != "count" and n:
        arr = fill_gaps(arr, fill)
    return {"grid": arr[r0:r1, c0:c1], "left": spec.left + c0 * spec.res,
            "top": spec.top - r0 * spec.res, "points": n, "dropped": dict(src.dropped)}
