"""Accuracy of detected trees against reference trees, after Eysn et al. (2015).

Eysn, L. et al. (2015) *A benchmark of lidar-based single tree detection methods using
heterogeneous forest data from the Alpine Space*, Forests 6, 1721-1747. Their matching: the
reference trees are visited from the tallest down; each takes the nearest detected tree not
yet taken that lies within 2.5 m horizontally and whose height differs by at most 5 m.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, ReadError

#: Eysn et al. 2015 matching limits
MAX_DIST = 2.5
MAX_DZ = 5.0


def match_eysn(det_x, det_y, det_h, ref_x, ref_y, ref_h, *, max_dist: float = MAX_DIST,
               max_dz: float = MAX_DZ):
    """One-to-one matching of detected to reference trees, tallest reference first.

    Parameters
    ----------
    det_x, det_y, det_h : (D,) array_like
        Detected tree positions and heights (heights may be None).
    ref_x, ref_y, ref_h : (R,) array_like
        Reference tree positions and heights (heights may be None: no height test, references
        visited in input order).
    max_dist : float
        Horizontal search radius (m).
    max_dz : float
        Largest height difference (m); ignored when either side has no heights.

    Returns
    -------
    det_index, ref_index : ndarray of int64
        Matched pairs, in the order the reference trees were visited.

    Examples
    --------
    >>> match_eysn([0, 1.0], [0, 0], [20, 10], [0.5], [0], [19])
    (array([0]), array([0]))
    """
    from scipy.spatial import cKDTree

    dx, dy = np.asarray(det_x, float), np.asarray(det_y, float)
    rx, ry = np.asarray(ref_x, float), np.asarray(ref_y, float)
    if dx.size == 0 or rx.size == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    use_h = det_h is not None and ref_h is not None
    dh = np.asarray(det_h, float) if use_h else None
    rh = np.asarray(ref_h, float) if use_h else None
    order = np.argsort(-rh, kind="stable") if use_h else np.arange(rx.size)
    tree = cKDTree(np.c_[dx, dy])
    taken = np.zeros(dx.size, bool)
    md, mr = [], []
    for i in order:
        cand = np.asarray(tree.query_ball_point([rx[i], ry[i]], max_dist), np.int64)
        if cand.size == 0:
            continue
        cand = cand[~taken[cand]]
        if use_h and cand.size:
            cand = cand[np.abs(dh[cand] - rh[i]) <= max_dz]
        if cand.size == 0:
            continue
        d = np.hypot(dx[cand] - rx[i], dy[cand] - ry[i])
        key = np.lexsort((np.abs(dh[cand] - rh[i]) if use_h else cand, d))
        j = int(cand[key[0]])
        taken[j] = True
        md.append(j)
        mr.append(int(i))
    return np.asarray(md, np.int64), np.asarray(mr, np.int64)


def _scores(n_det, n_ref, m):
    rec = m / n_ref if n_ref else float("nan")
    prec = m / n_det if n_det else float("nan")
    f = 2 * prec * rec / (prec + rec) if n_det and n_ref and (prec + rec) > 0 else 0.0
    return {"detected": int(n_det), "reference": int(n_ref), "matched": int(m),
            "recall": rec, "precision": prec, "f_score": f}


def evaluate_trees(det_x, det_y, det_h, ref_x, ref_y, ref_h=None, *, max_dist: float = MAX_DIST,
                   max_dz: float = MAX_DZ) -> dict:
    """Recall, precision, F-score and height bias / RMSE, for all and for dominant trees.

    Dominant trees are those at least half as tall as the tallest reference tree; for the
    dominant scores the detected trees of that height count, and matches are the pairs whose
    reference tree is dominant. Height bias = mean(detected - reference).

    Returns
    -------
    dict with ``all`` and ``dominant`` (each: detected, reference, matched, recall, precision,
    f_score, height_bias, height_rmse) and ``pairs`` (det_index, ref_index).
    """
    dh = None if det_h is None else np.asarray(det_h, float)
    rh = None if ref_h is None else np.asarray(ref_h, float)
    d, r = match_eysn(det_x, det_y, dh, ref_x, ref_y, rh, max_dist=max_dist, max_dz=max_dz)
    out = {"all": _scores(len(np.atleast_1d(det_x)), len(np.atleast_1d(ref_x)), len(d)),
           "pairs": (d, r), "max_dist": max_dist, "max_dz": max_dz}
    if rh is not None and dh is not None:
        def hstats(dd, rr):
            if len(dd) == 0:
                return {"height_bias": float("nan"), "height_rmse": float("nan")}
            e = dh[dd] - rh[rr]
            return {"height_bias": float(np.mean(e)), "height_rmse": float(np.sqrt(np.mean(e ** 2)))}

        out["all"].update(hstats(d, r))
        half = 0.5 * float(np.nanmax(rh)) if rh.size else 0.0
        dom_ref = rh >= half
        keep = dom_ref[r] if len(r) else np.zeros(0, bool)
        out["dominant"] = _scores(int((dh >= half).sum()), int(dom_ref.sum()), int(keep.sum()))
        out["dominant"]["min_height"] = half
        out["dominant"].update(hstats(d[keep], r[keep]))
    return out


def _pick(cols, attr):
    """The first of ``cols`` that names ``attr`` of :data:`~lidartrees_gis.io.names.TREE_COLUMNS`
    (English or Portuguese, any case or accents)."""
    from ..io.names import TREE_COLUMNS, match_column

    return next((c for c in cols if match_column(c, TREE_COLUMNS) == attr), None)


def read_trees(path, *, layer=None) -> dict:
    """Tree positions (and heights when present) from a CSV or a vector file (GeoPackage,
    shapefile, ...: point geometries, or polygons whose centroids are used).

    CSV (comma, semicolon or tab separated, decimal point or comma: pt-BR spreadsheets too)
    columns are found by name, in English or Portuguese, any case or accents: x/easting/este,
    y/northing/norte and, optionally, height/h/ht/altura. A vector layer's height comes from a ``height`` (or h, ht, z) attribute.

    Returns
    -------
    dict with ``x``, ``y``, ``height`` (None when absent), ``crs`` (WKT or None) and ``n``.
    """
    from pathlib import Path

    p = Path(path)
    if not p.exists():
        raise ReadError(f"{p}: no such file")
    if p.suffix.lower() in (".csv", ".txt"):
        from ..io.names import read_text_table

        try:
            df = read_text_table(p)
        except Exception as exc:  # noqa: BLE001 - pandas raises many kinds
            raise ReadError(f"{p}: cannot read as CSV ({exc})") from None
        xc, yc = _pick(df.columns, "x"), _pick(df.columns, "y")
        if xc is None or yc is None:
            raise InputError(f"{p}: no x/y columns found (columns: {', '.join(map(str, df.columns))}); "
                             "name them x and y (or easting/este, northing/norte)")
        hc = _pick(df.columns, "height")
        try:
            x = df[xc].to_numpy(float)
            y = df[yc].to_numpy(float)
            h = df[hc].to_numpy(float) if hc else None
        except ValueError as exc:
            raise InputError(f"{p}: non-numeric values in the coordinate/height columns ({exc})") from None
        return {"x": x, "y": y, "height": h, "crs": None, "n": len(x), "stand": _stands(df)}
    import pyogrio

    try:
        layers = [lyr[0] for lyr in pyogrio.list_layers(p)]
    except Exception as exc:  # noqa: BLE001
        raise ReadError(f"{p}: cannot open as a vector file ({exc})") from None
    if layer is None:
        pts = [lyr for lyr in layers if lyr.endswith("tree_tops")]
        layer = pts[0] if pts else layers[0]
    elif layer not in layers:
        raise InputError(f"{p}: no layer {layer!r}; layers: {', '.join(layers)}")
    import geopandas as gpd

    gdf = gpd.read_file(p, layer=layer)
    if len(gdf) == 0:
        return {"x": np.empty(0), "y": np.empty(0), "height": None,
                "crs": gdf.crs.to_wkt() if gdf.crs else None, "n": 0}
    geom = gdf.geometry
    if not (geom.geom_type == "Point").all():
        geom = geom.centroid
    hc = _pick(gdf.columns, "height")
    h = gdf[hc].to_numpy(float) if hc else None
    return {"x": geom.x.to_numpy(), "y": geom.y.to_numpy(), "height": h,
            "crs": gdf.crs.to_wkt() if gdf.crs else None, "n": len(gdf), "layer": layer,
            "stand": _stands(gdf)}


def _stands(df):
    """The trees' stand ids as strings ("" for none) when the table has a stand column."""
    sc = _pick([c for c in df.columns if c != "geometry"], "stand")
    if sc is None:
        return None
    v = df[sc]
    return np.asarray(["" if (isinstance(a, float) and not np.isfinite(a)) or a is None else
                       (str(int(a)) if isinstance(a, float) and a.is_integer() else str(a))
                       for a in v.tolist()], dtype=object)


def per_stand(det, ref, det_idx, ref_idx) -> dict:
    """Scores per stand when the reference gives each tree's stand: its reference trees, the
    detections matched to them, and the unmatched detections of the stand: their own
    ``stand_id`` when it is one of the reference's stands, else the stand of the nearest
    reference tree (the detections' stands may be another set: the planted blocks of a run
    without ``-stands``). Every unmatched detection counts in a stand, so the stands' false
    detections add up to the whole reference's."""
    from scipy.spatial import cKDTree

    rs = ref["stand"]
    ds = np.full(len(det["x"]), "", dtype=object)
    ds[det_idx] = rs[ref_idx]
    free = np.ones(len(det["x"]), bool)
    free[det_idx] = False
    if det.get("stand") is not None:
        own = free & np.isin(np.asarray(det["stand"], dtype=object),
                             np.asarray(sorted(set(rs.tolist()) - {""}), dtype=object))
        ds[own] = np.asarray(det["stand"], dtype=object)[own]
        free &= ~own
    if free.any() and len(ref["x"]):
        _, k = cKDTree(np.c_[ref["x"], ref["y"]]).query(np.c_[det["x"][free], det["y"][free]])
        ds[np.nonzero(free)[0]] = rs[k]
    out = {}
    for sid in sorted(set(rs.tolist()) - {""}):
        m = int((rs[ref_idx] == sid).sum())
        out[sid] = _scores(int((ds == sid).sum()), int((rs == sid).sum()), m)
    return out


def read_area(area, crs_wkt=None):
    """The reference's area: ``xmin,ymin,xmax,ymax`` or a polygon vector file (``PATH`` or
    ``PATH:LAYER``; every polygon, joined; reprojected to ``crs_wkt`` when both have a CRS).
    Returns ``(shapely geometry, description)``."""
    import shapely
    from pathlib import Path

    text = str(area).strip()
    parts = [t for t in text.replace(";", ",").split(",")]
    if len(parts) == 4:
        try:
            x0, y0, x1, y1 = (float(t) for t in parts)
        except ValueError:
            x0 = None
        if x0 is not None:
            if not (x1 > x0 and y1 > y0):
                raise InputError(f"-area: expected xmin,ymin,xmax,ymax with xmin < xmax and "
                                 f"ymin < ymax, got {text!r}")
            return shapely.box(x0, y0, x1, y1), f"box {x0:g},{y0:g},{x1:g},{y1:g}"
    from ..io.vector import read_polygons

    if not Path(text).exists() and not (":" in text and Path(text.rsplit(":", 1)[0]).exists()):
        raise InputError(f"-area: {text}: neither xmin,ymin,xmax,ymax nor a vector file")
    gdf, name = read_polygons(text, param="-area")
    gdf = gdf[gdf.geometry.notna() & gdf.geometry.geom_type.isin(["Polygon", "MultiPolygon"])]
    if gdf.empty:
        raise InputError(f"-area: {text}: no polygon in it")
    if crs_wkt and gdf.crs is not None:
        gdf = gdf.to_crs(crs_wkt)
    geom = shapely.make_valid(shapely.union_all(gdf.geometry.values))
    return geom, f"{name} ({len(gdf)} polygon(s), {geom.area:.0f} m²)"


def evaluate_file(detected, reference, output=None, *, layer=None, ref_layer=None,
                  max_dist: float = MAX_DIST, max_dz: float = MAX_DZ, area=None, overwrite=False,
                  table=None, progress=None) -> dict:
    """``lidartrees evaluate``: match the tree tops of ``detected`` to ``reference`` (Eysn et al.
    2015) and report recall, precision, F and height bias / RMSE for all and dominant trees;
    optionally write the report as JSON (``.json``) or the matched pairs as CSV (``.csv``).

    ``area``: where the reference was measured (``xmin,ymin,xmax,ymax`` or a polygon file, see
    :func:`read_area`): detections outside it are not false positives (a 50 m plot inside a
    larger flight), and references outside it are left out. A detection up to ``max_dist``
    outside may still match a reference tree inside. ``table``: how the pairs' table is
    written (:class:`lidartrees_gis.io.tables.TableOptions`; default the locale's); a name
    ending in ``.xlsx`` writes a workbook."""
    import json

    from ..io.output import atomic_output, check_output

    if not (max_dist > 0 and max_dz >= 0):
        raise InputError(f"-max_dist must be > 0 and -max_dz >= 0 (got {max_dist}, {max_dz})")
    if output is not None:
        check_output(output, overwrite)
    det = read_trees(detected, layer=layer)
    ref = read_trees(reference, layer=ref_layer)
    if ref["n"] == 0:
        raise InputError(f"{reference}: no reference trees")
    if det["crs"] and ref["crs"]:
        from pyproj import CRS

        if not CRS.from_wkt(det["crs"]).equals(CRS.from_wkt(ref["crs"]), ignore_axis_order=True):
            raise InputError(f"{reference}: CRS differs from {detected}'s; reproject one of them")
    area_note = None
    if area is not None:
        det, ref, area_note = _within_area(det, ref, area, max_dist, max_dz)
    r = evaluate_trees(det["x"], det["y"], det["height"], ref["x"], ref["y"], ref["height"],
                       max_dist=max_dist, max_dz=max_dz)
    d, rr = r.pop("pairs")
    report = {"detected_file": str(detected), "reference_file": str(reference),
              "matching": f"Eysn et al. 2015: tallest reference first, <= {max_dist:g} m "
                          f"horizontally, <= {max_dz:g} m in height", **r}
    if area_note:
        report["area"] = area_note
    if ref.get("stand") is not None and len(ref["stand"]) == len(ref["x"]):
        report["stands"] = per_stand(det, ref, d, rr)
    if output is not None:
        with atomic_output(output, overwrite) as tmp:
            if str(output).lower().endswith((".csv", ".xlsx")):
                _write_pairs(tmp, det, ref, d, rr, table)
            else:
                tmp.write_text(json.dumps(report, indent=2, default=float))
        report["output"] = str(output)
    report["table"] = format_report(report)
    return report


#: the matched pairs' table (``evaluate -o pairs.csv``) and its numbers' decimals (cm)
PAIR_COLUMNS = ("det_index", "ref_index", "det_x", "det_y", "ref_x", "ref_y", "det_height",
                "ref_height", "distance")


def _write_pairs(path, det, ref, d, rr, table) -> None:
    from ..io.tables import write_table

    def h(t, k):
        return None if t["height"] is None else float(t["height"][k])

    rows = ({"det_index": i, "ref_index": j, "det_x": float(det["x"][i]),
             "det_y": float(det["y"][i]), "ref_x": float(ref["x"][j]), "ref_y": float(ref["y"][j]),
             "det_height": h(det, i), "ref_height": h(ref, j),
             "distance": float(np.hypot(det["x"][i] - ref["x"][j], det["y"][i] - ref["y"][j]))}
            for i, j in zip(d.tolist(), rr.tolist()))
    write_table(path, rows, PAIR_COLUMNS, {c: 2 for c in PAIR_COLUMNS[2:]}, options=table,
                name="pairs")


def _within_area(det, ref, area, max_dist, max_dz):
    """The detections and references an area evaluation counts: references inside the area;
    detections inside it, and those up to ``max_dist`` outside that match a reference inside
    (an unmatched detection outside is not a false positive; leaving it out changes no match,
    since the matching only ever takes free detections)."""
    import shapely

    geom, text = read_area(area, det.get("crs") or ref.get("crs"))
    pick = lambda t, m: {**t, "x": t["x"][m], "y": t["y"][m], "n": int(m.sum()),  # noqa: E731
                         "height": None if t["height"] is None else t["height"][m],
                         "stand": None if t.get("stand") is None else t["stand"][m]}
    rin = shapely.contains_xy(geom, ref["x"], ref["y"])
    if not rin.any():
        raise InputError(f"-area: no reference tree inside {text}")
    ref = pick(ref, rin)
    near = shapely.contains_xy(shapely.buffer(geom, max_dist), det["x"], det["y"])
    inside = shapely.contains_xy(geom, det["x"], det["y"])
    cand = pick(det, near)
    r = evaluate_trees(cand["x"], cand["y"], cand["height"], ref["x"], ref["y"], ref["height"],
                       max_dist=max_dist, max_dz=max_dz)
    matched = np.zeros(cand["n"], bool)
    matched[r["pairs"][0]] = True
    keep = np.zeros(det["x"].size, bool)
    keep[np.nonzero(near)[0][matched | inside[near]]] = True
    note = {"area": text, "reference_trees_inside": int(rin.sum()),
            "reference_trees_outside": int((~rin).sum()),
            "detections_counted": int(keep.sum()), "detections_left_out": int((~keep).sum())}
    return pick(det, keep), ref, note


def format_report(report: dict) -> str:
    """Markdown table of an evaluation report."""
    rows = ["| trees | detected | reference | matched | recall | precision | F | height bias (m) | "
            "height RMSE (m) |", "|---|---|---|---|---|---|---|---|---|"]
    parts = [(k, report[k]) for k in ("all", "dominant") if k in report]
    parts += [(f"stand {k}", v) for k, v in (report.get("stands") or {}).items()]
    for k, s in parts:
        hb = s.get("height_bias")
        hr = s.get("height_rmse")
        rows.append(f"| {k} | {s['detected']} | {s['reference']} | {s['matched']} | "
                    f"{s['recall']:.3f} | {s['precision']:.3f} | {s['f_score']:.3f} | "
                    f"{'' if hb is None else f'{hb:+.2f}'} | {'' if hr is None else f'{hr:.2f}'} |")
    return "\n".join(rows)


def match_trees(det_x, det_y, ref_x, ref_y, max_dist: float = 1.0):
    """One-to-one matching of detected and reference trees (closest pairs first, within
    ``max_dist`` m). Returns ``(det_index, ref_index)`` arrays of matched pairs."""
    from scipy.spatial import cKDTree

    if len(det_x) == 0 or len(ref_x) == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    tree = cKDTree(np.c_[ref_x, ref_y])
    pairs = tree.sparse_distance_matrix(cKDTree(np.c_[det_x, det_y]), max_dist, output_type="ndarray")
    order = np.argsort(pairs["v"], kind="stable")
    used_r, used_d, md, mr = set(), set(), [], []
    for k in order:
        r, d = int(pairs["i"][k]), int(pairs["j"][k])
        if r in used_r or d in used_d:
            continue
        used_r.add(r)
        used_d.add(d)
        md.append(d)
        mr.append(r)
    return np.asarray(md, np.int64), np.asarray(mr, np.int64)


def accuracy(table: dict, truth: dict, max_dist: float = 1.0) -> dict:
    """Detection accuracy against known trees: matches, omission, commission, F-score, RMSE of
    height and of crown diameter (against ``visible_crown_diameter`` when given)."""
    d, r = match_trees(table["x"], table["y"], truth["x"], truth["y"], max_dist)
    n_det, n_ref, m = len(table["x"]), len(truth["x"]), len(d)
    prec = m / n_det if n_det else 0.0
    rec = m / n_ref if n_ref else 0.0
    out = {"detected": n_det, "reference": n_ref, "matched": m,
           "omission": 1 - rec, "commission": 1 - prec,
           "f_score": 2 * prec * rec / (prec + rec) if prec + rec else 0.0}
    if m:
        out["height_rmse"] = float(np.sqrt(np.mean((table["height"][d] - truth["height"][r]) ** 2)))
        key = "visible_crown_diameter" if "visible_crown_diameter" in truth else "crown_diameter"
        if key in truth:
            out["crown_diameter_rmse"] = float(np.sqrt(np.mean(
                (table["crown_diameter"][d] - truth[key][r]) ** 2)))
    return out
