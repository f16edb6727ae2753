"""Tiled processing of many files with buffers, on Dask (lidR LAScatalog semantics).

The area of a :class:`~lidartrees_gis.catalog.Catalog` is cut into tiles aligned to multiples of
the tile size; each tile is processed with a buffer around it as one task: its points (from
every file that touches the buffered tile) become a CHM, trees are detected on it, and only the
trees whose top lies in the tile's core are kept, with their whole crowns (grown inside the
buffer). Every choice that the defaults make from the data (cell size, crown scale, dominant
height) is made once for the whole area before the tiles run, and tree ids come from the top's
cell in the global grid, so the trees do not depend on the tiling. Memory is bounded by one
buffered tile per worker plus a bounded cache of decompressed files (so that neighbouring tiles
do not decompress a file again, :data:`~lidartrees_gis.catalog.READ_CACHE_BYTES`); results are
merged by the calling process as tiles finish.

Tasks run in this process with ``workers=1``, on a local ``dask.distributed`` cluster with
``workers`` processes (default: all cores), or on an existing cluster (``scheduler`` address).
"""
from __future__ import annotations

import math

import numpy as np

from ..catalog.catalog import Catalog, Tile, make_tiles
from ..catalog.mosaic import MosaicWriter
from ..catalog.runner import TileRunner, default_workers
from ..catalog.source import TileSource
from ..errors import InputError
from ..io.vector import start_from_existing
from ..progress import as_progress

#: the smallest and largest default tile side (m); between them the side holds about
#: TILE_POINTS points (see :func:`auto_tile_size`)
TILE_SIZE = 250.0
MAX_TILE_SIZE = 1000.0
TILE_POINTS = 500_000
#: default buffer = BUFFER_CROWNS x the crown scale, at least MIN_BUFFER m (two DTM triangle
#: radii, see :data:`lidartrees_gis.grid.DTM_MAX_RADIUS`)
BUFFER_CROWNS = 8.0
MIN_BUFFER = 20.0


def auto_tile_size(density: float) -> float:
    """Default tile side (m) for ``density`` points per m² (over the 1 m cells holding points):
    the side of a square holding :data:`TILE_POINTS` points, rounded to 50 m, between
    :data:`TILE_SIZE` and :data:`MAX_TILE_SIZE`. Dense data keep 250 m tiles (memory per
    worker); in sparse data larger tiles spend less of the work on their buffers. Measured on
    the Megaplot copies (1.9 points per occupied m², so 500 m): 16 M points 39.8 -> 38.6 s on
    one core and 26.5 -> 24.4 s on two workers, peak RSS +85 MB (610 MB).

    >>> auto_tile_size(1.9), auto_tile_size(4.0), auto_tile_size(25.0), auto_tile_size(0.1)
    (500.0, 350.0, 250.0, 1000.0)
    """
    if not density > 0:
        return TILE_SIZE
    side = round(math.sqrt(TILE_POINTS / density) / 50.0) * 50.0
    return float(min(max(side, TILE_SIZE), MAX_TILE_SIZE))


def _tile_side(tile_size, density: float, res: float) -> float:
    """The tile side (m): ``tile_size`` or :func:`auto_tile_size`, on whole cells (inf: one
    tile)."""
    ts = float(tile_size) if tile_size else auto_tile_size(density)
    return max(res, round(ts / res) * res) if math.isfinite(ts) else ts


def _surfaces(catalog: Catalog, box, opts: dict):
    """Surfaces of the points in ``box``; None when the box holds no point (a gap between
    files, a corner of the area)."""
    from .pipeline import compute_surfaces
    from ..io.options import parse_classes

    src = TileSource(catalog, box)
    if not src.files:
        return None
    src.set_class_filter(drop=parse_classes(opts["drop_class"]) or (),
                         keep=parse_classes(opts["keep_class"], "-keep_class"))
    try:
        return compute_surfaces(src, opts["res"], dtm=opts["dtm"], fill=opts["fill"],
                                chm=opts["chm"], outliers=opts["outliers"],
                                max_edge=opts.get("max_edge"))
    except InputError as exc:
        if "no points" in str(exc):
            return None
        raise


def _window_edge(box, catalog: Catalog, opts: dict, res: float) -> float:
    """The pit-free edge limit of the points in ``box`` by the rule of a single file
    (:func:`lidartrees_gis.chm.pitfree_edge` of the first returns over the ``res`` cells that
    hold a return); NaN for an empty box."""
    from .chm import pitfree_edge
    from ..io.options import parse_classes

    src = TileSource(catalog, box)
    src.set_class_filter(drop=parse_classes(opts["drop_class"]) or (),
                         keep=parse_classes(opts["keep_class"], "-keep_class"))
    n_first, cells = 0, set()
    for c in src.chunks():
        n_first += len(c) if c.return_number is None else int((c.return_number <= 1).sum())
        cells.update(np.unique(np.floor(c.x / res).astype(np.int64) * 100_000_007
                               + np.floor(c.y / res).astype(np.int64)).tolist())
    return pitfree_edge(n_first, len(cells) * res * res) if cells else float("nan")


def _window_density(box, catalog: Catalog, opts: dict) -> float:
    """Points per m² inside ``box``, over the cells of
    :data:`~lidartrees_gis.pipeline.FOOTPRINT_CELL` (aligned on the box) that hold points, so edges, gaps between files and a file's empty
    corners do not count: the rule of one file's ``-tr auto``. (Over 1 m cells sparse data
    looked denser than it is, as a 1 m cell is often empty: 1.73 points/m² for Topography's
    1.0, and 0.75 m cells instead of one file's 1.0 m.)"""
    from .pipeline import FOOTPRINT_CELL
    from ..io.options import parse_classes

    src = TileSource(catalog, box)
    src.set_class_filter(drop=parse_classes(opts["drop_class"]) or (),
                         keep=parse_classes(opts["keep_class"], "-keep_class"))
    n, cells = 0, set()
    for c in src.chunks():
        n += len(c)
        gx = np.floor((c.x - box[0]) / FOOTPRINT_CELL).astype(np.int64)
        gy = np.floor((c.y - box[1]) / FOOTPRINT_CELL).astype(np.int64)
        cells.update(np.unique(gx * 10_000_019 + gy).tolist())
    return n / (len(cells) * FOOTPRINT_CELL ** 2) if cells else float("nan")


def _window_canopy(box, catalog: Catalog, opts: dict, min_height: float, want_scale: bool):
    """``(95th percentile of canopy height, crown scale or NaN)`` of one window, or None when
    it holds no points or too little canopy."""
    from .chm import crown_scale

    s = _surfaces(catalog, box, opts)
    if s is None:
        return None
    chm = s["chm"]
    canopy = chm[np.isfinite(chm) & (chm >= min_height)]
    if canopy.size < 25:
        return None
    cs = crown_scale(chm, opts["res"], min_height=min_height) if want_scale else float("nan")
    return float(np.percentile(canopy, 95)), cs


def area_parameters(catalog: Catalog, res, params, opts: dict, *, window: float = 150.0,
                    runner=None) -> dict:
    """Cell size, crown scale and dominant height of the whole area, measured once.

    They are measured on up to nine ``window``-metre squares centred on a 3 x 3 grid over the
    area (windows without points or canopy are skipped): the median point density over the 3 m
    cells holding points gives the cell size (as for one file); the medians of the windows' crown scales and
    95th percentiles of canopy height give the crown scale and the dominant height. They
    depend on the points only, not on how the area is tiled or split into files. The windows
    are measured as tasks of ``runner`` (a :class:`TileRunner`; default: in this process).
    """
    from .chm import chm_resolution
    from ..grid import check_resolution
    from .trees import SPACING_FACTOR

    fixed_res = None if res is None or str(res).strip().lower() == "auto" else check_resolution(res)
    out = {"res": fixed_res, "crown_scale": params.crown_scale,
           "dominant_height": params.dominant_height}
    if params.crown_scale is None and params.spacing is not None:
        out["crown_scale"] = SPACING_FACTOR * min(params.spacing)
    x0, y0, x1, y1 = catalog.extent
    h = window / 2
    boxes = []
    for fy in (1 / 6, 1 / 2, 5 / 6):
        for fx in (1 / 6, 1 / 2, 5 / 6):
            cx, cy = x0 + fx * (x1 - x0), y0 + fy * (y1 - y0)
            box = (max(cx - h, x0), max(cy - h, y0), min(cx + h, x1), min(cy + h, y1))
            if box not in boxes:
                boxes.append(box)
    run = runner.map if runner is not None else TileRunner(1).map
    dens = [d for d in run(_window_density, boxes, (catalog, opts), ordered=True)
            if np.isfinite(d)]
    if not dens:
        raise InputError(f"{catalog.files[0]}: no points found to measure the point density")
    out["density"] = float(np.median(dens))
    r = fixed_res if fixed_res is not None else chm_resolution(int(round(out["density"] * 1e6)), 1e6)
    out["res"] = r
    # the pit-free edge limit of the area (the single-file rule, median of the windows), the
    # same in every tile
    edges = [e for e in run(_window_edge, boxes, (catalog, opts, r), ordered=True)
             if np.isfinite(e)]
    out["max_edge"] = float(np.median(edges)) if edges else 1.5
    opts = {**opts, "max_edge": out["max_edge"]}
    if out["crown_scale"] is not None and out["dominant_height"] is not None:
        return out
    got = [g for g in run(_window_canopy, boxes, (catalog, {**opts, "res": r}, params.min_height,
                                                   out["crown_scale"] is None), ordered=True)
           if g is not None]
    heights = [h for h, _ in got]
    scales = [c for _, c in got if np.isfinite(c)]
    if out["crown_scale"] is None:
        if not scales:
            raise InputError(f"{catalog.files[0]}: no canopy above {params.min_height:g} m found "
                             "to measure the crown scale; give -crown_scale")
        out["crown_scale"] = float(np.median(scales))
    if out["dominant_height"] is None:
        out["dominant_height"] = float(np.median(heights)) if heights else max(params.min_height, 1.0)
    return out


def tile_trees(tile: Tile, catalog: Catalog, params, opts: dict) -> dict:
    """Trees of one tile: the tops in its core with their whole crowns, and its core CHM."""
    import shapely

    from .metrics import crown_polygons
    from .trees import detect_trees

    s = _surfaces(catalog, tile.box, opts)
    if s is None:
        cols = ("tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells")
        return {**{c: np.empty(0, np.int64 if c in ("tree_id", "n_cells") else np.float64)
                   for c in cols}, "wkb": [], "top_wkb": [], "gap_trees": 0, "planting": None,
                "stocking": None, "chm": np.empty((0, 0), np.float32),
                "chm_left": tile.core[0], "chm_top": tile.core[3], "res": opts["res"],
                "canopy_cells": 0, "points": 0, "dropped": {}, "outlier_points": 0,
                "tile": tile.index}
    spec = s["spec"]
    if params.looks_at_planting:
        # the tile's own look for a planting lattice under its tops (with its buffer), and a
        # second look at the lattice's empty positions, as for one file
        from .pipeline import detect_with_stocking

        r = detect_with_stocking(s["chm"], spec, params, heights=s["heights"],
                                 returns=s["returns"],
                                 within=tile.core if params.spacing is not None else None)
    else:
        r = detect_trees(s["chm"], spec, params, heights=s["heights"])
    t = r["table"]
    keep = tile.in_core(t["x"], t["y"])
    idx = np.nonzero(keep)[0]
    remap = np.zeros(len(t["x"]) + 1, np.int64)
    remap[idx + 1] = np.arange(1, idx.size + 1)
    labels = remap[r["labels"]]
    polys = crown_polygons(labels, spec, idx.size)
    cols = ("tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells")
    out = {c: np.asarray(t[c])[idx] for c in cols}
    gap_trees = 0
    if "gap_tops" in r:  # the trees of the second look that lie in the core
        added = set(zip(*(np.asarray(a).tolist() for a in r["gap_tops"])))
        gap_trees = sum((a, b) in added for a, b in zip(np.asarray(t["row"])[idx].tolist(),
                                                         np.asarray(t["col"])[idx].tolist()))
    out["gap_trees"] = gap_trees
    g = r.get("planting_detected")
    out["planting"] = tuple(float(v) for v in g.split("x")) if g else None
    st = r.get("stocking")  # plantation mode: the core's positions
    out["stocking"] = None if st is None else {
        **{k: st[k] for k in ("expected", "stocked", "missing", "extra", "planted_area_ha",
                              "gaps_x", "gaps_y", "gaps_i", "gaps_j")},
        "azimuth": st["grid"].azimuth}
    out["wkb"] = shapely.to_wkb(np.asarray(polys, dtype=object)) if idx.size else []
    out["top_wkb"] = shapely.to_wkb(shapely.points(out["x"], out["y"])) if idx.size else []
    # the core window of the CHM in the tile's grid
    x0, y0, x1, y1 = tile.core
    c0 = max(0, int(math.floor((x0 - spec.left) / spec.res + 1e-9)))
    c1 = min(spec.width, int(math.ceil((x1 - spec.left) / spec.res - 1e-9)))
    r0 = max(0, int(math.floor((spec.top - y1) / spec.res + 1e-9)))
    r1 = min(spec.height, int(math.ceil((spec.top - y0) / spec.res - 1e-9)))
    core = s["chm"][r0:r1, c0:c1]
    send = opts.get("return_chm", True)  # the core CHM goes back only for a -chm_out mosaic
    out.update({"chm": core.astype(np.float32) if send else np.empty((0, 0), np.float32),
                "chm_left": spec.left + c0 * spec.res,
                "chm_top": spec.top - r0 * spec.res, "res": spec.res,
                "canopy_cells": int(np.isfinite(core).sum()), "points": s["points"],
                "dropped": s["dropped"], "outlier_points": s["outlier_points"],
                "tile": tile.index})
    return out


def plan(catalog: Catalog, params, opts: dict, tile_size=None, buffer=None, runner=None):
    """Area parameters and tiles: ``(params with crown scale and dominant height, opts with the
    cell size and the median point density, tiles, buffer)``."""
    from dataclasses import replace

    ap = area_parameters(catalog, opts.get("res"), params, opts, runner=runner)
    params = replace(params, crown_scale=ap["crown_scale"], dominant_height=ap["dominant_height"])
    opts = {**opts, "res": ap["res"], "max_edge": ap["max_edge"], "density": ap["density"]}
    ts = _tile_side(tile_size, ap["density"], ap["res"])  # tile edges on cell edges
    buf = float(buffer) if buffer is not None else max(MIN_BUFFER, BUFFER_CROWNS * ap["crown_scale"])
    if buf < 0:
        raise InputError(f"-buffer must be >= 0 m, got {buffer}")
    return params, opts, make_tiles(catalog.extent, ts, buf), buf


def _options(kw: dict) -> dict:
    return {"res": kw.get("res", "auto"), "dtm": kw.get("dtm", "auto"),
            "chm": kw.get("chm", "pitfree"), "fill": kw.get("fill", "mean8"),
            "outliers": kw.get("outliers", True), "drop_class": kw.get("drop_class", "7,18"),
            "keep_class": kw.get("keep_class")}


_TREE_COLS = ("tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells")


def _tree_rows(r: dict) -> dict:
    """One tile's trees as arrays, ordered by tree_id (WKB crowns and tops under ``wkb`` and
    ``top_wkb``)."""
    order = np.argsort(r["tree_id"], kind="stable")
    rows = {c: np.asarray(r[c])[order] for c in _TREE_COLS}
    for g in ("wkb", "top_wkb"):
        rows[g] = np.asarray(list(r[g]), dtype=object)[order]
    return rows


def _tree_fields(parts: list, method: str):
    """Field names and arrays of several tiles' :func:`_tree_rows`, for one write of the
    batch: the workers' WKB goes to GDAL as it is (decoding it into shapely geometries and a
    GeoDataFrame only to encode it again was a fifth of the calling process's work)."""
    data = [np.concatenate([p[c] for p in parts]) for c in _TREE_COLS]
    data[0] = data[0].astype(np.int64)  # tree_id
    data[-1] = data[-1].astype(np.int64)  # n_cells
    data.append(np.full(len(data[0]), method, dtype=object))
    return [*_TREE_COLS, "method"], data


def trees_tiled(input, output, *, params=None, tile_size=None, buffer=None, workers=None,
                scheduler=None, nln="", layer_options=None, overwrite=False, append=False,
                chm_out=None, creation_options=None, a_srs=None, progress=None, read_kw=None,
                **kw) -> dict:
    """``lidartrees trees`` over many files or a large area, tile by tile (see module doc).

    Trees are appended to the GeoPackage (a temporary copy, renamed at the end) as tiles finish,
    so the calling process holds one tile's trees at a time; the summary table comes last.
    """
    import contextlib
    import warnings
    from pathlib import Path

    import pandas as pd
    import pyogrio
    import pyogrio.raw

    from .. import __version__
    from ..crs import crs_label
    from ..grid import GridSpec
    from ..io.output import atomic_output, check_outputs
    from .metrics import tree_ids
    from .pipeline import stocking_fields, warn_sparse_plantation
    from ..progress import SubProgress
    from .trees import TreeParams

    p = params or TreeParams()
    out_path = Path(output)
    if out_path.suffix.lower() != ".gpkg":
        raise InputError(f"OUTPUT: {out_path}: expected a .gpkg file name")
    outputs = [(output, "OUTPUT", overwrite or append), (chm_out, "-chm_out")]
    check_outputs(outputs, (), overwrite)
    prog = as_progress(progress)
    catalog = Catalog.open(input, a_srs=a_srs, **(read_kw or {}))
    check_outputs(outputs, catalog.files, overwrite)
    opts = _options(kw)
    prog.update(0.01, "area parameters")
    with TileRunner(default_workers(workers, scheduler, catalog.count), scheduler) as runner:
        p, opts, tiles, buf = plan(catalog, p, opts, tile_size, buffer, runner=runner)
        res = opts["res"]
        if p.spacing is not None:
            warn_sparse_plantation(opts["density"])
        gspec = GridSpec.from_bounds(*catalog.extent, res, crs=catalog.crs)
        crs = catalog.crs.to_wkt() if catalog.crs is not None else None
        meta = {"lidartrees_version": __version__, "input": str(input),
                "files": [str(f) for f in catalog.files], "res": res, **opts, **p.as_dict(),
                "tiles": len(tiles), "buffer": buf}
        meta = {k: (v if isinstance(v, str) else __import__("json").dumps(v, default=str))
                for k, v in meta.items()}
        names = {"tops": f"{nln}tree_tops", "crowns": f"{nln}crowns", "summary": f"{nln}summary",
                 "gaps": f"{nln}gaps"}
        ids, n, hsum, h2sum, dsum = [], 0, 0.0, 0.0, 0.0
        canopy, points, dropped, outliers = 0, 0, {}, 0
        gap_trees, lattices = 0, []  # trees of the second look; the tiles' planting lattices
        # plantation mode: the tiles' positions, stocked, missing, extra tops, planted area,
        # row azimuths
        stock = {"expected": 0, "stocked": 0, "missing": 0, "extra": 0, "planted_area_ha": 0.0}
        azimuths = []
        with contextlib.ExitStack() as stack:
            tmp = stack.enter_context(atomic_output(output, overwrite=True))
            existing = start_from_existing(out_path, tmp, append)
            created = set()

            def put(df, layer, geometry_type=None):
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", message="'crs' was not provided")
                    new = layer not in existing and layer not in created
                    pyogrio.write_dataframe(df, tmp, layer=layer, driver="GPKG", append=not new,
                                            layer_options=(layer_options or None) if new else None,
                                            layer_metadata=meta if new else None,
                                            geometry_type=geometry_type)
                created.add(layer)

            def put_wkb(wkb, fields, data, layer, geometry_type):
                new = layer not in existing and layer not in created
                pyogrio.raw.write(tmp, wkb, data, fields, layer=layer, driver="GPKG",
                                  geometry_type=geometry_type, crs=crs, append=not new,
                                  layer_options=(layer_options or None) if new else None,
                                  layer_metadata=meta if new else None)
                created.add(layer)

            def put_gaps(st, tile):
                # ids from the position's cell in the global grid (as tree_id); the row and
                # position indices are those of the tile's own lattice (``tile``)
                import shapely

                gx, gy = np.asarray(st["gaps_x"]), np.asarray(st["gaps_y"])
                fields = ["gap_id", "row_index", "position_in_row", "x", "y", "tile"]
                data = [tree_ids(gx, gy, res), np.asarray(st["gaps_j"], np.int64),
                        np.asarray(st["gaps_i"], np.int64), gx, gy,
                        np.full(gx.size, "_".join(map(str, tile)), dtype=object)]
                put_wkb(shapely.to_wkb(shapely.points(gx, gy)), fields, data, names["gaps"],
                        "Point")

            mosaic = None
            if chm_out:
                ctmp = stack.enter_context(atomic_output(chm_out, overwrite, param="-chm_out"))
                mosaic = MosaicWriter(ctmp, gspec, creation_options=creation_options,
                                      description="canopy height (m)",
                                      tags={"LIDARTREES_COMMAND": "trees", "LIDARTREES_INPUT": str(input)})
                stack.callback(mosaic.close)
            pending, pending_rows = [], 0

            def flush():
                # tiles' trees written together: one GeoPackage write per ~20,000 trees, not
                # two per tile (the writes are the calling process's main work)
                nonlocal pending, pending_rows
                if pending:
                    fields, data = _tree_fields(pending, p.method)
                    put_wkb(np.concatenate([q["top_wkb"] for q in pending]), fields, data,
                            names["tops"], "Point")
                    put_wkb(np.concatenate([q["wkb"] for q in pending]), fields, data,
                            names["crowns"], "Polygon")
                pending, pending_rows = [], 0

            topts = {**opts, "return_chm": mosaic is not None}
            for done, r in enumerate(runner.map(tile_trees, tiles, (catalog, p, topts),
                                                progress=SubProgress(prog, 0.02, 0.95)), 1):
                k = len(r["tree_id"])
                if k:
                    pending.append(_tree_rows(r))
                    pending_rows += k
                    # in the last wave of tiles, written as they come while the other workers
                    # finish theirs: only the last tile's trees are left to write at the end
                    if pending_rows >= 20_000 or len(tiles) - done < runner.workers:
                        flush()
                    ids.append(np.asarray(r["tree_id"], np.int64))
                    h = np.asarray(r["height"], float)
                    n += k
                    hsum += float(h.sum())
                    h2sum += float((h ** 2).sum())
                    dsum += float(np.sum(r["crown_diameter"]))
                canopy += r["canopy_cells"]
                points += r["points"]
                gap_trees += r["gap_trees"]
                if r["planting"]:
                    lattices.append(r["planting"])
                st = r["stocking"]
                if st is not None:
                    for key in stock:
                        stock[key] += st[key]
                    azimuths.append(st["azimuth"])
                    if st["missing"]:
                        put_gaps(st, r["tile"])
                outliers += r["outlier_points"] or 0
                for c, v in r["dropped"].items():
                    dropped[c] = dropped.get(c, 0) + v
                if mosaic is not None:
                    mosaic.write(r["chm"], r["chm_left"], r["chm_top"])
            flush()
            if n == 0:  # the layers exist even without trees
                import geopandas as gpd

                empty = {c: pd.Series([], dtype="int64" if c in ("tree_id", "n_cells") else "float64")
                         for c in ("tree_id", "x", "y", "height", "crown_area", "crown_diameter", "n_cells")}
                empty["method"] = pd.Series([], dtype=object)
                put(gpd.GeoDataFrame(empty, geometry=gpd.GeoSeries([], crs=crs)), names["tops"], "Point")
                put(gpd.GeoDataFrame(empty, geometry=gpd.GeoSeries([], crs=crs)), names["crowns"], "Polygon")
            if p.spacing is not None and names["gaps"] not in created:  # no empty position
                put_gaps({"gaps_x": [], "gaps_y": [], "gaps_i": [], "gaps_j": []}, ())
            area_ha = canopy * res * res / 1e4
            # the median spacings of the tiles that found a planting lattice under their tops
            planting = ("{:.2f}x{:.2f}".format(*np.median(np.asarray(lattices), axis=0))
                        if lattices else "")
            mean_h = hsum / n if n else np.nan
            sd_h = float(np.sqrt(max(h2sum - n * mean_h ** 2, 0.0) / (n - 1))) if n > 1 else np.nan
            srow = {
                "trees": n, "area_ha": area_ha, "trees_per_ha": n / area_ha if area_ha else np.nan,
                "mean_height": mean_h, "sd_height": sd_h,
                "mean_crown_diameter": dsum / n if n else np.nan,
                "method": p.method, "smooth": p.smooth, "tops": p.tops_finder, "res": res,
                "crown_scale": p.crown_scale, "dominant_height": p.dominant_height,
                "tiles": len(tiles), "tile_size": tiles[0].core[2] - tiles[0].core[0] if tiles else np.nan,
                "buffer": buf, "points": catalog.count, "outlier_points": outliers,
                "dropped_classes": ",".join(f"{c}:{v}" for c, v in sorted(dropped.items())),
                "gap_trees": gap_trees, "planting_detected": planting, "planting_tiles": len(lattices)}
            if p.spacing is not None:  # plantation mode: the stocking of all tiles
                srow.update(stocking_fields(
                    p.spacing, float(np.median(azimuths)) if azimuths else np.nan, stock))
            summary = pd.DataFrame([srow])
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message=".*geometry.*")
                pyogrio.write_dataframe(summary, tmp, layer=names["summary"], driver="GPKG",
                                        append=names["summary"] in existing)
        prog.update(1.0, "done")
        ids_all = np.concatenate(ids) if ids else np.empty(0, np.int64)
        return {"output": str(output), "trees": n, "crs": crs_label(catalog.crs), "files": len(catalog.files),
                "points": catalog.count, "points_read": points, "tiles": len(tiles), "buffer": round(buf, 2),
                "res": res, "crown_scale": round(float(p.crown_scale), 3),
                "mean_height": round(mean_h, 2) if n else None,
                "mean_crown_diameter": round(dsum / n, 2) if n else None,
                "trees_per_ha": round(n / area_ha, 1) if area_ha else None,
                "dropped_classes": {str(k): v for k, v in sorted(dropped.items())} or None,
                "outlier_points": outliers or None, "gap_trees": gap_trees,
                "planting_detected": planting or None, "planting_tiles": len(lattices),
                **({"row_azimuth": srow["row_azimuth"], "planting_positions": stock["expected"],
                    "missing_trees": stock["missing"],
                    "stocking_pct": round(srow["stocking_pct"], 2) if stock["expected"] else None}
                   if p.spacing is not None else {}),
                "table": None, "tree_ids": ids_all}


def chm_tile(tile: Tile, catalog: Catalog, opts: dict) -> dict:
    """The core window of one tile's surfaces named in ``opts["surfaces"]`` (``chm``, ``dtm``,
    ``dsm``)."""
    s = _surfaces(catalog, tile.box, opts)
    if s is None:
        e = np.empty((0, 0), np.float32)
        return {**{k: e for k in opts["surfaces"]}, "left": tile.core[0], "top": tile.core[3],
                "points": 0, "dropped": {}, "outlier_points": 0}
    spec = s["spec"]
    x0, y0, x1, y1 = tile.core
    c0 = max(0, int(math.floor((x0 - spec.left) / spec.res + 1e-9)))
    c1 = min(spec.width, int(math.ceil((x1 - spec.left) / spec.res - 1e-9)))
    r0 = max(0, int(math.floor((spec.top - y1) / spec.res + 1e-9)))
    r1 = min(spec.height, int(math.ceil((spec.top - y0) / spec.res - 1e-9)))
    return {**{k: s[k][r0:r1, c0:c1].astype(np.float32) for k in opts["surfaces"]},
            "left": spec.left + c0 * spec.res, "top": spec.top - r0 * spec.res,
            "points": s["points"], "dropped": s["dropped"], "outlier_points": s["outlier_points"]}


def chm_tiled(input, output, *, tile_size=None, buffer=None, workers=None, scheduler=None,
              dtm_out=None, dsm_out=None, overwrite=False, creation_options=None, a_srs=None,
              progress=None, read_kw=None, **kw) -> dict:
    """``lidartrees chm`` over many files: a CHM (and DTM, DSM) mosaic, tile by tile."""
    import contextlib

    from ..crs import crs_label
    from ..grid import GridSpec
    from ..io.output import atomic_output, check_outputs
    from ..progress import SubProgress

    outputs = [(output, "OUTPUT"), (dtm_out, "-dtm_out"), (dsm_out, "-dsm_out")]
    check_outputs(outputs, (), overwrite)
    prog = as_progress(progress)
    catalog = Catalog.open(input, a_srs=a_srs, **(read_kw or {}))
    check_outputs(outputs, catalog.files, overwrite)
    opts = _options(kw)
    from .trees import TreeParams

    with TileRunner(default_workers(workers, scheduler, catalog.count), scheduler) as runner:
        ap = area_parameters(catalog, opts["res"], TreeParams(crown_scale=1.0, dominant_height=1.0),
                             opts, runner=runner)  # the same cell size and edge as trees_tiled
        res = opts["res"] = ap["res"]
        opts["max_edge"] = ap["max_edge"]
        ts = _tile_side(tile_size, ap["density"], res)
        buf = float(buffer) if buffer is not None else MIN_BUFFER
        tiles = make_tiles(catalog.extent, ts, buf)
        gspec = GridSpec.from_bounds(*catalog.extent, res, crs=catalog.crs)
        tags = {"LIDARTREES_COMMAND": "chm", "LIDARTREES_INPUT": str(input),
                "LIDARTREES_PARAMETERS": {**opts, "tiles": len(tiles), "buffer": buf}}
        points, dropped, outliers = 0, {}, 0
        with contextlib.ExitStack() as stack:
            mosaics = {}  # surface -> its mosaic, for the outputs asked for
            for key, path, param, what in (("chm", output, "OUTPUT", "canopy height (m)"),
                                           ("dtm", dtm_out, "-dtm_out", "terrain height (m)"),
                                           ("dsm", dsm_out, "-dsm_out", "surface height (m)")):
                if path:
                    tmp = stack.enter_context(atomic_output(path, overwrite, param=param))
                    mosaics[key] = MosaicWriter(tmp, gspec, creation_options=creation_options,
                                                tags=tags, description=what)
                    stack.callback(mosaics[key].close)
            for r in runner.map(chm_tile, tiles, (catalog, {**opts, "surfaces": tuple(mosaics)}),
                                progress=SubProgress(prog, 0.02, 0.98)):
                for key, mos in mosaics.items():
                    mos.write(r[key], r["left"], r["top"])
                points += r["points"]
                outliers += r["outlier_points"] or 0
                for k, v in r["dropped"].items():
                    dropped[k] = dropped.get(k, 0) + v
        prog.update(1.0, "done")
        return {"output": str(output), "files": len(catalog.files), "points": catalog.count,
                "points_read": points, "res": res,
                "shape": gspec.shape, "tiles": len(tiles), "crs": crs_label(catalog.crs),
                "dropped_classes": {str(k): v for k, v in sorted(dropped.items())} or None,
                "outlier_points": outliers or None}
